"""Half-space modes: FE roots (PML layer, plain truncated strips) checked against exact roots.

The computation behind ``workflows/halfspace_modes.py``. For one exact root of the half-space
spectrum (:class:`analytic.physics.halfspace.HalfSpaceRoot`) :func:`solve_k` computes the FE root
with
the PML layer (:func:`forms.models.pml.solve_halfspace`, two layer settings and its failure flags)
and with plain strips of given heights and top conditions (:func:`forms.models.pml.solve_truncated`,
flagged by the reflection estimate), one row each with the errors against the exact root.
:func:`silent_failures` picks the rows the code trusted although they are wrong, and
:func:`failure_summary` counts them.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterable, Sequence

import numpy as np

from mpi4py import MPI

from analytic.params import Params
from analytic.physics.halfspace import HalfSpaceRoot
from forms.models.pml import solve_halfspace, solve_truncated

#: Keys of a row of :func:`solve_k` (the CSV columns, in order).
COLUMNS = ("k", "family", "branch", "method", "bc", "H", "re_lambda", "im_lambda",
           "re_lambda_exact", "im_lambda_exact", "sheet_exact", "sheet", "rel_error",
           "growth_rel_error", "disagreement", "growth_disagreement", "residual", "attenuation",
           "reflection", "decay_length_s", "decay_length_d", "dofs", "seconds", "trusted", "flags")


def rel_error(a: complex, b: complex) -> float:
    """``|a - b| / |b|``; inf if ``a`` is NaN (no root found)."""
    return abs(a - b) / abs(b) if np.isfinite(a) else math.inf


def growth_rel_error(a: complex, b: complex) -> float:
    """``|Re a - Re b| / |Re b|``; inf if ``a`` is NaN or ``Re b = 0``."""
    return abs(a.real - b.real) / abs(b.real) if np.isfinite(a) and b.real else math.inf


def solve_k(comm: MPI.Comm, p: Params, root: HalfSpaceRoot, family: str, *, degree: int,
            attenuation: float, tol: float, heights: Sequence[float],
            bcs: Sequence[str]) -> list[dict]:
    """All rows of one ``k = root.q`` (PML, then every truncated strip) on ``comm``.

    Args:
        comm: Communicator of the meshes.
        p: Parameters (``H = inf``).
        root: Exact root (reference, PML target; its sheet is the one asked for, the
            ``"unphysical"`` sheet is asked for as ``"physical"``).
        family: Family name written into the rows.
        degree: Element degree.
        attenuation: e-folds of the slower wave across the first PML layer.
        tol: Relative disagreement (PML) and reflection (strips) accepted.
        heights: Heights of the truncated strips.
        bcs: Top conditions of the truncated strips (outer loop).

    Returns:
        Rows with the keys :data:`COLUMNS`; ``trusted`` is the code's own verdict.
    """
    k, exact = root.q, root.Lambda
    base = {"k": k, "family": family, "branch": root.branch or "-",
            "re_lambda_exact": exact.real, "im_lambda_exact": exact.imag, "sheet_exact": root.sheet,
            "decay_length_s": root.decay_length_s, "decay_length_d": root.decay_length_d}
    rows = []
    t0 = time.perf_counter()
    sheet = root.sheet if root.sheet != "unphysical" else "physical"
    r = solve_halfspace(comm, p, k, exact, degree=degree, attenuation=attenuation,
                        sheet=sheet, tol=tol)
    rows.append({**base, "method": "pml", "bc": "", "H": math.inf, "re_lambda": r.Lambda.real,
                 "im_lambda": r.Lambda.imag, "sheet": r.sheet,
                 "rel_error": rel_error(r.Lambda, exact),
                 "growth_rel_error": growth_rel_error(r.Lambda, exact),
                 "disagreement": r.disagreement, "growth_disagreement": r.growth_disagreement,
                 "residual": r.residual, "attenuation": r.attenuation, "reflection": math.nan,
                 "dofs": sum(r.sizes), "seconds": time.perf_counter() - t0,
                 "trusted": r.ok, "flags": ";".join(r.flags)})
    for bc in bcs:
        for H in heights:  # noqa: N806
            t0 = time.perf_counter()
            t = solve_truncated(comm, p, k, float(H), bc, exact, degree=degree, tol=tol)
            rows.append({**base, "method": "truncated", "bc": bc, "H": float(H),
                         "re_lambda": t.Lambda.real, "im_lambda": t.Lambda.imag, "sheet": "",
                         "rel_error": rel_error(t.Lambda, exact),
                         "growth_rel_error": growth_rel_error(t.Lambda, exact),
                         "disagreement": math.nan, "growth_disagreement": math.nan,
                         "residual": t.residual, "attenuation": math.nan,
                         "reflection": t.reflection, "dofs": t.size,
                         "seconds": time.perf_counter() - t0, "trusted": not t.flags,
                         "flags": ";".join(t.flags)})
    return rows


def merge_rows(parts: Iterable[list[dict]]) -> list[dict]:
    """All ranks' rows, sorted by branch, ``k``, method, top condition and height."""
    return sorted((r for part in parts for r in part),
                  key=lambda r: (r["branch"], r["k"], r["method"], r["bc"], r["H"]))


def silent_failures(rows: list[dict], silent_rtol: float) -> list[dict]:
    """Rows the code trusted although they are farther than ``silent_rtol`` from the root."""
    return [r for r in rows if r["trusted"] and not r["rel_error"] <= silent_rtol]


def failure_summary(rows: list[dict], silent: list[dict]) -> dict:
    """Counts of rows, trusted, flagged and silent failures, and the worst trusted PML error."""
    return {"rows": len(rows),
            "trusted": sum(r["trusted"] for r in rows),
            "flagged": sum(not r["trusted"] for r in rows),
            "silent_failures": len(silent),
            "silent_failure_rows": [{"k": r["k"], "method": r["method"], "bc": r["bc"],
                                     "H": r["H"], "rel_error": r["rel_error"]} for r in silent],
            "pml_max_rel_error_trusted": max(
                [r["rel_error"] for r in rows if r["method"] == "pml" and r["trusted"]],
                default=math.nan)}
