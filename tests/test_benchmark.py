"""forms.studies.benchmark: the measurements of workflows/benchmark.py (errors and orders, no
times).

The models live on COMM_SELF: every rank of the mpirun -n 2 pass computes the same numbers.
"""

import numpy as np
import pytest

from forms.studies import benchmark as bench


@pytest.mark.parametrize("degree, cells", [(2, (6, 12)), (3, (3, 6))])
def test_convergence_order_is_2p_at_the_check_point(degree, cells):
    rows = bench.convergence({degree: cells})
    assert [(r["degree"], r["cells"]) for r in rows] == [(degree, c) for c in cells]
    assert np.isnan(rows[0]["order"]) and rows[1]["rel_error"] < rows[0]["rel_error"]
    # eigenvalue error h^(2p): observed 3.99 (P2, 6 -> 12 cells) and 5.95 (P3, 3 -> 6 cells)
    assert rows[1]["order"] == pytest.approx(2 * degree, abs=0.1)


@pytest.mark.serial
def test_speed_reports_errors_of_every_method():
    """Baseline and FE continuation against the certified exact roots on a short grid."""
    k = np.linspace(0.2, 2.0, 8)
    res = bench.speed(k)
    assert res["k"] == [0.2, 2.0, 8] and res["analytic_certified"]["all_ok"]
    # Newton on S converges to the exact roots: measured 1.6e-16 here, 2.4e-16 on 0.05:6:40
    assert res["baseline"]["max_rel_error"] < 1e-12
    fe = res["fe_continuation"]
    assert fe is not None and fe["max_rel_error"] <= bench.FE_TARGET_ERROR
    assert fe["cells"] in bench.FE_CELLS and fe["factorizations_per_point"] >= 1
    # the mesh is the cheapest that meets the target: one cell size fewer does not
    assert fe["cells"] == bench.FE_CELLS[0] or bench.speed(
        k, fe_cells=bench.FE_CELLS[:bench.FE_CELLS.index(fe["cells"])])["fe_continuation"] is None


@pytest.mark.parametrize("value, met", [(1.5, True), (2.0, True), (2.5, False), (None, False)])
def test_check_targets_misses_are_reported(value, met):
    """A target is met at or below its value (>= for at_least); a missing value is missed."""
    out = bench.check_targets({"a": value}, {"a": 2.0, "b": 1.0})
    assert [t["met"] for t in out] == [met, False]
    assert out[1]["value"] is None
    assert bench.check_targets({"c": value}, {"c": 2.0}, at_least=("c",))[0]["met"] == (
        value is not None and value >= 2.0)


def test_all_targets_collects_sweeps_and_speed():
    """all_targets: the speed ratios, the sweep targets and the cost per eigenvalue."""
    report = {"speed": {"ratios": {"analytic_certified_over_baseline": 9.0,
                                   "target_analytic": 10.0, "fe_over_baseline": 25.0,
                                   "target_fe": 20.0},
                        "baseline": {"s_per_point": 1e-4}},
              "sweeps": {"cases": {"c": {"ranks": 2, "runs": {"fe_first": {
                  "wall_s": 1.0, "rows": 100}}}},
                         "targets": bench.check_targets({"c_fe_first_s": 1.0},
                                                        {"c_fe_first_s": 2.0})}}
    out = {t["name"]: t for t in bench.all_targets(report)}
    assert out["analytic_certified_over_baseline"]["met"]
    assert not out["fe_continuation_over_baseline"]["met"]
    assert out["c_fe_first_s"]["met"]
    # 1.0 s x 2 ranks / 100 rows / 1e-4 s per point = 200 > 100
    assert out["c_per_eigenvalue_over_baseline"]["value"] == pytest.approx(200.0)
    assert not out["c_per_eigenvalue_over_baseline"]["met"]


@pytest.mark.serial
def test_certified_sweeps_side_by_side(tmp_path):
    """Two modes of the sweep on two k, one rank: same rows, the ratio and the targets."""
    import os

    script = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                          "workflows", "sweep_k.py")
    modes = {m: bench.SWEEP_MODES[m] for m in ("fe_first", "exact_seeded")}
    res = bench.certified_sweeps(script, {"small": ("0.5,1", [], 1)}, modes)
    runs = res["cases"]["small"]["runs"]
    assert all(r["exit_code"] == 0 and r["k_not_closed"] == 0 for r in runs.values())
    assert runs["fe_first"]["rows"] == runs["exact_seeded"]["rows"] > 0
    assert res["ratios"]["small"] == pytest.approx(
        runs["fe_first"]["wall_s"] / runs["exact_seeded"]["wall_s"])
    # no wall-time target for a case of our own; the ratio target (issue 15) always
    assert [t["name"] for t in res["targets"]] == ["small_fe_first_over_exact_seeded"]


@pytest.mark.serial
def test_estimate_adds_the_sections():
    """The plan's model: linear in the speed grid, one sweep estimate per case and mode."""
    from analytic.cli import parse_k

    k = parse_k("0.05:6:120")
    base = bench.estimate_seconds(100, k, {}, False)
    assert bench.estimate_seconds(200, k, {}, False) - base == pytest.approx(
        100 * bench.SPEED_S_PER_K)
    one = bench.estimate_seconds(100, k, {"v": bench.SWEEP_CASES["default_velocity"]}, False)
    two = bench.estimate_seconds(100, k, {c: bench.SWEEP_CASES[c] for c in
                                          ("default_velocity", "k50_51")}, False)
    assert base < one < two
    assert bench.estimate_seconds(100, k, {}, True) > base  # the two MPI sweeps


@pytest.mark.serial
def test_benchmark_prints_its_plan_first(tmp_path):
    """One plan line before the results; the run's wall time within 10x of it (the machine is
    shared: measured 4.9 s against 5.6 s at a load average of 1, 2026-11-25)."""
    import os
    import re
    import subprocess
    import sys
    import time

    script = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                          "workflows", "benchmark.py")
    t0 = time.perf_counter()
    res = subprocess.run([sys.executable, script, "--skip-mpi", "--sweeps", "none", "--k",
                          "0.05:6:40", "--out", str(tmp_path / "b")], capture_output=True,
                         text=True, timeout=600)
    wall = time.perf_counter() - t0
    assert res.returncode in (0, 1), res.stderr[-2000:]  # 1: a target missed (reported)
    plans = [ln for ln in res.stderr.splitlines() if ln.startswith("plan:")]
    assert len(plans) == 1, res.stderr[-2000:]
    est = float(re.search(r"about ([\d.]+) s", plans[0]).group(1))
    assert est / 10 < wall < est * 10, (wall, plans[0])
