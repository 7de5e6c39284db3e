"""Smoke and consistency tests of workflows/phase_diagram.py (serial and mpirun -n 2)."""

import csv
import json
import os

import pytest
from _workflows import run_workflow

from analytic.physics import largek as lk

TINY = ["--f", "0.3", "--n-gamma", "2", "--gamma-min", "1e-4", "--gamma-max", "0.5"]


def run(args, nproc=1):
    return run_workflow("phase_diagram.py", args, nproc)


def read(out):
    with open(os.path.join(out, "boundaries.csv")) as fh:
        return list(csv.DictReader(fh))


@pytest.mark.slow  # measured 13 s (2026-11-22, serial pass)
@pytest.mark.serial
def test_phase_diagram_smoke_serial_and_mpi(tmp_path):
    from PIL import Image

    results = {}
    for nproc, betas in ((1, "0.45,0.6"), (2, "0.6")):
        out = str(tmp_path / f"pd{nproc}")
        args = [*TINY, "--beta", betas, "--out", out]
        res = run(args, nproc)
        assert res.returncode == 0, res.stderr
        results[nproc] = rows = read(out)
        assert list(rows[0].keys()) == ["boundary", "source", "f", "beta", "Gamma", "Delta"]
        assert {r["boundary"] for r in rows} == {"dilatational", "shear", "quasistatic"}
        assert {r["source"] for r in rows} == {"closed_form", "numerical"}
        assert {r["beta"] for r in rows} == set(betas.split(","))
        # numerical dilatational threshold = Delta/(beta(1/beta^2-2)) (issue: 1e-3; measured
        # <= 2.9e-9 on the default grid)
        num = [r for r in rows if r["boundary"] == "dilatational" and r["source"] == "numerical"]
        assert len(num) >= 2 * len(betas.split(","))
        for r in num:
            exact = float(lk.delta_d(float(r["Gamma"]), float(r["beta"])))
            assert abs(float(r["Delta"]) / exact - 1) < 1e-8
        meta = json.load(open(os.path.join(out, "phase_diagram.json")))
        assert meta["parameters"]["ranks"] == nproc
        assert "numpy" in meta["versions"]
        png = os.path.join(out, "phase_diagram.png")
        assert os.path.getsize(png) > 10_000
        info = Image.open(png).info
        assert "phase_diagram.py" in info["Description"] and "n_gamma" in info["Comment"]
    # the MPI split does not change a digit (same row computed serially and on 2 ranks)
    assert [r for r in results[1] if r["beta"] == "0.6"] == results[2]


@pytest.mark.serial
@pytest.mark.parametrize("args, word", [
    (["--beta", "0.8"], "beta"),
    (["--f", "-0.1"], "f"),
    (["--f", "0"], "f"),
    (["--f", "0.3,0.2", "--beta", "0.4,0.5,0.6"], "--f"),
    (["--gamma-min", "1", "--gamma-max", "0.5"], "gamma-min"),
    (["--n-gamma", "1"], "n-gamma"),
    (["--delta-max", "nan"], "delta-max"),
    (["--out", "/etc/hostname"], "--out"),
])
def test_bad_input_exit_2(tmp_path, args, word):
    out = tmp_path / "never"
    res = run(["--out", str(out), *args])
    assert res.returncode == 2
    lines = [ln for ln in res.stderr.strip().splitlines() if ln.strip()]
    assert len(lines) == 1 and word in lines[0]
    assert not out.exists()
