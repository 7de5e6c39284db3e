"""The condensed form's interior modes without a dense eigendecomposition: banded and lazy.

docs/design.md section 8. :class:`forms.solvers.condensed.CondensedOperator` needs, at one
``k``, the interior pencil's eigenvalues ``K phi_j = w_j M phi_j`` (all of them: the far modes'
``sum log(z^2 + w_j)``), the vectors of the few *near* modes (small ``|w_j|``) and, for the far
modes, only sums ``sum_(j >= j0) g_j h_j / w_j^(l + 1)``. :class:`NearModel` gives these from
the banded pencil (both real after the diagonal phase scaling ``D^H (.) D``):

- every eigenvalue by LAPACK ``dsbgvx`` without vectors (split Cholesky and a band reduction,
  ``O(n^2 b)``: 0.03 s at 728 interior rows, 0.2 s at 1 831, against 0.11 s and 2.0 s for the
  dense ``eigh`` with its products in :class:`forms.solvers.condensed.CondensedModel`,
  measured 2026-11-28);
- each near vector by inverse iteration at its eigenvalue (one banded LU, two solves), the
  vectors of a cluster of close eigenvalues separated by Rayleigh-Ritz;
- the far sums by deflated solves: ``X_0 = K^-1 (Y - M Phi_n Phi_n^T Y)``,
  ``X_(l+1) = K^-1 M X_l`` with the near components projected out after every solve, so that
  ``X_l = sum_(j >= j0) phi_j phi_j^T Y / w_j^(l+1)`` (``Y`` the interior-to-interface
  couplings: a few columns).

Nothing here forms a dense ``n x n`` matrix. :class:`PartialModes` is what
:class:`~forms.solvers.condensed.CondensedOperator` takes in place of the dense decomposition;
where a full basis is needed (the contour moments, a fallback) the operator decomposes densely
up to ``condensed.DENSE_MOMENTS_MAX`` interior rows and takes banded LUs above.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from scipy.linalg import lapack

from forms.solvers.condensed import _banded_cholesky, _real, real_interior_form

#: Near vectors computed beyond those asked for, and the relative distance under which
#: eigenvalues form a cluster whose vectors are separated by Rayleigh-Ritz
#: (:meth:`PartialModes._vectors_to`).
MARGIN = 4
CLUSTER = 1e-3


@functools.cache
def _lapack_dsbgvx() -> object:
    """LAPACK's ``dsbgvx`` through ctypes (scipy 1.10 does not wrap it); looked up once.

    (``ctypes.util.find_library`` runs ``ldconfig``: 3.3 ms a call, measured.)

    Raises:
        NotImplementedError: No LAPACK library found.
    """
    name = ctypes.util.find_library("lapack")
    if name is None:
        raise NotImplementedError("no LAPACK library for dsbgvx")
    fn = ctypes.CDLL(name).dsbgvx_
    fn.restype = None
    return fn


def band_upper(a: sp.spmatrix, bw: int) -> np.ndarray:
    """Upper band storage ``(bw + 1, n)`` of a symmetric sparse matrix (Fortran order)."""
    a = sp.csr_matrix(a)
    ab = np.zeros((bw + 1, a.shape[0]), order="F")
    for d in range(bw + 1):
        ab[bw - d, d:] = a.diagonal(d)
    return ab


def banded_eigenvalues(kab: np.ndarray, mab: np.ndarray) -> np.ndarray:
    """Every ``w`` of ``K phi = w M phi`` (real symmetric banded, ``M > 0``), ascending.

    ``kab``, ``mab``: upper band storage (:func:`band_upper`). LAPACK ``dsbgvx``, no vectors.

    Raises:
        NotImplementedError: LAPACK missing or failed (``M`` not positive definite).
    """
    ka, kb, n = kab.shape[0] - 1, mab.shape[0] - 1, kab.shape[1]
    ab, bb = np.array(kab, order="F", dtype=float), np.array(mab, order="F", dtype=float)
    w, dummy = np.zeros(n), np.zeros((1, 1), order="F")
    work, iwork = np.zeros(7 * n), np.zeros(5 * n, dtype=np.int32)
    ifail = np.zeros(n, dtype=np.int32)
    m, info = ctypes.c_int(0), ctypes.c_int(0)

    def i(v: int) -> ctypes.c_void_p:
        return ctypes.byref(ctypes.c_int(v))

    def d(v: float) -> ctypes.c_void_p:
        return ctypes.byref(ctypes.c_double(v))

    def p(x: np.ndarray) -> ctypes.c_void_p:
        return x.ctypes.data_as(ctypes.c_void_p)

    _lapack_dsbgvx()(b"N", b"A", b"U", i(n), i(ka), i(kb), p(ab), i(ka + 1), p(bb), i(kb + 1),
                     p(dummy), i(1), d(0.0), d(0.0), i(1), i(1), d(0.0), ctypes.byref(m),
                     p(w), p(dummy), i(1), p(work), p(iwork), p(ifail), ctypes.byref(info),
                     ctypes.c_size_t(1), ctypes.c_size_t(1), ctypes.c_size_t(1))
    if info.value != 0 or m.value != n:
        raise NotImplementedError(f"dsbgvx: info = {info.value}, {m.value} of {n} values")
    return w


def _bandwidth(*mats: sp.spmatrix) -> int:
    """Largest ``|i - j|`` of a nonzero entry over ``mats``."""
    out = 0
    for x in mats:
        c = x.tocoo()
        if c.nnz:
            out = max(out, int(np.max(np.abs(c.row - c.col))))
    return out


class NearModel:
    """The ``k``-independent banded parts of the condensed form of a banded model.

    The conditions of :class:`forms.solvers.condensed.CondensedModel` (polynomial, ``k``-free
    mass, Hermitian interior blocks with one real phase form ``D``); the parts are kept sparse:
    ``K_p`` and ``M`` real (``D^H (.) D``), the couplings ``A_f[B, I] D`` and ``D^H A_f[I, B]``
    per part ``p`` of ``T0 + k T1 + k^2 T2``.

    Raises:
        NotImplementedError: No such form (the caller uses the dense model).
    """

    def __init__(self, banded: object) -> None:
        _lapack_dsbgvx()
        form = real_interior_form(banded)
        powers, parts, k_parts, m_ii, ph = (form.powers, form.parts, form.k_parts, form.m_ii,
                                            form.phases)
        self.b_idx, self.i_idx = bi, ii = form.b_idx, form.i_idx
        self.phases, self.powers = ph, np.array(powers)
        self.k_parts = [_real(ph, x) for x in k_parts]
        self.m = _real(ph, m_ii)
        self.bw = _bandwidth(self.m, *self.k_parts)
        self.mab = band_upper(self.m, self.bw)
        try:
            _, _, _, logdet = _banded_cholesky(self.m.toarray())
        except np.linalg.LinAlgError as err:
            raise NotImplementedError("the interior mass is not positive definite") from err
        self.logdet_m = complex(logdet)
        self._a_bb = np.array([[m[bi][:, bi].toarray() for m in part] for part in parts])
        # stacked over f: G = [A_f[B, I] D] (f b, n_I), H = [D^H A_f[I, B]] (n_I, f b)
        self._g = [np.concatenate([m[bi][:, ii].toarray() * ph[None, :] for m in part])
                   for part in parts]
        self._h = [np.concatenate([ph.conj()[:, None] * m[ii][:, bi].toarray() for m in part],
                                  axis=1) for part in parts]
        self.nf, self.nb = len(powers), bi.size

    def modes(self, k: float) -> PartialModes:
        """The interior modes at ``k`` (eigenvalues now, vectors and far sums on demand)."""
        return PartialModes(self, float(k))

    def operator(self, bop: object, k: float) -> object:
        """The condensed form of ``bop``, the banded operator of this model at ``k``."""
        from forms.solvers.condensed import CondensedOperator

        return CondensedOperator(bop, self.modes(k))


class PartialModes:
    """The interior modes of a :class:`NearModel` at one ``k``, for ``CondensedOperator``.

    Attributes:
        partial: Marks this provider (no full basis: ``to_modes``/``from_modes`` absent).
        b_idx, i_idx, logdet_m, a_bb: As :class:`forms.solvers.condensed._Modes`.
        w: Every eigenvalue, sorted by ``|w|`` (complex dtype).
    """

    partial = True

    def __init__(self, model: NearModel, k: float) -> None:
        self.model, self.k = model, k
        self.b_idx, self.i_idx, self.logdet_m = model.b_idx, model.i_idx, model.logdet_m
        self.a_bb = self._at(model._a_bb)
        self.kmat = sum(((k ** p) * x for p, x in enumerate(model.k_parts)), 0 * model.m).tocsr()
        self._kab = band_upper(self.kmat, model.bw)
        w = banded_eigenvalues(self._kab, model.mab)
        self.w = w[np.argsort(np.abs(w), kind="stable")].astype(complex)
        self._gs, self._hs = self._at(model._g), self._at(model._h)
        self._phi = np.zeros((model.m.shape[0], 0))
        self._rng = np.random.default_rng(7)
        self._kchol, self._band_store = None, None
        # the couplings' columns that are not zero (interior rows carry powers 0 and 2 only)
        self._hcols = np.flatnonzero(np.abs(self._hs).max(axis=0) > 0)

    def _at(self, x: list | np.ndarray) -> np.ndarray:
        """``x[0] + k x[1] + k^2 x[2] + ...``."""
        return sum((self.k ** p) * np.asarray(v) for p, v in enumerate(x))

    def near(self, j: int) -> tuple[np.ndarray, np.ndarray]:
        """``(g, h)`` of the first ``j`` modes: ``(f, b, j)`` and ``(f, j, b)``."""
        self._vectors_to(j)
        phi = self._phi[:, :j]
        nf, nb = self.model.nf, self.model.nb
        g = _times_real(self._gs.T, phi).T.reshape(nf, nb, j)  # G Phi
        h = _times_real(self._hs, phi).reshape(j, nf, nb).transpose(1, 0, 2)  # Phi^T H
        return g, h

    def _vectors_to(self, j: int) -> None:
        """Near vectors up to ``j`` (``M``-orthonormal, real): inverse iteration, Rayleigh-Ritz.

        At each eigenvalue ``w_i`` (``dsbgvx``'s, accurate to rounding) two solves with one LU
        of ``K - w_i M`` from a random start give its vector to rounding over the gap to its
        neighbours. Eigenvalues closer than :data:`CLUSTER` (relative) form a cluster, whose
        iterates are independent combinations of its vectors: the Rayleigh-Ritz pairs of
        ``(K, M)`` on them are its modes. The vectors are computed to the end of the cluster
        that holds ``j + MARGIN``, so no cluster is cut.
        """
        have = self._phi.shape[1]
        if j <= have:
            return
        n, bw, m = self.kmat.shape[0], self.model.bw, self.model.m
        w = self.w.real
        top = min(j + MARGIN, n)
        while top < n and abs(w[top] - w[top - 1]) <= CLUSTER * abs(w[top]):
            top += 1
        full = np.zeros((3 * bw + 1, n))  # dgbtrf storage: A[r, c] at [2 bw + r - c, c]
        kb, mb = self._bands()
        x = self._rng.standard_normal((n, top - have))
        for c, i in enumerate(range(have, top)):
            for nudge in (0.0, 1e-13, 1e-11):  # an exactly singular shift is moved off
                full[bw:] = kb - w[i] * (1.0 + nudge) * mb
                lu, piv, info = lapack.dgbtrf(full, bw, bw)
                if info == 0:
                    for _ in range(2):
                        x[:, c] = lapack.dgbtrs(lu, bw, bw, m @ x[:, c], piv)[0]
                        x[:, c] /= np.linalg.norm(x[:, c])
                    break
        x /= np.sqrt(np.einsum("ij,ij->j", x, m @ x))[None, :]
        lo = 0
        for hi in range(1, x.shape[1] + 1):  # Rayleigh-Ritz on each cluster
            if hi < x.shape[1] and abs(w[have + hi] - w[have + hi - 1]) <= CLUSTER * abs(
                    w[have + hi]):
                continue
            if hi - lo > 1:
                v = x[:, lo:hi]
                kv, mv = v.T @ (self.kmat @ v), v.T @ (m @ v)
                ritz, y = sla.eigh(0.5 * (kv + kv.T), 0.5 * (mv + mv.T))
                x[:, lo:hi] = v @ y[:, np.argsort(np.abs(ritz), kind="stable")]
            lo = hi
        self._phi = np.concatenate([self._phi, x], axis=1)

    def _bands(self) -> tuple[np.ndarray, np.ndarray]:
        """General band storage of ``K`` (this ``k``) and ``M`` (made once)."""
        if self._band_store is None:
            bw = self.model.bw
            self._band_store = (_general_band(self.kmat, bw), _general_band(self.model.m, bw))
        return self._band_store

    def far_sums(self, j0: int, terms: int, scale: float) -> np.ndarray:
        """``scale^l G_f (sum_(j >= j0) phi_j phi_j^T / w_j^(l+1)) H_f'``, ``l < terms``.

        Shape ``(terms, f, f', b, b)``, by deflated banded solves (module docstring).
        """
        nf, nb = self.model.nf, self.model.nb
        out = np.zeros((terms, nf, nf, nb, nb), dtype=complex)
        if terms == 0:
            return out
        self._vectors_to(j0)
        phi, m, cols = self._phi[:, :j0], self.model.m, self._hcols
        y = np.ascontiguousarray(self._hs[:, cols])  # (n_I, nonzero columns of f b), complex

        x = self._solve_k(y - _real_product(m @ phi, _times_real(y, phi)))
        full = np.zeros((nf * nb, nf * nb), dtype=complex)
        mphi = m @ phi
        for t in range(terms):
            if t:
                x = scale * self._solve_k(m @ x)
            x = x - _real_product(phi, _times_real(x, mphi))
            full[:, cols] = self._gs @ x
            out[t] = full.reshape(nf, nb, nf, nb).transpose(0, 2, 1, 3)
        return out

    def _solve_k(self, y: np.ndarray) -> np.ndarray:
        """``K^-1 y`` (``K`` real symmetric positive definite banded; complex ``y``)."""
        if self._kchol is None:
            try:
                self._kchol = sla.cholesky_banded(self._kab, lower=False)
            except np.linalg.LinAlgError as err:
                raise NotImplementedError("the interior stiffness is not positive definite"
                                          ) from err
        yr = np.ascontiguousarray(y, dtype=complex).view(np.float64)
        xr = sla.cho_solve_banded((self._kchol, False), yr.reshape(y.shape[0], -1))
        return np.ascontiguousarray(xr).view(complex).reshape(y.shape)

    def interior_response(self, z: complex, xb: np.ndarray) -> np.ndarray:
        """``x_I = -T_II(z)^-1 T_IB(z) x_B`` (original basis) by one banded solve."""
        q, nb = self.model.powers, self.model.nb
        rhs = -sum((z ** int(q[f])) * (self._hs[:, f * nb:(f + 1) * nb] @ xb)
                   for f in range(q.size))
        bw = self.model.bw
        kb, mb = self._bands()
        return self.model.phases * sla.solve_banded((bw, bw), kb + (z * z) * mb, rhs,
                                                    check_finite=False)


def _times_real(v: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """``phi^T v`` for real ``phi`` and complex ``v`` in real arithmetic: ``(cols(phi), ...)``."""
    vr = np.ascontiguousarray(v, dtype=complex).view(np.float64)
    return np.ascontiguousarray(phi.T @ vr).view(complex)


def _real_product(phi: np.ndarray, a: np.ndarray) -> np.ndarray:
    """``phi a`` for real ``phi`` and complex ``a`` in real arithmetic."""
    ar = np.ascontiguousarray(a, dtype=complex).view(np.float64)
    return np.ascontiguousarray(phi @ ar).view(complex)


def _general_band(a: sp.spmatrix, bw: int) -> np.ndarray:
    """General band storage ``(2 bw + 1, n)`` of ``a``: ``A[r, c]`` at ``[bw + r - c, c]``."""
    a = sp.csr_matrix(a)
    n = a.shape[0]
    out = np.zeros((2 * bw + 1, n))
    for d in range(-bw, bw + 1):
        diag = a.diagonal(d)
        if d >= 0:
            out[bw - d, d:] = diag
        else:
            out[bw - d, :n + d] = diag
    return out
