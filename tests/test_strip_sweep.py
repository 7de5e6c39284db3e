"""Every eigenvalue of the 2D Bloch strip cell in a box (forms.studies.strip_sweep).

No exact root is used: the region solve counts (argument principle on MUMPS's log det) and finds
(shift-and-invert over tiles) the eigenvalues of the cell; each carries its harmonic. The
harmonic-1 ones must be eigenvalues of the 1D cross-section model at ``k`` (solved next to
them, degree 3), the harmonic-0 one the uniform (``k = 0``) mode. Runs serially and under
``mpirun -n 2`` (the cell on the whole communicator).
"""

import pytest

from mpi4py import MPI

from analytic.params import Params
from forms.solvers.continuation import cross_section_mode
from forms.studies.strip_sweep import strip_spectrum

# Relative distance of the cell's harmonic-1 eigenvalues (P2, 12 cells per wavelength, ny = 6)
# to the 1D model's: measured 1.9e-4 at k = 4 and 1.5e-4 at k = 6 (the 2D discretisation
# error: on a mesh refined twice in x and y, the harmonic-2 mode at k = 2 moved from 2.2e-3 to
# 1.5e-4 of the 1D value). The bound is that measured error rounded up.
RTOL_1D = 3e-4


@pytest.mark.slow
@pytest.mark.parametrize("k, im_max", [(4.0, 7.0), (6.0, 8.0)])
def test_harmonic_one_is_the_cross_section_set(k: float, im_max: float) -> None:
    params = Params()
    s = strip_spectrum(MPI.COMM_WORLD, params, k, (-0.01, 0.5, 0.0, im_max),
                       cells_per_wavelength=12, ny=6)
    assert s.closed and s.counted == len(s.values) > 0
    ones = [z for z, h in zip(s.values, s.harmonics, strict=True) if h == 1.0]
    assert ones, "no harmonic-1 eigenvalue in the box"
    for z in ones:
        xs = cross_section_mode(params, k, complex(z))
        assert xs is not None
        assert abs(xs.eigenvalue - z) / abs(z) < RTOL_1D
