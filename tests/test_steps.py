"""Step-wise algorithms run one at a time and side by side (analytic.numerics.steps).

The exact root families of a sweep are followed side by side, their determinant calls answered
together (``spectrum.follow_many``); one by one (``spectrum.follow_family``) they make the calls
they made before. Both ways must give the same families: the same labels, flags and checks,
the values to rounding.
"""

import dataclasses

import numpy as np
import pytest

from analytic.numerics.branches import (
    Ask,
    branch_answers,
    branch_answers_all,
    follow_branch,
    follow_branches,
)
from analytic.numerics.roots import (
    point_answers,
    polish,
    polish_steps,
    stencil_request,
    winding_numbers,
)
from analytic.numerics.spectrum import (
    Region,
    certified_roots,
    follow_family,
    follow_many,
    plan_families,
    plan_items,
)
from analytic.numerics.steps import run_many, run_steps
from analytic.params import Params
from analytic.physics.finite_h import det_M

pytestmark = pytest.mark.serial  # numpy only, no MPI


def cubic(c: complex):
    """``z^3 - c``, vectorised."""
    return lambda z: z**3 - c


def all_at_once(requests: list) -> list:
    """Answers to ``(kind, z, c)`` requests of several cubics from one evaluation per kind."""
    return [point_answers(cubic(c))((kind, z)) for kind, z, c in requests]


@pytest.mark.parametrize("width", [1, 2, 16])
@pytest.mark.parametrize("start", [1.0 + 0.3j, -0.7 + 1.1j])
def test_newton_side_by_side_equals_one_at_a_time(width, start):
    cs = [1.0, 2.0 + 1.0j, -3.0, 0.5j, 8.0]
    alone = [polish(cubic(c), start) for c in cs]

    def gen(c):  # the request carries which cubic it is about
        return polish_steps(start, ask=lambda kind, z, c=c: (kind, z, c))

    together = run_many(((i, gen(c)) for i, c in enumerate(cs)), all_at_once, width)
    for i, r in enumerate(alone):
        assert r.converged
        assert together[i].value == r.value and together[i].iterations == r.iterations


def test_run_many_takes_at_most_width_items_at_once():
    taken, running = [], []

    def gen(i):
        running.append(i)
        yield i
        running.remove(i)
        return 2 * i

    def items():
        for i in range(7):
            taken.append(len(running))  # running when the next item is taken
            yield i, gen(i)

    assert run_many(items(), lambda reqs: [None] * len(reqs), width=3) == {
        i: 2 * i for i in range(7)}
    assert max(taken) <= 2  # the 4th item is taken only when one of the first 3 has ended


def test_an_answer_that_raises_is_raised_at_its_request():
    def gen():
        try:
            yield "bad"
        except ZeroDivisionError:
            return "caught where it was asked"
        return "not raised"

    assert run_steps(gen(), lambda req: 1 / 0) == "caught where it was asked"


def test_winding_number_through_the_driver():
    # z^3 - 1: three zeros in the box around the unit circle, one in the right half
    assert winding_numbers(lambda z: (z**3 - 1)[None, :], (-2, 2, -2, 2), 1) == [3]
    assert winding_numbers(lambda z: (z**3 - 1)[None, :], (0.5, 2, -0.5, 0.5), 1) == [1]


#: Families one by one against side by side: the values differ by rounding only, because
#: ``det_M`` rounds its few-point calls differently from its arrays (tests/test_det_m_fast.py):
#: measured at most 2e-15 relative on the stress top's 225 default families and 4e-16 on the
#: velocity top's 37 (120 k, session 37); a continuation that took another step or root
#: would differ by far more than this bound.
ROUNDING = 1e-12


@pytest.mark.parametrize("params", [
    Params(bc="stress"),
    Params(bc="velocity", Delta=-0.3),
    Params(bc="stress", mu2=4.0, rho2=1.0, H2=0.5),  # two bodies: answered one by one
], ids=["stress", "velocity", "two-body"])
def test_families_side_by_side_equal_one_by_one(params):
    ks = np.linspace(0.1, 3.0, 9) if not params.two_body else np.array([0.3, 0.6])
    region = Region(c_max=4.0)
    plan = plan_families(params, region, float(ks[-1]))
    items = plan_items(plan)
    assert len(items) >= 6
    alone = [follow_family(params, plan, it, ks, region) for it in items]
    together = follow_many(params, plan, range(len(items)), ks, region, width=5)
    assert sorted(together) == list(range(len(items)))
    n_values = 0
    for i, a in enumerate(alone):
        b = together[i]
        assert (b.label, b.flag, list(b.ok)) == (a.label, a.flag, list(a.ok))
        assert np.array_equal(np.isfinite(a.Lambda), np.isfinite(b.Lambda))
        m = np.isfinite(a.Lambda)
        n_values += int(m.sum())
        assert np.all(np.abs(a.Lambda[m] - b.Lambda[m])
                      <= ROUNDING * np.maximum(1.0, np.abs(a.Lambda[m])))
    assert n_values >= 20


def test_families_skipped_to_a_lone_far_k_are_traced_back_to_their_seeds():
    """Stress top, paper defaults, the lone k = 26.5 (issue 17's case): four families seeded at
    Re = -0.69 are predicted far below the region from k = 0.04 and skipped, but rise through a
    trapped-wave bump into it. Their roots were left unlabelled ("?", flagged); traced back to
    the seeds they are labelled, certified. Independent: each such family followed forward
    without the skip reaches the same root; with that family left out, its root is not given
    to another one."""
    p, k = Params(bc="stress"), 26.5
    region = Region(c_max=16.0)
    ks = np.array([k])
    plan = plan_families(p, region, k)
    items = plan_items(plan)
    done = follow_many(p, plan, range(len(items)), ks, region)
    fams = [done[i] for i in range(len(items))]
    labelled, _, n = certified_roots(p, k, region, fams)
    assert len(labelled) == n and all(r.certified for r in labelled)
    assert len({r.label for r in labelled}) == n
    skipped = {f.label for f in fams if f.flag[0] == "outside"}
    traced = [r for r in labelled if r.label in skipped]
    assert len(traced) == 4 and max(r.value.real for r in traced) > 0.28
    for r in traced:
        item = next(it for it in items if it[0] == "s" and it[1] == r.label)
        alone = follow_family(p, plan, item, ks)  # no region: never skipped
        # the same root, polished by Newton both ways (measured 8e-19 to 1.9e-16 apart)
        assert abs(alone.Lambda[0] - r.value) < 1e-12 * abs(r.value)
    gone = traced[0].label
    without = certified_roots(p, k, region, [f for f in fams if f.label != gone])[0]
    left = [r for r in without if abs(r.value - traced[0].value) < 1e-12 * abs(r.value)]
    assert len(left) == 1 and left[0].label.startswith("?") and not left[0].certified
    # that family made to reach another root at k instead (a wrong continuation): the traced
    # root keeps the label, not certified, and says why
    other = next(r for r in labelled if r.label not in skipped)
    wrong = [dataclasses.replace(f, Lambda=np.array([other.value]), ok=np.array([True]),
                                 flag=[""]) if f.label == gone else f for f in fams]
    again = certified_roots(p, k, region, wrong)[0]
    mine = next(r for r in again if abs(r.value - traced[0].value) < 1e-12 * abs(r.value))
    assert mine.label == gone and not mine.certified and "reaches another root" in mine.note


@pytest.mark.parametrize("params", [Params(bc="stress"), Params(bc="velocity"),
                                    Params(bc="stress", mu2=4.0, rho2=1.0, H2=0.5)],
                         ids=["stress", "velocity", "two-body"])
def test_follow_branches_side_by_side_equal_one_by_one(params):
    """``follow_branches`` (``python -m analytic branches``) runs its continuations side by side:
    the same labels, flags and ``ok`` as :func:`follow_branch` one by one, the values to
    rounding (measured 2.2e-16 relative on both tops, 120 k, 4 cut-offs: session 38)."""
    ks = np.linspace(0.05, 6.0, 40) if not params.two_body else np.array([0.3, 0.6])
    alone = [follow_branch(params, n, s, ks) for n in range(3) for s in (1, -1)]
    together = follow_branches(params, 3, ks)
    assert [b.label for b in together] == [a.label for a in alone]
    n_values = 0
    for a, b in zip(alone, together, strict=True):
        assert (b.flag, list(b.ok)) == (a.flag, list(a.ok))
        m = np.isfinite(a.Lambda)
        assert np.array_equal(m, np.isfinite(b.Lambda))
        n_values += int(m.sum())
        assert np.all(np.abs(a.Lambda[m] - b.Lambda[m])
                      <= ROUNDING * np.maximum(1.0, np.abs(a.Lambda[m])))
    assert n_values >= 10


#: One request answered together with others against alone: ``det_M``'s array path against its
#: few-point path, rounding only, relative to the function's size (a value, and a derivative
#: times the stencil's step ``h`` over the largest stencil value): measured at most 1.2e-12 on
#: 2 000 random points, ``|Im| <= 60``, ``k <= 8``, both tops (session 37; the 4 x 4 matrix's
#: conditioning). A point or wavenumber mixed up differs at order one.
VALUE_ROUNDING = 1e-10


@pytest.mark.parametrize("bc", ["velocity", "stress"])
def test_requests_answered_together_as_one_by_one(bc):
    p = Params(bc=bc)
    rng = np.random.default_rng(3)
    line = 0.3 + 1j * np.linspace(-20.0, 20.0, 41)
    asks = [Ask("vd", 0.2 - 7.1j, (1.3,), "physical"), Ask("d", 0.1 + 3.0j, (0.4,), "physical"),
            Ask("f", line, (2.0,), "physical"), Ask("f", line[:7], (2.5, 0.7), "physical"),
            Ask("vd", 0.05 + 30.0j, (5.0,), "physical"), Ask("f", rng.normal(size=3) * 5j,
                                                           (0.9, 3.3), "physical")]
    one = branch_answers(p)
    for a, got in zip(asks, branch_answers_all(p)(asks), strict=True):
        want = one(a)
        if a.kind == "f":
            assert np.all(np.abs(got - want) <= VALUE_ROUNDING * np.abs(want)), a
            continue
        pts, h = stencil_request("d", a.z)
        size = np.abs(det_M(pts, a.k[0], p)).max() / h  # the derivative's rounding scale
        (f_got, d_got), (f_want, d_want) = (got, want) if a.kind == "vd" else (
            (0.0, got), (0.0, want))
        assert abs(f_got - f_want) <= VALUE_ROUNDING * abs(f_want), a
        assert abs(d_got - d_want) <= VALUE_ROUNDING * size, a
