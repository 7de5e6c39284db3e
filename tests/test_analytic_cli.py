import csv
import io
import json
import os
import subprocess
import sys

import pytest

from analytic.cli import main

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CHECK_VALUE = 0.2716852879456 - 6.5866951866228j  # docs/design.md section 4


def _run(*args, cwd=None):
    env = dict(os.environ)
    env["PYTHONPATH"] = ROOT + os.pathsep + env.get("PYTHONPATH", "")
    return subprocess.run([sys.executable, "-m", "analytic", *args], capture_output=True,
                          text=True, env=env, cwd=cwd, timeout=120)


@pytest.mark.serial
def test_branch_csv_contains_the_check_value():
    r = _run("branch", "--k", "0.5,1,2", "--H", "0.5", "--bc", "velocity", "--branches", "2")
    assert r.returncode == 0, r.stderr
    rows = list(csv.DictReader(io.StringIO(r.stdout)))
    assert list(rows[0]) == ["k", "branch", "re_lambda", "im_lambda", "residual", "flag"]
    assert all(row["flag"] == "" for row in rows)
    assert len(rows) == 3 * 4
    assert sorted({row["branch"] for row in rows}) == ["0+", "0-", "1+", "1-"]
    row = next(x for x in rows if x["branch"] == "0-" and float(x["k"]) == 1.0)
    L = complex(float(row["re_lambda"]), float(row["im_lambda"]))
    assert abs(L - CHECK_VALUE) / abs(CHECK_VALUE) < 1e-12
    assert float(row["residual"]) < 1e-13


@pytest.mark.serial
@pytest.mark.parametrize(
    "args,needle",
    [
        (["branch", "--k", "0.5,-1"], "k"),
        (["branch", "--k", "0:1:3"], "k"),
        (["branch", "--k", "1", "--beta", "0.8"], "beta"),
        (["branch", "--k", "1", "--H", "0"], "H"),
        (["branch", "--k", "1", "--H", "inf"], "H"),
        (["branch", "--k", "1", "--gamma", "-1"], "gamma"),
        (["branch", "--k", "1", "--f", "nan"], "f"),
        (["branch", "--k", "1", "--branches", "0"], "branches"),
        (["branch", "--k", "1", "--f", "x"], "--f"),
        (["units", "--nu", "0.6"], "nu"),
        (["dispersion"], "--out"),
    ],
)
def test_bad_input_one_line_exit_2(args, needle, tmp_path):
    r = _run(*args, cwd=tmp_path)
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], r.stderr
    assert r.stdout == ""
    assert list(tmp_path.iterdir()) == []  # nothing half-written


@pytest.mark.serial
def test_units_subcommand_json():
    r = _run("units", "--mu", "3e10", "--nu", "0.25", "--rho", "2700", "--sigma0", "5e7",
             "--v0", "1e-6", "--D", "1e-5", "--f", "0.6", "--a", "0.015", "--b", "0.01",
             "--H-m", "10")
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["dimensionless"]["Delta"] == pytest.approx(1 / 3)
    assert out["units"]["t0_s"] == pytest.approx(10.0)


@pytest.mark.serial
def test_dispersion_writes_csv_json_png(tmp_path):
    out = tmp_path / "disp"
    r = _run("dispersion", "--out", str(out), "--k", "0.1:3:12", "--branches", "1")
    assert r.returncode == 0, r.stderr
    assert {p.name for p in out.iterdir()} == {"dispersion.csv", "dispersion.json",
                                               "dispersion.png"}
    rows = list(csv.DictReader(open(out / "dispersion.csv")))
    assert len(rows) == 2 * 12 and all(row["ok"] == "1" for row in rows)
    info = json.loads((out / "dispersion.json").read_text())
    assert info["params"]["H"] == 0.5 and "numpy" in info["versions"]
    assert (out / "dispersion.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.serial
def test_main_in_process_returns_2_on_bad_input(capsys):
    """Every rank returns 2; under mpirun only rank 0 prints the line."""
    from analytic.cli import rank as _rank

    assert main(["branch", "--k", "1", "--Delta", "nan"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    if _rank() == 0:
        assert len(err) == 1 and "Delta" in err[0]
    else:
        assert err == []
