"""The 1D model: a cross-section ``u_hat(y) exp(Lambda t - i k x)`` through a stack of layers.

docs/design.md section 5. One model (:class:`SectionModel`) for every 1D case: the finite strip
on a rigid substrate (:class:`forms.models.cross_section.CrossSectionModel` is its
constructor), a PML-terminated half-space (:class:`forms.models.pml.HalfSpaceModel`), layered
or graded bodies and a deformable substrate. Along ``y`` the stack has

- the **slider** (body 1), ``0 < y < H``: one or more layers from the interface ``y = 0`` up;
- the **substrate** (body 2), ``-H2 < y < 0``: layers from ``y = 0`` down, or none (rigid
  substrate, the paper's limit ``mu2 = inf``).

Each :class:`Layer` has its material (``mu``, ``rho``, ``beta = c_s/c_d``, in units of body 1),
each either a number or a :class:`forms.models.profiles.Profile` (a function of ``y``, evaluated
at the quadrature points), its mesh vertices and an optional constant complex stretch
``s = dy~/dy`` (a PML layer: in the weak form ``d/dy -> (1/s) d/dy``, ``dy -> s dy``, see
:mod:`forms.models.pml`). The stiffness keeps the split ``K(k) = K0 + k K1 + k^2 K2`` through a
stretch, so one assembly path (coefficients ``mu, lambda, rho, s`` summed over all layers in one
form) serves every case. The friction row operation (:mod:`forms.friction`) is linear in ``K``:
it is applied once per block, and ``T(L; k)`` is recombined per ``k`` (:class:`KOperator`).

The two bodies have their own nodes at ``y = 0`` (:func:`meshes.layered.interval_from_pieces`).
Interface conditions (contact kept): ``u_y`` continuous, ``sigma_xy`` and ``sigma_yy``
continuous, and the friction law on the slip ``u_x1 - u_x2``::

    (1 + alpha_pc L) sxy + (f - alpha_ld L/(L+1)) syy - (1/gamma) L (L + Delta)/(L + 1) slip = 0.

They are imposed by a map ``u_full = P u_red`` (``u_y2 = u_y1``; ``u_x1 = s + u_x2``, ``s`` the
slip) and the reduction ``P^H A P``, then the friction row operation of :mod:`forms.friction` on
the row of ``s`` with the slider's own reactions (the general case described there). The
rigid substrate is the special case without substrate nodes (no ``P``, ``u_y1 = 0`` strongly).

Outer conditions: ``top`` at the slider's top, ``bottom`` at the substrate's bottom, each
``"velocity"`` (``u_x = 0``; ``sigma_yy = 0`` natural), ``"stress"`` (traction free, natural)
or ``"clamped"`` (``u = 0``: the end of a PML layer).

Typical use::

    stack = stack_from_params(params, degree=4, cells=6, cells2=6)
    model = SectionModel(comm, stack, params, degree=4)
    res = PolynomialSolver(comm).solve(model.operator(k), target)
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Union

import numpy as np

import dolfinx
import dolfinx.fem.petsc
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from analytic.numerics.roots import samples_for_turn
from analytic.params import ParameterError, Params
from forms.elasticity import cross_section_gradients, stiffness_density
from forms.friction import (
    DIRICHLET_DIAGONAL,
    FrictionLaw,
    FrictionOperator,
    apply_dirichlet,
    friction_operator,
)
from forms.models.periodic import reduce_matrix
from forms.models.profiles import MATERIAL_HIGH, LayerRow, Profile, SliderMaterial
from meshes.interval import default_cells, grading_ratio, interval_vertices
from meshes.layered import interval_from_pieces

#: Conditions at the outer ends of the stack.
END_CONDITIONS = ("velocity", "stress", "clamped")
#: A material coefficient: a number or a function of ``y``.
Material = Union[float, Profile]  # noqa: UP007 (a runtime alias)
#: The material coefficients of a layer.
MATERIALS = ("mu", "rho", "beta")


@dataclass(frozen=True)
class Layer:
    """One layer: material (units of body 1), mesh vertices and complex stretch.

    Attributes:
        vertices: Strictly increasing ``y`` of the layer's mesh vertices (its two ends included).
        mu: Shear modulus (a number or a :class:`~forms.models.profiles.Profile` of ``y``).
        rho: Density (the same).
        beta: ``c_s / c_d`` of the layer, ``0 < beta < 1/sqrt(2)`` (the same).
        stretch: ``dy~/dy`` (``1``: physical; complex: a PML layer).
    """

    vertices: np.ndarray
    mu: Material = 1.0
    rho: Material = 1.0
    beta: Material = 0.5
    stretch: complex = 1.0

    def __post_init__(self) -> None:
        v = np.asarray(self.vertices, dtype=float)
        if v.ndim != 1 or len(v) < 2 or not np.all(np.diff(v) > 0):
            raise ValueError("Layer.vertices must be strictly increasing, length >= 2")
        object.__setattr__(self, "vertices", v)
        for name in MATERIALS:
            value = getattr(self, name)
            if isinstance(value, Profile):
                value.check(self.bottom, self.top, 0.0, MATERIAL_HIGH[name])
            elif not 0 < value < MATERIAL_HIGH[name]:
                raise ValueError(f"bad layer material mu={self.mu}, rho={self.rho}, "
                                 f"beta={self.beta}")
        if complex(self.stretch) == 0:
            raise ValueError("Layer.stretch must be nonzero")

    @property
    def profiled(self) -> bool:
        """Some material coefficient is a function of ``y``."""
        return any(isinstance(getattr(self, n), Profile) for n in MATERIALS)

    @property
    def lame_lambda(self) -> float:
        """First Lame parameter ``mu (1/beta^2 - 2)`` (constant layers)."""
        if self.profiled:
            raise ValueError("lame_lambda of a profiled layer varies with y")
        return self.mu * (1.0 / self.beta**2 - 2.0)

    @property
    def wave_time(self) -> float:
        """``int (1/c_s + 1/c_d) |dy~|`` over the layer: S plus P travel time across it.

        ``1/c_s + 1/c_d = (1 + beta) sqrt(rho/mu)``; a profiled coefficient is integrated by
        the trapezoidal rule on 8 points per mesh interval. The phase of ``det T`` along the
        imaginary axis turns by about this much per unit of ``Im Lambda`` (every thickness
        resonance of the layer passed), which sets the contour's initial sampling
        (:func:`contour_samples`).
        """
        y = np.linspace(self.vertices[:-1], self.vertices[1:], 9).T.ravel()
        vals = {n: (v(y) if isinstance(v, Profile) else np.full(y.shape, float(v)))
                for n, v in (("mu", self.mu), ("rho", self.rho), ("beta", self.beta))}
        slowness = (1.0 + vals["beta"]) * np.sqrt(vals["rho"] / vals["mu"])
        return float(np.trapz(slowness, y)) * abs(complex(self.stretch))

    @property
    def bottom(self) -> float:
        """Lowest ``y``."""
        return float(self.vertices[0])

    @property
    def top(self) -> float:
        """Highest ``y``."""
        return float(self.vertices[-1])

@dataclass(frozen=True)
class Stack:
    """The layered stack: slider layers from ``y = 0`` up, substrate layers from ``y = 0`` down.

    Attributes:
        slider: Body 1, bottom-up; the first layer starts at ``y = 0``; contiguous.
        substrate: Body 2, top-down; the first layer ends at ``y = 0``; empty: rigid substrate.
        top: Condition at the slider's top (:data:`END_CONDITIONS`).
        bottom: Condition at the substrate's bottom (ignored when rigid).
    """

    slider: tuple[Layer, ...]
    substrate: tuple[Layer, ...] = ()
    top: str = "velocity"
    bottom: str = "stress"

    def __post_init__(self) -> None:
        object.__setattr__(self, "slider", tuple(self.slider))
        object.__setattr__(self, "substrate", tuple(self.substrate))
        if not self.slider:
            raise ValueError("the stack needs at least one slider layer")
        for name in ("top", "bottom"):
            if getattr(self, name) not in END_CONDITIONS:
                raise ValueError(f"{name} = {getattr(self, name)!r} is not one of "
                                 f"{', '.join(END_CONDITIONS)}")
        if self.slider[0].bottom != 0.0:
            raise ValueError("the first slider layer must start at y = 0")
        for a, b in zip(self.slider, self.slider[1:], strict=False):
            if a.top != b.bottom:
                raise ValueError("slider layers must be contiguous")
        if self.substrate:
            if self.substrate[0].top != 0.0:
                raise ValueError("the first substrate layer must end at y = 0")
            for a, b in zip(self.substrate, self.substrate[1:], strict=False):
                if b.top != a.bottom:
                    raise ValueError("substrate layers must be contiguous")

    @property
    def rigid(self) -> bool:
        """No substrate layers: the rigid substrate."""
        return not self.substrate

    def pieces(self) -> list[np.ndarray]:
        """Vertex arrays of the bodies (substrate first if any), increasing."""
        def join(layers: list[Layer]) -> np.ndarray:
            parts = [layers[0].vertices] + [lay.vertices[1:] for lay in layers[1:]]
            return np.concatenate(parts)
        out = []
        if self.substrate:
            out.append(join(list(reversed(self.substrate))))
        out.append(join(list(self.slider)))
        return out

    def layers(self) -> list[Layer]:
        """All layers, bottom-up."""
        return list(reversed(self.substrate)) + list(self.slider)

    @property
    def wave_time(self) -> float:
        """:attr:`Layer.wave_time` summed over every layer of both bodies."""
        return sum(lay.wave_time for lay in self.layers())


def contour_samples(stack: Stack, box: Sequence[float]) -> int:
    """Initial samples (longest side) of a contour count of ``det T`` of ``stack`` around ``box``.

    The rule of the exact count (:func:`analytic.numerics.branches._n_initial`): the phase
    of the determinant turns by about :attr:`Stack.wave_time` per unit of ``Im Lambda``, so
    ``8 + 2 wave_time side`` samples on the longest side (at least 32) keep the first pass
    below one turn per few samples; the refinement and the sample guard (``32`` times this,
    :func:`analytic.numerics.roots.winding_numbers`) scale with it. A fixed 32 was left to
    refine from far too coarse a start on tall boxes: the stress top's count at ``k =
    41.56``, 12 ``c_d`` (``|Im| <= 1023``), hit the 50 000-sample guard (the sweep at that
    ``k``: 521 s, exit 1); from 3 077 on the long sides it closes in under a second.
    """
    return max(32, samples_for_turn(stack.wave_time, box))


def stack_from_params(params: Params, degree: int = 3, cells: int | None = None,
                      cells2: int | None = None, k_max: float = 1.0, n_max: int = 0,
                      ratio: float | None = None, ratio2: float | None = None) -> Stack:
    """The finite stack of ``params``: slider ``0 < y < H`` (+ substrate ``-H2 < y < 0``).

    The slider mesh is exactly the one of :class:`forms.models.cross_section.CrossSectionModel` (the
    same gmsh vertices: :func:`meshes.interval.interval_vertices`, default cells and grading
    towards ``y = 0`` from :func:`meshes.interval.default_cells`,
    :func:`meshes.interval.grading_ratio`). With ``params.two_body`` the substrate
    (``mu2, rho2, beta2``, height ``H2``, bottom condition ``bc2``) is meshed the same way,
    graded towards ``y = 0``; its default cells are those of a slider of height ``H2`` divided
    by ``min(1, c_s2)`` (``c_s2 = sqrt(mu2/rho2)``: slower waves are shorter).

    Args:
        params: Parameters (``H`` finite; ``H2`` finite when ``mu2`` is).
        degree: Lagrange degree (sets the default cells).
        cells: Slider cells.
        cells2: Substrate cells.
        k_max: Largest wavenumber the mesh is made for.
        n_max: Highest waveguide branch wanted.
        ratio: Slider grading ``h_max/h_min``.
        ratio2: Substrate grading.

    Raises:
        ParameterError: ``H`` or (deformable substrate) ``H2`` infinite: build the
            :class:`Stack` with a PML layer (:func:`pml_layers`) instead.
    """
    if not math.isfinite(params.H):
        raise ParameterError("H = inf: a layered stack from params needs a finite H "
                             "(half-space: add a PML layer with pml_layers)")
    n1 = int(cells) if cells else default_cells(k_max, params.H, degree, n_max, params.beta)
    r1 = float(ratio) if ratio else grading_ratio(k_max, params.H)
    slider = Layer(interval_vertices(params.H, n1, r1), 1.0, 1.0, params.beta)
    if not params.two_body:
        return Stack((slider,), (), top=params.bc)
    if not math.isfinite(params.H2):
        raise ParameterError("H2 = inf: a layered stack from params needs a finite H2 "
                             "(half-space substrate: add a PML layer with pml_layers)")
    m2 = params.substrate
    n2 = int(cells2) if cells2 else math.ceil(
        default_cells(k_max, params.H2, degree, n_max, params.beta) / min(1.0, m2.c_s))
    r2 = float(ratio2) if ratio2 else grading_ratio(k_max, params.H2)
    layer2 = Layer(-interval_vertices(params.H2, n2, r2)[::-1], m2.mu, m2.rho, m2.beta)
    return Stack((slider,), (layer2,), top=params.bc, bottom=params.bc2)


def pml_layers(design, side: str = "slider", mu: float = 1.0, rho: float = 1.0,  # noqa: ANN001
               beta: float = 0.5) -> tuple[Layer, Layer]:
    """A physical layer and a stretched (PML) layer from a :class:`forms.models.pml.LayerDesign`.

    ``design`` was made for the body's own units: :func:`forms.models.pml.design_layer` with
    ``target / c_s`` and the body's ``beta`` (``c_s = sqrt(mu/rho)``), so that its
    ``k_s = sqrt((Lambda/c_s)^2 + k^2)`` is the body's. ``side = "slider"``: the layers go up
    from ``y = 0``; ``"substrate"``: mirrored, down from ``y = 0`` (the stretch is the same:
    the partial waves decay away from the interface on both sides). End the stack with
    ``"clamped"`` on that side.
    """
    v = np.asarray(design.vertices, dtype=float)
    h = design.h_phys
    i = int(np.argmin(np.abs(v - h)))
    phys, layer = v[: i + 1], v[i:]
    if side == "substrate":
        phys, layer = -phys[::-1], -layer[::-1]
        return (Layer(phys, mu, rho, beta), Layer(layer, mu, rho, beta, design.stretch))
    if side != "slider":
        raise ValueError(f"side = {side!r} is not 'slider' or 'substrate'")
    return (Layer(phys, mu, rho, beta), Layer(layer, mu, rho, beta, design.stretch))




def stack_from_layers(params: Params, rows: list[LayerRow], degree: int = 3,
                      cells: int | None = None, k_max: float = 1.0, n_max: int = 0,
                      ratio: float | None = None,
                      profiles: dict[str, Profile] | None = None, cells2: int | None = None,
                      ratio2: float | None = None) -> Stack:
    """The stack of a layers file (:func:`forms.models.profiles.read_layers`) on a substrate.

    The slider is ``0 < y < rows[-1].y_top`` (``params.H`` is not used); the substrate, the
    outer conditions and the friction come from ``params`` as in :func:`stack_from_params`.
    The cells: ``cells`` (default :func:`meshes.interval.default_cells` for the whole slider
    with its smallest ``beta``) shared by height, each layer's share divided by
    ``min(1, c_s)`` (slower waves are shorter), at least 2; the first layer is graded towards
    ``y = 0`` like the homogeneous slider, the others are uniform. One row ``y_top = H,
    mu = rho = 1, beta = params.beta`` gives exactly :func:`stack_from_params`' slider.

    Args:
        params: Friction, substrate and outer conditions.
        rows: The layers, from the interface up.
        degree: Lagrange degree (sets the default cells).
        cells: Slider cells in all.
        k_max: Largest wavenumber the mesh is made for.
        n_max: Highest waveguide branch wanted.
        ratio: Grading ``h_max/h_min`` of the first layer.
        profiles: ``{"mu" | "rho" | "beta": Profile}``: that coefficient follows the profile in
            every slider layer (the file's column is then not used).
        cells2: Substrate cells (:func:`stack_from_params`).
        ratio2: Substrate grading.
    """
    height = rows[-1].y_top
    beta_min = min(r.beta for r in rows)
    n_all = int(cells) if cells else default_cells(k_max, height, degree, n_max, beta_min)
    profiles = dict(profiles or {})
    layers, below = [], 0.0
    for j, r in enumerate(rows):
        h = r.y_top - below
        n = max(2, math.ceil(n_all * h / height / min(1.0, math.sqrt(r.mu / r.rho)) - 1e-9))
        grading = (float(ratio) if ratio else grading_ratio(k_max, h)) if j == 0 else 1.0
        v = below + interval_vertices(h, n, grading)
        v[0], v[-1] = below, r.y_top
        mat = {name: profiles.get(name, getattr(r, name)) for name in MATERIALS}
        layers.append(Layer(v, **mat))
        below = r.y_top
    base = stack_from_params(params.replace(H=height), degree=degree, cells=2, cells2=cells2,
                             k_max=k_max, n_max=n_max, ratio2=ratio2)
    return Stack(tuple(layers), base.substrate, top=base.top, bottom=base.bottom)


def section_stack(params: Params, material: SliderMaterial | None = None, degree: int = 3,
                  cells: int | None = None, k_max: float = 1.0, n_max: int = 0,
                  ratio: float | None = None, cells2: int | None = None,
                  ratio2: float | None = None) -> Stack:
    """The stack of the command-line options: ``params`` and the slider's material.

    ``material = None`` (``--model section``): :func:`stack_from_params`. Otherwise
    (``--model layers``, :func:`forms.models.profiles.slider_material`): its layers (or the
    homogeneous slider of ``params``) with its profiles, :func:`stack_from_layers`. The other
    arguments are those of these two.
    """
    if material is None:
        return stack_from_params(params, degree=degree, cells=cells, cells2=cells2,
                                 k_max=k_max, n_max=n_max, ratio=ratio, ratio2=ratio2)
    return stack_from_layers(params, material.layer_rows(params.H, params.beta), degree=degree,
                             cells=cells, k_max=k_max, n_max=n_max, ratio=ratio,
                             profiles=dict(material.profiles), cells2=cells2, ratio2=ratio2)


def layer_coefficients(msh: dolfinx.mesh.Mesh, stack: Stack, axis: int
                       ) -> dict[str, dolfinx.fem.Function]:
    """Cell-wise (DG0) ``mu, lmbda, rho, s`` (stretch) and ``chi1`` (1 in the slider).

    Each cell takes the values of the layer its midpoint's coordinate ``x[axis]`` (``y``)
    falls in. Constant layers only (the 2D model); the 1D model also takes profiles
    (:func:`section_coefficients`).
    """
    if any(lay.profiled for lay in stack.layers()):
        raise ValueError("layer_coefficients: constant layers only (profiles: 1D model)")
    return _cellwise(msh, stack, axis)[0]


def _cellwise(msh: dolfinx.mesh.Mesh, stack: Stack, axis: int
              ) -> tuple[dict[str, dolfinx.fem.Function], list[tuple[Layer, np.ndarray]]]:
    """DG0 coefficients of the constant values (0 where profiled) and each layer's cells."""
    Q = dolfinx.fem.FunctionSpace(msh, ("DG", 0))  # noqa: N806
    mid = Q.tabulate_dof_coordinates()[:, axis]
    names = ("mu", "lmbda", "rho", "beta", "s", "chi1")
    coef = {name: dolfinx.fem.Function(Q) for name in names}
    found = np.zeros(len(mid), dtype=bool)
    cells = []
    for body, layers in ((1, stack.slider), (2, stack.substrate)):
        for lay in layers:
            inside = (mid > lay.bottom) & (mid < lay.top)
            found |= inside
            cells.append((lay, inside))
            values = {"s": complex(lay.stretch), "chi1": 1.0 if body == 1 else 0.0}
            values.update({n: getattr(lay, n) for n in MATERIALS
                           if not isinstance(getattr(lay, n), Profile)})
            if not lay.profiled:
                values["lmbda"] = lay.lame_lambda
            for name, value in values.items():
                coef[name].x.array[inside] = value
    if not found.all():
        raise RuntimeError("a cell lies in no layer")
    return coef, cells


def section_coefficients(msh: dolfinx.mesh.Mesh, stack: Stack
                         ) -> dict[str, ufl.core.expr.Expr]:
    """``mu, lmbda, rho, s, chi1`` of a 1D stack as UFL coefficients of the mesh.

    Constant layers only: the DG0 functions of :func:`layer_coefficients`. With profiles, each
    profiled layer adds ``chi_layer * profile(y)`` (``chi_layer`` its DG0 indicator) to the
    constant part, and ``lmbda = mu (1/beta^2 - 2)`` is formed pointwise: the profiles are
    evaluated exactly at the quadrature points.
    """
    coef, cells = _cellwise(msh, stack, 0)
    if not any(lay.profiled for lay, _ in cells):
        return {n: coef[n] for n in ("mu", "lmbda", "rho", "s", "chi1")}
    y = ufl.SpatialCoordinate(msh)[0]
    out: dict[str, ufl.core.expr.Expr] = {n: coef[n] for n in MATERIALS}
    for lay, inside in cells:
        if not lay.profiled:
            continue
        chi = dolfinx.fem.Function(coef["s"].function_space)
        chi.x.array[inside] = 1.0
        for name in MATERIALS:
            value = getattr(lay, name)
            if isinstance(value, Profile):
                out[name] = out[name] + chi * value.ufl(y)
    mu, beta = out["mu"], out.pop("beta")
    return {**out, "lmbda": mu * (1.0 / beta**2 - 2.0), "s": coef["s"], "chi1": coef["chi1"]}


def pml_stack(params: Params, k: float, target: complex, degree: int = 4,
              cells: int | None = None, cells2: int | None = None,
              attenuation: float = 16.0) -> Stack:
    """The stack of ``params`` with a PML layer on every infinite side (``H`` and/or ``H2``).

    Each layer is :func:`forms.models.pml.design_layer` for wavenumber ``k`` and ``target`` in the
    body's own units (``target / c_s``, the body's ``beta``), ended by ``"clamped"``; finite
    sides are meshed as in :func:`stack_from_params`. With ``H`` and ``H2`` finite this *is*
    :func:`stack_from_params`. The layer is designed for one ``k`` and one target: use a new
    stack for other ``k`` (see :func:`forms.models.pml.solve_halfspace` for the checks a root
    computed with a PML needs).
    """
    from forms.models.pml import design_layer

    finite = {"H": params.H if math.isfinite(params.H) else 1.0,
              "H2": params.H2 if math.isfinite(params.H2) else 1.0}
    base = stack_from_params(params.replace(**finite) if params.two_body
                             else params.replace(H=finite["H"]),
                             degree=degree, cells=cells, cells2=cells2, k_max=k)
    slider, top = base.slider, base.top
    if not math.isfinite(params.H):
        d = design_layer(k, complex(target), params.beta, degree, attenuation=attenuation)
        slider, top = pml_layers(d, "slider", 1.0, 1.0, params.beta), "clamped"
    if not params.two_body:
        return Stack(slider, (), top=top)
    substrate, bottom = base.substrate, base.bottom
    if not math.isfinite(params.H2):
        m2 = params.substrate
        d = design_layer(k, complex(target) / m2.c_s, m2.beta, degree, attenuation=attenuation)
        substrate = pml_layers(d, "substrate", m2.mu, m2.rho, m2.beta)
        bottom = "clamped"
    return Stack(slider, substrate, top=top, bottom=bottom)


@dataclass
class _Reduction:
    """``u_full = P u_red`` for the two-body interface (see the module docstring)."""

    P: PETSc.Mat
    Q: PETSc.Mat  # injection of the kept dofs (for the interface mass, which acts on s only)
    red: np.ndarray  # global reduced index of each owned full dof (-1: eliminated)

    def destroy(self) -> None:
        self.P.destroy()
        self.Q.destroy()


def _pair_value(comm: MPI.Comm, mine: list[int]) -> int:
    """The one value some rank(s) hold in ``mine`` (1D stacks: one interface pair)."""
    values = {v for part in comm.allgather(mine) for v in part}
    if len(values) != 1:
        raise RuntimeError(f"interface pairing failed: {sorted(values)}")
    return values.pop()


def _reduction(comm: MPI.Comm, n_full_local: int, n_full_global: int, f0: int,
               x1: np.ndarray, x2: np.ndarray, y1: np.ndarray, y2: np.ndarray) -> _Reduction:
    """Build ``P`` (``u_y2 = u_y1``, ``u_x1 = s + u_x2``) and the injection ``Q``.

    ``x1, ... y2`` are the owned global full indices of the interface dofs (one node per body).
    """
    keep = np.ones(n_full_local, dtype=bool)
    keep[np.asarray(y2, dtype=np.int64) - f0] = False
    n_red = int(keep.sum())
    offset = comm.exscan(n_red, op=MPI.SUM) or 0
    n_red_global = comm.allreduce(n_red, op=MPI.SUM)
    red = np.full(n_full_local, -1, dtype=np.int64)
    red[keep] = offset + np.arange(n_red)
    red_x2 = _pair_value(comm, [int(red[i - f0]) for i in x2])
    red_y1 = _pair_value(comm, [int(red[i - f0]) for i in y1])

    def build(with_slip: bool) -> PETSc.Mat:
        cols: list[list[int]] = [[int(r)] if r >= 0 else [] for r in red]
        for i in y2:
            cols[int(i) - f0] = [red_y1] if with_slip else []
        if with_slip:
            for i in x1:
                cols[int(i) - f0] = [int(red[int(i) - f0]), red_x2]
        indptr = np.zeros(n_full_local + 1, dtype=PETSc.IntType)
        indptr[1:] = np.cumsum([len(c) for c in cols])
        flat = np.array([c for row in cols for c in row], dtype=PETSc.IntType)
        vals = np.ones(len(flat), dtype=PETSc.ScalarType)
        m = PETSc.Mat().createAIJ(((n_full_local, n_full_global), (n_red, n_red_global)),
                                  csr=(indptr, flat, vals), comm=comm)
        m.assemble()
        return m

    return _Reduction(build(True), build(False), red)





def owned_global_rows(V: dolfinx.fem.FunctionSpace, local_dofs: np.ndarray) -> np.ndarray:
    """Unrolled local dof indices -> owned global PETSc rows (ghosts dropped).

    For the row arguments of :func:`forms.friction.friction_operator` and
    :func:`forms.friction.apply_dirichlet` on any 1D model (also :mod:`forms.models.pml`).
    """
    bs = V.dofmap.index_map_bs
    imap = V.dofmap.index_map
    local_dofs = np.asarray(local_dofs, dtype=np.int64)
    nodes, comps = local_dofs // bs, local_dofs % bs
    owned = nodes < imap.size_local
    return (bs * (imap.local_range[0] + nodes[owned]) + comps[owned]).astype(np.int64)



class KOperator:
    """``T(Lambda; k) = T0 + k T1 + k^2 T2`` combined from three k-blocks of one pattern.

    Shared by :class:`CrossSectionModel` and :class:`forms.models.section.SectionModel`: the blocks
    are checked to share one nonzero pattern once, and :meth:`at` recombines them in place by
    two ``axpy`` per matrix (skipped when ``k`` is unchanged).

    Args:
        parts: ``[T0, T1, T2]`` (owned: destroyed by :meth:`destroy`).
        law: The friction law of the blocks.
    """

    def __init__(self, parts: list[FrictionOperator], law: FrictionLaw) -> None:
        base = parts[0]
        for part in parts[1:]:
            for a, b in zip(base.matrices, part.matrices, strict=True):
                if a.getInfo()["nz_used"] != b.getInfo()["nz_used"]:
                    raise RuntimeError("k-blocks do not share one nonzero pattern")
        self.parts = parts
        self.op = FrictionOperator(
            matrices=[a.duplicate(copy=True) for a in base.matrices],
            functions=list(base.functions), form=base.form, constant_term=base.constant_term,
            law=law,
        )
        self._k: float | None = None

    def at(self, k: float) -> FrictionOperator:
        """The operator at ``k`` (its matrices are reused between calls)."""
        k = float(k)
        if self._k != k:
            same = PETSc.Mat.Structure.SAME_NONZERO_PATTERN
            for j, a in enumerate(self.op.matrices):
                self.parts[0].matrices[j].copy(a, structure=same)
                a.axpy(k, self.parts[1].matrices[j], structure=same)
                a.axpy(k * k, self.parts[2].matrices[j], structure=same)
            self._k = k
        return self.op

    def destroy(self) -> None:
        """Destroy the blocks and the combined operator."""
        for part in self.parts:
            part.destroy()
        self.op.destroy()



@dataclass
class _Ends:
    """Mesh vertices of the stack's ends: slider and substrate sides of ``y = 0``, top, bottom."""

    iface1: np.ndarray
    iface2: np.ndarray
    top: np.ndarray
    bottom: np.ndarray


def _ends(msh: dolfinx.mesh.Mesh, stack: Stack) -> _Ends:
    """Locate the ends; the two ``y = 0`` vertices are told apart by their cell."""
    fdim = 0
    y_top, y_bot = stack.pieces()[-1][-1], stack.pieces()[0][0]
    msh.topology.create_connectivity(fdim, 1)
    v2c = msh.topology.connectivity(fdim, 1)
    at0 = dolfinx.mesh.locate_entities(msh, fdim, lambda x: np.isclose(x[0], 0.0))
    cell_of = np.array([v2c.links(v)[0] for v in at0], dtype=np.int32)
    side = dolfinx.mesh.compute_midpoints(msh, 1, cell_of)[:, 0] if len(at0) else np.zeros(0)
    return _Ends(
        iface1=at0[side > 0] if len(at0) else at0,
        iface2=at0[side < 0] if len(at0) else at0,
        top=dolfinx.mesh.locate_entities(msh, fdim, lambda x: np.isclose(x[0], y_top)),
        bottom=dolfinx.mesh.locate_entities(msh, fdim, lambda x: np.isclose(x[0], y_bot)),
    )


def _k_forms(V: dolfinx.fem.FunctionSpace, coef: dict[str, ufl.core.expr.Expr],  # noqa: N803
             weight: ufl.core.expr.Expr | float, dx: ufl.Measure) -> list[ufl.Form]:
    """``[K0, K1, K2, M]`` of the stretched elasticity, times ``weight`` (1, or ``chi1``)."""
    mu, lm, rho, s = (coef[n] for n in ("mu", "lmbda", "rho", "s"))
    u, w = ufl.TrialFunction(V), ufl.TestFunction(V)
    gu0, gu1 = cross_section_gradients(u)
    gw0, gw1 = cross_section_gradients(w)
    sc = ufl.conj(s)  # inner() conjugates the test side: d/dy~ = (1/s) d/dy on both sides
    return [
        weight * stiffness_density(gu0 / s, gw0 / sc, lm, mu) * s * dx,
        weight * (stiffness_density(gu1, gw0 / sc, lm, mu)
                  + stiffness_density(gu0 / s, gw1, lm, mu)) * s * dx,
        weight * stiffness_density(gu1, gw1, lm, mu) * s * dx,
        weight * rho * ufl.inner(u, w) * s * dx,
    ]


def _assembled(forms: list[ufl.Form]) -> list[PETSc.Mat]:
    """Assemble (and finalise) each form's matrix."""
    mats = [dolfinx.fem.petsc.assemble_matrix(dolfinx.fem.form(a)) for a in forms]
    for a in mats:
        a.assemble()
    return mats


@dataclass
class _Operands:
    """What the friction row operation needs (reduced for two bodies); owned matrices."""

    blocks: list[PETSc.Mat]
    mass: PETSc.Mat
    imass: PETSc.Mat
    reactions: list[tuple[PETSc.Mat, PETSc.Mat | None] | None]
    x: np.ndarray
    y: np.ndarray
    dirichlet: np.ndarray
    owned: list[PETSc.Mat]


class SectionModel:
    """Assembled operator ``T(Lambda; k)`` of a 1D stack (the one 1D model).

    Call :meth:`operator` for ``T`` at a given ``k`` (:meth:`k_blocks` for its three parts in
    powers of ``k``), :meth:`canonical`, :meth:`full_vector` and :meth:`slip` for solution
    vectors, and :meth:`destroy` at the end.

    Args:
        comm: Communicator of the mesh and matrices (``MPI.COMM_SELF`` for one rank per k).
        stack: The layers and end conditions.
        params: Friction parameters (``f, gamma, Delta, alpha_pc, alpha_ld``; the geometry and
            the materials come from ``stack``).
        degree: Lagrange degree ``p`` (vector ``P_p``).
        form: ``"polynomial"`` (PEP) or ``"split"`` (NEP), see :mod:`forms.friction`.
    """

    def __init__(self, comm: MPI.Comm, stack: Stack, params: Params, degree: int = 3,
                 form: str = "polynomial") -> None:
        self.comm, self.stack, self.params = comm, stack, params
        self.degree, self.form = int(degree), form
        self.law = FrictionLaw.from_params(params)
        self.mesh = msh = interval_from_pieces(comm, stack.pieces())
        self.V = V = dolfinx.fem.FunctionSpace(
            msh, ufl.VectorElement("Lagrange", msh.ufl_cell(), self.degree, dim=2))
        self.coefficients = coef = section_coefficients(msh, stack)
        ends = _ends(msh, stack)
        tags = dolfinx.mesh.meshtags(msh, 0, np.sort(ends.iface1),
                                     np.full(len(ends.iface1), 1, dtype=np.int32))
        ds = ufl.Measure("ds", domain=msh, subdomain_data=tags)
        # Profiles are not polynomials: integrate them with 2 more than the P_p mass needs.
        meta = ({"quadrature_degree": 2 * self.degree + 2}
                if any(lay.profiled for lay in stack.layers()) else {})
        dx = ufl.Measure("dx", domain=msh, metadata=meta)
        full = _assembled(_k_forms(V, coef, 1.0, dx))
        u, w = ufl.TrialFunction(V), ufl.TestFunction(V)
        imass = _assembled([ufl.inner(u[0], w[0]) * ds(1)])[0]
        self._reduction: _Reduction | None = None
        if stack.rigid:
            ops = self._rigid(full, imass, ends)
        else:
            ops = self._two_body(full, imass, _assembled(_k_forms(V, coef, coef["chi1"], dx)),
                                 ends)
        self.interface_x, self.interface_y = ops.x, ops.y
        self.dirichlet_dofs = ops.dirichlet
        self._parts: list[FrictionOperator] = []
        for m, kb in enumerate(ops.blocks):
            op = friction_operator(self.law, kb, ops.mass if m == 0 else None,
                                   ops.imass if m == 0 else None, ops.x, ops.y, form=form,
                                   reactions=ops.reactions[m])
            apply_dirichlet(op.matrices, ops.dirichlet, op.constant_term,
                            DIRICHLET_DIAGONAL if m == 0 else 0.0)
            self._parts.append(op)
        for a in ops.owned:
            a.destroy()
        self._kop = KOperator(self._parts, self.law)
        self._y_owned, self._body_owned = self._owned_nodes(ends)

    def _rows(self, component: int, entities: np.ndarray) -> np.ndarray:
        """Owned global rows of one displacement component at mesh vertices."""
        V = self.V  # noqa: N806
        return owned_global_rows(
            V, dolfinx.fem.locate_dofs_topological(V.sub(component), 0, entities))

    def _outer_dirichlet(self, ends: _Ends) -> list[np.ndarray]:
        """Rows of the strong outer conditions (``velocity``: ``u_x``; ``clamped``: ``u``)."""
        out = []
        bottom = self.stack.bottom if not self.stack.rigid else ""
        for cond, ents in ((self.stack.top, ends.top), (bottom, ends.bottom)):
            if cond in ("velocity", "clamped"):
                out.append(self._rows(0, ents))
            if cond == "clamped":
                out.append(self._rows(1, ents))
        return out

    def _rigid(self, full: list[PETSc.Mat], imass: PETSc.Mat, ends: _Ends) -> _Operands:
        """Rigid substrate: ``u_y(0) = 0`` strongly, friction on the row of ``u_x(0)``."""
        x1, y1 = self._rows(0, ends.iface1), self._rows(1, ends.iface1)
        dirichlet = np.concatenate([*self._outer_dirichlet(ends), y1]).astype(np.int64)
        return _Operands(full[:3], full[3], imass, [None, None, None], x1, y1, dirichlet,
                         [*full, imass])

    def _two_body(self, full: list[PETSc.Mat], imass: PETSc.Mat, slider: list[PETSc.Mat],
                  ends: _Ends) -> _Operands:
        """Deformable substrate: reduce by ``P`` (module docstring), friction on the slip row."""
        x1, y1 = self._rows(0, ends.iface1), self._rows(1, ends.iface1)
        x2, y2 = self._rows(0, ends.iface2), self._rows(1, ends.iface2)
        dirichlet = self._outer_dirichlet(ends)
        bs, imap = self.V.dofmap.index_map_bs, self.V.dofmap.index_map
        f0 = bs * imap.local_range[0]
        red = _reduction(self.comm, bs * imap.size_local, bs * imap.size_global, f0,
                         x1, x2, y1, y2)
        self._reduction = red
        reduced = [reduce_matrix(a, red.P) for a in full]
        sreduced = [reduce_matrix(a, red.P) for a in slider]
        bmat = reduce_matrix(imass, red.Q)
        for a in (*full, *slider, imass):
            a.destroy()
        reactions = [(sreduced[0], sreduced[3]), (sreduced[1], None), (sreduced[2], None)]
        dir_dofs = (red.red[np.concatenate(dirichlet).astype(np.int64) - f0]
                    if dirichlet else np.zeros(0, dtype=np.int64))
        return _Operands(reduced[:3], reduced[3], bmat, reactions, red.red[x1 - f0],
                         red.red[y1 - f0], dir_dofs, [*reduced, *sreduced, bmat])

    def _owned_nodes(self, ends: _Ends) -> tuple[np.ndarray, np.ndarray]:
        """``y`` and body (1 slider, 2 substrate) of each owned node."""
        n_owned = self.V.dofmap.index_map.size_local
        y = self.V.tabulate_dof_coordinates()[:n_owned, 0].copy()
        body = np.where(y > 0, 1, 2)
        slider_nodes = dolfinx.fem.locate_dofs_topological(self.V, 0, ends.iface1)  # collective
        body[slider_nodes[slider_nodes < n_owned]] = 1
        if self.stack.rigid:
            body[:] = 1
        return y, body

    @property
    def size(self) -> int:
        """Global number of unknowns (reduced: without the eliminated ``u_y2``)."""
        return self._kop.op.matrices[0].getSize()[0]

    def k_blocks(self) -> tuple[FrictionOperator, FrictionOperator, FrictionOperator]:
        """The three parts of ``T(Lambda; k) = T0(Lambda) + k T1(Lambda) + k^2 T2(Lambda)``.

        Each ``Tm`` is a :class:`~forms.friction.FrictionOperator` in :attr:`form`: the friction
        row operation applied to the stiffness block ``Km`` (``T0`` also holds the mass ``M`` and
        the interface mass ``B``), with the Dirichlet rows applied (diagonal
        :data:`forms.friction.DIRICHLET_DIAGONAL` in the constant term of ``T0`` only). All
        matrices share one nonzero pattern. :meth:`operator` combines them for one ``k``; at
        fixed ``Lambda`` they give a quadratic eigenproblem in ``k``
        (:func:`forms.solvers.spatial_stability.spatial_roots`).

        Returns:
            ``(T0, T1, T2)``, owned by the model: read them, do not modify or destroy them.
        """
        t0, t1, t2 = self._parts
        return t0, t1, t2

    def operator(self, k: float) -> FrictionOperator:
        """``T(Lambda; k)`` as a :class:`FrictionOperator` (matrices reused between calls)."""
        return self._kop.at(k)

    def full_vector(self, vec: PETSc.Vec) -> PETSc.Vec:
        """Displacement on all nodes (both sides of the interface) from a solution vector.

        Returns a new vector in the layout of ``V`` (caller destroys it).
        """
        if self._reduction is None:
            return vec.copy()
        out = self._reduction.P.createVecLeft()
        self._reduction.P.mult(vec, out)
        return out

    def canonical(self, vec: PETSc.Vec) -> np.ndarray | None:
        """Gather a solution on rank 0 in a partition-independent order.

        Returns:
            On rank 0: array ``(n_nodes, 4)``: ``y``, ``body`` (1 slider, 2 substrate),
            ``u_x``, ``u_y`` (complex), sorted by ``y`` then body (substrate first at
            ``y = 0``); ``None`` on the other ranks.
        """
        full = self.full_vector(vec)
        vals = full.getArray(readonly=True).reshape(-1, 2).copy()
        full.destroy()
        local = np.column_stack([self._y_owned.astype(complex),
                                 self._body_owned.astype(complex), vals])
        parts = self.comm.gather(local, root=0)
        if self.comm.rank != 0:
            return None
        allv = np.concatenate(parts)
        order = np.lexsort((-allv[:, 1].real, allv[:, 0].real))
        return allv[order]

    def slip(self, vec: PETSc.Vec) -> complex:
        """Slip ``u_x1 - u_x2`` at the interface (``u_x1`` on a rigid substrate), all ranks."""
        arr = self.canonical(vec)
        val = None
        if arr is not None:
            zero = np.isclose(arr[:, 0].real, 0.0)
            ux1 = arr[zero & (arr[:, 1].real == 1), 2]
            ux2 = arr[zero & (arr[:, 1].real == 2), 2]
            val = complex(ux1[0] - (ux2[0] if len(ux2) else 0.0))
        return self.comm.bcast(val, root=0)

    def destroy(self) -> None:
        """Destroy the PETSc matrices."""
        self._kop.destroy()
        if self._reduction is not None:
            self._reduction.destroy()
