"""Stability boundaries in the Delta-Gamma plane, kH -> infinity (Fig. stability_diagram).

Each of the three root families (:data:`FAMILIES`) has a boundary ``Delta(Gamma)`` below which
it is unstable. Two sources, compared point by point:

- closed forms, Eq. (stability_boundaries) (:mod:`analytic.physics.largek`): :func:`closed_form`;
- the spectrum ``s(z, q)`` itself (:mod:`analytic.physics.halfspace`): :func:`bracket_and_threshold`
  brackets the threshold by doubling (never from the closed form) and refines it with Brent
  bisection on the sign of the family's largest growth rate over ``q``.

:func:`boundary_records` gives one grid point's records (the rows of ``boundaries.csv``),
:func:`measured_differences` the largest relative difference of the two sources and
:func:`closed_form_points` the diagram's special points, :func:`estimate_seconds` the time the
points take. Used by ``workflows/phase_diagram.py``
and the gallery ``workflows/figures.py``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from analytic.params import Params
from analytic.physics import halfspace as hs
from analytic.physics import largek as lk

#: The paper's two ``(f, beta)`` rows of Fig. stability_diagram.
PAPER_ROWS: tuple[tuple[float, float], ...] = ((0.3, 0.45), (0.3, 0.6))
#: The root families, each with its own boundary.
FAMILIES: tuple[str, ...] = ("dilatational", "shear", "quasistatic")
#: Default number of log-spaced ``Gamma`` points per boundary (plus half as many linear ones).
N_GAMMA = 24


@dataclass(frozen=True)
class Window:
    """Extent of the diagram: the ``Gamma`` grid and the axes (defaults: the paper's).

    Attributes:
        gamma_min: Smallest ``Gamma`` (log axes, log grid).
        gamma_max: Largest ``Gamma``.
        delta_min: Smallest ``Delta`` shown on log axes.
        delta_max: Largest ``Delta`` shown; also the cap of the threshold search.
    """

    gamma_min: float = 1e-5
    gamma_max: float = 1.0
    delta_min: float = 1e-5
    delta_max: float = 1.0


def bracket_and_threshold(family: str, gamma_f: float, f: float, beta: float,
                          delta_cap: float) -> float:
    """Numerical boundary ``Delta(Gamma)`` of one family from the spectrum alone.

    The bracket: ``Delta = 1e-12`` must be unstable, then the upper end is doubled from
    ``1e-4`` until the family is stable (at most up to ``delta_cap``); Brent bisection
    (:func:`analytic.physics.halfspace.threshold_delta`, ``xtol = 1e-13``) refines it.

    Args:
        family: One of :data:`FAMILIES`.
        gamma_f: ``Gamma = gamma f``.
        f: Friction coefficient (> 0).
        beta: ``c_s / c_d``.
        delta_cap: Largest ``Delta`` searched.

    Returns:
        The threshold ``Delta``, NaN if the family has none in ``(0, delta_cap]``.
    """
    gamma = gamma_f / f

    def unstable(delta: float) -> bool:
        p = Params(f=f, gamma=gamma, beta=beta, Delta=delta, H=math.inf)
        return hs.max_growth(family, p).unstable

    lo = 1e-12
    if not unstable(lo):
        return math.nan
    hi = 1e-4
    while unstable(hi):
        lo = hi
        hi *= 2.0
        if hi > delta_cap:
            return math.nan
    return hs.threshold_delta(family, gamma_f, f, beta, (lo, hi), xtol=1e-13)


def closed_form(family: str, gamma_f: float, f: float, beta: float) -> float:
    """Eq. (stability_boundaries) for one family.

    Args:
        family: One of :data:`FAMILIES`.
        gamma_f: ``Gamma = gamma f``.
        f: Friction coefficient.
        beta: ``c_s / c_d``.

    Returns:
        ``Delta`` on the boundary; NaN for the shear family where ``Delta_s <= 0`` or
        ``Gamma >= 1``.
    """
    if family == "dilatational":
        return float(lk.delta_d(gamma_f, beta))
    if family == "shear":
        if gamma_f >= 1.0:
            return math.nan
        v = float(lk.delta_s(gamma_f, f, beta))
        return v if v > 0 else math.nan
    return lk.delta_qs(f, beta)


def boundary_records(f: float, beta: float, family: str, gamma_f: float,
                     delta_cap: float) -> list[dict]:
    """Records (closed form and numerical, where they exist) of one grid point.

    A numerical threshold at which the most unstable root sits on the edge of its family's
    region (``not MaxGrowth.interior`` just below the threshold) marks where the root leaves
    the region, not a change of stability: it carries a ``"dropped"`` reason.

    Args:
        f: Friction coefficient (> 0).
        beta: ``c_s / c_d``.
        family: One of :data:`FAMILIES`.
        gamma_f: ``Gamma = gamma f``.
        delta_cap: Largest ``Delta`` searched (:func:`bracket_and_threshold`).

    Returns:
        Dicts with keys ``boundary, source, f, beta, Gamma, Delta`` (``source``
        ``"closed_form"`` or ``"numerical"``), plus ``dropped`` (a reason) where it applies.
    """
    out = []
    closed = closed_form(family, gamma_f, f, beta)
    if math.isfinite(closed):
        out.append({"boundary": family, "source": "closed_form", "f": f, "beta": beta,
                    "Gamma": gamma_f, "Delta": closed})
    num = bracket_and_threshold(family, gamma_f, f, beta, delta_cap)
    if math.isfinite(num):
        rec = {"boundary": family, "source": "numerical", "f": f, "beta": beta,
               "Gamma": gamma_f, "Delta": num}
        below = hs.max_growth(family, Params(f=f, gamma=gamma_f / f, beta=beta,
                                             Delta=num * (1 - 1e-6), H=math.inf))
        if not below.interior:
            z = below.root_margin.z if below.root_margin is not None else math.nan
            rec["dropped"] = (f"most unstable root at the edge of the {family} region "
                              f"(z = {complex(z):.4g}): not a stability change")
        out.append(rec)
    return out


def gamma_grid(gmin: float, gmax: float, n: int) -> np.ndarray:
    """The ``Gamma`` points: log-spaced for the log panels plus linear ones for the linear ones.

    Args:
        gmin: Smallest ``Gamma`` (> 0).
        gmax: Largest ``Gamma``.
        n: Log-spaced points; ``max(n // 2, 2)`` linear ones are added.

    Returns:
        Sorted unique points (rounded to 14 decimals).
    """
    g = np.concatenate([np.logspace(math.log10(gmin), math.log10(gmax), n),
                        np.linspace(gmax / n, gmax, max(n // 2, 2))])
    return np.unique(np.round(g, 14))


def tasks(rows: list[tuple[float, float]],
          grid: np.ndarray) -> list[tuple[float, float, str, float]]:
    """Every ``(f, beta, family, Gamma)`` point of the diagram, rows first, then families.

    Args:
        rows: ``(f, beta)`` rows.
        grid: ``Gamma`` points (:func:`gamma_grid`).

    Returns:
        The arguments of :func:`boundary_records` (without the cap), one tuple per point.
    """
    return [(f, b, fam, float(g)) for f, b in rows for fam in FAMILIES for g in grid]


#: Seconds of one point of :func:`tasks` (its threshold: bracketing, then Brent bisection) on
#: one rank. Measured on this 2-core machine (2026-11-25, in the scene): ``--f 0.3 --beta 0.5
#: --n-gamma 2`` (9 points) 11.4 s and 7.7 s at a load of 3-4 (1.3 and 0.85 s each); the
#: default's first 54 of 210 points in 249 s at a load of 11 (4.6 s each, 1-16 s).
TASK_SECONDS = 2.0


def estimate_seconds(n_tasks: int, ranks: int) -> float:
    """Estimated seconds of ``n_tasks`` points of :func:`tasks` shared over ``ranks``."""
    return TASK_SECONDS * math.ceil(n_tasks / max(1, ranks))


def sort_records(records: list[dict]) -> tuple[list[dict], list[dict]]:
    """Split records into kept (sorted) and dropped ones.

    Args:
        records: Records of :func:`boundary_records`, in any order.

    Returns:
        ``(kept, dropped)``: kept sorted by ``f, beta``, family (order of :data:`FAMILIES`),
        source and ``Gamma``; dropped in the given order.
    """
    dropped = [r for r in records if "dropped" in r]
    kept = sorted((r for r in records if "dropped" not in r),
                  key=lambda r: (r["f"], r["beta"], FAMILIES.index(r["boundary"]),
                                 r["source"], r["Gamma"]))
    return kept, dropped


def measured_differences(records: list[dict], rows: list[tuple[float, float]]) -> dict:
    """Largest ``|numerical / closed form - 1|`` per row and boundary (the README quotes these).

    Args:
        records: Kept records (no ``dropped`` ones).
        rows: ``(f, beta)`` rows.

    Returns:
        ``{"f=..,beta=..": {family: {"n_numerical", "max_rel_diff", ...}}}``; the quasi-static
        entry also has the leading-order and limit thresholds and the numerical value at the
        smallest ``Gamma``.
    """
    out = {}
    for f, beta in rows:
        key = f"f={f:g},beta={beta:g}"
        out[key] = {}
        for fam in FAMILIES:
            pairs = {}
            for r in records:
                if r["f"] == f and r["beta"] == beta and r["boundary"] == fam:
                    pairs.setdefault(r["Gamma"], {})[r["source"]] = r["Delta"]
            rel = [abs(v["numerical"] / v["closed_form"] - 1) for v in pairs.values()
                   if "numerical" in v and "closed_form" in v and v["closed_form"] > 0]
            entry = {"n_numerical": sum("numerical" in v for v in pairs.values()),
                     "max_rel_diff": max(rel) if rel else None}
            if fam == "quasistatic":
                lim = lk.delta_qs_limit(f, beta)
                num = sorted((g, v["numerical"]) for g, v in pairs.items() if "numerical" in v)
                entry["delta_qs_leading"] = lk.delta_qs(f, beta)
                entry["delta_qs_limit"] = lim
                entry["numerical_at_smallest_gamma"] = num[0] if num else None
                entry["numerical_gamma_range"] = [num[0][0], num[-1][0]] if num else None
            out[key][fam] = entry
    return out


def closed_form_points(rows: list[tuple[float, float]]) -> dict:
    """Special points of the diagram per row, from :mod:`analytic.physics.largek`.

    Args:
        rows: ``(f, beta)`` rows.

    Returns:
        ``{"f=..,beta=..": {"all_modes_gamma", "delta_m", "delta_m_gamma",
        "shear_zero_gamma", "qs_truncation_gamma"}}``.
    """
    return {f"f={f:g},beta={b:g}": {
        "all_modes_gamma": lk.all_modes_gamma(b),
        "delta_m": lk.delta_m(f, b), "delta_m_gamma": lk.delta_m_gamma(f, b),
        "shear_zero_gamma": lk.delta_s_zero_gamma(f, b),
        "qs_truncation_gamma": lk.qs_truncation_gamma(f, b)}
        for f, b in rows}
