"""The one 2D eigen-model: Bloch cell or finite block, one or two bodies, friction along x.

Physics: :mod:`forms.elasticity` (the one definition of stress and strain), assembled on a 2D
mesh from :mod:`meshes.strip` (:func:`strip_mesh_for` picks it):

- one body (rigid substrate, ``params.mu2 = inf``): the slider ``0 < y < H``, ``u_y = 0`` at
  ``y = 0`` (a Dirichlet row);
- two bodies (``params.two_body``, finite ``H2``): the slider on the substrate ``-H2 < y < 0``
  (``mu2, rho2, beta2``, bottom condition ``bc2``), separate nodes at ``y = 0`` tied by the map
  of :mod:`forms.models.periodic` (``u_y`` continuous, ``u_x1 = s + u_x2``).

Matrices: ``stiffness`` ``inner(sigma(u), eps(w)) dx``, ``mass`` ``rho inner(u, w) dx``,
``interface_mass`` ``inner(u_x, w_x) ds(INTERFACE)`` (the consistent boundary mass that turns the
law's pointwise ``u_x`` term into a nodal one, docs/design.md section 5), and with two bodies the
slider's own ``K_1, M_1`` whose rows are the slider's reactions in the friction law.

On a Bloch cell (wavenumber ``k``) or with two bodies, the matrices are reduced by ``P^H A P``
(:func:`forms.models.periodic.reduction_map`) *before* any row operation, so every reduced row is
the row of a node of the periodic strip (a left-edge node carries its right-edge image). On a
one-body finite block there is no ``P``. The lateral ends of a block are free, rollers
(``u_x = 0``) or clamped, except the slider's interface nodes, which keep their rows.

The friction parameters may vary along the interface (:class:`FrictionProfile`: ``Delta``,
``f``, ``gamma`` as functions of ``x``, taken at the interface nodes): the law of each node's
row is that of its values (:func:`friction_operator_for`).

Related modules: :mod:`forms.mode_postprocessing` (what to do with a computed mode: harmonic
content, normalisation, interface stresses), :mod:`forms.solvers.continuation` (the 1D
model's branch followed in ``k``, and its mode evaluated on this mesh) and
:mod:`forms.solvers.spatial_stability` (spatial roots ``k(Lambda)`` and the long-block limit).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

import dolfinx.fem
import dolfinx.fem.petsc
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from analytic.params import ParameterError, Params
from forms.elasticity import mass_density, stiffness_density
from forms.friction import (
    DIRICHLET_DIAGONAL,
    FrictionLaw,
    FrictionOperator,
    apply_dirichlet,
    friction_operator,
)
from forms.mode_postprocessing import harmonic_content
from forms.models.periodic import ReductionMap, reduce_matrix, reduction_map
from forms.solvers.slepc import PolynomialSolver
from meshes.strip import (
    INTERFACE,
    SLIDER,
    SUBSTRATE,
    StripMesh,
    strip_mesh,
    two_body_strip_mesh,
)

LATERAL_CONDITIONS = ("free", "roller", "clamped")

#: A friction parameter along the interface: values at the points ``x`` (a 1D array).
Profile = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class FrictionProfile:
    """Friction parameters as functions of ``x`` along the interface (``None``: uniform).

    Each function takes the node abscissae (1D array) and returns the values there; a
    velocity-weakening patch is e.g. ``Delta=lambda x: np.where(abs(x - c) < Lp / 2, -0.3,
    0.2)``. The other parameters (``alpha_pc``, ``alpha_ld``) stay uniform.
    """

    Delta: Profile | None = None  # noqa: N815 - the paper's name
    f: Profile | None = None
    gamma: Profile | None = None

    def values(self, params: Params, x: np.ndarray) -> np.ndarray:
        """``(n, 3)`` columns ``Delta, f, gamma`` at the points ``x``."""
        out = []
        for name in ("Delta", "f", "gamma"):
            fn = getattr(self, name)
            base = np.full(len(x), float(getattr(params, name)))
            out.append(base if fn is None else np.broadcast_to(
                np.asarray(fn(np.asarray(x)), dtype=float), base.shape))
        return np.column_stack(out) if out else np.zeros((0, 3))


@dataclass
class StripProblem:
    """Assembled operators of a strip (Bloch cell if ``k`` is set, else a finite block).

    Attributes:
        strip: The mesh (one or two bodies).
        params: Physical parameters.
        k: Bloch wavenumber, or ``None`` for a finite block.
        V: The displacement space (vector Lagrange, both bodies).
        map: The reduction ``u = P x``, or ``None`` (one-body finite block: ``u = x``).
        stiffness: ``K`` (reduced by ``P``).
        mass: ``M`` (reduced).
        interface_mass: ``M_Gamma`` for the ``u_x`` (slip) term of the friction law (reduced).
        reactions: Two bodies: the slider's reduced ``(K_1, M_1)``; ``None``: ``(K, M)``.
        interface_x: Owned global rows (operator numbering) of ``u_x`` (the slip) at the
            slider's interface nodes.
        interface_y: Owned global rows of ``u_y`` at the same nodes, in the same order.
        interface_coordinate: ``x`` of those nodes.
        dirichlet: Owned global rows of the other constrained dofs (top, bottom, lateral ends;
            one body: also ``u_y`` at the interface).
        friction: Friction parameters along ``x`` (``None``: uniform, from ``params``).
        timings: Wall times of the set-up steps (s).
        last_solve: SLEPc outcome and settings of the last :func:`solve_modes`.
    """

    strip: StripMesh
    params: Params
    k: float | None
    V: dolfinx.fem.FunctionSpace
    map: ReductionMap | None
    stiffness: PETSc.Mat
    mass: PETSc.Mat
    interface_mass: PETSc.Mat
    reactions: tuple[PETSc.Mat, PETSc.Mat] | None
    interface_x: np.ndarray
    interface_y: np.ndarray
    interface_coordinate: np.ndarray
    dirichlet: np.ndarray
    friction: FrictionProfile | None = None
    timings: dict[str, float] = field(default_factory=dict)
    last_solve: dict[str, object] = field(default_factory=dict)

    @property
    def comm(self) -> MPI.Comm:
        """Communicator of the mesh and of every matrix."""
        return self.strip.comm

    @property
    def size(self) -> int:
        """Global number of unknowns of ``T(Lambda)``."""
        return self.stiffness.getSize()[0]

    def to_function(self, x: PETSc.Vec, name: str = "u") -> dolfinx.fem.Function:
        """Full displacement field ``u = P x`` (or ``x``), both bodies, ghosts updated."""
        u = dolfinx.fem.Function(self.V, name=name)
        if self.map is None:
            x.copy(u.vector)
        else:
            self.map.P.mult(x, u.vector)
        u.x.scatter_forward()
        return u

    def destroy(self) -> None:
        """Free the PETSc objects."""
        for A in (self.stiffness, self.mass, self.interface_mass, *(self.reactions or ())):
            A.destroy()
        if self.map is not None:
            self.map.destroy()


def strip_mesh_for(comm: MPI.Comm, params: Params, length: float, nx: int, ny: int,
                   grading: float = 1.0, ny2: int | None = None,
                   cell: str = "triangle") -> StripMesh:
    """The mesh of ``params``: the gmsh slider alone (rigid substrate) or both bodies.

    Args:
        comm: Mesh communicator.
        params: Parameters (``H``; with two bodies ``H2``, which must be finite).
        length: ``L``.
        nx: Cells along x.
        ny: Cells along y in the slider.
        grading: Cell-height ratio far/near the interface, both bodies.
        ny2: Cells along y in the substrate (default ``ny``).
        cell: One body: ``"triangle"`` or ``"quadrilateral"`` (two bodies: triangles only).
    """
    if not params.two_body:
        return strip_mesh(comm, length, params.H, nx, ny, grading=grading, cell=cell)
    if cell != "triangle":
        raise ParameterError(f"cell = {cell!r} is outside its allowed values here (two bodies:"
                             " triangle)")
    if not np.isfinite(params.H2):
        raise ParameterError(f"H2 = {params.H2!r} is outside its allowed range here"
                             " (finite: the substrate is meshed)")
    return two_body_strip_mesh(comm, length, params.H, params.H2, nx, ny,
                               ny if ny2 is None else ny2, grading, grading)


def node_bodies(strip: StripMesh, V: dolfinx.fem.FunctionSpace) -> np.ndarray:
    """Per owned node of ``V``: 1 (slider) or 2 (substrate); the two ``y = 0`` nodes differ."""
    n_owned = V.dofmap.index_map.size_local
    if not strip.two_body:
        return np.ones(n_owned, dtype=int)
    ind = dolfinx.fem.Function(V)
    slider = strip.cell_tags.indices[strip.cell_tags.values == SLIDER]
    ind.interpolate(lambda x: np.ones((2, x.shape[1])), cells=slider)
    return np.where(ind.x.array.reshape(-1, 2)[:n_owned, 0].real > 0.5, 1, 2)


def cellwise(mesh: dolfinx.mesh.Mesh, cells: np.ndarray,
             pairs: tuple[tuple[float, float], ...]) -> tuple:
    """Cell-wise (DG0) coefficients of two bodies.

    Per ``(one, two)`` of ``pairs``: a function equal to ``one`` on every cell of ``mesh`` and
    to ``two`` on ``cells`` (this rank's substrate cells).
    """
    Q = dolfinx.fem.FunctionSpace(mesh, ("DG", 0))
    out = []
    for one, two in pairs:
        c = dolfinx.fem.Function(Q)
        c.x.array[:] = one
        c.interpolate(lambda x, v=two: np.full(x.shape[1], v), cells=cells)
        out.append(c)
    return tuple(out)


def materials(strip: StripMesh, params: Params) -> tuple:
    """``(mu, lambda, rho)`` as UFL coefficients: numbers (one body) or cell-wise (DG0)."""
    if not strip.two_body:
        return 1.0, params.lame_lambda, 1.0
    sub = strip.cell_tags.indices[strip.cell_tags.values == SUBSTRATE]
    return cellwise(strip.mesh, sub, ((1.0, params.mu2),
                                      (params.lame_lambda, params.substrate.lame_lambda),
                                      (1.0, params.rho2)))


def _assemble(strip: StripMesh, params: Params, V: dolfinx.fem.FunctionSpace
              ) -> dict[str, PETSc.Mat]:
    """``K, M, B`` (and with two bodies the slider's ``K1, M1``), unreduced."""
    msh = strip.mesh
    u, w = ufl.TrialFunction(V), ufl.TestFunction(V)
    ds = ufl.Measure("ds", domain=msh, subdomain_data=strip.facet_tags)
    mu, lmbda, rho = materials(strip, params)
    forms = {
        "stiffness": stiffness_density(ufl.grad(u), ufl.grad(w), lmbda, mu) * ufl.dx,
        "mass": mass_density(u, w, rho) * ufl.dx,
        "interface_mass": ufl.inner(u[0], w[0]) * ds(INTERFACE),
    }
    if strip.two_body:
        dx = ufl.Measure("dx", domain=msh, subdomain_data=strip.cell_tags)
        forms["K1"] = stiffness_density(ufl.grad(u), ufl.grad(w), lmbda, mu) * dx(SLIDER)
        forms["M1"] = mass_density(u, w) * dx(SLIDER)
    mats = {}
    for name, a in forms.items():
        A = dolfinx.fem.petsc.assemble_matrix(dolfinx.fem.form(a))
        A.assemble()
        mats[name] = A
    return mats


def explicit_operators(strip: StripMesh, params: Params, V: dolfinx.fem.FunctionSpace
                       ) -> dict[str, PETSc.Mat | PETSc.Vec]:
    """The explicit time domain's operators on the one 2D model, unreduced (collective).

    The stiffness of :func:`_assemble` (materials of :func:`materials`), the lumped mass (row
    sums of the mass matrix) and ``int_Gamma w_x ds`` (the slider's side); with two bodies
    also the slider's own stiffness and lumped mass (its reactions). Vectors have their ghosts
    summed.

    Returns:
        ``{"K", "lump", "interface"}`` and with two bodies ``"K1", "lump1"``; the caller
        destroys them.
    """
    u, w = ufl.TrialFunction(V), ufl.TestFunction(V)
    ds = ufl.Measure("ds", domain=strip.mesh, subdomain_data=strip.facet_tags)
    dx = ufl.Measure("dx", domain=strip.mesh, subdomain_data=strip.cell_tags)
    mu, lmbda, rho = materials(strip, params)
    ones = ufl.as_vector((1.0, 1.0))
    forms = {"K": stiffness_density(ufl.grad(u), ufl.grad(w), lmbda, mu) * ufl.dx,
             "lump": rho * ufl.inner(ones, w) * ufl.dx,
             "interface": ufl.inner(ufl.as_vector((1.0, 0.0)), w) * ds(INTERFACE)}
    if strip.two_body:
        forms["K1"] = stiffness_density(ufl.grad(u), ufl.grad(w), lmbda, mu) * dx(SLIDER)
        forms["lump1"] = ufl.inner(ones, w) * dx(SLIDER)
    out: dict[str, PETSc.Mat | PETSc.Vec] = {}
    for name, a in forms.items():
        if name.startswith("K"):
            out[name] = dolfinx.fem.petsc.assemble_matrix(dolfinx.fem.form(a))
            out[name].assemble()
        else:
            out[name] = dolfinx.fem.petsc.assemble_vector(dolfinx.fem.form(a))
            out[name].ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    return out


@dataclass
class ExplicitStrip:
    """The one 2D model set up for explicit time stepping: P1/Q1, lumped mass, periodic strip.

    Same mesh, materials (:func:`explicit_operators`), periodic map
    (:func:`forms.models.periodic.reduction_map` with phase exactly 1, and with two bodies the
    tie ``u_y`` continuous, ``u_x1 = s + u_x2``) and constrained rows (those of
    :func:`build_strip_problem`) as the eigen-model.

    The reduced lumped mass ``M_r = P^T diag(m) P`` is diagonal except, with two bodies, the
    ``2 x 2`` block ``[[m1, m1], [m1, m1 + m2]]`` of each interface pair ``(s, u_x2)`` (kinetic
    energy ``m1 (s' + u_x2')^2 + m2 u_x2'^2``); its inverse has the block
    ``[[1/m1 + 1/m2, -1/m2], [-1/m2, 1/m2]]``. The two nodes of a pair may be owned by
    different ranks: ``M_r`` and ``M_r^{-1}`` are distributed matrices.

    Attributes:
        V: Vector P1/Q1 space.
        map: The reduction ``u = P x``.
        stiffness: Reduced ``P^T K P``.
        mass: Diagonal of ``M_r`` (``P^T m``) at the owned reduced rows (local array).
        interface_length: Lumped interface length ``P^T B`` of the owned reduced rows.
        interface_x: Owned global rows of ``u_x`` (the slip with two bodies) at the slider's
            interface nodes, sorted by ``x``.
        interface_y: Owned global rows of ``u_y`` at the same nodes, in the same order.
        interface_coordinate: ``x`` of those nodes (increasing).
        top_x: Owned global rows of ``u_x`` on the top held by ``bc = velocity`` (else empty).
        dirichlet: Owned global rows held fixed (one body: ``interface_y``; ``top_x``; with two
            bodies and ``bc2 = velocity`` the bottom's ``u_x2``).
        row_bound: Per owned reduced row, the Gershgorin row bound of the generalised problem
            ``K x = omega^2 M_r x``: ``sum_j |K_ij| / m_i`` in the variables where the lumped
            mass is diagonal (two bodies: ``u_x1, u_x2`` instead of ``s, u_x2``, i.e. the map
            ``Q``; the same spectrum).
        mass_matrix: Two bodies: ``M_r``; ``None``: it is ``diag(mass)``.
        inverse_mass: Two bodies: ``M_r^{-1}``; ``None``: ``1/mass``.
        reactions: Two bodies: the slider's reduced ``(K_1, M_1)`` (lumped ``M_1``); ``None``:
            ``(stiffness, diag(mass))``.
    """

    V: dolfinx.fem.FunctionSpace
    map: ReductionMap
    stiffness: PETSc.Mat
    mass: np.ndarray
    interface_length: np.ndarray
    interface_x: np.ndarray
    interface_y: np.ndarray
    interface_coordinate: np.ndarray
    top_x: np.ndarray
    dirichlet: np.ndarray
    row_bound: np.ndarray
    mass_matrix: PETSc.Mat | None = None
    inverse_mass: PETSc.Mat | None = None
    reactions: tuple[PETSc.Mat, PETSc.Mat] | None = None

    def destroy(self) -> None:
        """Free the PETSc objects."""
        for obj in (self.stiffness, self.mass_matrix, self.inverse_mass, *(self.reactions or ())):
            if obj is not None:
                obj.destroy()
        self.map.destroy()


def _diagonal(template: PETSc.Mat, values: PETSc.Vec) -> PETSc.Mat:
    """A square AIJ matrix with the row layout of ``template``'s rows holding ``diag(values)``."""
    n = template.getSizes()[0]
    D = PETSc.Mat().createAIJ((n, n), nnz=1, comm=template.getComm())
    D.setDiagonal(values)
    D.assemble()
    return D


def _transpose_apply(P: PETSc.Mat, full: PETSc.Vec) -> np.ndarray:
    """``P^T full`` as the local real array of the owned reduced rows."""
    red = P.createVecRight()
    P.multTranspose(full, red)
    out = red.array.real.copy()
    red.destroy()
    return out


def _row_bound(K: PETSc.Mat, mass: np.ndarray) -> np.ndarray:
    """``sum_j |K_ij| / m_i`` per owned row (Gershgorin rows of ``m^{-1} K``)."""
    indptr, _, vals = K.getValuesCSR()
    rows = np.repeat(np.arange(len(indptr) - 1), np.diff(indptr))
    return np.bincount(rows, weights=np.abs(vals), minlength=len(indptr) - 1) / mass


def _inverse_block_mass(Mr: PETSc.Mat, mass_q: np.ndarray, slip: np.ndarray) -> PETSc.Mat:
    """``M_r^{-1}`` of the reduced lumped mass with the ``[[m1, m1], [m1, m1 + m2]]`` blocks.

    ``O`` (``M_r`` without its diagonal) holds ``m1`` at ``(s, u_x2)`` and ``(u_x2, s)``; with
    the diagonal masses ``mass_q`` of ``(u_x1, u_x2)`` (``m1`` in the row of ``s``, ``m2`` in
    that of ``u_x2``): ``(O 1)_i = m1`` and ``(O mass_q)_s = m1 m2`` in a pair's rows, so every
    rank finds both masses of its pair rows by two mat-vecs. Then ``M_r^{-1} = diag(d) -
    diag(1/(m1 m2)) O`` with ``d = 1/m1 + 1/m2`` (``s``), ``1/m2`` (``u_x2``), ``1/m``
    (other rows).
    """
    rstart = Mr.getOwnershipRange()[0]
    diag = Mr.getDiagonal()
    off = Mr.copy()
    zero = diag.duplicate()
    zero.set(0.0)
    off.setDiagonal(zero)
    ones, o1, omq = (diag.duplicate() for _ in range(3))
    ones.set(1.0)
    off.mult(ones, o1)
    zero.array[:] = mass_q
    off.mult(zero, omq)
    m1 = o1.array.real.copy()
    pair = m1 > 0
    is_s = np.zeros(len(m1), dtype=bool)
    is_s[np.asarray(slip, dtype=np.int64) - rstart] = True
    m2 = np.where(is_s, omq.array.real / np.where(pair, m1, 1.0), mass_q)
    d = np.where(pair, np.where(is_s, 1.0 / np.where(pair, m1, 1.0), 0.0) + 1.0 / m2,
                 1.0 / diag.array.real)
    scale = zero
    scale.array[:] = np.where(pair, -1.0 / np.where(pair, m1 * m2, 1.0), 0.0)
    off.diagonalScale(L=scale)
    ones.array[:] = d
    off.setDiagonal(ones)
    for v in (diag, o1, omq, scale, ones):
        v.destroy()
    return off


def explicit_strip(strip: StripMesh, params: Params) -> ExplicitStrip:
    """Assemble :class:`ExplicitStrip` on a periodic strip, one or two bodies (collective).

    Args:
        strip: Mesh from :func:`strip_mesh_for` (triangles: P1, quadrilaterals: Q1; two bodies:
            P1).
        params: Physical parameters (``bc`` chooses the top condition, ``bc2`` the bottom's).
    """
    if strip.two_body != params.two_body:
        raise ParameterError(f"mu2 = {params.mu2!r} does not match the mesh (two bodies:"
                             f" {strip.two_body}); build it with strip_mesh_for")
    msh = strip.mesh
    V = dolfinx.fem.FunctionSpace(msh, ufl.VectorElement("Lagrange", msh.ufl_cell(), 1))
    ops = explicit_operators(strip, params, V)
    body = node_bodies(strip, V)
    rmap = reduction_map(V, strip, 0.0, body)  # k = 0: phase exactly 1
    Kr = reduce_matrix(ops["K"], rmap.P)
    mass = _transpose_apply(rmap.P, ops["lump"])
    blen = _transpose_apply(rmap.P, ops["interface"])
    ix, iy, xi, rows = _constrained_rows(strip, params, V, rmap.reduced, body, False, "free")
    order = np.argsort(xi)
    n_owned = V.dofmap.index_map.size_local
    xy = V.tabulate_dof_coordinates()[:n_owned, :2]
    at_top = (np.abs(xy[:, 1] - strip.height) < 1e-10 * (strip.height + strip.depth)) \
        & (rmap.reduced[:, 0] >= 0)
    top_x = np.intersect1d(rmap.reduced[at_top, 0], rows).astype(PETSc.IntType)
    out = ExplicitStrip(V, rmap, Kr, mass, blen, ix[order], iy[order], xi[order], top_x, rows,
                        _row_bound(Kr, mass))
    if strip.two_body:
        _two_body_mass(out, ops)
    for obj in ops.values():
        obj.destroy()
    return out


def _two_body_mass(out: ExplicitStrip, ops: dict[str, PETSc.Mat | PETSc.Vec]) -> None:
    """Fill the two-body fields of ``out``: ``M_r``, ``M_r^{-1}``, reactions, row bound."""
    P, Q = out.map.P, out.map.Q
    D = _diagonal(ops["K"], ops["lump"])
    out.mass_matrix = reduce_matrix(D, P)
    mass_q = _transpose_apply(Q, ops["lump"])
    Kq = reduce_matrix(ops["K"], Q)
    out.row_bound = _row_bound(Kq, mass_q)
    Kq.destroy()
    out.inverse_mass = _inverse_block_mass(out.mass_matrix, mass_q, out.interface_x)
    D1 = _diagonal(ops["K"], ops["lump1"])
    out.reactions = (reduce_matrix(ops["K1"], P), reduce_matrix(D1, P))
    D.destroy()
    D1.destroy()


def _reduce(mats: dict[str, PETSc.Mat], rmap: ReductionMap | None) -> dict[str, PETSc.Mat]:
    """``P^H A P`` of every matrix (``Q`` for the interface mass of the slip); frees ``A``."""
    if rmap is None:
        return mats
    out = {}
    for name, full in mats.items():
        out[name] = reduce_matrix(full, rmap.Q if (name == "interface_mass"
                                                   and rmap.Q is not None) else rmap.P)
        full.destroy()
    return out


def _constrained_rows(strip: StripMesh, params: Params, V: dolfinx.fem.FunctionSpace,
                      red: np.ndarray, body: np.ndarray, finite_block: bool, lateral: str
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Interface rows ``(x, y)``, their abscissae and the Dirichlet rows (owned, global)."""
    n_owned = V.dofmap.index_map.size_local
    xy = V.tabulate_dof_coordinates()[:n_owned, :2]
    tol = 1e-10 * max(strip.length, strip.height + strip.depth)
    ok = red[:, 0] >= 0  # not an eliminated right-edge node
    at = {"interface": np.abs(xy[:, 1]) < tol, "top": np.abs(xy[:, 1] - strip.height) < tol,
          "bottom": strip.two_body & (np.abs(xy[:, 1] + strip.depth) < tol),
          "ends": finite_block & ((np.abs(xy[:, 0]) < tol)
                                  | (np.abs(xy[:, 0] - strip.length) < tol))}
    iface = np.flatnonzero(at["interface"] & (body == 1) & ok)
    ix, iy = red[iface, 0], red[iface, 1]
    dirichlet = []
    if params.bc == "velocity":
        dirichlet.append(red[at["top"] & ok, 0])
    if strip.two_body and params.bc2 == "velocity":
        dirichlet.append(red[at["bottom"] & ok, 0])
    if finite_block and lateral != "free":
        # The slider's interface nodes keep their rows (the friction law); the substrate's
        # take the lateral condition (its u_y there is the slider's: not an unknown).
        ends = at["ends"] & ~(at["interface"] & (body == 1))
        dirichlet.append(red[ends, 0])
        if lateral == "clamped":
            dirichlet.append(red[ends, 1])
    if not strip.two_body:
        dirichlet.append(iy)  # the rigid substrate: u_y = 0
    rows = np.unique(np.concatenate(dirichlet)) if dirichlet else np.zeros(0, np.int64)
    rows = rows[rows >= 0]  # slots that are not unknowns (right edge, the substrate's u_y2)
    # A node on the interface and on a Dirichlet edge keeps its friction row.
    rows = np.setdiff1d(rows, ix).astype(PETSc.IntType)
    return (ix.astype(PETSc.IntType), iy.astype(PETSc.IntType), xy[iface, 0].copy(), rows)


def _check_arguments(degree: int, lateral: str, k: float | None) -> None:
    if degree < 1:
        raise ParameterError(f"degree = {degree} is outside its allowed range >= 1")
    if lateral not in LATERAL_CONDITIONS:
        raise ParameterError(f"lateral = {lateral!r} is not one of {', '.join(LATERAL_CONDITIONS)}")
    if k is not None and not (np.isfinite(k) and k > 0):
        raise ParameterError(f"k = {k!r} is outside its allowed range k > 0 (finite)")


def build_strip_problem(strip: StripMesh, params: Params, k: float | None = None,
                        degree: int = 2, lateral: str = "free",
                        friction: FrictionProfile | None = None) -> StripProblem:
    """Assemble ``K``, ``M``, ``M_Gamma`` (reduced) and locate the constrained rows.

    Args:
        strip: Mesh from :func:`strip_mesh_for` (two bodies if ``params.two_body``).
        params: Physical parameters (``bc``, ``bc2`` choose the outer conditions).
        k: Bloch wavenumber (``u(L) = exp(-i k L) u(0)``); ``None`` for a finite block.
        degree: Lagrange degree.
        lateral: Finite block only: lateral ends ``free``, ``roller`` (``u_x = 0``) or
            ``clamped`` (``u = 0``).
        friction: Friction parameters along ``x`` (default: uniform, from ``params``).

    Returns:
        The assembled :class:`StripProblem` (collective; destroy it when done).
    """
    _check_arguments(degree, lateral, k)
    if strip.two_body != params.two_body:
        raise ParameterError(f"mu2 = {params.mu2!r} does not match the mesh (two bodies:"
                             f" {strip.two_body}); build it with strip_mesh_for")
    timings: dict[str, float] = {}
    t0 = MPI.Wtime()
    msh = strip.mesh
    V = dolfinx.fem.FunctionSpace(msh, ufl.VectorElement("Lagrange", msh.ufl_cell(), degree))
    mats = _assemble(strip, params, V)
    timings["assemble"] = MPI.Wtime() - t0
    t0 = MPI.Wtime()
    body = node_bodies(strip, V)
    rmap = reduction_map(V, strip, k, body)
    timings["bloch_map"] = MPI.Wtime() - t0
    t0 = MPI.Wtime()
    mats = _reduce(mats, rmap)
    timings["reduce"] = MPI.Wtime() - t0
    if rmap is not None:
        red = rmap.reduced
    else:
        n_owned = V.dofmap.index_map.size_local
        start = V.dofmap.index_map.local_range[0]
        red = 2 * (start + np.arange(n_owned, dtype=np.int64))[:, None] + np.array([0, 1])
    ix, iy, xi, rows = _constrained_rows(strip, params, V, red, body, k is None, lateral)
    reactions = (mats["K1"], mats["M1"]) if strip.two_body else None
    return StripProblem(strip, params, k, V, rmap, mats["stiffness"], mats["mass"],
                        mats["interface_mass"], reactions, ix, iy, xi, rows, friction,
                        timings)


def _law_groups(problem: StripProblem) -> list[tuple[tuple[float, float, float], np.ndarray]]:
    """Distinct ``(Delta, f, gamma)`` along the interface, each with this rank's rows of it.

    Every rank gets the same sorted list of values (each is one collective operator build).
    """
    p = problem.params
    if problem.friction is None:
        return [((p.Delta, p.f, p.gamma), np.arange(len(problem.interface_x)))]
    vals = problem.friction.values(p, problem.interface_coordinate)
    mine = {tuple(map(float, v)) for v in vals}
    groups = sorted(set().union(*problem.comm.allgather(mine)))
    return [(g, np.flatnonzero(np.all(vals == np.array(g), axis=1))) for g in groups]


def friction_operator_for(problem: StripProblem, form: str = "polynomial") -> FrictionOperator:
    """``T(Lambda)`` of the strip: :mod:`forms.friction` rows on the (reduced) ``K, M, M_Gamma``.

    Interface ``x``-rows (the slip with two bodies) carry the friction law with the slider's
    reactions; the Dirichlet rows read ``u_d = 0`` through
    :func:`forms.friction.apply_dirichlet` (diagonal 1 in the constant term only: their
    eigenvalues sit at infinity, far from every finite target). With a
    :class:`FrictionProfile`, every distinct ``(Delta, f, gamma)`` gives the law of its rows:
    one operator per distinct value set, its rows copied into the first (collective).
    """
    ops = []
    for (delta, f, gamma), sel in _law_groups(problem):
        law = FrictionLaw.from_params(problem.params.replace(Delta=delta, f=f, gamma=gamma))
        ops.append((friction_operator(law, problem.stiffness, problem.mass,
                                      problem.interface_mass, problem.interface_x[sel],
                                      problem.interface_y[sel], form=form,
                                      reactions=problem.reactions), sel))
    op = ops[0][0]
    for other, sel in ops[1:]:
        for a, b in zip(op.matrices, other.matrices, strict=True):
            for row in problem.interface_x[sel].tolist():
                cols, vals = b.getRow(row)
                a.setValues([row], cols, vals, addv=PETSc.InsertMode.INSERT_VALUES)
            a.assemble()
        op.cleared_rows += other.cleared_rows
        other.destroy()
    apply_dirichlet(op.matrices, problem.dirichlet, op.constant_term, DIRICHLET_DIAGONAL)
    return op


@dataclass
class StripMode:
    """One eigenpair of a strip problem.

    Attributes:
        eigenvalue: ``Lambda``.
        vector: Eigenvector in the operator numbering (reduced on a Bloch cell).
        residual: Relative residual ``||T u|| / (sum |phi_j| ||A_j|| ||u||)``.
        harmonics: :func:`harmonic_content` of the mode (Bloch cell only).
    """

    eigenvalue: complex
    vector: PETSc.Vec
    residual: float
    harmonics: dict[int, float] | None = None

    @property
    def harmonic(self) -> int | None:
        """Dominant ``m`` (wavenumber ``k + 2 pi m / L``), or ``None`` on a finite block."""
        if not self.harmonics:
            return None
        return max(self.harmonics, key=self.harmonics.get)


def solve_modes(problem: StripProblem, target: complex, nev: int = 6,
                prefix: str = "strip_") -> list[StripMode]:
    """Eigenpairs nearest ``target`` (SLEPc PEP of :mod:`forms.solvers.slepc`), sorted by distance.

    Each mode carries its relative residual and, on a Bloch cell, its harmonic content.
    Collective. Destroy the vectors (``mode.vector.destroy()``) when done. SLEPc options with
    ``prefix`` (default ``-strip_pep_*``, ``-strip_st_*``) reach the solver.
    """
    op = friction_operator_for(problem)
    solver = PolynomialSolver(problem.comm, nev=nev, prefix=prefix)
    try:
        settings = solver.settings()
        result = solver.solve(op, target)
    finally:
        solver.destroy()
        op.destroy()
    modes = []
    for pair in result.pairs:
        harmonics = None
        if problem.k is not None:
            harmonics = harmonic_content(problem, problem.to_function(pair.vector))
        modes.append(StripMode(pair.value, pair.vector, pair.residual, harmonics))
    problem.last_solve = {"reason": result.reason, "converged": result.converged,
                          "iterations": result.iterations,
                          "dropped": [str(z) for z in result.dropped], **settings}
    return modes
