"""The 1D models' vertices (``meshes.interval.interval_vertices``) and gmsh kept off their path."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from meshes.interval import interval_vertices

pytestmark = pytest.mark.serial


@pytest.mark.parametrize("ratio", [1.0, 1.0 + 1e-9, 1.5, 4.0, 20.0])
@pytest.mark.parametrize("cells", [1, 2, 7, 40, 500])
@pytest.mark.parametrize("H", [0.1, 1.0, 37.5])
def test_vertices_are_the_geometric_progression_with_exact_ends(H: float, cells: int,
                                                                ratio: float) -> None:
    y = interval_vertices(H, cells, ratio)
    assert y.shape == (cells + 1,)
    assert y[0] == 0.0 and y[-1] == H  # exact: the models' Dirichlet rows find y = H by value
    h = np.diff(y)
    assert np.all(h > 0)
    if cells > 1:
        # h_i = h_0 r^i with h_max / h_min = ratio. Measured over these cases: h_max / h_min
        # within 5.8e-14 of ratio, successive ratios within 2.3e-13 of r (500 cells); the plain
        # (r^i - 1) / (r^n - 1) gives 2.6e-11 at ratio = 1 + 1e-9, 40 cells
        r = ratio ** (1.0 / (cells - 1))
        assert h[-1] / h[0] == pytest.approx(ratio, rel=1e-13)
        assert np.allclose(h[1:] / h[:-1], r, rtol=1e-12, atol=0)
    else:
        assert h[0] == H


@pytest.mark.parametrize("bad", [(0.0, 4, 1.0), (float("inf"), 4, 1.0), (1.0, 0, 1.0),
                                 (1.0, 4, 0.5), (1.0, 4, float("nan"))])
def test_bad_intervals_are_refused(bad: tuple[float, int, float]) -> None:
    with pytest.raises(ValueError, match="bad interval"):
        interval_vertices(*bad)


def test_the_1d_models_do_not_import_gmsh() -> None:
    # gmsh's import cost 0.3-0.5 s per process (sweep_k.py --help: 1.5-2.0 s -> 1.1-1.5 s)
    code = ("import sys; import forms.models.section, forms.solvers.certified, meshes.strip; "
            "print('gmsh' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "False"


def test_the_strip_mesh_imports_gmsh_and_keeps_the_sigint_handler() -> None:
    code = ("import signal, sys\n"
            "from mpi4py import MPI\n"
            "from meshes.strip import strip_mesh\n"
            "def mine(*a): pass\n"
            "signal.signal(signal.SIGINT, mine)\n"
            "m = strip_mesh(MPI.COMM_SELF, 1.0, 0.5, 3, 2, 2.0)\n"
            "print('gmsh' in sys.modules, signal.getsignal(signal.SIGINT) is mine,\n"
            "      m.mesh.geometry.x.shape[0])\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.split() == ["True", "True", "12"]
