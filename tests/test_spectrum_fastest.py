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


@pytest.mark.parametrize("starts", ["the roots", "moved", "slower only", "wrong"])
@pytest.mark.parametrize("ik", [0, 2])
@pytest.mark.parametrize("case", ["velocity", "stress", "two_body"])
def test_whole_false_gives_the_same_fastest_root(case, ik, starts, count_calls):
    """fastest_in_box(whole=False): the starts' fastest root proven by one count of a band left
    of it when that band holds only roots reached, else the search continues in that band; the
    same root as the whole box's search, a count between 1 and the box's, the root among those
    located. "the roots": the band's roots (one count, measured: every case); "moved": the
    roots at a k 2.5 % lower (the stability map's starts); "slower only": every located root
    but the fastest (the band then holds more than was reached: the bisection goes on);
    "wrong": starts that converge outside the box or nowhere (the whole box is counted).
    """
    kw, ks = CASES[case]
    p, k = Params(**kw), ks[ik]
    box = Region(c_max=4.0, re_min=1e-6).box(p, k)
    ref, n_ref, band = fastest_in_box(p, k, box)
    assert ref is not None  # every case holds an unstable root
    moved = fastest_in_box(p, 0.975 * k, Region(c_max=4.0, re_min=1e-6).box(p, 0.975 * k))[2]
    guess = {"the roots": list(band), "moved": list(moved),
             "slower only": [w for w in band if w != ref] or [ref - 0.05],
             "wrong": [-0.5 + 3j, 5.0 - 900j]}[starts]
    count_calls.clear()
    z, n, located = fastest_in_box(p, k, box, starts=guess, whole=False)
    assert abs(z - ref) <= 1e-13 * abs(ref)  # measured 0 .. 2e-16 (one root, two polishes)
    assert 1 <= n <= n_ref and z in located
    if starts == "the roots":
        assert len(count_calls) == 1
    if starts == "wrong":
        assert n == n_ref  # no root reached: the whole box counted


#: Stability-map steps (stress top, ``Delta = -1``; the previous k's fastest band moved to this
#: k as the map moves it) whose starts reach a slower root only: the band left of it holds the
#: faster one too (session 25's profile of the stress 5 x 5 map: 132 of 625 bands so).
SECOND_CHANCE_CASES = {
    "chain, H = 1": (1.0, 3.979, [0.15 - 17.025j, 0.15 - 21.436j]),
    "chain, H = 0.1": (0.1, 39.79, [1.467 - 170.418j, 1.467 - 214.566j]),
    "lowest resonance": (0.316, 0.5003, [0.17 + 0.414j, 0.17 + 0.522j]),
    "mirror": (0.1, 2.508, [0.454 - 33.203j, 0.454 - 41.804j]),
}


@pytest.mark.parametrize("case", list(SECOND_CHANCE_CASES))
def test_second_chance_reaches_the_faster_root_without_a_search(case, monkeypatch, count_calls):
    """When the band holds more roots than the starts reached, Newton from the reached roots'
    mirrors and neighbouring thickness resonances (``_second_chance``) reaches them all: the
    same fastest root as the whole box's search, proven by the band's one count, and the band
    not searched (no ``zeros_in_box``; before session 25 each such band was scanned and
    bisected, 60 ms on average)."""
    H, k, starts = SECOND_CHANCE_CASES[case]
    p = Params(bc="stress", Delta=-1.0, H=H)
    box = Region(c_max=spectrum.C_LADDER[0], re_min=1e-6).box(p, k)
    ref, n_ref, _ = fastest_in_box(p, k, box)
    searched = []
    monkeypatch.setattr(spectrum, "zeros_in_box",
                        lambda *a, **kw: searched.append(1) or zeros_in_box(*a, **kw))
    count_calls.clear()
    z, n, located = fastest_in_box(p, k, box, starts=starts, whole=False)
    assert abs(z - ref) <= 1e-13 * abs(ref)  # measured 0 .. 2e-16 (one root, two polishes)
    assert not searched and len(count_calls) == 1 and 2 <= n == len(located) <= n_ref


#: Map steps (stress top, ``Delta = -1``) where the guesses reach a faster root but not every
#: root of the band: the band moved up to the fastest root reached closes.
NARROWER_CASES = {
    "H = 1": (1.0, 10.0, [0.176 - 55.693j, 0.176 - 70.120j]),
    "H = 3.16": (3.1623, 3.1623, [0.056 - 17.609j, 0.056 - 22.171j]),
    "H = 0.316": (0.31623, 31.623, [0.557 - 176.123j, 0.557 - 221.749j]),
}


@pytest.mark.parametrize("case", list(NARROWER_CASES))
def test_narrower_band_closes_where_the_guesses_leave_roots(case, monkeypatch, count_calls):
    """The band left of the fastest root the guesses reached (``_narrower_band``) holds only
    roots reached: the same fastest root as the whole box's search, two counts (the first
    band's and this one's), no band searched (session 25: 27 of the 60 bands the guesses left
    open in the stress 5 x 5 map close so)."""
    H, k, starts = NARROWER_CASES[case]
    p = Params(bc="stress", Delta=-1.0, H=H)
    box = Region(c_max=spectrum.C_LADDER[0], re_min=1e-6).box(p, k)
    ref, _, _ = fastest_in_box(p, k, box)
    searched, narrowed = [], []
    monkeypatch.setattr(spectrum, "zeros_in_box",
                        lambda *a, **kw: searched.append(1) or zeros_in_box(*a, **kw))
    real = spectrum._narrower_band
    monkeypatch.setattr(spectrum, "_narrower_band", lambda *a: narrowed.append(1) or real(*a))
    count_calls.clear()
    z, n, located = fastest_in_box(p, k, box, starts=starts, whole=False)
    assert abs(z - ref) <= 1e-13 * abs(ref)  # measured 0 .. 2e-16
    assert narrowed and not searched and len(count_calls) == 2 and n == len(located) >= 1


@pytest.mark.parametrize("case", ["velocity", "stress"])
def test_whole_false_finds_no_root_where_there_is_none(case):
    """A box without roots: whole=False with starts outside it still counts the whole box (a
    zero count is always the box's): root None, count 0."""
    p, k = Params(**CASES[case][0]), 8.0
    box = (1.9, 2.0, -50.0, 50.0)  # far right of every root (the fastest is below 0.4 here)
    z, n, located = fastest_in_box(p, k, box, starts=[0.3 - 20j, 0.2 + 10j], whole=False)
    assert z is None and n == 0 and located == ()


@pytest.mark.parametrize("k0", [1.8, 8.0, 20.0])
@pytest.mark.parametrize("case", ["velocity", "stress"])
def test_family_peak_is_the_family_maximum_on_a_fine_grid(case, k0):
    """family_peak (Brent's bounded search) against the independent way: the same family
    followed over 801 points of ``[k0 / 1.26, 1.26 k0]`` (the stability map's grid ratio) in
    steps of at most 0.05. Every peak here is inside the interval. Its value is at least the
    samples' largest (measured: 5.5e-10 .. 4.9e-7 above it, the peak lies between samples;
    allowed 1e-13 below it, rounding) and its k within two sample spacings of theirs (measured
    at most 0.46)."""
    import numpy as np

    from analytic.numerics.branches import polish_root
    from analytic.numerics.spectrum import family_peak

    p = Params(**CASES[case][0])
    z0, _, _ = fastest_in_box(p, k0, Region(c_max=4.0, re_min=1e-6).box(p, k0))
    lo, hi = k0 / 1.26, 1.26 * k0
    k, z = family_peak(p, k0, z0, lo, hi)
    assert lo <= k <= hi
    assert abs(polish_root(p, k, z).value - z) <= 1e-12 * abs(z)  # a root at k
    grid = np.linspace(lo, hi, 801)
    values = np.empty(grid.size)
    for side in (grid[grid >= k0], grid[grid < k0][::-1]):
        w, kw = z0, k0
        for kk in side:
            n = max(1, int(np.ceil(abs(kk - kw) / 0.05)))
            for i in range(1, n + 1):
                w = polish_root(p, kw + (kk - kw) * i / n, w).value
            kw = kk
            values[np.searchsorted(grid, kk)] = w.real
    j = int(np.argmax(values))
    assert z.real >= values[j] * (1 - 1e-13)
    assert abs(k - grid[j]) <= 2 * (grid[1] - grid[0])
