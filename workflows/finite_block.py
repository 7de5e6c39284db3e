"""Finite slider: global modes of a block of length L on the substrate, versus the infinite strip.

The block ``0 < x < L``, ``0 < y < H`` has the same physics as the strip (:mod:`forms.models.strip`,
``k = None``: no Bloch map), with lateral ends ``--lateral free`` (traction-free, default),
``roller`` (``u_x = 0``) or ``clamped`` (``u = 0``); on a rigid substrate, or on a deformable one
of finite height (``--mu2 --rho2 --beta2 --H2 --bc2``: a substrate block of the same length, the
reference from the exact two-body roots, no Kulikovskii limit). For every ``L`` of ``--lengths`` the
eigenvalues near the infinite strip's branches (``--branches``, cross-section model at several
``k`` around each one's most unstable wavenumber) are computed and the most unstable one is
kept. That is ``--search targets`` (the default; ``--search grid``: near a line of targets
across a frequency band instead, ``--grid``); ``--search complete`` instead returns every
eigenvalue in a box (``--box``, default :func:`forms.studies.block.auto_box`) with its certificate
(:func:`forms.studies.block.block_spectrum`: argument-principle count of ``det T_h`` == found,
conjugate symmetry, P(p+1) estimate), with no infinite-strip target. Written to ``--out``:

- ``finite_block.csv``: ``L, re_lambda, im_lambda, residual, candidates`` plus the infinite-strip
  reference ``re_lambda_inf, im_lambda_inf, k_inf`` (by increasing L, rewritten as each L
  finishes from ``raw/L*.json``, one part per finished length (:mod:`_parts`): ``--resume``
  skips the lengths there);
- ``finite_block_spectrum.csv`` (complete search): every eigenvalue in the box per length, with
  ``found, counted, closed``; the per-length certificate is in ``finite_block.json``
  (``certificates``); ``finite_block_spectrum.png``: those eigenvalues and the boxes;
- ``finite_block.png``: ``Re Lambda`` of the most unstable block mode against ``L`` with the
  infinite-strip value, and ``|Lambda_block - Lambda_inf|`` on log axes;
- ``block_mode.png``: that mode for the largest ``L``: stresses and slip along the interface;
- ``finite_block.json``: parameters, reference, timings, versions, and the long-block limit
  from the cross-section model alone (:func:`forms.solvers.spatial_stability.kulikovskii_limit`: the
  global mode of a long block is made of two spatial waves ``k1, k2``; either they have equal
  spatial growth ``Im k1 = Im k2`` (Kulikovskii's condition, convective instability with
  reflections) or they pinch, ``k1 = k2`` (saddle point, absolute instability)), drawn in
  ``finite_block.png`` too.

Example::

    ./run mpirun -n 2 python workflows/finite_block.py --out workflows/results/finite_block
"""

from __future__ import annotations

import argparse
import csv
import os
import sys
import time

import _block_search
import _cli
import _plots  # matplotlib only: no pyvista/VTK here, so no import order to keep
import numpy as np
from tqdm import tqdm

from analytic.numerics.branches import parse_branch_label
from forms.studies import block
from forms.studies.strip_mode import interface_of

#: Options prefixes of the SLEPc objects: block target solves, block region solve and its count
#: (MUMPS log det) and its elastic reference, cross-section model, spatial roots.
PETSC_PREFIXES = ("block_", "block_region_", "block_region_det_", "block_region_det_ref_", "xs_",
                  "kroots_")
#: Files this workflow writes.
OUTPUTS = ("finite_block.csv", "finite_block_spectrum.csv", "finite_block_spectrum.png",
           "finite_block.png", "block_mode.png", "finite_block.json", "raw",
           _block_search.JOURNALS)
COLUMNS = list(block.ROW_COLUMNS)


def build_parser() -> argparse.ArgumentParser:
    """Command-line options."""
    p = _cli.make_parser(__doc__, PETSC_PREFIXES)
    _cli.add_param_arguments(p)
    p.add_argument("--lengths", default="2,4,8,16,32,64,128", help="block lengths L (comma list)")
    p.add_argument("--lateral", choices=("free", "roller", "clamped"), default="free",
                   help="lateral ends")
    p.add_argument("--branches", default="0-,0+",
                   help="infinite-strip branches whose most unstable growth is the reference and"
                        " whose eigenvalues seed the shift targets")
    p.add_argument("--k-scan", default="0.05:4:80",
                   help="k grid for the infinite strip's most unstable k")
    p.add_argument("--cells-per-unit", type=int, default=8, help="cells per unit length in x")
    p.add_argument("--ny", type=int, default=8, help="cells along y")
    p.add_argument("--degree", type=int, default=2, help="Lagrange degree")
    p.add_argument("--targets", type=int, default=3,
                   help="shift targets per L (infinite-strip Lambda at k around k_inf)")
    p.add_argument("--nev", type=int, default=6, help="eigenpairs per target")
    _block_search.add_arguments(p)
    p.add_argument("--no-kulikovskii", action="store_true",
                   help="skip the long-block limit from the cross-section model")
    p.add_argument("--resume", action="store_true",
                   help="keep the lengths already finished (raw/L*.json; same parameters "
                        "required; --lengths may differ: only the missing lengths are computed);"
                        " a complete search's count stopped part way continues from its "
                        "samples (count_samples/L*.csv)")
    p.add_argument("--out", default="out/finite_block", help="output directory")
    return p


def validate(args: argparse.Namespace):
    """Check every option before anything collective or any file is created."""
    params = _cli.params_from_args(args)
    _cli.require_finite_heights(params, "a finite block", substrate=True)
    lengths = _cli.parse_k(args.lengths, name="--lengths")
    branches = [parse_branch_label(b, name="--branches") for b in args.branches.split(",")
                if b.strip()]
    if not branches:
        raise _cli.ParameterError("--branches is empty (give e.g. 0-,0+)")
    k_scan = _cli.parse_k(args.k_scan, name="--k-scan")
    _cli.positive_int("--cells-per-unit", args.cells_per_unit, 1)
    _cli.positive_int("--ny", args.ny, 1)
    _cli.positive_int("--degree", args.degree, 1, 5)
    _cli.positive_int("--targets", args.targets, 1, 50)
    _cli.positive_int("--nev", args.nev, 1, 200)
    _block_search.parse_box(args.box, args.half)
    _block_search.parse_grid(args.grid)
    _cli.check_block_size(float(np.max(lengths)), args.cells_per_unit, args.ny, args.degree,
                          params.two_body)
    return params, np.unique(lengths), branches, k_scan


def _write_table(path: str, done: dict[float, dict], out: str, certificates: dict) -> None:
    """``finite_block.csv`` and the complete search's spectrum CSV from the parts (rank 0)."""
    with _cli.atomic_open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(COLUMNS)
        w.writerows(done[L]["row"] for L in sorted(done))
    _block_search.write_spectrum(out, certificates)


def plot_convergence(L: np.ndarray, lam: np.ndarray, g_inf: float, order_p: float,
                     lam_inf: complex, k_inf: float, out_png: str, title: str, meta: dict,
                     kul: dict | None = None) -> None:
    """Growth rate of the most unstable block mode against L (rank 0).

    ``L``, ``lam``: the converged lengths, sorted, and their eigenvalues
    (:func:`forms.studies.block.converged_rows`); ``g_inf``, ``order_p``: the extrapolated limit
    and its
    order (:func:`forms.studies.block.extrapolate`).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11.5, 4.3))
    ax = axes[0]
    ax.plot(L, lam.real, "o-", label="finite block: most unstable Re $\\Lambda$"
            " (labels: |Im $\\Lambda$|, which tell the thickness modes apart)")
    for x, z in zip(L, lam, strict=True):
        ax.annotate(f"{abs(z.imag):.3g}", (x, z.real), textcoords="offset points",
                    xytext=(0, 6), ha="center", fontsize=7)
    ax.axhline(lam_inf.real, color="k", ls="--",
               label=f"infinite strip ({meta.get('reference_branch', '')}): max over k of"
                     f" Re $\\Lambda$ = {lam_inf.real:.5f} (k = {k_inf:.4g})")
    if np.isfinite(g_inf):
        ax.axhline(g_inf, color="tab:red", ls=":",
                   label=f"block, $L \\to \\infty$ (Richardson, order {order_p:.2f}):"
                         f" {g_inf:.5f}")
    if kul is not None:
        what = ("Kulikovskii limit (1D model, Im $k_1$ = Im $k_2$)" if kul["type"] ==
                "kulikovskii" else "saddle point (1D model, $k_1 = k_2$)")
        ax.axhline(kul["lambda"][0], color="tab:green", ls="-.", lw=1,
                   label=f"{what}: {kul['lambda'][0]:.5f}")
    ax.set_xscale("log")
    ax.set_xlabel("block length $L$ (units $c_s t_0$)")
    ax.set_ylabel("growth rate Re $\\Lambda$")
    ax.legend(fontsize=8, loc="lower right")
    ax.set_title(title, fontsize=9)
    ax = axes[1]
    gap = np.abs(lam.real - (g_inf if np.isfinite(g_inf) else lam_inf.real))
    ax.loglog(L, gap, "o-", label="|Re $\\Lambda_L$ - limit|")
    if len(L) >= 2 and np.isfinite(order_p):
        ax.loglog(L, gap[-1] * (L / L[-1]) ** -order_p, "k:", lw=1,
                  label=f"$\\propto L^{{-{order_p:.2f}}}$")
    ax.set_xlabel("block length $L$")
    ax.set_ylabel("distance to the extrapolated limit")
    ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    _cli.save_figure(fig, out_png, dpi=130, metadata=_cli.png_metadata(meta, title))
    plt.close(fig)


def run_parameters(args: argparse.Namespace, params, branches) -> dict:
    """What determines the rows (the folder's record; ``--resume`` must match it).

    Not ``--lengths``: every row is one length, so a resumed run may add lengths.
    """
    return {"params": params.as_dict(), "lateral": args.lateral,
            "branches": [list(b) for b in branches], "k_scan": args.k_scan,
            "cells_per_unit": args.cells_per_unit, "ny": args.ny, "degree": args.degree,
            "targets": args.targets, "nev": args.nev, **_block_search.record(args)}


def main(comm=None, argv: list[str] | None = None) -> int:
    """Run the scan over block lengths.

    Exit code 1 if some length failed: no converged mode (``--search targets``) or a count that
    did not close (``--search complete``).
    """
    args, comm = _cli.start(build_parser(), argv, comm)
    params, lengths, branches, k_scan = validate(args)
    with _cli.RunFolder(comm, args.out, "finite_block", run_parameters(args, params, branches),
                        resume=args.resume, resumable=True, outputs=OUTPUTS) as run:
        return _run(comm, args, run, params, lengths, branches, k_scan)


def _run(comm, args: argparse.Namespace, run: _cli.RunFolder, params, lengths, branches,
         k_scan) -> int:
    t_start = time.perf_counter()
    parts = run.parts("raw", "L*", payloads=True)  # one per finished length (--resume)
    done = {float(d["L"]): d for d in parts.present.values()}
    todo = [L for L in lengths if float(L) not in done]
    _cli.say_plan(comm, f"the infinite strip's reference, then {len(todo)} block length(s)",
                  block.estimate_seconds([_cli.block_unknowns(L, args.cells_per_unit, args.ny,
                                          args.degree, params.two_body) for L in todo],
                                         _block_search.target_count(args), args.search,
                                         len(k_scan), len(branches)))
    ref = block.infinite_strip_reference(comm, params, branches, k_scan, args.targets)
    csv_path = os.path.join(args.out, "finite_block.csv")
    json_path = os.path.join(args.out, "finite_block.json")
    for lb_, kb_, zb_ in ref.per_branch:
        _cli.say(f"infinite strip, branch {lb_}: max Re Lambda = {zb_:.8g} at k = {kb_:.6g}")
    bar = tqdm(total=len(todo), desc="block lengths", file=sys.stderr) if comm.rank == 0 else None
    # per-L times and certificates of the lengths kept from the earlier run
    timings = {f"{L:g}": d["seconds"] for L, d in done.items()}
    certificates = {f"{L:g}": d["certificate"] for L, d in done.items() if d["certificate"]}
    if comm.rank == 0:
        _write_table(csv_path, done, args.out, certificates)
    failed, last = 0, None
    for L in todo:
        t0 = time.perf_counter()
        mode, ok = _block_search.solve_length(comm, args, params, float(L), ref,
                                          bool(L == lengths[-1]), certificates)
        failed += not ok
        last = mode if mode.u is not None else last
        timings[f"{float(L):g}"] = time.perf_counter() - t0
        if comm.rank == 0:
            done[float(L)] = _block_search.save_length(parts, args.out, float(L), {
                "L": float(L), "seconds": timings[f"{float(L):g}"], "certificate":
                certificates.get(f"{float(L):g}"), "row": [f"{v:.12g}" if isinstance(v, float)
                                                          else v for v in mode.row(ref)]})
            _write_table(csv_path, done, args.out, certificates)
            bar.update(1)
    if bar is not None:
        bar.close()

    meta = {"workflow": "finite_block", "params": params.as_dict(), "lateral": args.lateral,
            **ref.record(), "cells_per_unit": args.cells_per_unit, "ny": args.ny,
            "degree": args.degree,
            "ranks": comm.size, "search": args.search, "certificates": certificates,
            "timings": timings, "versions": _cli.versions(),
            "command": _cli.command()}
    title = (f"finite block ({args.lateral} ends, bc = {params.bc}, H = {params.H:g}"
             + (f"; substrate mu2 = {params.mu2:g}, H2 = {params.H2:g}" if params.two_body
                else "") + f"), P{args.degree} strip FE")
    interface = None
    if last is not None:
        interface = interface_of(last.u, params)
    if comm.rank == 0:
        L_all, lam_all = block.converged_rows([dict(zip(COLUMNS, d["row"], strict=True))
                                               for d in done.values()])
        kul = None
        if len(L_all) and not args.no_kulikovskii:
            try:
                kul = block.long_block_limit(params, L_all, lam_all)
            except RuntimeError as err:  # reported, the run goes on
                print(f"Kulikovskii limit not computed: {err}", file=sys.stderr, flush=True)
            if kul is not None:
                meta["kulikovskii"] = kul
                print(f"long-block limit ({kul['type']}, cross-section): Lambda ="
                      f" {kul['lambda'][0]:.6f} {kul['lambda'][1]:+.6f}i (k1 ="
                      f" {complex(*kul['k1_at_block']):.4f}, k2 ="
                      f" {complex(*kul['k2_at_block']):.4f})", flush=True)
        if len(L_all):
            L_tail, lam_tail = block.same_mode_tail(L_all, lam_all)  # one global mode
            g_inf, order_p = block.extrapolate(L_tail, lam_tail.real)
            meta["extrapolated_growth"], meta["extrapolation_order"] = g_inf, order_p
            plot_convergence(L_all, lam_all, g_inf, order_p, ref.lam_inf, ref.k_inf,
                             os.path.join(args.out, "finite_block.png"), title, meta, kul)
        _block_search.plot_spectrum(args.out, certificates, ref.lam_inf, title, meta)
        if interface is not None:
            _plots.plot_interface(
                interface, os.path.join(args.out, "block_mode.png"),
                f"most unstable mode of a block, L = {last.length:g}, {args.lateral} ends:"
                f" Lambda = {last.eigenvalue.real:.5f} {last.eigenvalue.imag:+.5f}i", meta)
        meta["timings"]["total (this run)"] = time.perf_counter() - t_start
        with _cli.atomic_open(json_path, "w") as f:
            _cli.json_dump(meta, f, indent=2)
        print(f"wrote {args.out}/", flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    _cli.run(main)
