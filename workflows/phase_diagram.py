"""Stability phase diagram in the Delta-Gamma plane, kH -> infinity (Fig. stability_diagram).

For each ``(f, beta)`` row (default: the paper's two rows, ``(0.3, 0.45)`` and ``(0.3, 0.6)``):

- the three boundaries of Eq. (stability_boundaries) from the closed forms
  (:mod:`analytic.physics.largek`), and
- the same three boundaries located numerically from the spectrum ``s(z, q)``
  (:func:`analytic.physics.phase_diagram.bracket_and_threshold`: Brent bisection in ``Delta`` on the
  sign of the largest growth rate over ``q`` of each root family; the bracket is found by
  doubling, not from the closed form),

the regions where each instability exists, the upper stability boundary and the
all-dilatational-modes-unstable line (Eq. all_modes), on linear and logarithmic axes.
Parallel over the (row, family, Gamma) tasks with MPI; rank 0 writes
``DIR/boundaries.csv`` (columns ``boundary, source, f, beta, Gamma, Delta``),
``DIR/phase_diagram.json`` (parameters, versions, measured closed-form vs numerical
differences) and ``DIR/phase_diagram.png``.

    python workflows/phase_diagram.py --out out/phase_diagram
    mpirun -n 2 python workflows/phase_diagram.py --f 0.3 --beta 0.5 --n-gamma 12 --out DIR
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import sys
import time

import _cli
import _plots
from tqdm import tqdm

from mpi4py import MPI

from analytic.params import ParameterError, Params
from analytic.physics import phase_diagram as pd


# -------------------------------------------------------------------------------------- main
def build_parser() -> argparse.ArgumentParser:
    """Command-line options (no PETSc/SLEPc object here: single-dash options are errors)."""
    ap = _cli.make_parser(__doc__, petsc=False)
    ap.add_argument("--f", type=str, default=None,
                    help="friction coefficient(s) f > 0, comma list (default: paper rows)")
    ap.add_argument("--beta", type=str, default=None,
                    help="beta = c_s/c_d in (0, 1/sqrt 2), comma list matching --f")
    w = pd.Window()
    ap.add_argument("--gamma-min", type=float, default=w.gamma_min,
                    help="smallest Gamma (log axes)")
    ap.add_argument("--gamma-max", type=float, default=w.gamma_max, help="largest Gamma")
    ap.add_argument("--delta-min", type=float, default=w.delta_min,
                    help="smallest Delta (log axes)")
    ap.add_argument("--delta-max", type=float, default=w.delta_max, help="largest Delta shown")
    ap.add_argument("--n-gamma", type=int, default=pd.N_GAMMA,
                    help="log-spaced Gamma points per boundary (plus n/2 linear ones)")
    ap.add_argument("--out", default="out/phase_diagram", help="output folder")
    return ap


def rows_from(opts: argparse.Namespace) -> list[tuple[float, float]]:
    """Validate and return the ``(f, beta)`` rows (raises ParameterError)."""
    if opts.f is None and opts.beta is None:
        return list(pd.PAPER_ROWS)
    fs = [0.3] if opts.f is None else [_num("f", v) for v in opts.f.split(",")]
    bs = [0.5] if opts.beta is None else [_num("beta", v) for v in opts.beta.split(",")]
    if len(fs) == 1 and len(bs) > 1:
        fs = fs * len(bs)
    if len(bs) == 1 and len(fs) > 1:
        bs = bs * len(fs)
    if len(fs) != len(bs):
        raise ParameterError(f"--f has {len(fs)} values but --beta has {len(bs)}")
    for f, b in zip(fs, bs, strict=True):
        Params(f=f, beta=b)  # range checks with the shared messages
        if f <= 0:
            raise ParameterError(f"f = {f!r} is outside its allowed range f > 0 "
                                 "(Gamma = gamma f needs f > 0)")
    return list(zip(fs, bs, strict=True))


def _num(name: str, text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise ParameterError(f"{name} = {text!r} is not a number") from None


def validate(opts: argparse.Namespace) -> list[tuple[float, float]]:
    """All input checks, before any collective call or output; returns the ``(f, beta)`` rows."""
    rows = rows_from(opts)
    for name in ("gamma_min", "gamma_max", "delta_min", "delta_max"):
        v = getattr(opts, name)
        if not (math.isfinite(v) and v > 0):
            raise ParameterError(f"--{name.replace('_', '-')} = {v!r} is outside its allowed "
                                 "range > 0 (finite)")
    if opts.gamma_min >= opts.gamma_max:
        raise ParameterError(f"--gamma-min = {opts.gamma_min} must be < --gamma-max = "
                             f"{opts.gamma_max}")
    if opts.delta_min >= opts.delta_max:
        raise ParameterError(f"--delta-min = {opts.delta_min} must be < --delta-max = "
                             f"{opts.delta_max}")
    _cli.positive_int("--n-gamma", opts.n_gamma, minimum=2, maximum=2000)
    return rows


def main(comm: MPI.Comm | None = None, argv: list[str] | None = None) -> int:
    """Compute and (rank 0) write the phase diagram; returns 0."""
    opts, comm = _cli.start(build_parser(), argv, comm)
    rows = validate(opts)  # every rank validates the same input: all raise or none
    parameters = {"rows": [[f, b] for f, b in rows], "gamma_min": opts.gamma_min,
                  "gamma_max": opts.gamma_max, "delta_min": opts.delta_min,
                  "delta_max": opts.delta_max, "n_gamma": opts.n_gamma}
    with _cli.RunFolder(comm, opts.out, "phase_diagram", parameters,
                        outputs=("boundaries.csv", "phase_diagram.json", "phase_diagram.png")):
        return _run(comm, opts, rows)


def _run(comm: MPI.Comm, opts: argparse.Namespace, rows: list[tuple[float, float]]) -> int:
    window = pd.Window(opts.gamma_min, opts.gamma_max, opts.delta_min, opts.delta_max)
    tasks = pd.tasks(rows, pd.gamma_grid(opts.gamma_min, opts.gamma_max, opts.n_gamma))
    _cli.say_plan(comm, f"{len(tasks)} boundary points (rows x families x Gamma)",
                  pd.estimate_seconds(len(tasks), comm.size))
    mine = [tasks[i] for i in _cli.my_share(comm, [1.0] * len(tasks))]
    t0 = time.perf_counter()
    iterator = mine
    if comm.rank == 0:
        iterator = tqdm(mine, desc="phase diagram (rank 0 share)", file=sys.stderr)
    local = [r for f, b, fam, g in iterator
             for r in pd.boundary_records(f, b, fam, g, window.delta_max)]
    gathered = comm.gather(local, root=0)
    elapsed = comm.reduce(time.perf_counter() - t0, op=MPI.MAX, root=0)
    if comm.rank != 0:
        return 0
    records, dropped = pd.sort_records([r for part in gathered for r in part])
    with _cli.atomic_open(os.path.join(opts.out, "boundaries.csv"), "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=["boundary", "source", "f", "beta", "Gamma", "Delta"])
        w.writeheader()
        for r in records:
            w.writerow({k: (f"{v:.15g}" if isinstance(v, float) else v) for k, v in r.items()})
    parameters = {"rows": [{"f": f, "beta": b} for f, b in rows],
                  "gamma_min": opts.gamma_min, "gamma_max": opts.gamma_max,
                  "delta_min": opts.delta_min, "delta_max": opts.delta_max,
                  "n_gamma": opts.n_gamma, "ranks": comm.size,
                  "method": "Brent bisection in Delta on the sign of max_q of the unstable margin"
                            " (analytic.physics.halfspace.max_growth, q grids of"
                            " analytic.physics.halfspace.default_qgrid)"}
    summary = {"parameters": parameters, "versions": _cli.versions(),
               "command": _cli.command(),
               "wall_time_s": elapsed,
               "closed_form_vs_numerical": pd.measured_differences(records, rows),
               "dropped_numerical_points": dropped,
               "closed_form_points": pd.closed_form_points(rows)}
    with _cli.atomic_open(os.path.join(opts.out, "phase_diagram.json"), "w") as fh:
        _cli.json_dump(summary, fh, indent=2)
    _plots.plot_phase_diagram(rows, records, window,
                              os.path.join(opts.out, "phase_diagram.png"), parameters)
    print(f"phase diagram: {len(records)} boundary points, {elapsed:.1f} s on {comm.size} "
          f"rank(s) -> {opts.out}", flush=True)
    return 0


if __name__ == "__main__":
    _cli.run(main)
