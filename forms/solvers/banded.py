"""A one-process FE operator ``T(z)`` as a banded matrix: determinant, root count, Newton.

The cross-section model is one-dimensional: after a reverse Cuthill-McKee ordering its matrices
are banded with a half-bandwidth of a few times the degree. That makes three things cheap that
a Krylov eigensolver cannot give (docs/design.md section 8):

- ``log det T(z)`` by one banded LU (LAPACK ``zgbtrf``) per point, so the *number* of discrete
  eigenvalues inside a rectangle follows from the argument principle
  (:func:`analytic.numerics.roots.winding_number` with ``log=True``): the FE side of the
  completeness
  certificate, independent of any exact reference;
- Newton's method on the discrete nonlinear eigenproblem (nonlinear inverse iteration, one
  factorisation per step, quadratic convergence for a simple eigenvalue): continuation of an
  eigenpair from a predictor costs a few factorisations;
- the same Newton step on a second discretisation, started from the first one's eigenvalue:
  a forward-error estimate for every eigenvalue.

Works for any :class:`forms.friction.FrictionOperator` on ``MPI.COMM_SELF`` (polynomial or split
form; the scalar functions come from the operator). The polynomial form's spurious roots
(``Lambda = -1``, ``-1/alpha_pc``) and the Dirichlet rows' eigenvalues at infinity are part of
``det T``: keep rectangles away from the former.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.linalg import lapack
from scipy.sparse.csgraph import reverse_cuthill_mckee

from analytic.numerics.roots import Box, ContourError, winding_number
from forms.friction import FrictionOperator, ScalarFunction


@dataclass
class Eigen:
    """A discrete eigenpair from :meth:`BandedOperator.newton`.

    Attributes:
        value: Eigenvalue ``Lambda``.
        vector: Eigenvector (the operator's original dof order), ``max |x_i| = 1``.
        residual: ``||T x|| / (sum_i |phi_i| ||A_i||_F ||x||)``.
        iterations: Newton steps taken.
        converged: Last step below the tolerance and residual below ``1e-10``, or residual
            below ``1e-13`` (rounding level).
        step: Size of the last Newton correction (a forward-error estimate of ``value``).
    """

    value: complex
    vector: np.ndarray
    residual: float
    iterations: int
    converged: bool
    step: float


class BandedOperator:
    """``T(z) = sum_i phi_i(z) A_i`` of a sequential operator, in LAPACK band storage.

    Args:
        op: The operator (its PETSc matrices must be sequential, e.g. on ``MPI.COMM_SELF``).
            The matrices are copied; ``op`` may be destroyed afterwards.
    """

    def __init__(self, op: FrictionOperator | None = None, *,
                 mats: list[sp.csr_matrix] | None = None,
                 functions: list[ScalarFunction] | None = None,
                 perm: np.ndarray | None = None) -> None:
        if op is not None:
            mats = [_csr(a) for a in op.matrices]
            functions = list(op.functions)
        if mats is None or functions is None:
            raise ValueError("give a FrictionOperator, or mats and functions")
        self.functions = list(functions)
        self.n = n = mats[0].shape[0]
        if perm is not None:
            self._setup(mats, np.asarray(perm, dtype=np.int64))
            return
        pattern = sp.csr_matrix((n, n))
        for m in mats:
            c = m.tocoo()
            pattern = pattern + sp.csr_matrix((np.ones(c.nnz), (c.row, c.col)), shape=(n, n))
        pattern = (pattern + pattern.T).tocsr()
        self._setup(mats, np.asarray(reverse_cuthill_mckee(pattern, symmetric_mode=True),
                                     dtype=np.int64))

    def _setup(self, mats: list[sp.csr_matrix], perm: np.ndarray) -> None:
        n = self.n
        self.perm = perm
        self.mats = [m[self.perm][:, self.perm].tocsr() for m in mats]
        # stored entries of every matrix (explicit zeros included: they are pattern too)
        offsets = np.concatenate([m.tocoo().row - m.tocoo().col for m in self.mats])
        self.kl = int(max(np.max(offsets), 0))
        self.ku = int(max(-np.min(offsets), 0))
        kl, ku = self.kl, self.ku
        # zgbtrf storage: A[i, j] at ab[kl + ku + i - j, j] (the top kl rows are LU workspace)
        self.bands = []
        for m in self.mats:
            c = m.tocoo()
            ab = np.zeros((2 * kl + ku + 1, n), dtype=complex)
            ab[kl + ku + c.row - c.col, c.col] = c.data
            self.bands.append(ab)
        self.norms = np.array([sp.linalg.norm(m) for m in self.mats])
        self.factorizations = 0  #: banded LU factorisations so far (cost measure)

    def _band(self, z: complex) -> np.ndarray:
        ab = np.zeros_like(self.bands[0])
        for fn, b in zip(self.functions, self.bands, strict=True):
            ab += fn.value_and_derivative(z)[0] * b
        return ab

    def _factor(self, z: complex) -> tuple[np.ndarray, np.ndarray, int]:
        self.factorizations += 1
        lu, piv, info = lapack.zgbtrf(self._band(z), self.kl, self.ku)
        return lu, piv, int(info)

    def log_det(self, z: complex) -> complex:
        """``log det T(z)`` (real part ``log|det|``; imaginary part some branch of ``arg``)."""
        lu, piv, info = self._factor(complex(z))
        diag = lu[self.kl + self.ku]
        if info > 0 or not np.all(np.isfinite(diag)):
            return complex(-np.inf)
        swaps = int(np.count_nonzero(piv != np.arange(self.n)))
        return complex(np.sum(np.log(diag.astype(complex))) + 1j * math.pi * (swaps % 2))

    def log_det_many(self, z: np.ndarray) -> np.ndarray:
        """Vectorised :meth:`log_det` (for :func:`analytic.numerics.roots.winding_number`)."""
        return np.array([self.log_det(v) for v in np.ravel(z)], dtype=complex).reshape(np.shape(z))

    def count(self, box: Box, n_initial: int = 32) -> int:
        """Number of eigenvalues of ``T`` inside ``box`` (argument principle on ``det T``).

        Raises:
            ContourError: An eigenvalue on or too near the contour (move the box edge).
        """
        return winding_number(self.log_det_many, box, n_initial=n_initial, log=True)

    def _apply(self, coeffs: np.ndarray, x: np.ndarray) -> np.ndarray:
        y = np.zeros(self.n, dtype=complex)
        for c, m in zip(coeffs, self.mats, strict=True):
            if c != 0:
                y += c * (m @ x)
        return y

    def residual(self, z: complex, x: np.ndarray) -> float:
        """Relative residual of ``(z, x)`` (``x`` in the operator's original order)."""
        xp = np.asarray(x, dtype=complex)[self.perm]
        phi = np.array([fn.value_and_derivative(z)[0] for fn in self.functions])
        den = float(np.sum(np.abs(phi) * self.norms)) * np.linalg.norm(xp)
        return float(np.linalg.norm(self._apply(phi, xp)) / den) if den > 0 else math.inf

    def newton(self, z0: complex, x0: np.ndarray | None = None, *, tol: float = 1e-14,
               maxit: int = 12) -> Eigen:
        """Eigenpair near ``z0`` by nonlinear inverse iteration (Newton on ``T(z) x = 0``).

        ``u = T(z)^{-1} T'(z) x``, ``z <- z - (v^H x)/(v^H u)``, ``x <- u/(v^H u)`` with a fixed
        normalisation vector ``v``: one banded factorisation per step, quadratic convergence to
        the simple eigenvalue nearest ``z0`` (Ruhe 1973). Without ``x0`` a fixed pseudo-random
        start vector is used, so results do not depend on the run.

        Args:
            z0: Predictor of the eigenvalue.
            x0: Predictor of the eigenvector (original dof order), e.g. the previous k's.
            tol: Relative step tolerance.
            maxit: Maximum number of steps.
        """
        z = complex(z0)
        if x0 is None:
            rng = np.random.default_rng(12345)
            x = rng.standard_normal(self.n) + 1j * rng.standard_normal(self.n)
        else:
            x = np.asarray(x0, dtype=complex)[self.perm].copy()
        v = x / np.vdot(x, x)
        x = x / np.vdot(v, x)
        step, it, converged = math.inf, 0, False
        for it in range(1, maxit + 1):  # noqa: B007 - it is reported
            lu, piv, info = self._factor(z)
            if info > 0:  # exactly singular: z is an eigenvalue to rounding
                step = 0.0
                break
            dphi = np.array([fn.value_and_derivative(z)[1] for fn in self.functions])
            rhs = self._apply(dphi, x)
            u, info2 = lapack.zgbtrs(lu, self.kl, self.ku, rhs, piv)
            den = np.vdot(v, u)
            if info2 != 0 or den == 0 or not np.isfinite(den):
                break
            dz = -np.vdot(v, x) / den
            z, x = z + dz, u / den
            step = abs(dz)
            if step <= tol * max(abs(z), 1.0):
                converged = True
                break
        out = np.empty(self.n, dtype=complex)
        out[self.perm] = x
        out /= out[np.argmax(np.abs(out))]
        res = self.residual(z, out)
        # Near convergence the step stalls at the rounding level of z (~1e-13 relative), so a
        # backward error at rounding level also counts as converged.
        converged = (converged and res < 1e-10) or res < 1e-13
        return Eigen(z, out, res, it, converged, step)


def _csr(a: object) -> sp.csr_matrix:
    """A sequential PETSc matrix as a complex scipy CSR matrix (a copy)."""
    indptr, indices, data = a.getValuesCSR()
    n = a.getSize()[0]
    return sp.csr_matrix((data, indices, indptr), shape=(n, n), dtype=complex)


class BandedModel:
    """Banded operators ``T(z; k)`` of a model with k-blocks, without PETSc work per ``k``.

    ``T(z; k) = T0(z) + k T1(z) + k^2 T2(z)`` (:meth:`forms.models.cross_section.CrossSectionModel.
    k_blocks`): the three parts are copied once; :meth:`operator` combines them in scipy.

    Args:
        model: A model with ``k_blocks()`` on ``MPI.COMM_SELF``.
    """

    def __init__(self, model: object) -> None:
        parts = model.k_blocks()
        self.functions = list(parts[0].functions)
        self.parts = [[_csr(a) for a in part.matrices] for part in parts]
        first = BandedOperator(mats=self.parts[0], functions=self.functions)
        self.perm = first.perm

    def operator(self, k: float) -> BandedOperator:
        """The banded ``T(z; k)``."""
        k = float(k)
        mats = [a + k * b + (k * k) * c for a, b, c in zip(*self.parts, strict=True)]
        return BandedOperator(mats=mats, functions=self.functions, perm=self.perm)


def count_or_none(bop: BandedOperator, box: Box) -> tuple[int | None, str]:
    """:meth:`BandedOperator.count`, or ``(None, reason)`` if the contour cannot be used."""
    try:
        return bop.count(box), ""
    except ContourError as err:
        return None, str(err)
