"""The fastest-first search (analytic.numerics.spectrum.fastest_in_box) against every root.

The search counts the whole box, then narrows a band below ``re_max`` by counts and locates only
that band's roots. Checked here against the independent way: every root of the box located and
polished (``zeros_in_box`` on the whole box), the fastest taken from them.
"""

from __future__ import annotations

import pytest

from analytic.numerics import spectrum
from analytic.numerics.branches import _n_initial, spectrum_function
from analytic.numerics.roots import zeros_in_box
from analytic.numerics.spectrum import BAND_ROOTS, LOCATE_ALL, Region, fastest_in_box
from analytic.params import Params

pytestmark = pytest.mark.serial

#: Parameters and the k of each case (two bodies: 43 roots at k = 20, whose whole-box search
#: alone takes 10-40 s here, so smaller k).
CASES = {
    "velocity": ({"bc": "velocity"}, (0.5, 8.0, 20.0)),
    "stress": ({"bc": "stress"}, (0.5, 8.0, 20.0)),
    "two_body": ({"mu2": 4.0, "rho2": 1.0, "H2": 0.5}, (0.5, 1.0, 2.0)),
}


@pytest.mark.parametrize("ik", [0, 1, 2])
@pytest.mark.parametrize("case", ["velocity", "stress", "two_body"])
@pytest.mark.parametrize("re_min", [1e-6, 0.3])
def test_fastest_in_box_equals_the_fastest_of_every_root(case, ik, re_min):
    kw, ks = CASES[case]
    p, k = Params(**kw), ks[ik]
    box = Region(c_max=4.0, re_min=re_min).box(p, k)
    every = zeros_in_box(spectrum_function(p, k), box, n_initial=_n_initial(p, box))
    z, n, located = fastest_in_box(p, k, box)
    assert n == len(every)
    assert (z in located) if every else located == ()
    if not every:
        assert z is None
        return
    best = max(every, key=lambda r: r.value.real).value
    # both are the same root polished from different starts: measured 0 .. 2.4e-16 relative
    assert abs(z - best) <= 1e-13 * abs(best)


def test_only_the_band_is_located_at_large_k(monkeypatch):
    """At k = 20 (velocity top, 18 roots) only a band of at most BAND_ROOTS roots is located."""
    totals = []

    def recording(*args, **kwargs):
        totals.append(kwargs.get("total"))
        return zeros_in_box(*args, **kwargs)

    monkeypatch.setattr(spectrum, "zeros_in_box", recording)
    p = Params()
    z, n, _ = fastest_in_box(p, 20.0, Region(c_max=4.0, re_min=1e-6).box(p, 20.0))
    assert n > LOCATE_ALL
    assert totals and all(t is not None and 1 <= t <= BAND_ROOTS for t in totals)


@pytest.mark.parametrize("hint", ["none", "good", "bad"])
def test_a_hint_gives_the_same_root_with_fewer_counts(hint, count_calls):
    """fastest_in_box(hint=...): velocity top, k = 20 (18 roots): the same root whatever the
    hint; the counts (the box's and the bisection's; measured: 6 without a hint, 3 with the
    root's own Re, 10 with 1.9, far above it)."""
    p, k = Params(), 20.0
    box = Region(c_max=4.0, re_min=1e-6).box(p, k)
    ref, n_ref, _ = fastest_in_box(p, k, box)
    count_calls.clear()
    guess = {"none": None, "good": ref.real, "bad": 1.9}[hint]
    z, n, _ = fastest_in_box(p, k, box, guess)
    assert n == n_ref and abs(z - ref) <= 1e-13 * abs(ref)
    if hint == "good":
        assert len(count_calls) <= 3


@pytest.mark.parametrize("starts", ["none", "the roots", "moved", "wrong", "one of two"])
@pytest.mark.parametrize("case", ["velocity", "stress"])
def test_starts_give_the_same_root_and_spare_the_scan(case, starts, monkeypatch):
    """fastest_in_box(starts=...): the band's roots from Newton's starts when they reach all of
    them (no scan), else the search as without them; the same root and count either way.

    k = 20 (the band of the fastest root at most BAND_ROOTS of 18 or more); "moved": the roots
    at k = 19.5 (what the stability map passes: the last k's located roots); "wrong": starts
    that converge to roots outside the band or nowhere; "one of two": a band of two roots and
    only one start (the count says one is missing: scanned).
    """
    from analytic.numerics import roots

    p, k = Params(**CASES[case][0]), 20.0
    box = Region(c_max=4.0, re_min=1e-6).box(p, k)
    ref, n_ref, band = fastest_in_box(p, k, box)
    scans: list[int] = []
    real = roots._scan

    def scanning(*args, **kwargs):
        scans.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(roots, "_scan", scanning)
    if starts == "one of two" and len(band) < 2:
        pytest.skip(f"the {case} band at k = 20 holds one root")
    guess = {"none": [], "the roots": list(band),
             "moved": list(fastest_in_box(p, 19.5, Region(c_max=4.0, re_min=1e-6)
                                          .box(p, 19.5))[2]),
             "wrong": [-0.5 + 3j, 5.0 - 900j, complex(ref.real, -ref.imag)],
             "one of two": list(band[:1])}[starts]
    scans.clear()
    z, n, located = fastest_in_box(p, k, box, starts=guess)
    assert n == n_ref and abs(z - ref) <= 1e-13 * abs(ref)
    assert sorted(located, key=abs) == pytest.approx(sorted(band, key=abs), rel=1e-13)
    if starts == "the roots":
        assert not scans  # every root of the band reached from its start
    if starts in ("none", "wrong", "one of two"):
        assert scans or len(band) == 1  # one root: polished from the band's centre first
