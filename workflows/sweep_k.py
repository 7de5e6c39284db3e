"""Complete, certified dispersion sweep: every eigenvalue in a stated region, over k, under MPI.

    mpirun -n N python workflows/sweep_k.py [options]        # paper defaults, bc=velocity

At every requested k the sweep reports *every* eigenvalue of the cross-section FE model in the
region R = {re_min <= Re Lambda <= re_max, |Im Lambda| <= c_max k c_d + omega0}, and checks
that nothing is missing or counted twice (docs/design.md section 8). With ``--c-max auto``
(default) the phase-velocity bound grows per k (4, 6, 8, 12, 16, 24, 32 c_d; c_d the largest of
the stack) until the tail bound (docs/design.md 8.1) shows that no root outside R grows faster
than the fastest root in R; summary.json states the bound and the tail bound at every k:

- FE first (``--solver moments``, default): the FE count in R (argument principle on the
  discrete determinant, adaptive contour points) and, from contour-integral moments on the
  same points (Beyn's method), every FE eigenvalue inside, each polished by Newton on the
  discrete nonlinear eigenproblem; the values found must be as many as counted and distinct.
  No exact root is an input. One Newton solve on the P(p+1) model gives the error estimate;
- exact check (``--check-exact yes``, default): every exact root family that can reach R is
  followed in k by exact continuation (from the waveguide cut-offs ``0+``, ``0-``, ``1+``, ...
  and the other roots present at small k, ``s0+``, ``r0``, ...); the exact count in R must
  equal the FE count and each FE value is matched to a distinct exact root, whose family
  gives its label. ``--check-exact no``: analytic's roots are never consulted, the labels are
  ``fe0, fe1, ...`` by increasing ``|Im Lambda|`` at each k (no tracking in k);
- ``--solver newton``: the former path, FE Newton from each exact root (needs the check);
- ``--model layers`` with several layers or profiles: FE only (``--check-exact no``), c_d the
  stack's largest; where the layers' tail bound is derived (constant layers on a rigid
  substrate, at most two if their phase rates are not commensurate: analytic.physics.
  tail_layers) R climbs at every k until it is below the fastest value (``--layers-bound
  no``: not asked for), else R is the first rung, not proven to hold the fastest mode; labels
  ``c0, c1, ...``
  by continuation of the FE eigenpairs in k (forms.studies.sweep.label_by_continuation).

``status = ok`` means: count closed, estimate (and, when checked, label and error) within
``--rtol``; the column ``certificate`` says what a row carries (``fe``, ``exact``).
The families are shared over the ranks, then the k values (each rank a run of neighbouring k,
taken from both ends of the range as the ranks get free: _sharing.EndClaims); every finished k
is written at once to ``DIR/raw/k#####.json`` (``--resume`` continues); rank 0 writes
``spectrum.csv``, ``summary.json`` (``most_unstable`` with its certificate) and
``dispersion.png`` (exact lines, FE points, the envelope ``max Re Lambda(k)``).

Exit codes: 0 every row ok; 1 some rows or k values flagged (see ``status`` and
``summary.json``); 2 bad input (nothing written); 130 interrupted.
"""

from __future__ import annotations

import os

# One MPI rank per core: a threaded BLAS/OpenMP in every rank oversubscribes the cores. Must be
# set before numpy/PETSc load OpenBLAS and libgomp.
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import csv  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import _cli  # noqa: E402
import _sweep_strip  # noqa: E402
import numpy as np  # noqa: E402
from _plot_dispersion import plot_dispersion, preload  # noqa: E402
from tqdm import tqdm  # noqa: E402

from analytic.numerics.spectrum import Region  # noqa: E402
from analytic.params import Params  # noqa: E402
from forms.models.profiles import homogeneous_params, slider_material  # noqa: E402
from forms.solvers.certified import (  # noqa: E402
    ROW_FIELDS,
    SOLVERS,
    KResult,
)
from forms.studies import sweep  # noqa: E402

#: Default k grid: the paper's range (k H up to 3 at H = 0.5).
DEFAULT_K = "0.05:6:120"
DEFAULT_RTOL = 1e-8  # --rtol of --model section and layers
PETSC_PREFIXES: tuple[str, ...] = _sweep_strip.PETSC_PREFIXES  # --model strip only
OUTPUTS = ("spectrum.csv", "summary.json", "dispersion.png", "raw", "run.json", "run.lock")


def build_parser() -> argparse.ArgumentParser:
    """Command-line options."""
    ap = _cli.make_parser(__doc__, PETSC_PREFIXES)
    _cli.add_param_arguments(ap)
    reg = Region()
    ap.add_argument("--k", default=DEFAULT_K,
                    help="start:stop:count or k1,k2,... (duplicates are merged)")
    ap.add_argument("--re-min", type=float, default=reg.re_min,
                    help="region R: smallest growth rate Re Lambda reported (> -1)")
    ap.add_argument("--re-max", type=float, default=reg.re_max,
                    help="region R: largest growth rate searched")
    ap.add_argument("--c-max", default="auto",
                    help="region R: largest phase velocity |Im Lambda|/k, in units of the "
                    "largest c_d, or 'auto': per k, until the region provably holds the fastest "
                    "mode")
    ap.add_argument("--omega0", type=float, default=0.0,
                    help="region R: |Im Lambda| allowance at k -> 0 (0: 2 pi/(beta H))")
    ap.add_argument("--rtol", type=float, default=None,
                    help="relative accuracy every eigenvalue must reach to be 'ok'; sets the "
                    f"default discretisation (default {DEFAULT_RTOL:g}; --model strip: "
                    f"{_sweep_strip.STRIP_RTOL:g})")
    ap.add_argument("--degree", type=int, default=0, help="Lagrange degree 1..6 (0: auto, P6)")
    ap.add_argument("--cells", type=int, default=0,
                    help="cells of the interval mesh (0: chosen from the region and --rtol)")
    ap.add_argument("--solver", default="linear",
                    help="linear (FE first, predictors from the linearised condensed form, "
                    "moments where they fall short; default), moments (FE first, contour "
                    "moments only) or newton (FE from exact roots)")
    ap.add_argument("--check-exact", default="auto",
                    help="yes: match the FE values to the exact roots; no: never consult them; "
                    "auto: no for several layers or profiles (no exact roots), else yes")
    m = ap.add_argument_group("slider (1D model; forms.models.profiles)")
    m.add_argument("--model", default="section", help="section (homogeneous, default), "
                   "layers (--layers and/or profiles) or strip (2D Bloch cell, below)")
    m.add_argument("--layers", default=None, metavar="FILE",
                   help="CSV y_top,mu,rho,beta, one layer per row from y = 0 up (--model layers)")
    for name, example in (("mu", "1 - 0.6*exp(-y/0.05)"), ("rho", "1 - 0.2*exp(-y/0.05)"),
                          ("beta", "0.5 + 0.1*exp(-y/0.05)")):
        m.add_argument(f"--{name}-profile", default=None, metavar="EXPR",
                       help=f"{name}(y) as an expression of y, e.g. '{example}' "
                       "(--model layers)")
    m.add_argument("--layers-bound", default="auto",
                   help="auto (yes with --model layers) | yes | no: the region climbs at every "
                   "k until the layers' tail bound (analytic.physics.tail_layers: constant "
                   "layers on a rigid substrate, at most two if their phase rates are not "
                   "commensurate) is below the fastest value, so that R provably holds the "
                   "fastest mode; each rank bounds its own k, 0.05-1 s a bound (no: R is the "
                   "first rung, not proven to hold it)")
    _sweep_strip.add_arguments(ap)
    ap.add_argument("--out", default=os.path.join("out", "sweep_k"), help="output directory")
    ap.add_argument("--resume", action="store_true",
                    help="continue a sweep in --out with the same settings")
    ap.add_argument("--no-plot", action="store_true", help="skip dispersion.png")
    ap.add_argument("--quiet", action="store_true", help="no progress output")
    return ap


def validate(args: argparse.Namespace) -> tuple[Params, np.ndarray, int, Region]:
    """Check every input (no side effects); raise ParameterError on the first bad one.

    Returns:
        ``(params, k, merged, region)``: ``k`` sorted and unique, ``merged`` the number of
        duplicate values dropped.
    """
    if args.model not in ("section", "layers", "strip"):  # strip: dispatched before this
        raise _cli.ParameterError(f"--model = {args.model!r} is not one of section, layers, strip")
    _sweep_strip.refuse_strip_options(args)
    # the slider of --model: one homogeneous layer (mu = rho = 1, no profile) is today's slider
    # (H, beta of its row; exact roots checked); several layers or profiles have no exact roots
    # (FE only: sweep.layered_params; --check-exact auto is then no)
    params = _cli.params_from_args(args)
    args.material = slider_material(args.model, args.layers, args.mu_profile, args.rho_profile,
                                    args.beta_profile, H=params.H)
    one = homogeneous_params(params, args.material) if args.material is not None else None
    layered = args.material is not None and one is None
    params = one or (sweep.layered_params(params, args.material, args.check_exact, args.solver)
                     if layered else params)
    if params.two_body and not math.isfinite(params.H2):
        raise _cli.ParameterError("H2 = inf is outside its allowed range here: the certified "
                                  "sweep needs a finite substrate (H2 > 0 finite)")
    if not math.isfinite(params.H):
        raise _cli.ParameterError("H = inf is outside its allowed range here: the cross-section"
                                  " model needs a finite H > 0")
    k_all = _cli.parse_k(args.k)
    k = np.unique(k_all)
    args.rtol = DEFAULT_RTOL if args.rtol is None else args.rtol
    _cli.check_section_options(args)  # --degree, --cells, --rtol, --omega0
    if args.solver not in SOLVERS:
        raise _cli.ParameterError(f"--solver = {args.solver} is outside its allowed values "
                                  + " | ".join(SOLVERS))
    if args.check_exact == "auto":
        args.check_exact = "no" if layered else "yes"
    if args.check_exact not in ("yes", "no"):
        raise _cli.ParameterError(f"--check-exact = {args.check_exact} is outside its allowed "
                                  "values yes | no | auto")
    if args.solver == "newton" and args.check_exact == "no":
        raise _cli.ParameterError("--check-exact = no is outside its allowed values with "
                                  "--solver newton (it starts from the exact roots): yes")
    region = _cli.region_from_args(args.c_max, args.re_min, args.re_max, args.omega0 or None)
    if args.layers_bound not in ("auto", "no", "yes") or (args.layers_bound == "yes"
                                                          and not layered):
        raise _cli.ParameterError(f"--layers-bound = {args.layers_bound} is outside its allowed "
                                  "values auto | no | yes (yes: with several layers, --model "
                                  "layers)")
    args.layers_bound = "yes" if layered and args.layers_bound != "no" else "no"  # auto: yes
    # a layered slider's summary keys, its climb's rungs and tail bound (None: not climbed)
    args.layered, args.tail = (sweep.layered_setup(params, args.material, region, args.layers_bound
                                                   == "yes") if layered else (None, None))
    if layered:  # phase velocities in units of the stack's largest c_d; the first rung
        region = sweep.layered_region(params, args.material, region)
    _cli.check_sweep_limits(params, k, region, args.degree, args.cells, args.rtol)
    merged = len(k_all) - len(k)
    args.notes = ([f"note: {merged} duplicate k value(s) merged"] if merged else []) + (
        [sweep.LAYERED_NOTE] if layered else [])  # said once the run folder is taken
    return params, k, merged, region


def write_outputs(out: str, params: Params, region: Region, k: np.ndarray,
                  results: list[KResult], fams: list, meta: dict, plot: bool,
                  c_max_at_k: list[float], layered: dict | None = None,
                  tail_bounds: list[float | None] | None = None) -> dict:
    """Rank 0: spectrum.csv and dispersion.png; returns the summary.

    The caller adds the timings and writes ``summary.json`` once. ``layered``: the region's
    keys of a layered slider (:func:`forms.studies.sweep.layered_summary`); its tail bounds
    (``--layers-bound yes``) as each ``k``'s climb saved them (``tail_bounds``).
    """
    with _cli.atomic_open(os.path.join(out, "spectrum.csv"), "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(ROW_FIELDS))
        w.writeheader()
        w.writerows(sweep.csv_rows(results, ROW_FIELDS))
    summary = meta | sweep.summarise(params, region, k, results, fams, c_max_at_k,
                                     meta["check_exact"], layered, tail_bounds)
    if plot:
        plot_dispersion(os.path.join(out, "dispersion.png"), params,
                        sweep.largest_region(params, region, k, c_max_at_k), results, fams,
                        summary["most_unstable"], meta["parameters"])
    return summary


def main(comm: object = None, argv: list[str] | None = None) -> int:
    """Run the sweep on ``comm`` (every rank calls this)."""
    args, comm = _cli.start(build_parser(), argv, comm)
    if args.model == "strip":  # the 2D Bloch cell, workflows/_sweep_strip.py
        return _sweep_strip.run(comm, args, OUTPUTS)
    params, k, merged, region = validate(args)  # every rank, before any collective or file
    check = args.check_exact == "yes"
    # the slider's material first: a changed profile is named, not the region it changes
    config = {**({"material": args.material.as_dict(), "layers_bound": args.layers_bound}
                 if args.material is not None else {}),
              "params": params.as_dict(), "k": [float(v) for v in k],
              "region": region.as_dict(params), "rtol": args.rtol,
              "degree": args.degree, "cells": args.cells,
              "solver": args.solver, "check_exact": check}
    with _cli.RunFolder(comm, args.out, "sweep_k", config, resume=args.resume, resumable=True,
                        outputs=OUTPUTS) as run:
        out, t_start = run.path, time.perf_counter()
        for note in [] if args.quiet else args.notes:
            _cli.say(note, err=True)
        todo = (parts := run.parts("raw", "k{:05d}", count=len(k))).todo  # --resume: k left
        if not args.quiet:  # an estimate up front, then bars from the first second
            t_est = sweep.estimate_seconds(params, region, k[todo], comm.size)
            _cli.say(f"plan: {len(todo)} k value(s) on {comm.size} rank(s), about {t_est:.0f} s"
                     " of solving at the region's first rung (longer where it grows)", err=True)
        # FE first: the FE climbs its own region at each k (exact roots only referee it); the
        # exact-seeded path and the family plan take the exact roots' region
        plan = sweep.plan_regions(params, region, k, check, args.solver,  # a bar from the start
                                  _cli.progress_mapper(comm, "region bound", args.quiet))
        # rank 0 imports the picture's matplotlib first: meanwhile the last rank plans the
        # exact families (sweep.family_plan) or, unchecked, the other ranks take more k
        t_pre = preload() if comm.rank == 0 and not args.no_plot else 0.0
        t_fam, fams = time.perf_counter(), []
        if check:
            def fam_share(n: int) -> object:  # progress from the first second
                if not args.quiet:
                    _cli.say(f"following {n} root families (continuation in k) ...", err=True)
                # costs 0.002-0.8 s each, unpredictable: each rank takes the next when free
                mine = _cli.claim_shared(comm, n)
                return mine if comm.rank or args.quiet else tqdm(
                    mine, desc=f"root families (taken by rank 0 of {comm.size})",
                    unit=" families", file=sys.stderr)
            fams = sweep.follow_all(comm, params, plan, region, k, fam_share)
        t_fam = time.perf_counter() - t_fam
        # runs of neighbouring k per rank, from both ends of a block as each rank gets free
        mine = (todo[j] for j in _cli.EndClaims(comm, len(todo), sweep.k_costs(
            params, plan.big, k, todo), bar=None if args.quiet else "k values"))
        rungs = sweep.RungSolvers(params, region, float(k[-1]), args.rtol,
                                  (args.degree, args.cells, 1.0), args.material,
                                  check_exact=check, solver=args.solver)
        share = sweep.solve_k_values(params, region, rungs, k, mine, fams, parts.save,
                                     None, None if args.tail else plan.given, args.tail)
        share_end = time.time()  # epoch s, one host's clock (mpi.per_rank): serial tail below
        times = comm.gather({"rank": comm.rank, "families_s": t_fam, "solve_s": share.seconds,
                             "k_values": share.k_values, "unknowns": share.rungs,
                             "cells": share.rung_cells, "share_end": share_end})
        comm.Barrier()
        code = 0
        if comm.rank == 0:
            t2 = time.perf_counter()
            results, used = sweep.results_from_json(saved := [parts.load(i)
                                                              for i in range(len(k))])
            meta = sweep.sweep_meta(params, args.k, k, merged, rungs, used, share, args.solver,
                                    check, times, run.resumed, len(todo)) | {
                "versions": _cli.versions(), "command": _cli.command()}
            summary = write_outputs(out, params, region, k, results, fams, meta,
                                    not args.no_plot, used, args.layered,
                                    sweep.saved_tail_bounds(saved) if args.tail else None)
            summary["region"] = plan.referee(k, used, check) | summary["region"]  # layered: "by"
            wall = time.perf_counter() - t_start
            summary["timing_s"] = {"wall": wall, "post_processing_rank0": time.perf_counter()
                                   - t2 + t_pre, "matplotlib_import_rank0": t_pre,
                                   "serial_tail": time.time() - max(t["share_end"] for t in times)}
            _cli.write_json(os.path.join(out, "summary.json"), summary)  # strict JSON
            code = report(summary, len(k), wall, comm.size, out, args.quiet)
        code = comm.bcast(code)
    return code


def report(summary: dict, n_k: int, wall: float, ranks: int, out: str, quiet: bool) -> int:
    """Rank 0: the warning (flagged rows or open counts) and the most unstable line; exit code."""
    cert = summary["certificate"]
    code = int(bool(cert["k_not_closed"]) or cert["rows_ok"] < cert["rows"])
    if code:
        print(f"warning: {cert['rows'] - cert['rows_ok']} of {cert['rows']} "
              f"eigenvalue(s) flagged, count not closed at {len(cert['k_not_closed'])}"
              f" of {n_k} k value(s); see status in {out}/spectrum.csv", file=sys.stderr)
    # the result line, also with --quiet (it removes progress only)
    if (best := summary["most_unstable"]) is not None:
        sure = "certified" if best["certificate"]["certified"] else "NOT certified"
        if not best["certificate"]["fastest_mode"]:  # the largest in R only: say so
            sure += "; in R only, R not proven to hold the fastest mode: see summary.json"
        print(f"most unstable ({sure}): {best['branch']} at k = {best['k']:.6g}: "
              f"Lambda = {best['re_lambda']:.10g} {best['im_lambda']:+.10g}i "
              f"({cert['rows']} eigenvalues in R over {n_k} k values, {wall:.1f} s"
              f" on {ranks} rank(s)) -> {out}")
    return code


if __name__ == "__main__":
    _cli.run(main)
