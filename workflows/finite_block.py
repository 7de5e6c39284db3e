"""Finite slider: global modes of a block of length L on the substrate, versus the infinite strip.

The block ``0 < x < L``, ``0 < y < H`` has the same physics as the strip (:mod:`forms.strip`,
``k = None``: no Bloch map), with lateral ends ``--lateral free`` (traction-free, default),
``roller`` (``u_x = 0``) or ``clamped`` (``u = 0``). For every ``L`` of ``--lengths`` the
eigenvalues near the infinite strip's branch (cross-section model at several ``k`` around its
most unstable wavenumber) are computed and the most unstable one is kept. Written to ``--out``:

- ``finite_block.csv``: ``L, re_lambda, im_lambda, residual, candidates`` plus the infinite-strip
  reference ``re_lambda_inf, im_lambda_inf, k_inf`` (rows appended as each L finishes;
  ``--resume`` skips the lengths already there);
- ``finite_block.png``: ``Re Lambda`` of the most unstable block mode against ``L`` with the
  infinite-strip value, and ``|Lambda_block - Lambda_inf|`` on log axes;
- ``block_mode.png``: that mode for the largest ``L``: stresses and slip along the interface;
- ``finite_block.json``: parameters, reference, timings, versions, and the long-block limit
  from the cross-section model alone (Kulikovskii's condition: the global mode of a long
  block is made of two spatial waves ``k1, k2`` with equal spatial growth ``Im k1 = Im k2``;
  its growth rate is the largest on that curve), drawn in ``finite_block.png`` too.

Example::

    ./run mpirun -n 2 python workflows/finite_block.py --out workflows/results/finite_block
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import sys
import time

import _cli
import mode_shape  # imports pyvista before dolfinx (see there)
import numpy as np

COLUMNS = ["L", "re_lambda", "im_lambda", "residual", "candidates", "re_lambda_inf",
           "im_lambda_inf", "k_inf"]


def build_parser() -> argparse.ArgumentParser:
    """Command-line options."""
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    _cli.add_param_arguments(p)
    p.add_argument("--lengths", default="2,4,8,16,32,64,128", help="block lengths L (comma list)")
    p.add_argument("--lateral", choices=("free", "roller", "clamped"), default="free",
                   help="lateral ends")
    p.add_argument("--branch", default="0-", help="infinite-strip branch used as reference")
    p.add_argument("--k-scan", default="0.05:4:80",
                   help="k grid for the infinite strip's most unstable k")
    p.add_argument("--cells-per-unit", type=int, default=8, help="cells per unit length in x")
    p.add_argument("--ny", type=int, default=8, help="cells along y")
    p.add_argument("--degree", type=int, default=2, help="Lagrange degree")
    p.add_argument("--targets", type=int, default=5,
                   help="shift targets per L (infinite-strip Lambda at k around k_inf)")
    p.add_argument("--nev", type=int, default=6, help="eigenpairs per target")
    p.add_argument("--no-kulikovskii", action="store_true",
                   help="skip the long-block limit from the cross-section model")
    p.add_argument("--resume", action="store_true", help="keep the rows already in the CSV")
    p.add_argument("--out", default="finite_block", help="output directory")
    return p


def validate(args: argparse.Namespace):
    """Check every option before anything collective or any file is created."""
    params = _cli.params_from_args(args)
    if math.isinf(params.H):
        raise _cli.ParameterError("H = inf is outside its allowed range here (a finite block)")
    lengths = _cli.parse_k(args.lengths, name="--lengths")
    branch = mode_shape.parse_branch(args.branch)
    k_scan = _cli.parse_k(args.k_scan, name="--k-scan")
    _cli.positive_int("--cells-per-unit", args.cells_per_unit, 1)
    _cli.positive_int("--ny", args.ny, 1)
    _cli.positive_int("--degree", args.degree, 1, 5)
    _cli.positive_int("--targets", args.targets, 1, 50)
    _cli.positive_int("--nev", args.nev, 1, 200)
    return params, np.unique(lengths), branch, k_scan


def _read_done(path: str) -> dict[float, dict]:
    if not os.path.exists(path):
        return {}
    with open(path) as f:
        return {float(r["L"]): r for r in csv.DictReader(f)}


def extrapolate(L: np.ndarray, values: np.ndarray, points: int = 3) -> tuple[float, float]:
    """Fit ``v = v_inf + c / L`` to the ``points`` largest lengths; returns ``(v_inf, c)``."""
    order = np.argsort(L)[-points:]
    if len(order) < 2:
        return float("nan"), float("nan")
    c, v_inf = np.polyfit(1.0 / L[order], values[order], 1)
    return float(v_inf), float(c)


def plot_convergence(rows: list[dict], lam_inf: complex, k_inf: float, out_png: str,
                     title: str, meta: dict, kul: dict | None = None) -> None:
    """Growth rate of the most unstable block mode against L (rank 0)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    L = np.array([float(r["L"]) for r in rows])
    lam = np.array([complex(float(r["re_lambda"]), float(r["im_lambda"])) for r in rows])
    order = np.argsort(L)
    L, lam = L[order], lam[order]
    g_inf, c = extrapolate(L, lam.real)
    fig, axes = plt.subplots(1, 2, figsize=(11.5, 4.3))
    ax = axes[0]
    ax.plot(L, lam.real, "o-", label="finite block: most unstable Re $\\Lambda$")
    ax.axhline(lam_inf.real, color="k", ls="--",
               label=f"infinite strip: max over k of Re $\\Lambda$ = {lam_inf.real:.4f}"
                     f" (k = {k_inf:.3g})")
    if np.isfinite(g_inf):
        ax.axhline(g_inf, color="tab:red", ls=":",
                   label=f"block, $L \\to \\infty$ (fit $a + b/L$): {g_inf:.4f}")
    if kul is not None:
        ax.axhline(kul["lambda"][0], color="tab:green", ls="-.", lw=1,
                   label="Kulikovskii limit (1D model, Im $k_1$ = Im $k_2$):"
                         f" {kul['lambda'][0]:.4f}")
    ax.set_xscale("log")
    ax.set_xlabel("block length $L$ (units $c_s t_0$)")
    ax.set_ylabel("growth rate Re $\\Lambda$")
    ax.legend(fontsize=8, loc="lower right")
    ax.set_title(title, fontsize=9)
    ax = axes[1]
    ax.plot(1.0 / L, lam.real, "o", label="finite block")
    if np.isfinite(g_inf):
        xx = np.linspace(0, 1.0 / L.min(), 50)
        ax.plot(xx, g_inf + c * xx, "r:", label=f"{g_inf:.4f} {c:+.3f}/L (3 largest L)")
    ax.axhline(lam_inf.real, color="k", ls="--", label="infinite strip, max over k")
    if kul is not None:
        ax.axhline(kul["lambda"][0], color="tab:green", ls="-.", lw=1, label="Kulikovskii limit")
    ax.set_xlabel("$1/L$")
    ax.set_ylabel("Re $\\Lambda$")
    ax.set_xlim(left=0)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out_png, dpi=130, metadata={"Title": title, "Description": json.dumps(meta)})
    plt.close(fig)


def main(comm=None, argv: list[str] | None = None) -> int:
    """Run the scan over block lengths; exit code 1 if some length had no converged mode."""
    parser = build_parser()
    args, petsc_args = parser.parse_known_args(argv)
    bad = [a for a in petsc_args if a.startswith("--")]
    if petsc_args and not petsc_args[0].startswith("-"):
        bad.insert(0, petsc_args[0])
    if bad:
        parser.error(f"unrecognized arguments: {' '.join(bad)}")
    params, lengths, branch, k_scan = validate(args)

    import slepc4py

    slepc4py.init(sys.argv[:1] + petsc_args)
    import logging

    from mpi4py import MPI

    from forms.strip import (
        build_strip_problem,
        kulikovskii_limit,
        most_unstable_k,
        normalise,
        solve_modes,
    )
    from forms.tracking import Branch, waveguide_lambda
    from meshes.strip import strip_mesh

    logging.getLogger().setLevel(logging.WARNING)
    comm = comm or MPI.COMM_WORLD
    t_start = time.perf_counter()
    b = Branch(*branch)

    def wg(k: float) -> complex:
        return waveguide_lambda(params, b, k)

    # Infinite strip: most unstable k of the branch on the grid, refined on a finer grid.
    k0, _ = most_unstable_k(params, wg, k_scan)
    dk = (k_scan[-1] - k_scan[0]) / max(len(k_scan) - 1, 1)
    fine = np.linspace(max(k0 - dk, 1e-3), k0 + dk, 21)
    k_inf, lam_inf = most_unstable_k(params, wg, fine)
    k_inf, lam_inf = comm.bcast((k_inf, lam_inf), root=0)
    ks = np.linspace(0.5 * k_inf, 1.5 * k_inf, args.targets) if args.targets > 1 else [k_inf]
    from forms.strip import cross_section_mode

    targets = []
    for kt in ks:
        xs = cross_section_mode(params, float(kt), wg(float(kt)))
        if xs is not None:
            targets.append(xs.eigenvalue)
    targets = comm.bcast(targets, root=0)

    csv_path = os.path.join(args.out, "finite_block.csv")
    done = _read_done(csv_path) if (args.resume and comm.rank == 0) else {}
    done = comm.bcast(done, root=0)
    if comm.rank == 0:
        os.makedirs(args.out, exist_ok=True)
        if not done:
            with open(csv_path, "w", newline="") as f:
                csv.writer(f).writerow(COLUMNS)
        print(f"infinite strip, branch {b.label}: max Re Lambda = {lam_inf:.8g} at k ="
              f" {k_inf:.6g}", flush=True)
    todo = [L for L in lengths if float(L) not in done]
    bar = None
    if comm.rank == 0:
        from tqdm import tqdm

        bar = tqdm(total=len(todo), desc="block lengths", file=sys.stderr)
    failed = 0
    timings = {}
    last = None
    for L in todo:
        t0 = time.perf_counter()
        nx = max(2, int(round(args.cells_per_unit * L)))
        strip = strip_mesh(comm, float(L), params.H, nx, args.ny)
        problem = build_strip_problem(strip, params, k=None, degree=args.degree,
                                      lateral=args.lateral)
        found = []
        for tgt in targets:
            for m in solve_modes(problem, tgt, nev=args.nev, prefix="block_"):
                if all(abs(m.eigenvalue - f.eigenvalue) > 1e-8 * abs(m.eigenvalue)
                       for f in found):
                    found.append(m)
                else:
                    m.vector.destroy()
        if found:
            best = max(found, key=lambda m: m.eigenvalue.real)
            row = [float(L), best.eigenvalue.real, best.eigenvalue.imag, best.residual,
                   len(found), lam_inf.real, lam_inf.imag, k_inf]
            if L == lengths[-1]:
                u = problem.to_function(best.vector)
                normalise(u)
                last = (u, best.eigenvalue, float(L))
        else:
            failed += 1
            row = [float(L), float("nan"), float("nan"), float("nan"), 0, lam_inf.real,
                   lam_inf.imag, k_inf]
        for m in found:
            m.vector.destroy()
        if comm.rank == 0:
            with open(csv_path, "a", newline="") as f:
                csv.writer(f).writerow([f"{v:.12g}" if isinstance(v, float) else v
                                        for v in row])
            bar.update(1)
        timings[f"{float(L):g}"] = time.perf_counter() - t0
        problem.destroy()
    if bar is not None:
        bar.close()

    meta = {"workflow": "finite_block", "params": params.as_dict(), "lateral": args.lateral,
            "branch": b.label, "k_inf": k_inf, "lambda_inf": [lam_inf.real, lam_inf.imag],
            "targets": [[t.real, t.imag] for t in targets], "cells_per_unit": args.cells_per_unit,
            "ny": args.ny, "degree": args.degree, "ranks": comm.size, "timings": timings,
            "versions": mode_shape.versions(), "command": " ".join(sys.argv)}
    title = (f"finite block ({args.lateral} ends, bc = {params.bc}, H = {params.H:g}),"
             f" P{args.degree} strip FE")
    interface = None
    if last is not None:
        from forms.strip import interface_stresses

        interface = interface_stresses(last[0], params.lame_lambda, params.H)
    if comm.rank == 0:
        rows = list(_read_done(csv_path).values())
        rows = [r for r in rows if r["re_lambda"] not in ("nan", "")]
        kul = None
        if rows and not args.no_kulikovskii:
            big = max(rows, key=lambda r: float(r["L"]))
            try:
                kul = kulikovskii_limit(params, complex(float(big["re_lambda"]),
                                                        float(big["im_lambda"])))
            except RuntimeError as err:  # reported, the run goes on
                print(f"Kulikovskii limit not computed: {err}", file=sys.stderr, flush=True)
            if kul is not None:
                kul["from_block_length"] = float(big["L"])
                meta["kulikovskii"] = kul
                print(f"Kulikovskii limit (cross-section): Lambda = {kul['lambda'][0]:.6f}"
                      f" {kul['lambda'][1]:+.6f}i (k1 = {complex(*kul['k1_at_block']):.4f},"
                      f" k2 = {complex(*kul['k2_at_block']):.4f})", flush=True)
        if rows:
            L_all = np.array([float(r["L"]) for r in rows])
            g_all = np.array([float(r["re_lambda"]) for r in rows])
            meta["extrapolated_growth"] = extrapolate(L_all, g_all)[0]
            plot_convergence(rows, lam_inf, k_inf, os.path.join(args.out, "finite_block.png"),
                             title, meta, kul)
        if interface is not None:
            _, lam_b, L_b = last
            mode_shape.plot_interface(
                interface, os.path.join(args.out, "block_mode.png"),
                f"most unstable mode of a block, L = {L_b:g}, {args.lateral} ends:"
                f" Lambda = {lam_b.real:.5f} {lam_b.imag:+.5f}i", meta)
        meta["timings"]["total"] = time.perf_counter() - t_start
        with open(os.path.join(args.out, "finite_block.json"), "w") as f:
            json.dump(meta, f, indent=2)
        print(f"wrote {args.out}/", flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    _cli.run(main)
