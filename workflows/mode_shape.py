"""Mode shape of the sliding strip in real space: files for ParaView and pictures.

Solves the Bloch-periodic strip (:mod:`forms.models.strip`) at one wavenumber ``k`` near a target
(on a rigid substrate, or on a deformable one of finite height: ``--mu2 --rho2 --beta2 --H2
--bc2``, both bodies meshed and drawn),
keeps the eigenvalue whose mode really carries ``exp(-i k x)`` (a one-wavelength cell also holds
``0, -k, 2k, ...``: see :func:`forms.mode_postprocessing.harmonic_content`), and writes to
``--out``:

- ``mode.xdmf`` (+ ``.h5``): ``Re(u exp(i Im(Lambda) t))`` over one period ``T = 2 pi/|Im
  Lambda|`` (``--phases`` steps, growth factored out; XDMF stores vertex values), for ParaView;
- ``mode_p2.pvd``: the complex mode at phase 0 at full polynomial degree (VTK Lagrange cells);
- ``mode_shape.png``: the deformed strip coloured by ``|u|`` (or ``--color stress``: the normal
  stress perturbation ``sigma_yy``), sliding and propagation directions marked; PyVista
  off-screen; ``mode_phases.png``: four phases of the period;
- ``interface_tractions.png`` and ``interface.csv``: shear and normal stress perturbations and
  slip along the interface (the bi-material coupling);
- ``mode.json``: parameters, eigenvalue, backward error, harmonic content, timings, versions.

Under ``mpirun -n N`` the strip is distributed; the writers use the mesh communicator and the
pictures are drawn on rank 0 from gathered data.

Example (the README picture)::

    ./run mpirun -n 2 python workflows/mode_shape.py --out workflows/results/mode_shape
"""

from __future__ import annotations

import argparse
import math
import os
import time

import numpy as np

# No display here: VTK >= 9.4 picks its window class from this (EGL, no X server attempt).
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
# VTK's wheel must be loaded before dolfinx's C++ library: the other way round, std::regex in
# vtkScalarBarActor aborts with std::bad_alloc (a libstdc++ clash, seen with vtk 9.7.2 and
# Debian's dolfinx 0.5.2). So pyvista is imported first, here.
import pyvista  # noqa: E402, F401, I001

import _cli  # noqa: E402
from _plot_mode import plot_mode  # noqa: E402
import _plots  # noqa: E402

import dolfinx.io  # noqa: E402

from analytic.numerics.branches import parse_branch_label  # noqa: E402
from analytic.numerics.tracking import Branch  # noqa: E402
from forms.studies import strip_mode  # noqa: E402

DEFAULT_K = 1.0
#: Options prefixes of the SLEPc objects: the strip solve and the cross-section model.
PETSC_PREFIXES = ("strip_", "xs_")
#: Files this workflow writes (an older run's folder holding only these may be overwritten).
OUTPUTS = ("mode.xdmf", "mode.h5", "mode_p2.pvd", "mode_p2*.vtu", "mode_p2*.pvtu",
           "mode_shape.png", "mode_phases.png", "interface_tractions.png", "interface.csv",
           "mode.json")


def build_parser() -> argparse.ArgumentParser:
    """Command-line options."""
    p = _cli.make_parser(__doc__, PETSC_PREFIXES)
    _cli.add_param_arguments(p)
    p.add_argument("--k", type=float, default=DEFAULT_K, help="wavenumber k > 0")
    p.add_argument("--most-unstable", action="store_true",
                   help="instead of --k: the k of largest growth of --branch on the --k-scan grid"
                        " (cross-section model)")
    p.add_argument("--k-scan", default="0.05:4:80", help="k grid for --most-unstable")
    p.add_argument("--branch", default="0-",
                   help="waveguide branch n and sign of Im Lambda_0 (e.g. 0-, 1+)")
    p.add_argument("--target", type=complex, default=None,
                   help="eigenvalue target (Python complex, e.g. 0.27-6.59j); default: the"
                        " cross-section eigenvalue of --branch at k")
    p.add_argument("--source", choices=("strip", "cross-section"), default="strip",
                   help="strip: solve the Bloch strip; cross-section: show Re(u_hat(y) exp(-ikx))"
                        " of the 1D model on the strip mesh, no strip solve")
    p.add_argument("--wavelengths", type=int, default=1, help="strip length in wavelengths")
    p.add_argument("--cells-per-wavelength", type=int, default=32, help="cells along x")
    p.add_argument("--ny", type=int, default=8, help="cells along y")
    p.add_argument("--grading", type=float, default=None,
                   help="top/bottom cell height ratio (>= 1; > 1 refines towards y = 0);"
                        " default: from k H as for the cross-section mesh (uniform for"
                        " k H <= 4, then k H / 4, at most 20)")
    p.add_argument("--degree", type=int, default=2, help="Lagrange degree")
    p.add_argument("--nev", type=int, default=8, help="eigenpairs computed near the target")
    p.add_argument("--phases", type=int, default=16, help="phases over one period in mode.xdmf")
    p.add_argument("--color", choices=("displacement", "stress"), default="displacement",
                   help="colour of the deformed strip: |u| or sigma_yy")
    p.add_argument("--no-render", action="store_true", help="skip the PyVista pictures")
    p.add_argument("--out", default="out/mode_shape", help="output directory")
    return p


def validate(args: argparse.Namespace):
    """Check every option before anything collective or any file is created."""
    params = _cli.params_from_args(args)
    _cli.require_finite_heights(params, "a finite strip", substrate=True)
    if params.two_body and args.source == "cross-section":
        raise _cli.ParameterError("--source = cross-section is for the rigid substrate (mu2 ="
                                  " inf); use --source strip")
    _cli.check_k(args.k, name="k")
    branch = parse_branch_label(args.branch, name="--branch")
    k_scan = _cli.parse_k(args.k_scan, name="--k-scan") if args.most_unstable else None
    _cli.check_branch_kh(params, max(k_scan) if args.most_unstable else args.k,
                         "--k-scan" if args.most_unstable else "--k")
    _cli.positive_int("--wavelengths", args.wavelengths, 1, 64)
    _cli.positive_int("--cells-per-wavelength", args.cells_per_wavelength, 2)
    _cli.positive_int("--ny", args.ny, 1)
    _cli.positive_int("--degree", args.degree, 1, 5)
    _cli.positive_int("--nev", args.nev, 1, 200)
    _cli.positive_int("--phases", args.phases, 1, 1000)
    if args.grading is not None and not (math.isfinite(args.grading) and args.grading >= 1.0):
        raise _cli.ParameterError(f"--grading = {args.grading} is outside its allowed range >= 1")
    if args.target is not None and not np.isfinite(args.target):
        raise _cli.ParameterError(f"--target = {args.target} is not a finite complex number")
    return params, branch, k_scan


def _write_outputs(args: argparse.Namespace, meta: dict, title: str, mode: strip_mode.ModeOnStrip,
                   params, strip) -> None:
    """XDMF/PVD files (collective), then CSV, PNGs and JSON on rank 0."""
    u, lam, comm = mode.u, mode.eigenvalue, strip.comm
    # ParaView: a period of phases (vertex values) and the full-degree complex mode.
    with _cli.atomic_files(args.out, ("mode.xdmf", "mode_p2.pvd"), comm) as tmp:
        with dolfinx.io.XDMFFile(comm, os.path.join(tmp, "mode.xdmf"), "w") as f:
            f.write_mesh(strip.mesh)
            for t, u_phase in strip_mode.phase_snapshots(u, lam, args.phases):
                f.write_function(u_phase, t=t)
        with dolfinx.io.VTKFile(comm, os.path.join(tmp, "mode_p2.pvd"), "w") as f:
            f.write_function(u, 0.0)
    data = strip_mode.interface_of(u, params)
    gathered = None if args.no_render else strip_mode.gather_mode(
        u, *strip_mode.stress_coefficients(u, params))
    if comm.rank != 0:
        return
    with _cli.atomic_open(os.path.join(args.out, "interface.csv"), "w") as fh:
        np.savetxt(fh, strip_mode.interface_table(data), fmt="%.12g", delimiter=",",
                   header=",".join(strip_mode.INTERFACE_COLUMNS), comments="")
    _plots.plot_interface(data, os.path.join(args.out, "interface_tractions.png"), title,
                          meta)
    if gathered is not None:
        for name, fractions in (("mode_shape.png", (0.0,)),
                                ("mode_phases.png", (0.0, 0.25, 0.5, 0.75))):
            path = os.path.join(args.out, name)
            frames = strip_mode.phase_frames(gathered["point_data"], lam.imag, fractions)
            plot_mode(gathered, frames, path, title, args.color, lam, meta["k"], params.H,
                      strip.length, fractions, strip.depth)
            _cli.add_png_metadata(path, meta, title)


def run_parameters(args: argparse.Namespace, params, branch: tuple[int, int]) -> dict:
    """Everything that determines the numbers (the folder's record)."""
    return {"params": params.as_dict(), "k": args.k, "most_unstable": args.most_unstable,
            "k_scan": args.k_scan if args.most_unstable else None, "branch": list(branch),
            "target": None if args.target is None else [args.target.real, args.target.imag],
            "source": args.source, "wavelengths": args.wavelengths,
            "cells_per_wavelength": args.cells_per_wavelength, "ny": args.ny,
            "grading": args.grading, "degree": args.degree, "nev": args.nev,
            "phases": args.phases, "color": args.color, "render": not args.no_render}


def main(comm=None, argv: list[str] | None = None) -> int:
    """Run the workflow; returns the exit code (0, or 1 if no suitable mode converged)."""
    args, comm = _cli.start(build_parser(), argv, comm)
    params, branch, k_scan = validate(args)
    with _cli.RunFolder(comm, args.out, "mode_shape", run_parameters(args, params, branch),
                        outputs=OUTPUTS):
        return _run(comm, args, params, branch, k_scan)


def _run(comm, args: argparse.Namespace, params, branch: tuple[int, int], k_scan) -> int:
    t_start = time.perf_counter()
    label = Branch(*branch).label
    k, lam_branch = strip_mode.branch_eigenvalue(comm, params, branch, float(args.k), k_scan)
    if args.most_unstable:
        _cli.say(f"most unstable on the k grid (branch {label}): k = {k:.6g},"
                 f" Lambda = {lam_branch:.6g}")
    xs = strip_mode.cross_section_near(params, k, lam_branch, args.target)
    start = xs.eigenvalue if xs is not None else lam_branch  # two bodies: the exact root
    if not np.isfinite(start) and (args.source == "cross-section" or args.target is None):
        _cli.say(f"error: branch {label} not followed to k = {k:.6g}; give --target", err=True)
        return 1
    strip = strip_mode.bloch_strip(comm, params, k, args.wavelengths, args.cells_per_wavelength,
                                   args.ny, args.grading)
    meta = strip_mode.mode_metadata(strip, params, k, label, most_unstable=args.most_unstable,
                                    wavelengths=args.wavelengths, degree=args.degree, xs=xs,
                                    versions=_cli.versions(), command=_cli.command())
    if args.source == "strip":
        target = args.target if args.target is not None else start
        solved = strip_mode.solve_bloch_mode(strip, params, k, args.degree, target, args.nev)
        _cli.say(f"k = {k:.6g}, target = {target:.6g}: {len(solved.eigenvalues)} converged"
                 f" ({solved.reason}); harmonics m = {solved.harmonics}")
        if solved.mode is None:
            _cli.say("error: no converged eigenvalue carries exp(-i k x) near the target; try"
                     " --target or a larger --nev", err=True)
            return 1
        mode = solved.mode
        what = f"Bloch strip (2D FE, P{args.degree})"
    else:
        mode = strip_mode.cross_section_on_strip(strip, xs, args.degree)
        what = "cross-section model (1D FE, P3) as Re(u_hat(y) exp(-ikx))"
    lam = mode.eigenvalue
    meta.update(mode.meta)
    title = f"{what}, k = {k:.4g}, branch {label}: Lambda = {lam.real:.6f} {lam.imag:+.6f}i"
    _write_outputs(args, meta, title, mode, params, strip)
    if comm.rank == 0:
        meta["timings"]["total"] = time.perf_counter() - t_start
        _cli.write_json(os.path.join(args.out, "mode.json"), meta, indent=2)
        print(f"{meta['source']}\nLambda = {lam:.10g} (relative residual"
              f" {meta['residual']:.1e}); wrote {args.out}/", flush=True)
    return 0


if __name__ == "__main__":
    _cli.run(main)
