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
    from forms.cross_section import CrossSectionModel
    from forms.solvers import PolynomialSolver, dense_companion_eig

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
