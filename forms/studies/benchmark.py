"""Measurements of ``workflows/benchmark.py``: speed against the paper's method, MPI, h-convergence.

Three independent measurements, each returning plain data (the scene writes and draws it):

- :func:`speed`: per branch point, the paper's own method (Newton continuation on the closed
  form ``S``, :func:`analytic.physics.baseline.continue_S`), the certified exact continuation
  (:func:`analytic.numerics.branches.follow_branch`) and the FE continuation
  (:func:`forms.solvers.certified.continue_fe`) on the cheapest P4 mesh meeting
  :data:`FE_TARGET_ERROR` on the grid, with their errors against the exact roots;
- :func:`mpi_scaling`: the throughput of two concurrent copies of a CPU-bound kernel against
  one copy, and the wall times of a sweep script under ``mpirun -n 1`` and ``-n 2``;
- :func:`convergence`: the relative error of the cross-section model at the check point
  (``k = 1``, branch ``0-``, docs/design.md section 4) for P1..P4 and the observed orders.

Times are wall-clock on a shared machine: ratios, not absolute values, are the result. Every
model lives on ``COMM_SELF``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence

import numpy as np

from mpi4py import MPI

from analytic.numerics.branches import follow_branch
from analytic.params import Params
from analytic.physics.baseline import continue_S
from forms.models.cross_section import CrossSectionModel
from forms.solvers.banded import BandedModel
from forms.solvers.certified import continue_fe

#: ``k = 1``, branch ``0-``, paper defaults: the 13-digit check value (docs/design.md section 4).
CHECK_VALUE = 0.2716852879456 - 6.5866951866228j
#: Cells per degree of the h-convergence table.
CONVERGENCE_CELLS: dict[int, tuple[int, ...]] = {1: (32, 64, 128, 256), 2: (6, 8, 12, 16, 24),
                                                 3: (3, 4, 6, 8, 12), 4: (2, 3, 4, 6)}
#: Largest relative error on the grid the FE continuation's mesh must meet.
FE_TARGET_ERROR = 1e-10
#: P4 meshes tried for the FE continuation, cheapest first.
FE_CELLS = (3, 4, 5, 6, 8, 10, 12, 16)
#: A CPU-bound kernel (dense eigenvalues) that prints its own run time.
KERNEL = ("import time, numpy as np\nt=time.perf_counter()\na=np.random.default_rng(0)"
          ".standard_normal((300,300))\nfor _ in range(60): np.linalg.eigvals(a)\n"
          "print(time.perf_counter()-t)")


def _fe_continuation(p: Params, k: np.ndarray, exact: dict, fe_cells: Sequence[int]
                     ) -> dict | None:
    """The cheapest P4 mesh of ``fe_cells`` whose FE continuation meets the target."""
    points = 2 * len(k)
    for cells in fe_cells:
        model = CrossSectionModel(MPI.COMM_SELF, p, degree=4, cells=cells, ratio=1.0)
        banded = BandedModel(model)
        t0 = time.perf_counter()
        vals, facts = {}, 0
        for s in (1, -1):
            vals[s], f = continue_fe(banded, k, exact[s].Lambda[0])
            facts += f
        t_fe = time.perf_counter() - t0
        model.destroy()
        err = max(float(np.max(np.abs(vals[s] - exact[s].Lambda) / np.abs(exact[s].Lambda)))
                  for s in (1, -1))
        if err <= FE_TARGET_ERROR:
            return {"degree": 4, "cells": cells, "s_per_point": t_fe / points,
                    "max_rel_error": err, "factorizations_per_point": facts / points}
    return None


def speed(k: np.ndarray, p: Params | None = None, fe_cells: Sequence[int] = FE_CELLS) -> dict:
    """Per-branch-point times and errors of the three methods on both partners of ``n = 0``.

    Args:
        k: Sorted wavenumbers.
        p: Parameters (default: the paper's).
        fe_cells: P4 meshes tried for the FE continuation, cheapest first.

    Returns:
        Keys ``k`` (first, last, count), ``branches``, ``baseline``, ``analytic_certified``,
        ``fe_continuation`` (``None``: no mesh of ``fe_cells`` met the target) and
        ``ratios`` (each method's time per point over the baseline's, with the targets).
    """
    p = p or Params()
    res = {"k": [float(k[0]), float(k[-1]), len(k)], "branches": ["0+", "0-"]}
    t0 = time.perf_counter()
    exact = {s: follow_branch(p, 0, s, k) for s in (1, -1)}
    t_an = time.perf_counter() - t0
    t0 = time.perf_counter()
    base = {s: continue_S(p, 0, s, k)[0] for s in (1, -1)}
    t_base = time.perf_counter() - t0
    points = 2 * len(k)
    res["baseline"] = {"s_per_point": t_base / points, "max_rel_error": max(
        float(np.nanmax(np.abs(base[s] - exact[s].Lambda) / np.abs(exact[s].Lambda)))
        for s in (1, -1))}
    res["analytic_certified"] = {"s_per_point": t_an / points,
                                 "all_ok": bool(all(exact[s].ok.all() for s in (1, -1)))}
    fe = _fe_continuation(p, k, exact, fe_cells)
    res["fe_continuation"] = fe
    b = res["baseline"]["s_per_point"]
    res["ratios"] = {"analytic_certified_over_baseline": res["analytic_certified"]
                     ["s_per_point"] / b, "target_analytic": 10.0,
                     "fe_over_baseline": fe["s_per_point"] / b if fe else None,
                     "target_fe": 20.0}
    return res


def _env() -> dict:
    """This process's environment without its OpenMPI/PMIx singleton state (for mpirun)."""
    return {key: v for key, v in os.environ.items()
            if not key.startswith(("OMPI_COMM", "OMPI_MCA_ess", "PMIX_", "OMPI_FILE", "OMPI_APP",
                                   "OMPI_UNIVERSE", "OMPI_FIRST", "OMPI_NUM_APP", "OMPI_ARGV",
                                   "OMPI_COMMAND"))}


def mpi_scaling(sweep_script: str, k_spec: str) -> dict:
    """Two-copy throughput of :data:`KERNEL`; 1- and 2-rank wall times of a sweep.

    The sweep (``sweep_script --k k_spec --quiet --out TMP`` under ``mpirun -n 1`` and ``-n
    2``) must write ``summary.json`` with ``timing_s`` (``wall``, ``post_processing_rank0``)
    and ``mpi.per_rank``, as ``workflows/sweep_k.py`` does.

    Returns:
        Keys ``kernel_one_copy_s``, ``kernel_two_copies_s``, ``two_copy_throughput``,
        ``sweep_k``, ``n1`` and ``n2`` (times, or ``error``: the end of the failed run's
        output) and, if both ran, ``sweep_speedup``, its fraction of the two-copy throughput,
        the post-processing share of the 2-rank wall time and the ``targets``.
    """
    env = _env()
    one = float(subprocess.run([sys.executable, "-c", KERNEL], capture_output=True, text=True,
                               env=env).stdout)
    t0 = time.perf_counter()
    procs = [subprocess.Popen([sys.executable, "-c", KERNEL], stdout=subprocess.PIPE,
                              text=True, env=env) for _ in range(2)]
    for pr in procs:
        pr.communicate()
    two = time.perf_counter() - t0
    res = {"kernel_one_copy_s": one, "kernel_two_copies_s": two,
           "two_copy_throughput": 2 * one / two, "sweep_k": k_spec}
    for n in (1, 2):
        with tempfile.TemporaryDirectory() as tmp:
            out = os.path.join(tmp, "o")
            cmd = ["mpirun", "-n", str(n), sys.executable, sweep_script, "--k", k_spec,
                   "--quiet", "--out", out]
            proc = subprocess.run(cmd, capture_output=True, text=True, env=env)
            if proc.returncode not in (0, 1):
                res[f"n{n}"] = {"error": (proc.stdout + proc.stderr)[-800:]}
                continue
            with open(os.path.join(out, "summary.json")) as fh:
                s = json.load(fh)
            res[f"n{n}"] = {"wall_s": s["timing_s"]["wall"],
                            "post_processing_s": s["timing_s"]["post_processing_rank0"],
                            "per_rank": s["mpi"]["per_rank"]}
    if "wall_s" in res.get("n1", {}) and "wall_s" in res.get("n2", {}):
        sp = res["n1"]["wall_s"] / res["n2"]["wall_s"]
        res["sweep_speedup"] = sp
        res["speedup_fraction_of_two_copy_throughput"] = sp / res["two_copy_throughput"]
        res["post_processing_share_2_ranks"] = (res["n2"]["post_processing_s"]
                                                / res["n2"]["wall_s"])
        res["targets"] = {"speedup_fraction": 0.9, "post_processing_share": 0.10}
    return res


def convergence(cells_by_degree: dict[int, tuple[int, ...]] | None = None,
                p: Params | None = None, reference: complex = CHECK_VALUE) -> list[dict]:
    """Relative error of the cross-section model at ``k = 1`` (Newton from ``reference``).

    Args:
        cells_by_degree: Uniform meshes per Lagrange degree (default
            :data:`CONVERGENCE_CELLS`).
        p: Parameters (default: the paper's, whose root is :data:`CHECK_VALUE`).
        reference: The exact eigenvalue (Newton's start and the reference of the error).

    Returns:
        One row per mesh: ``degree``, ``cells``, ``h = H / cells``, ``rel_error`` and the
        observed ``order`` against the previous mesh of the same degree (NaN for the first).
    """
    p = p or Params()
    rows = []
    for deg, cells_list in (cells_by_degree or CONVERGENCE_CELLS).items():
        prev = None
        for cells in cells_list:
            model = CrossSectionModel(MPI.COMM_SELF, p, degree=deg, cells=cells, ratio=1.0)
            lam = BandedModel(model).operator(1.0).newton(reference).value
            model.destroy()
            h = p.H / cells
            err = abs(lam - reference) / abs(reference)
            order = np.log(prev[1] / err) / np.log(prev[0] / h) if prev else float("nan")
            rows.append({"degree": deg, "cells": cells, "h": h, "rel_error": err,
                         "order": order})
            prev = (h, err)
    return rows
