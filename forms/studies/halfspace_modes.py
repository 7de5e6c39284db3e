"""Half-space modes: FE roots (PML layer, plain truncated strips) checked against exact roots.

The computation behind ``workflows/halfspace_modes.py``. For one exact root of the half-space
spectrum (:class:`analytic.physics.halfspace.HalfSpaceRoot`) :func:`solve_k` computes the FE root
with
the PML layer (:func:`forms.models.pml.solve_halfspace`, two layer settings and its failure flags)
and with plain strips of given heights and top conditions (:func:`forms.models.pml.solve_truncated`,
flagged by the reflection estimate), one row each with the errors against the exact root.
:func:`silent_failures` picks the rows the code trusted although they are wrong, and
:func:`failure_summary` counts them.

Two bodies (a half-space slider on a deformable substrate of finite ``H2``): the exact roots
are every root of :func:`analytic.physics.twobody.det_twobody` in boxes under the slider's shear
cut (:func:`two_body_roots`), and :func:`solve_two_body_k` computes each with the one 1D model
of layers (:class:`forms.models.section.SectionModel` on :func:`forms.models.section.pml_stack`,
PML on top of the slider) at two layer settings; no truncated strips.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from mpi4py import MPI

from analytic.numerics.branches import roots_in_box
from analytic.params import Params
from analytic.physics.halfspace import HalfSpaceRoot
from forms.models.pml import solve_halfspace, solve_truncated
from forms.models.section import SectionModel, pml_stack
from forms.solvers.slepc import PolynomialSolver

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


@dataclass(frozen=True)
class TwoBodyRoot:
    """An exact root of the half-space slider on a finite substrate (the fields the rows use).

    Attributes:
        q: Wavenumber.
        Lambda: The root (physical sheet).
        branch: ``"+"`` or ``"-"``: the sign of ``Im Lambda``.
        decay_length_s: ``1 / Re k_s`` of the slider's shear wave, ``k_s = sqrt(q^2 + L^2)``.
        decay_length_d: ``1 / Re k_d``, ``k_d = sqrt(q^2 + beta^2 L^2)``.
    """

    q: float
    Lambda: complex
    branch: str
    decay_length_s: float
    decay_length_d: float
    sheet: str = "physical"


def two_body_roots(p: Params, ks: Sequence[float], re_max: float = 2.0,
                   margin: float = 0.05) -> list[TwoBodyRoot]:
    """Every exact root with ``|Re| < re_max`` and ``margin < |Im Lambda|/k < 1 - margin``.

    Below the slider's shear cut ``|Im Lambda| = k`` (``c_s = 1``) every root is an eigenvalue
    on the physical sheet; counted by the argument principle
    (:func:`analytic.numerics.branches.roots_in_box`) in one box on each side of the real axis.
    """
    out = []
    for k in ks:
        lo, hi = margin * k, (1.0 - margin) * k
        for sign, box in (("+", (-re_max, re_max, lo, hi)), ("-", (-re_max, re_max, -hi, -lo))):
            for r in roots_in_box(p, float(k), box):
                lam = complex(r.value)
                k_s = np.sqrt(k * k + lam * lam)
                k_d = np.sqrt(k * k + (p.beta * lam) ** 2)
                out.append(TwoBodyRoot(float(k), lam, sign, 1.0 / abs(k_s.real),
                                       1.0 / abs(k_d.real)))
    return out


def _pml_solve(comm: MPI.Comm, p: Params, k: float, target: complex, degree: int,
               attenuation: float) -> tuple[complex, float, int]:
    """``(Lambda, residual, unknowns)`` of the layered model with a PML, nearest ``target``."""
    model = SectionModel(comm, pml_stack(p, k, target, degree=degree, attenuation=attenuation),
                         p, degree=degree)
    solver = PolynomialSolver(comm, nev=1, prefix="pml_")
    try:
        res = solver.solve(model.operator(k), target)
        lam, resid = ((res.pairs[0].value, res.pairs[0].residual) if res.pairs
                      else (complex("nan"), math.nan))
        res.destroy()
        return complex(lam), float(resid), model.size
    finally:
        solver.destroy()
        model.destroy()


def solve_two_body_k(comm: MPI.Comm, p: Params, root: TwoBodyRoot, family: str, *,
                     degree: int, attenuation: float, tol: float) -> list[dict]:
    """The PML row of one exact root (two bodies): settings ``attenuation`` and ``1.25x``.

    Trusted when the two settings agree within ``tol`` (relative, and in ``Re Lambda``).
    ``family`` is not used: the row's family is ``"two-body"``.
    """
    t0 = time.perf_counter()
    lam1, _, n1 = _pml_solve(comm, p, root.q, root.Lambda, degree, attenuation)
    lam, resid, n2 = _pml_solve(comm, p, root.q, root.Lambda, degree, 1.25 * attenuation)
    dis = rel_error(lam1, lam)
    gdis = growth_rel_error(lam1, lam) if lam.real else abs(lam1.real)
    flags = [f for f, bad in (("no_root", not np.isfinite(lam)), ("disagreement", not dis <= tol),
                              ("growth_disagreement", not gdis <= 1e-3)) if bad]
    exact = root.Lambda
    return [{"k": root.q, "family": "two-body", "branch": root.branch, "method": "pml", "bc": "",
             "H": math.inf, "re_lambda": lam.real, "im_lambda": lam.imag,
             "re_lambda_exact": exact.real, "im_lambda_exact": exact.imag,
             "sheet_exact": root.sheet, "sheet": root.sheet,
             "rel_error": rel_error(lam, exact), "growth_rel_error": growth_rel_error(lam, exact),
             "disagreement": dis, "growth_disagreement": gdis, "residual": resid,
             "attenuation": 1.25 * attenuation, "reflection": math.nan,
             "decay_length_s": root.decay_length_s, "decay_length_d": root.decay_length_d,
             "dofs": n1 + n2, "seconds": time.perf_counter() - t0, "trusted": not flags,
             "flags": ";".join(flags)}]


#: Seconds per unit of the scene's cost of one ``k`` (2 for the PML solve with two layer
#: settings, 1 per truncated strip) at degree 4, one rank; times ``(degree / 4)^2.5``.
#: Measured on this 2-core machine (2026-11-25): the default run (11 ``k``, 66 units, P4)
#: 45.6 s in all at a load of 8 (about 40 s of solves: 0.6 s a unit); ``--k 0.3 --degree 2
#: --H-trunc ''`` (2 units, P2) 0.2 s at a load of 3 (model 0.21 s).
UNIT_SECONDS = 0.6


def estimate_seconds(costs: Sequence[float], degree: int, ranks: int) -> float:
    """Estimated seconds of the ``k`` values of cost ``costs`` shared over ``ranks``."""
    work = max(sum(costs) / max(1, ranks), max(costs, default=0.0))
    return UNIT_SECONDS * (degree / 4) ** 2.5 * work


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
