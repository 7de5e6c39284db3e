"""The largest growth rate over every mode: maxima over ``k`` and curves (exact roots, counted).

The fastest root in a region at one ``k`` comes from the argument principle
(:func:`analytic.numerics.spectrum.fastest_root`); here it is maximised over ``k``. Pass
``Region(c_max=None)`` for the region that provably holds the fastest mode at each ``k``
(:func:`analytic.numerics.spectrum.provable_region`; docs/design.md 8.1):

- :func:`extremum_midpoints`, :func:`refine_envelope` and :func:`envelope_maximum`: the envelope
  ``max Re Lambda(k)`` sampled on a grid, the grid refined around every local extremum of the
  samples (maxima and dips alike) and its largest local maxima refined along their root's family
  (``workflows/envelope.py``);
- :func:`best_over_k`: the fastest root over ``k`` for one parameter set, refined by sampling
  between the best grid values (``workflows/contrast.py``);
- :func:`curve_shape`: maximum and monotonicity of a growth rate sampled against a parameter;
- :func:`count_seconds`, :func:`counts_seconds`: up-front estimates of the time the counts take
  (the scenes print them before the work).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from analytic.numerics.roots import ContourError
from analytic.numerics.spectrum import Region, family_peak, fastest_mode
from analytic.params import Params

#: Local maxima of the sampled envelope refined along their family (:func:`refine_envelope`;
#: ``envelope.py --fe-check all`` refines as many along the FE's modes).
PEAKS_REFINED = 6
#: What ``workflows/envelope.py`` reports about its refinement.
REFINEMENT = ("the grid: geometric midpoints inserted on both sides of every local extremum of "
              "the samples (maxima and minima) and in every interval where the fastest root "
              "changes family, until neighbours there are within the stated ratio; "
              f"then each of the {PEAKS_REFINED} largest local maxima of the samples: "
              "golden-section on its root's family, checked to be the fastest in R")


def local_extrema(re: Sequence[float]) -> list[int]:
    """Indices of the interior local extrema (maxima and minima) of sampled values.

    A sample counts when it is ``>=`` or ``<=`` both neighbours; the ends and samples without a
    value (NaN), or next to one, are left out.
    """
    v = np.asarray(re, dtype=float)
    return [j for j in range(1, len(v) - 1) if np.isfinite(v[j - 1:j + 2]).all()
            and (v[j] >= max(v[j - 1], v[j + 1]) or v[j] <= min(v[j - 1], v[j + 1]))]


def local_maxima(re: Sequence[float], top: int = PEAKS_REFINED) -> list[int]:
    """Indices of the ``top`` largest local maxima of sampled values, largest first.

    A sample counts when it has a value (not NaN) and is ``>=`` each neighbour that has one; the
    ends count against their one neighbour (a maximum at the grid's edge is refined towards it).
    """
    v = np.where(np.isfinite(np.asarray(re, dtype=float)), re, -np.inf)
    peaks = [j for j in range(len(v)) if np.isfinite(v[j])
             and v[j] >= v[max(j - 1, 0)] and v[j] >= v[min(j + 1, len(v) - 1)]]
    return sorted(peaks, key=lambda i: -v[i])[:top]


def same_family(p: Params, ka: float, za: complex, kb: float, zb: complex, dk: float = 0.05
                ) -> bool:
    """Whether the root ``zb`` at ``kb`` is the continuation of ``za`` at ``ka``.

    ``za`` is followed to ``kb`` by Newton in steps of at most ``dk`` (as
    :func:`analytic.numerics.spectrum.family_peak` does); same family when it lands on ``zb``
    (relative ``1e-6``). A failed Newton step counts as another family (the interval is then
    refined, never skipped).
    """
    from analytic.numerics.branches import polish_root

    n = max(1, int(math.ceil(abs(kb - ka) / dk)))
    z = complex(za)
    for i in range(1, n + 1):
        r = polish_root(p, ka + (kb - ka) * i / n, z)
        if not r.converged:
            return False
        z = complex(r.value)
    return abs(z - zb) <= 1e-6 * max(1.0, abs(zb))


def handovers(p: Params, ks: Sequence[float], zs: Sequence[complex | None]) -> list[int]:
    """Indices ``j`` where the fastest root changes family between ``ks[j]`` and ``ks[j + 1]``.

    A change of family is where the envelope has a kink, usually a dip; an interval with no
    root (``None``) on one side counts as a change.
    """
    return [j for j in range(len(ks) - 1)
            if zs[j] is None or zs[j + 1] is None
            or not same_family(p, ks[j], zs[j], ks[j + 1], zs[j + 1])]


def refinement_points(p: Params, ks: Sequence[float], zs: Sequence[complex | None],
                      min_ratio: float) -> list[float]:
    """New ``k`` samples around every extremum and every change of family.

    :func:`extremum_midpoints` plus the midpoint of every interval with a change of family
    (:func:`handovers`) wider than ``min_ratio``. Repeated until it returns nothing, every
    local extremum of the samples and every change of family are bracketed by samples within
    ``min_ratio`` of each other. Not excluded: a maximum
    and a minimum of *one* family's smooth ``Re Lambda(k)`` both hidden between two samples.
    """
    re = [z.real if z is not None else np.nan for z in zs]
    new = set(extremum_midpoints(ks, re, min_ratio))
    new.update(float(np.sqrt(ks[j] * ks[j + 1])) for j in handovers(p, ks, zs)
               if ks[j + 1] / ks[j] > min_ratio)
    return sorted(new)


def extremum_midpoints(ks: Sequence[float], re: Sequence[float], min_ratio: float) -> list[float]:
    """New ``k`` samples around every local extremum of the sampled envelope.

    The envelope is a maximum over root families: a dip (where one family hands over to the
    next) or a peak can lie between two samples and be jumped over. On each side of every local
    extremum (:func:`local_extrema`) the geometric midpoint is added when the two samples are
    more than ``min_ratio`` apart; repeating until nothing is added resolves every extremum to
    that ratio.

    Args:
        ks: Sorted, positive sample points.
        re: The envelope at each (NaN: no value).
        min_ratio: Neighbouring samples closer than this ratio (> 1) are not split.

    Returns:
        The new points, sorted, without duplicates (empty when every extremum is resolved).
    """
    if not min_ratio > 1.0:
        raise ValueError(f"min_ratio = {min_ratio} must be > 1")
    new: set[float] = set()
    for j in local_extrema(re):
        for a, b in ((j - 1, j), (j, j + 1)):
            if ks[b] / ks[a] > min_ratio:
                new.add(float(np.sqrt(ks[a] * ks[b])))
    return sorted(new)


def refine_envelope(p: Params, region: Region, ks: list[float], zs: list,
                    top: int = PEAKS_REFINED) -> dict:
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
    best = {"k": ks[int(np.argmax(re))], "Lambda": zs[int(np.argmax(re))], "fastest": True}
    peaks = []
    for j in local_maxima(re, top):
        lo, hi = ks[max(j - 1, 0)], ks[min(j + 1, len(ks) - 1)]
        k, z = family_peak(p, ks[j], zs[j], lo, hi)
        try:
            # the family's peak as hint and start: one band count proves it the fastest
            zf = fastest_mode(p, k, region, z.real, [z], whole=False).root
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


def fastest_at(p: Params, k: float, region: Region) -> tuple[complex | None, int, str, bool]:
    """:func:`analytic.numerics.spectrum.fastest_mode` at ``k``, a failed count kept as such.

    Returns:
        ``(root or None, count, error text, proven)``; a count that fails on its contour gives
        ``(None, -1, its message, False)`` (the scenes report it and go on).
    """
    try:
        m = fastest_mode(p, float(k), region)
    except ContourError as err:
        return None, -1, str(err), False
    return m.root, m.count, "", bool(m.proven)


def best_over_k(p: Params, ks: np.ndarray, region: Region) -> dict:
    """Fastest root over every mode in R and over k (grid, then local samples).

    The two largest grid values are refined by 8 samples between their neighbours.

    Returns:
        ``k``, ``re_lambda`` and ``im_lambda`` of the fastest root found (``None``: no root in
        the region at any sample), ``failed_counts``, the grid ``k`` whose count failed, and
        ``proven_k_count`` / ``k_with_root``: grid ``k`` at which the tail bound proves that
        no root outside the region grows faster than the fastest inside, of those with a root
        inside (:func:`analytic.numerics.spectrum.fastest_mode`).
    """

    def growth(k: float) -> tuple[float, complex | None, int, bool]:
        root, count, _, proven = fastest_at(p, k, region)
        return (root.real if root is not None else -np.inf), root, count, proven

    vals = [growth(k) for k in ks]
    grid_proven = sum(v[3] for v in vals)
    with_root = sum(v[1] is not None for v in vals)
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
    k, g, z, _, _ = best
    return {"k": k, "re_lambda": g if np.isfinite(g) else None,
            "im_lambda": z.imag if z is not None else None, "failed_counts": failed,
            "proven_k_count": grid_proven, "k_with_root": with_root}


#: Seconds of one count (:func:`fastest_root`) per ``S^COUNT_EXPONENT``, ``S`` the region's
#: height ``W`` times the S-wave travel time across the stack (``H/c_s + H2/c_s2``: the roots'
#: spacing in ``Im Lambda`` goes as its inverse). Refitted 2026-11-30 (the counts had become
#: faster than the 2026-11-25 fit, 0.02 + 6e-5 S^1.75, predicted: 3x at ``S = 172.6``, 13x at
#: ``S = 1613``): this 2-core
#: machine, idle (load average 0.3), ``fastest_root`` in-process, region ``c_max = 4``, best of
#: 3, rigid substrate, 26 counts over ``S = 13.8 .. 1613`` (paper parameters, both tops, ``k =
#: 0.3 .. 100``; ``H = 2``; stress ``H = 0.2, Delta = -0.5``), least squares in log space:
#: ``0.005 + 1.7e-3 S^0.9``, measured / model 0.62-1.67 (e.g. ``S = 13.8, 96.6, 412.6, 1613``:
#: 0.021, 0.104-0.111, 0.29-0.33, 1.87 s). Under a load of 12 counts took 3-4x longer.
COUNT_SECONDS = 1.7e-3
#: The exponent of the region's size in :data:`COUNT_SECONDS`.
COUNT_EXPONENT = 0.9
#: Seconds of the smallest count (set-up, a few contour samples).
COUNT_FLOOR = 0.005
#: A two-body count costs this many times a rigid one of the same size (larger determinant,
#: more samples): measured 2.5-5.2, geometric mean 3.6, for ``H2 = H``, ``mu2 = 100`` at ``k =
#: 0.3, 1, 3, 6, 12`` (``S = 19 .. 225``: 0.080, 0.103, 0.367, 0.397, 1.16 s; idle, 2026-11-30).
TWO_BODY_COUNT_FACTOR = 4.0
#: An adaptive region (``c_max = None``) costs this many times its first rung, 4 ``c_d``: the
#: climb to higher rungs where the tail bound does not yet prove the fastest mode. Measured
#: 0.9-1.6 at the paper's parameters (both tops, ``k = 0.3 .. 100``, and two bodies, ``mu2 =
#: 100``), up to 6.7 on a stress top with ``beta = 0.6, gamma = 1`` (idle, 2026-11-30).
#: The plans with this model against the scenes' measured wall times, 2 ranks, idle,
#: 2026-11-30 (the old fit's plans in brackets): ``envelope.py``'s 48-point grid, both tops,
#: 2.8 s against 3.1 and 4.5 s less start-up (5.4 s); ``contrast.py``'s default, ``H2 = 0.5``
#: and ``inf`` apart: 61 s against 117 s, 38 s against 104 s (520 s both); the 41 x 41 stress
#: map: 1 135 s against session 24's 624 s (983 s). Under where two ranks share this machine's
#: two cores (1.05-1.4x the throughput of one, not 2x) and for the half-space substrate, over
#: for the map, whose region ``Re > 0`` holds few roots.
ADAPTIVE_COUNT_FACTOR = 1.5


def count_seconds(p: Params, k: float, region: Region) -> float:
    """Estimated seconds of one count at ``k`` (:func:`fastest_root`; see :data:`COUNT_SECONDS`).

    An adaptive region (``c_max = None``) is estimated at its first rung (4 ``c_d``) times
    :data:`ADAPTIVE_COUNT_FACTOR`.
    """
    reg = region if region.c_max is not None else region.fixed(4.0)
    travel = p.H / p.slider.c_s
    if p.two_body and math.isfinite(p.H2):
        travel += p.H2 / p.substrate.c_s
    size = reg.im_max(p, float(k)) * travel
    factor = TWO_BODY_COUNT_FACTOR if p.two_body else 1.0
    if region.c_max is None:
        factor *= ADAPTIVE_COUNT_FACTOR
    return COUNT_FLOOR + COUNT_SECONDS * factor * size**COUNT_EXPONENT


def counts_seconds(items: Sequence[Sequence[tuple[Params, float]]], region: Region,
                   ranks: int) -> float:
    """Estimated wall seconds of counts: ``items[i]`` the ``(p, k)`` counts of one work item.

    The items are shared over ``ranks`` (largest first): the wall time is the larger of the
    total over the ranks and the largest item.
    """
    costs = [sum(count_seconds(p, k, region) for p, k in item) for item in items]
    return max(sum(costs) / max(1, ranks), max(costs, default=0.0))


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


def follow_parameter(p: Params, k: float, z: complex, name: str, values: Sequence[float],
                     substeps: int = 10) -> list[complex | None]:
    """The root ``z`` of ``p`` at ``k``, continued in one parameter to each of ``values``.

    Newton continuation from ``p``'s value outwards (values below it in decreasing order, above
    it in increasing order), ``substeps`` equal steps between successive values; ``None`` from
    the first Newton failure on (that side).
    """
    from analytic.numerics.branches import polish_root

    v0 = float(getattr(p, name))
    out: dict[float, complex | None] = {}
    for side in (sorted(v for v in values if v < v0)[::-1], sorted(v for v in values if v >= v0)):
        zz: complex | None = complex(z)
        prev = v0
        for v in side:
            for s in range(1, substeps + 1):
                if zz is None:
                    break
                r = polish_root(p.replace(**{name: prev + (v - prev) * s / substeps}), k, zz)
                zz = complex(r.value) if r.converged else None
            out[float(v)] = zz
            prev = v
    return [out[float(v)] for v in values]


def plateau_dependence(p: Params, k: float, z: complex) -> dict:
    """``H Re Lambda`` of one plateau mode against ``alpha_pc``, ``f gamma`` and ``H``.

    The root ``z`` at ``k`` (a local maximum of the envelope at large ``k H``) is followed in
    ``alpha_pc`` (0, then 1e-4 to 1: the filter acts from ``alpha_pc ~ 1/|Lambda|``), in
    ``gamma`` (``f gamma`` from 0.03 to 3, ``f`` fixed) and in ``H`` at fixed ``k H``
    (``Lambda H`` is invariant at ``|Lambda| >> 1``, docs/envelope.md).

    Returns:
        ``{"alpha_pc": [[value, H Re Lambda], ...], "f_gamma": ..., "H": ...}`` (``None``
        where the continuation failed), plus ``kH`` and ``Lambda`` of the mode.
    """
    apc = [0.0] + [float(v) for v in np.geomspace(1e-4, 1.0, 13)]
    gam = [float(v) for v in np.geomspace(0.1, 10.0, 11)]
    hs = [float(v) for v in np.geomspace(0.25, 4.0, 9)]

    def h_re(zz: complex | None, h: float) -> float | None:
        return None if zz is None else zz.real * h

    out = {"kH": k * p.H, "Lambda": [z.real, z.imag]}
    out["alpha_pc"] = [[v, h_re(w, p.H)] for v, w in
                       zip(apc, follow_parameter(p, k, z, "alpha_pc", apc), strict=True)]
    out["f_gamma"] = [[v * p.f, h_re(w, p.H)] for v, w in
                      zip(gam, follow_parameter(p, k, z, "gamma", gam), strict=True)]
    kh = k * p.H
    out["H"] = [[h, h_re(w, h)] for h, w in
                zip(hs, [_polished(p.replace(H=h), kh / h, z * p.H / h) for h in hs],
                    strict=True)]
    return out


def _polished(p: Params, k: float, guess: complex) -> complex | None:
    from analytic.numerics.branches import polish_root

    r = polish_root(p, k, guess)
    return complex(r.value) if r.converged else None
