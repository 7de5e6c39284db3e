import math

import numpy as np
import pytest
import scipy.linalg

from analytic.numerics.branches import follow_branch, polish_root, roots_in_box
from analytic.numerics.roots import count_zeros, polish
from analytic.params import ParameterError, Params
from analytic.physics import finite_h
from analytic.physics.finite_h import (
    cutoff,
    det_M,
    det_M_even,
    det_M_waves,
    spectrum_S,
)

# Pure numpy (no MPI, no FE): the serial pass is enough.
pytestmark = pytest.mark.serial

CHECK_VALUE = 0.2716852879456 - 6.5866951866228j  # docs/design.md section 4


def test_design_check_value_by_continuation_from_cutoff():
    b = follow_branch(Params(), 0, -1, [1.0])
    assert b.label == "0-"
    assert b.k_path[0] == 0.0 and b.Lambda_path[0] == cutoff(0, -1, Params())
    assert b.ok[0], b.note
    # measured 3.5e-15 on 2026-11-21
    assert abs(b.Lambda[0] - CHECK_VALUE) / abs(CHECK_VALUE) < 1e-12
    assert b.residual[0] < 1e-13


PARAM_SETS = [
    dict(),
    dict(H=2.0, beta=0.4),
    dict(f=0.6, gamma=1.0, Delta=0.2, beta=0.3, H=1.0),
    dict(Delta=-0.5, gamma=10.0, H=0.3),
    dict(alpha_pc=0.3, alpha_ld=0.5, beta=0.45),
]
BOXES = [(-1.0, 1.0, -12.0, -3.0), (-1.0, 1.0, 2.0, 9.0)]


def _roots(p, k, box):
    return [r.value for r in roots_in_box(p, k, box)]


@pytest.mark.parametrize("box", BOXES)
@pytest.mark.parametrize("kw", PARAM_SETS)
def test_det_M_zeros_are_the_closed_form_zeros(kw, box):
    """All roots of det_M in a box are roots of the paper's S, and of the two other bases."""
    p = Params(**kw)
    k = 0.8
    roots = _roots(p, k, box)
    assert roots, "no roots in the box: the test would be empty"
    for z in roots:
        for other in (spectrum_S, det_M_even, det_M_waves):
            r = polish(lambda L, f=other: f(L, k, p), z)
            assert r.converged, (other.__name__, r.reason)
            # measured <= 3.5e-16 on 2026-11-21 (32 roots: 5 parameter sets, both boxes)
            assert abs(r.value - z) / abs(z) < 1e-12, other.__name__


def _propagator_det(L, k, p):
    """Independent formulation: first-order ODE w' = A w for w = (u_x, u_y, s_xy, s_yy)."""
    lam = p.lame_lambda
    ik = 1j * k
    A = np.array([
        [0, ik, 1, 0],
        [ik * lam / (lam + 2), 0, 0, 1 / (lam + 2)],
        [L * L + k * k * (lam + 2) - k * k * lam * lam / (lam + 2), 0, 0, ik * lam / (lam + 2)],
        [0, L * L, ik, 0],
    ], dtype=complex)
    T = scipy.linalg.expm(-A * p.H)  # w(0) = T w(H)
    free = [1, 2] if p.bc == "velocity" else [0, 1]  # velocity: u_x = s_yy = 0 on top
    # the friction law of docs/design.md section 3 times (L + 1), written here independently
    a = (1 + p.alpha_pc * L) * (L + 1)
    b = p.f * (L + 1) - p.alpha_ld * L
    c = -L * (L + p.Delta) / p.gamma
    bottom = np.array([[0, 1, 0, 0], [complex(c), 0, complex(a), complex(b)]])
    return np.linalg.det(bottom @ T[:, free])


@pytest.mark.parametrize("bc", ["velocity", "stress"])
@pytest.mark.parametrize("kw", [dict(), dict(H=1.3, beta=0.35, alpha_pc=0.2, alpha_ld=0.1)])
def test_det_M_against_independent_propagator(bc, kw):
    p = Params(bc=bc, **kw)
    k = 1.1
    roots = _roots(p, k, (-1.5, 1.5, -15.0, -1.0))
    assert len(roots) >= 2
    for z in roots:
        r = polish(np.vectorize(lambda L: _propagator_det(L, k, p)), z, scale=1.0)
        # measured <= 4.1e-16 on 2026-11-21 (24 roots; scipy expm, H <= 1.3)
        assert abs(r.value - z) / abs(z) < 1e-11


def test_no_overflow_at_large_kH():
    p = Params(H=0.5)
    k = 400.0  # kH = 200
    vals = det_M(np.array([0.3 - 800j, 5 + 5j, -3 - 100j]), k, p)
    assert np.all(np.isfinite(vals)) and np.all(np.abs(vals) > 0)
    roots = _roots(p, k, (-3.0, 3.0, -805.0, -795.0))
    assert roots
    for z in roots:
        r = polish(lambda L: spectrum_S(L, k, p), z)
        # measured 1.4e-16 on 2026-11-21
        assert abs(r.value - z) / abs(z) < 1e-12


def test_det_M_is_single_valued_across_the_cuts():
    p = Params()
    for y in (3.0, -5.0, 7.5):  # imaginary axis beyond +-ik: the cut of the principal sqrt
        a = det_M(1e-10 + 1j * y, 1.0, p)
        b = det_M(-1e-10 + 1j * y, 1.0, p)
        # continuous: differs by O(1e-10 * derivative); measured 5e-10
        assert abs(a - b) < 1e-7 * abs(a)
    w1 = det_M_waves(1e-10 + 3j, 1.0, p)
    w2 = det_M_waves(-1e-10 + 3j, 1.0, p)
    assert abs(w1 - w2) > 0.1 * abs(w1)  # the literal partial-wave determinant jumps


@pytest.mark.parametrize("bc", ["velocity", "stress"])
def test_cutoff_is_a_simple_zero_at_small_k(bc):
    p = Params(bc=bc, beta=0.37, H=0.8)
    k = 1e-6
    for n in (0, 1):
        for sign in (1, -1):
            L0 = cutoff(n, sign, p)
            r = 1e-3 * abs(L0)
            assert count_zeros(lambda L, k=k: det_M(L, k, p),
                               (L0.real - r, L0.real + r, L0.imag - r, L0.imag + r)) == 1


def test_polish_root_from_rough_guess():
    r = polish_root(Params(), 1.0, 0.2 - 6.4j)
    assert r.converged
    assert abs(r.value - CHECK_VALUE) < 1e-12


@pytest.mark.parametrize(
    "call,needle",
    [
        (lambda: det_M(1j, 1.0, Params(H=math.inf)), "H"),
        (lambda: cutoff(-1, 1, Params()), "n"),
        (lambda: cutoff(0, 2, Params()), "sign"),
        (lambda: follow_branch(Params(), 0, -1, [1.0, 0.0]), "k"),
        (lambda: follow_branch(Params(), 0, -1, [math.nan]), "k"),
        (lambda: spectrum_S(1j, 1.0, Params(bc="stress")), "bc"),
    ],
)
def test_bad_input_is_named(call, needle):
    with pytest.raises(ParameterError, match=needle):
        call()


def test_stress_top_grows_slower_than_velocity_top():
    """Paper, Appendix B (Fig. stress-controlled, gamma f = 0.9, n = 0): same shape, lower."""
    ks = np.linspace(0.2, 4.0, 12)
    peak = {}
    for bc in ("velocity", "stress"):
        b = follow_branch(Params(bc=bc), 0, -1, ks)
        assert b.ok.all(), b.note
        assert (b.Lambda.real[:6] > 0).all()  # unstable at small kH for both tops
        peak[bc] = b.Lambda.real.max()
    # measured 2026-11-21: peaks 0.325 (velocity) and 0.133 (stress) on this grid
    assert peak["stress"] < 0.6 * peak["velocity"]


def _jump(p: Params, re: float, k: float) -> float:
    """How far det_M at ``re + 0i`` stands out from its neighbours ``|Im| <= 1e-4``."""
    y = np.linspace(-1e-4, 1e-4, 9)
    f = np.abs(det_M(re + 1j * y, k, p))
    return abs(f[4] / np.median(np.delete(f, 4)) - 1.0)


#: The stability map's edge Re Lambda = 1e-6 and its nudged copies.
EDGES = (0.97e-6, 1e-6, 1.03e-6, 1.3e-6)


def test_det_m_next_to_the_origin_in_double_precision_fails_at_large_k(monkeypatch):
    """The reason for the stability map's failed counts at H = 0.1, k = 100 before session 12:
    in double precision det_M at Lambda = 1e-6 + 0i stood out from its neighbours by 1e-4 ..
    7e-4 at k = 1 and by a factor of 2 .. 9 at k = 100 (k_s and k_d round to k; the columns
    cancel). Measured with the near-origin path switched off."""
    monkeypatch.setattr(finite_h, "NEAR_ORIGIN", 0.0)
    p = Params(H=0.1, Delta=-1.0)
    assert max(_jump(p, a, 1.0) for a in EDGES) < 1e-2
    assert min(_jump(p, a, 100.0) for a in EDGES) > 0.5


@pytest.mark.parametrize("params", [dict(H=0.1, Delta=-1.0), dict(bc="stress"),
                                    dict(bc="stress", alpha_pc=1.0), dict(alpha_ld=0.3)])
def test_det_m_next_to_the_origin_is_smooth_and_continuous(params, monkeypatch):
    """With the divided-difference determinant for ``|Lambda| < NEAR_ORIGIN k`` (extended
    precision, mpmath, in session 12) the same edges are smooth: the value at Im = 0 within
    8.2e-5 of its neighbours' over these four parameter sets (session 13; that is the function's
    own variation over |Im| <= 1e-4: the path equals an mpmath determinant to 5e-15, below),
    against a factor of 2-9 in plain double precision; and at ``|Lambda| = 0.9 NEAR_ORIGIN k``,
    where double precision is still accurate, the two computations agree (measured: at most
    2.9e-10 relative, k = 0.05 .. 100)."""
    p = Params(**params)
    for k in (1.0, 10.0, 100.0):
        assert max(_jump(p, a, k) for a in EDGES) < 1e-4
    for k in (0.05, 1.0, 10.0, 100.0):
        L = 0.9 * finite_h.NEAR_ORIGIN * k * np.exp(1j * np.linspace(0.0, 2 * np.pi, 13))
        extended = det_M(L, k, p)
        monkeypatch.setattr(finite_h, "NEAR_ORIGIN", 0.0)
        double = det_M(L, k, p)
        monkeypatch.undo()
        assert np.max(np.abs(extended - double) / np.abs(double)) < 1e-9


def _det_extended(L: complex, k: float, p: Params) -> complex:  # noqa: N803
    """``row_normalised_det`` of the partial-wave matrix at one point, the determinant in mpmath.

    An independent reference for det_M next to the origin (det_M's own path there before
    session 13): the elastic entries from ``L`` with ``30 + 4 log10(k/|L|)`` digits (the
    partial-wave pairs cancel by about four decades per decade of ``k/|L|``), the friction
    coefficients in double precision (the determinant is linear in that row), the row norms of
    the double-precision matrix.
    """
    import mpmath

    from analytic.law import FrictionLaw

    ks0, kd0 = finite_h.wavenumbers(np.array(L), k, p.beta)
    M = finite_h._waves_matrix(np.array(L), k, ks0, kd0, p)  # noqa: N806
    dps = int(30 + 4 * math.log10(max(k / abs(L), 10.0)))
    with mpmath.workdps(dps):
        Lm, km, H = mpmath.mpc(L), mpmath.mpf(k), mpmath.mpf(p.H)  # noqa: N806
        ks = mpmath.sqrt(Lm * Lm + km * km)
        kd = mpmath.sqrt(mpmath.mpf(p.beta) ** 2 * Lm * Lm + km * km)
        es, ed = mpmath.exp(-H * ks), mpmath.exp(-H * kd)
        P = Lm * Lm + 2 * km * km  # noqa: N806
        j = mpmath.mpc(0, 1)
        vt = [es, j * ed, mpmath.mpf(1), j]
        dt = [-ks * es, -j * kd * ed, ks, j * kd]
        swap = [2, 3, 0, 1]
        vb, db = [vt[c] for c in swap], [-dt[c] for c in swap]
        a, b, c = (mpmath.mpc(complex(x)) for x in
                   np.ravel(FrictionLaw.from_params(p).row(np.array(L))))
        rows = [[None] * 4 for _ in range(4)]
        for col in range(4):
            psi = col % 2 == 0
            if p.bc == "velocity":  # u_x at the top
                rows[0][col] = dt[col] if psi else -j * km * vt[col]
            else:  # s_xy at the top
                rows[0][col] = P * vt[col] if psi else -2 * j * km * dt[col]
            rows[1][col] = 2 * j * km * dt[col] if psi else P * vt[col]  # s_yy at the top
            rows[2][col] = j * km * vb[col] if psi else db[col]  # u_y at the bottom
            if psi:  # friction at the bottom: a s_xy + b s_yy + c u_x
                rows[3][col] = a * (P * vb[col]) + b * (2 * j * km * db[col]) + c * db[col]
            else:
                rows[3][col] = a * (-2 * j * km * db[col]) + b * (P * vb[col]) \
                    + c * (-j * km * vb[col])
        det = complex(mpmath.det(mpmath.matrix(rows)))
    norms = np.sqrt(np.add.reduce((M.conj() * M).real, axis=-1))
    return det / float(np.multiply.reduce(norms))


@pytest.mark.parametrize("params", [dict(H=0.1, Delta=-1.0), dict(bc="stress"),
                                    dict(bc="stress", alpha_pc=1.0), dict(alpha_ld=0.3),
                                    dict(bc="stress", H=3.0, beta=0.3)])
@pytest.mark.parametrize("k", [0.05, 1.0, 100.0])
def test_det_m_next_to_the_origin_equals_the_extended_precision_determinant(params, k):
    """det_M's divided-difference path (|Lambda| < NEAR_ORIGIN k, 1e-9 k .. 0.01 k in every
    direction, and the stability map's edge Re = 1e-6 next to Im = 0) against the determinant
    in mpmath: measured at most 5.4e-15 relative (session 13, five parameter sets, k = 0.05 ..
    100); the plain double-precision determinant is off by up to a factor of 9 there (above)."""
    p = Params(**params)
    rng = np.random.default_rng(3)
    L = k * 10 ** rng.uniform(-9, math.log10(0.99 * finite_h.NEAR_ORIGIN), 12) \
        * np.exp(1j * rng.uniform(0, 2 * np.pi, 12))
    L = np.concatenate([L, 1e-6 + 1j * np.linspace(-1e-4, 1e-4, 5)])
    ks, kd = finite_h.wavenumbers(L, k, p.beta)
    got = finite_h._det_near_origin(L, np.full(L.shape, k), ks, kd,
                                    finite_h._waves_matrix(L, k, ks, kd, p), p)
    ref = np.array([_det_extended(z, k, p) for z in L])
    assert np.max(np.abs(got - ref) / np.abs(ref)) < 2e-14
