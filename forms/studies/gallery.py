"""FE check points of the gallery figures (``workflows/figures.py``, ``analytic.studies.gallery``).

Each :class:`analytic.studies.gallery.FETask` is an exact root on a drawn curve; here it is computed
by a FE model, with the exact root as shift and reference: finite ``H`` by the cross-section
model (:class:`forms.models.cross_section.CrossSectionModel`, one mesh per curve), the half-space by
the PML model (:func:`forms.models.pml.solve_halfspace`, including ``alpha_PC``/``alpha_LD``: the
friction row carries them). Only points the FE itself trusts are drawn (cross-section:
converged, backward error < :data:`CS_RESIDUAL`; PML: no flag). The work is shared over the
ranks in units (:func:`fe_units`), each solved on ``MPI.COMM_SELF``.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from mpi4py import MPI

from analytic.studies.gallery import FETask, fe_value
from forms.models.cross_section import CrossSectionModel
from forms.models.pml import design_layer, solve_halfspace
from forms.solvers.slepc import PolynomialSolver, shift_off

#: Element degree of the cross-section model (finite H); cells from
#: :func:`meshes.interval.default_cells` (the sweep's default mesh).
CS_DEGREE = 3
#: Largest backward error of a cross-section eigenpair drawn as trusted. Converged PEP pairs of
#: this model have 1e-16 .. 1e-14 (measured 2026-11-21 on the gallery's points); a pair above
#: this is not a converged eigenpair of the discrete problem.
CS_RESIDUAL = 1e-10
#: Element degree of the half-space (PML) model, ``forms.models.pml.solve_halfspace``'s default.
PML_DEGREE = 4
#: Options prefix of the cross-section solves (the PML solves use ``forms.models.pml``'s ``pml_``).
CS_PREFIX = "gallery_cs_"
#: Description of each FE model, as listed in ``figures.json``.
FE_MODELS = {
    "cross_section": f"cross-section model P{CS_DEGREE} (forms.models.cross_section, SLEPc PEP), "
                     f"trusted if converged and backward error < {CS_RESIDUAL:g}",
    "pml": f"half-space PML model P{PML_DEGREE} (forms.models.pml.solve_halfspace: two layer "
           "settings), trusted if no flag",
}


@dataclass(frozen=True)
class Marker:
    """A trusted FE point as drawn.

    Attributes:
        panel: Axes index.
        x: Abscissa (figure units).
        y: Ordinate (the task's quantity of the FE eigenvalue).
        model: ``"cross_section"`` or ``"pml"``.
        color: Colour of the curve it checks.
    """

    panel: int
    x: float
    y: float
    model: str
    color: str


def _fail(err: Exception) -> str:
    return f"error: {type(err).__name__}: {err}".replace("\n", " ")[:200]


def solve_cross_section(comm: MPI.Comm, tasks: list[FETask]) -> list[dict[str, Any]]:
    """FE eigenvalues of tasks sharing one parameter set, on one cross-section mesh.

    Args:
        comm: Communicator of the model.
        tasks: Cross-section tasks of one curve (same parameters).

    Returns:
        Per task ``{"Lambda", "residual", "flags", "size", "seconds"}``: the converged
        eigenvalue nearest the exact root, its backward error, the reasons not to trust it
        (``residual``, ``no_root``, ``not_converged (...)``, ``error: ...``), the number of
        unknowns, and the mean time per task.
    """
    t0 = time.perf_counter()
    model = CrossSectionModel(comm, tasks[0].params, degree=CS_DEGREE,
                              k_max=max(t.k for t in tasks), n_max=max(t.n_max for t in tasks))
    solver = PolynomialSolver(comm, nev=2, prefix=CS_PREFIX)
    out = []
    for t in tasks:
        row = {"Lambda": complex("nan"), "residual": float("nan"), "flags": [],
               "size": model.size}
        try:
            # the exact root is (nearly) an eigenvalue: shift off it (forms.solvers.slepc.shift_off)
            res = solver.solve(model.operator(t.k), shift_off(t.target))
        except Exception as err:  # noqa: BLE001 - one failed solve must not stop the gallery
            row["flags"].append(_fail(err))
            solver.destroy()
            solver = PolynomialSolver(comm, nev=2, prefix=CS_PREFIX)
            out.append(row)
            continue
        if res.pairs:  # the converged eigenvalue nearest the exact root
            pair = min(res.pairs, key=lambda q: abs(q.value - t.target))
            row["Lambda"], row["residual"] = pair.value, pair.residual
            if not row["residual"] < CS_RESIDUAL:
                row["flags"].append("residual")
        else:
            row["flags"].append("no_root")
        if not res.ok:
            row["flags"].append(f"not_converged ({res.reason})")
        res.destroy()
        out.append(row)
    solver.destroy()
    model.destroy()
    dt = (time.perf_counter() - t0) / len(tasks)
    for row in out:
        row["seconds"] = dt
    return out


def solve_pml(comm: MPI.Comm, task: FETask) -> dict[str, Any]:
    """FE half-space root near the exact one (PML, with its own failure checks).

    Args:
        comm: Communicator of the model.
        task: A ``"pml"`` task.

    Returns:
        ``{"Lambda", "residual", "flags", "size", "seconds"}`` as :func:`solve_cross_section`
        (flags: those of :func:`forms.models.pml.solve_halfspace`, or ``error: ...``).
    """
    t0 = time.perf_counter()
    try:
        r = solve_halfspace(comm, task.params, task.k, task.target, degree=PML_DEGREE,
                            sheet=task.sheet)
        row = {"Lambda": r.Lambda, "residual": r.residual, "flags": list(r.flags),
               "size": max(r.sizes)}
    except Exception as err:  # noqa: BLE001 - one failed solve must not stop the gallery
        row = {"Lambda": complex("nan"), "residual": float("nan"), "flags": [_fail(err)],
               "size": 0}
    row["seconds"] = time.perf_counter() - t0
    return row


def fe_units(tasks: Sequence[FETask]) -> list[tuple[float, list[int]]]:
    """Work units ``(estimated cost, task indices)``.

    One unit per cross-section curve (one mesh; ``400 + 20`` per point), one per PML point
    (cost twice the cells of the layer :func:`forms.models.pml.design_layer` would build, 100 cells
    if it cannot). PML units come first, in task order, then the curves.

    Args:
        tasks: All tasks.

    Returns:
        The units; every task index is in exactly one.
    """
    units: list[tuple[float, list[int]]] = []
    curves: dict[tuple, list[int]] = {}
    for i, t in enumerate(tasks):
        if t.model == "cross_section":
            curves.setdefault((t.figure, t.curve, t.params), []).append(i)
        else:
            try:
                cells = design_layer(t.k, t.target, t.params.beta, PML_DEGREE,
                                     sheet=t.sheet).cells
            except ValueError:
                cells = 100
            units.append((2.0 * cells, [i]))
    units += [(400.0 + 20.0 * len(idx), idx) for idx in curves.values()]
    return units


def solve_fe(comm: MPI.Comm, tasks: Sequence[FETask], units: Sequence[tuple[float, list[int]]],
             mine: Sequence[int]) -> list[dict[str, Any]]:
    """Every task solved once, the units split over the ranks (each on ``MPI.COMM_SELF``).

    Collective; every rank gets every result, in the order of ``tasks``.

    Args:
        comm: Communicator the work is shared over.
        tasks: All tasks (the same on every rank).
        units: :func:`fe_units` of ``tasks``.
        mine: Indices into ``units`` this rank solves (a split such as ``_cli.my_share``
            of the units' costs; the ranks' shares must cover every unit once).

    Returns:
        One result dict per task (:func:`solve_cross_section`, :func:`solve_pml`).
    """
    results: dict[int, dict] = {}
    for j in mine:
        idx = units[j][1]
        if tasks[idx[0]].model == "cross_section":
            results.update(zip(idx, solve_cross_section(MPI.COMM_SELF, [tasks[i] for i in idx]),
                               strict=True))
        else:
            results.update({i: solve_pml(MPI.COMM_SELF, tasks[i]) for i in idx})
    merged: dict[int, dict] = {}
    for part in comm.allgather(results):
        merged.update(part)
    return [merged[i] for i in range(len(tasks))]


def check_points(tasks: Sequence[FETask],
                 results: Sequence[dict[str, Any]]) -> tuple[dict[str, Any], list[Marker]]:
    """The trusted FE points of one figure and their summary for ``figures.json``.

    A point is trusted if its result has no flag and a finite eigenvalue.

    Args:
        tasks: The figure's tasks.
        results: Their results (:func:`solve_fe`), same order.

    Returns:
        ``(summary, markers)``: the summary has ``models`` (:data:`FE_MODELS`), ``requested``,
        ``points`` (trusted), ``max_rel_deviation`` and ``median_rel_deviation`` of
        ``Lambda`` from the exact root, ``max_abs_deviation_plotted`` (in the drawn
        quantities), ``seconds`` and ``skipped`` (``curve, k, x, reason`` per untrusted
        point); the markers are the trusted points as drawn, in task order.
    """
    markers: list[Marker] = []
    skipped, dev, dev_y, seconds = [], [], [], 0.0
    for t, r in zip(tasks, results, strict=True):
        seconds += r["seconds"]
        lam = r["Lambda"]
        if r["flags"] or not np.isfinite(lam):
            skipped.append({"curve": t.curve, "k": t.k, "x": t.x,
                            "reason": ";".join(r["flags"]) or "no value"})
            continue
        dev.append(abs(lam - t.target) / abs(t.target))
        for panel, quantity in t.draw:
            y = fe_value(lam, t, quantity)
            dev_y.append(abs(y - fe_value(t.target, t, quantity)))
            markers.append(Marker(panel, t.x, y, t.model, t.color))
    models = sorted({t.model for t in tasks})
    summary = {"models": [FE_MODELS[m] for m in models], "requested": len(tasks),
               "points": len(dev), "max_rel_deviation": max(dev) if dev else None,
               "median_rel_deviation": float(np.median(dev)) if dev else None,
               "max_abs_deviation_plotted": max(dev_y) if dev_y else None,
               "seconds": seconds, "skipped": skipped}
    return summary, markers


def figure_check(name: str, tasks: Sequence[FETask],
                 results: Sequence[dict[str, Any]]) -> tuple[dict[str, Any] | str, list[Marker]]:
    """:func:`check_points` of figure ``name`` out of every figure's tasks.

    Args:
        name: Figure name.
        tasks: Every figure's tasks.
        results: Their results, same order.

    Returns:
        ``(summary, markers)``; without tasks of this figure the summary is a sentence saying
        why (the phase diagram has no FE counterpart) and there are no markers.
    """
    mine = [(t, r) for t, r in zip(tasks, results, strict=True) if t.figure == name]
    if mine:
        return check_points([t for t, _ in mine], [r for _, r in mine])
    if name == "phase_diagram":
        return "none: no FE counterpart (the boundaries come from the spectrum)", []
    return "none: no curve points to check", []
