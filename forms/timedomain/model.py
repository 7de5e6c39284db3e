"""Time-domain elastodynamics of the sliding strip with nonlinear rate-and-state friction.

Model (issue 10). The periodic strip ``0 < x < L``, ``0 < y < H`` of :mod:`meshes.strip` (``L``
a whole number of wavelengths ``2 pi / k``), plane-strain elastodynamics with the one
definition of stress in :mod:`forms.elasticity`, on a rigid substrate: ``u_y = 0`` at ``y = 0``
and rate-and-state friction there (or on a deformable substrate: see **Two deformable
bodies**); on top ``sigma_yy = -sigma0`` and either ``du_x/dt = v0`` (``bc = "velocity"``) or
``sigma_xy = tau0 = f sigma0`` (``bc = "stress"``).

**Perturbation frame.** The steady solution ``u0 = (v0 t + tau0 y / mu, -sigma0 y/(lambda +
2 mu))`` is exact for the continuum and for P1/Q1 elements (it is linear in ``y``), so the
unknown is ``w = u - u0``: the same elastodynamics, homogeneous top conditions (``w_x = 0`` or
zero shear traction; zero normal traction), ``w_y = 0`` at the interface, and at the interface
the nonlinear law written for the *total* fields ``v = v0 + dw_x/dt``, ``sigma = sigma0 +
dsigma``, ``tau = tau0 + dtau``. The body's nodal equation carries the force ``-B dtau`` (``B``
the lumped interface length of the node). Working with ``w`` keeps the perturbation at full
floating-point precision (``v0/c_s ~ 1e-6`` in the PMMA example).

**Units and the parameter map.** Project units (docs/design.md section 2): ``c_s = mu = rho = 1``,
time ``t0 = D/v0`` (``|g'(1)| = 1`` for the aging law), length ``c_s t0``. The law (physical)::

    f(v, phi) = f0 + a ln(v/v0) + b ln(v0 phi/D)   (regularised: a asinh(v/(2 v0) e^{Psi/a}),
                                                    Psi = f0 + b ln(v0 phi/D)),
    dphi/dt = 1 - |v| phi/D - alpha_LD phi/(b sigma) dsigma/dt     (aging; Linker-Dieterich),
    tau = sigma f(v, phi)   or   dtau/dt = -(|v|/(alpha_PC D)) (tau - sigma f)  (Prakash-Clifton).

Dimensionless: ``vh = v/v0``, ``theta = v0 phi/D`` (steady: 1), ``t`` in units of ``D/v0``::

    dtheta/dt = 1 - |vh| theta - (alpha_LD/b) theta d ln(sigma)/dt,
    dtau/dt = -(|vh|/alpha_PC) (tau - sigma f).

*Derivation of the linearisation* (``exp(Lambda t - i k x)``, all perturbations small):
``(Lambda + 1) dtheta = -dvh - (alpha_LD/b) Lambda dsigma/sigma0``; ``df = a dvh + b dtheta``
(the regularisation changes these by ``O(exp(-2 f0/a))``, i.e. not at all in double precision),
hence ``sigma0 df = sigma0 a (Lambda + 1 - b/a)/(Lambda + 1) dvh - alpha_LD Lambda/(Lambda + 1)
dsigma``; the shear law gives ``(1 + alpha_PC Lambda) dtau = sigma0 df + f0 dsigma``. With
``dvh = Lambda du_x / v0``, ``dtau = dsigma_xy``, ``dsigma = -dsigma_yy`` at ``y = 0``::

    (1 + alpha_PC L) sxy + (f0 - alpha_LD L/(L+1)) syy - (sigma0 a/v0) L (L + 1 - b/a)/(L+1) ux = 0,

which is docs/design.md section 3 (the law of :mod:`forms.friction`) exactly when::

    f = f0,   Delta = 1 - b/a = (a - b)/a,   1/gamma = sigma0 a / v0   (units mu/c_s),

i.e. ``gamma = mu v0 / (c_s sigma0 a)``. The nonlinear model has two more dimensionless numbers:
``a`` (the direct effect; sets how soon the log law is nonlinear: ``df = a ln(1 + dvh)``) and
``v0/c_s`` (sets the size of the physical perturbation for a given relative slip-rate
perturbation). Given ``(f, gamma, Delta)`` and ``(a, v0/c_s)``::

    b = a (1 - Delta),   sigma0/mu = (v0/c_s) / (gamma a),   D = v0 t0 = v0/c_s (length unit).

Defaults: the PMMA worked example of ``analytic.units`` (README): ``a = 0.010``, ``v0/c_s =
1e-3/1345``. Only ``a`` and ``v0/c_s`` enter beyond the linear parameters; the perturbation
equations scale with ``v0/c_s`` exactly, so results in units of ``v0`` and ``sigma0`` do not
depend on it (it only fixes the physical scale).

**Discretisation.** The one 2D model (:func:`forms.models.strip.explicit_strip`): P1 or Q1
(the mesh of :func:`forms.models.strip.strip_mesh_for`, triangles or quadrilaterals), row-sum
lumped mass ``m`` and lumped interface length ``B``; periodicity by the model's map ``P`` with
phase 1 (``K_r = P^T K P``, ``m_r = P^T m``), the model's interface and Dirichlet rows.
Explicit central differences::

    m (v^{n+1/2} - v^{n-1/2}) / dt = -K w^n + F^n,    w^{n+1} = w^n + dt v^{n+1/2},

Dirichlet dofs (``w_y`` at the interface, ``w_x`` on top for ``bc = velocity``) do not move.
The normal stress at an interface node is its reaction: ``B dsigma^n = (K w^n)_y`` (lumped
mass: the constrained row carries no inertia). The friction force ``F_x^n = -B dtau^n`` is
taken at time ``n`` with the slip rate ``v^n = (v^{n-1/2} + v^{n+1/2})/2``: a scalar implicit
equation per interface node, ``eps dvh = v_free - c dtau(dvh)`` with ``c = dt B/(2 m)``,
solved by safeguarded Newton (the left side is increasing in ``dvh``: a bracket always exists).
The state is integrated exactly at constant slip rate ``v^{n+1/2}`` over a step (aging law in
closed form); the Linker-Dieterich term is a multiplication of ``theta`` by ``(sigma_old /
sigma_new)^(alpha_LD/b)``, split symmetrically around the aging step (Strang); Prakash-Clifton:
second-order exponential integrator of ``dtau/dt = -kappa (tau - S)`` at constant ``kappa =
|vh^{n-1/2}|/alpha_PC`` with ``S = sigma f`` linear over the step, implicit in ``S^n``. All of
it is second order in ``dt``. Stable step: Gershgorin bound of ``m^{-1} K`` (free dofs),
``dt = cfl * 2 / sqrt(bound)``; the friction rows are implicit in the slip rate (no extra
limit from the radiation-damping-like direct effect).

**Two deformable bodies** (``params.two_body``, finite ``H2``; P1 on the two-body mesh of
:func:`forms.models.strip.strip_mesh_for`). The interface nodes are duplicated and tied by the
model's map (``u_y`` continuous, ``u_x1 = s + u_x2``: the slip ``s`` is a reduced unknown,
``ix`` its rows). The reduced lumped mass ``M_r = P^T diag(m) P`` has the block ``[[m1, m1],
[m1, m1 + m2]]`` per pair ``(s, u_x2)`` (``m1``, ``m2`` the lumped masses of the slider's and
the substrate's node) and is diagonal elsewhere; the scheme is the same with ``m^{-1}``
replaced by the distributed ``M_r^{-1}`` (block ``[[1/m1 + 1/m2, -1/m2], [-1/m2, 1/m2]]``):
``v^{n+1/2} = v^{n-1/2} + dt M_r^{-1} (-K w^n + F^n)``, the friction force ``-B dtau`` acting
on the slip row only, so the implicit solve's coefficient is ``c = dt B (M_r^{-1})_ss / 2``.
The normal stress is the slider's own reaction (the eigen-model's ``reactions``):
``B dsigma^n = (K_1 w^n)_y + m1 a_y^n`` with ``a_y^n = (M_r^{-1} (-K w^n))_y`` (``F`` has no
``y`` part, so ``a_y`` is known before the friction solve). The bottom's rows (``bc2``) are
the eigen-model's; the steady state is linear in ``y`` in each body (exact for P1), so ``w``
has homogeneous conditions there too. Stable step: the Gershgorin bound in the variables
``(u_x1, u_x2)`` where the lumped mass is diagonal (the same spectrum). Every identity below
holds with ``M_r`` in place of ``m``.

**Energy.** For the perturbation, ``E^{n+1/2} = 1/2 v^{n+1/2} m v^{n+1/2} + 1/2 w^{n+1} K w^n``
satisfies ``E^{n+1/2} - E^{n-1/2} = dt F^n . v^n`` exactly (central differences), so the budget
``E - E(0) = W_friction`` (work of the perturbed friction force on the body; the top does no
work on the perturbation under either top condition) closes to round-off; the usual
``1/2 v m v + 1/2 w K w`` at integer steps differs from it by ``O(dt^2)``.

Parallel: the mesh, ``K_r`` and every vector are distributed over the mesh communicator;
interface nodes are owned by one rank each (all friction work is local). Results on 1 and 2
ranks agree to round-off.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

import dolfinx.fem
from mpi4py import MPI
from petsc4py import PETSc

from analytic.law import FrictionLaw
from analytic.params import ParameterError, Params
from forms.friction import apply_dirichlet, friction_operator
from forms.models.periodic import ReductionMap
from forms.models.strip import ExplicitStrip, explicit_strip
from forms.solvers.slepc import PolynomialSolver
from meshes.strip import StripMesh

#: PMMA worked example (README, ``analytic.units``): direct effect and v0/c_s = 1 mm/s / 1345 m/s.
PMMA_A = 0.010
PMMA_V0 = 1e-3 / 1345.0
FRICTION_KINDS = ("rate-state", "none")


@dataclass(frozen=True)
class NonlinearLaw:
    """The nonlinear friction law in project units, mapped from the linear parameters.

    Attributes:
        params: The linear parameters (``f = f0``, ``gamma``, ``Delta``, ``alpha_pc``,
            ``alpha_ld``; ``beta``, ``H``, ``bc`` for the bulk).
        a: Direct effect ``a = d f / d ln v`` (``> 0``).
        v0: Sliding velocity in units of ``c_s`` (``0 < v0 < 1``).
        regularised: Use ``a asinh(v/(2 v0) exp(Psi/a))`` (else the plain logarithm, which is
            undefined for ``v <= 0``).
        kind: ``"rate-state"`` or ``"none"`` (frictionless interface: ``tau = tau0`` fixed,
            for energy checks of the elastic stepper).
    """

    params: Params
    a: float = PMMA_A
    v0: float = PMMA_V0
    regularised: bool = True
    kind: str = "rate-state"

    def __post_init__(self) -> None:
        for name in ("a", "v0"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ParameterError(f"{name} = {v!r} is outside its allowed range {name} > 0")
        if self.v0 >= 1.0:
            raise ParameterError(f"v0 = {self.v0!r} is outside its allowed range 0 < v0/c_s < 1")
        if self.kind not in FRICTION_KINDS:
            raise ParameterError(f"friction = {self.kind!r} is not one of "
                                 f"{', '.join(FRICTION_KINDS)}")
        if self.params.alpha_ld > 0 and self.b <= 0:
            raise ParameterError(f"Delta = {self.params.Delta!r} is outside its allowed range"
                                 " Delta < 1 with alpha_ld > 0 (b = a (1 - Delta) must be > 0)")
        if not math.isfinite(self.params.H):
            raise ParameterError("H = inf is outside its allowed range (finite H for a strip)")

    @property
    def f0(self) -> float:
        """Steady friction coefficient (the project's ``f``)."""
        return self.params.f

    @property
    def b(self) -> float:
        """State effect ``b = a (1 - Delta)``."""
        return self.a * (1.0 - self.params.Delta)

    @property
    def sigma0(self) -> float:
        """Normal stress in units of ``mu``: ``v0 / (gamma a)``."""
        return self.v0 / (self.params.gamma * self.a)

    @property
    def tau0(self) -> float:
        """Steady shear stress ``f0 sigma0``."""
        return self.f0 * self.sigma0

    def inv_e(self, psi: np.ndarray) -> np.ndarray:
        """``1/E = 2 exp(-(f0 + b psi)/a)`` (``X = vh E`` is the asinh argument)."""
        return 2.0 * np.exp(-(self.f0 + self.b * psi) / self.a)

    def f_minus_f0(self, dv: np.ndarray, psi: np.ndarray) -> np.ndarray:
        """``f(v, theta) - f0`` at ``vh = 1 + dv``, ``psi = ln theta``, without cancellation.

        For ``vh > 0``: ``a ln vh + b psi + a ln((1 + sqrt(1 + X^-2))/2)`` (exact identity for
        the asinh form; the last term is ``O(X^-2)``); for ``vh <= 0`` (regularised only):
        ``a asinh(X) - f0``.
        """
        dv = np.asarray(dv, dtype=float)
        vh = 1.0 + dv
        pos = vh > 0
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            out = self.a * np.log1p(dv) + self.b * psi
            if self.regularised:
                q = (self.inv_e(psi) / np.where(pos, vh, 1.0)) ** 2
                out = out + self.a * np.log1p(q / (2.0 * (np.sqrt(1.0 + q) + 1.0)))
                neg = self.a * np.arcsinh(vh / np.maximum(self.inv_e(psi), 1e-300)) - self.f0
                out = np.where(pos, out, neg)
        return out

    def dfdv(self, dv: np.ndarray, psi: np.ndarray) -> np.ndarray:
        """``d f / d vh`` (``a / sqrt(vh^2 + E^-2)``, or ``a / vh`` unregularised)."""
        vh = 1.0 + np.asarray(dv, dtype=float)
        if self.regularised:
            return self.a / np.sqrt(vh**2 + self.inv_e(psi) ** 2)
        return self.a / vh

    def summary(self) -> dict[str, float | str | bool]:
        """The nonlinear numbers (for JSON)."""
        return {"a": self.a, "b": self.b, "v0_over_cs": self.v0, "sigma0_over_mu": self.sigma0,
                "tau0_over_mu": self.tau0, "f0": self.f0, "D_length_units": self.v0,
                "regularised": self.regularised, "friction": self.kind}


def _phi1(z: np.ndarray) -> np.ndarray:
    """``(1 - exp(-z))/z`` with the limit 1 at ``z = 0``."""
    z = np.asarray(z, dtype=float)
    small = np.abs(z) < 1e-8
    with np.errstate(divide="ignore", invalid="ignore"):
        out = -np.expm1(-z) / np.where(small, 1.0, z)
    return np.where(small, 1.0 - 0.5 * z, out)


def aging_step(dtheta: np.ndarray, dv: np.ndarray, dt: float) -> np.ndarray:
    """Exact aging-law step at constant slip rate: ``theta - 1`` after ``dt``.

    ``theta' = 1 - |vh| theta`` gives ``theta(dt) = theta E + dt phi1(|vh| dt)`` with
    ``E = exp(-|vh| dt)``; written for ``dtheta = theta - 1``:
    ``dtheta E + dt phi1(z) (1 - |vh|)`` (no cancellation for ``vh`` near 1).
    """
    vabs = np.abs(1.0 + dv)
    z = vabs * dt
    one_minus = np.where(1.0 + dv >= 0, -dv, 1.0 - vabs)
    return dtheta * np.exp(-z) + dt * _phi1(z) * one_minus


@dataclass
class InterfaceState:
    """Interface fields at the owned interface nodes (all perturbations, project units).

    Attributes:
        dtheta: ``theta - 1`` at the current integer step.
        dtau: ``tau - tau0`` at the current step (Prakash-Clifton state; else diagnostic).
        s_prev: ``sigma f - tau0`` at the previous step (Prakash-Clifton only).
        dsigma: ``sigma - sigma0`` at the current step.
        dv: ``v/v0 - 1`` at the current step (``v^n``).
    """

    dtheta: np.ndarray
    dtau: np.ndarray
    s_prev: np.ndarray
    dsigma: np.ndarray
    dv: np.ndarray


@dataclass
class Mode:
    """A discrete eigenpair of the linearised semi-discrete stepper (reduced numbering).

    Attributes:
        eigenvalue: ``Lambda_h`` of the lumped P1/Q1 system.
        vector: Local owned part of the reduced eigenvector (complex).
        residual: Relative residual of the PEP solve.
        exact: The exact (analytic) eigenvalue used as target, if given.
    """

    eigenvalue: complex
    vector: np.ndarray
    residual: float
    exact: complex | None = None


@dataclass
class Sample:
    """Diagnostics at one integer step (every rank holds the same values).

    Attributes:
        step: Step index ``n``.
        t: Time ``n dt``.
        coefficient: Fourier coefficient of ``exp(-i k x)`` in ``v/v0 - 1`` along the interface.
        energy: ``1/2 v m v + 1/2 w K w`` at step ``n`` (``v^n`` the mid-step average).
        energy_change: ``E^{n+1/2} - E^{-1/2}`` (the exactly balanced energy).
        work_friction: Work of the friction force ``-B dtau`` on the body, steps ``0..n``
            (``energy_change - work_friction`` is round-off).
        min_sigma: Smallest ``sigma/sigma0`` on the interface.
        min_v: Smallest ``v/v0``.
        max_dv: Largest ``|v/v0 - 1|``.
        newton_max: Most Newton iterations at any node in this step.
        top_force: ``bc = velocity``: perturbation of the total shear force the driver applies
            on the top (the reaction of the held ``w_x = 0``), over ``sigma0 L``; in a
            statistically steady state its mean equals the mean of ``(tau - tau0)/sigma0``.
            0 for ``bc = stress``.
    """

    step: int
    t: float
    coefficient: complex
    energy: float
    energy_change: float
    work_friction: float
    min_sigma: float
    min_v: float
    max_dv: float
    newton_max: int
    top_force: float = 0.0


@dataclass
class TimeDomainStrip:
    """Assembled stepper on a distributed strip (use :func:`build_time_domain`).

    Attributes:
        strip: The mesh.
        law: The nonlinear friction law (holds the linear :class:`Params`).
        k: Wavenumber whose Fourier component is measured (``k L / 2 pi`` a whole number).
        V: Vector P1/Q1 space.
        K: Reduced stiffness ``P^T K P``.
        mass: Local lumped mass of the owned reduced dofs.
        ix, iy: Local indices of the owned interface ``w_x``, ``w_y`` (same node order).
        x_interface: ``x`` of those nodes.
        b_interface: Lumped interface length ``B`` of those nodes.
        free: ``1.0`` for moving dofs, ``0.0`` for Dirichlet ones (local).
        dt: Time step.
        dt_stable: ``2 / sqrt(Gershgorin bound of m^{-1} K)``.
        top_x: Local indices of the top ``w_x`` (Dirichlet for ``bc = velocity``).
        periodic_map: The one 2D model's periodic map (``P``: full strip from reduced
            unknowns), for output.
        model: The one 2D model's operators (owns ``K`` and the map; with two bodies the
            block mass ``M_r``, its inverse and the slider's reactions).
        w, vh: Displacement ``w^n`` and velocity ``v^{n-1/2}`` (local, real).
        iface: Interface state.
        step: Current step ``n``.
        work_friction: Accumulated friction work (local part).
        energy0: ``E^{-1/2}`` of the initial condition.
    """

    strip: StripMesh
    law: NonlinearLaw
    k: float
    V: dolfinx.fem.FunctionSpace
    K: PETSc.Mat
    mass: np.ndarray
    ix: np.ndarray
    iy: np.ndarray
    x_interface: np.ndarray
    b_interface: np.ndarray
    free: np.ndarray
    dt: float
    dt_stable: float
    top_x: np.ndarray
    periodic_map: ReductionMap | None = None
    model: ExplicitStrip | None = None
    friction_theta: float = 0.5
    w: np.ndarray = field(default_factory=lambda: np.zeros(0))
    vh: np.ndarray = field(default_factory=lambda: np.zeros(0))
    iface: InterfaceState | None = None
    step: int = 0
    work_friction: float = 0.0
    energy0: float = 0.0
    _wvec: PETSc.Vec | None = None
    _rvec: PETSc.Vec | None = None
    _ld_pending: bool = False
    _newton_max: int = 0
    _slider_mass_y: np.ndarray | None = None
    _minv_x: np.ndarray | None = None
    _last: tuple | None = None

    # ------------------------------------------------------------------ set-up
    @property
    def comm(self) -> MPI.Comm:
        """Mesh communicator."""
        return self.strip.comm

    @property
    def num_dofs(self) -> int:
        """Global number of reduced unknowns."""
        return int(self.K.getSize()[0])

    @property
    def time(self) -> float:
        """Current time ``step * dt``."""
        return self.step * self.dt

    def destroy(self) -> None:
        """Free the PETSc objects."""
        owned = (self.model,) if self.model is not None else (self.K, self.periodic_map)
        for obj in (*owned, self._wvec, self._rvec):
            if obj is not None:
                obj.destroy()

    @property
    def two_body(self) -> bool:
        """Slider on a deformable substrate (block mass, the slider's reactions)."""
        return self.model is not None and self.model.mass_matrix is not None

    def _apply_k(self, x: np.ndarray, A: PETSc.Mat | None = None) -> np.ndarray:
        """``K_r x`` (or ``A x``) for a local array (real or complex)."""
        self._wvec.array[:] = x
        (self.K if A is None else A).mult(self._wvec, self._rvec)
        out = self._rvec.array.copy()
        return out if np.iscomplexobj(x) else out.real.copy()

    def _apply_m(self, x: np.ndarray) -> np.ndarray:
        """``M_r x``: the lumped mass (two bodies: with its ``(s, u_x2)`` blocks)."""
        return self._apply_k(x, self.model.mass_matrix) if self.two_body else self.mass * x

    def _apply_minv(self, x: np.ndarray) -> np.ndarray:
        """``M_r^{-1} x``."""
        return self._apply_k(x, self.model.inverse_mass) if self.two_body else x / self.mass

    def _normal_stress(self, w: np.ndarray, kw: np.ndarray, acc: np.ndarray) -> np.ndarray:
        """``dsigma`` at the interface nodes from the slider's normal reaction, over ``B``.

        Rigid substrate: ``(K w)_y`` (the constrained row carries no inertia). Two bodies:
        ``(K_1 w)_y + m_1 a_y`` with the slider's own stiffness and lumped mass (the
        eigen-model's ``reactions``); ``acc`` is the acceleration ``a`` (real or complex).
        """
        if not self.two_body:
            return kw[self.iy] / self.b_interface
        k1, m1 = self.model.reactions
        m1_y = self._slider_mass_y
        return (self._apply_k(w, k1)[self.iy] + m1_y * acc[self.iy]) / self.b_interface

    def _sum(self, value: float | complex) -> float | complex:
        return self.comm.allreduce(value, op=MPI.SUM)

    # ------------------------------------------------------------ linear mode
    def linear_mode(self, target: complex, nev: int = 8, prefix: str = "td_") -> Mode:
        """The eigenpair of the linearised lumped system nearest ``target`` carrying ``e^{-ikx}``.

        The operator is :func:`forms.friction.friction_operator` on ``(K_r, diag m, diag B)``
        with the Dirichlet rows of the stepper: the exact linearisation of this stepper in
        space (time continuous). Collective.

        Raises:
            ParameterError: If none of the ``nev`` nearest pairs carries ``exp(-i k x)`` (mesh
                too coarse for the branch).
        """
        p = self.law.params
        rstart = self.K.getOwnershipRange()[0]
        diag_m = self.model.mass_matrix if self.two_body else _diagonal_matrix(self.K, self.mass)
        bvals = np.zeros_like(self.mass)
        bvals[self.ix] = self.b_interface
        diag_b = _diagonal_matrix(self.K, bvals)
        op = friction_operator(FrictionLaw.from_params(p), self.K, diag_m, diag_b,
                               self.ix + rstart, self.iy + rstart,
                               reactions=self.model.reactions if self.two_body else None)
        fixed = np.flatnonzero(self.free == 0.0)
        fixed = np.setdiff1d(fixed, self.ix)
        apply_dirichlet(op.matrices, (fixed + rstart).astype(PETSc.IntType), op.constant_term)
        solver = PolynomialSolver(self.comm, nev=nev, prefix=prefix)
        try:
            res = solver.solve(op, target)
        finally:
            solver.destroy()
            op.destroy()
            if not self.two_body:
                diag_m.destroy()
            diag_b.destroy()
        best = None
        for pair in res.pairs:
            vec = pair.vector.array.copy()
            # Share of the interface slip carried by exp(-i k x) (others: 0, -k, 2k aliases).
            ux = vec[self.ix]
            wgt = self.b_interface
            c = self._sum(complex(np.sum(wgt * ux * np.exp(1j * self.k * self.x_interface))))
            n2 = self._sum(float(np.sum(wgt * np.abs(ux) ** 2)))
            share = abs(c) ** 2 / (self.strip.length * n2) if n2 > 0 else 0.0
            if share > 0.9:
                best = Mode(complex(pair.value), vec, float(pair.residual))
                break
        res.destroy()
        if best is None:
            raise ParameterError(f"mesh: none of the {nev} eigenpairs of the lumped system"
                                 f" nearest {target:.6g} carries exp(-i k x); refine the mesh"
                                 " (cells per wavelength, ny)")
        return best

    def cross_section_mode(self, target: complex, degree: int = 3) -> Mode:
        """The 1D cross-section model's mode ``u_hat(y) exp(-i k x)`` interpolated on the strip.

        Not an eigenvector of the stepper's discretisation: the other modes of wavenumber
        ``k`` are excited at the level of the mesh error (an independent initial condition).
        Collective (each rank solves the small 1D problem itself).
        """
        from forms.solvers.continuation import cross_section_mode

        if self.two_body:
            raise ParameterError("initial = 'cross-section' is outside its allowed values here"
                                 " (two bodies: lumped)")
        xs = cross_section_mode(self.law.params, self.k, target, degree=degree)
        if xs is None:
            raise ParameterError(f"branch: the cross-section model found no mode near {target}")
        u = dolfinx.fem.Function(self.V)
        u.interpolate(xs.field)
        u.x.scatter_forward()
        red, counts = self.K.createVecRight(), self.K.createVecRight()
        self.periodic_map.P.multTranspose(u.vector, red)
        ones = self.periodic_map.P.createVecLeft()
        ones.set(1.0)
        self.periodic_map.P.multTranspose(ones, counts)  # 2 on the left edge (its image added)
        vec = red.array / counts.array.real * self.free
        for v in (red, counts, ones):
            v.destroy()
        return Mode(complex(xs.eigenvalue), vec, float(xs.residual), exact=target)

    # ------------------------------------------------------- initial condition
    def set_initial_mode(self, mode: Mode, amplitude: float) -> None:
        """Steady sliding plus ``Re(U e^{Lambda t})``, scaled so ``max |v/v0 - 1| = amplitude``.

        The phase of ``U`` is fixed so that the ``exp(-i k x)`` coefficient of the interface
        slip rate is real and positive at ``t = 0``.

        Sets ``w^0``, ``v^{-1/2}`` (the mode half a step back), the interface state
        ``theta^0`` (and ``tau^0``, ``S^{-1}`` for Prakash-Clifton) from the linearised law.
        """
        law, lam = self.law, mode.eigenvalue
        u = mode.vector
        # Fix the eigenvector's arbitrary complex phase: the exp(-i k x) component of the
        # interface slip rate is real and positive at t = 0 (same start on any number of ranks).
        c0 = self._sum(complex(np.sum(self.b_interface * lam * u[self.ix]
                                      * np.exp(1j * self.k * self.x_interface))))
        if abs(c0) > 0:
            u = u * (abs(c0) / c0)
        peak = self.comm.allreduce(float(np.max(np.abs(lam * u[self.ix]), initial=0.0)),
                                   op=MPI.MAX)
        scale = amplitude * law.v0 / peak
        u = u * scale
        self.w = u.real * self.free
        self.vh = (lam * u * np.exp(-0.5 * lam * self.dt)).real * self.free
        ku = self._apply_k(u.astype(complex))
        dsig_hat = self._normal_stress(u.astype(complex), ku, lam**2 * u)
        dv_hat = lam * u[self.ix] / law.v0
        p = law.params
        alpha_ld_b = p.alpha_ld / law.b if p.alpha_ld > 0 else 0.0
        dth_hat = (-dv_hat - alpha_ld_b * lam * dsig_hat / law.sigma0) / (lam + 1.0)
        s_hat = law.sigma0 * (law.a * dv_hat + law.b * dth_hat) + law.f0 * dsig_hat
        dtau_hat = s_hat / (1.0 + p.alpha_pc * lam)
        if law.kind == "none":
            dtau_hat = 0 * s_hat
        s_prev = (s_hat * np.exp(-lam * self.dt)).real
        self.iface = InterfaceState(dth_hat.real.copy(), dtau_hat.real.copy(), s_prev,
                                    dsig_hat.real.copy(), dv_hat.real.copy())
        self._reset_counters()

    def set_initial_fields(self, w: np.ndarray, vh: np.ndarray) -> None:
        """Arbitrary initial ``w^0``, ``v^{-1/2}`` (local arrays); steady interface state."""
        self.w = np.asarray(w, float) * self.free
        self.vh = np.asarray(vh, float) * self.free
        n = len(self.ix)
        self.iface = InterfaceState(np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n),
                                    np.zeros(n))
        self._reset_counters()

    def _reset_counters(self) -> None:
        self.step = 0
        self.work_friction = 0.0
        self._ld_pending = False
        self._last = None
        wm1 = self.w - self.dt * self.vh  # E^{-1/2} with w^{-1} = w^0 - dt v^{-1/2}
        self.energy0 = self._sum(0.5 * float(np.dot(self._apply_m(self.vh), self.vh))
                                 + 0.5 * float(np.dot(self.w, self._apply_k(wm1))))

    # ------------------------------------------------------------------ step
    def _friction_solve(self, vfree: np.ndarray, c: np.ndarray, dsig: np.ndarray,
                        psi: np.ndarray, a0: np.ndarray, a1: float | np.ndarray,
                        guess: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Solve ``eps dv = vfree - c dtau(dv)`` per node; ``dtau = a0 + a1 (S(dv) - tau0)``.

        Returns ``(dv, dtau, S - tau0)``.
        """
        law = self.law
        eps = law.v0
        sigma = law.sigma0 + dsig
        cs = c / eps

        def dtau_of(dv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            s = sigma * law.f_minus_f0(dv, psi) + dsig * law.f0
            return a0 + a1 * s, s

        d_free = vfree / eps
        g_free = cs * dtau_of(d_free)[0]
        d_other = d_free - g_free
        lo = np.minimum(d_free, d_other)
        hi = np.maximum(d_free, d_other)
        if not law.regularised:
            lo = np.maximum(lo, -1.0 + 1e-300)
        d = np.clip(guess, lo, hi)
        iters = np.zeros(d.shape, dtype=int)
        active = np.ones(d.shape, dtype=bool)
        for it in range(100):
            dt_, _s = dtau_of(d)
            g = d - d_free + cs * dt_
            conv = np.abs(g) <= 1e-14 * (1.0 + np.abs(d_free)) + 1e-300
            conv |= (hi - lo) <= 4e-16 * (1.0 + np.abs(d))
            active &= ~conv
            if not active.any():
                break
            if it == 8 and law.regularised:
                # Near arrest (vh -> 0) f is steep in vh: finish these nodes in the variable
                # y = f (vh = sinh(y/a)/E), where the equation is smooth and convex.
                d = self._solve_in_f(d, active, lo, hi, d_free, cs, sigma, dsig, psi, a0, a1,
                                     iters)
                break
            iters += active
            lo = np.where(active & (g < 0), d, lo)
            hi = np.where(active & (g > 0), d, hi)
            gp = 1.0 + cs * a1 * sigma * law.dfdv(d, psi)
            d_new = d - g / gp
            bad = ~((d_new > lo) & (d_new < hi))
            d_new = np.where(bad, 0.5 * (lo + hi), d_new)
            d = np.where(active, d_new, d)
        self._newton_max = max(self._newton_max, int(iters.max(initial=0)))
        dtau, s = dtau_of(d)
        return d, dtau, s

    def _solve_in_f(self, d: np.ndarray, active: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                    d_free: np.ndarray, cs: np.ndarray, sigma: np.ndarray, dsig: np.ndarray,
                    psi: np.ndarray, a0: np.ndarray, a1: float | np.ndarray,
                    iters: np.ndarray) -> np.ndarray:
        """Safeguarded Newton on ``y = f`` for the ``active`` nodes (regularised law)."""
        law = self.law
        inv_e = law.inv_e(psi)
        idx = np.flatnonzero(active)
        a1v = np.broadcast_to(np.asarray(a1, float), d.shape)[idx]
        ie, sg, ds_, c_ = inv_e[idx], sigma[idx], dsig[idx], cs[idx]
        a0v, dfree = np.asarray(a0, float)[idx], d_free[idx]
        p_ = psi[idx]
        y_lo = law.f0 + law.f_minus_f0(lo[idx], p_)
        y_hi = law.f0 + law.f_minus_f0(hi[idx], p_)
        y = law.f0 + law.f_minus_f0(d[idx], p_)
        n_it = np.zeros(len(idx), dtype=int)
        for _ in range(100):
            vh = np.sinh(y / law.a) * ie
            g = (vh - 1.0) - dfree + c_ * (a0v + a1v * (sg * (y - law.f0) + ds_ * law.f0))
            gp = np.cosh(y / law.a) * ie / law.a + c_ * a1v * sg
            conv = (np.abs(g) <= 1e-13 * (1.0 + np.abs(dfree))) | ((y_hi - y_lo) <= 1e-15)
            if conv.all():
                break
            n_it += ~conv
            y_lo = np.where(~conv & (g < 0), y, y_lo)
            y_hi = np.where(~conv & (g > 0), y, y_hi)
            y_new = y - g / gp
            bad = ~((y_new > y_lo) & (y_new < y_hi))
            y = np.where(conv, y, np.where(bad, 0.5 * (y_lo + y_hi), y_new))
        iters[idx] += n_it + 8
        out = d.copy()
        out[idx] = np.sinh(y / law.a) * ie - 1.0
        return out

    def advance(self) -> None:
        """One central-difference step ``n -> n + 1`` (collective: one mat-vec)."""
        law, st, dt = self.law, self.iface, self.dt
        p = law.params
        kw = self._apply_k(self.w)
        r = -kw
        acc = self._apply_minv(r) * self.free  # acceleration without the friction force
        dsig = self._normal_stress(self.w, kw, acc)
        if self._ld_pending:  # state over [n-1, n]: LD half jump, aging at v^{n-1/2}, half jump
            dv_half = self.vh[self.ix] / law.v0
            half = None
            if p.alpha_ld > 0:
                dlog = np.log1p((dsig - st.dsigma) / (law.sigma0 + st.dsigma))
                half = np.expm1(-0.5 * (p.alpha_ld / law.b) * dlog)
                st.dtheta = st.dtheta * (1.0 + half) + half
            st.dtheta = aging_step(st.dtheta, dv_half, dt)
            if half is not None:
                st.dtheta = st.dtheta * (1.0 + half) + half
        st.dsigma = dsig
        vh_x = self.vh[self.ix]
        th = self.friction_theta
        c = th * dt * self.b_interface * self._minv_x  # (M_r^{-1})_ss: 1/m, or 1/m1 + 1/m2
        vfree = vh_x + th * dt * acc[self.ix]
        psi = np.log1p(st.dtheta)
        if law.kind == "none":
            dv = vfree / law.v0
            dtau = np.zeros_like(dv)
        elif p.alpha_pc > 0:
            if self.step == 0:
                dtau = st.dtau
                dv = (vfree - c * dtau) / law.v0
                s = law.sigma0 * law.f_minus_f0(dv, psi) + dsig * law.f0
            else:
                kappa_dt = np.abs(1.0 + vh_x / law.v0) * dt / p.alpha_pc
                e = np.exp(-kappa_dt)
                ph = _phi1(kappa_dt)
                a0 = e * st.dtau + (ph - e) * st.s_prev
                dv, dtau, s = self._friction_solve(vfree, c, dsig, psi, a0, 1.0 - ph, st.dv)
            st.s_prev = s
        else:
            dv, dtau, _ = self._friction_solve(vfree, c, dsig, psi, np.zeros_like(vfree), 1.0,
                                               st.dv)
        force = np.zeros_like(self.w)
        force[self.ix] = -self.b_interface * dtau
        # The momentum update uses the force; its mid-step average v^n equals the solved slip
        # rate up to the solver's residual: the work uses v^n (exact energy identity), the
        # state and the diagnostics the solved slip rate (consistent with the friction law;
        # near arrest vh ~ 1e-12 is below that residual and its sign is the law's).
        if self.two_body:
            vh_new = (self.vh + dt * (acc + self._apply_minv(force))) * self.free
        else:
            vh_new = (self.vh + dt * (r + force) / self.mass) * self.free
        v_n = 0.5 * (vh_x + vh_new[self.ix])
        st.dv, st.dtau = dv, dtau
        self.work_friction += dt * float(np.dot(force[self.ix], v_n))
        self._last = (kw, self.vh.copy(), vh_new)
        self.vh = vh_new
        self.w = self.w + dt * vh_new
        self.step += 1
        self._ld_pending = True

    # ------------------------------------------------------------- diagnostics
    def sample(self) -> Sample:
        """Diagnostics of the last completed step ``n`` (call right after :meth:`advance`)."""
        if self._last is None:
            raise RuntimeError("sample() needs a step: call advance() first")
        kw, vh_old, vh_new = self._last
        st, law = self.iface, self.law
        n = self.step - 1
        w_n = self.w - self.dt * vh_new
        v_n = 0.5 * (vh_old + vh_new)
        c_loc = complex(np.sum(self.b_interface * st.dv * np.exp(1j * self.k * self.x_interface)))
        loc = np.array([
            0.5 * np.dot(self._apply_m(v_n), v_n) + 0.5 * np.dot(w_n, kw),
            0.5 * np.dot(self._apply_m(vh_new), vh_new) + 0.5 * np.dot(self.w, kw),
            self.work_friction, c_loc.real, c_loc.imag, float(np.sum(kw[self.top_x])),
        ])
        tot = np.zeros(6)
        self.comm.Allreduce(loc, tot, op=MPI.SUM)  # one reduction for the sums, one for extremes
        coef = complex(tot[3], tot[4]) * 2.0 / self.strip.length
        big = np.inf
        ext = np.array([np.min(st.dsigma / law.sigma0, initial=big),
                        np.min(st.dv, initial=big),
                        -np.max(np.abs(st.dv), initial=0.0), -float(self._newton_max)])
        glob = np.zeros(4)
        self.comm.Allreduce(ext, glob, op=MPI.MIN)
        self._newton_max = 0
        # E^{n+1/2} - E^{-1/2} = work up to n: report the staggered energy at n + 1/2.
        return Sample(n, n * self.dt, coef, float(tot[0]), float(tot[1]) - self.energy0,
                      float(tot[2]), 1.0 + float(glob[0]), 1.0 + float(glob[1]),
                      -float(glob[2]), -int(glob[3]),
                      float(tot[5]) / (self.law.sigma0 * self.strip.length))

    def interface_fields(self) -> dict[str, np.ndarray] | None:
        """Interface fields of the last step on rank 0 (``None`` elsewhere), sorted by ``x``.

        Keys: ``x``, ``v`` (``v/v0``), ``tau`` (``(tau - tau0)/sigma0``), ``sigma``
        (``(sigma - sigma0)/sigma0``), ``theta`` (``v0 phi / D``).
        """
        st, law = self.iface, self.law
        rows = np.column_stack([self.x_interface, 1.0 + st.dv, st.dtau / law.sigma0,
                                st.dsigma / law.sigma0, 1.0 + st.dtheta])
        allrows = self.comm.gather(rows, root=0)
        if self.comm.rank != 0:
            return None
        a = np.vstack(allrows)
        a = a[np.argsort(a[:, 0])]
        return {"x": a[:, 0], "v": a[:, 1], "tau": a[:, 2], "sigma": a[:, 3], "theta": a[:, 4]}

    def displacement(self, name: str = "w") -> dolfinx.fem.Function:
        """The perturbation displacement ``w^{n}`` on the full strip (``P w_r``), collective."""
        u = dolfinx.fem.Function(self.V, name=name)
        self._wvec.array[:] = self.w
        self.periodic_map.P.mult(self._wvec, u.vector)
        u.x.scatter_forward()
        return u

    # -------------------------------------------------------------- checkpoint
    def state_arrays(self) -> dict[str, np.ndarray]:
        """Local state for a checkpoint (restore with :meth:`load_state` on the same layout)."""
        st = self.iface
        return {"w": self.w, "vh": self.vh, "dtheta": st.dtheta, "dtau": st.dtau,
                "s_prev": st.s_prev, "dsigma": st.dsigma, "dv": st.dv,
                "scalars": np.array([self.step, self.work_friction, self.energy0,
                                     float(self._ld_pending), self.dt])}

    def load_state(self, arrays: dict[str, np.ndarray]) -> None:
        """Restore :meth:`state_arrays` (same mesh, ranks and time step)."""
        sc = arrays["scalars"]
        if abs(float(sc[4]) - self.dt) > 1e-14 * self.dt or arrays["w"].shape != self.mass.shape:
            raise ValueError("checkpoint does not match this mesh/time step/rank layout")
        self.w = np.array(arrays["w"], float)
        self.vh = np.array(arrays["vh"], float)
        self.iface = InterfaceState(*(np.array(arrays[k], float) for k in
                                      ("dtheta", "dtau", "s_prev", "dsigma", "dv")))
        self.step = int(sc[0])
        self.work_friction = float(sc[1])
        self.energy0 = float(sc[2])
        self._ld_pending = bool(sc[3])
        kw = self._apply_k(self.w)
        self._last = (kw, self.vh, self.vh)


def _diagonal_matrix(like: PETSc.Mat, values: np.ndarray) -> PETSc.Mat:
    """A matrix with the layout and nonzero pattern of ``like`` holding ``diag(values)``."""
    d = like.duplicate(copy=False)
    v = like.createVecRight()
    v.array[:] = values
    d.setDiagonal(v)
    d.assemble()
    v.destroy()
    return d


def _local_diagonal(A: PETSc.Mat) -> np.ndarray:
    """The owned rows' diagonal of ``A`` (real part)."""
    d = A.getDiagonal()
    out = d.array.real.copy()
    d.destroy()
    return out


def _gershgorin(comm: MPI.Comm, row_bound: np.ndarray, free: np.ndarray) -> float:
    """Upper bound of the spectrum of ``M_r^{-1} K`` on the free dofs (Gershgorin, rows)."""
    return comm.allreduce(float(np.max(row_bound * free, initial=0.0)), op=MPI.MAX)


def build_time_domain(strip: StripMesh, law: NonlinearLaw, k: float, cfl: float = 0.9,
                      dt: float | None = None, friction_theta: float = 0.5) -> TimeDomainStrip:
    """Assemble the stepper on ``strip`` (collective).

    Args:
        strip: Periodic strip (length a whole number of ``2 pi / k``).
        law: Friction law and parameters (``law.params.bc`` chooses the top condition).
        k: Wavenumber of the measured Fourier component.
        cfl: Fraction of the stable step ``2 / sqrt(Gershgorin(m^{-1} K))``, ``0 < cfl <= 1``.
        dt: Explicit time step (overrides ``cfl``; must not exceed the stable step).
        friction_theta: The friction force of step ``n`` is taken at the slip rate
            ``(1 - theta) v^{n-1/2} + theta v^{n+1/2}``: 1/2 (default) is second order and
            leaves stuck nodes an undamped ``2 dt`` alternation; ``theta > 1/2`` damps it
            (factor ``(1 - theta)/theta`` per step) at first order ``(theta - 1/2) dt``.

    Returns:
        The :class:`TimeDomainStrip` (destroy it when done).
    """
    if not (math.isfinite(k) and k > 0):
        raise ParameterError(f"k = {k!r} is outside its allowed range k > 0 (finite)")
    m = strip.length * k / (2.0 * math.pi)
    if abs(m - round(m)) > 1e-9 * max(1.0, m) or round(m) < 1:
        raise ParameterError(f"length = {strip.length!r} is not a whole number of wavelengths"
                             f" 2 pi/k = {2 * math.pi / k:.6g}")
    if not (math.isfinite(friction_theta) and 0.5 <= friction_theta <= 1):
        raise ParameterError(f"friction-theta = {friction_theta!r} is outside its allowed range"
                             " 1/2 <= theta <= 1")
    if not (math.isfinite(cfl) and 0 < cfl <= 1):
        raise ParameterError(f"cfl = {cfl!r} is outside its allowed range 0 < cfl <= 1")
    p = law.params
    model = explicit_strip(strip, p)  # the one 2D model: space, operators, rows
    Kr, mass = model.stiffness, model.mass
    rstart = Kr.getOwnershipRange()[0]
    ix, iy, top_x = ((rows - rstart).astype(np.int64) for rows in
                     (model.interface_x, model.interface_y, model.top_x))
    free = np.ones_like(mass)
    free[model.dirichlet - rstart] = 0.0
    bound = _gershgorin(strip.comm, model.row_bound, free)
    dt_stable = 2.0 / math.sqrt(bound)
    if dt is None:
        dt = cfl * dt_stable
    elif not (math.isfinite(dt) and 0 < dt <= dt_stable):
        model.destroy()
        raise ParameterError(f"dt = {dt!r} is outside its allowed range 0 < dt <= {dt_stable:.6g}"
                             " (stable step of this mesh)")
    td = TimeDomainStrip(strip, law, float(k), model.V, Kr, mass, ix, iy,
                         model.interface_coordinate, model.interface_length[ix].copy(), free,
                         float(dt), dt_stable, top_x, model.map, model)
    td.friction_theta = float(friction_theta)
    td._minv_x = 1.0 / mass[ix]
    if td.two_body:
        td._minv_x = _local_diagonal(model.inverse_mass)[ix]
        td._slider_mass_y = _local_diagonal(model.reactions[1])[iy]
    td._wvec, td._rvec = Kr.createVecs()
    n = len(mass)
    td.set_initial_fields(np.zeros(n), np.zeros(n))
    return td
