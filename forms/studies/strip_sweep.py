"""Every eigenvalue of the 2D Bloch strip cell in a box, each with its dominant harmonic.

The cell of :mod:`forms.studies.strip_mode` (``wavelengths`` wavelengths ``2 pi / k`` long,
built by :func:`forms.studies.strip_mode.bloch_strip`) is solved by the region solver
(:class:`forms.solvers.region.RegionSolver`, options prefix ``strip_region_``, the count's LU
``strip_region_det_``) with no exact root as input: the argument-principle count on
``log det T_h`` (MUMPS) and shift-and-invert over tiles. A cell of ``w`` wavelengths also holds
the modes of wavenumbers ``k (1 + m / w)``; each eigenvalue carries the dominant one
(:attr:`forms.models.strip.StripMode.harmonic` ``m``) as ``harmonic = 1 + m / w``
(wavenumber ``harmonic * k``): harmonic 1 is the cross-section set at ``k``, the others the
cross-section set at ``harmonic * k``. Collective on the mesh communicator.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from mpi4py import MPI

from analytic.params import Params
from forms.mode_postprocessing import harmonic_content
from forms.models.strip import build_strip_problem, friction_operator_for
from forms.solvers.region import RegionSolver
from forms.studies.strip_mode import bloch_strip

PREFIX = "strip_region_"
"""Options prefix of the strip's region solve (the count's LU: ``strip_region_det_``)."""


@dataclass
class StripSpectrum:
    """Eigenvalues of the Bloch cell at ``k`` in a box.

    Attributes:
        k: Wavenumber.
        box: The box used.
        values: Eigenvalues (decreasing real part).
        residuals: Relative residuals.
        harmonics: Wavenumber of each mode in units of ``k`` (1: the mode ``exp(-i k x)``).
        counted: Argument-principle count.
        closed: ``found == counted``.
        unknowns: Size of ``T_h``.
        seconds: Timings (``solve``, ``count``, ``harmonics``).
    """

    k: float
    box: tuple
    values: np.ndarray
    residuals: np.ndarray
    harmonics: np.ndarray
    counted: int | None
    closed: bool
    unknowns: int
    seconds: dict = field(default_factory=dict)

    def rows(self) -> list[dict]:
        """One dict per eigenvalue (``k``, ``re``, ``im``, ``harmonic``, ``residual``)."""
        return [{"k": self.k, "re": z.real, "im": z.imag, "harmonic": float(h),
                 "residual": float(r)}
                for z, h, r in zip(self.values, self.harmonics, self.residuals, strict=True)]


def strip_spectrum(comm: MPI.Comm, params: Params, k: float, box: Sequence[float], *,
                   wavelengths: int = 1, cells_per_wavelength: int = 12, ny: int = 6,
                   degree: int = 2, nev: int = 12) -> StripSpectrum:
    """Every eigenvalue of the Bloch cell at ``k`` in ``box`` with its harmonic (collective).

    Args:
        comm: Mesh communicator (the whole communicator: MUMPS factorises in parallel).
        params: Parameters (``H`` finite).
        k: Wavenumber (> 0).
        box: ``(re_min, re_max, im_min, im_max)`` (``re_min > -1``).
        wavelengths: Cell length in wavelengths ``2 pi / k``.
        cells_per_wavelength: Cells along ``x`` per wavelength.
        ny: Cells along ``y``.
        degree: Lagrange degree.
        nev: Eigenpairs per shift-and-invert tile.

    Returns:
        :class:`StripSpectrum`; every PETSc object destroyed.
    """
    strip = bloch_strip(comm, params, k, wavelengths, cells_per_wavelength, ny)
    problem = build_strip_problem(strip, params, k=k, degree=degree)
    op = friction_operator_for(problem)
    solver = RegionSolver(comm, nev=nev, prefix=PREFIX)
    res = None
    try:
        res = solver.solve(op.matrices, box, op.law.spurious, count=True)
        t0 = MPI.Wtime()
        harmonics = []
        for v in res.vectors:
            content = harmonic_content(problem, problem.to_function(v))
            m = max(content, key=content.get)
            harmonics.append(1.0 + m / wavelengths)
        t_h = MPI.Wtime() - t0
        return StripSpectrum(float(k), tuple(res.box), res.values.copy(), res.residuals.copy(),
                             np.array(harmonics, dtype=float), res.counted, res.closed,
                             int(op.matrices[0].getSize()[0]),
                             {**res.seconds, "harmonics": t_h})
    finally:
        if res is not None:
            res.destroy()
        solver.destroy()
        op.destroy()
        problem.destroy()
