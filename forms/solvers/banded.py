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

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.linalg import lapack
from scipy.sparse._sparsetools import csr_matvec
from scipy.sparse.csgraph import reverse_cuthill_mckee

from analytic.numerics.roots import Box, _perimeter_point, winding_numbers
from forms.friction import FrictionOperator, ScalarFunction

#: Points whose band matrices are assembled in one matrix product (memory: rows x n x CHUNK).
CHUNK = 32
#: :meth:`BandedOperator.newton` without a start vector: a first step below this (relative)
#: ends the iteration. The start vector is one inverse iteration at ``z0``, so the first step is
#: a Newton step from an eigenvector accurate to ``|z0 - Lambda| / gap``: its error is
#: ``O(s_1^2)``. (The P(p+1) estimate starts at the P(p) value; where the two agree to the
#: rounding level the steps stall there instead of falling below ``tol``.)
START_STEP = 1e-10


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
        self.n = mats[0].shape[0]
        if perm is not None:
            self._setup(mats, np.asarray(perm, dtype=np.int64))
            return
        self._setup(mats, band_order(mats))

    def _setup(self, mats: list[sp.csr_matrix], perm: np.ndarray) -> None:
        n = self.n
        self.perm = perm
        mats = [m[perm][:, perm].tocsr() for m in mats]
        coo = [m.tocoo() for m in mats]
        # stored entries of every matrix (explicit zeros included: they are pattern too)
        offsets = np.concatenate([c.row - c.col for c in coo])
        kl, ku = int(max(np.max(offsets), 0)), int(max(-np.min(offsets), 0))
        rows = 2 * kl + ku + 1
        stack = np.zeros((len(mats), n * rows), dtype=complex)
        for f, c in enumerate(coo):
            stack[f, c.col * rows + kl + ku + c.row - c.col] = c.data
        self._init_bands(stack, kl, ku, np.array([sp.linalg.norm(m) for m in mats]))
        self._mats = mats

    def _init_bands(self, stack: np.ndarray, kl: int, ku: int, norms: np.ndarray,
                    pattern: tuple[np.ndarray, ...] | None = None) -> None:
        """Band storage of every matrix, one row of ``stack`` each (see :attr:`_stack`).

        ``pattern``: ``(f, pos, filled)`` or ``(f, pos, filled, structure)``: the entries of
        ``stack`` that may be nonzero, the distinct ``pos`` and :func:`stacked_structure` of
        them (default: those that are, the structure when first needed), e.g. one pattern for
        every ``k`` (:class:`BandedModel`).
        """
        self.kl, self.ku = kl, ku
        self.rows = 2 * kl + ku + 1
        # zgbtrf storage: A[i, j] at ab[kl + ku + i - j, j] (the top kl rows are LU workspace);
        # row f of _stack holds matrix f's ab in Fortran order (column j at j * rows), so a
        # combination phi @ _stack reshaped is the Fortran-ordered band zgbtrf works on in place
        self._stack = stack
        # the positions any A_i fills (a P6 section's band is about 40 % entries, the rest LU
        # workspace and zeros) and every A_i's values there: a combination writes only these
        if pattern is None:
            f, pos = np.nonzero(stack)
            pattern = (f, pos, np.unique(pos))
        self._nonzero, self._filled = pattern[:2], pattern[2]
        self._structure = pattern[3] if len(pattern) > 3 else None  # of :meth:`_stacked`
        self._filled_values = np.ascontiguousarray(stack[:, self._filled])
        self._products: tuple | None = None  # :meth:`_stacked`, built when first used
        self.norms = norms
        self.power = np.array([fn.power_index if fn.power_index is not None else -1
                               for fn in self.functions])
        self.polynomial = bool(np.all(self.power >= 0))
        self._powers = [int(q) for q in self.power]
        self.factorizations = 0  #: banded LU factorisations so far (cost measure)

    @classmethod
    def from_bands(cls, functions: list[ScalarFunction], perm: np.ndarray, stack: np.ndarray,
                   kl: int, ku: int, mats: Callable[[], list[sp.csr_matrix]],
                   pattern: tuple[np.ndarray, ...] | None = None,
                   norms: np.ndarray | None = None) -> BandedOperator:
        """An operator from its band storage (:class:`BandedModel`): no sparse work.

        Args:
            functions: The scalar functions ``phi_i``.
            perm: The band (reverse Cuthill-McKee) order of the dofs.
            stack: Band storage of every ``A_i`` (layout of :attr:`_stack`).
            kl: Lower half-bandwidth.
            ku: Upper half-bandwidth.
            mats: Builds the permuted CSR matrices ``A_i`` when :attr:`mats` is first read.
            pattern: As :meth:`_init_bands`'s.
            norms: The Frobenius norms of the ``A_i`` (default: from ``stack``).
        """
        self = cls.__new__(cls)
        self.functions, self.perm = list(functions), perm
        self.n = perm.size
        self._mats, self._make_mats = None, mats
        # the Frobenius norm of A_i is that of its band entries (each stored once)
        self._init_bands(stack, kl, ku, np.linalg.norm(stack, axis=1) if norms is None else norms,
                         pattern)
        return self

    @property
    def mats(self) -> list[sp.csr_matrix]:
        """The matrices ``A_i`` in band order, CSR."""
        if self._mats is None:
            self._mats = self._make_mats()
        return self._mats

    def _phi_and_derivative(self, z: complex) -> tuple[np.ndarray, np.ndarray]:
        """``phi_i(z)`` and ``phi_i'(z)`` of every scalar function."""
        if self.polynomial:
            # Python's complex powers: the same bits as numpy's ``z ** power`` and
            # ``power * z ** (power - 1)`` (tests/test_banded.py), a fifth of the time (the
            # vectorised form cost 33 us a call for 4-5 powers, twice per Newton step)
            z = complex(z)
            return (np.array([z ** q for q in self._powers]),
                    np.array([q * z ** (q - 1) if q > 0 else 0j for q in self._powers]))
        pairs = [fn.value_and_derivative(z) for fn in self.functions]
        return np.array([a for a, _ in pairs], complex), np.array([b for _, b in pairs], complex)

    def _combine(self, coeffs: np.ndarray) -> np.ndarray:
        """Band storage (Fortran order) of ``sum_i coeffs[i] A_i``.

        Only the filled positions are combined (:attr:`_filled`; the same sums as over the
        whole band, whose other entries are zero in every ``A_i``): 41 -> 22 us at 434 rows.
        """
        out = np.zeros(self.n * self.rows, dtype=complex)
        out[self._filled] = np.asarray(coeffs, dtype=complex) @ self._filled_values
        return out.reshape(self.n, self.rows).T

    def _stacked(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``[A_0; A_1; ...]`` (band order) on the pattern: CSR ``(indptr, indices, data)``."""
        if self._products is None:
            if self._structure is None:
                self._structure = stacked_structure(self._nonzero, self.n, self.rows,
                                                    self.kl + self.ku, len(self.functions))
            order, indices, indptr = self._structure
            f, pos = self._nonzero
            self._products = (indptr, indices, np.ascontiguousarray(self._stack[f, pos][order]))
        return self._products

    def _band(self, z: complex) -> np.ndarray:
        return self._combine(self._phi_and_derivative(z)[0])

    def _phis(self, z: np.ndarray) -> np.ndarray:
        """``phi_i(z_j)`` for every point (rows) and scalar function (columns), vectorised."""
        z = np.asarray(z, dtype=complex)
        pv = np.polynomial.polynomial
        cols = [z ** fn.power_index if fn.power_index is not None else
                pv.polyval(z, np.asarray(fn.num, dtype=complex))
                / pv.polyval(z, np.asarray(fn.den, dtype=complex)) for fn in self.functions]
        return np.stack(cols, axis=1)

    def _bands_many(self, z: np.ndarray) -> np.ndarray:
        """Band storage of ``T(z_j)`` for every point at once, shape ``(len(z), rows, n)``.

        Each ``[j]`` is Fortran-ordered (``zgbtrf`` overwrites it in place).
        """
        return (self._phis(z) @ self._stack).reshape(len(z), self.n, self.rows).transpose(
            0, 2, 1)

    def _factor(self, z: complex) -> tuple[np.ndarray, np.ndarray, int]:
        self.factorizations += 1
        lu, piv, info = lapack.zgbtrf(self._band(z), self.kl, self.ku, overwrite_ab=True)
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
        """Vectorised :meth:`log_det` (for :func:`analytic.numerics.roots.winding_number`).

        The band matrices of :data:`CHUNK` points are assembled in one matrix product; one
        ``zgbtrf`` per point remains.
        """
        flat = np.ravel(np.asarray(z, dtype=complex))
        out = np.empty(flat.size, dtype=complex)
        d = self.kl + self.ku
        idx = np.arange(self.n)
        for lo in range(0, flat.size, CHUNK):
            for j, ab in enumerate(self._bands_many(flat[lo:lo + CHUNK])):
                self.factorizations += 1
                lu, piv, info = lapack.zgbtrf(ab, self.kl, self.ku, overwrite_ab=True)
                diag = lu[d]
                if info > 0 or not np.all(np.isfinite(diag)):
                    out[lo + j] = -np.inf
                    continue
                swaps = int(np.count_nonzero(piv != idx))
                out[lo + j] = np.sum(np.log(diag)) + 1j * math.pi * (swaps % 2)
        return out.reshape(np.shape(z))

    def count(self, box: Box, n_initial: int = 32) -> int:
        """Number of eigenvalues of ``T`` inside ``box`` (argument principle on ``det T``).

        Raises:
            ContourError: An eigenvalue on or too near the contour (move the box edge).
        """
        return self.count_and_samples(box, n_initial)[0]

    def count_and_samples(self, box: Box, n_initial: int = 32) -> tuple[int, np.ndarray]:
        """:meth:`count` and the contour parameters ``t`` of the points it used.

        The points are those of :func:`analytic.numerics.roots.winding_numbers` (adaptive
        refinement where the argument of ``det T`` turns fast or ``|det T|`` changes fast,
        i.e. a spacing below the distance to the nearest eigenvalue, then a verification pass
        that bisects every interval).

        Raises:
            ContourError: An eigenvalue on or too near the contour (move the box edge).
        """
        def one_row(z: np.ndarray) -> np.ndarray:
            return self.log_det_many(z)[None, :]

        counts, t = winding_numbers(one_row, box, 1, n_initial=n_initial, log=True,
                                    samples=True)
        return counts[0], t

    def moment_eigs(self, box: Box, count: int, t: np.ndarray, *, moments: int = 2,
                    extra: int | None = None, seed: int = 2024,
                    sums: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray] | None = None
                    ) -> list[Eigen]:
        """The eigenvalues inside ``box`` by contour-integral moments, each Newton-polished.

        Beyn's method with higher moments (Beyn 2012, section 5): with a random ``n x L`` block
        ``V``, ``A_p = (1/2 pi i) oint s^p T(z)^{-1} V dz``, ``s = (z - c)/rho`` (box centre
        ``c``, half-size ``rho``), ``p < 2K``, by :func:`contour_rule` on the count's contour
        points ``t`` (one ``zgbtrf`` and one ``zgbtrs`` with ``L`` columns per point); the
        block Hankel matrices ``B0 = [A_{i+j}]``, ``B1 = [A_{i+j+1}]`` (``i, j < K``), the SVD
        ``B0 = U S W^H`` truncated to ``count + extra``, and the eigenvalues of ``U^H B1 W S^-1``
        give predictors (with eigenvectors) of every eigenvalue inside the box and of the
        strongest ones outside. Each predictor inside the box (widened by 10 %) starts
        :meth:`newton`. Nothing here is counted: the argument-principle count stays an
        independent check of what is returned.

        Args:
            box: The rectangle.
            count: Number of eigenvalues inside (sets the block size).
            t: Contour parameters of the quadrature nodes (from :meth:`count_and_samples`).
            moments: Number ``K`` of block rows (``L = ceil((count + extra) / K)`` columns).
            extra: Subspace dimension beyond ``count`` (default ``max(4, count // 2)``).
            seed: Seed of the random block ``V``.
            sums: ``sums(z, weights, V)`` returning ``sum_p weights[p, q] T(z_p)^{-1} V`` for
                every ``q`` (banded order), e.g. :meth:`forms.solvers.condensed.
                CondensedOperator.moment_sums`; default: one banded LU per point.

        Returns:
            The distinct converged eigenpairs strictly inside ``box``.
        """
        if count <= 0:
            return []
        if not all(fn.power_index is not None for fn in self.functions):
            raise NotImplementedError("moment_eigs needs the polynomial form (power functions)")
        bx = tuple(float(v) for v in box)
        z, w = contour_rule(bx, t)
        c = complex(0.5 * (bx[0] + bx[1]), 0.5 * (bx[2] + bx[3]))
        rho = 0.5 * max(bx[1] - bx[0], bx[3] - bx[2])
        s = (z - c) / rho
        dim = count + (extra if extra is not None else max(4, count // 2))
        k_mom = max(1, min(moments, dim))
        cols = int(math.ceil(dim / k_mom))
        rng = np.random.default_rng(seed)
        v = rng.standard_normal((self.n, cols)) + 1j * rng.standard_normal((self.n, cols))
        weights = w[:, None] * s[:, None] ** np.arange(2 * k_mom)[None, :]  # (points, 2K)
        acc = (sums or self._moment_sums)(z, weights, v)
        # block Hankel matrices B0[i, j] = A_{i+j}, B1[i, j] = A_{i+j+1} (Beyn 2012, sec. 5)
        b0 = np.block([[acc[i + j] for j in range(k_mom)] for i in range(k_mom)])
        b1 = np.block([[acc[i + j + 1] for j in range(k_mom)] for i in range(k_mom)])
        u, sv, vh = np.linalg.svd(b0, full_matrices=False)
        rank = int(min(dim, np.count_nonzero(sv > 1e-13 * sv[0]))) if sv[0] > 0 else 0
        if rank == 0:
            return []
        u, sv, vh = u[:, :rank], sv[:rank], vh[:rank]
        small = u.conj().T @ b1 @ vh.conj().T / sv[None, :]
        mu, y = np.linalg.eig(small)
        lam = c + rho * mu
        vecs = (u[:self.n] @ y)  # eigenvector approximations (permuted order)
        return self.polish(lam, vecs, bx)

    def _moment_sums(self, z: np.ndarray, weights: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``sum_p weights[p, q] T(z_p)^{-1} v`` by one ``zgbtrf`` and ``zgbtrs`` per point."""
        acc = np.zeros((weights.shape[1], self.n, v.shape[1]), dtype=complex)
        for lo in range(0, z.size, CHUNK):
            for j, ab in enumerate(self._bands_many(z[lo:lo + CHUNK])):
                self.factorizations += 1
                lu, piv, info = lapack.zgbtrf(ab, self.kl, self.ku, overwrite_ab=True)
                if info != 0:
                    continue  # exactly singular on the contour: the count fails there anyway
                y, _ = lapack.zgbtrs(lu, self.kl, self.ku, v, piv)
                acc += weights[lo + j][:, None, None] * y[None]
        return acc

    def polish(self, lam: np.ndarray, vecs: np.ndarray, bx: Box, *, exact_start: bool = False,
               maxit: int = 12) -> list[Eigen]:
        """Newton from each approximation inside ``bx`` (widened 10 %); distinct, inside.

        Args:
            lam: Predicted eigenvalues.
            vecs: Their vectors (banded order, one column each).
            bx: The box.
            exact_start: Each vector is ``T``'s near-null vector at its predictor (as
                :meth:`forms.solvers.condensed.CondensedOperator.linear_eigs` gives): the first
                step's rule of :meth:`newton` without a start vector applies.
            maxit: Newton steps per predictor (:meth:`newton`).
        """
        a0, b0, c0, d0 = bx
        near = predicted_near(lam, bx)
        found: list[Eigen] = []
        for i in np.argsort(lam.real):
            z0 = lam[i]
            if not near[i]:
                continue
            x0 = np.empty(self.n, dtype=complex)
            x0[self.perm] = vecs[:, i]
            finite = bool(np.all(np.isfinite(x0)))
            e = self.newton(z0, x0 if finite else None, exact_start=exact_start, maxit=maxit)
            if exact_start and finite and not e.converged:
                # the predicted vector is poor where T_II(z) is nearly singular (a mode that
                # hardly moves the interface, Re Lambda ~ 0): start by inverse iteration
                e = self.newton(z0)
            inside = a0 < e.value.real < b0 and c0 < e.value.imag < d0
            if e.converged and inside and is_new(e.value, found):
                found.append(e)
        return found

    def _apply(self, coeffs: np.ndarray, x: np.ndarray) -> np.ndarray:
        """``sum_i coeffs[i] A_i x`` (band order): every ``A_i x`` by one sparse product.

        Of the stacked nonzero entries (:meth:`_stacked`; the interface matrices have a few):
        14 us at 434 rows, against 51 us for combining the band and one ``zgbmv``.
        """
        indptr, indices, data = self._stacked()
        rows = indptr.size - 1
        y = np.zeros(rows, dtype=complex)
        # scipy's kernel without its dispatch (30 of the 44 us a product took at 434 rows)
        csr_matvec(rows, self.n, indptr, indices, data, np.ascontiguousarray(x, dtype=complex), y)
        return np.asarray(coeffs, dtype=complex) @ y.reshape(-1, self.n)

    def rayleigh_step(self, z: np.ndarray, x: np.ndarray, y: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray]:
        """One two-sided Rayleigh step from each ``(z_j, x_j, y_j)`` and its residual.

        ``z_j - y_j^H T(z_j) x_j / y_j^H T'(z_j) x_j`` (``x_j``, ``y_j`` right and left
        near-null vectors, band order, columns): its error is the product of the two vectors'
        errors, so from vectors accurate to rounding the value is ``T``'s to rounding. Every
        ``A_i x_j`` by one sparse product (:meth:`_stacked`), reused for ``T'(z_j) x_j`` and
        for the residual (:meth:`residual`'s) of ``x_j`` at the new value.

        Returns:
            ``(values, residuals)``.
        """
        z = np.asarray(z, dtype=complex)
        if not z.size:
            return z.copy(), np.zeros(0)
        indptr, indices, data = self._stacked()
        ax = sp.csr_matrix((data, indices, indptr), shape=(indptr.size - 1, self.n)) @ x
        ax = ax.reshape(len(self.functions), self.n, z.size)  # (f, n, points)
        phi, dphi = (np.array(c) for c in zip(*(self._phi_and_derivative(v) for v in z),
                                                strict=True))  # (points, f) each
        den = np.einsum("np,fnp,pf->p", y.conj(), ax, dphi)
        num = np.einsum("np,fnp,pf->p", y.conj(), ax, phi)
        with np.errstate(all="ignore"):
            step = num / den
        new = np.where(np.isfinite(step), z - step, z)
        phi_new = np.array([self._phi_and_derivative(v)[0] for v in new])
        tx = np.einsum("fnp,pf->np", ax, phi_new)
        scale = (np.abs(phi_new) @ self.norms) * np.linalg.norm(x, axis=0)
        with np.errstate(all="ignore"):
            res = np.where(scale > 0, np.linalg.norm(tx, axis=0) / scale, np.inf)
        return new, res

    def residual(self, z: complex, x: np.ndarray) -> float:
        """Relative residual of ``(z, x)`` (``x`` in the operator's original order)."""
        return self._residual(z, np.asarray(x, dtype=complex)[self.perm])

    def _residual(self, z: complex, xp: np.ndarray) -> float:
        """:meth:`residual` of ``xp`` in band order."""
        phi = self._phi_and_derivative(z)[0]
        den = float(np.sum(np.abs(phi) * self.norms)) * np.linalg.norm(xp)
        return float(np.linalg.norm(self._apply(phi, xp)) / den) if den > 0 else math.inf

    def newton(self, z0: complex, x0: np.ndarray | None = None, *, tol: float = 1e-14,
               maxit: int = 12, exact_start: bool = False) -> Eigen:
        """Eigenpair near ``z0`` by nonlinear inverse iteration (Newton on ``T(z) x = 0``).

        ``u = T(z)^{-1} T'(z) x``, ``z <- z - (v^H x)/(v^H u)``, ``x <- u/(v^H u)`` with a fixed
        normalisation vector ``v``: one banded factorisation per step, quadratic convergence to
        the simple eigenvalue nearest ``z0`` (Ruhe 1973). Without ``x0`` the start vector is one
        inverse iteration ``T(z0)^{-1} T'(z0) r`` of a fixed pseudo-random ``r`` (results do not
        depend on the run), with the factorisation of the first step.

        Stops when the step ``s_j`` is below ``tol``, or when the error of the new value
        predicted by quadratic convergence from the last two steps, ``s_j^3 / s_{j-1}^2``, is
        (relative to ``max(|z|, 1)``), or, started by inverse iteration, when the first step is
        below :data:`START_STEP` (its error is then of order ``s_1^2``): near convergence the
        steps stall at the rounding level of ``z`` (``1e-14`` to ``1e-12`` relative) and the
        first rule alone would run to ``maxit``.

        Args:
            z0: Predictor of the eigenvalue.
            x0: Predictor of the eigenvector (original dof order), e.g. the previous k's.
            tol: Relative step tolerance.
            maxit: Maximum number of steps.
            exact_start: ``x0`` is ``T(z0)``'s near-null vector (accurate to the order of
                ``|z0 - Lambda|``), so the first step's rule applies as without ``x0``.
        """
        z = complex(z0)
        lu = None
        if x0 is None:
            x = _start_vector(self.n)
            lu = self._factor(z)
            if lu[2] == 0:
                x = lapack.zgbtrs(lu[0], self.kl, self.ku,
                                  self._apply(self._phi_and_derivative(z)[1], x), lu[1])[0]
        else:
            x = np.asarray(x0, dtype=complex)[self.perm].copy()
        v = x / np.vdot(x, x)
        x = x / np.vdot(v, x)
        step, prev, it, converged = math.inf, math.inf, 0, False
        for it in range(1, maxit + 1):  # noqa: B007 - it is reported
            lu_, piv, info = lu if lu is not None else self._factor(z)
            lu = None
            if info > 0:  # exactly singular: z is an eigenvalue to rounding
                step = 0.0
                break
            rhs = self._apply(self._phi_and_derivative(z)[1], x)
            u, info2 = lapack.zgbtrs(lu_, self.kl, self.ku, rhs, piv)
            den = np.vdot(v, u)
            if info2 != 0 or den == 0 or not np.isfinite(den):
                break
            dz = -np.vdot(v, x) / den
            z, x = z + dz, u / den
            prev, step = step, abs(dz)
            scale = tol * max(abs(z), 1.0)
            if step <= scale or (it > 1 and step ** 3 <= scale * prev ** 2) or (
                    it == 1 and (x0 is None or exact_start)
                    and step <= START_STEP * max(abs(z), 1.0)):
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


def band_order(mats: list[sp.csr_matrix]) -> np.ndarray:
    """The reverse Cuthill-McKee order of the union of the matrices' patterns (symmetrised)."""
    n = mats[0].shape[0]
    pattern = sp.csr_matrix((n, n))
    for m in mats:
        c = m.tocoo()
        pattern = pattern + sp.csr_matrix((np.ones(c.nnz), (c.row, c.col)), shape=(n, n))
    pattern = (pattern + pattern.T).tocsr()
    return np.asarray(reverse_cuthill_mckee(pattern, symmetric_mode=True), dtype=np.int64)


def stacked_structure(nonzero: tuple[np.ndarray, np.ndarray], n: int, rows: int, diag: int,
                      functions: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """CSR structure of ``[A_0; A_1; ...]`` from band entries ``(f, pos)``.

    Band storage has ``A_f[i, j]`` at ``pos = j rows + diag + i - j``. Returns ``(order,
    indices, indptr)``: the entries in CSR order are ``stack[f, pos][order]``.
    """
    f, pos = nonzero
    col = pos // rows
    row = f * n + pos % rows - diag + col
    order = np.lexsort((col, row))
    indptr = np.concatenate([[0], np.cumsum(np.bincount(row, minlength=functions * n))])
    return order, col[order].astype(np.int32), indptr.astype(np.int32)


@functools.lru_cache(maxsize=16)
def _fixed_start(n: int) -> np.ndarray:
    """The fixed pseudo-random start of :meth:`BandedOperator.newton` (read-only)."""
    rng = np.random.default_rng(12345)
    x = rng.standard_normal(n) + 1j * rng.standard_normal(n)
    x.flags.writeable = False
    return x


def _start_vector(n: int) -> np.ndarray:
    """A copy of :func:`_fixed_start` (a generator per call cost 50 us)."""
    return _fixed_start(n).copy()


def is_new(value: complex, found: list[Eigen]) -> bool:
    """``value`` farther than ``1e-9`` (relative) from every eigenvalue of ``found``."""
    return all(abs(value - f.value) > 1e-9 * max(1.0, abs(value)) for f in found)


def predicted_near(lam: np.ndarray, bx: Box) -> np.ndarray:
    """Which predictors :meth:`BandedOperator.polish` starts from (a mask over ``lam``).

    Finite, and inside ``bx`` widened by 10 % of its size on every side.
    """
    a, b, c, d = bx
    mw, mh = 0.1 * (b - a), 0.1 * (d - c)
    return (np.isfinite(lam) & (lam.real >= a - mw) & (lam.real <= b + mw)
            & (lam.imag >= c - mh) & (lam.imag <= d + mh))


def contour_rule(box: Box, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights of ``oint f(z) dz`` on the boundary of ``box`` from the points ``t``.

    ``t`` are contour parameters (:func:`analytic.numerics.roots.winding_numbers` with
    ``samples=True``). Its points of odd index are the midpoints of their neighbours (the
    verification pass bisects every interval) and the corners ``t = 1, 2, 3`` have even index:
    then composite Simpson on the panels ``(t_{2i}, t_{2i+1}, t_{2i+2})`` (error ``O(h^4)``),
    otherwise the trapezoidal rule on the polygon through the points and the corners.
    """
    t = np.union1d(np.asarray(t, dtype=float), np.arange(4.0))
    z = _perimeter_point(box, t)
    t4 = np.append(t, 4.0)
    even = t4[0::2]
    if t.size % 2 == 0 and np.allclose(t4[1::2], 0.5 * (even[:-1] + even[1:]), rtol=0,
                                       atol=1e-13) and np.all(np.isin(np.arange(4.0), t[::2])):
        zz = np.append(z, z[0])
        d = zz[2::2] - zz[0:-2:2]
        w = np.zeros(z.size, dtype=complex)
        w[1::2] = 4.0 * d / 6.0
        w[0::2] += d / 6.0
        w[2::2] += d[:-1] / 6.0
        w[0] += d[-1] / 6.0
        return z, w
    return z, 0.5 * (np.roll(z, -1) - np.roll(z, 1))


def _csr(a: object) -> sp.csr_matrix:
    """A sequential PETSc matrix as a complex scipy CSR matrix (a copy)."""
    indptr, indices, data = a.getValuesCSR()
    n = a.getSize()[0]
    return sp.csr_matrix((data, indices, indptr), shape=(n, n), dtype=complex)


class BandedModel:
    """Banded operators ``T(z; k)`` of a model with k-blocks, without PETSc work per ``k``.

    ``T(z; k) = T0(z) + k T1(z) + k^2 T2(z)`` (:meth:`forms.models.cross_section.CrossSectionModel.
    k_blocks`): the three parts are copied once, put in the band order of ``T0``'s pattern and
    in LAPACK band storage; :meth:`operator` combines the three band stores (no sparse work
    per ``k``; the same numbers as adding the parts in scipy, ``a + k b + (k k) c``).

    Args:
        model: A model with ``k_blocks()`` on ``MPI.COMM_SELF``.
    """

    def __init__(self, model: object) -> None:
        parts = model.k_blocks()
        self.functions = list(parts[0].functions)
        self.parts = [[_csr(a) for a in part.matrices] for part in parts]
        self.perm = perm = band_order(self.parts[0])
        n = self.n = perm.size
        iperm = np.empty(n, dtype=np.int64)
        iperm[perm] = np.arange(n)
        # per function: the union of the parts' stored entries (band order, row-major sorted,
        # i.e. canonical CSR order) and each part's values on it
        self._pattern: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        lins = []
        for f in range(len(self.functions)):
            # each part's stored entries (explicit zeros too) at their band-order positions
            coo = [part[f].tocoo() for part in self.parts]
            at_lin = [iperm[c.row] * n + iperm[c.col] for c in coo]
            lin = np.unique(np.concatenate(at_lin))
            vals = np.zeros((len(coo), lin.size), dtype=complex)
            for j, c in enumerate(coo):
                # np.add.at's sums (each part of a complex sum on its own) by bincount: 38 -> 3
                # ms over a sweep's 14 models
                at = np.searchsorted(lin, at_lin[j])
                vals[j] = (np.bincount(at, c.data.real, lin.size)
                           + 1j * np.bincount(at, c.data.imag, lin.size))
            self._pattern.append((lin, vals, _indptr(lin // n, n)))
            lins.append(lin)
        rows, cols = np.concatenate(lins) // n, np.concatenate(lins) % n
        self.kl = int(max(np.max(rows - cols), 0))
        self.ku = int(max(np.max(cols - rows), 0))
        nrow = 2 * self.kl + self.ku + 1
        self._bands = np.zeros((len(self.parts), len(self.functions), n * nrow), dtype=complex)
        for f, (lin, vals, _) in enumerate(self._pattern):
            r, c = lin // n, lin % n
            self._bands[:, f, c * nrow + self.kl + self.ku + r - c] = vals
        # the pattern of every k, and the three parts' values on it (operator: no work on the
        # band's zeros)
        f, pos = np.nonzero(np.any(self._bands != 0, axis=0))
        self._band_pattern = (f, pos, np.unique(pos), stacked_structure(
            (f, pos), n, nrow, self.kl + self.ku, len(self.functions)))
        self._band_values = np.ascontiguousarray(self._bands[:, f, pos])

    def part_matrices(self) -> list[list[sp.csr_matrix]]:
        """``[T0, T1, T2]``, each the list of its matrices ``A_i`` in band order (CSR)."""
        return [[sp.csr_matrix((vals[j], (lin % self.n).astype(np.int32), indptr),
                               shape=(self.n, self.n)) for lin, vals, indptr in self._pattern]
                for j in range(len(self.parts))]

    def operator(self, k: float) -> BandedOperator:
        """The banded ``T(z; k)``."""
        k = float(k)
        b = self._band_values
        vals = b[0] + k * b[1] + (k * k) * b[2]  # the same sums as on the whole band
        f, pos = self._band_pattern[:2]
        stack = np.zeros(self._bands.shape[1:], dtype=complex)
        stack[f, pos] = vals
        # the Frobenius norm of A_i is that of its band entries (each stored once; f sorted)
        ends = np.searchsorted(f, np.arange(stack.shape[0] + 1))
        norms = np.array([np.linalg.norm(vals[ends[i]:ends[i + 1]])
                          for i in range(stack.shape[0])])

        def mats() -> list[sp.csr_matrix]:
            out = []
            for lin, vals, indptr in self._pattern:
                data = vals[0] + k * vals[1] + (k * k) * vals[2]
                out.append(sp.csr_matrix((data, (lin % self.n).astype(np.int32), indptr),
                                         shape=(self.n, self.n)))
            return out

        return BandedOperator.from_bands(self.functions, self.perm, stack, self.kl, self.ku,
                                         mats, self._band_pattern, norms)


def _indptr(rows: np.ndarray, n: int) -> np.ndarray:
    """CSR row pointers of sorted row indices."""
    return np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=n))]).astype(np.int32)
