"""Accuracy and speed of the FE sweep, measured (not asserted): prints and saves a report.

    python workflows/benchmark.py [--out out/benchmark] [--mpi-k 400] [--skip-mpi]

1. Accuracy: the default sweep of ``sweep_k.py`` (paper defaults, default discretisation): the
   relative error of every tracked FE eigenvalue against the exact root
   (``analytic.branches.polish_root`` started from the FE value).
2. Cost: per-k time of the FE solves (all branches) against the per-k time of the analytic
   continuation (``analytic.branches.follow_branch``) on the same k grid, side by side in this
   run (one rank).
3. MPI: wall time of ``sweep_k.py`` on ``--mpi-k`` k values with ``mpirun -n 1`` and ``-n 2``
   (subprocesses; the sweep's own ``wall_time_s`` and the whole process).
4. Convergence in h for P1..P4 at the check point of docs/design.md section 4 (k = 1, branch
   0-): table, CSV, PNG.

Writes ``benchmark.json``, ``convergence.csv``, ``convergence.png`` in ``--out``.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile
import time

import _cli
import numpy as np

from mpi4py import MPI

from analytic.branches import follow_branch, polish_root
from analytic.params import Params
from forms.cross_section import CrossSectionModel
from forms.solvers import PolynomialSolver
from forms.tracking import branches, track_branch, waveguide_lambda

HERE = os.path.dirname(os.path.abspath(__file__))
CHECK_VALUE = 0.2716852879456 - 6.5866951866228j  # docs/design.md section 4
#: Options prefixes of the SLEPc objects ("": the cross-section solves use the default prefix).
PETSC_PREFIXES = ("",)
OUTPUTS = ("benchmark.json", "accuracy.csv", "convergence.csv", "convergence.png")
CONVERGENCE_CELLS = {1: (32, 64, 128, 256), 2: (6, 8, 12, 16, 24), 3: (3, 4, 6, 8, 12),
                     4: (2, 3, 4, 6)}


def exact_reference(p: Params, k: float, guess: complex) -> tuple[complex, str]:
    """Exact root near ``guess`` (``analytic.branches.polish_root``), else the check value."""
    root = polish_root(p, k, guess)
    if root.converged:
        return complex(root.value), "analytic.branches.polish_root"
    return CHECK_VALUE, "docs/design.md check value (13 digits)"


def accuracy_and_cost(comm: MPI.Comm, out: str) -> dict:
    """Default sweep: FE errors vs exact, FE per-k cost vs analytic continuation per-k cost."""
    import sweep_k

    p = Params()
    k = _cli.parse_k(sweep_k.DEFAULT_K)
    nb = 3
    blist = branches(nb)
    model = CrossSectionModel(comm, p, degree=3, k_max=float(k.max()), n_max=nb - 1)
    solver = PolynomialSolver(comm, nev=4)
    # warm-up (first factorisation, JIT): not counted
    sweep_k.solve_one_k(model, solver, blist, p, float(k[0]), 4)
    t0 = time.perf_counter()
    data = [sweep_k.solve_one_k(model, solver, blist, p, float(kk), 4) for kk in k]
    t_fe = (time.perf_counter() - t0) / len(k)
    cells = model.cells
    solver.destroy()
    model.destroy()

    result = {"k": sweep_k.DEFAULT_K, "branches": [b.label for b in blist], "degree": 3,
              "cells": cells, "fe_per_k_s": t_fe}
    errors = {}
    for j, b in enumerate(blist):
        vals = [d["values"][d["owner"] == j] for d in data]
        vecs = [d["vectors"][d["owner"] == j] for d in data]
        tr = track_branch(vals, vecs, waveguide_lambda(p, b, float(k[0])))
        errs = []
        for m, c in enumerate(tr.choice):
            if c < 0:
                errs.append(np.nan)
                continue
            lam = vals[m][c]
            root = polish_root(p, float(k[m]), complex(lam))
            errs.append(abs(root.value - lam) / abs(root.value) if root.converged else np.nan)
        errors[b.label] = errs
    t0 = time.perf_counter()
    for b in blist:
        follow_branch(p, b.n, b.sign, k)
    t_an = (time.perf_counter() - t0) / len(k)
    allerr = np.array([e for v in errors.values() for e in v], dtype=float)
    result |= {
        "analytic_per_k_s": t_an,
        "fe_over_analytic": t_fe / t_an,
        "max_relative_error": float(np.nanmax(allerr)),
        "unmatched_points": int(np.isnan(allerr).sum()),
        "max_relative_error_per_branch": {lab: float(np.nanmax(v)) for lab, v in errors.items()},
    }
    with open(os.path.join(out, "accuracy.csv"), "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["k", *errors.keys()])
        for m, kk in enumerate(k):
            w.writerow([repr(float(kk)), *[repr(float(errors[lab][m])) for lab in errors]])
    return result


def mpi_speedup(n_k: int) -> dict:
    """Wall time of sweep_k.py with mpirun -n 1 and -n 2 on n_k k values."""
    res = {"k": f"0.05:6:{n_k}", "branches": 3}
    for n in (1, 2):
        with tempfile.TemporaryDirectory() as tmp:
            cmd = ["mpirun", "-n", str(n), sys.executable, os.path.join(HERE, "sweep_k.py"),
                   "--k", res["k"], "--quiet", "--no-plot", "--out", tmp]
            # this process is an MPI singleton: do not leak its OpenMPI/PMIx state to mpirun
            env = {key: v for key, v in os.environ.items()
                   if not key.startswith(("OMPI_COMM", "OMPI_MCA_ess", "PMIX_", "OMPI_FILE",
                                          "OMPI_APP", "OMPI_UNIVERSE", "OMPI_FIRST",
                                          "OMPI_NUM_APP", "OMPI_ARGV", "OMPI_COMMAND"))}
            t0 = time.perf_counter()
            proc = subprocess.run(cmd, capture_output=True, text=True, env=env)
            total = time.perf_counter() - t0
            if proc.returncode != 0:
                res[f"n{n}"] = {"error": (proc.stdout + proc.stderr)[-800:]}
                continue
            with open(os.path.join(tmp, "summary.json")) as fh:
                s = json.load(fh)
            res[f"n{n}"] = {"sweep_wall_s": s["wall_time_s"], "process_wall_s": total,
                            "cpu_time_s_per_rank": s["cpu_time_s_per_rank"]}
    res["load_average_after"] = os.getloadavg()
    if "sweep_wall_s" in res.get("n1", {}) and "sweep_wall_s" in res.get("n2", {}):
        res["speedup_sweep"] = res["n1"]["sweep_wall_s"] / res["n2"]["sweep_wall_s"]
        res["speedup_process"] = res["n1"]["process_wall_s"] / res["n2"]["process_wall_s"]
        # load-independent: serial CPU time over the busiest rank's CPU time
        res["speedup_cpu"] = (res["n1"]["cpu_time_s_per_rank"][0]
                              / max(res["n2"]["cpu_time_s_per_rank"]))
    return res


def convergence(comm: MPI.Comm, out: str) -> dict:
    """Relative error at the check point for P1..P4 on uniform meshes; observed orders."""
    p = Params()
    ref, source = exact_reference(p, 1.0, CHECK_VALUE)
    rows = []
    for deg, cells_list in CONVERGENCE_CELLS.items():
        prev = None
        for cells in cells_list:
            model = CrossSectionModel(comm, p, degree=deg, cells=cells, ratio=1.0)
            solver = PolynomialSolver(comm, nev=1)
            r = solver.solve(model.operator(1.0), ref)
            lam = r.pairs[0].value
            r.destroy()
            solver.destroy()
            model.destroy()
            h = p.H / cells
            err = abs(lam - ref) / abs(ref)
            order = np.log(prev[1] / err) / np.log(prev[0] / h) if prev else float("nan")
            rows.append({"degree": deg, "cells": cells, "h": h, "rel_error": err,
                         "order": order})
            prev = (h, err)
    with open(os.path.join(out, "convergence.csv"), "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4.5))
    for deg in CONVERGENCE_CELLS:
        sel = [r for r in rows if r["degree"] == deg]
        h = np.array([r["h"] for r in sel])
        e = np.array([r["rel_error"] for r in sel])
        line, = ax.loglog(h, e, "o-", label=f"P{deg}")
        ax.loglog(h, e[-1] * (h / h[-1]) ** (2 * deg), ":", color=line.get_color(), lw=0.8)
    ax.set_xlabel("h = H / cells")
    ax.set_ylabel(r"relative error of $\Lambda$")
    ax.set_title(f"check point k = 1, branch 0- (dotted: h^(2p)); reference: {source}",
                 fontsize=8)
    ax.legend()
    ax.grid(True, which="both", lw=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "convergence.png"), dpi=130,
                metadata=_cli.png_metadata({"cells": CONVERGENCE_CELLS, "reference": source},
                                           "h-convergence of the cross-section model"))
    plt.close(fig)
    return {"reference": source, "rows": rows}


def build_parser() -> argparse.ArgumentParser:
    """Command-line options."""
    ap = _cli.make_parser(__doc__, PETSC_PREFIXES)
    ap.add_argument("--out", default=os.path.join("out", "benchmark"), help="output folder")
    ap.add_argument("--mpi-k", type=int, default=400, help="k values of the MPI timing")
    ap.add_argument("--skip-mpi", action="store_true", help="skip the MPI timing")
    return ap


def main(comm: MPI.Comm | None = None, argv: list[str] | None = None) -> int:
    """Run the benchmark (one rank; it launches mpirun itself)."""
    args, comm = _cli.start(build_parser(), argv, comm)
    _cli.positive_int("--mpi-k", args.mpi_k, 2)
    if comm.size != 1:
        raise _cli.ParameterError("run benchmark.py on one rank (it launches mpirun itself)")
    parameters = {"mpi_k": args.mpi_k, "mpi": not args.skip_mpi}
    with _cli.RunFolder(comm, args.out, "benchmark", parameters, outputs=OUTPUTS):
        return _run(comm, args)


def _run(comm: MPI.Comm, args: argparse.Namespace) -> int:
    report = {"machine": {"cpus": os.cpu_count(), "load_average_at_start": os.getloadavg()},
              "command": _cli.command(), "versions": _cli.versions()}
    report["accuracy_and_cost"] = accuracy_and_cost(comm, args.out)
    report["convergence"] = conv = convergence(comm, args.out)
    if not args.skip_mpi:
        report["mpi"] = mpi_speedup(args.mpi_k)
    with open(os.path.join(args.out, "benchmark.json"), "w") as fh:
        json.dump(report, fh, indent=1)
    ac = report["accuracy_and_cost"]
    print(json.dumps({key: v for key, v in ac.items() if key != "k"}, indent=1))
    print(f"convergence (reference: {conv['reference']})")
    print(f"{'P':>2} {'cells':>6} {'h':>10} {'rel. error':>11} {'order':>6}")
    for r in conv["rows"]:
        print(f"{r['degree']:>2} {r['cells']:>6} {r['h']:>10.4g} {r['rel_error']:>11.3e} "
              f"{r['order']:>6.2f}")
    if "mpi" in report:
        print(json.dumps(report["mpi"], indent=1))
    return 0


if __name__ == "__main__":
    _cli.run(main)
