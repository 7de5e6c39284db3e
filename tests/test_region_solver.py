"""forms.solvers.region: every eigenpair in a box and the argument-principle count of det T_h."""

import sys

import numpy as np
import pytest

import slepc4py

slepc4py.init(sys.argv[:1])

from mpi4py import MPI  # noqa: E402

from analytic.params import Params  # noqa: E402
from forms.models.strip import build_strip_problem, friction_operator_for  # noqa: E402
from forms.solvers.region import LogDet, RegionSolver, count_in_box, winding  # noqa: E402
from forms.solvers.slepc import dense_companion_eigenvalues  # noqa: E402
from meshes.strip import strip_mesh  # noqa: E402


@pytest.mark.serial
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_winding_many_zeros_near_the_edge(seed):
    """600 zeros; the phase turns ~150 times along one side, some zeros 1e-4 from the edge."""
    rng = np.random.default_rng(seed)
    zs = rng.uniform(-0.5, 0.5, 600) + 1j * rng.uniform(-30, 30, 600)
    box = (0.05, 0.6, -16.0, 16.0)
    inside = int(np.sum((zs.real > box[0]) & (zs.real < box[1]) & (zs.imag > box[2])
                        & (zs.imag < box[3])))

    def logf(z):
        return np.sum(np.log(z[:, None] - zs[None, :]), axis=1)

    assert winding(logf, box, n_initial=16) == inside


def _block_operator(comm, bc="velocity", length=2.0, nx=8, ny=3, degree=2):
    params = Params(bc=bc)
    strip = strip_mesh(comm, length, params.H, nx, ny)
    problem = build_strip_problem(strip, params, k=None, degree=degree)
    return problem, friction_operator_for(problem)


def _inside(w, box):
    return w[(w.real > box[0]) & (w.real < box[1]) & (w.imag > box[2]) & (w.imag < box[3])]


@pytest.mark.slow  # measured 30 .. 50 s per case (dense companion eig, count, tiles)
@pytest.mark.serial
@pytest.mark.parametrize("bc, box", [("velocity", (-0.5, 0.6, -10.0, 10.0)),
                                     ("stress", (0.02, 0.6, -10.0, 10.0))])
def test_log_det_and_region_against_dense(bc, box):
    """Count and eigenvalues equal the dense companion's (block L = 2, 8 x 3 cells, P2).

    The stress top's free block has ``Lambda = 0`` (rigid sliding), which the tiles resolve
    poorly (residual 1.4e-4 measured): its box starts right of it.
    """
    problem, op = _block_operator(MPI.COMM_SELF, bc)
    w = dense_companion_eigenvalues(op)
    exact = np.sort_complex(_inside(w, box))
    assert exact.size >= 4  # measured 16 (velocity), 6 (stress): a test that can fail
    # the determinant itself, at a few points (dense slogdet): measured agreement ~1e-12
    dense = [np.array(a.copy().convert("dense").getDenseArray()) for a in op.matrices]
    logdet = LogDet(op.matrices)
    z = np.array([0.2 - 3.0j, 0.1 + 7.0j])
    got = logdet(z)
    logdet.destroy()
    for zi, gi in zip(z, got, strict=True):
        sign, mag = np.linalg.slogdet(sum(zi**j * a for j, a in enumerate(dense)))
        assert abs(gi.real - mag) < 1e-9 * abs(mag)
        assert abs(np.angle(np.exp(1j * gi.imag) / sign)) < 1e-9
    solver = RegionSolver(MPI.COMM_SELF, nev=8)
    res = solver.solve(op.matrices, box, op.law.spurious)
    solver.destroy()
    try:
        assert res.counted == exact.size and res.closed
        gap = [np.min(np.abs(res.values - z)) / abs(z) for z in exact]
        # SLEPc tolerance 1e-12 against LAPACK: measured 5e-14 .. 2e-12 relative
        assert max(gap) < 1e-8
        assert res.conjugate_gap() < 1e-8 and res.residuals.max() < 1e-10
    finally:
        res.destroy()
        op.destroy()
        problem.destroy()


def test_region_closes_under_mpi():
    """Distributed matrices (mpirun -n 2): the count closes, the spectrum is symmetric."""
    problem, op = _block_operator(MPI.COMM_WORLD, "velocity", length=4.0, nx=16, ny=3)
    solver = RegionSolver(MPI.COMM_WORLD, nev=8)
    res = solver.solve(op.matrices, (0.0, 0.6, -9.0, 9.0), op.law.spurious)
    solver.destroy()
    try:
        assert res.counted >= 2 and res.closed  # measured: 10 eigenvalues in the box
        assert res.conjugate_gap() < 1e-8  # measured ~1e-13
        assert MPI.COMM_WORLD.allgather(res.found) == [res.found] * MPI.COMM_WORLD.size
    finally:
        res.destroy()
        op.destroy()
        problem.destroy()


@pytest.mark.serial
def test_box_with_the_spurious_root_is_refused():
    problem, op = _block_operator(MPI.COMM_SELF)
    try:
        with pytest.raises(ValueError, match="spurious root"):
            count_in_box(op.matrices, (-1.5, 0.5, -2.0, 2.0), op.law.spurious)
        with pytest.raises(ValueError, match="re_max > re_min"):
            count_in_box(op.matrices, (0.5, 0.1, -2.0, 2.0), op.law.spurious)
    finally:
        op.destroy()
        problem.destroy()
