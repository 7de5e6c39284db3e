"""``det_M`` builds the partial-wave matrix entry by entry (``_waves_matrix``) instead of through
``matrix_M``: the previous computation is kept here as the reference, and the two must agree
to rounding (same floating-point operations), including at the removable points.

Bit for bit on an AVX2 machine (sessions 5-11); on an AVX-512 one (session 12, the same Debian
numpy) numpy's SIMD loops round the contiguous and the strided operands of the two
constructions differently: measured over the cases below, at most 3.3e-14 relative at ordinary
points and 7.1e-12 at the removable ones, which are evaluated a relative 1e-12 away from a
singular matrix (its condition number amplifies the entries' rounding)."""

from __future__ import annotations

import numpy as np
import pytest

from analytic.params import Params
from analytic.physics import finite_h
from analytic.physics.finite_h import (
    SPURIOUS_ORDER_AT_ZERO,
    matrix_M,
    row_normalised_det,
    wavenumbers,
)

pytestmark = pytest.mark.serial

#: Largest relative difference allowed: 3x the AVX-512 measurement above, ordinary points.
RTOL = 1e-13
#: The same at the removable points (measured 7.1e-12).
RTOL_REMOVABLE = 2e-11


def det_M_reference(Lambda: np.ndarray, k: float, p: Params) -> np.ndarray:  # noqa: N802, N803
    """``det_M`` as it was computed before (through ``matrix_M(..., "waves")``)."""
    H = p.H
    L, kk = np.broadcast_arrays(np.asarray(Lambda, dtype=complex), np.asarray(k, dtype=float))
    ks, kd = wavenumbers(L, kk, p.beta)
    degenerate = (np.abs(ks) < 1e-12 * (np.abs(L) + kk)) | (np.abs(kd) < 1e-12 * (np.abs(L) + kk)) \
        | (L == 0)
    if degenerate.any():
        L = np.where(degenerate, L + 1e-12 * (np.abs(L) + kk) * (1 + 1j), L)
    M = matrix_M(L, kk, p, "waves")
    ks, kd = wavenumbers(L, kk, p.beta)
    with np.errstate(invalid="ignore", divide="ignore"):
        hs, hd, aL = H * np.abs(ks), H * np.abs(kd), np.abs(L)
        phase = np.exp(1j * H * (ks.imag + kd.imag))
        phase = phase * np.where(hs > 0, np.abs(ks) / ks, 1.0)
        phase = phase * np.where(hd > 0, np.abs(kd) / kd, 1.0)
        phase = phase * np.where(aL > 0, aL / L, 1.0) ** SPURIOUS_ORDER_AT_ZERO
        weight = (hs / (1.0 + hs)) * (hd / (1.0 + hd)) \
            * (aL / (aL + kk + 1.0 / H)) ** SPURIOUS_ORDER_AT_ZERO
        return row_normalised_det(M) * phase / weight


@pytest.mark.parametrize("params", [
    dict(bc="velocity"), dict(bc="stress"), dict(bc="stress", alpha_pc=1.0),
    dict(bc="velocity", alpha_ld=0.3), dict(bc="stress", H=0.3, Delta=1.0)])
@pytest.mark.parametrize("k", [0.05, 3.0, 50.0])
def test_det_m_equals_previous_computation(params: dict, k: float, monkeypatch) -> None:
    # the double-precision construction everywhere (next to the origin det_M now takes the
    # determinant in extended precision: tests/test_analytic_finite_h.py)
    monkeypatch.setattr(finite_h, "NEAR_ORIGIN", 0.0)
    p = Params(**params)
    rng = np.random.default_rng(1)
    L = rng.normal(size=300) * 3 + 1j * rng.normal(size=300) * 40
    # removable points (Lambda = 0, k_s = 0, k_d = 0) and a 2-d array
    L = np.concatenate([L, [0.0, 1j * k, -1j * k / p.beta]])
    for z in (L, L[:12].reshape(3, 4), L[0]):
        new, old = finite_h.det_M(z, k, p), det_M_reference(z, k, p)
        assert new.shape == old.shape
        rel = np.abs(new - old) / np.abs(old)
        removable = np.isin(np.asarray(z), L[-3:])
        assert np.all(rel[~removable] <= RTOL)
        assert np.all(rel[removable] <= RTOL_REMOVABLE)


#: Relative difference of the point-by-point path (``_det_M_points``) from the array path, per
#: unit of the partial-wave matrix's condition number: measured at most 2.1e-16 (session 21, the
#: cases below, 4 500 points; median difference 1.3e-15 absolute-relative); 1e-15 allows 4.5x.
RTOL_PER_COND = 1e-15


@pytest.mark.parametrize("params", [
    dict(bc="velocity"), dict(bc="stress"), dict(bc="stress", alpha_pc=1.0),
    dict(bc="velocity", alpha_ld=0.3), dict(bc="stress", H=0.3, Delta=1.0)])
@pytest.mark.parametrize("k", [0.05, 3.0, 50.0])
def test_det_m_point_by_point_equals_the_array_path(params: dict, k: float) -> None:
    """A Newton step's few points go point by point; the same values as the arrays' path."""
    p = Params(**params)
    rng = np.random.default_rng(1)
    L = rng.normal(size=300) * 3 + 1j * rng.normal(size=300) * 40
    arrays = finite_h.det_M(L, k, p)  # 300 points: the array path
    taken = [finite_h._det_M_points(np.array([z]), k, p) is not None for z in L]
    assert sum(taken) >= 299  # at most one point within NEAR_ORIGIN k of 0 here
    points = np.array([finite_h.det_M(z, k, p) for z in L])
    ks, kd = wavenumbers(L, k, p.beta)
    cond = np.linalg.cond(finite_h._waves_matrix(L, k, ks, kd, p))
    assert np.all(np.abs(points - arrays) / np.abs(arrays) <= RTOL_PER_COND * cond)
    # shapes as the array path's: a 0-d array for a scalar, the input's shape otherwise
    assert finite_h.det_M(complex(L[0]), k, p).shape == ()
    assert finite_h.det_M(L[:6].reshape(2, 3), k, p).shape == (2, 3)


@pytest.mark.parametrize("special", ["origin", "near origin", "k_s = 0", "nan"])
def test_det_m_special_points_take_the_array_path(special: str) -> None:
    """Removable points, ``|Lambda| < NEAR_ORIGIN k`` and non-finite values: the arrays' result."""
    p, k = Params(), 3.0
    z = {"origin": 0j, "near origin": 1e-3 + 1e-3j, "k_s = 0": 1j * k,
         "nan": complex("nan")}[special]
    assert finite_h._det_M_points(np.array([z]), k, p) is None
    with np.errstate(invalid="ignore"):  # nan in, nan out
        small = finite_h.det_M(np.array([z, 0.5 + 2j]), k, p)
        big = finite_h.det_M(np.array([z, 0.5 + 2j] + [0.1 + 1j] * 20), k, p)[:2]
    np.testing.assert_array_equal(small[:1], big[:1])


def det4_loop(m: list[list[complex]]) -> complex:
    """``finite_h._det4`` as it was before session 25: the loop over columns."""
    m = [list(r) for r in m]
    d: complex = 1.0
    for j in range(3):
        piv, best = j, abs(m[j][j].real) + abs(m[j][j].imag)
        for i in range(j + 1, 4):
            v = abs(m[i][j].real) + abs(m[i][j].imag)
            if v > best:
                piv, best = i, v
        if piv != j:
            m[j], m[piv] = m[piv], m[j]
            d = -d
        rj = m[j]
        a = rj[j]
        if a == 0:
            return 0j
        d *= a
        for i in range(j + 1, 4):
            ri = m[i]
            f = ri[j] / a
            for c in range(j + 1, 4):
                ri[c] -= f * rj[c]
    return d * m[3][3]


@pytest.mark.parametrize("kind", ["random", "tiny row", "equal pivots", "singular", "waves"])
def test_det4_written_out_equals_the_loop_bit_for_bit(kind: str) -> None:
    """The written-out ``_det4`` takes the loop's pivots and operations: the same bits."""
    rng = np.random.default_rng(7)
    for _ in range(2000):
        a = rng.normal(size=(4, 4)) + 1j * rng.normal(size=(4, 4))
        if kind == "tiny row":
            a[rng.integers(4)] *= 1e-9
        elif kind == "equal pivots":  # ties in |Re| + |Im|: the first row wins in both
            a[:, rng.integers(3)] = rng.choice([1.0, -1.0, 1j, -1j], size=4)
        elif kind == "singular":  # a zero pivot on the way
            a[:, 0] = 0.0
        elif kind == "waves":
            z = complex(rng.normal() * 0.5, rng.normal() * 30)
            k = float(rng.uniform(0.05, 50))
            ks, kd = wavenumbers(z, k, 0.5)
            a = finite_h._waves_matrix(np.asarray(z), k, ks, kd, Params(bc="stress"))
        rows = a.tolist()
        new, old = finite_h._det4(rows), det4_loop(rows)
        assert (new.real, new.imag) == (old.real, old.imag) or (new == old == 0)
