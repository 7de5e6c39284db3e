"""Half-space modes: the cross-section model with a complex-stretched absorbing layer (PML).

docs/design.md section 5, "Half-space". Above a physical region ``0 < y < h_phys`` a layer
``h_phys < y < h_phys + L`` maps ``y`` to the complex coordinate ``y~`` with
``dy~/dy = s(y)``; in the weak form ``d/dy -> (1/s) d/dy`` and ``dy -> s dy``
(:class:`forms.models.section.SectionModel`). The layer's top is clamped (``u = 0``). A partial wave
``exp(-k_* y~)`` (``k_* = k_s`` or ``k_d``) then decays in the layer like
``exp(-Re(k_* s) (y - h_phys))``.

Layer choice (:func:`design_layer`), from ``k`` and the target ``Lambda``:

- ``k_s = sqrt(Lambda^2 + k^2)``, ``k_d = sqrt(beta^2 Lambda^2 + k^2)`` on the sheet wanted
  (principal roots, ``Re >= 0``: the physical sheet of ``s(z, q)``; ``sheet = "s_tilde"`` flips
  ``k_s``, Appendix C).
- Angle: ``s = S exp(i phi)`` with ``phi = -arg(k_s/|k_s| + k_d/|k_d|)``, the bisector: both
  ``Re(k_s s)`` and ``Re(k_d s)`` are then ``|k| S cos(theta)`` with the same
  ``cos(theta) = |k_s/|k_s| + k_d/|k_d|| / 2`` (:attr:`LayerDesign.margin`). For the
  dilatational instability (``k_s ~ -i sqrt(1/beta^2 - 1) k``: an outgoing shear wave;
  ``k_d = k kappa_d`` small) this gives ``phi`` of about 60-75 degrees.
- Strength/thickness: the slower wave (``min(|k_s|, |k_d|)``: ``k_d`` near ``z = 1/beta``,
  ``k_s`` near ``z = -1``) must lose ``attenuation`` e-folds across the layer (round-trip
  reflection ``exp(-2 attenuation)``, 1e-14 for the default 16). The layer's real thickness is
  ``L = h_phys`` and ``S = attenuation / (L |k_slow| cos(theta))``: near a threshold, where
  ``kappa_d -> 0``, the layer gets *stronger*, not thicker.
- Profile and mesh: ``s`` is constant in the layer (the complex coordinate is continuous and
  piecewise linear; a vertex sits at ``h_phys``, so the kink is exact for the FE). Cells, in
  units of ``|y~|``, start at ``rho / |k_fast|`` (the fast wave is resolved) and grow by
  ``growth`` up to ``rho / |k_slow|``; the physical region has cells ``rho / |k_fast|``.
  ``rho`` depends on the degree (:data:`RESOLUTION`).

Failure detection (:func:`solve_halfspace`): the root is computed with two layer settings (the
second designed from the first root, with more attenuation, a finer mesh and a rotated
angle); their relative disagreement, the backward error, the attenuation actually achieved at
the computed root, the sheet the root belongs to and the cell budget are reported, and
:attr:`HalfSpaceResult.flags` names every check that failed (empty: trusted).
"""

from __future__ import annotations

import cmath
import math
from dataclasses import dataclass, field

import numpy as np

from mpi4py import MPI

from analytic.params import Params
from analytic.physics import finite_h
from forms.friction import FrictionOperator
from forms.models.section import SectionModel, Stack, pml_layers
from forms.solvers.slepc import PolynomialSolver, SolveResult, SplitSolver
from meshes.layered import geometric_sizes, layer_count

#: Cell size times |k_*| (in units of |y~|) per element degree. Measured (2026-11-21, default
#: layer): P4 gives relative errors 2e-14 .. 1.3e-13 on the dilatational roots and
#: 1e-10 .. 4e-10 on the shear roots (where both waves are fast and matter); P3 4e-12 .. 1e-11
#: (dilatational). With 1.0 (P4) the shear roots were only good to 5e-9.
RESOLUTION = {1: 0.02, 2: 0.15, 3: 0.35, 4: 0.6, 5: 0.9}
SHEETS = ("physical", "s_tilde")


def wavenumbers(lam: complex, k: float, beta: float, sheet: str = "physical"
                ) -> tuple[complex, complex]:
    """``(k_s, k_d)`` of ``exp(Lambda t - i k x)`` on a sheet.

    Principal roots (:func:`analytic.physics.finite_h.wavenumbers`, the one definition) on
    ``"physical"``; ``"s_tilde"`` flips ``k_s`` (a shear wave growing away from the interface,
    Appendix C).
    """
    ks, kd = (complex(w) for w in finite_h.wavenumbers(lam, k, beta))
    if sheet == "s_tilde":
        ks = -ks
    elif sheet != "physical":
        raise ValueError(f"sheet = {sheet!r} is not one of {SHEETS}")
    return ks, kd


def classify_sheet(lam: complex, k: float, beta: float, stretch: complex) -> str:
    """Sheet of a root found with a layer of stretch ``stretch``.

    The layer represents the partial waves that decay in it (``Re(k_* stretch) > 0``); if those
    are the principal ``k_s, k_d`` the root is a root of ``s`` (``"physical"``); with ``-k_s``
    of ``s~`` (``"s_tilde"``); with ``-k_d`` (a growing dilatational wave) ``"unphysical"``.
    """
    ks, kd = wavenumbers(lam, k, beta)
    if (kd * stretch).real < 0:
        return "unphysical"
    return "physical" if (ks * stretch).real >= 0 else "s_tilde"


@dataclass(frozen=True)
class LayerDesign:
    """A PML layer for one ``k`` and target (see the module docstring for the rules).

    Attributes:
        k: Wavenumber.
        target: Lambda the layer is designed for.
        sheet: Sheet of the target (``"physical"`` or ``"s_tilde"``).
        ks: ``k_s`` used.
        kd: ``k_d`` used.
        phi: Stretch angle (radians).
        margin: ``cos(theta)``: ``Re(k_* s) = |k_*| |s| cos(theta)`` for both waves.
        strength: ``|s|`` in the layer.
        h_phys: Height of the unstretched region.
        thickness: Real thickness ``L`` of the layer.
        attenuation: e-folds of the slower wave across the layer (one way).
        vertices: Mesh vertices (real coordinate).
        budget_exceeded: The cell budget capped the mesh (accuracy not guaranteed).
    """

    k: float
    target: complex
    sheet: str
    ks: complex
    kd: complex
    phi: float
    margin: float
    strength: float
    h_phys: float
    thickness: float
    attenuation: float
    vertices: np.ndarray = field(repr=False)
    budget_exceeded: bool = False

    @property
    def stretch(self) -> complex:
        """Complex ``s = dy~/dy`` in the layer."""
        return self.strength * cmath.exp(1j * self.phi)

    @property
    def cells(self) -> int:
        """Number of cells."""
        return len(self.vertices) - 1

    @property
    def top(self) -> float:
        """Real coordinate of the clamped top."""
        return float(self.vertices[-1])

    def achieved_attenuation(self, lam: complex, beta: float) -> float:
        """e-folds across the layer of the slower partial wave of ``lam`` (its own sheet)."""
        sheet = classify_sheet(lam, self.k, beta, self.stretch)
        if sheet == "unphysical":
            return -math.inf
        ks, kd = wavenumbers(lam, self.k, beta, sheet)
        return self.thickness * min((ks * self.stretch).real, (kd * self.stretch).real)

    def summary(self) -> dict[str, object]:
        """JSON-friendly description."""
        return {"k": self.k, "target": [self.target.real, self.target.imag],
                "sheet": self.sheet, "phi_deg": math.degrees(self.phi), "margin": self.margin,
                "strength": self.strength, "h_phys": self.h_phys, "thickness": self.thickness,
                "attenuation": self.attenuation, "cells": self.cells,
                "budget_exceeded": self.budget_exceeded}


def design_layer(k: float, target: complex, beta: float, degree: int = 4, *,
                 attenuation: float = 16.0, sheet: str = "physical",
                 resolution: float | None = None, growth: float = 1.3,
                 h_phys: float | None = None, angle_offset: float = 0.0,
                 max_cells: int = 4000) -> LayerDesign:
    """Choose the layer for wavenumber ``k`` and a target ``Lambda`` (module docstring).

    Args:
        k: Wavenumber ``> 0``.
        target: Expected Lambda (e.g. an approximate root).
        beta: ``c_s / c_d``.
        degree: Element degree (sets the default ``resolution``).
        attenuation: e-folds of the slower partial wave across the layer.
        sheet: ``"physical"`` (roots of ``s``) or ``"s_tilde"``.
        resolution: Cell size times ``|k_*|`` (default :data:`RESOLUTION`).
        growth: Ratio of neighbouring layer cells.
        h_phys: Unstretched height (default ``1/k``).
        angle_offset: Rotation of the angle away from the bisector, as a fraction of the
            admissible half-width ``pi/2 - theta`` (used by the second layer setting).
        max_cells: Cell budget; beyond it the mesh is coarsened and
            :attr:`LayerDesign.budget_exceeded` is set.
    """
    if not k > 0:
        raise ValueError(f"k = {k!r} must be > 0")
    ks, kd = wavenumbers(complex(target), float(k), beta, sheet)
    us, ud = ks / abs(ks), kd / abs(kd)
    bis = us + ud
    if abs(bis) < 1e-12:
        raise ValueError("no stretch angle makes both partial waves decay (k_s = -k_d)")
    theta = math.acos(min(1.0, abs(bis) / 2.0))
    phi = -cmath.phase(bis) + angle_offset * (0.5 * math.pi - theta)
    margin = min((us * cmath.exp(1j * phi)).real, (ud * cmath.exp(1j * phi)).real)
    slow, fast = min(abs(ks), abs(kd)), max(abs(ks), abs(kd))
    rho = RESOLUTION.get(degree, 1.4) if resolution is None else float(resolution)
    h_phys = 1.0 / k if h_phys is None else float(h_phys)
    length = attenuation / (slow * margin)  # layer length in units of |y~|
    h0, hmax = rho / fast, rho / slow
    n_phys = max(2, math.ceil(h_phys / h0))
    budget = False
    while n_phys + layer_count(length, h0, hmax, growth) > max_cells:
        budget = True
        h0, hmax = 1.5 * h0, 1.5 * hmax
        n_phys = max(2, math.ceil(h_phys / h0))
    sizes = geometric_sizes(length, h0, max(hmax, h0), growth)
    thickness = h_phys
    strength = length / thickness
    vertices = np.concatenate([np.linspace(0.0, h_phys, n_phys + 1),
                               h_phys + np.cumsum(sizes) / strength])
    vertices[-1] = h_phys + thickness
    return LayerDesign(k=float(k), target=complex(target), sheet=sheet, ks=ks, kd=kd, phi=phi,
                       margin=margin, strength=strength, h_phys=h_phys, thickness=thickness,
                       attenuation=attenuation, vertices=vertices, budget_exceeded=budget)


class HalfSpaceModel(SectionModel):
    """Cross-section operator ``T(Lambda)`` at one ``k`` with a PML layer on top.

    A constructor of the one 1D model (:class:`forms.models.section.SectionModel`): a physical
    layer ``0 < y < h_phys`` and the stretched layer of ``design``
    (:func:`forms.models.section.pml_layers`), clamped at the top, on a rigid substrate. Strong
    conditions: ``u_y(0) = 0`` and ``u = 0`` at the top of the layer; friction at ``y = 0`` by
    the row operation of :mod:`forms.friction`. :attr:`op` is the operator at ``design.k``.

    Args:
        comm: Communicator of the mesh and matrices.
        params: Physical parameters (``H``, ``bc`` and the substrate are ignored: half-space on
            a rigid substrate).
        design: Layer (:func:`design_layer`).
        degree: Lagrange degree.
        form: ``"polynomial"`` (PEP) or ``"split"`` (NEP).
    """

    def __init__(self, comm: MPI.Comm, params: Params, design: LayerDesign, degree: int = 4,
                 form: str = "polynomial") -> None:
        self.design = design
        stack = Stack(pml_layers(design, "slider", beta=params.beta), top="clamped")
        super().__init__(comm, stack, params, degree, form)
        self.op: FrictionOperator = self.operator(design.k)


@dataclass
class HalfSpaceResult:
    """A half-space root computed with two PML settings (see :func:`solve_halfspace`).

    Attributes:
        k: Wavenumber.
        Lambda: Root from the second (more attenuating, finer) setting; NaN if none.
        Lambda_first: Root from the first setting.
        disagreement: ``|Lambda - Lambda_first| / |Lambda|``.
        growth_disagreement: ``|Re Lambda - Re Lambda_first| / |Re Lambda|`` (the growth rate
            of a root next to a branch point is a tiny difference of large numbers).
        residual: Backward error of the SLEPc pair (second setting).
        sheet: Sheet of the root (:func:`classify_sheet`).
        attenuation: e-folds achieved at the root (second setting, slower wave).
        reason: SLEPc converged reason (second setting, or the first if it failed).
        designs: The two layers.
        sizes: Unknowns of the two models.
        flags: Checks that failed: ``"no_root"``, ``"not_converged"``, ``"layer_sensitive"``
            (disagreement above ``tol``), ``"growth_unresolved"`` (growth disagreement above
            ``growth_tol``: the sign of ``Re Lambda`` is not trustworthy), ``"residual"``,
            ``"low_attenuation"`` (below half the design value), ``"weak_angle"``
            (``margin < 0.2``), ``"budget"``, ``"sheet"`` (not the sheet asked for).
    """

    k: float
    Lambda: complex
    Lambda_first: complex
    disagreement: float
    growth_disagreement: float
    residual: float
    sheet: str
    attenuation: float
    reason: str
    designs: list[LayerDesign]
    sizes: list[int]
    flags: list[str]

    @property
    def ok(self) -> bool:
        """No check failed."""
        return not self.flags


def _solve_one(comm: MPI.Comm, params: Params, design: LayerDesign, degree: int, form: str,
               target: complex, nev: int) -> tuple[complex, float, str, int]:
    model = HalfSpaceModel(comm, params, design, degree, form)
    if form == "polynomial":
        # scalar scaling (-pml_pep_scale scalar): at k = 100 (|Lambda| = 200, Fig. gaps) the
        # unscaled TOAR pair had a backward error of 1.3e-9 on an AMD EPYC (above the 1e-10 the
        # result is trusted at; below it on an AVX-512 Xeon), 1.3e-17 scaled (session 13)
        solver: PolynomialSolver | SplitSolver = PolynomialSolver(comm, nev=nev,
                                                                  prefix="pml_", scale=True)
    else:
        solver = SplitSolver(comm, nev=nev, radius=max(0.5 * abs(target), 0.1), prefix="pml_")
    res: SolveResult = solver.solve(model.op, target)
    size = model.size
    if res.pairs:
        lam, resid = res.pairs[0].value, res.pairs[0].residual
    else:
        lam, resid = complex("nan"), math.inf
    reason = res.reason
    res.destroy()
    solver.destroy()
    model.destroy()
    return lam, resid, reason, size


def solve_halfspace(comm: MPI.Comm, params: Params, k: float, target: complex, *,
                    degree: int = 4, attenuation: float = 16.0, sheet: str = "physical",
                    form: str = "polynomial", tol: float = 1e-8, growth_tol: float = 1e-3,
                    nev: int = 1,
                    max_cells: int = 4000, check: bool = True) -> HalfSpaceResult:
    """Half-space root nearest ``target`` at wavenumber ``k``, with failure detection.

    Setting 1: :func:`design_layer` from ``target``. Setting 2 (if ``check``): designed from
    the first root, with ``1.25 attenuation``, ``0.8`` times the cell size and the angle
    rotated by a quarter of its admissible half-width. The reported root is setting 2's.

    Args:
        comm: Communicator of the mesh.
        params: Parameters (``H``/``bc`` ignored).
        k: Wavenumber.
        target: Expected Lambda (shift of shift-and-invert, and the first layer's design).
        degree: Element degree.
        attenuation: e-folds of the slower wave across the first layer.
        sheet: Sheet of the wanted root.
        form: ``"polynomial"`` (PEP) or ``"split"`` (NEP).
        tol: Largest accepted relative disagreement between the two settings.
        growth_tol: Largest accepted relative disagreement of ``Re Lambda``.
        nev: Eigenpairs computed per solve (the nearest to the target is used).
        max_cells: Cell budget per layer.
        check: Compute the second setting (otherwise ``Lambda = Lambda_first`` and no
            disagreement check).
    """
    beta = params.beta
    d1 = design_layer(k, target, beta, degree, attenuation=attenuation, sheet=sheet,
                      max_cells=max_cells)
    lam1, res1, reason1, n1 = _solve_one(comm, params, d1, degree, form, target, nev)
    designs, sizes = [d1], [n1]
    flags: list[str] = []
    if not np.isfinite(lam1):
        return HalfSpaceResult(k, lam1, lam1, math.nan, math.nan, res1, "", math.nan, reason1,
                               designs, sizes, ["no_root"])
    lam, resid, reason, dlast = lam1, res1, reason1, d1
    disagreement = growth_dis = math.nan
    if check:
        sheet1 = classify_sheet(lam1, k, beta, d1.stretch)
        sheet2 = sheet1 if sheet1 in SHEETS else sheet
        d2 = design_layer(k, lam1, beta, degree, attenuation=1.25 * attenuation, sheet=sheet2,
                          resolution=0.8 * RESOLUTION.get(degree, 1.4), angle_offset=0.25,
                          max_cells=max_cells)
        lam2, res2, reason2, n2 = _solve_one(comm, params, d2, degree, form, lam1, nev)
        designs.append(d2)
        sizes.append(n2)
        if not np.isfinite(lam2):
            flags.append("no_root")
        else:
            lam, resid, reason, dlast = lam2, res2, reason2, d2
            disagreement = abs(lam2 - lam1) / abs(lam2)
            growth_dis = abs(lam2.real - lam1.real) / abs(lam2.real) if lam2.real else math.inf
            if not disagreement <= tol:
                flags.append("layer_sensitive")
            if not growth_dis <= growth_tol:
                flags.append("growth_unresolved")
    found_sheet = classify_sheet(lam, k, beta, dlast.stretch)
    achieved = dlast.achieved_attenuation(lam, beta)
    if not reason.startswith("CONVERGED"):
        flags.append("not_converged")
    if not resid < 1e-10:
        flags.append("residual")
    if not achieved >= 0.5 * dlast.attenuation:
        flags.append("low_attenuation")
    if min(d.margin for d in designs) < 0.2:
        flags.append("weak_angle")
    if any(d.budget_exceeded for d in designs):
        flags.append("budget")
    if found_sheet != sheet:
        flags.append("sheet")
    return HalfSpaceResult(k=float(k), Lambda=lam, Lambda_first=lam1,
                           disagreement=disagreement, growth_disagreement=growth_dis,
                           residual=resid, sheet=found_sheet,
                           attenuation=achieved, reason=reason, designs=designs, sizes=sizes,
                           flags=flags)


@dataclass
class TruncatedResult:
    """Root of a plain truncated strip (no layer) of height ``H`` (see :func:`solve_truncated`).

    Attributes:
        k: Wavenumber.
        H: Strip height.
        bc: Top condition (``"velocity"`` or ``"stress"``).
        Lambda: Eigenvalue nearest the target (NaN if none).
        residual: Backward error.
        reflection: ``exp(-2 H min(Re k_s, Re k_d))`` at ``Lambda`` (physical sheet): the
            round-trip amplitude of the slower partial wave reflected by the top.
        size: Unknowns.
        flags: ``"no_root"``, ``"residual"``, ``"reflection"`` (``reflection > tol``).
    """

    k: float
    H: float
    bc: str
    Lambda: complex
    residual: float
    reflection: float
    size: int
    flags: list[str]


def solve_truncated(comm: MPI.Comm, params: Params, k: float, H: float, bc: str,
                    target: complex, *, degree: int = 4, tol: float = 1e-8) -> TruncatedResult:
    """The half-space approximated by a plain strip of height ``H`` (the cross-section model).

    The check is the reflection estimate: a root is only trusted if both partial waves have
    decayed by ``tol`` on the way to the top and back.
    """
    from forms.models.cross_section import CrossSectionModel

    p = Params(f=params.f, gamma=params.gamma, beta=params.beta, Delta=params.Delta, H=H,
               bc=bc, alpha_pc=params.alpha_pc, alpha_ld=params.alpha_ld)
    model = CrossSectionModel(comm, p, degree=degree, k_max=k)
    solver = PolynomialSolver(comm, nev=1, prefix="trunc_")
    res = solver.solve(model.operator(k), target)
    size = model.size
    flags: list[str] = []
    if res.pairs:
        lam, resid = res.pairs[0].value, res.pairs[0].residual
        ks, kd = wavenumbers(lam, k, params.beta)
        reflection = math.exp(-2.0 * H * min(ks.real, kd.real))
        if not resid < 1e-10:
            flags.append("residual")
        if not reflection <= tol:
            flags.append("reflection")
    else:
        lam, resid, reflection = complex("nan"), math.inf, math.nan
        flags.append("no_root")
    res.destroy()
    solver.destroy()
    model.destroy()
    return TruncatedResult(k=float(k), H=float(H), bc=bc, Lambda=lam, residual=resid,
                           reflection=reflection, size=size, flags=flags)
