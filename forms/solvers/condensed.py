"""The condensed form of a banded 1D operator at one ``k``: ``log det T`` at many points at once.

docs/design.md section 8. For the 1D section models ``T(z) = sum_i z^i A_i`` and only the
interface (friction) rows carry the powers other than 0 and 2; the Dirichlet rows are decoupled.
Split the dofs into ``B`` (rows where a matrix of power not 0 or 2 is nonzero, and rows where
``A_2`` vanishes, e.g. Dirichlet rows) and the interior ``I``. Then
``T_II(z) = K + z^2 M`` (``K = A0_II``, ``M = A2_II`` nonsingular). One generalised
eigendecomposition ``K phi_j = w_j M phi_j`` (``eigh`` if Hermitian-definite, else ``eig`` with
left vectors, ``psi_j^H M phi_j = 1``) gives ``T_II(z)^{-1} = sum_j phi_j psi_j^H / (z^2 + w_j)``
and, by the Schur complement (Weinstein-Aronszajn) identity,

    det T(z) = det M * prod_j (z^2 + w_j) * det S(z),
    S(z) = T_BB(z) - T_BI(z) T_II(z)^{-1} T_IB(z)      (a few x a few).

So ``log det T = log det M + sum_j log(z^2 + w_j) + log det S`` is the *same* function whose
winding the banded count (:meth:`forms.solvers.banded.BandedOperator.count_and_samples`) measures,
evaluated in ``O(n)`` vectorised numpy per point instead of one banded LU; the adaptive rules of
:func:`analytic.numerics.roots.winding_numbers` are unchanged. ``S`` has poles at
``z = +-i sqrt(w_j)``, which cancel the zeros of the product: the sum of logarithms is smooth
there (accuracy against the banded value: tests/test_condensed.py). The same decomposition
solves ``T(z) X = V`` at all contour points at once (:meth:`CondensedOperator.moment_sums`) for
the contour moments of :meth:`forms.solvers.banded.BandedOperator.moment_eigs`. Nothing here
depends on an exact root; the eigenpairs are still polished by the banded Newton on ``T``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from scipy.linalg import lapack

from analytic.numerics.roots import Box, winding_numbers
from forms.solvers.banded import BandedOperator, contour_rule

#: Points per vectorised block (memory: points x n x columns).
BLOCK = 256
#: Largest interior block condensed: :class:`CondensedModel` holds dense ``n x n`` matrices,
#: about ``65 n^2`` bytes at its peak (measured, session 12, stress top, 12 ``c_d`` rung, one
#: process: 1.5 GB at 4 394 unknowns, 2.8 GB at 6 298, 7.0 GB at 10 418, ``k`` = 41.6, 60,
#: 100). Larger operators raise ``NotImplementedError`` and their callers count with one banded
#: LU per contour point (:meth:`forms.solvers.banded.BandedOperator.count_and_samples`, ``O(n)``
#: memory: 0.42 GB at 4 394), slower by about 4x at 4 394 unknowns (114 s against 27 s of CPU,
#: the same count, 121, and values) and by less above: the dense ``eigh`` grows as ``n^3``, the
#: banded count as ``n^2``.
DENSE_MAX = 10500


def dense_fits(n: int) -> None:
    """Raise ``NotImplementedError`` for an interior block of more than :data:`DENSE_MAX` rows."""
    if n > DENSE_MAX:
        raise NotImplementedError(f"the interior block ({n} rows) is above DENSE_MAX = "
                                  f"{DENSE_MAX}: counted banded")
#: Truncation of the far modes' power series (relative, per mode): below the rounding level.
SERIES_EPS = 2.0 ** -60
#: :meth:`CondensedOperator.linear_eigs`: the far modes' series truncated at this relative size
#: (predictors only: measured, P4 paper defaults, both tops, k = 1 to 26.5, the predictors were
#: within 2e-9 of the polished eigenvalues), the ratios ``|z|^2 / |w_j|`` tried for the split,
#: and the largest pencil (its dense eigenvalues cost about ``n^3``: 0.29 s at 461 rows; the
#: stress top's 12 ``c_d`` rung at ``k = 100``, 10 418 unknowns, needs 1 754 rows, and above
#: the limit the moments decompose the interior densely: 438 s and 10.8 GB there).
LIN_EPS = 1e-8
LIN_RATIOS = (1 / 2, 1 / 4, 1 / 8, 1 / 16, 1 / 32, 1 / 64)
LIN_MAX = 2500
#: A partial operator's moments (:meth:`CondensedOperator.moment_sums`) decompose the interior
#: densely up to this many rows (1.5 GB at 4 394, session 12), above it one banded LU per point.
DENSE_MOMENTS_MAX = 4500
#: Candidate ratios ``rho = |z|^2 / |w_j|`` bounding the far modes; the one with the fewest
#: near modes plus series terms is taken.
SERIES_RATIOS = (1 / 4, 1 / 8, 1 / 16, 1 / 64, 1 / 256)


@dataclass
class _Far:
    """The modes ``j >= j0`` (``|w_j| >= scale / rho``) as power series in ``zeta = z^2/scale``.

    For ``|z|^2 <= scale``: ``1/(z^2 + w_j) = sum_{l < terms} (-zeta)^l weights[l, j]``
    (``weights[l, j] = scale^l / w_j^(l + 1)``) and ``log(z^2 + w_j) = log w_j +
    sum_{1 <= l <= terms} (-1)^(l+1) zeta^l (scale/w_j)^l / l``, each truncated after a term of
    relative size ``rho^terms <= SERIES_EPS``. A sum over the far modes is then a sum over
    ``terms`` coefficients, precomputed once per ``scale``, instead of one per mode and point.

    Attributes:
        j0: First far mode (modes sorted by ``|w_j|``); ``terms = 0``: none.
        terms: Series terms.
        scale: The bound on ``|z|^2`` (a power of 2).
        weights: ``(terms, modes - j0)``.
        log_const: ``sum_j log w_j``.
        log_coef: ``(-1)^(l+1)/l sum_j (scale/w_j)^l``, ``l = 1 .. terms``.
        cols: The columns ``(e, b b)`` of ``S``'s mode terms that any mode fills (the
            interface rows' couplings: 6 of 28 on a section), set by
            :meth:`CondensedOperator._far`.
        near_r: ``R[:j0, cols]``.
        coef_cols: ``(weights @ R[j0:])[:, cols]``: the far part of ``S(z)``, per term.
        col_power: The exponent ``e`` of each of ``cols``.
        scatter: ``(cols, b b)``: where each of ``cols`` adds.
    """

    j0: int
    terms: int
    scale: float
    weights: np.ndarray
    log_const: complex
    log_coef: np.ndarray
    cols: np.ndarray
    near_r: np.ndarray
    coef_cols: np.ndarray
    col_power: np.ndarray
    scatter: np.ndarray

    def zeta_powers(self, z: np.ndarray) -> np.ndarray:
        """``zeta^l`` for ``l = 0 .. terms`` (points x terms + 1)."""
        return np.vander(z * z / self.scale, self.terms + 1, increasing=True)

    def series(self, zpow: np.ndarray) -> np.ndarray:
        """``(-zeta)^l``, ``l < terms``, from :meth:`zeta_powers`."""
        return zpow[:, :self.terms] * (-1.0) ** np.arange(self.terms)

    def log_sum(self, zpow: np.ndarray) -> np.ndarray:
        """``sum_{j >= j0} log(z^2 + w_j)`` from :meth:`zeta_powers`."""
        return self.log_const + zpow[:, 1:] @ self.log_coef


class CondensedOperator:
    """``T(z)`` of a :class:`BandedOperator` condensed onto its few non-quadratic rows.

    Args:
        bop: A banded operator in polynomial form (every function a power ``z^i``).

    Raises:
        NotImplementedError: Not polynomial, or the interior block is not ``K + z^2 M`` with
            ``M`` nonsingular.
    """

    def __init__(self, bop: BandedOperator, modes: _Modes | None = None) -> None:
        powers = [fn.power_index for fn in bop.functions]
        if any(q is None for q in powers) or 2 not in powers:
            raise NotImplementedError("the condensed form needs a polynomial with a z^2 term")
        self.bop, self.powers = bop, np.array(powers, dtype=float)
        modes = modes if modes is not None else _modes_of(bop.n, bop.mats, powers)
        self.b_idx, self.i_idx, self.logdet_m = modes.b_idx, modes.i_idx, modes.logdet_m
        self.a_bb = modes.a_bb
        #: A :class:`forms.solvers.partial.PartialModes` (vectors of the near modes only, far
        #: sums by solves) instead of a full decomposition.
        self.partial = getattr(modes, "partial", False)
        self._modes, self._dense = modes, None
        if self.partial:  # sorted by |w|; g, h, S's R grow with the near modes asked for
            self.w = modes.w
            nf, nb = len(powers), modes.b_idx.size
            self.g = np.zeros((nf, nb, 0), dtype=complex)
            self.h = np.zeros((nf, 0, nb), dtype=complex)
        else:
            order = np.argsort(np.abs(modes.w), kind="stable")  # near (small |w_j|) modes first
            self.w = modes.w[order]
            self.g, self.h = modes.g[:, :, order], modes.h[:, order]
            self._to_modes = lambda x: modes.to_modes(x)[order]
            self._from_modes = lambda a: modes.from_modes(a[np.argsort(order)])
            left = getattr(modes, "left_from_modes", None)
            self._left_from_modes = (None if left is None
                                     else lambda a: left(a[np.argsort(order)]))
        self._s_form()
        self._fars: dict[float, _Far] = {}
        self.evaluations = 0  #: points evaluated so far (cost measure)
        #: ``box -> (t, log det T)`` of each count (:meth:`power_sums`)
        self._samples: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}

    def _ensure(self, j0: int) -> None:
        """The near modes' ``g``, ``h`` and ``S``-terms for ``j < j0`` (a partial provider)."""
        if self.partial and self.g.shape[2] < j0:
            self.g, self.h = self._modes.near(j0)
            self._s_form()

    def _far_coef(self, j0: int, terms: int, scale: float) -> np.ndarray:
        """``sum_(j >= j0) scale^l / w_j^(l+1) R_j`` for ``l < terms``: ``(terms, e b b)``."""
        if not self.partial:
            wf = self.w[j0:]
            weights = (scale / wf)[None, :] ** np.arange(terms)[:, None] / wf[None, :]
            return weights @ self._s_r[j0:]
        pairs = self._modes.far_sums(j0, terms, scale)  # (terms, f, f', b, b)
        q = self.powers.astype(int)
        idx = {int(e): i for i, e in enumerate(self._s_exp)}
        nb = self.b_idx.size
        out = np.zeros((terms, self._s_exp.size, nb, nb), dtype=complex)
        for f in range(q.size):
            for f2 in range(q.size):
                out[:, idx[q[f] + q[f2]]] += pairs[:, f, f2]
        return out.reshape(terms, -1)

    def _dense_operator(self) -> CondensedOperator:
        """The same operator with a full (dense) decomposition, made once, for the moments."""
        if self._dense is None:
            self._dense = CondensedOperator(self.bop)
        return self._dense

    def _far(self, z: np.ndarray) -> _Far:
        """The far modes' series for points ``z`` (made per power of 2 above ``max |z|^2``).

        A series made for a larger bound is reused (the smallest such): :meth:`count_and_samples`
        makes the one of its rectangle first, so every point of a count and of the moments on
        its contour is evaluated with the same split.

        The split minimises near modes plus series terms over :data:`SERIES_RATIOS`.
        """
        z2 = float(np.max(np.abs(z))) ** 2 if z.size else 0.0
        held = [s for s in self._fars if s >= z2]  # any series made for a larger |z| holds
        if held:
            return self._fars[min(held)]
        scale = 2.0 ** math.ceil(math.log2(max(z2, 2.0 ** -60)))
        if scale not in self._fars:
            aw, m = np.abs(self.w), self.w.size
            j0, terms = m, 0
            for rho in SERIES_RATIOS:
                j = int(np.searchsorted(aw, scale / rho))
                t = math.ceil(math.log(SERIES_EPS) / math.log(rho))
                if j + t < j0 + terms:
                    j0, terms = j, t
            self._ensure(j0)
            wf = self.w[j0:]
            ratio = scale / wf
            powers = ratio[None, :] ** np.arange(terms + 1)[:, None]  # (terms + 1, far)
            weights = powers[:terms] / wf[None, :]
            signs = (-1.0) ** np.arange(terms)  # (-1)^(l+1) for l = 1 .. terms
            coef = self._far_coef(j0, terms, scale)
            near_r = self._s_r[:j0]
            cols = np.flatnonzero(np.any(near_r != 0, axis=0) | np.any(coef != 0, axis=0))
            nbb = self.b_idx.size ** 2
            scatter = np.zeros((cols.size, nbb))
            scatter[np.arange(cols.size), cols % nbb] = 1.0
            self._fars[scale] = _Far(
                j0, terms, scale, weights, complex(np.sum(np.log(wf.astype(complex)))),
                signs / np.arange(1, terms + 1) * powers[1:].sum(axis=1), cols,
                np.ascontiguousarray(near_r[:, cols]), np.ascontiguousarray(coef[:, cols]),
                self._s_exp[cols // nbb], scatter)
        return self._fars[scale]

    def _s_form(self) -> None:
        """``S(z) = sum_e z^e (A_e - D(z) R_e)``: the Schur complement as one matrix product.

        ``T_BI Phi diag(d) Psi^H T_IB = sum_{f,f'} z^(q_f + q_f') sum_j d_j g_f[:, j] h_f'[j, :]``;
        grouped by the total power ``e``, ``R_e[j]`` is the ``b x b`` matrix of mode ``j``, and
        ``D R`` (points x modes times modes x (powers b^2)) is one dense product: no
        ``points x b x modes`` intermediate (at 1 831 modes, ``k = 50``, this was the largest
        cost of the count).
        """
        q = self.powers.astype(int)
        nf, nb, nm = self.g.shape
        es = sorted({int(a + b) for a in q for b in q} | {int(a) for a in q})
        idx = {e: i for i, e in enumerate(es)}
        r = np.zeros((len(es), nm, nb, nb), dtype=complex)
        a = np.zeros((len(es), nb, nb), dtype=complex)
        for f in range(nf):
            a[idx[q[f]]] += self.a_bb[f]
            for f2 in range(nf):
                r[idx[q[f] + q[f2]]] += np.einsum("ij,jk->jik", self.g[f], self.h[f2])
        self._s_exp = np.array(es)
        self._s_a = a.reshape(len(es), nb * nb)
        self._s_r = r.transpose(1, 0, 2, 3).reshape(nm, len(es) * nb * nb)

    def _mode_sums(self, z: np.ndarray, far: _Far
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(d, zeta powers, x)``: near ``d = 1/(z^2 + w)``, the far series' powers, sums.

        ``x``: the mode sums of ``S`` on ``far.cols`` (near modes plus the far series).
        """
        d = 1.0 / (z[:, None] ** 2 + self.w[None, :far.j0])
        x = d @ far.near_r  # only the columns any mode fills (far.cols)
        zpow = far.zeta_powers(z)
        if far.terms:
            x += far.series(zpow) @ far.coef_cols
        return d, zpow, x

    def _d_and_s(self, z: np.ndarray, far: _Far) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Near ``d = 1/(z^2 + w)`` (points x j0), ``S(z)``, the far modes' ``zeta`` powers.

        ``S(z)``: points x b x b; the powers: :meth:`_Far.zeta_powers`.
        """
        d, zpow, x = self._mode_sums(z, far)
        s = (z[:, None] ** self._s_exp[None, :]) @ self._s_a - (
            z[:, None] ** far.col_power[None, :] * x) @ far.scatter
        return d, s.reshape(z.size, self.b_idx.size, self.b_idx.size), zpow

    def _s_and_derivative(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``S(z)`` and ``S'(z)`` at every point (points x b x b each), as :meth:`_d_and_s`.

        ``d_j = 1/(z^2 + w_j)`` has ``d_j' = -2 z d_j^2``; the far series' ``(-zeta)^l``,
        ``zeta = z^2/scale``, has ``l (-1)^l zeta^(l-1) 2 z/scale``.
        """
        far = self._far(z)
        nb, nt = self.b_idx.size, far.terms
        d, zpow, x = self._mode_sums(z, far)
        dx = (-2.0 * z[:, None] * d * d) @ far.near_r
        if nt:
            ls = np.arange(1, nt)
            dx += np.concatenate([np.zeros((z.size, 1)), ls * (-1.0) ** ls * zpow[:, :nt - 1]
                                  * (2.0 * z[:, None] / far.scale)], axis=1) @ far.coef_cols

        def powers(e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # z^e and (z^e)'
            return (z[:, None] ** e[None, :],
                    e[None, :] * z[:, None] ** np.maximum(e - 1, 0)[None, :])

        (zp, dzp), (zc, dzc) = powers(self._s_exp), powers(far.col_power)
        s = zp @ self._s_a - (zc * x) @ far.scatter
        ds = dzp @ self._s_a - (dzc * x + zc * dx) @ far.scatter
        return s.reshape(z.size, nb, nb), ds.reshape(z.size, nb, nb)

    def newton_many(self, z0: np.ndarray, tol: float = 1e-14, maxit: int = 12
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Newton on ``det S(z) = 0`` from every start at once (one vectorised step for all).

        ``z <- z - 1 / tr(S(z)^-1 S'(z))`` (``(log det S)' = tr(S^-1 S')``): ``det T`` and
        ``det S`` have the same zeros away from the interior eigenvalues ``z^2 = -w_j``. A point
        stops by the rules of :meth:`forms.solvers.banded.BandedOperator.newton` (its step below
        ``tol`` relative, or the error that quadratic convergence predicts from the last two
        steps). Nothing here is certified: the caller checks each eigenpair's residual on ``T``.

        Returns:
            ``(z, converged, iterations, last step)``, one entry per start.
        """
        z = np.array(z0, dtype=complex).ravel()
        conv = np.zeros(z.size, dtype=bool)
        its = np.zeros(z.size, dtype=int)
        step, prev = np.full(z.size, np.inf), np.full(z.size, np.inf)
        live = np.isfinite(z)
        for it in range(1, maxit + 1):
            idx = np.flatnonzero(live)
            if not idx.size:
                break
            s, ds = self._s_and_derivative(z[idx])
            try:
                with np.errstate(all="ignore"):
                    dz = -1.0 / np.trace(np.linalg.solve(s, ds), axis1=1, axis2=2)
            except np.linalg.LinAlgError:  # S exactly singular at a point: the caller's Newton
                break
            z[idx] += dz
            prev[idx], step[idx], its[idx] = step[idx], np.abs(dz), it
            scale = tol * np.maximum(np.abs(z[idx]), 1.0)
            done = (step[idx] <= scale) | ((it > 1) & (step[idx] ** 3 <= scale * prev[idx] ** 2))
            bad = ~np.isfinite(z[idx])
            conv[idx[done & ~bad]] = True
            live[idx[done | bad]] = False
        return z, conv, its, step

    @property
    def has_left(self) -> bool:
        """:meth:`null_vector_pairs` is available (a full decomposition with ``Psi``)."""
        return not self.partial and self._left_from_modes is not None

    def null_vector_pairs(self, lam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``T(z)``'s and ``T(z)^H``'s near-null vectors at each ``z`` (banded order, columns).

        Both from one SVD of ``S(z)``: the right one as :meth:`_vectors`; the left one ``y_B``,
        the left singular vector of the smallest singular value, extended by ``y_I =
        -T_II(z)^-H T_BI(z)^H y_B = -Psi (conj(d) * conj(G(z))^T y_B)`` with ``G(z) = T_BI(z)
        Phi`` and ``d = 1/(z^2 + w)`` (every mode). Needs :attr:`has_left`.
        """
        lam = np.asarray(lam, dtype=complex)
        x, y = (np.zeros((self.bop.n, lam.size), dtype=complex) for _ in range(2))
        if not lam.size:
            return x, y
        _, s, _ = self._d_and_s(lam, self._far(lam))
        u, _, vh = np.linalg.svd(s)
        x = self._vectors(lam, vh[:, -1, :].conj())
        yb = u[:, :, -1]  # (points, b)
        y[self.b_idx] = yb.T
        zp = lam[:, None] ** self.powers[None, :]  # (points, f)
        gy = np.einsum("pf,fbj,pb->jp", zp.conj(), self.g.conj(), yb)  # conj(G)^T y_B
        y[self.i_idx] = self._left_from_modes(
            -gy / (lam.conj()[None, :] ** 2 + self.w.conj()[:, None]))
        return x, y

    def log_det_many(self, z: np.ndarray) -> np.ndarray:
        """``log det T(z)`` at every point (some branch of the argument), vectorised."""
        flat = np.ravel(np.asarray(z, dtype=complex))
        out = np.empty(flat.size, dtype=complex)
        far = self._far(flat)
        for lo in range(0, flat.size, BLOCK):
            d, s, zpow = self._d_and_s(flat[lo:lo + BLOCK], far)
            sign, logabs = np.linalg.slogdet(s)
            out[lo:lo + BLOCK] = (self.logdet_m - _sum_log(d) + far.log_sum(zpow) + logabs
                                  + 1j * np.angle(sign))
            bad = (sign == 0) | ~np.isfinite(out[lo:lo + BLOCK])
            out[lo:lo + BLOCK][bad] = -np.inf
        self.evaluations += flat.size
        return out.reshape(np.shape(z))

    def count_and_samples(self, box: Box, n_initial: int = 32) -> tuple[int, np.ndarray]:
        """Eigenvalues of ``T`` inside ``box`` and the contour parameters used.

        The rules of :meth:`forms.solvers.banded.BandedOperator.count_and_samples` on the same
        ``log det T``, evaluated in condensed form.

        Raises:
            ContourError: An eigenvalue on or too near the contour (move the box edge).
        """
        self._far(np.array([complex(x, y) for x in box[:2] for y in box[2:]]))  # box's series
        counts, t, f = winding_numbers(lambda z: self.log_det_many(z)[None, :], box, 1,
                                       n_initial=n_initial, log=True, samples=True,
                                       values=True)
        self._samples[tuple(float(v) for v in box)] = (t, f[0])
        return counts[0], t

    def power_sums(self, box: Box, count: int, top: int
                   ) -> tuple[np.ndarray, complex, float] | None:
        """``(sum_i u_i^p for p = 1 .. top, c, r)`` over the eigenvalues inside ``box``.

        ``u = (z - c)/r`` (box centre ``c``, half its longest side ``r``), from the samples of
        ``log det T`` its count kept (:meth:`count_and_samples`): by parts, ``oint u^p d log f =
        u_0^p 2 pi i N - p oint u^(p-1) L du`` with ``L`` the logarithm continued along the
        contour from the first point ``u_0`` (it gains ``2 pi i N`` around the loop), the
        integral by :func:`forms.solvers.banded.contour_rule` (Simpson on the verification
        pass's panels). Measured (stress top, ``k = 2.8``, 24 eigenvalues, ``|Im| < 160``): the
        sum of the eigenvalues to 2.4e-4 (``u``'s first three power sums to 1.5e-6). Predictors
        only (:func:`forms.solvers.certified.missing_roots`); ``None`` where that box was not
        counted here. ``count`` is the box's count.
        """
        got = self._samples.get(tuple(float(v) for v in box))
        if got is None:
            return None
        t, logf = got
        z, w = contour_rule(box, t)
        if z.size != t.size:  # the count's samples always hold the corners
            return None
        c = complex(0.5 * (box[0] + box[1]), 0.5 * (box[2] + box[3]))
        r = 0.5 * max(box[1] - box[0], box[3] - box[2])
        u, w = (z - c) / r, w / r
        d = np.diff(logf)
        d = d.real + 1j * np.angle(np.exp(1j * d.imag))
        lu = logf[0] + np.concatenate([[0.0], np.cumsum(d)])  # continued along the contour
        jump = 2j * math.pi * count
        last = (u[0] - u[-2]) / 6.0  # the closing panel's weight of u_0, where L is L_0 + jump
        out = np.empty(top, dtype=complex)
        for p in range(1, top + 1):
            integral = np.sum(w * u ** (p - 1) * lu) + last * u[0] ** (p - 1) * jump
            out[p - 1] = (u[0] ** p * jump - p * integral) / (2j * math.pi)
        return out, c, r

    def moment_sums(self, z: np.ndarray, weights: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``sum_p weights[p, q] T(z_p)^{-1} v`` for every ``q``, shape ``(q, n, columns)``.

        ``T^{-1} v`` by the block elimination ``x_B = S^{-1}(v_B - T_BI T_II^{-1} v_I)``,
        ``x_I = T_II^{-1}(v_I - T_IB x_B)`` with ``T_II^{-1}`` diagonal in the eigenbasis; the
        interior part is summed in that basis and mapped back once (banded order, as ``v``).
        Every product over the near modes is one dense matrix product per block of points
        (``T_BI Phi diag(d) Psi^H v_I``: ``d`` times ``g_f[i, j] (Psi^H v_I)[j, c]``;
        ``Psi^H T_IB x_B``: ``[h_f] (z^q_f x_B)``); the far modes' ``d_j`` are the power series
        of :class:`_Far`, so their sums over the points are taken once per series term.
        """
        if self.partial:  # needs every mode's vector: the dense decomposition, once
            try:
                if self.i_idx.size > DENSE_MOMENTS_MAX:
                    raise NotImplementedError("above DENSE_MOMENTS_MAX")
                dense = self._dense_operator()
            except NotImplementedError:  # one banded LU per point, O(n) memory
                return self.bop._moment_sums(z, weights, v)
            return dense.moment_sums(z, weights, v)
        bi, ii = self.b_idx, self.i_idx
        nf, nb, nm = self.g.shape
        cols, nq = v.shape[1], weights.shape[1]
        far = self._far(z)
        j0, nt = far.j0, far.terms
        wv = self._to_modes(v[ii])  # Psi^H v_I, (m, c)
        gw = (self.g[:, :, :, None] * wv[None, None]).transpose(2, 0, 1, 3).reshape(nm, -1)
        gw = np.concatenate([gw[:j0], far.weights @ gw[j0:]])  # near modes, series terms
        hcat = self.h.transpose(1, 0, 2).reshape(nm, nf * nb)  # [h_0 h_1 ...]  (m, f b)
        acc_b = np.zeros((nq, nb, cols), dtype=complex)
        acc_i = np.zeros((nq, cols, j0), dtype=complex)
        e_far = np.zeros((nq * nt, cols * nf * nb), dtype=complex)
        wu_far = np.zeros(nq * nt, dtype=complex)
        for lo in range(0, z.size, BLOCK):
            zz, wt = z[lo:lo + BLOCK], weights[lo:lo + BLOCK]
            npt = zz.size
            d, sm, zpow = self._d_and_s(zz, far)
            u = far.series(zpow)  # (P, terms)
            zp = zz[:, None] ** self.powers[None, :]  # (P, f)
            y = (np.concatenate([d, u], axis=1) @ gw).reshape(npt, nf, nb, cols)
            r = v[bi][None] - np.einsum("pf,pfic->pic", zp, y)
            xb = np.linalg.solve(sm, r)  # (P, b, c)
            acc_b += np.tensordot(wt, xb, axes=(0, 0))
            xbf = (zp[:, :, None, None] * xb[:, None]).reshape(npt, nf * nb, cols).transpose(
                0, 2, 1).reshape(npt, cols * nf * nb)  # z^q_f x_B per point, (P, c f b)
            qx = (xbf.reshape(npt * cols, nf * nb) @ hcat[:j0].T).reshape(
                npt, cols, j0)  # Psi^H T_IB x_B per point, (P, c, j0)
            xi = d[:, None, :] * (wv[:j0].T[None] - qx)  # T_II^{-1}(...) in the eigenbasis
            acc_i += np.tensordot(wt, xi, axes=(0, 0))
            wu = (wt[:, :, None] * u[:, None, :]).reshape(npt, nq * nt)
            e_far += wu.T @ xbf
            wu_far += wu.sum(axis=0)
        self.evaluations += z.size
        if nt:  # the far modes: sum_l weights[l, j] (WU[q, l] wv[j, c] - h_j . E[q, l, c])
            he = (hcat[j0:] @ e_far.reshape(nq * nt * cols, nf * nb).T).reshape(
                nm - j0, nq, nt, cols)
            acc_far = (np.einsum("lj,ql,jc->qcj", far.weights, wu_far.reshape(nq, nt), wv[j0:])
                       - np.einsum("lj,jqlc->qcj", far.weights, he))
            acc_i = np.concatenate([acc_i, acc_far], axis=2)
        out = np.empty((nq, self.bop.n, cols), dtype=complex)
        out[:, bi] = acc_b
        back = self._from_modes(acc_i.transpose(2, 0, 1).reshape(nm, nq * cols))  # Phi acc
        out[:, ii] = back.reshape(-1, nq, cols).transpose(1, 0, 2)
        return out

    def linear_eigs(self, box: Box, widen: float = 1e-3) -> tuple[np.ndarray, np.ndarray]:
        """Predictors of the eigenvalues in ``box`` from one dense linear eigenproblem.

        The near modes ``j < j0`` stay as unknowns ``a_j``, with ``c_j = z a_j``:
        ``(z^2 + w_j) a_j + h_j(z) x_B = 0`` is first order in ``(a, c)`` (``T_IB`` has powers 0
        and 2 only), and the ``B`` rows ``P(z) x_B + sum_j g_j(z) a_j = 0`` with ``g_j(z) a_j``
        written in ``a, c, x_B, z x_B, ...`` (powers up to 3). ``P(z) = T_BB(z)`` minus the far
        modes' series truncated after a term of relative size ``rho^terms <= LIN_EPS`` is a
        ``b x b`` polynomial of degree ``D``, linearised by its companion form in
        ``z / sigma`` (``sigma^2 = max |z|^2`` on the box). The pencil has ``D b + 2 j0`` rows
        (``j0`` and ``terms`` minimise that); its eigenvalues inside the box (widened by
        ``widen``) are returned with vectors of ``T`` (the null vector of ``S(z)`` and
        ``x_I = T_II(z)^{-1}(-T_IB(z) x_B)``). Predictors only: the truncation moves them by
        about ``LIN_EPS``; Newton on ``T`` polishes them, and the count checks that none is
        missing (docs/design.md section 8).

        Returns:
            ``(values, vectors)``: vectors in banded order, one column per value.

        Raises:
            NotImplementedError: The pencil would exceed :data:`LIN_MAX` rows.
        """
        corners = np.array([complex(x, y) for x in box[:2] for y in box[2:]])
        scale = max(float(np.max(np.abs(corners))) ** 2, 1e-300)
        a, b, sigma = self._lin_pencil(scale, *self._lin_split(scale))
        a0, b0, c0, d0 = box
        # shift and invert: (A - s B)^-1 B y = y / (z~ - s), a standard eigenproblem (2.5-3.5x
        # faster than the QZ of the pencil at 160-240 rows, measured); s right of the box by
        # half its width, so no eigenvalue is near it and B's singular rows go to 1/mu = 0
        shift = complex(b0 + 0.5 * (b0 - a0), 0.5 * (c0 + d0)) / sigma
        try:
            lu = sla.lu_factor(a - shift * b, overwrite_a=True, check_finite=False)
        except (np.linalg.LinAlgError, ValueError) as err:
            raise NotImplementedError(f"the linearised pencil at the shift: {err}") from err
        mu = np.linalg.eigvals(sla.lu_solve(lu, b, check_finite=False))
        with np.errstate(all="ignore"):
            lam = (shift + 1.0 / mu) * sigma
        mw, mh = widen * (b0 - a0), widen * (d0 - c0)
        lam = lam[np.isfinite(lam) & (lam.real > a0 - mw) & (lam.real < b0 + mw)
                  & (lam.imag > c0 - mh) & (lam.imag < d0 + mh)]
        return lam, self._vectors(lam)

    def _lin_split(self, scale: float) -> tuple[int, int]:
        """``(j0, terms)`` of the pencil for ``|z|^2 <= scale``: fewest rows over LIN_RATIOS.

        Raises:
            NotImplementedError: More than :data:`LIN_MAX` rows.
        """
        aw, nb = np.abs(self.w), self.b_idx.size
        best = None
        for rho in LIN_RATIOS:
            j0 = int(np.searchsorted(aw, scale / rho))
            terms = 0 if j0 == aw.size else math.ceil(math.log(LIN_EPS) / math.log(rho))
            rows = 2 * j0 + nb * (5 + 2 * terms)
            if best is None or rows < best[0]:
                best = (rows, j0, terms)
        if best[0] > LIN_MAX:
            raise NotImplementedError(f"the linearised pencil would have {best[0]} rows "
                                      f"(LIN_MAX = {LIN_MAX})")
        return best[1], best[2]

    def _lin_coefficients(self, scale: float, j0: int, terms: int) -> list[np.ndarray]:
        """``P_d sigma^d``: ``T_BB(z)`` minus the far modes' series (``j >= j0``), by power."""
        nb, exps = self.b_idx.size, self._s_exp
        ne = exps.size
        coef: dict[int, np.ndarray] = {}
        for i, e in enumerate(exps):
            coef[int(e)] = coef.get(int(e), 0) + self._s_a[i].reshape(nb, nb)
        self._ensure(j0)
        if terms:
            sc = self._far_coef(j0, terms, scale).reshape(terms, ne, nb, nb)
            for t in range(terms):
                # 1/(z^2 + w) = sum_t (-z^2/scale)^t scale^t/w^(t+1)
                for i, e in enumerate(exps):
                    d = int(e) + 2 * t
                    coef[d] = coef.get(d, 0) - (-1.0 / scale) ** t * sc[t, i]
        top = max([d for d, c in coef.items() if np.any(c != 0)] + [2])
        sigma = math.sqrt(scale)
        return [coef.get(d, np.zeros((nb, nb))) * sigma ** d for d in range(top + 1)]

    def _lin_pencil(self, scale: float, j0: int, terms: int
                    ) -> tuple[np.ndarray, np.ndarray, float]:
        """``(A, B, sigma)``: ``A v = (z / sigma) B v``, ``v = [x_B, z~ x_B, ..., a, c]``.

        ``z~ = z / sigma``; ``X_d = z~^d x_B`` for ``d < D``; the near modes' equations
        ``z~ a = c``, ``z~ c = -om a - eta0 X_0 - h2 X_2`` (``om = w / sigma^2``); the last
        block row ``z~ P_D X_(D-1) = -sum_(d<D) P_d X_d - sum_q G_q z~^q a`` with ``z~^q a``
        in those unknowns (:meth:`_lin_powers`).
        """
        p = self._lin_coefficients(scale, j0, terms)
        q = self.powers.astype(int)
        top_q = int(q.max())
        while len(p) < top_q + 2:  # X_(top_q) must be one of the unknowns
            p.append(np.zeros_like(p[0]))
        deg, nb = len(p) - 1, self.b_idx.size
        sigma = math.sqrt(scale)
        gq = [sum((self.g[f, :, :j0] for f in range(q.size) if q[f] == e),
                  np.zeros((nb, j0), dtype=complex)) * sigma ** e for e in range(top_q + 1)]
        h0, h2 = (sum((self.h[f, :j0] for f in range(q.size) if q[f] == e),
                      np.zeros((j0, nb), dtype=complex)) for e in (0, 2))
        om = self.w[:j0] / scale
        n = deg * nb + 2 * j0
        a = np.zeros((n, n), dtype=complex)
        b = np.zeros((n, n), dtype=complex)
        xs = [slice(d * nb, (d + 1) * nb) for d in range(deg)]
        sa, sc = slice(deg * nb, deg * nb + j0), slice(deg * nb + j0, n)
        eye = np.eye(nb)
        for d in range(deg - 1):  # z~ X_d = X_(d+1)
            a[xs[d], xs[d + 1]], b[xs[d], xs[d]] = eye, eye
        last = xs[-1]
        b[last, last] = p[deg]
        for d in range(deg):
            a[last, xs[d]] -= p[d]
        for e, (ca, cc, cx) in enumerate(self._lin_powers(om, h0 / scale, h2, top_q)):
            a[last, sa] -= gq[e] * ca[None, :]
            a[last, sc] -= gq[e] * cc[None, :]
            for d, m in cx.items():
                a[last, xs[d]] -= gq[e] @ m
        a[sa, sc] = b[sa, sa] = b[sc, sc] = np.eye(j0)  # z~ a = c
        a[sc, sa] = -np.diag(om)  # z~ c = -om a - eta0 X_0 - h2 X_2
        a[sc, xs[0]], a[sc, xs[2]] = -h0 / scale, -h2
        return a, b, sigma

    @staticmethod
    def _lin_powers(om: np.ndarray, eta0: np.ndarray, h2: np.ndarray, top: int
                    ) -> list[tuple[np.ndarray, np.ndarray, dict[int, np.ndarray]]]:
        """``z~^q a`` for ``q <= top`` as ``(coefficient of a, of c, {d: matrix on X_d})``.

        ``z~^0 a = a``, ``z~ a = c`` and ``z~^q a = -om z~^(q-2) a - eta0 X_(q-2) - h2 X_q``.
        """
        one, zero = np.ones_like(om), np.zeros_like(om)
        out = [(one, zero, {}), (zero, one, {})]
        for e in range(2, top + 1):
            ca, cc, cx = out[e - 2]
            nx = {d: -om[:, None] * m for d, m in cx.items()}
            nx[e - 2] = nx.get(e - 2, 0) - eta0
            nx[e] = nx.get(e, 0) - h2
            out.append((-om * ca, -om * cc, nx))
        return out[:top + 1]

    def _vectors(self, lam: np.ndarray, xb: np.ndarray | None = None) -> np.ndarray:
        """``T(z)``'s near-null vector at each ``z`` (banded order, columns): ``S``'s, extended.

        ``x_B`` the right singular vector of ``S(z)`` of its smallest singular value (or
        ``xb``, points x b, if given), ``x_I = -T_II(z)^{-1} T_IB(z) x_B`` in the eigenbasis
        (every mode, exactly).
        """
        out = np.zeros((self.bop.n, lam.size), dtype=complex)
        if not lam.size:
            return out
        if xb is None:
            _, s, _ = self._d_and_s(lam, self._far(lam))
            xb = np.linalg.svd(s)[2][:, -1, :].conj()  # (points, b)
        out[self.b_idx] = xb.T
        if self.partial:  # one banded solve each
            for c, z in enumerate(lam):
                out[self.i_idx, c] = self._modes.interior_response(complex(z), xb[c])
            return out
        zp = lam[:, None] ** self.powers[None, :]  # (points, f)
        hx = np.einsum("pf,fjb,pb->jp", zp, self.h, xb)  # Psi^H T_IB(z) x_B, (m, points)
        out[self.i_idx] = self._from_modes(-hx / (lam[None, :] ** 2 + self.w[:, None]))
        return out


@dataclass
class _Modes:
    """The interior eigendecomposition of ``T`` at one ``k`` and its couplings to ``B``.

    Attributes:
        b_idx: The rows of ``B`` (banded order).
        i_idx: The interior rows ``I``.
        w: ``K phi_j = w_j M phi_j`` (any order).
        logdet_m: ``log det M_II``.
        a_bb: ``(f, b, b)``: ``A_f[B, B]``.
        g: ``(f, b, m)``: ``A_f[B, I] Phi``.
        h: ``(f, m, b)``: ``Psi^H A_f[I, B]``.
        to_modes: ``x -> Psi^H x`` (interior vectors, columns).
        from_modes: ``a -> Phi a``.
        left_from_modes: ``a -> Psi a`` (``None``: not provided).
    """

    b_idx: np.ndarray
    i_idx: np.ndarray
    w: np.ndarray
    logdet_m: complex
    a_bb: np.ndarray
    g: np.ndarray
    h: np.ndarray
    to_modes: Callable[[np.ndarray], np.ndarray]
    from_modes: Callable[[np.ndarray], np.ndarray]
    left_from_modes: Callable[[np.ndarray], np.ndarray] | None = None


def _split_rows(n: int, parts: list[list[sp.csr_matrix]], powers: list[int]
                ) -> tuple[np.ndarray, np.ndarray]:
    """``(B, I)``: rows where a matrix of power not 0 or 2 is nonzero, or the mass vanishes.

    ``parts[j][f]``: the matrices (one list, or one per power of ``k``; the mass is that of
    ``parts[0]``).

    Raises:
        NotImplementedError: A matrix of power other than 0, 2 in the interior.
    """
    b = np.zeros(n, dtype=bool)
    for mats in parts:
        for q, m in zip(powers, mats, strict=True):
            if q not in (0, 2):
                c = m.tocoo()
                b[c.row[c.data != 0]] = True
    b |= np.asarray(abs(parts[0][powers.index(2)]).sum(axis=1)).ravel() == 0
    bi, ii = np.flatnonzero(b), np.flatnonzero(~b)
    for mats in parts:
        for q, m in zip(powers, mats, strict=True):
            if q not in (0, 2) and m[ii][:, ii].count_nonzero():
                raise NotImplementedError("a matrix of power other than 0, 2 in the interior")
    return bi, ii


def _modes_of(n: int, mats: list[sp.csr_matrix], powers: list[int]) -> _Modes:
    """:class:`_Modes` of one operator's matrices (:func:`_decompose` of its interior)."""
    mats = [m.tocsr() for m in mats]
    bi, ii = _split_rows(n, [mats], powers)
    dense_fits(ii.size)
    mass = mats[powers.index(2)]
    kmat = sum((m for q, m in zip(powers, mats, strict=True) if q == 0), 0 * mass)
    w, phi, psi_h, logdet_m = _decompose(kmat[ii][:, ii].toarray(), mass[ii][:, ii].toarray())
    return _Modes(bi, ii, w, logdet_m, np.stack([m[bi][:, bi].toarray() for m in mats]),
                  np.stack([m[bi][:, ii].toarray() @ phi for m in mats]),
                  np.stack([psi_h @ m[ii][:, bi].toarray() for m in mats]),
                  lambda x: psi_h @ x, lambda a: phi @ a, lambda a: psi_h.conj().T @ a)


@dataclass
class InteriorForm:
    """The interior blocks of a banded model ``T0 + k T1 + k^2 T2`` in their real form.

    Attributes:
        powers: The power of ``z`` of each matrix function.
        parts: Each part's matrices (banded order).
        b_idx, i_idx: The rows of ``B`` and the interior ``I`` (:func:`_split_rows`).
        k_parts: ``K_p = A0_p[I, I]`` per part (sparse, complex).
        m_ii: ``M = A2[I, I]`` (``k``-free).
        phases: ``D`` with every ``D^H K_p D`` and ``D^H M D`` real.
    """

    powers: list[int]
    parts: list
    b_idx: np.ndarray
    i_idx: np.ndarray
    k_parts: list[sp.csr_matrix]
    m_ii: sp.csr_matrix
    phases: np.ndarray


def real_interior_form(banded: object) -> InteriorForm:
    """:class:`InteriorForm` of a banded model, the conditions of a ``k``-independent half.

    Raises:
        NotImplementedError: Not a polynomial with a ``z^2`` term, a mass that depends on
            ``k``, an interior block that is not Hermitian, or no one real phase form.
    """
    powers = [fn.power_index for fn in banded.functions]
    if any(q is None for q in powers) or 2 not in powers:
        raise NotImplementedError("the condensed form needs a polynomial with a z^2 term")
    parts = banded.part_matrices()
    f2 = powers.index(2)
    if any(part[f2].count_nonzero() for part in parts[1:]):
        raise NotImplementedError("the mass depends on k")
    bi, ii = _split_rows(banded.n, parts, powers)
    k_parts = [sum((m for q, m in zip(powers, part, strict=True) if q == 0),
                   0 * part[f2])[ii][:, ii].tocsr() for part in parts]
    m_ii = parts[0][f2][ii][:, ii].tocsr()
    if not all(_hermitian(x) for x in [*k_parts, m_ii]):
        raise NotImplementedError("an interior block is not Hermitian")
    ph = _sparse_real_phases(sum(k_parts), m_ii)
    if ph is None or any(_not_real(ph, x) for x in [*k_parts, m_ii]):
        raise NotImplementedError("no real form of every part")
    return InteriorForm(powers, parts, bi, ii, k_parts, m_ii, ph)


class CondensedModel:
    """The ``k``-independent half of the condensed form, for every ``k`` of a banded model.

    ``T(z; k) = T0 + k T1 + k^2 T2`` (:class:`forms.solvers.banded.BandedModel`) with a mass
    ``M`` that does not depend on ``k`` and a real form ``D^H (.) D`` (diagonal phases ``D``,
    :func:`_real_phases`) of the interior blocks of every part: then ``M = U^T U`` (banded
    Cholesky), ``C_j = U^-T D^H K_j D U^-1`` and the couplings ``A_f[B, I] D U^-1``,
    ``U^-T D^H A_f[I, B]`` are computed once, and each ``k`` costs one dense ``eigh`` of
    ``C_0 + k C_1 + k^2 C_2`` (``Phi = D U^-1 Y``) and products with ``Y`` (the decomposition of
    :func:`_real_banded_eigh`, its sparse extraction, phases and banded solves no longer per ``k``).

    Args:
        banded: The banded model.

    Raises:
        NotImplementedError: No such form (the caller condenses each ``k`` on its own).
    """

    def __init__(self, banded: object) -> None:
        form = real_interior_form(banded)
        powers, parts, k_parts, m_ii, ph = (form.powers, form.parts, form.k_parts, form.m_ii,
                                            form.phases)
        self.b_idx, self.i_idx = bi, ii = form.b_idx, form.i_idx
        dense_fits(ii.size)
        self.phases = ph
        try:
            self._u, _, self._bw, logdet = _banded_cholesky(_real(ph, m_ii).toarray())
        except np.linalg.LinAlgError as err:
            raise NotImplementedError("the interior mass is not positive definite") from err
        self.logdet_m = complex(logdet)
        self._c = []
        for x in k_parts:
            a = self._solve_ut(self._solve_ut(_real(ph, x).toarray()).T)  # U^-T K U^-1
            self._c.append(0.5 * (a + a.T))
        self._a_bb = np.array([[m[bi][:, bi].toarray() for m in part] for part in parts])
        # (A_f[B, I] D U^-1)^T = U^-T D A_f[B, I]^T, and U^-T D^H A_f[I, B]: (part, m, f b)
        self._gt = np.array([self._solve_ut(ph[:, None] * np.concatenate(
            [m[bi][:, ii].toarray().T for m in part], axis=1)) for part in parts])
        self._h = np.array([self._solve_ut(ph.conj()[:, None] * np.concatenate(
            [m[ii][:, bi].toarray() for m in part], axis=1)) for part in parts])
        self.nf, self.nb = len(powers), bi.size

    def _solve_ut(self, x: np.ndarray) -> np.ndarray:
        """``U^-T x``."""
        return _triangular(self._u, x, "T")

    def modes(self, k: float) -> _Modes:
        """The decomposition at ``k`` (for :class:`CondensedOperator`)."""
        k = float(k)

        def at(x: np.ndarray) -> np.ndarray:
            return x[0] + k * x[1] + (k * k) * x[2]

        w, y = sla.eigh(at(self._c), driver="evd", overwrite_a=True, check_finite=False)
        nf, nb, m = self.nf, self.nb, w.size
        g = _real_times(y.T, at(self._gt)).T.reshape(nf, nb, m)  # A_f[B, I] Phi
        h = _real_times(y.T, at(self._h)).reshape(m, nf, nb).transpose(1, 0, 2)  # Psi^H A_f[I, B]
        ph, u = self.phases, self._u

        def from_modes(a: np.ndarray) -> np.ndarray:  # Phi a = Psi a (Psi^H M Phi = I)
            return ph[:, None] * _triangular(u, _real_times(y, a), "N")

        return _Modes(self.b_idx, self.i_idx, w.astype(complex), self.logdet_m, at(self._a_bb),
                      g, h, lambda x: _real_times(y.T, self._solve_ut(ph.conj()[:, None] * x)),
                      from_modes, from_modes)

    def operator(self, bop: BandedOperator, k: float) -> CondensedOperator:
        """The condensed form of ``bop``, the banded operator of this model at ``k``."""
        return CondensedOperator(bop, self.modes(k))


def _real_times(y: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``y @ x`` for real ``y`` and complex ``x`` in real arithmetic (columns as re/im pairs)."""
    x = np.ascontiguousarray(x, dtype=complex)
    return np.ascontiguousarray(y @ x.view(np.float64)).view(complex)


def _triangular(u: np.ndarray, x: np.ndarray, trans: str) -> np.ndarray:
    """``U^-1 x`` (``trans = "N"``) or ``U^-T x`` (``"T"``) by LAPACK ``dtbtrs``.

    ``U`` is real, upper banded; a complex ``x`` is solved as its real and imaginary columns.
    """
    xr = np.ascontiguousarray(x)
    cplx = np.iscomplexobj(xr)
    if cplx:
        xr = xr.view(np.float64)
    out, info = lapack.dtbtrs(u, xr.reshape(xr.shape[0], -1), uplo="U", trans=trans)
    if info != 0:
        raise np.linalg.LinAlgError(f"dtbtrs: info = {info}")
    out = np.ascontiguousarray(out).reshape(xr.shape)
    return out.view(complex) if cplx else out


def _hermitian(x: sp.csr_matrix) -> bool:
    """``x`` Hermitian to ``1e-12`` of its largest entry."""
    return bool(abs(x - x.conj().T).max() <= 1e-12 * max(abs(x).max(), 1e-300))


def _real(ph: np.ndarray, x: sp.csr_matrix) -> sp.csr_matrix:
    """``D^H x D`` (real part)."""
    c = x.tocoo()
    return sp.csr_matrix(((ph.conj()[c.row] * c.data * ph[c.col]).real, (c.row, c.col)),
                         shape=x.shape)


def _not_real(ph: np.ndarray, x: sp.csr_matrix, tol: float = 1e-13) -> bool:
    """``D^H x D`` not real to ``tol`` of its largest entry (the test of :func:`_real_phases`)."""
    c = x.tocoo()
    y = ph.conj()[c.row] * c.data * ph[c.col]
    return bool(y.size and np.abs(y.imag).max() > tol * max(np.abs(y).max(), 1e-300))


def _sparse_real_phases(k: sp.csr_matrix, m: sp.csr_matrix) -> np.ndarray | None:
    """:func:`_real_phases` of sparse ``K``, ``M`` (the phases only; the caller tests them)."""
    kc, mc = k.tocoo(), m.tocoo()
    n = k.shape[0]
    knz = kc.data != 0
    klin = kc.row[knz].astype(np.int64) * n + kc.col[knz]
    mlin = mc.row.astype(np.int64) * n + mc.col
    mine = ~np.isin(mlin, klin)  # where K is zero, M's entry (as np.where(k != 0, k, m))
    a = sp.csr_matrix((np.concatenate([kc.data[knz], mc.data[mine]]),
                       (np.concatenate([kc.row[knz], mc.row[mine]]),
                        np.concatenate([kc.col[knz], mc.col[mine]]))), shape=(n, n))
    a.eliminate_zeros()
    return _tree_phases(a)


def _tree_phases(a: sp.csr_matrix) -> np.ndarray:
    """Unit phases making ``A``'s entries real along a breadth-first spanning tree of its pattern.

    From each component's first dof, ``d_c = d_r exp(-i arg A_rc)`` for every tree edge
    ``(r, c)`` (see :func:`_real_phases`; the caller tests the scaled matrices).
    """
    from scipy.sparse.csgraph import breadth_first_order

    n = a.shape[0]
    graph = abs(a)
    d = np.zeros(n, dtype=complex)
    for start in range(n):
        if d[start] != 0:
            continue
        order, pred = breadth_first_order(graph, start, directed=False)
        rest = order[1:]
        steps = np.exp(-1j * np.angle(np.asarray(a[pred[rest], rest]).ravel())).tolist()
        phase = {int(start): 1.0 + 0j}
        for c, r, u in zip(rest.tolist(), pred[rest].tolist(), steps, strict=True):
            phase[c] = phase[r] * u
        d[list(phase)] = list(phase.values())
    return d


def _sum_log(d: np.ndarray, group: int = 16) -> np.ndarray:
    """``sum_j log d[:, j]`` (imaginary part modulo ``2 pi``) with one logarithm per ``group``.

    Products of ``group`` (a power of 2) factors first, by pairwise halving of the columns
    (session 34: with 16 instead of 8 and the products taken along the long axis, 384 -> 270 us
    for 256 points and 250 modes); a row where a product over- or underflows is summed one
    logarithm at a time. The count uses only the wrapped increments of the argument.
    """
    rows, cols = d.shape
    if cols == 0:
        return np.zeros(rows, dtype=d.dtype)
    pad = (-cols) % group
    prods = np.concatenate([d, np.ones((rows, pad), dtype=d.dtype)], axis=1) if pad else d
    while prods.shape[1] > (cols + pad) // group:
        prods = prods[:, 0::2] * prods[:, 1::2]
    bad = ~np.all(np.isfinite(prods) & (np.abs(prods) > 1e-290), axis=1)
    prods[bad] = 1.0
    out = np.sum(np.log(prods), axis=1)
    out[bad] = np.sum(np.log(d[bad]), axis=1)
    return out


def _decompose(k: np.ndarray, m: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                       complex]:
    """``w``, ``Phi``, ``Psi^H`` (``Psi^H M Phi = I``, ``K Phi = M Phi diag(w)``), ``log det M``.

    ``eigh`` when ``K`` and ``M`` are Hermitian to rounding and ``M`` positive definite (then
    ``Psi = Phi``), otherwise ``eig`` with left vectors.
    """
    scale_k, scale_m = max(np.abs(k).max(), 1e-300), max(np.abs(m).max(), 1e-300)
    herm = (np.abs(k - k.conj().T).max() <= 1e-12 * scale_k
            and np.abs(m - m.conj().T).max() <= 1e-12 * scale_m)
    if herm:
        try:
            # D^H K D and D^H M D real (D a diagonal of phases) when it exists: real banded
            # reduction and eigh, phi = D phi_real (799 unknowns, side by side: real 1.8x faster
            # than complex eigh(K, M), the banded reduction another 2.3x)
            ph = _real_phases(k, m)
            if ph is not None:
                w, phi, logdet = _real_banded_eigh((ph.conj()[:, None] * k * ph[None, :]).real,
                                                   (ph.conj()[:, None] * m * ph[None, :]).real)
                phi = ph[:, None] * phi
                return w.astype(complex), phi, phi.conj().T, complex(logdet)
            chol = sla.cho_factor(m, lower=True)
            w, phi = sla.eigh(k, m)
            logdet = 2.0 * np.sum(np.log(np.diag(chol[0]).real))
            return w.astype(complex), phi, phi.conj().T, complex(logdet)
        except np.linalg.LinAlgError:
            pass
    w, vl, vr = sla.eig(k, m, left=True, right=True)
    if not np.all(np.isfinite(w)):
        raise NotImplementedError("the interior mass block is singular")
    psi_h = vl.conj().T
    scale = np.einsum("ji,jk,ki->i", vl.conj(), m, vr)
    psi_h = psi_h / scale[:, None]
    lu, piv = sla.lu_factor(m)
    swaps = int(np.count_nonzero(piv != np.arange(m.shape[0])))
    logdet = np.sum(np.log(np.diag(lu).astype(complex))) + 1j * np.pi * (swaps % 2)
    return w, vr, psi_h, complex(logdet)


def _real_banded_eigh(k: np.ndarray, m: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """``K phi = M phi diag(w)``, ``phi^T M phi = I`` for real symmetric ``K``, ``M`` (``M > 0``).

    ``M = U^T U`` by a banded Cholesky factorisation (``M`` is banded in the operator's
    reverse Cuthill-McKee order), ``A = U^-T K U^-1`` by two banded triangular solves, the
    standard ``eigh`` of ``A`` (divide and conquer), ``phi = U^-1 Y``: the same pairs as
    ``eigh(K, M)`` without its dense ``O(n^3)`` reduction and back-substitution (measured 2.3x
    faster at 799 unknowns, residual and ``M``-orthogonality at rounding level).

    Returns:
        ``(w, phi, log det M)``.

    Raises:
        numpy.linalg.LinAlgError: ``M`` not positive definite.
    """
    u, lower, bw, logdet = _banded_cholesky(m)
    x = sla.solve_banded((bw, 0), lower, k)  # U^-T K
    a = sla.solve_banded((bw, 0), lower, x.T)  # U^-T K U^-1 (K symmetric)
    w, y = sla.eigh(0.5 * (a + a.T), driver="evd")
    phi = sla.solve_banded((0, bw), u, y)
    return w, phi, logdet


def _banded_cholesky(m: np.ndarray) -> tuple[np.ndarray, np.ndarray, int, float]:
    """``M = U^T U`` of a banded real symmetric ``M > 0``.

    Returns:
        ``(U in upper band storage, U^T in lower band storage, bandwidth, log det M)``.

    Raises:
        numpy.linalg.LinAlgError: ``M`` not positive definite.
    """
    n = m.shape[0]
    rows, cols = np.nonzero(m)
    bw = int(np.max(np.abs(rows - cols))) if rows.size else 0
    upper = np.zeros((bw + 1, n))
    for d in range(bw + 1):
        upper[bw - d, d:] = np.diagonal(m, d)
    u = sla.cholesky_banded(upper, lower=False)  # M = U^T U, U upper banded
    lower = np.zeros((bw + 1, n))  # U^T in lower band storage
    for d in range(bw + 1):
        lower[d, :n - d] = u[bw - d, d:]
    return u, lower, bw, float(2.0 * np.sum(np.log(u[bw])))


def _real_phases(k: np.ndarray, m: np.ndarray, tol: float = 1e-13) -> np.ndarray | None:
    """Unit phases ``d`` with ``diag(d)^H A diag(d)`` real for ``A = K, M``, or ``None``.

    Along a spanning tree of the pattern of ``|K| + |M|`` (breadth first from each component's
    first dof) ``d_c = d_r exp(-i arg A_rc)`` makes the tree's entries real; the scaled
    matrices are accepted only if every imaginary part is below ``tol`` times the largest
    entry (e.g. the ``i k`` coupling of ``u_x`` and ``u_y`` of the ``exp(-i k x)`` ansatz:
    ``d = 1`` on one component and ``-i`` on the other).
    """
    d = _tree_phases(sp.csr_matrix(np.where(k != 0, k, m)))
    for x in (k, m):
        y = d.conj()[:, None] * x * d[None, :]
        if np.abs(y.imag).max() > tol * max(np.abs(y).max(), 1e-300):
            return None
    return d
