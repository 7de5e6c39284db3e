"""workflows/stability_map.py (serial and mpirun -n 2) and analytic.studies.stability_map, checked
against independent root counts and roots of det_M."""

import csv
import json
import os
from pathlib import Path

import numpy as np
import pytest
from _workflows import run_workflow

from analytic import Params, roots_in_box
from analytic.numerics.branches import polish_root, spectrum_function
from analytic.numerics.roots import count_zeros
from analytic.numerics.spectrum import C_LADDER, Region, exact_roots, fastest_mode, fastest_root
from analytic.physics.tail import tail_bound
from analytic.studies.stability_map import closed_form_delta, kh_grid, map_point, parse_axis

pytestmark = pytest.mark.serial  # subprocesses (their own mpirun) and pure numpy

#: A 3 x 3 map that is cheap (k H <= 1) and holds stable and unstable points: gamma = 0.01 with
#: Delta >= 0.75 is stable, gamma >= 0.1 or Delta = -0.5 unstable (measured with the scene).
SMALL = ["--x", "Delta:-0.5:2:3", "--y", "gamma:0.01:1:3log", "--H", "1", "--kH-max", "1",
         "--nk", "3"]


def _rows(out):
    with open(out / "stability_map.csv") as fh:
        return list(csv.DictReader(fh))


@pytest.mark.parametrize("top", ["velocity", "stress"])
def test_committed_41_maps_fastest_point_found_by_the_fe(top):
    """README "Each map's fastest point, by the FE alone" (session 38): the committed 41 x 41
    maps' ``fe_check``: the FE's own fastest eigenvalue at the fastest point's k, count closed,
    region proven by the FE's climb, the exact value to 4.0e-14 / 6.9e-15 (measured); against
    an exact root polished from the FE value here. The maps run with ``--fe-check all`` (session
    40: all 1 681 points, at most 5.6e-13 velocity and 8.1e-12 stress) are checked at every
    point."""
    path = Path(__file__).parent.parent / "workflows" / "results" / f"stability_map_{top}_41"
    s = json.loads((path / "summary.json").read_text())
    best, checked = s["fastest_point"], s["fe_check"]
    if len(checked) > 1:
        rows = _rows(path)
        assert len(checked) == len(rows) == 1681 and all(r["fe_proven"] for r in checked)
        _fe_checked(checked, rows, top)
    (fe,) = [r for r in checked if (r["x"], r["y"]) == (best["x"], best["y"])]
    assert fe["k"] == best["k"] and fe["fe_closed"] and fe["fe_proven"]
    z = complex(fe["fe_re_lambda"], fe["fe_im_lambda"])
    exact = polish_root(Params(bc=top, Delta=best["x"], H=best["y"]), best["k"], z).value
    assert abs(z - exact) < 1e-9 * abs(exact)
    assert abs(z - complex(best["re_lambda"], best["im_lambda"])) < 1e-9 * abs(exact)


def _fe_checked(fe: list[dict], rows: list[dict], top: str = "velocity") -> None:
    """Each ``fe_check`` entry is its map point's fastest mode (``x`` = Delta, ``y`` = H), its
    FE count closed, and an exact root polished from the FE value here."""
    at = {(float(r["x"]), float(r["y"])): r for r in rows}
    for r in fe:
        row = at[(r["x"], r["y"])]
        assert r["k"] == float(row["k"]) and r["fe_closed"]
        z = complex(r["fe_re_lambda"], r["fe_im_lambda"])
        exact = polish_root(Params(bc=top, Delta=r["x"], H=r["y"]), r["k"], z).value
        # FE (P6, the 1e-8 rule) against exact: measured 6.9e-15 on the default map, at most
        # 4.0e-12 over the committed 63-point maps
        assert abs(z - exact) < 1e-9 * abs(exact)
        point = complex(float(row["re_lambda"]), float(row["im_lambda"]))
        assert abs(z - point) < 1e-9 * abs(exact)


def _fe_grid_checked(out: Path, rows: list[dict], point_params, kh_max: float) -> None:
    """``--fe-check grid``: every point's value found by the FE alone (``fe_grid``), set against
    the exact map (its referee) and, independently, against exact roots polished here from the
    FE's own values; a stable point's FE zero counts against an exact count in a wider region
    (Re Lambda >= 1e-6 up to 5, phase velocities up to 12 c_d) at every grid k."""
    s = json.loads((out / "summary.json").read_text())
    grid = s["fe_grid"]
    with open(out / "fe_grid.csv") as fh:
        samples = list(csv.DictReader(fh))
    assert len(grid) == len(rows) and len(samples) == len(rows) * s["kH_grid"]["count"]
    for q, r in zip(grid, rows, strict=True):
        assert (q["x"], q["y"]) == (float(r["x"]), float(r["y"]))
        assert q["agrees"] and q["counts_closed"] and q["stable_as_exact"]
        assert q["fe_stable_on_grid"] == (r["stable_on_grid"] == "True")
        if q["fe_stable_on_grid"]:
            continue
        p = point_params(r)
        z = complex(q["re_lambda"], q["im_lambda"])
        at = polish_root(p, q["k"], z).value
        # the FE at the sweep's 1e-8 rule: measured at most 4.0e-12 relative (committed maps)
        assert abs(at - z) < 1e-9 * abs(at)
        # the FE's maximum is the exact point's growth rate: Re measured to 7e-12 relative
        # (its k is a maximum's: flat, 2e-6 apart on the 3-sample SMALL map, so not compared)
        assert abs(q["re_lambda"] - float(r["re_lambda"])) < 1e-9 * abs(at)
        assert all(g["same_mode"] for g in q["peaks"])
    wide = Region(1e-6, 5.0, 12.0)
    for smp in samples:
        p, k = point_params(smp), float(smp["k"])
        assert smp["fe_closed"] == "True" and float(smp["kH"]) <= kh_max * (1 + 1e-12)
        if smp["fe_re_lambda"] == "":  # the FE counted nothing in its region: nor does det_M
            assert int(smp["fe_count"]) == 0
            assert count_zeros(spectrum_function(p, k), wide.box(p, k)) == 0
            continue
        z = complex(float(smp["fe_re_lambda"]), float(smp["fe_im_lambda"]))
        assert abs(polish_root(p, k, z).value - z) < 1e-9 * abs(z)


@pytest.mark.parametrize("nproc", [1, 2])
def test_fe_grid_finds_every_point_and_stability_on_its_own(tmp_path, nproc):
    """``--fe-check grid`` on SMALL (2 stable and 7 unstable points): every point's value and
    every stable point by the FE alone; the map itself is that of a run without the check."""
    out = tmp_path / "m"
    proc = run_workflow("stability_map.py", [*SMALL, "--fe-check", "grid", "--out", str(out)],
                        nproc=nproc)
    assert proc.returncode == 0, proc.stderr[-2000:]
    rows = _rows(out)
    assert sum(r["stable_on_grid"] == "True" for r in rows) == 2
    _fe_grid_checked(out, rows, lambda r: Params(H=1.0, Delta=float(r["x"]),
                                                 gamma=float(r["y"])), 1.0)
    assert ("FE grid: at 9 of 9 point(s) the FE's own maximum over the k H grid, refined along "
            "its modes, is the exact point's") in proc.stdout
    assert "2 stable by the FE's own counts; 0 point(s) with a count not closed" in proc.stdout


GOOD = {"agrees": True, "counts_closed": True, "stable_as_exact": True, "re_rel_diff": 1e-12,
        "k_rel_diff": 1e-7, "fe_stable_on_grid": False}


@pytest.mark.parametrize(("change", "failed"), [
    ({}, 0), ({"agrees": False}, 1), ({"counts_closed": False}, 1),
    ({"stable_as_exact": False}, 1),
    ({"fe_stable_on_grid": True, "re_rel_diff": None, "k_rel_diff": None}, 0)])
def test_fe_grid_line_counts_a_point_that_disagrees_as_failed(change, failed):
    """``_points.map_fe_line``: a point whose FE value is another mode, whose count did not
    close or whose stability differs from the exact point's is a failed point (exit code 1)."""
    from _points import map_fe_line

    line, n = map_fe_line([GOOD, GOOD | change])
    assert n == failed
    assert line.startswith(f"FE grid: at {2 - failed} of 2 point(s)")


@pytest.mark.parametrize("nproc", [1, 2])
@pytest.mark.parametrize("which", ["yes", "all"])
def test_fe_check_finds_the_maps_fastest_point(tmp_path, which, nproc):
    """``--fe-check yes``: the map's fastest point is the FE's own fastest eigenvalue at its k
    (the sweep's FE path, no exact root consulted), set against an exact root polished from the
    FE value here; ``all``: every unstable point's; the points themselves are those of a run
    without the check."""
    args = ["--x", "Delta:-1:1:2", "--y", "H:0.5:1:2", "--nk", "3", "--kH-max", "2"]
    out, plain = tmp_path / "m", tmp_path / "plain"
    proc = run_workflow("stability_map.py", [*args, "--fe-check", which, "--out", str(out)],
                        nproc=nproc)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert run_workflow("stability_map.py", [*args, "--out", str(plain)]).returncode == 0
    rows = _rows(out)
    assert rows == _rows(plain)
    s = json.loads((out / "summary.json").read_text())
    best, fe = s["fastest_point"], s["fe_check"]
    unstable = [r for r in rows if r["re_lambda"]]
    assert len(unstable) == 4
    n = len(unstable) if which == "all" else 1
    assert len(fe) == n and (fe[0]["x"], fe[0]["y"]) == (
        (best["x"], best["y"]) if which == "yes" else (float(unstable[0]["x"]),
                                                       float(unstable[0]["y"])))
    _fe_checked(fe, rows)
    assert f"FE check: {n} of {n} point(s) found again by the FE on its own" in proc.stdout


@pytest.mark.parametrize("top", ["velocity", "stress"])
def test_committed_63_point_maps_found_by_the_fe_at_every_point(top):
    """README "Stability map", session 40: the committed 63-point maps with ``--fe-check all``:
    at every point (all unstable) the fastest mode is the FE's own fastest eigenvalue at its k,
    count closed, region proven by the FE's climb. Session 41 (``--fe-check grid``): every
    point's value is also the FE's own maximum over the grid, its peaks refined along its
    modes, and every one of the 1 008 FE samples is an exact root."""
    path = Path(__file__).parent.parent / "workflows" / "results" / f"stability_map_{top}"
    s = json.loads((path / "summary.json").read_text())
    rows = _rows(path)
    assert len(rows) == len(s["fe_check"]) == 63
    assert all(r["fe_proven"] for r in s["fe_check"])
    _fe_checked(s["fe_check"], rows, top)
    # session 41, --fe-check grid: each point's value by the FE alone, over all 16 grid k
    _fe_grid_checked(path, rows, lambda r: Params(bc=top, Delta=float(r["x"]), H=float(r["y"])),
                     10.0)


@pytest.mark.slow  # 25 s serial on a quiet machine, 80-90 s with 7 helpers running
@pytest.mark.parametrize("nproc", [1, 2])
def test_small_map_matches_exact_roots(tmp_path, nproc):
    out = tmp_path / "m"
    proc = run_workflow("stability_map.py", [*SMALL, "--out", str(out)], nproc=nproc)
    assert proc.returncode == 0, proc.stderr[-2000:]
    rows = _rows(out)
    assert len(rows) == 9 and len(proc.stdout.strip().splitlines()) == 1  # rank 0 only
    s = json.loads((out / "summary.json").read_text())
    assert s["points"] == 9 and s["stable_on_grid"] == sum(r["stable_on_grid"] == "True"
                                                           for r in rows)
    assert 0 < s["stable_on_grid"] < 9  # the grid crosses the boundary
    region = Region(1e-6, 2.0, 4.0)
    auto = Region(1e-6, 2.0, None)  # the scene's default region (--c-max auto)
    for r in rows:
        p = Params(H=1.0, Delta=float(r["x"]), gamma=float(r["y"]))
        if r["stable_on_grid"] == "True":
            assert r["re_lambda"] == ""
            continue
        k, z = float(r["k"]), complex(float(r["re_lambda"]), float(r["im_lambda"]))
        zf = fastest_root(p, k, auto)[0]  # the reported root is the fastest at its k
        assert abs(zf - z) <= 1e-8 * abs(z)
        for kh in kh_grid(0.05, 1.0, 3):  # and at least every grid sample's fastest in 4 c_d
            roots = roots_in_box(p, kh, region.box(p, kh))
            assert z.real >= max((w.value.real for w in roots), default=0.0) - 1e-12
    assert (out / "stability_map.png").stat().st_size > 10000
    # the line says whether R was proven to hold the fastest mode, from the rows' own counts
    proven = sum(int(r["proven_k_count"]) for r in rows)
    with_root = sum(int(r["unstable_k_count"]) for r in rows)
    assert 0 < proven <= with_root
    assert (f"at all {with_root} k with a root" if proven == with_root
            else f"in R only, R proven to hold the fastest mode at {proven} of {with_root}"
            ) in proc.stdout


@pytest.mark.slow  # four runs of the scene: 48 s for three on the loaded machine
def test_resume_keeps_done_points_and_recomputes_missing(tmp_path):
    """raw/p#####.json are the run's parts: --resume (2 ranks) takes a marked one as it is and
    computes a missing one; a run without --resume clears them and computes every point."""
    out = tmp_path / "m"
    args = ["--x", "Delta:1:2:2", "--y", "f:0:0.02:2", "--kH-max", "0.5", "--nk", "2",
            "--gamma", "1", "--H", "1", "--out", str(out)]
    assert run_workflow("stability_map.py", args).returncode == 0
    raw = sorted(os.listdir(out / "raw"))
    assert raw == [f"p{i:05d}.json" for i in range(4)]
    marked = json.loads((out / "raw" / raw[0]).read_text())
    marked["unstable_k_count"] = 99  # a value no computation gives: shows it was not redone
    (out / "raw" / raw[0]).write_text(json.dumps(marked))
    first = _rows(out)
    os.remove(out / "raw" / raw[1])
    proc = run_workflow("stability_map.py", [*args, "--resume"], nproc=2)
    assert proc.returncode == 0, proc.stderr[-2000:]
    rows = _rows(out)
    assert rows == [{**first[0], "unstable_k_count": "99"}, *first[1:]]  # f = 0: no closed
    assert first[0]["delta_closed_form"] == "nan"  # form, the same "nan" from a loaded part
    assert run_workflow("stability_map.py", args).returncode == 0  # no --resume: starts over
    assert _rows(out) == first and sorted(os.listdir(out / "raw")) == raw
    proc = run_workflow("stability_map.py", [*args[:-2], "--nk", "3", "--out", str(out),
                                             "--resume"])
    assert proc.returncode == 2, proc.stderr  # --resume continues only the same parameters


@pytest.mark.parametrize("bad, word", [(["--x", "Delta:1:0:3"], "--x"),
                                       (["--y", "nu:0:1:3"], "--y"),
                                       (["--x", "H:0.1:1:3", "--y", "H:1:2:3"], "--x"),
                                       (["--kH-max", "0"], "--kH-max"),
                                       (["--nk", "1"], "--nk"),
                                       (["--re-min", "0"], "--re-min"),
                                       (["--c-max", "fast"], "--c-max"),
                                       (["--c-max", "-1"], "--c-max"),
                                       (["--y", "f:-1:1:3"], "f")])
@pytest.mark.parametrize("nproc", [1, 2])
def test_bad_input_one_line(tmp_path, bad, word, nproc):
    proc = run_workflow("stability_map.py", [*bad, "--out", str(tmp_path / "o")], nproc=nproc)
    assert proc.returncode == 2
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and word in lines[0], proc.stderr
    assert not (tmp_path / "o").exists()


# ------------------------------------------------------- analytic.studies.stability_map (direct)
def test_stable_point_has_no_root_in_a_wider_region():
    """gamma = 0.01, Delta = 2, H = 1: stable on the k H grid; checked independently with a
    wider count (Re Lambda >= 1e-6 up to 5, phase velocities up to 12 c_d) at the grid and
    half-way between its points."""
    p = Params(gamma=0.01, Delta=2.0, H=1.0)
    khs = kh_grid(0.05, 3.0, 5)
    res = map_point(p, khs, Region(1e-6, 2.0, 4.0))
    assert res["stable_on_grid"] and res["re_lambda"] is None and res["failed_counts"] == 0
    # no root inside: the (positive) tail bound proves nothing about roots beyond the region
    assert res["proven_k_count"] == 0 and res["c_max_largest"] == 4.0
    wide = Region(1e-6, 5.0, 12.0)
    for k in np.sort(np.concatenate([khs, np.sqrt(khs[1:] * khs[:-1])])):
        fun = spectrum_function(p, float(k))
        assert count_zeros(fun, wide.box(p, k)) == 0


def test_unstable_point_is_the_fastest_root_at_least_the_grid():
    """The paper's defaults (velocity top, H = 0.5): unstable; the value is an exact root, the
    fastest in a wider region at its k, and at least the fastest root at every grid k."""
    p = Params()
    khs = kh_grid(0.2, 2.0, 4)
    res = map_point(p, khs, Region(1e-6, 2.0, 4.0))
    assert not res["stable_on_grid"] and res["unstable_k_count"] == 4
    z = complex(res["re_lambda"], res["im_lambda"])
    wide = Region(1e-6, 5.0, 12.0)
    assert fastest_root(p, res["k"], wide)[0] == pytest.approx(z, rel=1e-8)
    proven = 0
    for kh in khs:
        k = kh / p.H
        assert res["re_lambda"] >= max(w.value.real for w in roots_in_box(p, k, wide.box(p, k)))
        inside = max(w.value.real for w in roots_in_box(p, k, Region(1e-6, 2.0, 4.0).box(p, k)))
        proven += tail_bound(p, k, Region(c_max=4.0).im_max(p, k)) < inside
    # the fastest mode proven in the 4 c_d region at each grid k: the bound at its top edge
    # below the fastest root inside (here at every k)
    assert res["proven_k_count"] == proven == len(khs) and res["c_max_largest"] == 4.0


@pytest.mark.parametrize("spec, values", [("Delta:-1:1:3", [-1.0, 0.0, 1.0]),
                                          ("H:0.1:10:3log", [0.1, 1.0, 10.0])])
def test_parse_axis(spec, values):
    name, v = parse_axis(spec, "--x")
    assert name == spec.split(":")[0] and np.allclose(v, values, rtol=1e-14)


def test_closed_form_delta_is_the_largest_family_boundary():
    from analytic.physics import phase_diagram as pd

    p = Params()
    vals = [pd.closed_form(f, p.Gamma, p.f, p.beta) for f in pd.FAMILIES]
    assert closed_form_delta(p) == max(v for v in vals if np.isfinite(v))
    assert np.isnan(closed_form_delta(p.replace(f=0.0)))


def test_adaptive_region_climbs_and_proves_at_an_unstable_point():
    """--c-max auto (Region(c_max=None)): the paper's defaults at stress top, k H = 13.25
    (k = 26.5, the issue's case): the 4 c_d region misses the fastest root (0.2962), the
    adaptive one proves 0.3171 at 16 c_d; the map point reports both."""
    p = Params(bc="stress")
    khs = np.array([13.25])
    fixed = map_point(p, khs, Region(1e-6, 2.0, 4.0), top=0)
    auto = map_point(p, khs, Region(1e-6, 2.0, None), top=0)
    assert fixed["proven_k_count"] == 0 and fixed["c_max_largest"] == 4.0
    assert auto["proven_k_count"] == 1 and auto["c_max_largest"] > 4.0
    # independent: the exact fastest roots quoted by issue 17 (det_M, zeros_in_box by hand)
    assert fixed["re_lambda"] == pytest.approx(0.2961604, abs=1e-7)
    assert auto["re_lambda"] == pytest.approx(0.3170864, abs=1e-7)


#: The README's committed maps (stability_map.py --x Delta:-1:1:9 --y H:0.1:10:7log --nk 16).
RESULTS = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                       "workflows", "results")


@pytest.mark.serial
@pytest.mark.parametrize("top, lo, hi", [("velocity", 0.167, 0.183), ("stress", 0.177, 0.191)])
def test_committed_maps_close_every_count_and_their_h0_1_row_is_the_fastest_root(top, lo, hi):
    """The README's reading of the committed maps: no failed count (12 and 18 before det_M's
    extended precision next to the origin), ``H max Re Lambda`` within the README's range for
    ``H <= 1`` (rounded to 5e-4), and the ``H = 0.1`` row's value at ``Delta = -1``
    recomputed by ``fastest_root`` with the adaptive region at its ``k`` (1e-8: both polish the
    same root)."""
    rows = _rows(Path(RESULTS) / f"stability_map_{top}")
    assert len(rows) == 63 and all(int(r["failed_counts"]) == 0 for r in rows)
    # session 24: every grid k with a root proven (boxes beyond the ladder's top where needed)
    assert all(r["proven_k_count"] == r["unstable_k_count"] for r in rows)
    hmax = [float(r["y"]) * float(r["re_lambda"]) for r in rows if float(r["y"]) <= 1.0 + 1e-9]
    assert lo - 5e-4 <= min(hmax) and max(hmax) <= hi + 5e-4
    r = next(r for r in rows if r["ix"] == "0" and r["iy"] == "0")  # Delta = -1, H = 0.1
    p = Params(bc=top, Delta=float(r["x"]), H=float(r["y"]))
    z = complex(float(r["re_lambda"]), float(r["im_lambda"]))
    zf = fastest_root(p, float(r["k"]), Region(1e-6, 2.0, None))[0]
    assert abs(zf - z) <= 1e-8 * abs(z)


@pytest.mark.serial
def test_committed_41_by_41_velocity_map_and_its_reading():
    """README, the 41 x 41 velocity map (session 22's run): every count closed, no point stable, the
    plateau's ``H max Re Lambda`` in 0.166-0.183 for ``H <= 1`` (rounded to 5e-4), the slower
    fastest mode only in the pocket 1.6 <= H <= 6.3, Delta <= -0.45; two points recomputed by
    ``fastest_root`` (adaptive region) at their ``k``: one in the pocket (phase velocity below
    c_d), one on the plateau (above it), each to 1e-8 (both polish the same root)."""
    rows = _rows(Path(RESULTS) / "stability_map_velocity_41")
    assert len(rows) == 41 * 41 and all(int(r["failed_counts"]) == 0 for r in rows)
    assert all(r["proven_k_count"] == r["unstable_k_count"] for r in rows)  # session 24
    assert not any(r["stable_on_grid"] == "True" for r in rows)
    slow = [r for r in rows if float(r["phase_velocity_over_c_d"]) <= 1.0]
    assert slow and all(1.5 < float(r["y"]) < 6.4 and float(r["x"]) <= -0.45 + 1e-9
                        for r in slow)
    hmax = [float(r["y"]) * float(r["re_lambda"]) for r in rows if float(r["y"]) <= 1.0 + 1e-9]
    assert 0.166 - 5e-4 <= min(hmax) and max(hmax) <= 0.183 + 5e-4
    fast = next(r for r in rows if r["ix"] == "40" and r["iy"] == "20")  # Delta = 1, H = 1
    for r in (slow[len(slow) // 2], fast):
        p = Params(Delta=float(r["x"]), H=float(r["y"]))
        z = complex(float(r["re_lambda"]), float(r["im_lambda"]))
        zf = fastest_root(p, float(r["k"]), Region(1e-6, 2.0, None))[0]
        assert abs(zf - z) <= 1e-8 * abs(z)
    assert float(fast["phase_velocity_over_c_d"]) > 1.0


@pytest.mark.serial
def test_committed_41_by_41_stress_map_against_the_63_point_map_and_fastest_root():
    """README, the 41 x 41 stress map (session 22, the fastest root proven by band counts from
    the previous k's roots, ``whole=False``): every count closed, no point stable, ``H max Re
    Lambda`` in 0.1768-0.1906 for ``H <= 1`` (rounded to 5e-4), the slower fastest mode only at
    0.85 < H < 4.6, Delta <= 0. Against the committed 63-point stress map (another k grid,
    ``--nk 16``) at the 27 points the two grids share: never below it (1e-12), and equal to 1e-12
    at all but one (measured: 26 to 2.3e-15; at Delta = 0.5, H = 10 the finer grid finds a
    peak at k H = 6.5 that the coarser one missed, 0.017957 against 0.017790). Two points
    recomputed by ``fastest_root`` (the whole region counted, no starts: the path without
    band counts) at their ``k``: one slow, one on the plateau, each to 1e-8."""
    rows = _rows(Path(RESULTS) / "stability_map_stress_41")
    assert len(rows) == 41 * 41 and all(int(r["failed_counts"]) == 0 for r in rows)
    # session 24: every grid k with a root proven (38 557 of 40 344 before the taller boxes)
    assert all(r["proven_k_count"] == r["unstable_k_count"] for r in rows)
    assert not any(r["stable_on_grid"] == "True" for r in rows)
    slow = [r for r in rows if float(r["phase_velocity_over_c_d"]) <= 1.0]
    assert slow and all(0.85 < float(r["y"]) < 4.6 and float(r["x"]) <= 1e-9 for r in slow)
    hmax = [float(r["y"]) * float(r["re_lambda"]) for r in rows if float(r["y"]) <= 1.0 + 1e-9]
    assert 0.1768 - 5e-4 <= min(hmax) and max(hmax) <= 0.1906 + 5e-4
    coarse = {(round(float(r["x"]), 9), round(float(r["y"]), 9)): float(r["re_lambda"])
              for r in _rows(Path(RESULTS) / "stability_map_stress")}
    shared = [(float(r["re_lambda"]), coarse[key]) for r in rows
              if (key := (round(float(r["x"]), 9), round(float(r["y"]), 9))) in coarse]
    assert len(shared) == 27
    assert all(fine >= c * (1 - 1e-12) for fine, c in shared)
    assert sum(abs(fine - c) <= 1e-12 * c for fine, c in shared) >= 26
    fast = next(r for r in rows if r["ix"] == "40" and r["iy"] == "20")  # Delta = 1, H = 1
    for r in (slow[len(slow) // 2], fast):
        p = Params(bc="stress", Delta=float(r["x"]), H=float(r["y"]))
        z = complex(float(r["re_lambda"]), float(r["im_lambda"]))
        zf = fastest_root(p, float(r["k"]), Region(1e-6, 2.0, None))[0]
        assert abs(zf - z) <= 1e-8 * abs(z)
    assert float(fast["phase_velocity_over_c_d"]) > 1.0


def test_committed_stress_map_point_beyond_the_ladder_is_proven_by_the_whole_box():
    """The committed 63-point stress map's point with the tallest box (c_max_largest beyond the
    ladder's top, 32 c_d: an H = 0.1 point): at the grid k where the adaptive region goes
    beyond the ladder, one count and search of the whole box (exact_roots, not the map's band
    counts) holds a root whose Re is above the tail bound at the box's edge, and the bound at
    the ladder's top is not (the taller box was needed)."""
    rows = _rows(Path(RESULTS) / "stability_map_stress")
    r = max(rows, key=lambda r: float(r["c_max_largest"]))
    assert float(r["c_max_largest"]) > C_LADDER[-1]
    p = Params(bc="stress", Delta=float(r["x"]), H=float(r["y"]))
    region = Region(1e-6, 2.0, None)
    modes = [(k, fastest_mode(p, k, region)) for k in kh_grid(0.05, 10.0, 16) / p.H]
    k, c = next((k, m.c_max) for k, m in modes if m.c_max > C_LADDER[-1])
    roots, _ = exact_roots(p, k, region.fixed(c).box(p, k))
    fastest = max(z.value.real for z in roots)
    assert tail_bound(p, k, region.fixed(c).im_max(p, k)) < fastest
    assert not tail_bound(p, k, region.fixed(C_LADDER[-1]).im_max(p, k)) < fastest
