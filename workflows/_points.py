"""The points of the exact-root scenes over ``k`` (:func:`fastest_on`) and their ``--fe-check``.

``contrast.py``, ``envelope.py`` and ``stability_map.py`` maximise the growth rate over the
exact roots (their argument-principle counts); with ``--fe-check yes`` each of their points
is handed to the certified FE sweep's own path at the point's ``k``
(:func:`forms.studies.sweep.fe_fastest`: its meshes, its count, its region climbed by the FE,
no exact root consulted) and the FE's fastest eigenvalue is set against the point: the
columns :data:`FE_COLUMNS`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from _grids import check_sweep_limits, progress_mapper

from analytic.params import ParameterError

#: The FE's fastest eigenvalue is the exact point's mode when this close to it (relative): the
#: FE's error at the sweep's ``--rtol`` 1e-8 rule (measured at most 1.5e-10 on the contrast
#: curve), far below the distance between two modes.
SAME_MODE = 1e-6
#: The columns of one checked point.
FE_COLUMNS = ("fe_re_lambda", "fe_im_lambda", "fe_rel_diff", "fe_count", "fe_closed", "fe_c_max",
              "fe_proven", "fe_note")


def fe_ready() -> None:
    """Import the FE sweep on every rank (collective: call it on all ranks before the points).

    Importing ``forms`` initialises PETSc on ``COMM_WORLD``, a collective step: a rank that
    imported it alone inside :func:`fe_point` (its share of the points) left the others
    waiting (``contrast.py --fe-check yes`` under ``mpirun -n 2`` hung).
    """
    import forms.studies.sweep  # noqa: F401


def fe_own(params: Any, k: float, region: Any) -> dict:
    """The FE's own fastest mode at ``k`` (:func:`forms.studies.sweep.fe_fastest`), no exact root.

    Not collective once :func:`fe_ready` has run on every rank. A half-space substrate (no FE
    model) and a ``k`` the sweep refuses (:func:`_grids.check_sweep_limits`) are not run:
    ``fe_note`` says why (``fe_closed`` is then ``None``).

    Returns:
        :data:`FE_COLUMNS` (``fe_rel_diff`` left ``None``).
    """
    out: dict = dict.fromkeys(FE_COLUMNS)
    if params.two_body and not math.isfinite(params.H2):
        out["fe_note"] = "no FE model of a half-space substrate"
        return out
    try:
        check_sweep_limits(params, np.array([float(k)]), region)
    except ParameterError as err:
        out["fe_note"] = f"not run: {err}"
        return out
    from forms.studies.sweep import fe_fastest

    return out | fe_fastest(params, region, float(k))


def fe_point(params: Any, k: float, exact: complex | None, region: Any) -> dict:
    """The FE's own fastest mode at ``k`` (:func:`fe_own`) set against the exact point ``exact``.

    A point without a root is not run (``fe_note``; a half-space substrate's note first, as
    :func:`fe_own` gives it).

    Returns:
        :data:`FE_COLUMNS` (``fe_rel_diff``: ``|FE - exact| / |exact|``).
    """
    if exact is None and not (params.two_body and not math.isfinite(params.H2)):
        return dict.fromkeys(FE_COLUMNS) | {"fe_note": "no exact root to check"}
    out = fe_own(params, k, region)
    if out["fe_re_lambda"] is not None:
        fe = complex(out["fe_re_lambda"], out["fe_im_lambda"])
        out["fe_rel_diff"] = abs(fe - exact) / abs(exact)
    return out


def fe_points(comm: Any, params: Any, points: Sequence[tuple[float, complex]], region: Any,
              quiet: bool = False) -> list[dict]:
    """:func:`fe_point` at each ``(k, exact)`` of ``points``, shared over the ranks (collective).

    ``params``: the parameters of every point, or a list of one per point (a map's points).

    Returns:
        One dict per point, ``k`` first, on every rank.
    """
    each = list(params) if isinstance(params, list | tuple) else [params] * len(points)
    got = progress_mapper(comm, "FE checks", quiet, " points")(
        [float(k * q.H) ** 1.5 for (k, _), q in zip(points, each, strict=True)],
        lambda i: fe_point(each[i], points[i][0], points[i][1], region))
    return [{"k": float(points[i][0])} | got[i] for i in range(len(points))]


def fe_report(checked: Sequence[dict]) -> tuple[str | None, int]:
    """The scene's line on the points checked (``None``: no check asked) and the points failed.

    A point is found again when the FE's fastest eigenvalue is within :data:`SAME_MODE` of it;
    a point the FE could not be run at (``fe_note``: a half-space substrate, a ``k`` the sweep
    refuses) is counted as such, so that a check asked for never ends in silence. A point fails
    (the scene's exit code 1) where the FE's count did not close or where it closed on a fastest
    eigenvalue that is not the point: FE and exact disagree there.
    """
    asked = [r for r in checked if "fe_closed" in r]
    if not asked:
        return None, 0
    run = [r for r in asked if r["fe_closed"] is not None]
    if not run:
        return f"FE check: none of {len(asked)} point(s) run (see fe_note)", 0
    diffs = [r["fe_rel_diff"] for r in run if r["fe_rel_diff"] is not None]
    found = sum(d < SAME_MODE for d in diffs)
    unclosed = sum(not r["fe_closed"] for r in run)
    other = sum(bool(r["fe_closed"]) and not (r["fe_rel_diff"] is not None
                                              and r["fe_rel_diff"] < SAME_MODE) for r in run)
    line = (f"FE check: {found} of {len(run)} point(s) found again by the FE on its own "
            f"(largest relative difference from the exact point "
            f"{max(diffs, default=float('nan')):.2g}); {unclosed} FE count(s) not closed")
    if other:
        line += f"; {other} closed count(s) whose fastest eigenvalue is not the point"
    not_run = len(asked) - len(run)
    if not_run:
        line += f"; {not_run} point(s) not run (see fe_note)"
    return line, unclosed + other


def fastest_on(comm: Any, p: Any, region: Any, ks: Sequence[float]) -> dict[float, tuple]:
    """The fastest exact root in ``region`` at each ``k`` of ``ks``, shared over the ranks.

    Collective, with rank 0's bar (:func:`progress_mapper`); a count that fails on its contour
    is kept as such, for the scene to report (``envelope.py``).

    Returns:
        ``{k: (root or None, count (-1: failed), error text, proven)}`` on every rank
        (:func:`analytic.studies.growth.fastest_at`).
    """
    from analytic.studies.growth import fastest_at

    first = region if region.c_max is not None else region.fixed(4.0)
    costs = [first.im_max(p, kk) ** 1.5 for kk in ks]
    got = progress_mapper(comm, "k values")(costs, lambda i: fastest_at(p, float(ks[i]), region))
    return {float(ks[i]): got[i] for i in range(len(ks))}


def fe_peaks(comm: Any, params: Any, region: Any, samples: Sequence[Sequence[dict]],
             top: int | None = None, quiet: bool = False) -> list[list[dict]]:
    """The FE's own local maxima over ``k``, refined along their FE modes (collective).

    ``samples``: one or more runs of samples, each the FE's fastest eigenvalue at each ``k``
    of a sorted grid (entries of :func:`fe_points`), with ``params`` the parameters of every
    run or a list of one per run. The ``top`` (default
    :data:`analytic.studies.growth.PEAKS_REFINED`) largest local maxima of a run's FE values
    (:func:`analytic.studies.growth.local_maxima`, the exact envelope's rule) are each
    maximised along their FE mode between the neighbouring samples and certified at the ``k``
    found (:func:`forms.studies.peaks.fe_peak`); all runs' peaks are shared over the ranks. No
    exact root is consulted.

    Returns:
        Per run, one dict per peak, largest sample first, on every rank; ``same_mode``: the
        certified fastest eigenvalue at the peak's ``k`` is the mode refined (within
        :data:`SAME_MODE`) and its count closed.
    """
    from analytic.studies.growth import PEAKS_REFINED, local_maxima
    from forms.studies.peaks import fe_peak

    each = list(params) if isinstance(params, list | tuple) else [params] * len(samples)
    jobs = []  # (run, sample index)
    for r, run in enumerate(samples):
        re = [math.nan if s.get("fe_re_lambda") is None else s["fe_re_lambda"] for s in run]
        jobs += [(r, j) for j in local_maxima(re, PEAKS_REFINED if top is None else top)]

    def one(i: int) -> dict:
        r, j = jobs[i]
        run, s = samples[r], samples[r][j]
        return fe_peak(each[r], region, s["k"], complex(s["fe_re_lambda"], s["fe_im_lambda"]),
                       s["fe_c_max"], run[max(j - 1, 0)]["k"], run[min(j + 1, len(run) - 1)]["k"])

    got = progress_mapper(comm, "FE peaks", quiet, " peaks")(
        [(samples[r][j]["k"] * each[r].H) ** 1.5 for r, j in jobs], one)
    out: list[list[dict]] = [[] for _ in samples]
    for i, (r, _) in enumerate(jobs):
        g = got[i]
        cert = None if g["fe_re_lambda"] is None else complex(g["fe_re_lambda"], g["fe_im_lambda"])
        cont = None if g["continued_re"] is None else complex(g["continued_re"], g["continued_im"])
        g["same_mode"] = bool(g["fe_closed"] and cert is not None and cont is not None
                              and abs(cert - cont) <= SAME_MODE * abs(cert))
        out[r].append(g)
    return out


def fe_maximum(samples: Sequence[dict], peaks: Sequence[dict], exact: dict | None) -> dict:
    """The FE's own largest growth rate: of its closed samples and its peaks that are the mode.

    ``exact``: the exact maximum (``k``, ``re_lambda``, ``im_lambda``; ``None``: no root) it is
    set against.

    Returns:
        ``k``, ``re_lambda``, ``im_lambda`` (``None``: the FE has no value), ``source``
        (``sample`` or ``refined peak``), ``rel_diff`` (``|FE - exact| / |exact|`` of
        ``Lambda``), ``re_rel_diff`` (of ``Re Lambda``) and ``k_rel_diff`` against ``exact``,
        ``agrees`` (both have no value, or
        the same mode: ``rel_diff`` within :data:`SAME_MODE`), ``local_peaks`` (``peaks``).
    """
    cands = [(s["k"], s["fe_re_lambda"], s["fe_im_lambda"], "sample") for s in samples
             if s.get("fe_closed") and s.get("fe_re_lambda") is not None]
    cands += [(g["k"], g["fe_re_lambda"], g["fe_im_lambda"], "refined peak") for g in peaks
              if g["same_mode"]]
    k, re, im, source = max(cands, key=lambda c: c[1]) if cands else (None,) * 4
    out = {"k": k, "re_lambda": re, "im_lambda": im, "source": source,
           "rel_diff": None, "re_rel_diff": None, "k_rel_diff": None,
           "agrees": not cands and exact is None, "local_peaks": list(peaks)}
    if exact is not None and cands:
        z = complex(exact["re_lambda"], exact["im_lambda"])
        out["rel_diff"] = abs(complex(re, im) - z) / abs(z)
        out["re_rel_diff"] = abs(re - z.real) / abs(z.real)
        out["k_rel_diff"] = abs(k - exact["k"]) / exact["k"]
        out["agrees"] = out["rel_diff"] <= SAME_MODE
    return out


def fe_own_maximum(comm: Any, p: Any, region: Any, ks: Sequence[float], fe: Sequence[dict],
                   exact: dict | None, exact_re: Sequence[float]) -> dict:
    """The FE's own maximum over the samples ``ks`` (collective).

    :func:`fe_peaks` and :func:`fe_maximum` of the FE's values there (``fe``: :func:`fe_points`
    at the samples with an exact root, and maybe other points; a sample without one has no FE
    value).

    ``exact``, ``exact_re``: the exact maximum and the exact envelope's values at ``ks``
    (NaN: none). Adds ``local_maxima_as_exact``: the FE's values have their local maxima at
    the same samples as the exact ones (:func:`analytic.studies.growth.local_maxima`).
    """
    from analytic.studies.growth import local_maxima

    at = {r["k"]: r for r in fe}
    samples = [at.get(kk, {"k": kk, "fe_re_lambda": None}) for kk in ks]
    out = fe_maximum(samples, fe_peaks(comm, p, region, [samples])[0], exact)
    mine = [math.nan if s["fe_re_lambda"] is None else s["fe_re_lambda"] for s in samples]
    out["local_maxima_as_exact"] = set(local_maxima(mine)) == set(local_maxima(exact_re))
    return out


def fe_maximum_line(b: dict) -> str:
    """``envelope.py``'s line on the FE's own maximum (``summary.json`` ``fe_maximum``)."""
    n, same = len(b["local_peaks"]), sum(g["same_mode"] for g in b["local_peaks"])
    if b["re_lambda"] is None:
        return "FE's own maximum: none (no FE value at any sample)" + (
            "" if b["agrees"] else ": the exact envelope has one")
    line = (f"FE's own maximum: Re Lambda = {b['re_lambda']:.6f} at k = {b['k']:.7g} "
            f"({b['source']}; {same} of {n} local maxima refined along the FE mode and "
            "certified at their k")
    if b["rel_diff"] is None:
        return line + "; no exact maximum to set it against)"
    return line + (f"); against the exact maximum: Re Lambda to {b['re_rel_diff']:.1g}, k to "
                   f"{b['k_rel_diff']:.1g}, Lambda to {b['rel_diff']:.1g}"
                   + ("" if b["agrees"] else ": NOT THE SAME MODE"))


def envelope_fe(comm: Any, p: Any, region: Any, which: str, ks: Sequence[float],
                roots: Sequence[complex | None], best: dict | None, exact_re: Sequence[float]
                ) -> tuple[list[dict], str | None, int, dict | None]:
    """``envelope.py --fe-check which`` (collective).

    ``yes``: each refined local maximum of ``best`` (the exact envelope's maximum) handed to
    :func:`fe_points`; ``all``: every sample with a root (``roots`` at ``ks``) too, and the
    FE's own maximum (:func:`fe_own_maximum`).

    Returns:
        ``(points checked, fe_report's line, points failed, the FE's own maximum or None)``;
        an FE maximum that is not the exact one's mode counts as one point failed.
    """
    points = [] if which == "no" or best is None else [
        (pk["k"], complex(pk["re_lambda"], pk["im_lambda"])) for pk in best["local_peaks"]]
    if which == "all" and points:  # every sample with a root, and the refined peaks
        points = sorted(({kk: z for kk, z in zip(ks, roots, strict=True) if z is not None}
                         | dict(points)).items())
    fe = fe_points(comm, p, points, region) if points else []
    line, failed = fe_report(fe)
    own = fe_own_maximum(comm, p, region, ks, fe, best, exact_re) \
        if which == "all" and fe else None
    return fe, line, failed + (own is not None and not own["agrees"]), own


#: The columns of ``fe_grid.csv`` (``stability_map.py --fe-check grid``), one row per point and k.
GRID_COLUMNS = ("ix", "iy", "x", "y", "k", "kH", "fe_re_lambda", "fe_im_lambda", "fe_count",
                "fe_closed", "fe_c_max", "fe_proven", "fe_note")


def map_fe_grid(comm: Any, params: Sequence[Any], khs: Sequence[float], region: Any,
                rows: Sequence[dict], quiet: bool = False) -> tuple[list[dict], list[dict]]:
    """``stability_map.py --fe-check grid``: each point's value found by the FE alone (collective).

    At every point (``params``, one per row of ``rows``, the exact map's rows) and every ``k H``
    of the grid, the FE's own fastest eigenvalue (:func:`fe_own`: its count, its climbed
    region; a ``k`` without one: the FE's zero count there); then the
    :data:`analytic.studies.stability_map.MAP_PEAKS_REFINED` largest local maxima of those
    values refined along the FE's modes (:func:`fe_peaks`), and the largest of all
    (:func:`fe_maximum`) set against the exact row. Everything shared over the ranks.

    Returns:
        ``(points, samples)``: per point ``x``, ``y``, the FE's own maximum (:func:`fe_maximum`
        without ``local_peaks``; ``peaks``: their ``k``, ``fe_re_lambda``, ``same_mode``),
        ``counts_closed`` (every grid count closed), ``fe_stable_on_grid`` (closed, and no
        FE eigenvalue in the region at any grid ``k``), ``stable_as_exact``, ``proven_k``;
        and every sample (:data:`GRID_COLUMNS`).
    """
    from analytic.studies.stability_map import MAP_PEAKS_REFINED

    jobs = [(i, float(kh) / params[i].H) for i in range(len(params)) for kh in khs]
    got = progress_mapper(comm, "FE grid", quiet, " k values")(
        [(k * params[i].H) ** 1.5 for i, k in jobs], lambda m: fe_own(params[jobs[m][0]],
                                                                      jobs[m][1], region))
    nk = len(khs)
    runs = [[{"k": jobs[i * nk + j][1]} | got[i * nk + j] for j in range(nk)]
            for i in range(len(params))]
    peaks = fe_peaks(comm, list(params), region, runs, MAP_PEAKS_REFINED, quiet)
    points, samples = [], []
    for row, p, run, pk in zip(rows, params, runs, peaks, strict=True):
        exact = None if row["re_lambda"] is None else row
        best = fe_maximum(run, pk, exact)
        del best["local_peaks"]
        closed = all(s["fe_closed"] for s in run)
        stable = closed and all(s["fe_re_lambda"] is None for s in run)
        points.append({"x": row["x"], "y": row["y"], **best, "counts_closed": closed,
                       "fe_stable_on_grid": stable,
                       "stable_as_exact": stable == bool(row["stable_on_grid"]),
                       "proven_k": sum(bool(s["fe_proven"]) for s in run),
                       "peaks": [{"k": g["k"], "fe_re_lambda": g["fe_re_lambda"],
                                  "same_mode": g["same_mode"]} for g in pk]})
        samples += [{"ix": row["ix"], "iy": row["iy"], "x": row["x"], "y": row["y"],
                     "kH": s["k"] * p.H} | s for s in run]
    return points, samples


def map_fe_line(points: Sequence[dict]) -> tuple[str, int]:
    """``stability_map.py --fe-check grid``'s line on :func:`map_fe_grid`'s points.

    Returns:
        ``(line, points failed)``: a point fails where a count did not close, or where the FE's
        own value is not the exact point's mode (or not its stability).
    """
    bad = [q for q in points if not (q["agrees"] and q["counts_closed"] and q["stable_as_exact"])]
    unstable = [q for q in points if q["re_rel_diff"] is not None]
    worst = (f" (Re Lambda to {max(q['re_rel_diff'] for q in unstable):.1g}, k to "
             f"{max(q['k_rel_diff'] for q in unstable):.1g})" if unstable else "")
    stable = sum(q["fe_stable_on_grid"] for q in points)
    line = (f"FE grid: at {len(points) - len(bad)} of {len(points)} point(s) the FE's own "
            f"maximum over the k H grid, refined along its modes, is the exact point's{worst}; "
            f"{stable} stable by the FE's own counts; "
            f"{sum(not q['counts_closed'] for q in points)} point(s) with a count not closed")
    return line, len(bad)
