"""The certified dispersion sweep over many ``k``, shared over MPI ranks (``workflows/sweep_k.py``).

docs/design.md section 8. The steps of a sweep, each a call of the scene:

1. :func:`pending_k`: the per-``k`` result files ``DIR/raw/k#####.json`` (one per requested
   ``k``, written as soon as it is finished) tell which ``k`` are still to compute, so that a
   resumed sweep continues where it stopped;
2. :func:`family_plan` and :func:`follow_families` (only when the exact roots are checked,
   ``--check-exact yes``): every root family that can reach the region is followed in ``k`` by
   exact continuation; the families are shared over the ranks and gathered on all of them;
3. :func:`k_costs` and :func:`solve_k_values`: each rank solves its share of the pending ``k``
   with one :class:`forms.solvers.certified.CertifiedSolver` (its models live on ``COMM_SELF``;
   FE first by default) and writes each :class:`forms.solvers.certified.KResult` to its raw
   file;
4. :func:`load_results` and :func:`summarise` (rank 0): the rows of every ``k`` and the summary:
   certificate (counts closed, rows ok or flagged), accuracy, families, the most unstable
   eigenvalue with its certificate, per-``k`` counts and costs.

Sharing work over the ranks is left to the caller: the functions take this rank's indices
(for instance a cost-balanced split of :func:`k_costs`), so no rule for it lives here.
"""

from __future__ import annotations

import glob
import json
import math
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from analytic.numerics.branches import BranchResult
from analytic.numerics.spectrum import FamilyPlan, Region, follow_family, plan_families, plan_items
from analytic.params import Params
from forms.solvers.certified import CertifiedSolver, KResult

#: What ``summary.json`` says the certificate of the most unstable eigenvalue states, per mode
#: ``(solver, check_exact)``.
CERTIFICATE_STATEMENTS = {
    True: ("largest Re Lambda over every eigenvalue in the region R at every swept k; at each k "
           "the FE eigenvalues found in R are as many as, and distinct, the FE argument-principle"
           " count of det T_h in R, which equals the exact argument-principle count, and every "
           "FE value is matched to a distinct exact root"),
    False: ("largest Re Lambda over every eigenvalue in the region R at every swept k; at each k "
            "the FE eigenvalues found in R are as many as, and distinct, the FE "
            "argument-principle count of det T_h in R (no exact reference consulted)"),
}
#: How the sweep's values are obtained (``summary.json``, key ``method``), per ``--solver``.
METHODS = {
    "moments": ("FE first: argument-principle count of det T_h in R and contour-integral moments"
                " (Beyn) on the same contour points, Newton-polished; no exact root as input"),
    "newton": ("exact continuation labels; FE Newton on the discrete NEP from the exact roots; "
               "FE and exact argument-principle counts in R"),
}
#: Flagged rows listed in the summary at most (all of them are in the CSV).
MAX_FLAGGED_LISTED = 200


def raw_file(folder: str, i: int) -> str:
    """Path of the result file of the ``i``-th requested ``k`` in the run folder ``folder``."""
    return os.path.join(folder, "raw", f"k{i:05d}.json")


def write_json(path: str, data: dict) -> None:
    """Write ``data`` to ``path`` atomically (a temporary file beside it, then a rename)."""
    tmp = os.path.join(os.path.dirname(path), "." + os.path.basename(path) + ".tmp")
    with open(tmp, "w") as fh:
        json.dump(data, fh, indent=1)
    os.replace(tmp, path)


def pending_k(comm: object, folder: str, count: int, resumed: bool) -> list[int]:
    """Indices of the requested ``k`` (``0 .. count - 1``) that have no result file yet.

    Rank 0 creates ``folder/raw`` and, unless the run is ``resumed``, deletes the result files
    of an earlier run there; the list is rank 0's, the same on every rank (collective).

    Args:
        comm: The communicator of the sweep.
        folder: The run folder.
        count: Number of requested ``k``.
        resumed: Keep the existing result files (continue a sweep).
    """
    if comm.rank == 0:
        os.makedirs(os.path.join(folder, "raw"), exist_ok=True)
        if not resumed:
            for name in glob.glob(os.path.join(folder, "raw", "k*.json")):
                os.remove(name)
    comm.Barrier()
    todo = [i for i in range(count) if not os.path.exists(raw_file(folder, i))]
    return comm.bcast(todo)


def family_plan(comm: object, params: Params, region: Region, k_max: float
                ) -> tuple[FamilyPlan, list[tuple]]:
    """The families that can reach the region up to ``k_max``, planned on rank 0 (collective).

    Returns:
        ``(plan, items)``: :func:`analytic.numerics.spectrum.plan_families` and its items
        (:func:`analytic.numerics.spectrum.plan_items`), the same on every rank.
    """
    plan = comm.bcast(plan_families(params, region, k_max) if comm.rank == 0 else None)
    return plan, plan_items(plan)


def follow_families(comm: object, params: Params, region: Region, plan: FamilyPlan,
                    items: list[tuple], k: np.ndarray, mine: Sequence[int]
                    ) -> list[BranchResult]:
    """Every item of the plan followed to every ``k``; each rank follows ``mine`` (collective).

    Args:
        comm: The communicator of the sweep.
        params: Parameters.
        region: The region ``R``.
        plan: The plan of :func:`family_plan`.
        items: Its items.
        k: The requested wavenumbers, sorted.
        mine: This rank's indices into ``items``; the ranks' shares together cover them once.

    Returns:
        The followed families in the order of ``items``, on every rank.
    """
    done = {i: follow_family(params, plan, items[i], k, region) for i in mine}
    merged: dict[int, BranchResult] = {}
    for part in comm.allgather(done):
        merged.update(part)
    return [merged[i] for i in range(len(items))]


def k_costs(params: Params, region: Region, k: np.ndarray, indices: Sequence[int]
            ) -> list[float]:
    """Relative cost of solving at ``k[i]`` for each of ``indices``.

    The cost of a ``k`` goes with the number of roots in the region, i.e. with the region's
    height ``|Im Lambda| <= W(k)``.
    """
    return [region.im_max(params, float(k[i])) for i in indices]


@dataclass
class ShareRun:
    """What one rank spent on its share of the ``k`` values (:func:`solve_k_values`).

    Attributes:
        seconds: Wall time of the share, solver set-up included.
        k_values: Number of ``k`` solved.
        unknowns: Unknowns of the degree-``p`` model.
        substrate_cells: Cells of the substrate mesh (0: rigid substrate).
    """

    seconds: float
    k_values: int
    unknowns: int
    substrate_cells: int


def solve_k_values(params: Params, region: Region, discretisation: tuple[int, int, float],
                   rtol: float, k: np.ndarray, mine: Sequence[int], fams: list[BranchResult],
                   folder: str, progress: Callable[[], object] | None = None, *,
                   check_exact: bool = True, solver: str = "moments") -> ShareRun:
    """The certified spectrum at ``k[i]`` for each ``i`` of ``mine``, each written to its file.

    One :class:`forms.solvers.certified.CertifiedSolver` (on ``COMM_SELF``, for ``k`` up to
    ``k[-1]``) solves every ``k`` of the share; each :class:`forms.solvers.certified.KResult` goes
    to
    :func:`raw_file` as soon as it is finished. Not collective.

    Args:
        params: Parameters.
        region: The region ``R``.
        discretisation: ``(degree, cells, grading ratio)`` of the FE model.
        rtol: Relative accuracy a row must reach to be ``ok``.
        k: Every requested wavenumber, sorted.
        mine: Indices into ``k`` to solve here.
        fams: The followed families (:func:`follow_families`).
        folder: The run folder (``folder/raw`` exists).
        progress: Called after every finished ``k`` (e.g. a progress bar's update).
        check_exact: Match the FE values to the exact roots (``fams``; else ``fams`` is unused).
        solver: ``"moments"`` (FE first) or ``"newton"`` (exact-seeded).
    """
    t0 = time.perf_counter()
    degree, cells, ratio = discretisation
    cs = CertifiedSolver(params, region, degree, cells, ratio, float(k[-1]), rtol,
                         check_exact=check_exact, solver=solver)
    try:
        for i in mine:
            write_json(raw_file(folder, i), cs.solve(float(k[i]), fams).as_dict())
            if progress is not None:
                progress()
        unknowns, cells2 = cs.unknowns, cs.cells2
    finally:
        cs.destroy()
    return ShareRun(time.perf_counter() - t0, len(mine), unknowns, cells2)


def load_results(folder: str, count: int) -> list[KResult]:
    """The results of the ``count`` requested ``k``, read back from their files (in order)."""
    results = []
    for i in range(count):
        with open(raw_file(folder, i)) as fh:
            results.append(KResult.from_dict(json.load(fh)))
    return results


def describe_discretisation(params: Params, discretisation: tuple[int, int, float],
                            share: ShareRun, rtol: float, solver: str = "newton",
                            check_exact: bool = True) -> dict:
    """``summary.json`` keys ``discretisation`` and ``method``: the model, mesh and estimate."""
    degree, cells, ratio = discretisation
    model = "cross-section (1D in y), polynomial form"
    if params.two_body:
        model += ", layered (two bodies)"
    return {"discretisation": {"model": model, "degree": degree, "cells": cells,
                               "grading_ratio": ratio, "substrate_cells": share.substrate_cells,
                               "unknowns": share.unknowns, "rtol": rtol,
                               "error_estimate": f"P{degree + 1} on the same mesh, one Newton "
                               f"solve from the P{degree} value"},
            "method": METHODS[solver], "solver": solver, "check_exact": check_exact}


def most_unstable(rows: list[dict], results: list[KResult], k: np.ndarray,
                  open_k: list[dict], check_exact: bool = True) -> dict | None:
    """The row with the largest ``Re Lambda`` and its certificate (``None``: no rows).

    Args:
        rows: Every row of the sweep.
        results: The per-``k`` results the rows come from.
        k: The requested wavenumbers, sorted.
        open_k: The ``k`` whose count did not close (see :func:`summarise`).
        check_exact: The exact roots were consulted (the certificate's statement).
    """
    if not rows:
        return None
    best = max(rows, key=lambda r: r["re_lambda"])
    res_best = next((res for res in results if res.k == best["k"]), None)
    return {"k": best["k"], "re_lambda": best["re_lambda"], "im_lambda": best["im_lambda"],
            "branch": best["label"], "status": best["status"],
            "rel_error": best["rel_error"], "error_estimate": best["error_estimate"],
            "at_edge_of_k_range": best["k"] in (float(k[0]), float(k[-1])),
            "certificate": {
                "statement": CERTIFICATE_STATEMENTS[check_exact],
                "carries": best.get("certificate", ""),
                "all_k_closed": not open_k,
                "region_at_k": list(res_best.box) if res_best else None,
                "count_at_k": (res_best.n_exact if check_exact else res_best.n_fe)
                if res_best else None,
                "certified": bool(best["status"] == "ok" and not open_k)}}


def summarise(params: Params, region: Region, k: np.ndarray, results: list[KResult],
              fams: list[BranchResult], check_exact: bool = True) -> dict:
    """The sweep's summary: region, certificate, accuracy, families, most unstable, per ``k``.

    Pure data (no files). The keys, in order: ``region``, ``certificate`` (``k`` values closed
    or not, rows ok or flagged), ``accuracy`` (largest error against the exact roots and
    largest error estimate), ``families`` (count, notes), ``most_unstable``
    (:func:`most_unstable`), ``per_k`` (counts, box, seconds, factorisations, and the
    certificate each row carries: ``fe`` and/or ``exact``).
    """
    rows = [r for res in results for r in res.rows]
    flagged = [r for r in rows if r["status"] != "ok"]
    open_k = [{"k": res.k, "n_fe": res.n_fe, "n_exact": res.n_exact, "note": res.note}
              for res in results if not res.closed]
    errs = [r["rel_error"] for r in rows if math.isfinite(r["rel_error"])]
    ests = [r["error_estimate"] for r in rows if math.isfinite(r["error_estimate"])]
    return {
        "region": region.as_dict(params),
        "certificate": {"k_values": len(results), "k_closed": len(results) - len(open_k),
                        "k_not_closed": open_k, "rows": len(rows),
                        "rows_ok": len(rows) - len(flagged),
                        "rows_flagged": flagged[:MAX_FLAGGED_LISTED]},
        "accuracy": {"max_rel_error_vs_exact": max(errs) if errs else None,
                     "max_error_estimate": max(ests) if ests else None},
        "families": {"count": len(fams), "notes": {f.label: f.note for f in fams if f.note}},
        "most_unstable": most_unstable(rows, results, k, open_k, check_exact),
        "per_k": [{"k": res.k, "n_fe": res.n_fe, "n_exact": res.n_exact, "closed": res.closed,
                   "box": list(res.box), "seconds": res.seconds,
                   "factorizations": res.factorizations,
                   "certificate": [r.get("certificate", "") for r in res.rows]}
                  for res in results],
    }
