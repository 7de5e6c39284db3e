"""Smoke tests of workflows/figures.py (serial and mpirun -n 2) and its data helpers."""

import json
import os

import numpy as np
import pytest
from _workflows import run_workflow

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run(args, nproc=1):
    return run_workflow("figures.py", args, nproc)


@pytest.mark.serial
@pytest.mark.parametrize("nproc", [1, 2])
def test_figures_smoke(tmp_path, nproc):
    from PIL import Image

    out = tmp_path / "fig"
    ov = tmp_path / "overlay"
    ov.mkdir()
    (ov / "gaps.csv").write_text("x,y,label\n0.5,0.0001,FE test\n1.0,0.00005,FE test\n")
    names = ["gaps", "both", "modified2"]
    res = run(["--out", str(out), "--only", ",".join(names), "--n-q", "12",
               "--overlay", str(ov), "--no-fe"], nproc)
    assert res.returncode == 0, res.stderr
    index = json.loads((out / "figures.json").read_text())
    for name in names:
        assert index["figures"][name]["status"] == "written"
        png = out / f"{name}.png"
        assert png.stat().st_size > 10_000
        info = Image.open(png).info
        assert "figures.py" in info["Description"]
        assert json.loads(info["Comment"])["figure"] == name
        assert index["figures"][name]["fe"].startswith("off")


# FE markers drawn by figures.py itself: cross-section P3 (finiteH, stress_top) and the
# half-space PML P4 (both, gaps), each checked against the exact root at its abscissa.
# Measured on 2026-11-21 with this configuration: max relative deviation 2.4e-10 (finiteH),
# 1.4e-10 (stress_top), 1.6e-10 (both), 3.3e-10 (gaps); 6 of 8 gaps points trusted (the other
# two are flagged by the PML's own checks and not drawn).
FE_DEVIATION = {"finiteH": 5e-10, "stress_top": 5e-10, "both": 5e-10, "gaps": 1e-9}


@pytest.mark.slow  # measured 13 .. 35 s per case (2026-11-22, one file at a time, serial pass)
@pytest.mark.serial
@pytest.mark.parametrize("nproc", [1, 2])
def test_figures_fe_points_on_exact_curves(tmp_path, nproc):
    out = tmp_path / "fig"
    res = run(["--out", str(out), "--only", ",".join(FE_DEVIATION), "--n-q", "12",
               "--fe-points", "3"], nproc)
    assert res.returncode == 0, res.stderr
    index = json.loads((out / "figures.json").read_text())
    assert index["fe"] is True
    for name, bound in FE_DEVIATION.items():
        fe = index["figures"][name]["fe"]
        assert fe["points"] >= 0.7 * fe["requested"] > 0, (name, fe)
        assert fe["points"] + len(fe["skipped"]) == fe["requested"], (name, fe)
        assert fe["max_rel_deviation"] < bound, (name, fe)


@pytest.mark.serial
@pytest.mark.parametrize("args, word", [
    (["--only", "nosuchfigure"], "--only"),
    (["--n-q", "3"], "--n-q"),
    (["--overlay", "/nonexistent/folder"], "--overlay"),
    (["--out", "/etc/hostname"], "--out"),
])
def test_figures_bad_input(tmp_path, args, word):
    out = tmp_path / "never"
    res = run(["--out", str(out), *args])
    assert res.returncode == 2
    lines = [ln for ln in res.stderr.strip().splitlines() if ln.strip()]
    assert len(lines) == 1 and word in lines[0]
    assert not out.exists()


@pytest.mark.serial
def test_gap_tracks_are_continuous_and_switch_sheet():
    """The data behind Fig. gaps: each curve is one continuous root, solid (s) then dashed (s~)."""
    from analytic.halfspace import dilatational_tracks, physical_curve
    from analytic.params import Params

    p = Params(gamma=0.96 / 0.3)
    steps = {}
    for n in (80, 160):
        qs = np.logspace(-2, 2, n)
        tracks = dilatational_tracks(qs, p)
        for branch, roots in tracks.items():
            solid = physical_curve(roots, lambda r: r.growth)
            dashed = physical_curve(roots, lambda r: r.growth, "s_tilde")
            assert np.all(np.isfinite(solid) ^ np.isfinite(dashed))  # exactly one at each q
            assert np.isfinite(solid).any() and np.isfinite(dashed).any()
            g = np.array([r.growth for r in roots])
            steps[n, branch] = np.max(np.abs(np.diff(g)))
    # no jump along a track: the largest step halves with the grid spacing (a jump would not)
    for branch in ("unstable", "stable"):
        assert steps[160, branch] < 0.6 * steps[80, branch]


@pytest.mark.serial
def test_finite_h_figure_written(tmp_path):
    """stress_top (finite-H continuation of analytic.branches, no FE) is written."""
    out = tmp_path / "fig"
    res = run(["--out", str(out), "--only", "stress_top", "--n-q", "24", "--no-fe"])
    assert res.returncode == 0, res.stderr
    entry = json.loads((out / "figures.json").read_text())["figures"]["stress_top"]
    assert entry["status"] == "written"
    assert (out / "stress_top.png").stat().st_size > 10_000
