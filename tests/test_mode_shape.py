"""workflows/mode_shape.py: files readable back, pictures drawn without a display, serial and MPI.

The workflow runs in a subprocess (it must import pyvista before dolfinx, see its header), once
serially and once under ``mpirun -n 2``; these tests are marked serial so each launches once.
"""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPT = os.path.join(ROOT, "workflows", "mode_shape.py")
CHECK_VALUE = 0.2716852879456 - 6.5866951866228j  # docs/design.md section 4
TINY = ["--cells-per-wavelength", "12", "--ny", "3", "--phases", "3", "--nev", "6"]


def _run(cmd, **kw):
    env = dict(os.environ)
    env.pop("DISPLAY", None)  # rendering must work with no display
    return subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=300, **kw)


@pytest.mark.serial
@pytest.mark.parametrize("ranks", [1, 2])
def test_mode_shape_files(tmp_path, ranks):
    import pyvista as pv  # a dependency; imported here, after the subprocess-only workflow
    from PIL import Image

    out = tmp_path / "out"
    cmd = [sys.executable, SCRIPT, "--out", str(out), *TINY]
    if ranks > 1:
        cmd = ["mpirun", "-n", str(ranks), *cmd]
    res = _run(cmd)
    assert res.returncode == 0, res.stderr[-3000:]

    meta = json.loads((out / "mode.json").read_text())
    lam = complex(*meta["eigenvalue"])
    assert meta["ranks"] == ranks
    # measured 3.20e-4 relative (P2, 12 x 3 cells on one wavelength), serial and 2 ranks alike
    assert abs(lam - CHECK_VALUE) / abs(CHECK_VALUE) < 3.3e-4
    assert meta["harmonic_content_m0"] > 0.999

    # XDMF: three phases of a real field, not zero, readable with pyvista (VTK's XDMF reader)
    reader = pv.get_reader(str(out / "mode.xdmf"))
    assert len(reader.time_values) == 3
    reader.set_active_time_value(reader.time_values[1])
    blocks = reader.read()  # the mesh grid, then the temporal grid of u
    grid = next(b for b in blocks if "real_u" in b.point_data)
    u = np.asarray(grid.point_data["real_u"])
    assert grid.n_points > 0 and np.max(np.abs(u)) > 0.1
    # PVD (full degree): the complex mode, max |u| normalised to 1 at a node
    mesh = pv.get_reader(str(out / "mode_p2.pvd")).read()
    mesh = mesh.combine() if isinstance(mesh, pv.MultiBlock) else mesh
    ure = np.asarray(mesh.point_data["u_real"])
    uim = np.asarray(mesh.point_data["u_imag"])
    assert np.isclose(np.max(np.hypot(np.linalg.norm(ure, axis=1), np.linalg.norm(uim, axis=1))),
                      1.0, rtol=1e-12)

    rows = np.loadtxt(out / "interface.csv", delimiter=",", skiprows=1)
    assert rows.shape[1] == 7 and rows.shape[0] >= 12
    assert np.all(np.diff(rows[:, 0]) > 0)

    for name in ("mode_shape.png", "mode_phases.png", "interface_tractions.png"):
        with Image.open(out / name) as im:
            assert "Lambda" in im.info.get("Title", "")
            pixels = np.asarray(im.convert("RGB"), dtype=float)
        assert pixels.shape[0] > 100 and pixels.std() > 10  # a picture, not a blank canvas


@pytest.mark.serial
@pytest.mark.parametrize("bad", [["--beta", "0.9"], ["--k", "-1"], ["--branch", "x"],
                                 ["--ny", "0"], ["--grading", "0.5"]])
def test_mode_shape_bad_input(tmp_path, bad):
    out = tmp_path / "never"
    res = _run([sys.executable, SCRIPT, "--out", str(out), *bad])
    assert res.returncode == 2
    assert len(res.stderr.strip().splitlines()) == 1 and "error" in res.stderr
    assert not out.exists()


@pytest.mark.serial
def test_mode_shape_from_cross_section(tmp_path):
    """--source cross-section: no strip solve; the picture says where it came from."""
    from PIL import Image

    out = tmp_path / "xs"
    res = _run([sys.executable, SCRIPT, "--out", str(out), "--source", "cross-section",
                "--color", "stress", *TINY])
    assert res.returncode == 0, res.stderr[-3000:]
    meta = json.loads((out / "mode.json").read_text())
    assert meta["source"].startswith("cross-section model")
    lam = complex(*meta["eigenvalue"])
    assert meta["residual"] < 1e-12  # measured ~2e-16
    # the 1D model at its default mesh for k = 1 (P3): measured 7.6e-11 from the exact root
    assert abs(lam - CHECK_VALUE) / abs(CHECK_VALUE) < 1e-10
    with Image.open(out / "mode_shape.png") as im:
        assert im.info["Title"].startswith("cross-section model")
