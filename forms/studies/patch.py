"""A finite block whose interface has a friction patch: the computation.

The block ``0 < x < L`` on the rigid substrate (:func:`forms.models.strip.build_strip_problem`
with ``k=None``) with friction parameters that differ on a centred patch
``|x - L/2| < Lp/2`` (:class:`forms.models.strip.FrictionProfile`). Sign convention of
:class:`analytic.params.Params`: ``Delta < 0`` is steady-state velocity *weakening*, ``Delta > 0``
velocity strengthening.

- :func:`patch_profile`: the piecewise-constant profile (patch values inside, ``params``
  outside);
- :func:`patch_spectrum`: every eigenvalue of the patched block in a box with its certificate
  (found against the argument-principle count, the P+1 estimate), as a
  :class:`forms.studies.block.BlockSpectrum`;
- :func:`critical_length`: where ``max Re Lambda`` against ``Lp`` crosses 0 (bracketing and
  linear interpolation between the two grid points around the first sign change).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mpi4py import MPI

from analytic.params import Params
from forms.models.strip import FrictionProfile
from forms.studies.block import BlockSpectrum, block_spectrum


@dataclass(frozen=True)
class Patch:
    """Friction values on the patch (``None``: the value of ``params``, i.e. no contrast).

    Attributes:
        length: ``Lp``, centred in the block.
        Delta: ``Delta`` on the patch.
        f: ``f`` on the patch.
        gamma: ``gamma`` on the patch.
    """

    length: float
    Delta: float | None = None  # noqa: N815 - the paper's name
    f: float | None = None
    gamma: float | None = None


def patch_profile(block_length: float, patch: Patch) -> FrictionProfile:
    """The :class:`FrictionProfile` with ``patch`` values on ``|x - L/2| < Lp/2``.

    A node exactly on the patch's edge counts as inside (``<=`` with a ``1e-12`` margin), so
    ``Lp = L`` is the uniform block with the patch's values.
    """
    centre, half = 0.5 * block_length, 0.5 * patch.length

    def make(value: float | None):
        if value is None:
            return None

        def fn(x: np.ndarray, base: Params | None = None) -> np.ndarray:
            return np.where(np.abs(np.asarray(x) - centre) <= half + 1e-12, value, np.nan)

        return fn

    return _Outside(make(patch.Delta), make(patch.f), make(patch.gamma))


class _Outside(FrictionProfile):
    """A profile whose ``nan`` values (outside the patch) take the uniform ``params`` value."""

    def values(self, params: Params, x: np.ndarray) -> np.ndarray:
        """``(n, 3)`` columns ``Delta, f, gamma`` at ``x``; outside the patch, ``params``'."""
        vals = np.array(super().values(params, x), dtype=float)
        base = np.array([params.Delta, params.f, params.gamma], dtype=float)
        return np.where(np.isnan(vals), base, vals)


def patch_spectrum(comm: MPI.Comm, params: Params, length: float, patch: Patch, *,
                   cells_per_unit: int, ny: int, degree: int, lateral: str,
                   box: Sequence[float], nev: int, estimate: bool = True,
                   keep_mode: bool = False) -> BlockSpectrum:
    """Every eigenvalue of the patched block in ``box``, with its certificate.

    As :func:`forms.studies.block.block_spectrum` (options prefix ``patch_region_``, the
    count's LU ``patch_region_det_``), with ``patch`` on the interface. Collective; every
    PETSc object destroyed before returning.

    Args:
        comm: Mesh communicator.
        params: Parameters (the values outside the patch).
        length: ``L``.
        patch: The patch (length and values).
        cells_per_unit: Cells per unit length in ``x``.
        ny: Cells along ``y``.
        degree: Lagrange degree.
        lateral: Lateral ends.
        box: ``(re_min, re_max, im_min, im_max)``, ``re_min > -1``.
        nev: Eigenpairs per tile solve.
        estimate: Also solve at degree ``degree + 1`` (the P+1 estimate).
        keep_mode: Also return the fastest mode as a normalised function.
    """
    return block_spectrum(comm, params, length, cells_per_unit=cells_per_unit, ny=ny,
                          degree=degree, lateral=lateral, box=box, nev=nev, estimate=estimate,
                          keep_mode=keep_mode, friction=patch_profile(length, patch),
                          prefix="patch_region_")


#: Seconds of one patch length (:func:`patch_spectrum`: count and tiles in the default box
#: ``-0.05 < Re < 0.5``, ``|Im| < 3``) per unknown squared (the count's samples grow with the
#: unknowns, and so does each sample's factorisation). Measured on this 2-core machine
#: (2026-11-25, load 3-12, one rank, P2): 350 unknowns (L = 3, 4 x 3 cells per unit) 4.1 and
#: 3.9 s (model 4.7 s); workflows/results/friction_patch (910 unknowns) 9.3-63 s per patch
#: length, 10.2-21.7 s below the critical length (model 25.8 s).
SECONDS_PER_UNKNOWN2 = 3e-5


def estimate_seconds(unknowns: int, lengths: int) -> float:
    """Estimated seconds of ``lengths`` patch lengths on a block of ``unknowns`` unknowns.

    The ranks share each solve (no speed-up assumed).
    """
    return lengths * (1.0 + SECONDS_PER_UNKNOWN2 * unknowns**2)


def critical_length(lp: Sequence[float], growth: Sequence[float]) -> float | None:
    """The first ``Lp`` where ``growth`` changes sign, by linear interpolation (``None``: none).

    Args:
        lp: Patch lengths, increasing.
        growth: ``max Re Lambda`` at each (``nan`` entries are skipped).
    """
    x = np.asarray(lp, dtype=float)
    g = np.asarray(growth, dtype=float)
    ok = np.isfinite(g)
    x, g = x[ok], g[ok]
    for i in range(len(x) - 1):
        if g[i] == 0.0:
            return float(x[i])
        if g[i] * g[i + 1] < 0:
            return float(x[i] - g[i] * (x[i + 1] - x[i]) / (g[i + 1] - g[i]))
    return None


def nucleation_estimates(params: Params, patch_delta: float) -> dict[str, float]:
    """Published nucleation lengths in this project's length unit ``c_s t0`` (aging law).

    With ``a = d_v f`` (direct effect), ``b = a (1 - Delta)``, ``gamma = mu v0 / (c_s sigma0
    a)`` and ``c_s t0 = c_s D / v0`` (docs/design.md section 2), ``mu' D / (sigma0 a)`` is
    ``(mu'/mu) gamma``. ``mu' = mu / (1 - nu)`` (in-plane) for two identical half-spaces;
    against a rigid substrate the slip is the one body's displacement, which doubles the
    stiffness per unit slip: ``mu' = 2 mu / (1 - nu)`` here. Formulas as quoted in the
    README, not checked against the papers (Rubin & Ampuero 2005:
    ``L_b = mu' D_c / (b sigma)``, ``L_inf = (1/pi) (b/(b-a))^2 L_b``;
    Uenishi & Rice 2003: ``1.377 mu' D_c / (sigma (b - a))``); quasi-static, half-space, no
    ``Lambda``-dependent direct effect. ``nan`` unless ``patch_delta < 0``.
    """
    if patch_delta >= 0:
        nan = float("nan")
        return {"L_b": nan, "L_inf": nan, "Uenishi-Rice": nan}
    nu = (1.0 - 2.0 * params.beta**2) / (2.0 * (1.0 - params.beta**2))
    scale = 2.0 / (1.0 - nu) * params.gamma  # mu' D / (sigma0 a)
    b_over_a = 1.0 - patch_delta
    l_b = scale / b_over_a
    return {"L_b": l_b, "L_inf": (b_over_a / -patch_delta) ** 2 * l_b / np.pi,
            "Uenishi-Rice": 1.377 * scale / -patch_delta}
