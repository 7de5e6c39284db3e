"""Where methods fail: each way of finding the 1D model's eigenvalues in R against the count.

    python workflows/methods_chart.py [--out DIR] [--k 0.5,4,12] [--c-max 2,6]
    mpirun -n 2 python workflows/methods_chart.py ...   # the (k, c_max) points are shared out

Paper defaults (velocity top, H = 0.5). At each (k, c_max) the section model of the sweep's
default discretisation is solved by a shift-and-invert PEP tiling (``tiling``), the dense
companion linearisation (``dense``, failed above a pencil size), the sweep's default
FE-first path (``linear``: the linearised condensed form, moments where it falls short), the
FE-first moments path (``moments``), SLEPc PEP CISS on ellipses over the region (``ciss``),
SLEPc NEP NLEIGS on the region (``nleigs``) and the exact-seeded Newton (``newton``, the
sweep's ``--solver newton``); each is set against the banded argument-principle count
(found / missed / spurious, wall seconds), see :mod:`forms.studies.methods`. A method that
raises or does not converge at a point is a row with its reason in ``failed``.
Writes ``DIR/methods.csv``, ``DIR/summary.json``, ``DIR/methods.png``.
"""

from __future__ import annotations

import argparse
import csv
import os

import _cli
import numpy as np
from _plot_methods import plot_methods

from analytic.numerics.spectrum import Region
from analytic.params import Params
from forms.studies import methods as ms

#: Options prefixes of the SLEPc objects (the tiling's PEP, the CISS PEP, the NLEIGS NEP).
PETSC_PREFIXES = ms.PREFIXES
OUTPUT_FILES = ("methods.csv", "summary.json", "methods.png")


def build_parser() -> argparse.ArgumentParser:
    """Command-line options."""
    ap = _cli.make_parser(__doc__, PETSC_PREFIXES)
    ap.add_argument("--out", default="out/methods_chart", help="output folder")
    ap.add_argument("--k", default="0.5,2,6", help="wavenumbers (comma list or grid)")
    ap.add_argument("--c-max", default="2,4", help="region sizes c_max (comma list)")
    ap.add_argument("--rtol", type=float, default=1e-6, help="same-eigenvalue distance")
    return ap


def main(comm=None, argv: list[str] | None = None) -> int:
    """Entry point."""
    args, comm = _cli.start(build_parser(), argv, comm)
    ks = [float(v) for v in _cli.parse_grid(args.k, "--k", 50)]
    cs = [float(v) for v in _cli.parse_grid(args.c_max, "--c-max", 10)]
    if not 1e-12 <= args.rtol <= 1e-2:
        raise _cli.ParameterError(f"--rtol = {args.rtol} is outside its allowed range "
                                  "1e-12 .. 1e-2")
    _cli.check_sweep_limits(Params(), np.array(ks), Region(c_max=max(cs)))  # the sweep's
    parameters = {"k": ks, "c_max": cs, "rtol": args.rtol}
    with _cli.RunFolder(comm, args.out, "methods_chart", parameters, outputs=OUTPUT_FILES):
        _cli.say_plan(comm, f"{len(ks)} k x {len(cs)} c_max point(s), {len(ms.METHODS)} methods "
                      "each", ms.estimate_seconds(Params(), ks, cs, comm.size))
        rows = ms.methods_grid(Params(), ks, cs, args.rtol, comm=comm)
        if comm.rank == 0:
            with _cli.atomic_open(os.path.join(args.out, OUTPUT_FILES[0]), "w",
                                  newline="") as fh:
                w = csv.DictWriter(fh, fieldnames=ms.COLUMNS)
                w.writeheader()
                w.writerows(rows)
            meta = {"command": _cli.command(), **_cli.versions(), "ranks": comm.size,
                    "params": "paper defaults", **parameters}
            totals = {m: {key: sum(r[key] for r in rows if r["method"] == m)
                          for key in ("count", "found", "missed", "spurious", "seconds")}
                      | {"failed": sum(bool(r["failed"]) for r in rows if r["method"] == m)}
                      for m in ms.METHODS}
            _cli.write_json(os.path.join(args.out, OUTPUT_FILES[1]),
                            {**meta, "totals": totals, "points": len(rows)})
            plot_methods(rows, os.path.join(args.out, OUTPUT_FILES[2]), meta)
            print(f"{len(rows)} rows -> {args.out}", flush=True)
        comm.Barrier()
    return 0


if __name__ == "__main__":
    _cli.run(main)
