"""Speed of the certified sweep against the paper's own method, measured side by side.

    python workflows/benchmark.py [--k 0.05:6:400] [--out out/benchmark] [--skip-mpi]

On one k grid (paper defaults, both partners of n = 0), in this one run:

1. baseline: the paper's method, numpy Newton continuation on the closed form S(Lambda, k, H)
   (:mod:`analytic.baseline`), one root per branch;
2. ``analytic`` certified continuation (:func:`analytic.branches.follow_branch`: adaptive steps,
   a root count at every step);
3. FE continuation (:func:`forms.certified.continue_fe`: Newton on the discrete nonlinear
   eigenproblem, previous eigenpair + predictor) on the cheapest P4 mesh whose largest error on
   the grid is <= 1e-10 (measured here against the exact roots);
4. MPI: the throughput of two concurrent copies of a CPU-bound kernel against one copy, and
   the 2-rank speed-up of ``sweep_k.py`` (default grid) as a fraction of it; the share of the
   sweep's wall time spent in rank 0's post-processing.
5. h-convergence of P1..P4 at the check point (k = 1, branch 0-): table, CSV, PNG.

Numbers are reported (``benchmark.json``), not asserted. Ratios, not absolute times, are the
result: this machine is shared.
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

from analytic.baseline import continue_S
from analytic.branches import follow_branch
from analytic.params import Params
from forms.banded import BandedModel
from forms.certified import continue_fe
from forms.cross_section import CrossSectionModel

HERE = os.path.dirname(os.path.abspath(__file__))
CHECK_VALUE = 0.2716852879456 - 6.5866951866228j  # docs/design.md section 4
PETSC_PREFIXES: tuple[str, ...] = ()
OUTPUTS = ("benchmark.json", "convergence.csv", "convergence.png", "run.json", "run.lock")
CONVERGENCE_CELLS = {1: (32, 64, 128, 256), 2: (6, 8, 12, 16, 24), 3: (3, 4, 6, 8, 12),
                     4: (2, 3, 4, 6)}
KERNEL = ("import time, numpy as np\nt=time.perf_counter()\na=np.random.default_rng(0)"
          ".standard_normal((300,300))\nfor _ in range(60): np.linalg.eigvals(a)\n"
          "print(time.perf_counter()-t)")


def speed(k: np.ndarray) -> dict:
    """Sections 1-3: per-branch-point times and errors, side by side."""
    p = Params()
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
    fe = None
    for cells in (3, 4, 5, 6, 8, 10, 12, 16):
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
        if err <= 1e-10:
            fe = {"degree": 4, "cells": cells, "s_per_point": t_fe / points,
                  "max_rel_error": err, "factorizations_per_point": facts / points}
            break
    res["fe_continuation"] = fe
    b = res["baseline"]["s_per_point"]
    res["ratios"] = {"analytic_certified_over_baseline": res["analytic_certified"]
                     ["s_per_point"] / b, "target_analytic": 10.0,
                     "fe_over_baseline": fe["s_per_point"] / b if fe else None,
                     "target_fe": 20.0}
    return res


def _env() -> dict:
    # this process is an MPI singleton: do not leak its OpenMPI/PMIx state to mpirun
    return {key: v for key, v in os.environ.items()
            if not key.startswith(("OMPI_COMM", "OMPI_MCA_ess", "PMIX_", "OMPI_FILE", "OMPI_APP",
                                   "OMPI_UNIVERSE", "OMPI_FIRST", "OMPI_NUM_APP", "OMPI_ARGV",
                                   "OMPI_COMMAND"))}


def mpi(k_spec: str) -> dict:
    """Section 4: two-copy throughput, sweep speed-up, post-processing share."""
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
            cmd = ["mpirun", "-n", str(n), sys.executable, os.path.join(HERE, "sweep_k.py"),
                   "--k", k_spec, "--quiet", "--out", out]
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


def convergence(out: str) -> dict:
    """Section 5: relative error at the check point for P1..P4; observed orders."""
    p = Params()
    rows = []
    for deg, cells_list in CONVERGENCE_CELLS.items():
        prev = None
        for cells in cells_list:
            model = CrossSectionModel(MPI.COMM_SELF, p, degree=deg, cells=cells, ratio=1.0)
            lam = BandedModel(model).operator(1.0).newton(CHECK_VALUE).value
            model.destroy()
            h = p.H / cells
            err = abs(lam - CHECK_VALUE) / abs(CHECK_VALUE)
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
    ax.set_title("check point k = 1, branch 0- (dotted: h^(2p)); reference: 13-digit value",
                 fontsize=8)
    ax.legend()
    ax.grid(True, which="both", lw=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "convergence.png"), dpi=130,
                metadata=_cli.png_metadata({"cells": CONVERGENCE_CELLS},
                                           "h-convergence of the cross-section model"))
    plt.close(fig)
    return {"reference": "docs/design.md check value (13 digits)", "rows": rows}


def build_parser() -> argparse.ArgumentParser:
    """Command-line options."""
    ap = _cli.make_parser(__doc__, PETSC_PREFIXES)
    ap.add_argument("--out", default=os.path.join("out", "benchmark"), help="output folder")
    ap.add_argument("--k", default="0.05:6:400", help="k grid of the speed comparison")
    ap.add_argument("--sweep-k", default="0.05:6:120", help="k grid of the MPI timing")
    ap.add_argument("--skip-mpi", action="store_true", help="skip the mpirun timings")
    return ap


def main(comm: object = None, argv: list[str] | None = None) -> int:
    """Run the benchmark (one rank)."""
    args, comm = _cli.start(build_parser(), argv, comm)
    k = np.unique(_cli.parse_k(args.k))
    _cli.parse_k(args.sweep_k, name="--sweep-k")
    if comm.size != 1:
        raise _cli.ParameterError("run the benchmark on one rank (it starts mpirun itself)")
    with _cli.RunFolder(comm, args.out, "benchmark", {"k": args.k, "sweep_k": args.sweep_k},
                        outputs=OUTPUTS) as run:
        report = {"machine": {"cpus": os.cpu_count(), "load_average_at_start": os.getloadavg()},
                  "speed": speed(k)}
        if not args.skip_mpi:
            report["mpi"] = mpi(args.sweep_k)
        report["convergence"] = convergence(run.path)
        report["versions"] = _cli.versions()
        report["command"] = _cli.command()
        with open(run.file("benchmark.json"), "w") as fh:
            json.dump(report, fh, indent=1)
    r = report["speed"]["ratios"]
    print(f"per branch point: analytic certified / baseline = "
          f"{r['analytic_certified_over_baseline']:.2f} (target <= 10), FE / baseline = "
          f"{r['fe_over_baseline']:.2f} (target <= 20)")
    if "mpi" in report and "sweep_speedup" in report["mpi"]:
        m = report["mpi"]
        print(f"MPI: sweep speed-up {m['sweep_speedup']:.2f} = "
              f"{m['speedup_fraction_of_two_copy_throughput']:.2f} of the two-copy throughput "
              f"{m['two_copy_throughput']:.2f} (target >= 0.9); post-processing "
              f"{100 * m['post_processing_share_2_ranks']:.1f} % of the 2-rank wall time")
    return 0


if __name__ == "__main__":
    _cli.run(main)
