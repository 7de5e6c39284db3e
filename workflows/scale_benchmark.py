"""Cost of the 2D region solve against the number of unknowns: one finite block, several meshes.

For every size of ``--unknowns`` (increasing; square P2 cells, the nearest mesh) the free block
``0 < x < --length`` (paper parameters) is solved for every eigenvalue in ``--box``
(:func:`forms.studies.scale.measure_region_solve`): the tiles (shift-and-invert Krylov-Schur,
MUMPS, covering the box) always, the argument-principle count of ``det T_h`` (MUMPS
``ICNTL(33)``) only up to ``--count-up-to`` unknowns. Written to ``--out``:

- ``scale_np<ranks>.csv``: per size the columns of :data:`forms.studies.scale.COLUMNS`: wall
  time, setup, the count's time, LU factorisations and their PETSc-logged time, the tiles' time,
  tile solves, their LU and ``MatSolve`` times, the factorisation's share of the wall time, the
  peak resident memory (largest rank, MiB), MUMPS's ``INFOG(21)`` (MiB), found, counted, the
  fastest eigenvalue, the 1-minute load average before and after (rewritten as each size
  finishes);
- ``scale_np<ranks>.json``: parameters, the machine's load average at start and end (other jobs
  share the machine: times are what this run got, not the machine's speed), the rows, and the
  cost model fitted to them (:func:`forms.studies.scale.fit_cost_model`).

Example (the README's table)::

    ./run python workflows/scale_benchmark.py --out workflows/results/scale/np1
    ./run mpirun -n 2 python workflows/scale_benchmark.py --out workflows/results/scale/np2
"""

from __future__ import annotations

import argparse
import csv
import os
import time

import _block_search
import _cli

from analytic.params import Params
from forms.studies import scale

#: Options prefixes: the tile solver (PEP) and the count's LU.
PETSC_PREFIXES = ("scale_region_", "scale_region_det_")


def build_parser() -> argparse.ArgumentParser:
    """Command-line options."""
    p = _cli.make_parser(__doc__, PETSC_PREFIXES)
    p.add_argument("--unknowns", default="10000,50000,200000",
                   help="approximate numbers of unknowns, increasing (comma list)")
    p.add_argument("--length", type=float, default=2.0, help="block length L")
    p.add_argument("--box", default="0.02:0.6:10", help="RE_MIN:RE_MAX:IM_MAX of the region")
    p.add_argument("--nev", type=int, default=8, help="eigenpairs per tile solve")
    p.add_argument("--count-up-to", type=int, default=10000,
                   help="count by the argument principle only up to this many unknowns")
    p.add_argument("--no-divide", action="store_true",
                   help="count det T_h itself, without dividing out the cleared denominator's"
                        " (Lambda + 1)^m (for comparison: its sampling grows with the mesh)")
    p.add_argument("--out", default="out/scale", help="output directory")
    return p


def validate(args: argparse.Namespace) -> tuple[list[int], tuple[float, ...]]:
    """Sizes and box, or one-line errors (exit 2)."""
    try:
        sizes = [int(v) for v in args.unknowns.split(",") if v.strip()]
    except ValueError:
        raise _cli.ParameterError(f"--unknowns {args.unknowns!r}: give integers") from None
    if not sizes or sizes != sorted(sizes) or sizes[0] < 100:
        raise _cli.ParameterError(f"--unknowns {args.unknowns!r} is outside its allowed range"
                                  " (increasing, each >= 100)")
    if not 0 < args.length <= 1000:
        raise _cli.ParameterError(f"--length {args.length} is outside its allowed range"
                                  " (0, 1000]")
    _cli.positive_int("--nev", args.nev, 1, 200)
    _cli.positive_int("--count-up-to", args.count_up_to, 0)
    box = _block_search.parse_box(args.box)
    if box is None:
        raise _cli.ParameterError(f"--box {args.box!r} is outside its allowed values here"
                                  " (RE_MIN:RE_MAX:IM_MAX; auto is not taken)")
    return sizes, (box[0], box[1], -box[2], box[2])


def main(comm=None, argv: list[str] | None = None) -> int:
    """Run the sizes; exit code 1 if a counted size did not close."""
    args, comm = _cli.start(build_parser(), argv, comm)
    sizes, box = validate(args)
    parameters = {"unknowns": sizes, "length": args.length, "box": list(box),
                  "nev": args.nev, "count_up_to": args.count_up_to,
                  "divide": not args.no_divide, "degree": 2,
                  "lateral": "free", "params": Params().as_dict()}
    name = f"scale_np{comm.size}"
    with _cli.RunFolder(comm, args.out, "scale_benchmark", parameters,
                        outputs=("scale_np*.csv", "scale_np*.json")):
        _cli.say_plan(comm, f"{len(sizes)} size(s) of one region solve", scale.estimate_seconds(
            sizes, args.count_up_to), "(the one-rank model)")
        return _run(comm, args, sizes, box, parameters, name)


def _run(comm, args, sizes, box, parameters, name) -> int:
    params, rows = Params(), []
    record = {"parameters": parameters, "ranks": comm.size, "load_start": os.getloadavg(),
              "started": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
              "command": _cli.command(), "versions": _cli.versions()}
    csv_path = os.path.join(args.out, name + ".csv")
    for target in sizes:
        nx, ny = scale.cells_for_unknowns(target, args.length, params.H)
        load = os.getloadavg()[0]
        row = scale.measure_region_solve(comm, params, args.length, nx, ny, box=box,
                                         nev=args.nev, count=target <= args.count_up_to,
                                         divide=not args.no_divide)
        row.update(load_start=load, load_end=os.getloadavg()[0])
        rows.append(row)
        _cli.say(f"{row['unknowns']} unknowns: wall {row['wall']:.1f} s, found {row['found']},"
                 f" counted {row['counted']}, LU share {row['lu_share']:.2f}", err=False)
        record.update(load_end=os.getloadavg(), rows=rows,
                      cost_model={str(k): v for k, v in scale.fit_cost_model(rows).items()})
        if comm.rank == 0:  # after every size: a run stopped by a time limit keeps its rows
            with _cli.atomic_open(csv_path, "w", newline="") as f:
                w = csv.DictWriter(f, [*scale.COLUMNS, "load_start", "load_end"])
                w.writeheader()
                w.writerows(rows)
            _cli.write_json(os.path.join(args.out, name + ".json"), record)
    return 0 if all(r["closed"] in ("", True) for r in rows) else 1


if __name__ == "__main__":
    _cli.run(main)
