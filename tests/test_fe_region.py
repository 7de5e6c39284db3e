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
    """A stand-in for a rung's CertifiedSolver: its fastest Re Lambda is ``fastest[c]``."""

    def __init__(self, fastest: dict, calls: list) -> None:
        self.fastest, self.calls = fastest, calls

    def __call__(self, c: float) -> "_Fake":
        self.c = c
        return self

    def solve(self, k: float, fams: list, region: Region) -> KResult:
        self.calls.append(region.c_max)
        re = self.fastest[region.c_max]
        return KResult(k, [] if re is None else [{"re_lambda": re}], closed=True)


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
    res, c = sweep.climb(p, region, k, [], _Fake({c: fast for c in C_LADDER}, calls))
    assert c == C_LADDER[2] and res.rows[0]["re_lambda"] == fast
    assert calls[-1] == C_LADDER[2] and calls[0] == C_LADDER[0]
    # nothing in any rung: the region's re_min decides
    calls.clear()
    res, c = sweep.climb(p, region, k, [], _Fake({c: None for c in C_LADDER}, calls))
    assert tail_bound(p, k, region.fixed(c).im_max(p, k)) < region.re_min or c == C_LADDER[-1]
    # a fixed region is solved once
    calls.clear()
    sweep.climb(p, Region(c_max=6.0), k, [], _Fake({6.0: -1.0}, calls))
    assert calls == [6.0]


@pytest.mark.serial  # starts scenes
@pytest.mark.slow  # measured 40-90 s on the loaded 2-core machine (the rung of c_max = 12)
@pytest.mark.parametrize("nproc", [1, 2])
def test_fe_climbs_to_the_same_region_without_analytic(tmp_path, nproc):
    """Stress top, k = 3, 6: the fastest mode at k = 6 runs beyond 4 c_d, so the region must
    grow (to 12 c_d, 16 eigenvalues); the FE climbs there with analytic unavailable, and the
    exact referee of the default run agrees on every bound."""
    ref_out, out = str(tmp_path / "ref"), str(tmp_path / "fe")
    ref = _scene(["--k", "3,6", "--bc", "stress"], ref_out)
    assert ref.returncode == 0, ref.stderr[-2000:]
    got = _scene(["--k", "3,6", "--bc", "stress", "--check-exact", "no"], out, nproc,
                 NO_EXACT_REGION)
    assert got.returncode == 0, got.stderr[-2000:]
    (ra, sa), (rb, sb) = _read(ref_out), _read(out)
    assert sa["region"]["by"] == sb["region"]["by"] == "fe"
    assert sa["region"]["exact_disagrees_at_k"] == []
    assert [d["c_max"] for d in sb["per_k"]] == [d["c_max"] for d in sa["per_k"]]
    assert max(d["c_max"] for d in sb["per_k"]) > C_LADDER[0]  # the region grew
    assert [d["n_fe"] for d in sb["per_k"]] == [d["n_exact"] for d in sa["per_k"]]
    assert all(d["fastest_proven"] for d in sb["per_k"])
    assert sb["most_unstable"]["certificate"]["fastest_mode"]
    for k in {r["k"] for r in ra}:
        va = _values([r for r in ra if r["k"] == k])
        vb = _values([r for r in rb if r["k"] == k])
        assert max(abs(va - vb) / abs(va)) < SAME_VALUE_RTOL
    with open(os.path.join(out, "summary.json")) as fh:
        assert json.load(fh)["discretisation"]["per_rung"][-1]["c_max"] == max(
            d["c_max"] for d in sb["per_k"])
