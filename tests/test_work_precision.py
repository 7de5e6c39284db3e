"""Smoke tests of workflows/work_precision.py (tiny configuration): serial and mpirun -n 2,
plus the dense companion baseline against the sparse PEP on one small operator.

The workflow runs are subprocesses, launched once (serial pass).
"""

import csv
import json

import pytest
from _workflows import run_workflow

CHECK_VALUE = 0.2716852879456 - 6.5866951866228j  # docs/design.md section 4


def _run(args, out, n=1):
    return run_workflow("work_precision.py", [*args, "--out", str(out)], n)


@pytest.mark.serial
@pytest.mark.parametrize("n", [1, 2])
def test_tiny_run(tmp_path, n):
    proc = _run(["--tiny", "--repeats", "1"], tmp_path, n)
    assert proc.returncode == 0, proc.stderr[-2000:]
    for name in ("work_precision.csv", "summary.json", "work_precision.png"):
        assert (tmp_path / name).stat().st_size > 0
    with open(tmp_path / "work_precision.csv") as fh:
        rows = list(csv.DictReader(fh))
    methods = {(r["case"], r["method"]) for r in rows}
    assert {("finite_H", "PEP"), ("finite_H", "NEP"), ("finite_H", "dense"),
            ("finite_H", "analytic"), ("halfspace", "PML PEP"), ("halfspace", "PML NEP"),
            ("halfspace", "analytic")} <= methods
    assert any(r["pareto"] == "True" for r in rows if r["case"] == "finite_H")
    for r in rows:
        assert float(r["seconds"]) > 0
        if r["method"] in ("PEP", "NEP", "dense") and r["degree"] == "3":
            # P3, 4 uniform cells on H = 0.5: measured 8.8e-8 (2026-11-21), all three solvers.
            assert float(r["rel_error"]) < 2e-7
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["ranks"] == n and "machine" in summary and "dolfinx" in summary


@pytest.mark.serial
def test_bad_repeats_exits_2(tmp_path):
    out = tmp_path / "out"
    proc = _run(["--repeats", "0"], out)
    assert proc.returncode == 2 and proc.stderr.startswith("error:")
    assert not out.exists()


def test_dense_companion_matches_pep():
    """The dense baseline solves the same polynomial problem as SLEPc's PEP."""
    from mpi4py import MPI

    from analytic.params import Params
    from forms.models.cross_section import CrossSectionModel
    from forms.solvers.slepc import PolynomialSolver, dense_companion_eig

    model = CrossSectionModel(MPI.COMM_SELF, Params(), degree=3, cells=6)
    op = model.operator(1.0)
    lam_dense = dense_companion_eig(op, -6.6j)
    solver = PolynomialSolver(MPI.COMM_SELF, nev=1)
    res = solver.solve(op, -6.6j)
    lam_pep = res.pairs[0].value
    # same discrete eigenvalue: measured 1e-14 apart; both 6e-9 from the exact root (P3, 6 cells).
    assert abs(lam_dense - lam_pep) / abs(lam_pep) < 1e-11
    assert abs(lam_dense - CHECK_VALUE) / abs(CHECK_VALUE) < 1e-7
    res.destroy()
    solver.destroy()
    model.destroy()


# ----------------------------------------------------------- forms/studies/work_precision.py
# directly
def _pt(case, method, seconds, err):
    from forms.studies.work_precision import error_row

    ref = 1.0 + 0j
    return error_row(case, method, 2, 4, 10, seconds, ref * (1 + err), ref)


@pytest.mark.serial
@pytest.mark.parametrize("case", ["finite_H", "halfspace"])
@pytest.mark.parametrize("fe_only", [False, True])
def test_mark_pareto(case, fe_only):
    """Dominance in time and error, with errors within PARETO_SLACK counted as equal."""
    from forms.studies.work_precision import PARETO_SLACK, mark_pareto

    other = "halfspace" if case == "finite_H" else "finite_H"
    rows = {"analytic": _pt(case, "analytic", 1e-4, 1e-15),
            "fast": _pt(case, "PEP", 0.01, 1e-6),
            "accurate": _pt(case, "PEP", 0.1, 1e-10),
            "slower_same": _pt(case, "NEP", 0.2, 1e-6),
            "within_slack": _pt(case, "NEP", 0.05, 1e-6 / (0.9 * PARETO_SLACK)),
            "beyond_slack": _pt(case, "NEP", 0.04, 1e-6 / (1.1 * PARETO_SLACK)),
            "no_root": _pt(case, "PEP", 1e-5, float("nan")),
            "other_case": _pt(other, "PEP", 10.0, 1e-3)}
    key = "pareto_fe" if fe_only else "pareto"
    mark_pareto(list(rows.values()), key, fe_only=fe_only)
    front = {name for name, r in rows.items() if r[key]}
    fe_front = {"fast", "accurate", "beyond_slack", "other_case"}
    assert front == (fe_front if fe_only else {"analytic", "other_case"})
    assert rows["no_root"]["rel_error"] == float("inf")


@pytest.mark.serial
def test_best_of_and_rows():
    from forms.studies.work_precision import (
        best_of,
        error_row,
        fastest_seconds,
        job_cost,
        make_jobs,
    )

    calls = []
    sec, out = best_of(lambda x: calls.append(x) or len(calls), 3, "a")
    assert calls == ["a"] * 3 and out == 3 and 0 < sec < float("inf")
    sec, out = best_of(lambda: calls.append(0) or len(calls), 3, budget=0.0)
    assert out == 4  # budget spent after the first run
    r = error_row("finite_H", "PEP", 3, 4, 26, 0.5, 2.0 + 1j, 2.0)
    assert r["rel_error"] == pytest.approx(0.5) and (r["re_lambda"], r["im_lambda"]) == (2.0, 1.0)
    rows = [r, error_row("finite_H", "PEP", 3, 8, 50, 0.2, 2.0 + 1e-7j, 2.0),
            error_row("finite_H", "PEP", 3, 9, 60, 0.9, 2.0 + 1e-12j, 2.0)]
    assert fastest_seconds(rows) == {"finite_H PEP err<=1e-06": 0.2,
                                     "finite_H PEP err<=1e-10": 0.9}
    jobs = make_jobs({2: (4, 8), 3: (4,)}, {2: (2.0,)})
    assert [j[0] for j in jobs] == ["finite"] * 3 + ["half", "analytic"]
    assert job_cost("finite", 2, (8,)) > job_cost("finite", 2, (4,))
    assert job_cost("half", 2, (1.0,)) > job_cost("half", 2, (2.0,))


@pytest.mark.parametrize("job", [("finite", 3, (4,)), ("half", 2, (2.0,)), ("analytic", 0, ())])
def test_job_points(job):
    """One job of each kind, as the scene runs it (one rank each)."""
    from mpi4py import MPI

    from forms.studies.work_precision import COLUMNS, job_points, merge_rows, reference_cases

    cases = reference_cases()
    rows = job_points(MPI.COMM_SELF, job, cases, 1, True, prefixes=("twp_pep_", "twp_nep_"))
    # the P2 layer has 314 unknowns: its companion pencil (942) exceeds DENSE_MAX, no dense row
    methods = {"finite": ["NEP", "PEP", "dense"], "half": ["PML NEP", "PML PEP"],
               "analytic": ["analytic", "analytic"]}[job[0]]
    assert sorted(r["method"] for r in rows) == methods
    for r in rows:
        assert tuple(r) == COLUMNS and r["seconds"] > 0
        ref = cases.lam_finite if r["case"] == "finite_H" else cases.lam_half
        if job[0] == "finite":
            # P3, 4 uniform cells on H = 0.5: measured 8.8e-8 (2026-11-22), all three solvers.
            assert 1e-8 < r["rel_error"] < 2e-7
        elif job[0] == "half":
            # P2 PML, cell size x2: measured 8.8e-10 (2026-11-22), PEP and NEP.
            assert 1e-10 < r["rel_error"] < 2e-9
        else:
            # Newton against the 13-digit check value: measured 3.5e-15; the half-space root
            # against a second start: 1.4e-19 (2026-11-22).
            assert r["rel_error"] < 1e-13
            ref = complex(r["re_lambda"], r["im_lambda"])
        assert abs(complex(r["re_lambda"], r["im_lambda"]) - ref) / abs(ref) == pytest.approx(
            r["rel_error"], rel=1e-6, abs=1e-14)
    merged = merge_rows([rows[1:], rows[:1]])
    assert [r["method"] for r in merged] == methods
    assert any(r["pareto"] for r in merged)
    assert any(r["pareto_fe"] for r in merged) == (job[0] != "analytic")
