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


def fe_point(params: Any, k: float, exact: complex | None, region: Any) -> dict:
    """The FE's own fastest mode at ``k`` set against the exact point ``exact``.

    Not collective once :func:`fe_ready` has run on every rank. A half-space substrate (no
    FE model), a point without a root and a ``k`` the sweep refuses
    (:func:`_grids.check_sweep_limits`) are not run: ``fe_note`` says why.

    Returns:
        :data:`FE_COLUMNS` (``fe_rel_diff``: ``|FE - exact| / |exact|``).
    """
    out: dict = dict.fromkeys(FE_COLUMNS)
    half_space = params.two_body and not math.isfinite(params.H2)
    if half_space or exact is None:
        out["fe_note"] = ("no FE model of a half-space substrate" if half_space
                          else "no exact root to check")
        return out
    try:
        check_sweep_limits(params, np.array([float(k)]), region)
    except ParameterError as err:
        out["fe_note"] = f"not run: {err}"
        return out
    from forms.studies.sweep import fe_fastest

    out |= fe_fastest(params, region, float(k))
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
