"""Smoke tests of workflows/halfspace_modes.py: serial, mpirun -n 2, bad input.

Launched once (serial pass); the MPI run is a subprocess.
"""

import csv
import json
import os

import pytest
from _workflows import run_workflow

TINY = ["--k", "0.3,1.0", "--H-trunc", "50", "--bc-trunc", "velocity", "--degree", "3"]

pytestmark = pytest.mark.serial


def _run(args, out, n=1):
    return run_workflow("halfspace_modes.py", [*args, "--out", str(out)], n)


def _rows(out):
    with open(os.path.join(out, "halfspace_modes.csv")) as fh:
        return list(csv.DictReader(fh))


@pytest.mark.parametrize("n", [1, 2])
def test_run_writes_outputs_and_flags_truncation(tmp_path, n):
    proc = _run(TINY, tmp_path, n)
    assert proc.returncode == 0, proc.stderr[-2000:]
    for name in ("halfspace_modes.csv", "summary.json", "halfspace_modes.png"):
        assert (tmp_path / name).stat().st_size > 0
    rows = _rows(tmp_path)
    assert len(rows) == 4  # 2 k x (PML + one strip)
    pml = {float(r["k"]): r for r in rows if r["method"] == "pml"}
    # k = 0.3: physical root; k = 1.0 is past q_c = 0.707: the s~ root (Appendix C).
    assert pml[0.3]["sheet"] == "physical" and pml[1.0]["sheet"] == "s_tilde"
    for r in pml.values():
        assert r["trusted"] == "True"
        # P3 layer: measured 4.0e-12 and 1.1e-12 (2026-11-21).
        assert float(r["rel_error"]) < 2e-11
    for r in rows:
        if r["method"] == "truncated":  # H = 50 strips reflect: flagged, and wrong
            assert r["trusted"] == "False" and "reflection" in r["flags"]
            assert float(r["rel_error"]) > 1e-5
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["silent_failures"] == 0 and summary["ranks"] == n


@pytest.mark.parametrize("n", [1, 2])
def test_half_space_slider_on_a_finite_substrate(tmp_path, n):
    """Two bodies: every exact root under the slider's shear cut, each with a trusted PML row."""
    args = ["--k", "0.5,1.0", "--degree", "3", "--mu2", "2", "--rho2", "1.5", "--beta2",
            "0.55", "--H2", "0.7", "--bc2", "stress"]
    proc = _run(args, tmp_path, n)
    assert proc.returncode == 0, proc.stderr[-2000:]
    rows = _rows(tmp_path)
    # one root on each side of the real axis at each k (counted by the argument principle)
    assert sorted((r["k"], r["branch"]) for r in rows) == [
        ("0.5", "+"), ("0.5", "-"), ("1.0", "+"), ("1.0", "-")]
    for r in rows:
        assert r["method"] == "pml" and r["family"] == "two-body" and r["trusted"] == "True"
        # P3: measured 1.97e-8 .. 2.07e-8 (2026-11-24), serial and 2 ranks; the two PML
        # settings agree to 3e-14: the error is the substrate's mesh, not the layer.
        assert float(r["rel_error"]) < 2.2e-8
        assert float(r["disagreement"]) < 1e-12
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["silent_failures"] == 0 and summary["ranks"] == n


@pytest.mark.parametrize("bad", [["--degree", "0"], ["--k", "-1"], ["--bc-trunc", "free"],
                                 ["--attenuation", "-3"], ["--gamma", "-1"],
                                 ["--branch", "sideways"], ["--overlay-name", "../x"],
                                 ["--mu2", "2"]])
def test_bad_input_exits_2_and_writes_nothing(tmp_path, bad):
    out = tmp_path / "out"
    proc = _run(bad, out)
    assert proc.returncode == 2
    assert proc.stderr.strip().count("\n") == 0 and proc.stderr.startswith("error:")
    assert not out.exists()
