"""Smoke tests of workflows/sweep_k.py: serial, mpirun -n 2, rank independence, bad input,
--resume. Launched once (serial pass); the MPI runs are subprocesses."""

import csv
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPT = os.path.join(ROOT, "workflows", "sweep_k.py")
CHECK_VALUE = 0.2716852879456 - 6.5866951866228j  # DESIGN.md section 4 (k = 1, branch 0-)
TINY = ["--k", "0.5,1.0,1.5", "--branches", "1", "--quiet", "--no-plot"]

pytestmark = pytest.mark.serial


def _run(args, out, n=1, check=True):
    cmd = [sys.executable, SCRIPT, *args, "--out", str(out)]
    if n > 1:
        cmd = ["mpirun", "-n", str(n), *cmd]
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=300)
    if check:
        assert proc.returncode == 0, proc.stderr[-2000:]
    return proc


def _table(out):
    with open(os.path.join(out, "spectrum.csv")) as fh:
        return list(csv.DictReader(fh))


def _values(rows):
    return np.array([[float(r["k"]), float(r["re_lambda"]), float(r["im_lambda"])] for r in rows])


def test_serial_run_writes_outputs_and_check_value(tmp_path):
    out = tmp_path / "s"
    _run(["--k", "0.5,1.0", "--branches", "1", "--quiet"], out)
    rows = _table(out)
    assert [r["branch"] for r in rows] == ["0-", "0+", "0-", "0+"]
    assert all(r["status"] == "ok" for r in rows)
    row = next(r for r in rows if r["branch"] == "0-" and float(r["k"]) == 1.0)
    lam = complex(float(row["re_lambda"]), float(row["im_lambda"]))
    # default discretisation (P3, chosen cells): measured relative error 1e-12, 2026-11-21.
    assert abs(lam - CHECK_VALUE) / abs(CHECK_VALUE) < 1e-10
    assert float(row["residual"]) < 1e-13
    summary = json.loads((out / "summary.json").read_text())
    assert summary["parameters"]["f"] == 0.3 and summary["mpi"]["ranks"] == 1
    assert summary["failures"] == [] and "petsc" in summary["versions"]
    assert summary["most_unstable"]["branch"] == "0-"
    assert (out / "dispersion.png").stat().st_size > 10000


@pytest.mark.parametrize("group_size", [1, 2])
def test_mpi_run_equals_serial_run(tmp_path, group_size):
    _run(TINY, tmp_path / "n1")
    _run([*TINY, "--group-size", str(group_size)], tmp_path / "n2", n=2)
    a, b = _table(tmp_path / "n1"), _table(tmp_path / "n2")
    assert [r["branch"] for r in a] == [r["branch"] for r in b]
    va, vb = _values(a), _values(b)
    assert np.abs(va - vb).max() < 1e-10
    summary = json.loads((tmp_path / "n2" / "summary.json").read_text())
    assert summary["mpi"] == {"ranks": 2, "group_size": group_size, "groups": 2 // group_size}


def test_failed_solves_are_recorded_and_sweep_goes_on(tmp_path):
    # a PETSc option that makes every PEP set-up fail (no shift-and-invert with LU on T(sigma))
    out = tmp_path / "fail"
    proc = _run([*TINY, "-st_type", "shift"], out, check=False)
    assert proc.returncode == 1
    rows = _table(out)
    assert len(rows) == 6 and all(r["status"].startswith("failed") for r in rows)
    assert all(r["re_lambda"] == "" for r in rows)
    summary = json.loads((out / "summary.json").read_text())
    assert len(summary["failures"]) == 6


def test_nep_solver_matches_pep(tmp_path):
    _run(TINY, tmp_path / "pep")
    _run([*TINY, "--solver", "nep"], tmp_path / "nep")
    a, b = _table(tmp_path / "pep"), _table(tmp_path / "nep")
    assert [r["branch"] for r in a] == [r["branch"] for r in b]
    # same discretisation, PEP (polynomial form) vs NEP (split rational form): measured
    # largest relative difference 1e-11, 2026-11-21.
    va, vb = _values(a), _values(b)
    la, lb = va[:, 1] + 1j * va[:, 2], vb[:, 1] + 1j * vb[:, 2]
    assert np.max(np.abs(la - lb) / np.abs(la)) < 1e-10
    summary = json.loads((tmp_path / "nep" / "summary.json").read_text())
    assert summary["solver"]["form"] == "split"


@pytest.mark.parametrize(
    "bad",
    [["--beta", "0.9"], ["--k=-1,2"], ["--k", "1:0:5"], ["--degree", "0"], ["--nope", "1"],
     ["--H", "inf"], ["--group-size", "3"], ["--gamma", "nan"]],
)
def test_bad_input_exit_2_nothing_written(tmp_path, bad):
    out = tmp_path / "bad"
    proc = _run([*TINY, *bad], out, check=False)
    assert proc.returncode == 2
    assert len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert not out.exists()


def test_resume_recomputes_only_missing_k(tmp_path):
    out = tmp_path / "r"
    _run(TINY, out)
    full = _values(_table(out))
    os.remove(out / "raw" / "k00001.npz")
    os.remove(out / "spectrum.csv")
    _run([*TINY, "--resume"], out)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["computed_this_run"] == 1 and summary["resumed"]
    assert np.abs(_values(_table(out)) - full).max() < 1e-12
    # resuming with other settings is refused and leaves the files alone
    before = (out / "spectrum.csv").read_text()
    proc = _run([*TINY, "--resume", "--f", "0.4"], out, check=False)
    assert proc.returncode == 2 and "different settings" in proc.stderr
    assert (out / "spectrum.csv").read_text() == before


def test_interrupted_sweep_keeps_finished_k_and_resumes(tmp_path):
    out = tmp_path / "int"
    args = ["--k", "0.05:3:300", "--branches", "1", "--quiet", "--no-plot"]
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.Popen([sys.executable, SCRIPT, *args, "--out", str(out)], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    raw = out / "raw"
    deadline = time.time() + 120
    while time.time() < deadline and (not raw.exists() or len(list(raw.glob("k*.npz"))) < 5):
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)  # Ctrl-C
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130 and b"--resume" in err
    finished = sorted(p.name for p in raw.glob("k*.npz"))
    assert 5 <= len(finished) < 300
    assert not (out / "spectrum.csv").exists()
    before = {name: (raw / name).stat().st_mtime_ns for name in finished}
    _run([*args, "--resume"], out)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["computed_this_run"] == 300 - len(finished)
    assert all((raw / name).stat().st_mtime_ns == t for name, t in before.items())
    rows = _table(out)
    assert len(rows) == 600 and all(r["status"] == "ok" for r in rows)
