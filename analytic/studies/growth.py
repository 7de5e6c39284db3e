"""The largest growth rate over every mode: maxima over ``k`` and curves (exact roots, counted).

The fastest root in a region at one ``k`` comes from the argument principle
(:func:`analytic.numerics.spectrum.fastest_root`); here it is maximised over ``k``. Pass
``Region(c_max=None)`` for the region that provably holds the fastest mode at each ``k``
(:func:`analytic.numerics.spectrum.provable_region`; docs/design.md 8.1):

- :func:`refine_envelope` and :func:`envelope_maximum`: the envelope ``max Re Lambda(k)``
  sampled on a grid, its largest local maxima refined along their root's family
  (``workflows/envelope.py``);
- :func:`best_over_k`: the fastest root over ``k`` for one parameter set, refined by sampling
  between the best grid values (``workflows/contrast.py``);
- :func:`curve_shape`: maximum and monotonicity of a growth rate sampled against a parameter.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from analytic.numerics.roots import ContourError
from analytic.numerics.spectrum import Region, family_peak, fastest_root
from analytic.params import Params

#: What ``workflows/envelope.py`` reports about its refinement.
REFINEMENT = ("each of the 6 largest local maxima of the samples: golden-section on its root's "
              "family, checked to be the fastest in R")


def refine_envelope(p: Params, region: Region, ks: list[float], zs: list, top: int = 6) -> dict:
    """Refine the ``top`` largest local maxima of the sampled envelope.

    The envelope is a maximum over families (a new mode takes over as k grows): it has kinks
    and many nearly equal local maxima. At each local maximum of the samples the fastest root's
    own family is maximised over the neighbouring interval (:func:`family_peak`), and the
    result is checked to be the fastest root in the region there (argument principle).

    Args:
        p: Parameters (finite ``H``).
        region: The region ``R``.
        ks: Sorted grid.
        zs: The fastest root in ``R`` at each ``k`` of the grid (``None``: none or no count).
        top: Local maxima refined.

    Returns:
        ``{"best": {"k", "Lambda", "fastest"}, "peaks": [{"k", "re_lambda", "im_lambda",
        "fastest_in_region"}, ...]}``: the largest value, of the grid or of a refined peak
        that is the fastest in ``R``, and every refined peak.
    """
    re = np.array([z.real if z is not None else -np.inf for z in zs])
    interior = [j for j in range(len(ks)) if np.isfinite(re[j])
                and re[j] >= re[max(j - 1, 0)] and re[j] >= re[min(j + 1, len(ks) - 1)]]
    best = {"k": ks[int(np.argmax(re))], "Lambda": zs[int(np.argmax(re))], "fastest": True}
    peaks = []
    for j in sorted(interior, key=lambda i: -re[i])[:top]:
        lo, hi = ks[max(j - 1, 0)], ks[min(j + 1, len(ks) - 1)]
        k, z = family_peak(p, ks[j], zs[j], lo, hi)
        try:
            zf = fastest_root(p, k, region)[0]
        except ContourError:
            zf = None
        fastest = zf is not None and abs(zf - z) <= 1e-8 * abs(z)
        peaks.append({"k": k, "re_lambda": z.real, "im_lambda": z.imag,
                      "fastest_in_region": fastest})
        if fastest and z.real > best["Lambda"].real:
            best = {"k": k, "Lambda": z, "fastest": True}
    return {"best": best, "peaks": peaks}


def envelope_maximum(p: Params, region: Region, ks: list[float], zs: list) -> dict:
    """The global maximum of the envelope on the grid, refined (:func:`refine_envelope`).

    Returns:
        ``k``, ``kH``, ``re_lambda``, ``im_lambda``, ``phase_velocity_over_c_d`` of the
        maximum; ``grid_k_of_largest_value`` and ``at_grid_edge`` of the largest sample;
        ``refinement`` (what was done) and ``local_peaks``. None if no ``k`` of the grid has a
        root in the region (or a count).
    """
    re = np.array([z.real if z is not None else np.nan for z in zs])
    if np.isnan(re).all():
        return None
    j = int(np.nanargmax(re))
    ref = refine_envelope(p, region, ks, zs)
    kb, zb = ref["best"]["k"], ref["best"]["Lambda"]
    return {"k": kb, "kH": kb * p.H, "re_lambda": zb.real, "im_lambda": zb.imag,
            "phase_velocity_over_c_d": abs(zb.imag) / kb * p.beta,
            "grid_k_of_largest_value": ks[j], "at_grid_edge": j in (0, len(ks) - 1),
            "refinement": REFINEMENT, "local_peaks": ref["peaks"]}


def best_over_k(p: Params, ks: np.ndarray, region: Region) -> dict:
    """Fastest root over every mode in R and over k (grid, then local samples).

    The two largest grid values are refined by 8 samples between their neighbours.

    Returns:
        ``k``, ``re_lambda`` and ``im_lambda`` of the fastest root found (``None``: no root in
        the region at any sample) and ``failed_counts``, the grid ``k`` whose count failed.
    """

    def growth(k: float) -> tuple[float, complex | None, int]:
        try:
            z, n, _ = fastest_root(p, float(k), region)
        except ContourError:
            return -np.inf, None, -1
        return (z.real if z is not None else -np.inf), z, n

    vals = [growth(k) for k in ks]
    re = np.array([v[0] for v in vals])
    failed = int(sum(v[2] < 0 for v in vals))
    best = (float(ks[int(np.argmax(re))]), *vals[int(np.argmax(re))])
    for j in np.argsort(re)[::-1][:2]:
        if not np.isfinite(re[j]):
            continue
        lo, hi = ks[max(j - 1, 0)], ks[min(j + 1, len(ks) - 1)]
        for k in np.linspace(lo, hi, 8):
            g = growth(k)
            if g[0] > best[1]:
                best = (float(k), *g)
    k, g, z, _ = best
    return {"k": k, "re_lambda": g if np.isfinite(g) else None,
            "im_lambda": z.imag if z is not None else None, "failed_counts": failed}


def curve_shape(x: Sequence[float], growth: Sequence[float], name: str = "x") -> dict:
    """Maximum and monotonicity of ``growth`` sampled at the sorted ``x``.

    Args:
        x: Sorted parameter values.
        growth: The growth rate at each.
        name: What ``x`` is called in the keys.

    Returns:
        ``max_growth``, ``<name>_at_max`` (the first ``x`` where it is reached),
        ``monotonic`` (never up and down; flat steps ignored) and ``direction_changes``.
    """
    g = np.asarray(growth, dtype=float)
    d = np.sign(np.diff(g))
    d = d[d != 0]
    return {"max_growth": float(g.max()), f"{name}_at_max": float(x[int(np.argmax(g))]),
            "monotonic": bool(np.all(d >= 0) or np.all(d <= 0)),
            "direction_changes": int(np.sum(d[1:] != d[:-1]))}
