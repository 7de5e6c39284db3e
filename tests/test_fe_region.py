"""The FE climbs its own region: :func:`forms.studies.sweep.climb` and the scene without analytic.

The FE-first sweep decides how far the region grows from its own eigenvalues (the tail bound of
``analytic.physics.tail`` against the fastest FE value of each rung); the exact roots, when
consulted, only referee the bound (``summary.json`` ``region.exact_disagrees_at_k``).
"""

import json
import os

import pytest
from test_fe_first import NO_EXACT, SAME_VALUE_RTOL, _read, _scene, _values

from analytic import Params
from analytic.numerics.spectrum import C_LADDER, Region
from analytic.physics.tail import tail_bound
from forms.solvers.certified import KResult
from forms.studies import sweep

#: NO_EXACT, and the exact region search of the sweep made unavailable too.
NO_EXACT_REGION = NO_EXACT + """
for _n in ("fastest_mode", "region_at_k", "regions_at_k"):
    setattr(W, _n, _no)
"""


class _Fake:
    """A stand-in for a rung's CertifiedSolver: its fastest Re Lambda is ``fastest[c]``.

    Nested like a spectrum: the solve of rung ``c`` returns, for every rung ``b <= c``, a row
    of ``Re = fastest[b]`` just inside ``W(b)``, so that the rows of a larger rung say what a
    smaller one holds."""

    def __init__(self, fastest: dict, calls: list, p: Params | None = None) -> None:
        self.fastest, self.calls, self.p = fastest, calls, p or Params()

    def __call__(self, c: float, k: float | None = None) -> "_Fake":
        self.c = c
        return self

    def solve(self, k: float, fams: list, region: Region, *, follow: bool = False) -> KResult:
        self.calls.append(region.c_max)
        rows = [{"re_lambda": self.fastest[b],
                 "im_lambda": 0.99 * region.fixed(b).im_max(self.p, k)}
                for b in self.fastest if b <= region.c_max and self.fastest[b] is not None]
        return KResult(k, rows, closed=True)


@pytest.mark.serial  # pure numpy
@pytest.mark.parametrize("k", [2.0, 6.0])
@pytest.mark.parametrize("bc", ["velocity", "stress"])
def test_climb_accepts_the_first_rung_whose_tail_bound_is_below_the_fe_value(bc, k):
    p, region = Params(bc=bc), Region(c_max=None)
    tb = {c: tail_bound(p, k, region.fixed(c).im_max(p, k)) for c in C_LADDER}
    # a fastest value just below the tail bound of the first two rungs, above that of the third
    fast = 0.5 * (tb[C_LADDER[1]] + tb[C_LADDER[2]])
    assert tb[C_LADDER[2]] < fast < tb[C_LADDER[1]]
    calls: list = []
    res, c, _ = sweep.climb(p, region, k, [], _Fake({c: fast for c in C_LADDER}, calls, p))
    assert c == C_LADDER[2] and max(r["re_lambda"] for r in res.rows) == fast
    assert calls[-1] == C_LADDER[2] and calls[0] == C_LADDER[0]
    # nothing in any rung: the region's re_min decides
    calls.clear()
    res, c, _ = sweep.climb(p, region, k, [], _Fake({c: None for c in C_LADDER}, calls, p))
    assert tail_bound(p, k, region.fixed(c).im_max(p, k)) < region.re_min or c == C_LADDER[-1]
    # a fixed region is solved once
    calls.clear()
    sweep.climb(p, Region(c_max=6.0), k, [], _Fake({6.0: -1.0}, calls, p))
    assert calls == [6.0]


@pytest.mark.serial  # pure numpy
@pytest.mark.parametrize("k", [2.0, 6.0])
@pytest.mark.parametrize("bc", ["velocity", "stress"])
@pytest.mark.parametrize("start", [1, 2, 4])
def test_a_warm_climb_accepts_the_cold_climbs_rung(bc, k, start):
    """climb(start=c): the rung the cold climb accepts (here C_LADDER[2]), from a warm start
    below it, at it or above it; solved: the start and the rung accepted (and any rung between
    them climbed through), never the rungs below the start that it only reads."""
    p, region = Params(bc=bc), Region(c_max=None)
    tb = {c: tail_bound(p, k, region.fixed(c).im_max(p, k)) for c in C_LADDER}
    fast = 0.5 * (tb[C_LADDER[1]] + tb[C_LADDER[2]])
    # the fastest value grows at rung 2 (a faster root beyond W of rung 1, none beyond rung 2),
    # and the slower one of rungs 0, 1 is still above rung 2's bound: the cold climb solves
    # rung 0, skips rung 1 and accepts rung 2. Beyond rung 3 a root faster than every bound: a
    # warm start there that read its fastest value without the |Im| <= W(c) filter would accept
    # rung 0
    slower = 0.5 * (tb[C_LADDER[2]] + fast)
    fastest = {c: slower if c < C_LADDER[2] else fast if c < C_LADDER[4] else 2 * tb[C_LADDER[0]]
               for c in C_LADDER}
    cold: list = []
    res0, c0, _ = sweep.climb(p, region, k, [], _Fake(fastest, cold, p))
    assert c0 == C_LADDER[2] and cold == [C_LADDER[0], C_LADDER[2]]
    warm: list = []
    res, c, _ = sweep.climb(p, region, k, [], _Fake(fastest, warm, p), start=C_LADDER[start])
    assert c == c0 and res.rows == res0.rows
    assert warm[0] == C_LADDER[start] and warm[-1] == c0
    assert len(warm) == (1 if start == 2 else 2)


@pytest.mark.serial  # starts scenes
@pytest.mark.parametrize("nproc", [1, 2])
@pytest.mark.parametrize("ks, beyond", [
    # measured 40-90 s on the loaded 2-core machine (the rung of c_max = 12)
    pytest.param("3,6", False, marks=pytest.mark.slow),
    ("0.05,0.1", True),
])
def test_fe_climbs_to_the_same_region_without_analytic(tmp_path, nproc, ks, beyond):
    """Stress top. k = 3, 6: the fastest mode at k = 6 runs beyond 4 c_d, so the region must
    grow (to 12 c_d, 16 eigenvalues). k = 0.05, 0.1: the ladder's top (32 c_d) does not prove
    it, a taller box does (session 24: 600 and 120 c_d). The FE climbs there with analytic
    unavailable, and the exact referee of the default run agrees on every bound, count and
    value."""
    ref_out, out = str(tmp_path / "ref"), str(tmp_path / "fe")
    ref = _scene(["--k", ks, "--bc", "stress"], ref_out)
    assert ref.returncode == 0, ref.stderr[-2000:]
    got = _scene(["--k", ks, "--bc", "stress", "--check-exact", "no"], out, nproc,
                 NO_EXACT_REGION)
    assert got.returncode == 0, got.stderr[-2000:]
    (ra, sa), (rb, sb) = _read(ref_out), _read(out)
    assert sa["region"]["by"] == sb["region"]["by"] == "fe"
    assert sa["region"]["exact_disagrees_at_k"] == []
    assert [d["c_max"] for d in sb["per_k"]] == [d["c_max"] for d in sa["per_k"]]
    assert max(d["c_max"] for d in sb["per_k"]) > C_LADDER[0]  # the region grew
    # beyond the ladder's top at every k, or within the ladder
    assert (min(d["c_max"] for d in sb["per_k"]) > C_LADDER[-1]) == beyond
    assert [d["n_fe"] for d in sb["per_k"]] == [d["n_exact"] for d in sa["per_k"]]
    assert all(d["fastest_proven"] for d in sa["per_k"] + sb["per_k"])
    assert sb["most_unstable"]["certificate"]["fastest_mode"]
    for k in {r["k"] for r in ra}:
        va = _values([r for r in ra if r["k"] == k])
        vb = _values([r for r in rb if r["k"] == k])
        assert max(abs(va - vb) / abs(va)) < SAME_VALUE_RTOL
    with open(os.path.join(out, "summary.json")) as fh:
        assert json.load(fh)["discretisation"]["per_rung"][-1]["c_max"] == max(
            d["c_max"] for d in sb["per_k"])


@pytest.mark.serial  # pure numpy
@pytest.mark.parametrize("k_max", [6.0, 100.0])
@pytest.mark.parametrize("bc", ["velocity", "stress"])
def test_the_mesh_of_a_k_is_never_coarser_than_the_rule_at_that_k(bc, k_max):
    """RungSolvers.mesh_k: planned at k rounded up to k_max MESH_K_RATIO^-j (within a ratio of
    MESH_K_RATIO above k, k_max itself at the top), so each rung's cells at k are at least the
    rule's at k and at most its at MESH_K_RATIO k, or MIN_CELLS (capped by the k_max mesh)."""
    from forms.solvers.certified import default_discretisation

    p, region = Params(bc=bc), Region(c_max=None)
    rungs = sweep.RungSolvers(p, region, k_max, 1e-8, (0, 0, 0.0))
    assert rungs.mesh_k(k_max) == k_max and rungs.mesh_k(None) == k_max
    for k in [0.05 * k_max, 0.3 * k_max, k_max / sweep.MESH_K_RATIO, 0.99 * k_max, k_max]:
        km = rungs.mesh_k(k)
        assert k <= km * (1 + 1e-12) and km < sweep.MESH_K_RATIO * k * (1 + 1e-12)
        for c in C_LADDER:
            deg, cells, _ = rungs.discretisation(c, k)
            rule = default_discretisation(p, region.fixed(c), k, 1e-8)[1]
            finer = default_discretisation(p, region.fixed(c), sweep.MESH_K_RATIO * k, 1e-8)[1]
            top = default_discretisation(p, region.fixed(c), k_max, 1e-8)[1]
            least = min(top, sweep.min_cells(deg))
            assert rule <= cells <= max(finer, least) and cells <= top


@pytest.mark.serial  # one rank's 1D solves
@pytest.mark.parametrize("degree", [3, 4, 5, 6])
def test_the_cells_rule_of_each_degree_meets_rtol_on_the_hardest_root(degree):
    """default_discretisation(degree=p): DEGREE_RATIO[p] was measured on this case (stress top,
    k = 6, the 16 c_d rung, |Im| up to 217): every eigenvalue of the region within rtol (its P(p+1)
    estimate), the count closed; and the rule's mesh is not wastefully fine: half its cells miss
    rtol on some root (so a ratio set too large would fail here as well as one set too small)."""
    from forms.solvers.certified import CertifiedSolver, default_discretisation

    p, region, k, rtol = Params(bc="stress"), Region(c_max=16.0), 6.0, 1e-8
    deg, cells, ratio = default_discretisation(p, region, k, rtol, degree)
    assert deg == degree
    worst = {}
    for n in (cells, cells // 2):
        cs = CertifiedSolver(p, region, deg, n, ratio, k, rtol, check_exact=False)
        try:
            res = cs.solve(k)
        finally:
            cs.destroy()
        assert res.closed, res.note
        worst[n] = max(r["error_estimate"] for r in res.rows)
    # measured (session 16): P3 283 cells 2.2e-9, 141: 1.4e-7; P4 117: 1.3e-9, 58: 3.3e-7;
    # P5 67: 6.5e-10, 33: 4.3e-7; P6 44: 4.0e-10, 22: 1.2e-6 (20 eigenvalues each)
    assert worst[cells] <= rtol, worst
    assert worst[cells // 2] > rtol, worst


@pytest.mark.serial  # pure numpy
def test_largest_region_holds_every_box_used():
    """The sweep's family plan region holds the box of every k: a taller box at small k
    (hundreds of c_d) raises omega0, not c_max (at the sweep's largest k that c_max would
    make a region many times too tall); without one it is the largest rung, as before."""
    p, region = Params(bc="stress"), Region(c_max=None)
    k, c = [0.05, 0.1, 3.0, 6.0], [600.0, 120.0, 12.0, 16.0]
    big = sweep.largest_region(p, region, k, c)
    assert big.c_max == 16.0 and big.omega_0(p) > region.omega_0(p)
    for x, cc in zip(k, c, strict=True):
        assert big.im_max(p, x) >= region.fixed(cc).im_max(p, x) * (1.0 - 1e-12)
    assert big.im_max(p, 0.05) == pytest.approx(region.fixed(600.0).im_max(p, 0.05), rel=1e-12)
    assert sweep.largest_region(p, region, k[2:], c[2:]) == region.fixed(16.0)
    # a fixed region: itself; a layered slider's climb (a fixed first rung, the rungs used
    # above it, no taller boxes): its largest rung used
    assert sweep.largest_region(p, region.fixed(4.0), k[2:], [4.0, 4.0]) == region.fixed(4.0)
    assert sweep.largest_region(p, region.fixed(4.0), k[2:], [4.0, 12.0]) == region.fixed(12.0)
    # the mesh summary.json describes: the largest ladder rung, or a fixed bound above the
    # ladder's top as it is (a fixed --c-max 40 was described by the 4 c_d mesh, 7 cells
    # against 21, before this was mended)
    assert sweep.largest_rung(c) == 16.0 and sweep.largest_rung([40.0, 40.0]) == 40.0
    assert sweep.largest_rung([600.0, 120.0]) == 600.0


@pytest.mark.serial  # pure numpy
def test_committed_stress_sweep_is_proven_at_every_k_with_the_exact_ladder():
    """README (session 24): the committed default stress sweep (workflows/results/sweep_k_stress)
    proves the fastest mode at all 120 k, 1 817 eigenvalues, with boxes beyond the ladder's top
    at its three smallest k; the exact roots' ladder (fastest_mode), recomputed here, chooses
    the same bound there and finds as many roots in each box as the FE rows."""
    folder = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                          "workflows", "results", "sweep_k_stress")
    with open(os.path.join(folder, "summary.json")) as fh:
        s = json.load(fh)
    per_k = s["per_k"]
    assert len(per_k) == 120 and all(d["fastest_proven"] and d["closed"] for d in per_k)
    assert s["certificate"]["rows"] == sum(d["n_fe"] for d in per_k) == 1817
    tall = [d for d in per_k if d["c_max"] > C_LADDER[-1]]
    assert [d["k"] for d in tall] == [d["k"] for d in per_k[:3]]
    from analytic.numerics.spectrum import fastest_mode
    p = Params(bc="stress")
    for d in tall:
        m = fastest_mode(p, d["k"], Region(c_max=None))
        assert m.proven and m.c_max == d["c_max"] and m.count == d["n_fe"]
