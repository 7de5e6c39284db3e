"""Predictors from the linearised condensed form (``CondensedOperator.linear_eigs``).

The default FE-first solver (``CertifiedSolver(solver="linear")``) takes the eigenvalues of one
dense linear eigenproblem of the condensed form (near interior modes and the interface rows,
the far modes as a truncated series), Newton-polishes them on ``T_h``, and keeps them when they
give the argument-principle count; otherwise the contour moments run. The references here are
the moments path (``solver="moments"``) and the count, neither of which uses the linearisation.
Serial and under mpirun -n 2 (the models live on COMM_SELF).
"""

import numpy as np
import pytest

from analytic import Params
from analytic.numerics.spectrum import Region
from forms.solvers import certified, condensed
from forms.solvers.certified import FILL_MAX, CertifiedSolver, _condensed, default_discretisation

#: Same discrete eigenvalue from the two paths (both Newton-polished): measured at most
#: 2.2e-11 relative over the default stress sweep (1 805 eigenvalues, 2026-11-28).
SAME_VALUE_RTOL = 1e-10
#: Predictor against its polished value: measured at most 1.4e-11 relative over the cases
#: below (P4, 2026-11-28); the truncation of the far modes' series is LIN_EPS = 1e-8.
PREDICTOR_RTOL = 1e-8

CASES = {
    "velocity": (Params(), 3.0, 4.0),
    "stress": (Params(bc="stress"), 3.0, 16.0),
    "alpha_pc": (Params(alpha_pc=1.0), 3.0, 4.0),  # T_h of degree 4 in Lambda
    "two_body": (Params(mu2=4.0, rho2=1.0, H2=0.5), 2.0, 4.0),
}


def _solver(p, region, k, solver):
    deg, cells, ratio = default_discretisation(p, region, k, 1e-8)
    return CertifiedSolver(p, region, deg, cells, ratio, k, 1e-8, check_exact=False,
                           solver=solver)


def _moments_and_linear(p, region, k):
    """The certified results at ``k`` of ``solver="moments"`` and ``solver="linear"``."""
    out = []
    for solver in ("moments", "linear"):
        s = _solver(p, region, k, solver)
        try:
            out.append(s.solve(k))
        finally:
            s.destroy()
    return out


def _values(res):
    return np.array(sorted((complex(r["re_lambda"], r["im_lambda"]) for r in res.rows),
                           key=lambda z: (z.imag, z.real)))


@pytest.mark.parametrize("case", list(CASES))
def test_linear_gives_the_moments_rows(case):
    p, k, c_max = CASES[case]
    region = Region(c_max=c_max)
    a, b = _moments_and_linear(p, region, k)
    assert a.closed and b.closed and a.n_fe == b.n_fe == len(b.rows) > 0
    assert b.note == ""  # the linearised predictors gave the count: no moments ran
    va, vb = _values(a), _values(b)
    assert np.max(np.abs(va - vb) / np.abs(va)) < SAME_VALUE_RTOL
    assert [r["status"] for r in b.rows] == ["ok"] * len(b.rows)


@pytest.mark.parametrize("case", list(CASES))
def test_predictors_are_near_the_polished_values(case):
    p, k, c_max = CASES[case]
    region = Region(c_max=c_max)
    s = _solver(p, region, k, "linear")
    try:
        op = s.banded[0].operator(k)
        cond = _condensed(op, s._condensed_model(), k)
        box = region.box(p, k)
        n, _ = cond.count_and_samples(box)
        lam, vecs = cond.linear_eigs(box)
        before = op.factorizations
        found = op.polish(lam, vecs, tuple(box), exact_start=True)
        steps = op.factorizations - before
    finally:
        s.destroy()
    assert len(found) == n > 0 and vecs.shape == (op.n, lam.size)
    for e in found:
        assert np.min(np.abs(lam - e.value)) <= PREDICTOR_RTOL * abs(e.value)
    # one Newton step each (the first step's rule): a factorisation per predictor
    assert steps == lam.size


@pytest.mark.filterwarnings("ignore:invalid value:RuntimeWarning")  # Newton from a zero vector
@pytest.mark.parametrize("fill", [np.nan, 0.0])
def test_a_poor_predicted_vector_is_replaced_by_inverse_iteration(fill, monkeypatch):
    """Where ``T_II(z)`` is nearly singular (a mode that hardly moves the interface, seen at
    ``|Im| ~ 800`` on the stress top's 12 ``c_d`` rung at ``k = 41.6``) the predicted vector
    is useless: Newton then starts by inverse iteration, and no moments are needed."""
    p, k, c_max = CASES["stress"]
    region = Region(c_max=c_max)
    orig = condensed.CondensedOperator.linear_eigs

    def no_vectors(self, box, *args, **kwargs):
        lam, vecs = orig(self, box, *args, **kwargs)
        return lam, np.full_like(vecs, fill)  # not finite, or a Newton that breaks down

    monkeypatch.setattr(condensed.CondensedOperator, "linear_eigs", no_vectors)
    a, b = _moments_and_linear(p, region, k)
    assert b.closed and b.note == "" and b.n_fe == a.n_fe == len(b.rows) > 0
    va, vb = _values(a), _values(b)
    assert np.max(np.abs(va - vb) / np.abs(va)) < SAME_VALUE_RTOL


@pytest.mark.parametrize("how", ["pencil too large", "a predictor lost"])
def test_moments_take_over_when_the_linearisation_falls_short(how, monkeypatch):
    p, k, c_max = CASES["stress"]
    region = Region(c_max=c_max)
    if how == "pencil too large":
        monkeypatch.setattr(condensed, "LIN_MAX", 10)
    else:
        orig = condensed.CondensedOperator.linear_eigs

        def lose_one(self, box, *args, **kwargs):
            lam, vecs = orig(self, box, *args, **kwargs)
            keep = np.argsort(lam.real)[:-1]  # the fastest predictor is lost
            return lam[keep], vecs[:, keep]

        monkeypatch.setattr(condensed.CondensedOperator, "linear_eigs", lose_one)
    a, b = _moments_and_linear(p, region, k)
    assert b.closed and b.n_fe == a.n_fe == len(b.rows)
    expect = "LIN_MAX" if how == "pencil too large" else f"gave {b.n_fe - 1} of {b.n_fe}"
    assert expect in b.note and "moments" in b.note
    va, vb = _values(a), _values(b)
    assert np.max(np.abs(va - vb) / np.abs(va)) < SAME_VALUE_RTOL


def _followed(p, region, ks, monkeypatch=None, lose=0):
    """``follow=True`` solves at ``ks`` on one solver; the last one's predictors may lose the
    ``lose`` fastest."""
    s = _solver(p, region, ks[-1], "linear")
    if lose:
        orig = CertifiedSolver.predictors

        def lose_fastest(self, k):
            pred = orig(self, k)
            if pred is None or k != ks[-1]:
                return pred
            keep = np.argsort(pred[0].real)[:-lose]  # the fastest eigenvalues' are lost
            return pred[0][keep], pred[1][:, keep]

        monkeypatch.setattr(CertifiedSolver, "predictors", lose_fastest)
    try:
        return [s.solve(k, follow=True) for k in ks]
    finally:
        s.destroy()


@pytest.mark.parametrize("case", list(CASES))
def test_a_followed_sweep_finds_the_same_eigenvalues_by_continuation(case):
    """The FE's own eigenpairs of the previous ``k`` (extrapolated in ``k``) are the
    predictors: after the first two ``k`` (an extrapolation needs two) no linearisation is
    needed where no eigenvalue enters the region (steps of 0.01 here; on the stress top's 16
    ``c_d`` box one enters between ``k = 2.9`` and 3), and the values are the linearised
    path's at every ``k``."""
    p, k, c_max = CASES[case]
    region = Region(c_max=c_max)
    ks = [k - 0.03, k - 0.02, k - 0.01, k]
    followed = _followed(p, region, ks)
    assert [r.found_by for r in followed] == ["linearised"] * 2 + ["continuation"] * 2
    for kk, res in zip(ks, followed, strict=True):
        s = _solver(p, region, ks[-1], "linear")
        try:
            alone = s.solve(kk)
        finally:
            s.destroy()
        assert alone.found_by == "linearised" and res.closed
        assert res.n_fe == alone.n_fe == len(res.rows) > 0
        va, vb = _values(alone), _values(res)
        assert np.max(np.abs(va - vb) / np.abs(va)) < SAME_VALUE_RTOL


@pytest.mark.parametrize("lose", [1, FILL_MAX, FILL_MAX + 1])
@pytest.mark.parametrize("case", ["velocity", "stress"])
def test_lost_continued_predictors_are_found_by_the_count(case, lose, monkeypatch):
    """The count, not the predictors, decides: up to FILL_MAX predictors short, the count's
    power sums predict the missing eigenvalues (``missing_roots``) and the continuation
    closes; one more, the linearised eigenproblem runs and finds them. Either way the values
    are the linearised path's."""
    p, k, c_max = CASES[case]
    region = Region(c_max=c_max)
    ks = [k - 0.03, k - 0.02, k - 0.01, k]
    lost = _followed(p, region, ks, monkeypatch, lose=lose)
    assert lost[2].found_by == "continuation"
    assert lost[-1].found_by == ("continuation" if lose <= FILL_MAX else "linearised")
    assert lost[-1].closed and lost[-1].n_fe == len(lost[-1].rows) > 0
    _, alone = _moments_and_linear(p, region, k)
    va, vb = _values(alone), _values(lost[-1])
    assert np.max(np.abs(va - vb) / np.abs(va)) < SAME_VALUE_RTOL


def test_predictors_gone_astray_pause_the_continuation(monkeypatch):
    """Predictors that end on the same eigenvalue (all of them copies of one here, as on a
    grid too coarse for the extrapolation) lose the others: the linearisation finds them, and
    the next FOLLOW_PAUSE solves try no continuation (then it resumes)."""
    p, k, c_max = CASES["velocity"]
    region = Region(c_max=c_max)
    ks = [k + 0.01 * i for i in range(5 + certified.FOLLOW_PAUSE)]
    orig = CertifiedSolver.predictors

    def astray(self, kk):
        pred = orig(self, kk)
        if pred is None or kk != ks[3]:
            return pred
        return np.full_like(pred[0], pred[0][0]), np.repeat(pred[1][:, :1], pred[0].size, 1)

    monkeypatch.setattr(CertifiedSolver, "predictors", astray)
    res = _followed(p, region, ks)
    assert [r.found_by for r in res] == (["linearised"] * 2 + ["continuation", "linearised"]
                                         + ["linearised"] * certified.FOLLOW_PAUSE
                                         + ["continuation"])
    assert all(r.closed and r.n_fe == len(r.rows) > 0 for r in res)


def test_no_continuation_farther_than_its_reach():
    """A ``k`` more than FOLLOW_REACH times the last spacing away (``--k 50,51``-like jumps)
    is not continued: the extrapolation would be a guess."""
    p, k, c_max = CASES["velocity"]
    ks = [k - 0.02, k - 0.01, k + 0.005, k + 0.005 + 3 * 0.015]  # 1.5x, then 3x the spacing
    res = _followed(p, Region(c_max=c_max), ks)
    assert [r.found_by for r in res] == ["linearised", "linearised", "continuation",
                                         "linearised"]
