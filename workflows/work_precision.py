"""Work-precision diagram: relative error of one eigenvalue against wall time per k.

    python workflows/work_precision.py [--out DIR] [--repeats 3] [--tiny]
    mpirun -n 2 python workflows/work_precision.py ...   # the points are shared out

Cases (parameters in ``summary.json``):

- ``finite_H``: velocity top, paper defaults (``f=0.3, gamma=3, beta=0.5, Delta=0.7,
  H=0.5``), ``k = 1``, branch ``0-``; reference: the exact root
  (``analytic.numerics.branches.polish_root``, = the check value of docs/design.md section 4,
  ``0.2716852879456 - 6.5866951866228i``). Cross-section FE, P1..P4, several uniform meshes.
- ``halfspace``: the same ``f, gamma, beta, Delta``, ``H = inf``, ``k = 0.3``: the
  dilatational instability; reference ``analytic.physics.halfspace.dilatational_root``.
  Cross-section
  FE with the PML layer of :mod:`forms.models.pml` (one layer setting, i.e. without the second,
  checking solve, which doubles the cost), P2..P4, the layer's cell size scaled.

Methods: SLEPc PEP (TOAR, shift-and-invert, MUMPS) on the polynomial form, SLEPc NEP
(NLEIGS) on the split form, a dense baseline (the same polynomial matrices as dense arrays,
linearised into the first companion pencil of size ``d n`` and solved by
``scipy.linalg.eig``: all eigenvalues, the one nearest the target kept), and the analytic
root itself (Newton on ``det M`` / on ``s`` from a generic start). Time per k: the best of
``--repeats`` runs of "operator at this k + solve" (finite H: the k-independent blocks are
assembled once and not counted; half-space: the layer depends on k, so assembly is counted).
The Pareto front (no other point both faster and more accurate) is marked.

The points, their errors and the Pareto marks are computed by :mod:`forms.studies.work_precision`.
Writes ``DIR/work_precision.csv``, ``DIR/summary.json``, ``DIR/work_precision.png``.
"""

from __future__ import annotations

import argparse
import csv
import math
import os

import _cli

from mpi4py import MPI

from forms.studies import work_precision as wp
from forms.studies.work_precision import COLUMNS, DENSE_MAX, K_FINITE, K_HALF

#: Options prefixes of the SLEPc objects (PEP and NEP solvers).
PETSC_PREFIXES = ("wp_pep_", "wp_nep_")

OUTPUT_FILES = ("work_precision.csv", "summary.json", "work_precision.png")
#: Meshes per degree (finite H, uniform cells on H = 0.5).
FINITE_CELLS = {1: (16, 32, 64, 128, 256, 512), 2: (3, 4, 6, 8, 12, 16, 24),
                3: (2, 3, 4, 6, 8, 12), 4: (1, 2, 3, 4, 6, 8)}
#: PML cell size factors (times forms.models.pml.RESOLUTION[degree]).
HALF_SCALES = {2: (2.0, 1.4, 1.0, 0.7, 0.5), 3: (2.0, 1.4, 1.0, 0.7, 0.5),
               4: (2.5, 2.0, 1.4, 1.0, 0.7, 0.5)}
TINY_FINITE = {2: (4, 8), 3: (4,)}
TINY_HALF = {2: (2.0,)}
#: Largest companion pencil (d n) handed to the dense eigensolver with --tiny (else
#: forms.studies.work_precision.DENSE_MAX).
TINY_DENSE_MAX = 300


def build_parser() -> argparse.ArgumentParser:
    """Command-line options."""
    ap = _cli.make_parser(__doc__, PETSC_PREFIXES)
    ap.add_argument("--out", default="out/work_precision", help="output folder")
    ap.add_argument("--repeats", type=int, default=3, help="timing repeats, best kept")
    ap.add_argument("--tiny", action="store_true", help="a few points only (smoke test)")
    ap.add_argument("--no-dense", action="store_true", help="skip the dense baseline")
    return ap


def plot(rows: list[dict], path: str, meta: dict) -> None:
    """Log-log error vs time, one panel per case, Pareto front as a step line."""
    import matplotlib.pyplot as plt

    cases = [c for c in ("finite_H", "halfspace") if any(r["case"] == c for r in rows)]
    fig, axes = plt.subplots(1, len(cases), figsize=(6.4 * len(cases), 5.2), squeeze=False)
    markers = {1: "v", 2: "s", 3: "o", 4: "D"}
    colors = {"PEP": "C0", "NEP": "C1", "dense": "C3", "analytic": "k"}
    titles = {"finite_H": f"finite H = 0.5, velocity top, k = {K_FINITE} (branch 0-)",
              "halfspace": f"half-space (PML), k = {K_HALF}, dilatational root"}
    for ax, case in zip(axes[0], cases, strict=True):
        sel = [r for r in rows if r["case"] == case and math.isfinite(r["rel_error"])]
        seen = set()
        for r in sel:
            kind = r["method"].split()[-1]
            lab = f"{r['method']} P{r['degree']}" if kind != "analytic" else r["method"]
            ax.loglog(r["seconds"], max(r["rel_error"], 1e-16), markers.get(r["degree"], "*"),
                      color=colors.get(kind, "C2"), ms=6, mfc="none" if kind == "NEP" else None,
                      ls="none", label=None if lab in seen else lab)
            seen.add(lab)
        for key, ls, lab in (("pareto", "--", "Pareto front"),
                             ("pareto_fe", ":", "Pareto front, FE only")):
            front = sorted((r for r in sel if r[key]), key=lambda r: r["seconds"])
            if len(front) > 1:
                ax.step([r["seconds"] for r in front],
                        [max(r["rel_error"], 1e-16) for r in front],
                        where="post", color="0.3", lw=1.2, ls=ls, label=lab)
        ax.set_xlabel("wall time per k [s] (best of repeats)")
        ax.set_ylabel("relative error of Lambda")
        ax.set_title(titles[case], fontsize=9)
        ax.grid(True, which="major", alpha=0.3)
        ax.legend(fontsize=6, ncol=2)
    fig.suptitle(f"{meta['machine']}, {meta['ranks']} rank(s); errors clipped at 1e-16",
                 fontsize=8)
    fig.tight_layout()
    _cli.save_figure(fig, path, dpi=110, metadata=_cli.png_metadata(meta, "work-precision"))
    plt.close(fig)


def main(comm=None, argv: list[str] | None = None) -> int:
    """Entry point; the points are shared out over the ranks of ``comm`` (one rank each)."""
    args, comm = _cli.start(build_parser(), argv, comm)
    _cli.positive_int("--repeats", args.repeats, 1, 100)
    parameters = {"repeats": args.repeats, "tiny": args.tiny, "dense": not args.no_dense}
    with _cli.RunFolder(comm, args.out, "work_precision", parameters, outputs=OUTPUT_FILES):
        return _run(comm, args)


def _run(comm, args: argparse.Namespace) -> int:
    cases = wp.reference_cases()
    cells = TINY_FINITE if args.tiny else FINITE_CELLS
    scales = TINY_HALF if args.tiny else HALF_SCALES
    dense_max = TINY_DENSE_MAX if args.tiny else DENSE_MAX
    jobs = wp.make_jobs(cells, scales)
    _cli.say_plan(comm, f"{len(jobs)} jobs (meshes, PML scales, analytic) x {args.repeats} "
                  "repeat(s)", wp.estimate_seconds(jobs, args.repeats, comm.size))
    mine: list[dict] = []
    for i in _cli.my_share(comm, [wp.job_cost(*job) for job in jobs]):
        mine += wp.job_points(MPI.COMM_SELF, jobs[i], cases, args.repeats, not args.no_dense,
                              dense_max, PETSC_PREFIXES)
    parts = comm.gather(mine, root=0)
    if comm.rank == 0:
        rows = wp.merge_rows(parts)
        with _cli.atomic_open(os.path.join(args.out, OUTPUT_FILES[0]), "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=COLUMNS)
            w.writeheader()
            for r in rows:
                w.writerow(r)
        meta = {"command": _cli.command(), **_cli.versions(), "ranks": comm.size,
                "repeats": args.repeats,
                "finite_H": {"params": "paper defaults, H=0.5, bc=velocity", "k": K_FINITE,
                             "target": str(wp.TARGET_FINITE), "reference": str(cases.lam_finite)},
                "halfspace": {"params": "paper defaults, H=inf", "k": K_HALF,
                              "target": str(cases.target_half),
                              "reference": str(cases.lam_half)}}
        with _cli.atomic_open(os.path.join(args.out, OUTPUT_FILES[1]), "w") as fh:
            _cli.json_dump({**meta, "fastest_seconds": wp.fastest_seconds(rows),
                            "points": len(rows)}, fh, indent=1)
        plot(rows, os.path.join(args.out, OUTPUT_FILES[2]), meta)
        print(f"{len(rows)} points -> {args.out}", flush=True)
    comm.Barrier()
    return 0


if __name__ == "__main__":
    _cli.run(main)
