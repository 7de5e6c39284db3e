"""Work-precision points: relative error of one eigenvalue against wall time per ``k``.

The computation behind ``workflows/work_precision.py`` (its docstring describes the study).
Two cases:

- ``finite_H``: velocity top, paper defaults, ``k =`` :data:`K_FINITE`, branch ``0-``;
  reference: the exact root (:func:`analytic.numerics.branches.polish_root`). Cross-section FE
  (:class:`forms.models.cross_section.CrossSectionModel`) on uniform meshes.
- ``halfspace``: the same parameters with ``H = inf``, ``k =`` :data:`K_HALF`, the
  dilatational instability; reference :func:`analytic.physics.halfspace.dilatational_root`. FE with
  the PML layer of :mod:`forms.models.pml` (one layer setting), its cell size scaled.

Methods: SLEPc PEP and NEP, the dense companion baseline
(:func:`forms.solvers.slepc.dense_companion_eig`) and the analytic root itself. Every point is the
best wall time of a few repeats (:func:`best_of`) and a row (:func:`error_row`) with the
relative error against the reference; :func:`mark_pareto` marks the Pareto front. The points
are shared out over ranks as jobs (:func:`make_jobs`, :func:`job_cost`,
:func:`job_points`), each job on its own communicator (one rank).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from mpi4py import MPI

from analytic.numerics.branches import polish_root
from analytic.params import Params
from analytic.physics.halfspace import dilatational_root
from analytic.physics.largek import z_linear
from forms.models.cross_section import CrossSectionModel
from forms.models.pml import RESOLUTION, HalfSpaceModel, LayerDesign, design_layer
from forms.solvers.slepc import PolynomialSolver, SolveResult, SplitSolver, dense_companion_eig

#: Wavenumber and solver target of the finite-H case.
K_FINITE, TARGET_FINITE = 1.0, 0.3 - 6.6j
#: Wavenumber of the half-space case.
K_HALF = 0.3
#: The check value of docs/design.md section 4 (13 digits): reference of the analytic point.
CHECK_VALUE = 0.2716852879456 - 6.5866951866228j
#: Errors within this factor count as equal for the Pareto front.
PARETO_SLACK = 1.25
#: Largest companion pencil (d n) handed to the dense eigensolver. With Debian's reference
#: LAPACK, d n = 774 takes ~14 s.
DENSE_MAX = 900
#: Default options prefixes of the PEP and NEP solvers.
PREFIXES = ("wp_pep_", "wp_nep_")
#: CSV columns of a row (:func:`error_row`).
COLUMNS = ("case", "method", "degree", "cells", "dofs", "seconds", "rel_error", "re_lambda",
           "im_lambda", "pareto", "pareto_fe", "note")
DENSE_NOTE = "scipy.linalg.eig on the companion pencil"


@dataclass(frozen=True)
class Cases:
    """Parameters and references of the two cases (:func:`reference_cases`).

    Attributes:
        finite: Parameters of the finite-H case (paper defaults).
        half: Parameters of the half-space case (``H = inf``).
        lam_finite: Exact root of the finite-H case.
        lam_half: Exact dilatational root of the half-space case.
        target_half: Solver target and layer design point of the half-space case (Eq. kappa_d1).
    """

    finite: Params
    half: Params
    lam_finite: complex
    lam_half: complex
    target_half: complex


def reference_cases(finite: Params | None = None, half: Params | None = None) -> Cases:
    """Exact roots and the half-space target of the two cases.

    Args:
        finite: Finite-H parameters (default: the paper's, ``Params()``).
        half: Half-space parameters (default ``Params(H=inf)``).
    """
    p_fin = Params() if finite is None else finite
    p_half = Params(H=math.inf) if half is None else half
    lam_fin = complex(polish_root(p_fin, K_FINITE, TARGET_FINITE).value)
    lam_half = dilatational_root(K_HALF, p_half).Lambda
    target_half = complex(-1j * K_HALF * z_linear(K_HALF, p_half))  # Eq. kappa_d1
    return Cases(p_fin, p_half, lam_fin, lam_half, target_half)


def best_of(fn: Callable[..., Any], repeats: int, *args: Any, budget: float = 5.0
            ) -> tuple[float, Any]:
    """``(best wall time, last result)`` of ``fn(*args)`` over ``repeats`` runs.

    Stops repeating once ``budget`` seconds have been spent (slow points vary little).
    """
    best, out, spent = math.inf, None, 0.0
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn(*args)
        dt = time.perf_counter() - t
        best, spent = min(best, dt), spent + dt
        if spent > budget:
            break
    return best, out


def error_row(case: str, method: str, degree: int, cells: int, dofs: int, seconds: float,
              lam: complex, ref: complex, note: str = "") -> dict:
    """One point: its relative error ``|lam - ref| / |ref|`` (inf if ``lam`` is NaN).

    The keys are :data:`COLUMNS`; ``pareto`` and ``pareto_fe`` start ``False``.
    """
    err = abs(lam - ref) / abs(ref) if np.isfinite(lam) else math.inf
    return {"case": case, "method": method, "degree": degree, "cells": cells, "dofs": dofs,
            "seconds": seconds, "rel_error": err, "re_lambda": complex(lam).real,
            "im_lambda": complex(lam).imag, "pareto": False, "pareto_fe": False, "note": note}


def _first_value(res: SolveResult) -> complex:
    """Eigenvalue of the first pair of a solve (NaN if none); destroys the result."""
    lam = res.pairs[0].value if res.pairs else complex("nan")
    res.destroy()
    return lam


def _finite_solve(model: CrossSectionModel, solver: PolynomialSolver | SplitSolver) -> complex:
    """The operator at :data:`K_FINITE` and one SLEPc solve.

    The model caches its operator at the last ``k``: only the first call combines the
    ``k``-blocks, later repeats time the solve alone.
    """
    return _first_value(solver.solve(model.operator(K_FINITE), TARGET_FINITE))


def _finite_dense(model: CrossSectionModel) -> complex:
    """The operator at :data:`K_FINITE` (cached) and the dense companion solve."""
    return dense_companion_eig(model.operator(K_FINITE), TARGET_FINITE)


def finite_points(comm: MPI.Comm, p: Params, cells: Mapping[int, Sequence[int]], repeats: int,
                  dense: bool, lam_ref: complex, dense_max: int = DENSE_MAX,
                  prefixes: tuple[str, str] = PREFIXES) -> list[dict]:
    """FE points of the finite-H case: every (degree, cells), PEP, NEP, dense.

    The k-independent blocks are assembled once, untimed; the timed work is the solve at
    :data:`K_FINITE` (:func:`_finite_solve`). The operator at that ``k`` (three sparse additions)
    is combined in the first repeat only and cached, so the best of several repeats is the solve.

    Args:
        comm: Communicator of the models (one rank in the scene).
        p: Parameters.
        cells: Uniform cell counts per degree.
        repeats: Timing repeats (best kept).
        dense: Add the dense baseline where the pencil ``3 n <= dense_max``.
        lam_ref: Reference eigenvalue.
        dense_max: Largest companion pencil.
        prefixes: Options prefixes of the PEP and NEP solvers.
    """
    rows = []
    for deg, cell_list in cells.items():
        for n in cell_list:
            for form, method in (("polynomial", "PEP"), ("split", "NEP")):
                model = CrossSectionModel(comm, p, degree=deg, cells=n, ratio=1.0, form=form)
                solver = (PolynomialSolver(comm, nev=1, prefix=prefixes[0])
                          if form == "polynomial"
                          else SplitSolver(comm, nev=1, prefix=prefixes[1]))
                sec, lam = best_of(_finite_solve, repeats, model, solver)
                rows.append(error_row("finite_H", method, deg, n, model.size, sec, lam, lam_ref))
                if form == "polynomial" and dense and 3 * model.size <= dense_max:
                    sec, lam = best_of(_finite_dense, repeats, model)
                    rows.append(error_row("finite_H", "dense", deg, n, model.size, sec, lam,
                                          lam_ref, DENSE_NOTE))
                solver.destroy()
                model.destroy()
    return rows


def _half_solve(comm: MPI.Comm, p: Params, design: LayerDesign, deg: int, form: str,
                target: complex, prefixes: tuple[str, str]) -> tuple[complex, int]:
    """Build the PML model, solve once, destroy: ``(eigenvalue, unknowns)``."""
    model = HalfSpaceModel(comm, p, design, deg, form)
    solver = (PolynomialSolver(comm, nev=1, prefix=prefixes[0]) if form == "polynomial" else
              SplitSolver(comm, nev=1, radius=0.3, prefix=prefixes[1]))
    lam = _first_value(solver.solve(model.op, target))
    solver.destroy()
    size = model.size
    model.destroy()
    return lam, size


def _half_dense(comm: MPI.Comm, p: Params, design: LayerDesign, deg: int,
                target: complex) -> complex:
    """Build the polynomial PML model and solve it densely."""
    model = HalfSpaceModel(comm, p, design, deg, "polynomial")
    lam = dense_companion_eig(model.op, target)
    model.destroy()
    return lam


def half_points(comm: MPI.Comm, p: Params, scales: Mapping[int, Sequence[float]], repeats: int,
                dense: bool, lam_ref: complex, target: complex, dense_max: int = DENSE_MAX,
                prefixes: tuple[str, str] = PREFIXES) -> list[dict]:
    """FE points of the half-space case: PML model per (degree, cell-size factor).

    The layer depends on ``k``, so model assembly is part of the timed work.

    Args:
        comm: Communicator of the models (one rank in the scene).
        p: Parameters (``H = inf``).
        scales: Factors of :data:`forms.models.pml.RESOLUTION` per degree.
        repeats: Timing repeats (best kept).
        dense: Add the dense baseline where the pencil ``3 n <= dense_max``.
        lam_ref: Reference eigenvalue.
        target: Solver target and layer design point.
        dense_max: Largest companion pencil.
        prefixes: Options prefixes of the PEP and NEP solvers.
    """
    rows = []
    for deg, factors in scales.items():
        for c in factors:
            design = design_layer(K_HALF, target, p.beta, deg, resolution=c * RESOLUTION[deg])
            for form, method in (("polynomial", "PEP"), ("split", "NEP")):
                sec, (lam, size) = best_of(_half_solve, repeats, comm, p, design, deg, form,
                                           target, prefixes)
                rows.append(error_row("halfspace", f"PML {method}", deg, design.cells, size, sec,
                                      lam, lam_ref, f"cell size x{c}"))
                if form == "polynomial" and dense and 3 * size <= dense_max:
                    sec, lam = best_of(_half_dense, repeats, comm, p, design, deg, target)
                    rows.append(error_row("halfspace", "PML dense", deg, design.cells, size, sec,
                                          lam, lam_ref, DENSE_NOTE))
    return rows


def analytic_points(cases: Cases, repeats: int) -> list[dict]:
    """The analytic roots as points: Newton on ``det M`` and Newton in ``kappa_d``.

    Finite H: error against :data:`CHECK_VALUE`; half-space: against a second Newton start
    (from Eq. kappa_d1's ``kappa_d``).
    """
    p_fin, p_half = cases.finite, cases.half
    sec, r = best_of(polish_root, repeats, p_fin, K_FINITE, TARGET_FINITE)
    rows = [error_row("finite_H", "analytic", 0, 0, 0, sec, complex(r.value), CHECK_VALUE,
                      "Newton on det M; error vs the check value of docs/design.md"
                      " section 4 (13 digits)")]
    sec, r = best_of(dilatational_root, repeats, K_HALF, p_half)
    ref2 = dilatational_root(K_HALF, p_half, guess=complex(
        np.sqrt(1 - (p_half.beta * cases.target_half / (-1j * K_HALF)) ** 2)))
    rows.append(error_row("halfspace", "analytic", 0, 0, 0, sec, r.Lambda, ref2.Lambda,
                          "Newton in kappa_d; error vs a second start"))
    return rows


def make_jobs(cells: Mapping[int, Sequence[int]], scales: Mapping[int, Sequence[float]]
              ) -> list[tuple[str, int, tuple]]:
    """Jobs ``(kind, degree, sub)``: one per finite-H mesh, per PML scale, and the analytic."""
    jobs = [("finite", d, (n,)) for d, ns in cells.items() for n in ns]
    jobs += [("half", d, (c,)) for d, cs in scales.items() for c in cs]
    jobs += [("analytic", 0, ())]
    return jobs


def job_cost(kind: str, degree: int, sub: tuple) -> float:
    """Rough cost of one job for sharing out (unknowns; PML layers are larger)."""
    if kind == "finite":
        return 2.0 * (degree * sub[0] + 1)
    if kind == "half":
        return 400.0 * degree / sub[0]
    return 1.0


#: Seconds per unit of :func:`job_cost` and per repeat on one rank. Measured on this 2-core
#: machine (2026-11-25): ``--tiny --repeats 1 --no-dense`` (479 units) 0.9 s at a load of 3
#: (model 0.7 s); the default (23 715 units, 3 repeats, dense baseline) 88 s for the whole
#: scene at a load of 9 (model 107 s).
SECONDS_PER_COST = 1.5e-3


def estimate_seconds(jobs: Sequence[tuple[str, int, tuple]], repeats: int, ranks: int) -> float:
    """Estimated seconds of ``jobs`` (:func:`make_jobs`) shared over ``ranks``.

    The total over the ranks, or the largest job.
    """
    costs = [job_cost(*job) for job in jobs]
    return SECONDS_PER_COST * repeats * max(sum(costs) / max(1, ranks), max(costs, default=0.0))


def job_points(comm: MPI.Comm, job: tuple[str, int, tuple], cases: Cases, repeats: int,
               dense: bool, dense_max: int = DENSE_MAX,
               prefixes: tuple[str, str] = PREFIXES) -> list[dict]:
    """Rows of one job of :func:`make_jobs` (on ``comm``, one rank in the scene)."""
    kind, d, sub = job
    if kind == "finite":
        return finite_points(comm, cases.finite, {d: sub}, repeats, dense, cases.lam_finite,
                             dense_max, prefixes)
    if kind == "half":
        return half_points(comm, cases.half, {d: sub}, repeats, dense, cases.lam_half,
                           cases.target_half, dense_max, prefixes)
    return analytic_points(cases, repeats)


def mark_pareto(rows: list[dict], key: str = "pareto", fe_only: bool = False) -> None:
    """``row[key] = True`` for the points no other point of the case beats in time and error.

    ``fe_only``: among the finite-element points only (the analytic root left out). A point
    is dominated by a faster (or equally fast) one whose error is at most ``PARETO_SLACK``
    times its own (errors that close are the same digits).
    """
    for case in {r["case"] for r in rows}:
        pts = [r for r in rows if r["case"] == case and math.isfinite(r["rel_error"])
               and not (fe_only and r["method"] == "analytic")]
        for r in pts:
            e = max(r["rel_error"], 1e-16)
            r[key] = not any(
                o is not r and o["seconds"] <= r["seconds"]
                and max(o["rel_error"], 1e-16) <= PARETO_SLACK * e for o in pts)


def merge_rows(parts: Iterable[list[dict]]) -> list[dict]:
    """All ranks' rows in one sorted list, both Pareto fronts marked."""
    rows = [r for part in parts for r in part]
    rows.sort(key=lambda r: (r["case"], r["method"], r["degree"], r["dofs"]))
    mark_pareto(rows)
    mark_pareto(rows, "pareto_fe", fe_only=True)
    return rows


def fastest_seconds(rows: list[dict], thresholds: Sequence[float] = (1e-6, 1e-10)
                    ) -> dict[str, float]:
    """Per case, threshold and method: the least time of a point at least that accurate."""
    fastest = {}
    for case in ("finite_H", "halfspace"):
        for thr in thresholds:
            for m in {r["method"] for r in rows if r["case"] == case}:
                ok = [r["seconds"] for r in rows if r["case"] == case and r["method"] == m
                      and r["rel_error"] <= thr]
                if ok:
                    fastest[f"{case} {m} err<={thr:g}"] = min(ok)
    return fastest
