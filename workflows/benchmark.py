"""Speed of the certified sweep against the paper's own method, measured side by side.

    python workflows/benchmark.py [--k 0.05:6:400] [--out out/benchmark] [--skip-mpi]

On one k grid (paper defaults, both partners of n = 0), in this one run:

1. baseline: the paper's method, numpy Newton continuation on the closed form S(Lambda, k, H)
   (:mod:`analytic.physics.baseline`), one root per branch;
2. ``analytic`` certified continuation (:func:`analytic.numerics.branches.follow_branch`: adaptive
steps,
   a root count at every step);
3. FE continuation (:func:`forms.solvers.certified.continue_fe`: Newton on the discrete nonlinear
   eigenproblem, previous eigenpair + predictor) on the cheapest P4 mesh whose largest error on
   the grid is <= 1e-10 (measured here against the exact roots);
4. MPI: the throughput of two concurrent copies of a CPU-bound kernel against one copy, and
   the 2-rank speed-up of ``sweep_k.py`` (default grid) as a fraction of it; the share of the
   sweep's wall time spent in rank 0's post-processing.
5. h-convergence of P1..P4 at the check point (k = 1, branch 0-): table, CSV, PNG.
6. the certified sweep (``sweep_k.py``) in its three modes side by side: FE first without the
   exact check (``--check-exact no``), FE first with it (the default), the exact-seeded path
   (``--solver newton``), on the default grid (both tops, 2 ranks) and at k = 50, 51 (1 rank)
   (``--sweeps``: which cases, ``none`` to skip).

Every target (issues 15 and 17: default sweep <= 2 s on 2 ranks, k = 50, 51 <= 3 s on one rank,
FE first <= 2x the exact-seeded path, cost per certified eigenvalue <= 100x Newton on S per
branch point; the older ones above) is listed with its measured value in ``benchmark.json``
(``targets``) and printed; the exit code is 1 when one is missed. Ratios, not absolute
times, are the result: this machine is shared.
"""

from __future__ import annotations

import argparse
import csv
import os

import _cli
import numpy as np

from forms.studies import benchmark as bench

HERE = os.path.dirname(os.path.abspath(__file__))
PETSC_PREFIXES: tuple[str, ...] = ()
OUTPUTS = ("benchmark.json", "convergence.csv", "convergence.png", "run.json", "run.lock")


def convergence(out: str) -> dict:
    """Section 5: relative error at the check point for P1..P4; observed orders (CSV, PNG)."""
    rows = bench.convergence(bench.CONVERGENCE_CELLS)
    with _cli.atomic_open(os.path.join(out, "convergence.csv"), "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    plot_convergence(os.path.join(out, "convergence.png"), rows, bench.CONVERGENCE_CELLS)
    return {"reference": "docs/design.md check value (13 digits)", "rows": rows}


def plot_convergence(path: str, rows: list[dict], cells: dict) -> None:
    """convergence.png: relative error against h per degree, with the h^(2p) slopes."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4.5))
    for deg in cells:
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
    _cli.save_figure(fig, path, dpi=130, metadata=_cli.png_metadata(
        {"cells": cells}, "h-convergence of the cross-section model"))
    plt.close(fig)


def build_parser() -> argparse.ArgumentParser:
    """Command-line options."""
    ap = _cli.make_parser(__doc__, PETSC_PREFIXES)
    ap.add_argument("--out", default=os.path.join("out", "benchmark"), help="output folder")
    ap.add_argument("--k", default="0.05:6:400", help="k grid of the speed comparison")
    ap.add_argument("--sweep-k", default="0.05:6:120", help="k grid of the MPI timing")
    ap.add_argument("--skip-mpi", action="store_true", help="skip the mpirun timings")
    ap.add_argument("--sweeps", default=",".join(bench.SWEEP_CASES),
                    help="certified sweep cases to time (comma list of "
                    + ", ".join(bench.SWEEP_CASES) + "), or none")
    return ap


def main(comm: object = None, argv: list[str] | None = None) -> int:
    """Run the benchmark (one rank)."""
    args, comm = _cli.start(build_parser(), argv, comm)
    k = np.unique(_cli.parse_k(args.k))
    sweep_k = _cli.parse_k(args.sweep_k, name="--sweep-k")
    cases = [] if args.sweeps == "none" else args.sweeps.split(",")
    if any(c not in bench.SWEEP_CASES for c in cases):
        raise _cli.ParameterError(f"--sweeps = {args.sweeps} is outside its allowed values: "
                                  "none or a comma list of " + ", ".join(bench.SWEEP_CASES))
    if comm.size != 1:
        raise _cli.ParameterError("run the benchmark on one rank (it starts mpirun itself)")
    with _cli.RunFolder(comm, args.out, "benchmark", {"k": args.k, "sweep_k": args.sweep_k},
                        outputs=OUTPUTS) as run:
        _cli.say_plan(comm, f"{k.size} k in the speed comparison, {len(cases)} sweep case(s) in "
                      f"{len(bench.SWEEP_MODES)} modes" + ("" if args.skip_mpi else ", MPI timing"),
                      bench.estimate_seconds(k.size, sweep_k, {c: bench.SWEEP_CASES[c]
                                                               for c in cases}, not args.skip_mpi))
        report = {"machine": {"cpus": os.cpu_count(), "load_average_at_start": os.getloadavg()},
                  "speed": bench.speed(k)}
        if not args.skip_mpi:
            report["mpi"] = bench.mpi_scaling(os.path.join(HERE, "sweep_k.py"), args.sweep_k)
        report["convergence"] = convergence(run.path)
        if cases:
            report["sweeps"] = bench.certified_sweeps(os.path.join(HERE, "sweep_k.py"),
                                                      {c: bench.SWEEP_CASES[c] for c in cases})
        report["targets"] = bench.all_targets(report)
        report["versions"] = _cli.versions()
        report["command"] = _cli.command()
        with _cli.atomic_open(run.file("benchmark.json"), "w") as fh:
            _cli.json_dump(report, fh, indent=1)
    r = report["speed"]["ratios"]
    print(f"per branch point: analytic certified / baseline = "
          f"{r['analytic_certified_over_baseline']:.2f} (target <= 10), FE / baseline = "
          f"{r['fe_over_baseline']:.2f} (target <= 20)")
    if "mpi" in report and "sweep_speedup" in report["mpi"]:
        m = report["mpi"]
        print(f"MPI: sweep speed-up {m['sweep_speedup']:.2f} = "
              f"{m['speedup_fraction_of_two_copy_throughput']:.2f} of the two-copy throughput "
              f"{m['two_copy_throughput']:.2f} (target >= 0.9); post-processing "
              f"{100 * m['post_processing_share_2_ranks']:.1f} % of the 2-rank wall time"
              + ("" if m.get("serial_tail_share_2_ranks") is None else
                 f" (serial tail after the last rank's share: "
                 f"{100 * m['serial_tail_share_2_ranks']:.1f} %)"))
    for name, case in report.get("sweeps", {}).get("cases", {}).items():
        walls = ", ".join(f"{m} {r.get('wall_s', float('nan')):.2f} s" for m, r in
                          case["runs"].items())
        print(f"sweep {name} ({case['ranks']} rank(s)): {walls}")
    missed = [t for t in report["targets"] if not t["met"]]
    for t in report["targets"]:
        v = "not measured" if t["value"] is None else f"{t['value']:.3g}"
        print(f"target {t['name']}: {v} (target {t['kind']} {t['target']:g})"
              f"{'' if t['met'] else '  MISSED'}")
    return 1 if missed else 0


if __name__ == "__main__":
    _cli.run(main)
