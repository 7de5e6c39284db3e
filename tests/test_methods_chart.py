"""Methods study (forms/studies/methods.py) and its scene workflows/methods_chart.py.

The study runs FE on MPI.COMM_SELF (each rank its own points), so its tests also run under
mpirun -n 2; the scene runs are subprocesses (serial marker).
"""

import csv
import json

import pytest
from _workflows import run_workflow

from mpi4py import MPI
from petsc4py import PETSc

from analytic.params import Params
from forms.studies import methods as ms


def test_every_method_found_set_against_the_count():
    rows = ms.methods_point(Params(), 1.0, 2.0, methods=("tiling", "dense", "moments"))
    assert [r["method"] for r in rows] == ["tiling", "dense", "moments"]
    for r in rows:
        assert r["count"] >= 1 and r["truth"] == r["count"], r
        assert not r["failed"], r
        assert r["found"] == r["count"] and r["missed"] == 0 and r["spurious"] == 0, r


def test_ciss_nleigs_newton_find_the_counted_set():
    rows = ms.methods_point(Params(), 2.0, 2.0, methods=("ciss", "nleigs", "newton"))
    assert [r["method"] for r in rows] == ["ciss", "nleigs", "newton"]
    for r in rows:
        assert r["count"] == 3 and r["truth"] == r["count"], r  # banded count at this point
        assert r["found"] == r["count"] and r["missed"] == 0 and r["spurious"] == 0, r
    assert not any(r["failed"] for r in rows if r["method"] != "ciss"), rows
    assert ms.ciss_pieces((-0.01, 2.0, -33.1, 33.1))[-1][3] == 33.1  # 5 pieces cover the box
    assert len(ms.ciss_pieces((-0.01, 2.0, -33.1, 33.1))) == 5


def test_a_slepc_run_that_does_not_converge_is_a_failed_point():
    opts = PETSc.Options()
    opts.setValue("methods_nleigs_nep_max_it", 1)  # the prefix reaches the NEP: it stops early
    try:
        row = ms.methods_point(Params(), 2.0, 2.0, methods=("nleigs",))[0]
    finally:
        opts.delValue("methods_nleigs_nep_max_it")
    assert row["failed"] == "SLEPc DIVERGED_ITS", row
    assert row["missed"] == row["count"] - row["found"] and row["spurious"] == 0, row


def test_ciss_on_an_rg_interval_raises_and_is_a_failed_point():
    # README: SLEPc 3.18's PEP CISS rejects an RG interval (PETSc error 56)
    opts = PETSc.Options()
    opts.setValue("methods_ciss_rg_type", "interval")
    opts.setValue("methods_ciss_rg_interval_endpoints", "-0.01,2,-6,6")
    try:
        row = ms.methods_point(Params(), 2.0, 2.0, methods=("ciss",))[0]
    finally:
        opts.delValue("methods_ciss_rg_type")
        opts.delValue("methods_ciss_rg_interval_endpoints")
    assert row["failed"].startswith("raised Error") and "56" in row["failed"], row
    assert row["found"] == 0 and row["missed"] == row["count"] == 3, row


@pytest.mark.slow
def test_one_ciss_ellipse_over_a_tall_region_finds_nothing(monkeypatch):
    # README (methods chart): why the region is cut into pieces for CISS
    monkeypatch.setattr(ms, "CISS_ASPECT", 1e9)
    row = ms.methods_point(Params(), 12.0, 8.0, methods=("ciss",))[0]
    # measured: 0 of 23 on the gmsh mesh, 1 of 23 on the numpy progression that replaced it
    # (vertices moved by up to 1.1e-8 H): the single ellipse misses almost every root
    assert row["count"] == 23 and row["found"] <= 1, row


def test_a_failing_method_is_reported_missing(monkeypatch):
    monkeypatch.setattr(ms, "DENSE_MAX", 10)  # the pencil is larger: dense fails
    rows = {r["method"]: r for r in ms.methods_point(Params(), 1.0, 2.0, methods=("dense",
                                                                                  "moments"))}
    assert "DENSE_MAX" in rows["dense"]["failed"]
    assert rows["dense"]["found"] == 0 and rows["dense"]["missed"] == rows["dense"]["count"] > 0
    assert rows["moments"]["found"] == rows["moments"]["count"]


def test_grid_shared_over_ranks():
    rows = ms.methods_grid(Params(), [0.5, 1.0], [2.0], methods=("moments",),
                           comm=MPI.COMM_WORLD)
    assert [(r["k"], r["method"]) for r in rows] == [(0.5, "moments"), (1.0, "moments")]
    assert all(r["found"] == r["count"] > 0 for r in rows)


@pytest.mark.serial
@pytest.mark.slow  # 15 s measured with the six methods (2026-11-24, loaded machine)
def test_scene_smoke(tmp_path):
    proc = run_workflow("methods_chart.py", ["--k", "1", "--c-max", "2", "--out", str(tmp_path)],
                        1)
    assert proc.returncode == 0, proc.stderr[-2000:]
    for name in ("methods.csv", "summary.json", "methods.png"):
        assert (tmp_path / name).stat().st_size > 0
    with open(tmp_path / "methods.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert {r["method"] for r in rows} == set(ms.METHODS)
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["totals"]["moments"]["missed"] == 0


@pytest.mark.serial
def test_bad_rtol_exits_2(tmp_path):
    out = tmp_path / "out"
    proc = run_workflow("methods_chart.py", ["--rtol", "5", "--out", str(out)], 1)
    assert proc.returncode == 2 and proc.stderr.startswith("error: --rtol")
    assert not out.exists()


@pytest.mark.serial
def test_committed_chart_matches_readme_table():
    from pathlib import Path

    res = Path(__file__).resolve().parents[1] / "workflows" / "results" / "methods_chart"
    with open(res / "methods.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 12 * len(ms.METHODS)

    def total(m, key):
        return sum(int(r[key]) for r in rows if r["method"] == m)

    # README table (methods chart section)
    table = {"linear": (90, 0, 0, 1.6), "moments": (90, 0, 0, 1.9), "newton": (90, 0, 0, 5.6),
             "tiling": (89, 1, 0, 6.3), "ciss": (82, 8, 5, 34), "nleigs": (63, 27, 7, 10),
             "dense": (4, 86, 10, 1.4)}
    for m, (found, missed, failed, seconds) in table.items():
        assert (total(m, "found"), total(m, "missed")) == (found, missed), m
        assert total(m, "count") == 90
        assert sum(bool(r["failed"]) for r in rows if r["method"] == m) == failed, m
        digits = 1 if seconds < 10 else 0
        assert round(sum(float(r["seconds"]) for r in rows if r["method"] == m), digits) \
            == seconds, m
    assert sum(total(m, "spurious") for m in ms.METHODS) == 0

    def missed_at(m):
        return [(float(r["k"]), float(r["c_max"])) for r in rows
                if r["method"] == m and r["missed"] != "0"]

    assert missed_at("tiling") == [(12.0, 8.0)]
    assert missed_at("ciss") == [(6.0, 4.0), (6.0, 8.0), (12.0, 4.0), (12.0, 8.0)]
    assert len(missed_at("nleigs")) == 7 and min(k for k, _ in missed_at("nleigs")) == 2.0
    assert max(int(r["missed"]) for r in rows if r["method"] == "nleigs") == 9
    for m in ("ciss", "nleigs"):
        assert {r["failed"] for r in rows if r["method"] == m} == {"", "SLEPc DIVERGED_ITS"}
    assert all("pencil" in r["failed"] for r in rows if r["method"] == "dense" and r["failed"])
    # README reading: per-point time ratios against moments
    sec = {(r["k"], r["c_max"], r["method"]): float(r["seconds"]) for r in rows}
    points = {(r["k"], r["c_max"]) for r in rows}
    for m, (lo, hi) in {"linear": (0.69, 1.0), "newton": (1.1, 4.0), "ciss": (10.5, 22),
                        "nleigs": (1.8, 8.6), "tiling": (0.49, 4.6)}.items():
        ratios = [sec[(*pt, m)] / sec[(*pt, "moments")] for pt in points]
        digits = 0 if hi >= 10 else 1
        assert (round(min(ratios), 2 if lo < 1 else 1), round(max(ratios), digits)) == (lo, hi), m


@pytest.mark.serial
def test_help_lists_every_prefix():
    proc = run_workflow("methods_chart.py", ["--help"], 1)
    assert proc.returncode == 0, proc.stderr[-2000:]
    text = " ".join(proc.stdout.split())
    for p in ("methods_tiling_", "methods_ciss_", "methods_nleigs_"):
        assert f"'{p}'" in text
