"""workflows/mode_shape.py: files readable back, pictures drawn without a display, serial and MPI.

The workflow runs in a subprocess (it must import pyvista before dolfinx, see its header), once
serially and once under ``mpirun -n 2``; these tests are marked serial so each launches once.
Its computation (:mod:`forms.studies.strip_mode`) is also tested directly, serially and under MPI.
"""

import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

# As in the workflow: VTK's library before dolfinx's (the reader tests below use pyvista).
import pyvista  # noqa: F401, I001

from mpi4py import MPI

from analytic.params import Params
from forms.solvers.continuation import follow_fe_branch
from forms.studies import strip_mode

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
                                 ["--ny", "0"], ["--grading", "0.5"], ["--mu2", "2"],
                                 ["--mu2", "2", "--H2", "0.5", "--source", "cross-section"]])
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


# ------------------------------------------------------------ forms.studies.strip_mode, called
# directly
@pytest.fixture(scope="module")
def bloch_k1():
    """The tiny strip of the workflow test (k = 1, 12 x 3 cells, P2) and its solved mode."""
    params = Params()
    k, lam_branch = strip_mode.branch_eigenvalue(MPI.COMM_WORLD, params, (0, -1), 1.0)
    xs = strip_mode.cross_section_near(params, k, lam_branch)
    strip = strip_mode.bloch_strip(MPI.COMM_WORLD, params, k, 1, 12, 3)
    solved = strip_mode.solve_bloch_mode(strip, params, k, 2, xs.eigenvalue, 6)
    return params, k, lam_branch, xs, strip, solved


def test_branch_and_bloch_mode(bloch_k1):
    params, k, lam_branch, xs, strip, solved = bloch_k1
    # the branch followed up to k = 1 (P3 default mesh): measured 7.6e-11 from the exact root
    assert abs(lam_branch - CHECK_VALUE) / abs(CHECK_VALUE) < 1e-10
    assert xs.eigenvalue == pytest.approx(lam_branch, rel=1e-12)  # same solve, shifted off
    assert strip.length == pytest.approx(2 * math.pi) and (strip.nx, strip.ny) == (12, 3)
    mode = solved.mode
    assert mode is not None and 0 in solved.harmonics
    # the kept eigenvalue is the first converged one (nearest the target) with m = 0
    assert mode.eigenvalue == solved.eigenvalues[solved.harmonics.index(0)]
    assert abs(mode.eigenvalue - CHECK_VALUE) / abs(CHECK_VALUE) < 3.3e-4  # measured 3.20e-4
    assert mode.meta["harmonic_content_m0"] > 0.999
    assert len(mode.meta["other_eigenvalues"]) == len(solved.eigenvalues)
    # normalised: largest nodal |u| is 1 (up to rounding)
    vals = mode.u.x.array.reshape(-1, 2)
    amp = MPI.COMM_WORLD.allreduce(float(np.max(np.linalg.norm(vals, axis=1))), op=MPI.MAX)
    assert amp == pytest.approx(1.0, rel=1e-12)


def test_most_unstable_branch_point():
    """With a k grid, the point of largest growth of the followed branch, on every rank."""
    params = Params()
    ks = np.array([0.5, 1.0, 1.5, 2.0, 2.5])
    k, lam = strip_mode.branch_eigenvalue(MPI.COMM_WORLD, params, (0, -1), 1.0, k_scan=ks)
    ref = follow_fe_branch(params, lambda q: lam, ks)  # every value near the branch
    assert k in ks and lam.real == pytest.approx(np.max(ref.real), rel=1e-9)
    assert MPI.COMM_WORLD.allgather((k, lam)) == [(k, lam)] * MPI.COMM_WORLD.size


def test_gathered_grid_and_snapshots(bloch_k1):
    params, k, _, xs, strip, solved = bloch_k1
    u, lam = solved.mode.u, solved.mode.eigenvalue
    comm = strip.comm
    gathered = strip_mode.gather_mode(u, params.lame_lambda)
    n_local = len(u.x.array) // 2
    n_total = comm.allreduce(n_local)
    if comm.rank == 0:
        data = gathered["point_data"]
        assert gathered["points"].shape == (n_total, 3)
        assert all(data[name].shape[0] == n_total for name in data)
        # VTK connectivity: every cell [count, ids...] points into the gathered points
        cells = gathered["cells"].reshape(len(gathered["cell_types"]), -1)
        assert np.all(cells[:, 0] == cells.shape[1] - 1)
        assert cells[:, 1:].min() >= 0 and cells[:, 1:].max() < n_total
        umax = np.max(np.linalg.norm(data["u_re"] + 1j * data["u_im"], axis=1))
        assert umax == pytest.approx(1.0, rel=1e-12)  # the normalised mode, all ranks' nodes
    else:
        assert gathered is None
    steps = list(strip_mode.phase_snapshots(u, lam, 4))
    period = 2 * math.pi / abs(lam.imag)
    assert [t for t, _ in steps] == pytest.approx([0, period / 4, period / 2, 3 * period / 4])
    t, last = steps[-1]
    assert np.allclose(last.x.array, (u.x.array * np.exp(1j * lam.imag * t)).real, atol=1e-14)

    # the cross-section mode on the same mesh: normalised too, its own eigenvalue
    other = strip_mode.cross_section_on_strip(strip, xs, 2)
    assert other.eigenvalue == xs.eigenvalue and other.meta["timings"] == {}
    vals = other.u.x.array.reshape(-1, 2)
    amp = comm.allreduce(float(np.max(np.linalg.norm(vals, axis=1))), op=MPI.MAX)
    assert amp == pytest.approx(1.0, rel=1e-12)


@pytest.mark.serial
@pytest.mark.parametrize("omega", [6.5, -6.5])
@pytest.mark.parametrize("n", [1, 7])
def test_phase_frames(omega, n):
    rng = np.random.default_rng(n)
    data = {"u_re": rng.normal(size=(n, 3)), "u_im": rng.normal(size=(n, 3)),
            "syy_re": rng.normal(size=n), "syy_im": rng.normal(size=n)}
    frames = strip_mode.phase_frames(data, omega, (0.0, 0.25, 1.0))
    (u0, s0), (u1, s1), (u4, s4) = frames
    assert np.array_equal(u0, data["u_re"]) and np.array_equal(s0, data["syy_re"])
    # a quarter period on: Re(z exp(+-i pi/2)) = -+Im z (cos(pi/2) rounding: 1e-16)
    sgn = math.copysign(1.0, omega)
    assert np.allclose(u1, -sgn * data["u_im"], atol=1e-15)
    assert np.allclose(s1, -sgn * data["syy_im"], atol=1e-15)
    assert np.allclose(u4, u0, atol=1e-14) and np.allclose(s4, s0, atol=1e-14)  # one period


@pytest.mark.serial
@pytest.mark.parametrize("n_slip", [2, 9])
def test_interface_table(n_slip):
    x = np.linspace(0.0, 3.0, 13)
    x_slip = np.linspace(0.0, 3.0, n_slip)
    data = {"x": x, "sxy": np.exp(-1j * x), "syy": 2j * x, "x_slip": x_slip,
            "ux": (1 + 2j) * x_slip - 1j}  # linear: interpolation exact
    table = strip_mode.interface_table(data)
    assert table.shape == (13, len(strip_mode.INTERFACE_COLUMNS))
    ux = (1 + 2j) * x - 1j
    expect = np.column_stack([x, np.cos(x), -np.sin(x), 0 * x, 2 * x, ux.real, ux.imag])
    assert np.allclose(table, expect, rtol=0, atol=1e-14)
