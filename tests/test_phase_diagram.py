"""Smoke and consistency tests of workflows/phase_diagram.py (serial and mpirun -n 2)."""

import csv
import json
import os
import shutil
import subprocess
import sys

import pytest

from analytic import largek as lk

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPT = os.path.join(ROOT, "workflows", "phase_diagram.py")
TINY = ["--f", "0.3", "--beta", "0.45,0.6", "--n-gamma", "2", "--gamma-min", "1e-4",
        "--gamma-max", "0.5"]


def run(args, nproc=1):
    cmd = [sys.executable, SCRIPT, *args]
    if nproc > 1:
        mpirun = shutil.which("mpirun")
        if mpirun is None:
            pytest.skip("mpirun not available")
        cmd = [mpirun, "-n", str(nproc), sys.executable, "-m", "mpi4py", SCRIPT, *args]
    # os.environ is the start-up environment: a singleton MPI_Init in this process (any test
    # that imports mpi4py) adds PMIX_/OMPI_ variables at C level that would confuse mpirun.
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PMIX_", "OMPI_COMM_"))}
    return subprocess.run(cmd, capture_output=True, text=True, timeout=300, cwd=ROOT, env=env)


def read(out):
    with open(os.path.join(out, "boundaries.csv")) as fh:
        return list(csv.DictReader(fh))


@pytest.mark.serial
def test_phase_diagram_smoke_serial_and_mpi(tmp_path):
    results = {}
    for nproc in (1, 2):
        out = str(tmp_path / f"pd{nproc}")
        res = run([*TINY, "--out", out], nproc)
        assert res.returncode == 0, res.stderr
        results[nproc] = rows = read(out)
        assert list(rows[0].keys()) == ["boundary", "source", "f", "beta", "Gamma", "Delta"]
        assert {r["boundary"] for r in rows} == {"dilatational", "shear", "quasistatic"}
        assert {r["source"] for r in rows} == {"closed_form", "numerical"}
        assert {r["beta"] for r in rows} == {"0.45", "0.6"}
        # numerical dilatational threshold = Delta/(beta(1/beta^2-2)) (issue: 1e-3; measured
        # <= 2.9e-9 on the default grid)
        num = [r for r in rows if r["boundary"] == "dilatational" and r["source"] == "numerical"]
        assert len(num) >= 4
        for r in num:
            exact = float(lk.delta_d(float(r["Gamma"]), float(r["beta"])))
            assert abs(float(r["Delta"]) / exact - 1) < 1e-8
        meta = json.load(open(os.path.join(out, "phase_diagram.json")))
        assert meta["parameters"]["ranks"] == nproc
        assert "numpy" in meta["versions"]
        png = os.path.join(out, "phase_diagram.png")
        assert os.path.getsize(png) > 10_000
        from PIL import Image

        info = Image.open(png).info
        assert "phase_diagram.py" in info["Description"] and "n_gamma" in info["Comment"]
    assert results[1] == results[2]  # the MPI split does not change a digit


@pytest.mark.serial
@pytest.mark.parametrize("args, word", [
    (["--beta", "0.8"], "beta"),
    (["--f", "-0.1"], "f"),
    (["--f", "0"], "f"),
    (["--f", "0.3,0.2", "--beta", "0.4,0.5,0.6"], "--f"),
    (["--gamma-min", "1", "--gamma-max", "0.5"], "gamma-min"),
    (["--n-gamma", "1"], "n-gamma"),
    (["--delta-max", "nan"], "delta-max"),
])
def test_bad_input_exit_2(tmp_path, args, word):
    out = tmp_path / "never"
    res = run([*args, "--out", str(out)])
    assert res.returncode == 2
    lines = [ln for ln in res.stderr.strip().splitlines() if ln.strip()]
    assert len(lines) == 1 and word in lines[0]
    assert not out.exists()
