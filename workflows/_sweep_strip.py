"""``sweep_k.py --model strip``: every eigenvalue of the 2D Bloch cell at each k, with its harmonic.

At each ``k`` the cell of one wavelength ``2 pi / k`` (P``--strip-degree`` on
``--strip-cells`` x ``--strip-ny`` cells) is solved by
:func:`forms.studies.strip_sweep.strip_spectrum` (region solver, no exact root: MUMPS's
``log det`` counts, shift-and-invert over tiles finds; collective, the mesh on the whole
communicator) in the box ``re_min <= Re Lambda <= re_max``,
``|Im Lambda| <= strip_c_max k c_d + omega0`` (:func:`forms.studies.strip_sweep.strip_box`;
default ``strip_c_max = 1``, ``omega0 = 0``, not the cross-section sweep's region: see
:data:`WHY_BOX`). Each eigenvalue carries its harmonic ``h`` (wavenumber ``h k``) and its
relative distance to the cross-section model's complete set at ``h k`` (rank 0,
:func:`forms.studies.strip_sweep.section_sets`, the 1D discretisation from ``--rtol``,
``--degree``, ``--cells``). Rank 0 writes ``spectrum.csv`` (the section model's columns plus
``harmonic``, ``rel_distance_1d``) and ``summary.json``; no picture, no ``--resume``.
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import time

import _cli
import numpy as np

from analytic.params import Params
from forms.solvers.certified import ROW_FIELDS
from forms.studies import strip_sweep as ss
from forms.studies import sweep

#: Every options prefix of the strip's PETSc/SLEPc objects (the region PEP and the count's LU).
PETSC_PREFIXES = ss.PREFIXES
FIELDS = (*ROW_FIELDS, *ss.EXTRA_FIELDS)
WHY_BOX = ("the cell holds every harmonic h k with its own spectrum: the cross-section sweep's "
           "region (c_max = 4, omega0 = 2 pi/(beta H)) at k = 4 held 102 eigenvalues of the "
           "cell (harmonics -9..9 in an exploratory run, most beyond what 12 cells per wavelength "
           "resolve) at 13 "
           "times the cost of the default box (528 s against 40 s, the count 93 % of it: "
           "workflows/results/strip_cost*)")


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """The strip's options (a group of ``sweep_k.py``'s parser)."""
    g = ap.add_argument_group("2D Bloch strip (--model strip; forms.studies.strip_sweep)")
    g.add_argument("--strip-cells", type=int, default=12, help="cells along x per wavelength")
    g.add_argument("--strip-ny", type=int, default=6, help="cells along y")
    g.add_argument("--strip-degree", type=int, default=2, help="Lagrange degree 1..4")
    g.add_argument("--strip-c-max", type=float, default=1.0,
                   help="box |Im Lambda| <= strip_c_max k c_d + omega0 (c_d: the slider's "
                   "largest; --omega0 0: none), Re Lambda in [--re-min, --re-max]")


def validate(args: argparse.Namespace) -> tuple[Params, np.ndarray]:
    """Check every input of ``--model strip``; raise ParameterError on the first bad one."""
    params = _cli.params_from_args(args)
    if not math.isfinite(params.H) or (params.two_body and not math.isfinite(params.H2)):
        raise _cli.ParameterError("H = inf (or H2 = inf) is outside its allowed range here: "
                                  "the Bloch cell needs finite H > 0 (and H2 > 0)")
    if args.layers or args.mu_profile or args.rho_profile or args.beta_profile or args.resume:
        raise _cli.ParameterError("--layers, --*-profile and --resume are outside the allowed "
                                  "options of --model strip")
    _cli.positive_int("--strip-cells", args.strip_cells, 2, 1000)
    _cli.positive_int("--strip-ny", args.strip_ny, 1, 1000)
    _cli.positive_int("--strip-degree", args.strip_degree, 1, 4)
    _cli.check_section_options(args)  # the 1D sets' --degree, --cells, --rtol; --omega0
    if not (math.isfinite(args.strip_c_max) and args.strip_c_max > 0):
        raise _cli.ParameterError(f"--strip-c-max = {args.strip_c_max} is outside its allowed "
                                  "range > 0")
    if not (-1.0 < args.re_min < args.re_max and math.isfinite(args.re_max)):
        raise _cli.ParameterError(f"--re-min = {args.re_min}, --re-max = {args.re_max} are "
                                  "outside their allowed range -1 < re_min < re_max")
    return params, np.unique(_cli.parse_k(args.k))


def solve_k(comm: object, params: Params, k: float, args: argparse.Namespace
            ) -> tuple[list[dict], dict]:
    """The strip at ``k`` and, on rank 0, its comparison with the 1D sets (collective)."""
    t0 = time.perf_counter()
    box = ss.strip_box(params, k, args.re_min, args.re_max, args.strip_c_max, args.omega0)
    spec = ss.strip_spectrum(comm, params, k, box, cells_per_wavelength=args.strip_cells,
                             ny=args.strip_ny, degree=args.strip_degree)
    t1 = time.perf_counter()
    rows, entry = [], {}
    if comm.rank == 0:
        sets = ss.section_sets(params, k, [*spec.harmonics, 1.0], spec.box, args.rtol,
                               args.degree, args.cells)
        dist, per = ss.compare_with_section(spec, sets)
        rows = ss.strip_rows(spec, dist)
        entry = {"k": float(k), "box": list(spec.box), "unknowns": spec.unknowns,
                 "counted": spec.counted, "found": len(spec.values), "closed": spec.closed,
                 "harmonics": per, "seconds": {**spec.seconds, "strip_total": t1 - t0,
                                               "section_sets": time.perf_counter() - t1}}
    return rows, entry


def run(comm: object, args: argparse.Namespace, outputs: tuple[str, ...]) -> int:
    """``sweep_k.py --model strip`` on ``comm`` (every rank calls this); the exit code."""
    params, ks = validate(args)
    config = {"model": "strip", "params": params.as_dict(), "k": [float(v) for v in ks],
              "re_min": args.re_min, "re_max": args.re_max, "strip_c_max": args.strip_c_max,
              "omega0": args.omega0, "strip": {"cells_per_wavelength": args.strip_cells,
                                               "ny": args.strip_ny, "degree": args.strip_degree},
              "section": {"rtol": args.rtol, "degree": args.degree, "cells": args.cells}}
    with _cli.RunFolder(comm, args.out, "sweep_k", config, outputs=outputs) as run_:
        t_start, rows, per_k = time.perf_counter(), [], []
        for k in ks:
            r, entry = solve_k(comm, params, float(k), args)
            rows += r
            per_k.append(entry)
            if comm.rank == 0 and not args.quiet:
                _cli.say(f"k = {k:g}: {entry['found']} eigenvalues (counted {entry['counted']}"
                         f"), {entry['seconds']['strip_total']:.1f} s", err=True)
        code = 0
        if comm.rank == 0:
            summary = summarise(config, rows, per_k, comm.size, WHY_BOX)
            summary["timing_s"] = {"wall": time.perf_counter() - t_start}
            _write(run_.path, rows, summary)
            code = report(summary, run_.path)
        code = comm.bcast(code)
    return code


def summarise(config: dict, rows: list[dict], per_k: list[dict], ranks: int, why: str) -> dict:
    """``summary.json`` of the strip sweep (pure data)."""
    by_h: dict[str, float] = {}
    for e in per_k:
        for h, v in e["harmonics"].items():
            if v["max_rel_distance"] is not None:
                by_h[h] = max(by_h.get(h, 0.0), v["max_rel_distance"])
    ones = [e["harmonics"]["1"] for e in per_k]
    best = max(rows, key=lambda r: r["re_lambda"], default=None)
    return {**config, "box_reason": why, "versions": _cli.versions(), "command": _cli.command(),
            "mpi": {"ranks": ranks}, "certificate": {
                "rows": len(rows), "rows_ok": sum(r["status"] == "ok" for r in rows),
                "k_not_closed": [e["k"] for e in per_k if not e["closed"]]},
            "harmonic_1": {"strip": sum(v["strip"] for v in ones),
                           "section": sum(v["section"] for v in ones),
                           "max_rel_distance": by_h.get("1")},
            "max_rel_distance_by_harmonic": by_h, "most_unstable": best, "per_k": per_k}


def _write(out: str, rows: list[dict], summary: dict) -> None:
    with _cli.atomic_open(os.path.join(out, "spectrum.csv"), "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(FIELDS))
        w.writeheader()
        w.writerows(sweep.csv_row(r, FIELDS) for r in rows)
    _cli.write_json(os.path.join(out, "summary.json"), summary)


def report(summary: dict, out: str) -> int:
    """Rank 0: the result line (and a warning if a count did not close); exit code."""
    cert, one = summary["certificate"], summary["harmonic_1"]
    code = 0
    if cert["k_not_closed"]:
        code = 1
        print(f"warning: count not closed at k = {cert['k_not_closed']}", flush=True)
    best = summary["most_unstable"]
    top = "none" if best is None else (f"{best['label']} at k = {best['k']:g}: Lambda = "
                                       f"{best['re_lambda']:.6g} {best['im_lambda']:+.6g}i")
    print(f"strip: {cert['rows']} eigenvalues over {len(summary['per_k'])} k value(s); "
          f"harmonic 1: {one['strip']} (1D: {one['section']}), max relative distance "
          f"{one['max_rel_distance']}; most unstable {top} -> {out}", flush=True)
    return code
