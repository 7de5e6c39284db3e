"""Stability map over two parameters: the largest growth rate over every mode and every ``k``.

For each point of a grid of two parameters (``H``, ``Delta``, ``gamma``, ``f``, ``beta``,
``alpha_pc``, ``alpha_ld``, ``mu2``, ...) :func:`map_point` takes the fastest exact root in a
region (:func:`analytic.numerics.spectrum.fastest_root`, argument principle on ``det_M``) at
every ``k`` of a grid in ``k H`` up to ``kH_max`` and refines the largest local maxima of the
samples along their root's family (:func:`analytic.studies.growth.refine_envelope`).

What is proven and what is not: at every grid ``k`` the count of roots in the region is the
argument principle's, so a point is *stable on the grid* when that count is zero at every grid
``k``. Between grid points nothing is proven: a root family can only enter the region
``Re Lambda >= re_min`` through ``Re Lambda = re_min`` (or the region's far edge), and the grid
is fine compared with the ``k`` scale on which the slowest family changes (the log grid has a
ratio ``(kH_max / kH_min)^(1/(n-1))`` between neighbours, stated in the output). The region's
phase-velocity bound is a parameter (``Region.c_max``), so an adaptive region plugs in.

The closed-form ``k H -> infinity`` boundary (:func:`closed_form_delta`) is that of
``workflows/phase_diagram.py`` (the half-space's three families, Eq. stability_boundaries): the
largest ``Delta`` on the boundaries of the dilatational, shear and quasi-static families.
"""

from __future__ import annotations

import math

import numpy as np

from analytic.numerics.roots import ContourError
from analytic.numerics.spectrum import Region, fastest_mode
from analytic.params import ParameterError, Params
from analytic.physics import phase_diagram as pd
from analytic.studies.growth import counts_seconds, refine_envelope

#: The parameters a map axis may vary (fields of :class:`analytic.params.Params`).
AXES: tuple[str, ...] = ("H", "Delta", "gamma", "f", "beta", "alpha_pc", "alpha_ld", "mu2",
                         "rho2", "beta2", "H2")
#: Axes on which a log scale is used for the picture when every value is positive.
LOG_AXES: tuple[str, ...] = ("H", "gamma", "mu2", "H2")


def parse_axis(spec: str, option: str) -> tuple[str, np.ndarray]:
    """``name:start:stop:count`` (linear) or ``name:start:stop:countlog`` (geometric).

    Args:
        spec: The option's value, e.g. ``"Delta:-1:1:41"``.
        option: The option's name for messages (``"--x"``).

    Returns:
        ``(name, values)``.

    Raises:
        ParameterError: One line naming ``option`` and what is allowed.
    """
    parts = spec.split(":")
    if len(parts) != 4 or parts[0] not in AXES:
        raise ParameterError(f"{option} = {spec!r}: need name:start:stop:count with name one of "
                             f"{', '.join(AXES)}")
    name, a, b, n = parts
    log = n.endswith("log")
    try:
        a, b, n = float(a), float(b), int(n[:-3] if log else n)
    except ValueError:
        raise ParameterError(f"{option} = {spec!r}: start, stop must be numbers and count an "
                             "integer (optionally followed by 'log')") from None
    if not (math.isfinite(a) and math.isfinite(b) and a < b and 2 <= n <= 1000):
        raise ParameterError(f"{option} = {spec!r}: need finite start < stop and "
                             "2 <= count <= 1000")
    if log and a <= 0:
        raise ParameterError(f"{option} = {spec!r}: a log axis needs 0 < start")
    return name, (np.geomspace(a, b, n) if log else np.linspace(a, b, n))


def point_params(base: Params, x: tuple[str, float], y: tuple[str, float]) -> Params:
    """``base`` with the two axis values set (validated: raises :class:`ParameterError`)."""
    return base.replace(**{x[0]: float(x[1]), y[0]: float(y[1])})


def kh_grid(kh_min: float, kh_max: float, count: int) -> np.ndarray:
    """The ``k H`` samples of every point: geometric from ``kh_min`` to ``kh_max``."""
    return np.geomspace(kh_min, kh_max, count)


#: Local maxima of a point's samples over ``k H`` refined along their family (:func:`map_point`;
#: ``stability_map.py --fe-check grid`` refines as many along the FE's modes).
MAP_PEAKS_REFINED = 2


def map_point(p: Params, khs: np.ndarray, region: Region, top: int = MAP_PEAKS_REFINED
              ) -> dict:
    """The largest growth rate over every root in ``region`` and every ``k = khs / H``.

    Args:
        p: Parameters (finite ``H``).
        khs: The ``k H`` samples (sorted).
        region: The region (``re_min > 0`` for a stability statement: small, e.g. ``1e-6``,
            keeps the contour off ``Lambda = 0``, where ``det_M`` vanishes or blows up).
        top: Local maxima of the samples refined along their family.

    Returns:
        ``re_lambda`` (``None``: no root in the region at any grid ``k``), ``im_lambda``, ``k``,
        ``kH``, ``phase_velocity_over_c_d`` of the fastest root; ``stable_on_grid`` (a certified
        zero count at every grid ``k``, no failed count), ``unstable_k_count`` (grid ``k`` with
        a root in the region), ``failed_counts`` (grid ``k`` whose count failed),
        ``refined`` (a refined peak beat the grid maximum), ``proven_k_count`` (grid ``k`` at
        which the tail bound proves that no root beyond the region grows faster than the
        fastest inside, :func:`analytic.numerics.spectrum.fastest_mode`; never at a ``k``
        without a root inside, where the bound is positive) and ``c_max_largest`` (the
        largest phase-velocity bound used, ``c_max = None``: the adaptive region).
    """
    ks = [float(v) / p.H for v in khs]
    zs: list[complex | None] = []
    counts: list[int] = []
    proven, c_used = 0, []
    located: tuple[complex, ...] = ()
    k_located = 1.0
    for k in ks:
        hint = next((w.real for w in reversed(zs) if w is not None), None)  # the previous k's
        # the last located roots as they were (thickness modes at small k keep their Im) and
        # with Im scaled to this k (waveguide modes keep their phase velocity): Newton's starts
        # in the fastest band, instead of a scan when they reach its roots
        starts = [*located, *(complex(w.real, w.imag * k / k_located) for w in located)]
        try:
            # only the fastest root and whether there is one are used (count > 0)
            m = fastest_mode(p, k, region, hint, starts, whole=False)
            z, n = m.root, m.count
            proven += bool(m.proven)
            c_used.append(m.c_max)
            located, k_located = m.located, k
        except ContourError:
            z, n = None, -1
        zs.append(z)
        counts.append(n)
    failed = sum(n < 0 for n in counts)
    out = {"re_lambda": None, "im_lambda": None, "k": None, "kH": None,
           "phase_velocity_over_c_d": None, "stable_on_grid": failed == 0 and max(counts) == 0,
           "unstable_k_count": sum(n > 0 for n in counts), "failed_counts": failed,
           "refined": False, "proven_k_count": proven,
           "c_max_largest": max(c_used) if c_used else None}
    if all(z is None for z in zs):
        return out
    ref = refine_envelope(p, region, ks, zs, top=top)
    k, z = ref["best"]["k"], ref["best"]["Lambda"]
    j = int(np.argmax([w.real if w is not None else -np.inf for w in zs]))
    out.update(re_lambda=z.real, im_lambda=z.imag, k=k, kH=k * p.H,
               phase_velocity_over_c_d=abs(z.imag) / k * p.beta, refined=k != ks[j])
    return out


def estimate_seconds(base: Params, x: tuple[str, np.ndarray], y: tuple[str, np.ndarray],
                     khs: np.ndarray, region: Region, ranks: int) -> float:
    """Estimated wall seconds of the map's grid counts on ``ranks`` (refinement not included).

    Every point's counts at ``k = khs / H`` (:func:`analytic.studies.growth.counts_seconds`).
    """
    points = [point_params(base, (x[0], xv), (y[0], yv)) for yv in y[1] for xv in x[1]]
    return counts_seconds([[(p, float(kh) / p.H) for kh in khs] for p in points], region, ranks)


def closed_form_delta(p: Params) -> float:
    """The ``k H -> infinity`` boundary: the largest ``Delta`` below which a family is unstable.

    Eq. (stability_boundaries) of the half-space (``workflows/phase_diagram.py``), at
    ``Gamma = gamma f`` and ``beta`` of ``p``; does not depend on ``H``. NaN where no family
    has a boundary (``f = 0``).
    """
    if p.f == 0:
        return math.nan
    vals = [pd.closed_form(fam, p.Gamma, p.f, p.beta) for fam in pd.FAMILIES]
    vals = [v for v in vals if math.isfinite(v)]
    return max(vals) if vals else math.nan
