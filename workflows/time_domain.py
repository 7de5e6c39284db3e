"""Time domain: watch a predicted instability grow on the sliding strip, then see what it becomes.

Simulates the periodic strip (one or more wavelengths ``2 pi / k``) with the full nonlinear
rate-and-state law (:mod:`forms.timedomain.model`: explicit central differences, lumped Q1/P1 mass,
implicit slip rate per interface node, exact aging step), starting from steady sliding plus
the eigenmode of ``--branch`` at ``--k`` (``--initial lumped``: the eigenvector of the
linearised lumped system on the same mesh; ``cross-section``: the 1D model's mode interpolated
on the strip), scaled so that ``max |v/v0 - 1| = --amplitude``. Measures, from the
simulation alone, the growth rate and the angular frequency of the ``exp(-i k x)`` Fourier
component of the interface slip rate over the linear window (least squares, with standard
errors) and compares them with the exact eigenvalue (:func:`analytic.follow_branch`). Then
keeps going into the nonlinear regime until ``--t-end``/``--periods`` or the end of the
model's validity (normal stress reaching zero: opening; slip rate reversing).

Two deformable bodies: ``--mu2 M --rho2 R [--beta2 B] --H2 H2 [--bc2 velocity|stress]``
puts the slider on a meshed substrate ``-H2 < y < 0`` (P1 triangles, ``--ny`` cells in each
body; ``--initial lumped`` only); the exact eigenvalue is the two-body root of
:mod:`analytic.physics.twobody` and the growth rate is measured on the interface slip rate.

Writes into ``--out`` as it goes: ``timeseries.csv`` (every step: Fourier coefficient,
energies, friction work, extremes), ``interface_NNNN.npz`` (interface ``v/v0``, ``(tau -
tau0)/sigma0``, ``(sigma - sigma0)/sigma0``, ``theta`` every ``--frame-every`` steps, in chunks),
the checkpoint (``checkpoint.json``, ``checkpoint_rank*.npz``: parts of :mod:`_parts`, for
``--resume``); at the end ``summary.json`` (predicted, measured, relative difference, window,
mesh, time step, parameters, nonlinear outcome, versions), ``growth.png``,
``spacetime_linear.png``, ``spacetime.png``, ``spacetime_nonlinear.png``, ``energy.png``; with
``--xdmf-every N`` also ``fields.xdmf`` (displacement perturbation, for ParaView).

The run itself is :mod:`forms.timedomain.run` (set-up, stepping loop), its files
:mod:`_time_files`, its measurement :mod:`analytic.studies.growth_fit` (fit, summary against
the prediction, the figures' curves).

Example (the README pictures)::

    ./run mpirun -n 2 python workflows/time_domain.py --out workflows/results/time_domain
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time

import _cli
from _plot_time import plot_all  # noqa: E402
from _time_files import RunWriter, read_checkpoint, read_outputs
from tqdm import tqdm

from analytic import parse_branch_label
from analytic.studies.growth_fit import excited_branch, figure_data, mode_period, summarise_run
from forms.timedomain.model import NonlinearLaw
from forms.timedomain.run import estimate_seconds, run_record, run_time_domain, setup_strip

PETSC_PREFIXES = ("td_",)
#: Files the scene writes (and the results folder's measured tables, made from its runs).
OUTPUTS = ("timeseries.csv", "interface_*.npz", "checkpoint*", "summary.json", "*.png",
           "fields.xdmf", "fields.h5", "benchmark.csv", "convergence.csv", "run.json",
           "run.lock")


def build_parser() -> argparse.ArgumentParser:
    """Command-line options (the eigenmode's SLEPc solver has the prefix ``td_``)."""
    p = _cli.make_parser(__doc__, PETSC_PREFIXES)
    _cli.add_param_arguments(p)
    g = p.add_argument_group("nonlinear friction (extra dimensionless numbers)")
    g.add_argument("--a", type=float, default=0.010,
                   help="direct effect a = df/dln v > 0 (PMMA example)")
    g.add_argument("--v0", type=float, default=1e-3 / 1345.0,
                   help="v0/c_s in (0, 1) (PMMA example: 1 mm/s / 1345 m/s)")
    g.add_argument("--friction", choices=("rate-state", "none"), default="rate-state",
                   help="none: frictionless interface (elastic check)")
    p.add_argument("--k", type=float, default=1.0, help="wavenumber k > 0")
    p.add_argument("--branch", default="0-", help="branch excited (0-, 0+, 1-, ...)")
    p.add_argument("--most-unstable", action="store_true",
                   help="excite the branch of largest growth among n = 0..2 at --k")
    p.add_argument("--initial", choices=("lumped", "cross-section"), default="lumped",
                   help="eigenmode of the lumped system on this mesh, or the cross-section"
                        " model's mode (P3) interpolated on the strip")
    p.add_argument("--amplitude", type=float, default=1e-4,
                   help="initial max |v/v0 - 1| along the interface, in (0, 1)")
    p.add_argument("--periods", type=float, default=60.0,
                   help="run length in periods 2 pi/|Im Lambda| of the excited mode")
    p.add_argument("--t-end", type=float, default=None, help="run length (overrides --periods)")
    p.add_argument("--wavelengths", type=int, default=1, help="strip length in wavelengths")
    p.add_argument("--cells-per-wavelength", type=int, default=64, help="cells along x")
    p.add_argument("--ny", type=int, default=16, help="cells along y (in each body)")
    p.add_argument("--cell", choices=("quadrilateral", "triangle"), default=None,
                   help="Q1 or P1 (default: quadrilateral; two bodies: triangle, the only one)")
    p.add_argument("--cfl", type=float, default=0.9,
                   help="time step as a fraction of the stable step (Gershgorin), (0, 1]")
    p.add_argument("--dt", type=float, default=None, help="explicit time step (overrides --cfl)")
    p.add_argument("--linear-limit", type=float, default=1e-2,
                   help="linear window ends when max |v/v0 - 1| exceeds this")
    p.add_argument("--friction-theta", type=float, default=0.55,
                   help="after the linear window, the friction force of step n is taken at"
                        " (1-theta) v^{n-1/2} + theta v^{n+1/2} (in [1/2, 1]); > 1/2 damps the"
                        " spurious 2 dt alternation of stuck nodes; 1/2 (second order) is"
                        " always used in the linear window"),
    p.add_argument("--fit-start", type=float, default=None,
                   help="start of the fit window (default: one period)")
    p.add_argument("--fit-end", type=float, default=None,
                   help="end of the fit window (default: --linear-limit reached; decaying"
                        " modes: amplitude down by e^2)")
    p.add_argument("--frame-every", type=int, default=None,
                   help="steps between interface frames (default: ~32 per period)")
    p.add_argument("--chunk", type=int, default=200, help="frames per interface_NNNN.npz")
    p.add_argument("--xdmf-every", type=int, default=0,
                   help="write the displacement perturbation to fields.xdmf every N steps"
                        " (ParaView; 0: never)")
    p.add_argument("--resume", action="store_true",
                   help="continue from the checkpoint in --out (same options and ranks)")
    p.add_argument("--no-plots", action="store_true", help="skip the PNGs")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--out", default="out/time_domain", help="output directory")
    return p


def validate(args: argparse.Namespace):  # noqa: ANN201 - (Params, NonlinearLaw)
    """Check every option (no collective call); raise ParameterError with one line."""
    params = _cli.params_from_args(args)
    _cli.require_finite_heights(params, "a finite strip", substrate=True)
    if params.two_body:
        if args.cell == "quadrilateral":
            raise _cli.ParameterError("cell = 'quadrilateral' is outside its allowed values"
                                      " here (two bodies: triangle)")
        if args.initial == "cross-section":
            raise _cli.ParameterError("initial = 'cross-section' is outside its allowed values"
                                      " here (two bodies: lumped)")
    args.cell = args.cell or ("triangle" if params.two_body else "quadrilateral")
    _cli.check_k(args.k)
    law = NonlinearLaw(params, a=args.a, v0=args.v0, kind=args.friction)
    parse_branch_label(args.branch)
    checks = [("amplitude", args.amplitude, 0.0, 1.0), ("periods", args.periods, 0.0, math.inf),
              ("linear-limit", args.linear_limit, args.amplitude, 1.0),
              ("cfl", args.cfl, 0.0, 1.0 + 1e-15),
              ("friction-theta", args.friction_theta, 0.5 - 1e-15, 1.0 + 1e-15)]
    for name, v, lo, hi in checks:
        if not (math.isfinite(v) and lo < v < hi) and not (name == "periods" and v == math.inf):
            raise _cli.ParameterError(f"{name} = {v!r} is outside its allowed range"
                                      f" ({lo:g}, {hi:g})")
    for name in ("t_end", "dt", "fit_start", "fit_end"):
        v = getattr(args, name)
        if v is not None and not (math.isfinite(v) and v >= 0 and (v > 0 or name == "fit_start")):
            raise _cli.ParameterError(f"{name.replace('_', '-')} = {v!r} is outside its allowed"
                                      " range (finite, > 0)")
    _cli.positive_int("wavelengths", args.wavelengths)
    _cli.positive_int("cells-per-wavelength", args.cells_per_wavelength, minimum=4)
    _cli.positive_int("ny", args.ny)
    _cli.positive_int("chunk", args.chunk)
    if args.xdmf_every < 0:
        raise _cli.ParameterError(f"xdmf-every = {args.xdmf_every} is outside its allowed range"
                                  " >= 0")
    if args.frame_every is not None:
        _cli.positive_int("frame-every", args.frame_every)
    return params, law


def _config(args: argparse.Namespace, nranks: int) -> dict:
    """Options that must match for ``--resume``."""
    keys = ["f", "gamma", "beta", "Delta", "H", "bc", "alpha_pc", "alpha_ld", "a", "v0",
            "friction", "k", "branch", "most_unstable", "initial", "amplitude", "wavelengths",
            "cells_per_wavelength", "ny", "cell", "cfl", "dt", "frame_every", "chunk", "xdmf_every",
            "linear_limit", "friction_theta"]
    if math.isfinite(args.mu2):  # two bodies (finite H2): the substrate must match too
        keys += ["mu2", "rho2", "beta2", "H2", "bc2"]
    out = {key: getattr(args, key) for key in keys}
    out["ranks"] = nranks
    return out


def main(comm: object = None, argv: list[str] | None = None) -> int:
    """Run the scene (every rank calls this)."""
    args, comm = _cli.start(build_parser(), argv, comm)
    params, law = validate(args)  # every rank, before any collective call or file
    with _cli.RunFolder(comm, args.out, "time_domain", _config(args, comm.size),
                        resume=args.resume, resumable=True, outputs=OUTPUTS):
        return _run(args, comm, params, law)


def _run(args: argparse.Namespace, comm: object, params: object, law: object) -> int:
    """The simulation, in a checked and locked output folder."""
    config = _config(args, comm.size)
    resume = read_checkpoint(args.out) if args.resume else None
    if resume is not None and resume["config"] != config:
        raise _cli.ParameterError("resume: the options or the number of ranks differ from"
                                  f" the checkpoint in {args.out} (run without --resume)")
    label, exact = excited_branch(params, args.k, args.branch, args.most_unstable)
    period = mode_period(exact)
    t_end = args.t_end if args.t_end is not None else args.periods * period
    t_setup = time.perf_counter()
    td, mode = setup_strip(comm, law, args.k, exact, wavelengths=args.wavelengths,
                           cells_per_wavelength=args.cells_per_wavelength, ny=args.ny,
                           cell=args.cell, cfl=args.cfl, dt=args.dt, initial=args.initial,
                           amplitude=args.amplitude)
    setup_time = time.perf_counter() - t_setup
    n_steps = int(math.ceil(t_end / td.dt))
    writer = RunWriter(comm, args.out, config, args.chunk, args.xdmf_every)
    theta_switch = writer.start(td, resume)
    _cli.say_plan(comm, f"{n_steps - td.step} time steps of {td.num_dofs} unknowns",
                  estimate_seconds(td.num_dofs, n_steps - td.step), quiet=args.quiet)
    bar = None
    if comm.rank == 0 and not args.quiet:
        bar = tqdm(total=n_steps, initial=td.step, unit="step", file=sys.stderr,
                   desc=f"time domain {label} k={args.k:g}")
    outcome = run_time_domain(td, writer, n_steps,
                              args.frame_every or max(1, int(round(period / 32 / td.dt))),
                              args.linear_limit, args.friction_theta, theta_switch,
                              progress=bar.update if bar is not None else None)
    if bar is not None:  # progress comes every 50 steps: the bar ends at the steps done
        bar.total = bar.n = td.step
        bar.close()
    if comm.rank == 0:
        _summarise(args, params, td, mode, label, exact, period, t_end, outcome, setup_time)
    td.destroy()
    return 0


def _summarise(args: argparse.Namespace, params: object, td: object, mode: object, label: str,
               exact: complex, period: float, t_end: float, outcome: object,
               setup_time: float) -> None:
    """summary.json, the printed numbers and the pictures (rank 0)."""
    data, frames = read_outputs(args.out)
    analysis = summarise_run(data, frames, exact, args.k, params.f,
                             args.fit_start if args.fit_start is not None else period,
                             args.linear_limit, args.fit_end)
    summary = run_record(td, mode, label, exact, analysis, outcome,
                         nx=args.wavelengths * args.cells_per_wavelength, ny=args.ny,
                         cell=args.cell, friction_theta=args.friction_theta, t_end=t_end,
                         inputs={"amplitude": args.amplitude, "linear_limit": args.linear_limit},
                         setup_time=setup_time, command=_cli.command(),
                         versions=_cli.versions())
    with _cli.atomic_open(os.path.join(args.out, "summary.json"), "w") as fh:
        _cli.json_dump(summary, fh, indent=1)
    if not args.no_plots:
        plot_all(args.out, figure_data(data, frames, exact, summary["window"],
                                       summary["measured"]), frames, summary, exact,
                 f"{label}, k = {args.k:g}, bc = {args.bc}, f = {args.f:g},"
                 f" gamma = {args.gamma:g}, Delta = {args.Delta:g}, H = {args.H:g}"
                 + (f", mu2 = {params.mu2:g}, rho2 = {params.rho2:g}, H2 = {params.H2:g},"
                    f" bc2 = {params.bc2}" if params.two_body else ""))
    print(_cli.dumps({"predicted": summary["predicted"], "measured": summary["measured"],
                      "relative_difference": summary["relative_difference"],
                      "end": summary["end"]}, indent=1))


if __name__ == "__main__":
    _cli.run(main)
