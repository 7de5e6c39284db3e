"""SLEPc eigen-solvers for ``T(Lambda) u = 0`` built by :mod:`forms.friction`.

- :class:`PolynomialSolver`: SLEPc PEP (TOAR, shift-and-invert, MUMPS LU) on the polynomial
  form ``sum_j L^j A_j``.
- :class:`SplitSolver`: SLEPc NEP on the split rational form ``sum_i phi_i(L) E_i`` (NLEIGS by
  default; ``-nep_type ciss`` with a region for "all eigenvalues in a box").
- :func:`dense_companion_eig`: the dense baseline (LAPACK on the companion pencil, serial).

Both take their defaults from setters and call ``setFromOptions()`` last, so the PETSc options
database (command line) wins: with the default empty prefix ``-pep_type``, ``-st_type``,
``-st_pc_factor_mat_solver_type``, ``-nep_type`` ... apply; pass ``prefix`` to give an object
its own. Every returned eigenvalue carries its relative residual
``||T(L) u|| / (sum_i |phi_i(L)| ||E_i||_F ||u||)`` (backward error), spurious roots of the
cleared denominators (:attr:`forms.friction.FrictionLaw.spurious`) are dropped, and the
Dirichlet rows have no finite eigenvalues (see :func:`forms.friction.apply_dirichlet`).

Entry points must call ``slepc4py.init(sys.argv)`` before this module is imported for
command-line options to reach SLEPc.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

from mpi4py import MPI
from petsc4py import PETSc
from slepc4py import SLEPc

from forms.friction import FrictionOperator, ScalarFunction

#: Relative distance by which :func:`shift_off` moves a shift away from a value that may be an
#: eigenvalue (an exact root, or an eigenvalue of the same mesh from an earlier solve). A shift
#: *at* an eigenvalue makes the shift-and-invert factorisation (nearly) singular; measured on the
#: cross-section model (P3, nev = 2, exact roots as targets, 2026-11-22): backward errors
#: 4.5e-8 / 6.4e-10 with no offset, 5.8e-12 / 3.9e-12 at 1e-7, 6e-14 at 1e-5 and 1e-16 .. 4e-16
#: at 1e-3 (the gallery's earlier measurement also saw DIVERGED_BREAKDOWN with no offset). At
#: 1e-3 the shift still lies nearest the same eigenvalue unless another one is closer than
#: ``1e-3 |Lambda|``.
SHIFT_OFFSET = 1e-3


def shift_off(target: complex, offset: float = SHIFT_OFFSET) -> complex:
    """``target`` moved by ``offset * max(|target|, 1)`` along ``(1 + i)/sqrt(2)``.

    The one rule for a shift-and-invert shift that may coincide with an eigenvalue (see
    :data:`SHIFT_OFFSET`). Pairs are still sorted by distance to the value the caller wants.
    """
    return complex(target) + offset * max(abs(target), 1.0) * complex(1.0, 1.0) / np.sqrt(2.0)


@dataclass
class Eigenpair:
    """One eigenpair: ``value`` (Lambda), relative ``residual`` and the PETSc ``vector``."""

    value: complex
    residual: float
    vector: PETSc.Vec


@dataclass
class SolveResult:
    """Outcome of one solve.

    Attributes:
        pairs: Converged, non-spurious eigenpairs sorted by distance to the target. The vectors
            are owned by the caller (call :meth:`destroy`).
        converged: Number of converged pairs SLEPc reported (before filtering).
        reason: SLEPc's converged reason as text (``"CONVERGED_TOL"``, ``"DIVERGED_ITS"`` ...).
        iterations: Outer iterations.
        dropped: Eigenvalues dropped as spurious.
    """

    pairs: list[Eigenpair]
    converged: int
    reason: str
    iterations: int
    dropped: list[complex] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """True if SLEPc converged (positive reason)."""
        return self.reason.startswith("CONVERGED")

    def destroy(self) -> None:
        """Destroy the eigenvectors."""
        for p in self.pairs:
            p.vector.destroy()
        self.pairs = []


def _reason_name(cls: type, value: int) -> str:
    for name in dir(cls):
        if not name.startswith("_") and getattr(cls, name) == value:
            return name
    return str(value)


def relative_residual(op: FrictionOperator, lam: complex, vec: PETSc.Vec,
                      norms: np.ndarray | None = None) -> float:
    """``||T(lam) u|| / (sum_i |phi_i(lam)| ||E_i||_F ||u||)`` (2-norm of vectors)."""
    if norms is None:
        norms = np.array([a.norm(PETSc.NormType.FROBENIUS) for a in op.matrices])
    phi = op.scalars(lam)
    r = vec.duplicate()
    tmp = vec.duplicate()
    r.set(0.0)
    for c, a in zip(phi, op.matrices, strict=True):
        if c != 0:
            a.mult(vec, tmp)
            r.axpy(c, tmp)
    num = r.norm()
    den = float(np.sum(np.abs(phi) * norms)) * vec.norm()
    r.destroy()
    tmp.destroy()
    return float(num / den) if den > 0 else float("inf")


def sinvert_pep(comm: MPI.Comm, nev: int, tol: float, max_it: int, prefix: str,
                scale: bool = False) -> SLEPc.PEP:
    """A PEP (TOAR) for the ``nev`` eigenpairs nearest a target: shift-and-invert, MUMPS LU.

    Defaults by setters, then the options prefix and ``setFromOptions()`` last, so the command
    line wins (empty prefix: ``-pep_*``, ``-st_*`` apply). ``scale``: SLEPc's scalar scaling
    of ``Lambda`` (``-pep_scale scalar``), for targets far from the unit circle.
    """
    pep = SLEPc.PEP().create(comm)
    pep.setType(SLEPc.PEP.Type.TOAR)
    pep.setProblemType(SLEPc.PEP.ProblemType.GENERAL)
    pep.setDimensions(nev=nev)
    pep.setTolerances(tol=tol, max_it=max_it)
    if scale:
        pep.setScale(SLEPc.PEP.Scale.SCALAR)
    pep.setWhichEigenpairs(SLEPc.PEP.Which.TARGET_MAGNITUDE)
    st = pep.getST()
    st.setType(SLEPc.ST.Type.SINVERT)
    st.setMatStructure(PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
    ksp = st.getKSP()
    ksp.setType(PETSc.KSP.Type.PREONLY)
    ksp.getPC().setType(PETSc.PC.Type.LU)
    ksp.getPC().setFactorSolverType("mumps")
    if prefix:
        pep.setOptionsPrefix(prefix)
    pep.setFromOptions()
    return pep


class PolynomialSolver:
    """SLEPc PEP: TOAR + shift-and-invert around a target, LU by MUMPS.

    Args:
        comm: Communicator of the matrices.
        nev: Number of eigenpairs nearest the target.
        tol: Relative convergence tolerance of SLEPc.
        max_it: Maximum number of restarts.
        prefix: Options prefix (empty: ``-pep_*``, ``-st_*`` apply).
        scale: Scalar scaling of ``Lambda`` (:func:`sinvert_pep`).
    """

    def __init__(self, comm: MPI.Comm, nev: int = 4, tol: float = 1e-13, max_it: int = 200,
                 prefix: str = "", scale: bool = False) -> None:
        self.comm = comm
        self.pep = sinvert_pep(comm, nev, tol, max_it, prefix, scale)

    def settings(self) -> dict[str, object]:
        """Solver settings actually in use (for summaries)."""
        pep = self.pep
        st = pep.getST()
        tol, max_it = pep.getTolerances()
        return {
            "eigensolver": "SLEPc PEP",
            "type": pep.getType(),
            "st": st.getType(),
            "pc": st.getKSP().getPC().getType(),
            "factor_solver": st.getKSP().getPC().getFactorSolverType(),
            "nev": pep.getDimensions()[0],
            "tol": tol,
            "max_it": max_it,
            "options_prefix": pep.getOptionsPrefix() or "",
        }

    def solve(self, op: FrictionOperator, target: complex, nev: int | None = None
              ) -> SolveResult:
        """Eigenpairs of the polynomial operator nearest ``target``.

        Args:
            op: A ``"polynomial"`` :class:`~forms.friction.FrictionOperator`.
            target: Shift (complex Lambda).
            nev: Override the number of wanted pairs.
        """
        if op.form != "polynomial":
            raise ValueError("PolynomialSolver needs the polynomial form")
        pep = self.pep
        shape = (len(op.matrices), op.matrices[0].getSize())
        if getattr(self, "_shape", shape) != shape:
            # SLEPc 3.18 keeps work arrays sized for the previous polynomial degree/size:
            # reusing them for another degree segfaults, so start afresh.
            pep.reset()
        self._shape = shape
        pep.setOperators(op.matrices)
        if nev is not None:
            pep.setDimensions(nev=nev)
        pep.setTarget(target)
        pep.solve()
        return _collect(pep, SLEPc.PEP.ConvergedReason, op, target)

    def destroy(self) -> None:
        """Destroy the SLEPc object."""
        self.pep.destroy()


def _make_fn(comm: MPI.Comm, fn: ScalarFunction) -> SLEPc.FN:
    """SLEPc FN for a scalar function of :class:`~forms.friction.FrictionOperator`."""
    f = SLEPc.FN().create(comm)
    f.setType(SLEPc.FN.Type.RATIONAL)
    f.setRationalNumerator(list(reversed(fn.num)))  # SLEPc wants descending coefficients
    if fn.power_index is None:
        f.setRationalDenominator(list(reversed(fn.den)))
    return f


class SplitSolver:
    """SLEPc NEP on the split rational form: NLEIGS in a disc around the target.

    The functions are SLEPc rational FNs and the problem type is ``RATIONAL``, so NLEIGS
    builds the rational operator exactly (no spurious roots at ``Lambda = -1``). The region is a
    disc of radius ``radius`` around each target; ``-nep_type ciss`` with the same region gives
    all eigenvalues in it (contour integral).

    Args:
        comm: Communicator of the matrices.
        nev: Number of eigenpairs wanted.
        tol: Relative tolerance.
        max_it: Maximum iterations.
        radius: Radius of the disc region around the target.
        prefix: Options prefix (empty: ``-nep_*`` apply).
    """

    def __init__(self, comm: MPI.Comm, nev: int = 4, tol: float = 1e-12, max_it: int = 30,
                 radius: float = 2.0, prefix: str = "") -> None:
        self.comm = comm
        self.radius = radius
        nep = SLEPc.NEP().create(comm)
        nep.setType(SLEPc.NEP.Type.NLEIGS)
        nep.setProblemType(SLEPc.NEP.ProblemType.RATIONAL)
        nep.setDimensions(nev=nev)
        nep.setTolerances(tol=tol, maxit=max_it)
        nep.setWhichEigenpairs(SLEPc.NEP.Which.TARGET_MAGNITUDE)
        if prefix:
            nep.setOptionsPrefix(prefix)
        self.nep = nep
        self._configured = False
        self._fns: list[SLEPc.FN] = []

    def settings(self) -> dict[str, object]:
        """Solver settings actually in use (for summaries)."""
        tol, max_it = self.nep.getTolerances()
        return {
            "eigensolver": "SLEPc NEP (split form)",
            "type": self.nep.getType(),
            "nev": self.nep.getDimensions()[0],
            "tol": tol,
            "max_it": max_it,
            "region": f"disc of radius {self.radius} around each target",
            "options_prefix": self.nep.getOptionsPrefix() or "",
        }

    def solve(self, op: FrictionOperator, target: complex, nev: int | None = None
              ) -> SolveResult:
        """Eigenpairs of the split operator nearest ``target`` inside the disc."""
        if op.form != "split":
            raise ValueError("SplitSolver needs the split form")
        nep = self.nep
        shape = (len(op.matrices), op.matrices[0].getSize())
        if getattr(self, "_shape", shape) != shape:
            nep.reset()  # see PolynomialSolver.solve
            for f in self._fns:
                f.destroy()
            self._fns = []
        self._shape = shape
        if not self._fns:
            self._fns = [_make_fn(self.comm, fn) for fn in op.functions]
        nep.setSplitOperator(op.matrices, self._fns, PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
        if nev is not None:
            nep.setDimensions(nev=nev)
        nep.setTarget(target)
        rg = nep.getRG()
        rg.setType(SLEPc.RG.Type.ELLIPSE)
        rg.setEllipseParameters(target, self.radius, 1.0)
        if not self._configured:
            if nep.getType() == SLEPc.NEP.Type.NLEIGS:
                for ksp in nep.getNLEIGSKSPs():
                    ksp.setType(PETSc.KSP.Type.PREONLY)
                    ksp.getPC().setType(PETSc.PC.Type.LU)
                    ksp.getPC().setFactorSolverType("mumps")
            nep.setFromOptions()
            if nep.getType() == SLEPc.NEP.Type.CISS:
                # contour integral: every eigenvalue inside the region
                nep.setWhichEigenpairs(SLEPc.NEP.Which.ALL)
            self._configured = True
        nep.solve()
        return _collect(nep, SLEPc.NEP.ConvergedReason, op, target)

    def destroy(self) -> None:
        """Destroy the SLEPc objects."""
        for f in self._fns:
            f.destroy()
        self.nep.destroy()


def _collect(eps, reasons: type, op: FrictionOperator, target: complex) -> SolveResult:  # noqa: ANN001
    """Converged pairs of a solved SLEPc PEP or NEP ``eps``.

    Spurious roots are dropped, residuals attached, pairs sorted by distance to ``target``.
    """
    nconv = eps.getConverged()
    reason = _reason_name(reasons, eps.getConvergedReason())
    norms = np.array([a.norm(PETSc.NormType.FROBENIUS) for a in op.matrices])
    pairs: list[Eigenpair] = []
    dropped: list[complex] = []
    for i in range(nconv):
        v = op.matrices[0].createVecRight()
        lam = complex(eps.getEigenpair(i, v))
        if op.law.is_spurious(lam):
            dropped.append(lam)
            v.destroy()
            continue
        pairs.append(Eigenpair(lam, relative_residual(op, lam, v, norms), v))
    pairs.sort(key=lambda p: abs(p.value - target))
    return SolveResult(pairs, nconv, reason, eps.getIterationNumber(), dropped)


def dense_companion_eig(op: FrictionOperator, target: complex) -> complex:
    """Nearest-to-target eigenvalue of ``sum_j L^j A_j`` by a dense companion linearisation.

    ``A_j`` are the PETSc matrices of a polynomial :class:`forms.friction.FrictionOperator`
    (serial). First companion form: ``L B z = A z`` with ``z = (x, L x, ..., L^(d-1) x)``,
    ``A = [[0, I, ...], ..., [-A_0, -A_1, ..., -A_(d-1)]]``, ``B = diag(I, ..., I, A_d)``,
    solved by LAPACK (``scipy.linalg.eig``): the dense baseline of the work-precision study.

    Args:
        op: Polynomial operator on ``MPI.COMM_SELF``.
        target: Where the wanted eigenvalue is.

    Returns:
        The finite eigenvalue nearest ``target`` (the spurious root ``L = -1`` of the cleared
        denominator excluded).
    """
    w = dense_companion_eigenvalues(op)
    w = w[np.abs(w + 1.0) > 1e-8]  # the spurious root of the cleared denominator (L = -1)
    return complex(w[np.argmin(np.abs(w - target))])


def dense_companion_eigenvalues(op: FrictionOperator) -> np.ndarray:
    """Every finite eigenvalue of ``sum_j L^j A_j`` by the companion form.

    The linearisation of :func:`dense_companion_eig`; the spurious root ``L = -1`` included.
    """
    mats = []
    for a in op.matrices:
        d = a.copy().convert("dense")
        mats.append(np.array(d.getDenseArray(), dtype=complex))
        d.destroy()
    deg = len(mats) - 1
    n = mats[0].shape[0]
    big_a = np.zeros((deg * n, deg * n), dtype=complex)
    big_b = np.eye(deg * n, dtype=complex)
    for i in range(deg - 1):
        big_a[i * n:(i + 1) * n, (i + 1) * n:(i + 2) * n] = np.eye(n)
    for j in range(deg):
        big_a[(deg - 1) * n:, j * n:(j + 1) * n] = -mats[j]
    big_b[(deg - 1) * n:, (deg - 1) * n:] = mats[deg]
    w = scipy.linalg.eig(big_a, big_b, right=False, overwrite_a=True, overwrite_b=True,
                         check_finite=False)
    return w[np.isfinite(w)]


#: Public names of :func:`_collect` and :func:`_make_fn` for studies that build their own
#: SLEPc objects (:mod:`forms.studies.methods`: PEP CISS, NEP NLEIGS on a region).
collect_pairs = _collect
rational_fn = _make_fn
