"""Time domain: watch a predicted instability grow on the sliding strip, then see what it becomes.

Simulates the periodic strip (one or more wavelengths ``2 pi / k``) with the full nonlinear
rate-and-state law (:mod:`forms.timedomain`: explicit central differences, lumped Q1/P1 mass,
implicit slip rate per interface node, exact aging step), starting from steady sliding plus
the eigenmode of ``--branch`` at ``--k`` (``--initial lumped``: the eigenvector of the
linearised lumped system on the same mesh; ``cross-section``: the 1D model's mode interpolated
on the strip), scaled so that ``max |v/v0 - 1| = --amplitude``. Measures, from the
simulation alone, the growth rate and the angular frequency of the ``exp(-i k x)`` Fourier
component of the interface slip rate over the linear window (least squares, with standard
errors) and compares them with the exact eigenvalue (:func:`analytic.follow_branch`). Then
keeps going into the nonlinear regime until ``--t-end``/``--periods`` or the end of the
model's validity (normal stress reaching zero: opening; slip rate reversing).

Writes into ``--out`` as it goes: ``timeseries.csv`` (every step: Fourier coefficient,
energies, friction work, extremes), ``interface_NNNN.npz`` (interface ``v/v0``, ``(tau -
tau0)/sigma0``, ``(sigma - sigma0)/sigma0``, ``theta`` every ``--frame-every`` steps, in chunks),
``checkpoint_rank*.npz`` (for ``--resume``); at the end ``summary.json`` (predicted, measured,
relative difference, window, mesh, time step, parameters, nonlinear outcome, versions),
``growth.png``, ``spacetime_linear.png``, ``spacetime.png``, ``spacetime_nonlinear.png``,
``energy.png``; with ``--xdmf-every N`` also ``fields.xdmf`` (displacement perturbation, for
ParaView).

Example (the README pictures)::

    ./run mpirun -n 2 python workflows/time_domain.py --out workflows/results/time_domain
"""

from __future__ import annotations

import argparse
import csv
import glob
import json
import math
import os
import sys
import time

import _cli
import numpy as np

from analytic.params import require_rigid

PETSC_PREFIXES = ("td_",)
#: Files the scene writes (and the results folder's measured tables, made from its runs).
OUTPUTS = ("timeseries.csv", "interface_*.npz", "checkpoint*", "summary.json", "*.png",
           "fields.xdmf", "fields.h5", "benchmark.csv", "convergence.csv", "run.json",
           "run.lock")
CSV_COLUMNS = ["step", "t", "re_c", "im_c", "energy", "energy_change", "work_friction",
               "min_sigma", "min_v", "max_dv", "newton", "top_force"]


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
    p.add_argument("--ny", type=int, default=16, help="cells along y")
    p.add_argument("--cell", choices=("quadrilateral", "triangle"), default="quadrilateral",
                   help="Q1 or P1")
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
    from forms.timedomain import NonlinearLaw

    params = _cli.params_from_args(args)
    require_rigid(params, "the time-domain scene")
    if not math.isfinite(params.H):
        raise _cli.ParameterError("H = inf is outside its allowed range (finite H for a strip)")
    _cli.check_k(args.k)
    law = NonlinearLaw(params, a=args.a, v0=args.v0, kind=args.friction)
    from analytic import parse_branch_label

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


def choose_branch(params, k: float, args: argparse.Namespace) -> tuple[str, complex]:  # noqa: ANN001
    """``(label, exact Lambda)`` of ``--branch`` or of the most unstable branch (n = 0..2)."""
    from analytic import follow_branch, parse_branch_label

    labels = ([f"{n}{s}" for n in range(3) for s in "-+"] if args.most_unstable
              else [args.branch])
    found = []
    for label in labels:
        n, sign = parse_branch_label(label)
        res = follow_branch(params, n, sign, [k])
        if res.ok[0]:
            found.append((label, complex(res.Lambda[0])))
    if not found:
        raise _cli.ParameterError(f"branch = {args.branch!r}: no exact root found at k = {k}")
    return max(found, key=lambda t: t[1].real)


def _config(args: argparse.Namespace, nranks: int) -> dict:
    """Options that must match for ``--resume``."""
    keys = ["f", "gamma", "beta", "Delta", "H", "bc", "alpha_pc", "alpha_ld", "a", "v0",
            "friction", "k", "branch", "most_unstable", "initial", "amplitude", "wavelengths",
            "cells_per_wavelength", "ny", "cell", "cfl", "dt", "frame_every", "chunk", "xdmf_every",
            "linear_limit", "friction_theta"]
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
    from forms.timedomain import build_time_domain
    from meshes.strip import strip_mesh

    rank0 = comm.rank == 0
    config = _config(args, comm.size)
    ckpt_json = os.path.join(args.out, "checkpoint.json")
    resume = None
    if args.resume and os.path.exists(ckpt_json):
        with open(ckpt_json) as fh:
            resume = json.load(fh)
        if resume["config"] != config:
            raise _cli.ParameterError("resume: the options or the number of ranks differ from"
                                      f" the checkpoint in {args.out} (run without --resume)")
    label, exact = choose_branch(params, args.k, args)
    period = 2.0 * math.pi / abs(exact.imag) if exact.imag != 0 else 1.0
    t_end = args.t_end if args.t_end is not None else args.periods * period

    t_setup = time.perf_counter()
    length = args.wavelengths * 2.0 * math.pi / args.k
    strip = strip_mesh(comm, length, params.H, args.wavelengths * args.cells_per_wavelength,
                       args.ny, cell=args.cell)
    td = build_time_domain(strip, law, args.k, cfl=args.cfl, dt=args.dt)
    mode = td.linear_mode(exact)  # the semi-discrete eigenvalue is reported in any case
    if args.initial == "cross-section":
        td.set_initial_mode(td.cross_section_mode(exact), args.amplitude)
    else:
        td.set_initial_mode(mode, args.amplitude)
    setup_time = time.perf_counter() - t_setup
    n_steps = int(math.ceil(t_end / td.dt))
    frame_every = args.frame_every or max(1, int(round(period / 32 / td.dt)))

    os.makedirs(args.out, exist_ok=True) if rank0 else None
    comm.barrier()
    ts_path = os.path.join(args.out, "timeseries.csv")
    chunk_index = 0
    theta_switch = None  # time at which the friction theta switched to --friction-theta
    if resume is not None:
        with np.load(os.path.join(args.out, f"checkpoint_rank{comm.rank}.npz")) as z:
            td.load_state(dict(z))
        chunk_index = int(resume["chunk"])
        td.friction_theta = float(resume.get("friction_theta", 0.5))
        theta_switch = resume.get("theta_switch")
        if rank0:  # drop rows written after the checkpoint
            with open(ts_path) as fh:
                rows = list(csv.reader(fh))
            keep = [rows[0]] + [r for r in rows[1:] if int(r[0]) < td.step]
            with open(ts_path, "w", newline="") as fh:
                csv.writer(fh).writerows(keep)
            for path in glob.glob(os.path.join(args.out, "interface_*.npz")):
                if int(os.path.basename(path)[10:14]) >= chunk_index:
                    os.remove(path)
    elif rank0:
        for path in glob.glob(os.path.join(args.out, "interface_*.npz")):
            os.remove(path)
        with open(ts_path, "w", newline="") as fh:
            csv.writer(fh).writerow(CSV_COLUMNS)

    rows: list[list] = []
    frames: dict[str, list] = {"t": [], "v": [], "tau": [], "sigma": [], "theta": []}
    x_interface = None
    stop = {"reason": "t_end", "t": None, "x": None}
    pending = 0  # frames gathered since the last flush (every rank counts; rank 0 holds them)

    def flush() -> None:
        nonlocal chunk_index, pending
        if rank0:
            with open(ts_path, "a", newline="") as fh:
                csv.writer(fh).writerows(rows)
            if frames["t"]:
                np.savez_compressed(os.path.join(args.out, f"interface_{chunk_index:04d}.npz"),
                                    x=x_interface, **{kk: np.array(vv) for kk, vv in
                                                      frames.items()})
        if pending:
            chunk_index += 1
        pending = 0
        rows.clear()
        for vv in frames.values():
            vv.clear()
        np.savez(os.path.join(args.out, f"checkpoint_rank{comm.rank}.npz"), **td.state_arrays())
        comm.barrier()
        if rank0:
            with open(ckpt_json, "w") as fh:
                json.dump({"config": config, "step": td.step, "chunk": chunk_index,
                           "friction_theta": td.friction_theta, "theta_switch": theta_switch},
                          fh)

    xdmf = None
    if args.xdmf_every:
        from dolfinx.io import XDMFFile

        # appended on --resume would need XDMF surgery: a resumed run starts a new file
        xdmf = XDMFFile(comm, os.path.join(args.out, "fields.xdmf"), "w")
        xdmf.write_mesh(strip.mesh)
    bar = None
    if rank0 and not args.quiet:
        from tqdm import tqdm

        bar = tqdm(total=n_steps, initial=td.step, unit="step", file=sys.stderr,
                   desc=f"time domain {label} k={args.k:g}")
    t_run = time.perf_counter()
    steps_run = 0
    while td.step < n_steps:
        td.advance()
        steps_run += 1
        s = td.sample()
        rows.append([s.step, repr(s.t), repr(s.coefficient.real), repr(s.coefficient.imag),
                     repr(s.energy), repr(s.energy_change), repr(s.work_friction),
                     repr(s.min_sigma), repr(s.min_v), repr(s.max_dv), s.newton_max,
                     repr(s.top_force)])
        invalid = s.min_sigma <= 0.0 or s.min_v < 0.0
        if s.max_dv > args.linear_limit and td.friction_theta != args.friction_theta:
            td.friction_theta = args.friction_theta  # the linear window is over
            theta_switch = s.t
        if s.step % frame_every == 0 or invalid:
            fields = td.interface_fields()
            pending += 1
            if rank0:
                x_interface = fields["x"]
                frames["t"].append(s.t)
                for key in ("v", "tau", "sigma", "theta"):
                    frames[key].append(fields[key])
                if invalid:
                    bad = fields["sigma"] <= -1.0 if s.min_sigma <= 0 else fields["v"] < 0
                    stop = {"reason": "opening (normal stress reached zero)" if s.min_sigma <= 0
                            else "slip rate reversed", "t": s.t,
                            "x": [float(v) for v in fields["x"][bad]]}
            if pending >= args.chunk and not invalid:
                flush()
        if xdmf is not None and (s.step % args.xdmf_every == 0 or invalid):
            xdmf.write_function(td.displacement(), s.t)
        if bar is not None and td.step % 50 == 0:
            bar.update(50)
        if invalid:
            break
    run_time = time.perf_counter() - t_run
    if xdmf is not None:
        xdmf.close()
    flush()
    if bar is not None:
        bar.close()
    stop = comm.bcast(stop, root=0)

    if rank0:
        summary = _summarise(args, params, law, td, mode, label, exact, period, t_end, stop,
                             setup_time, run_time, steps_run, comm.size, theta_switch)
        print(json.dumps({"predicted": summary["predicted"], "measured": summary["measured"],
                          "relative_difference": summary["relative_difference"],
                          "end": summary["end"]}, indent=1))
    td.destroy()
    return 0


def _read_outputs(out: str) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The time series (structured array) and the concatenated interface frames."""
    data = np.genfromtxt(os.path.join(out, "timeseries.csv"), delimiter=",", names=True)
    data = np.atleast_1d(data)
    chunks = sorted(glob.glob(os.path.join(out, "interface_*.npz")))
    frames: dict[str, list] = {}
    x = None
    for path in chunks:
        with np.load(path) as z:
            x = z["x"]
            for key in ("t", "v", "tau", "sigma", "theta"):
                frames.setdefault(key, []).append(z[key])
    merged = {key: np.concatenate(v) for key, v in frames.items()}
    merged["x"] = x
    return data, merged


def _summarise(args, params, law, td, mode, label, exact, period, t_end, stop,  # noqa: ANN001
               setup_time, run_time, steps_run, nranks, theta_switch=None) -> dict:
    """Fit, nonlinear outcome, pictures and summary.json (rank 0)."""
    from forms.timedomain import fit_growth, linear_window, nonlinear_outcome

    data, frames = _read_outputs(args.out)
    t = data["t"]
    c = data["re_c"] + 1j * data["im_c"]
    start = args.fit_start if args.fit_start is not None else period
    t0, t1 = linear_window(t, c, data["max_dv"], exact.real, start, args.linear_limit,
                           args.fit_end)
    measured, rel = None, None
    try:
        fit = fit_growth(t, c, t0, t1)
        measured = {"re_lambda": fit.re_lambda, "im_lambda": fit.im_lambda,
                    "re_uncertainty": fit.re_uncertainty, "im_uncertainty": fit.im_uncertainty}
        rel = {"re": (fit.re_lambda - exact.real) / abs(exact.real),
               "im": (fit.im_lambda - exact.imag) / abs(exact.imag)}
        window = {"t_start": fit.t_start, "t_end": fit.t_end, "points": fit.points}
    except ValueError as err:
        window = {"t_start": t0, "t_end": t1, "points": 0, "note": str(err)}
    balance = data["energy_change"] - data["work_friction"]
    scale = max(float(np.max(np.abs(data["energy_change"]))), 1e-300)
    summary = {
        "command": " ".join([sys.executable] + sys.argv),
        "branch": label, "k": args.k,
        "predicted": {"re_lambda": exact.real, "im_lambda": exact.imag, "source":
                      "analytic.follow_branch (exact root of det M)"},
        "measured": measured,
        "relative_difference": rel,
        "semi_discrete": {"re_lambda": mode.eigenvalue.real, "im_lambda": mode.eigenvalue.imag,
                          "residual": mode.residual,
                          "note": "eigenvalue of the linearised lumped Q1/P1 system on this"
                                  " mesh (time continuous): measured - this is the time-step"
                                  " error, this - predicted the spatial error"},
        "window": window,
        "mesh": {"cell": args.cell, "nx": args.wavelengths * args.cells_per_wavelength,
                 "ny": args.ny, "length": td.strip.length, "height": params.H,
                 "unknowns": td.num_dofs},
        "dt": td.dt, "dt_stable": td.dt_stable,
        "friction_theta": {"linear_window": 0.5, "after": args.friction_theta,
                           "switched_at_t": theta_switch},
        "steps": int(data["step"][-1]) + 1 if len(data) else 0,
        "t_end_requested": t_end,
        "parameters": {**params.as_dict(), **law.summary(), "amplitude": args.amplitude,
                       "linear_limit": args.linear_limit},
        "end": stop,
        "energy_balance": {"max_abs_residual": float(np.max(np.abs(balance))),
                           "relative": float(np.max(np.abs(balance))) / scale},
        "nonlinear": (nonlinear_outcome(frames, data, args.k, f0=params.f)
                      if frames.get("t") is not None else None),
        "timing": {"setup_s": setup_time, "run_s": run_time, "steps_run": steps_run,
                   "steps_per_s": steps_run / run_time if run_time > 0 else None,
                   "ranks": nranks},
        "versions": _cli.versions(),
    }
    with open(os.path.join(args.out, "summary.json"), "w") as fh:
        json.dump(summary, fh, indent=1)
    if not args.no_plots:
        _plots(args, data, frames, summary, exact)
    return summary


def _save(fig, path: str, summary: dict) -> None:  # noqa: ANN001
    meta = {"Title": os.path.basename(path), "Description": summary["command"],
            "Comment": json.dumps(summary["parameters"], default=str)}
    fig.savefig(path, dpi=120, metadata=meta)


def _plots(args, data, frames, summary, exact) -> None:  # noqa: ANN001
    """growth.png, energy.png, spacetime_linear.png, spacetime.png."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = data["t"]
    c = np.abs(data["re_c"] + 1j * data["im_c"])
    w = summary["window"]
    title = (f"{summary['branch']}, k = {args.k:g}, bc = {args.bc}, f = {args.f:g},"
             f" gamma = {args.gamma:g}, Delta = {args.Delta:g}, H = {args.H:g}")
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.semilogy(t, c, label="|c_k(t)| (simulation)")
    if summary["measured"]:
        m = summary["measured"]
        i0 = int(np.searchsorted(t, w["t_start"]))
        tt = np.linspace(w["t_start"], w["t_end"], 50)
        ax.semilogy(tt, c[i0] * np.exp(m["re_lambda"] * (tt - t[i0])), "k--",
                    label=f"fit Re Lambda = {m['re_lambda']:.5f} +- {m['re_uncertainty']:.1e}")
        ax.semilogy(tt, c[i0] * np.exp(exact.real * (tt - t[i0])), "r:",
                    label=f"exact Re Lambda = {exact.real:.5f}")
        ax.axvspan(w["t_start"], w["t_end"], color="0.9")
    ax.set_xlabel("t (units D/v0)")
    ax.set_ylabel("|Fourier component of v/v0 at k|")
    ax.set_title(title, fontsize=8)
    ax.legend(fontsize=8)
    fig.tight_layout()
    _save(fig, os.path.join(args.out, "growth.png"), summary)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(7, 4))
    ax.plot(t, data["energy"], label="kinetic + strain (perturbation)")
    ax.plot(t, data["work_friction"], label="work of friction on the body")
    ax.plot(t, data["energy_change"] - data["work_friction"], label="balance residual")
    ax.set_xlabel("t")
    ax.set_ylabel("energy (units mu (c_s t0)^2 per unit depth)")
    ax.set_yscale("symlog", linthresh=max(1e-30, float(np.max(np.abs(data["energy"]))) * 1e-12))
    ax.set_title(title, fontsize=8)
    ax.legend(fontsize=8)
    fig.tight_layout()
    _save(fig, os.path.join(args.out, "energy.png"), summary)
    plt.close(fig)

    if frames.get("t") is None or len(frames["t"]) < 2:
        return
    ft, x = frames["t"], frames["x"]
    sel = (ft >= 0) & (ft <= w["t_end"])
    if sel.sum() >= 2:
        fig, ax = plt.subplots(figsize=(6, 5))
        scaled = (frames["v"][sel] - 1.0) * np.exp(-exact.real * ft[sel])[:, None]
        scaled /= max(float(np.max(np.abs(scaled))), 1e-300)
        im = ax.pcolormesh(x, ft[sel], scaled, cmap="RdBu_r", shading="nearest", vmin=-1,
                           vmax=1)
        fig.colorbar(im, ax=ax, label="(v/v0 - 1) exp(-Re Lambda t), normalised")
        ax.set_xlabel("x")
        ax.set_ylabel("t")
        ax.set_title("linear window: slip-rate perturbation, exact growth divided out\n"
                     + title, fontsize=8)
        fig.tight_layout()
        _save(fig, os.path.join(args.out, "spacetime_linear.png"), summary)
        plt.close(fig)
    _spacetime(plt, frames, np.ones_like(ft, dtype=bool), summary,
               "interface, whole run: " + title + f"; end: {summary['end']['reason']}",
               os.path.join(args.out, "spacetime.png"), log_v=False)
    period = 2 * np.pi / abs(exact.imag) if exact.imag else 1.0
    late = ft >= max(w["t_end"], ft[-1] - 6 * period)
    if late.sum() >= 2:
        _spacetime(plt, frames, late, summary, "nonlinear regime, last periods: " + title
                   + f"; end: {summary['end']['reason']}",
                   os.path.join(args.out, "spacetime_nonlinear.png"), log_v=True)


def _spacetime(plt, frames, sel, summary, suptitle, path, log_v) -> None:  # noqa: ANN001
    """Three space-time panels: slip rate, shear and normal traction perturbations."""
    from matplotlib.colors import LogNorm

    ft, x = frames["t"][sel], frames["x"]
    fig, axes = plt.subplots(1, 3, figsize=(13, 5), sharey=True)
    for ax, key, lab, cmap in ((axes[0], "v", "v/v0", "viridis"),
                               (axes[1], "tau", "(tau - tau0)/sigma0", "RdBu_r"),
                               (axes[2], "sigma", "(sigma - sigma0)/sigma0", "RdBu_r")):
        vals = frames[key][sel]
        if cmap == "RdBu_r":
            lim = max(float(np.max(np.abs(vals))), 1e-300)
            im = ax.pcolormesh(x, ft, vals, cmap=cmap, shading="nearest", vmin=-lim, vmax=lim)
        elif log_v:
            pos = np.clip(vals, 1e-6, None)
            im = ax.pcolormesh(x, ft, pos, cmap=cmap, shading="nearest",
                               norm=LogNorm(vmin=1e-6, vmax=float(pos.max())))
            lab += " (log, clipped at 1e-6)"
        else:
            im = ax.pcolormesh(x, ft, vals, cmap=cmap, shading="nearest")
        fig.colorbar(im, ax=ax, label=lab)
        ax.set_xlabel("x (sliding towards +x)")
    axes[0].set_ylabel("t")
    fig.suptitle(suptitle, fontsize=9)
    fig.tight_layout()
    _save(fig, path, summary)
    plt.close(fig)


if __name__ == "__main__":
    _cli.run(main)
