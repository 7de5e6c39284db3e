"""Finite slider: global modes of a block of length L on the substrate, versus the infinite strip.

The block ``0 < x < L``, ``0 < y < H`` has the same physics as the strip (:mod:`forms.strip`,
``k = None``: no Bloch map), with lateral ends ``--lateral free`` (traction-free, default),
``roller`` (``u_x = 0``) or ``clamped`` (``u = 0``). For every ``L`` of ``--lengths`` the
eigenvalues near the infinite strip's branches (``--branches``, cross-section model at several
``k`` around each one's most unstable wavenumber) are computed and the most unstable one is
kept. Written to ``--out``:

- ``finite_block.csv``: ``L, re_lambda, im_lambda, residual, candidates`` plus the infinite-strip
  reference ``re_lambda_inf, im_lambda_inf, k_inf`` (rows appended as each L finishes;
  ``--resume`` skips the lengths already there);
- ``finite_block.png``: ``Re Lambda`` of the most unstable block mode against ``L`` with the
  infinite-strip value, and ``|Lambda_block - Lambda_inf|`` on log axes;
- ``block_mode.png``: that mode for the largest ``L``: stresses and slip along the interface;
- ``finite_block.json``: parameters, reference, timings, versions, and the long-block limit
  from the cross-section model alone (:func:`forms.spatial_stability.kulikovskii_limit`: the
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
import json
import math
import os
import sys
import time

import _cli
import _plots  # matplotlib only: no pyvista/VTK here, so no import order to keep
import numpy as np

from analytic.branches import parse_branch_label
from analytic.params import require_rigid  # noqa: E402
from analytic.tracking import Branch, waveguide_lambda
from forms.cross_section_continuation import follow_branch, most_unstable_k
from forms.mode_postprocessing import interface_stresses, normalise
from forms.spatial_stability import kulikovskii_limit
from forms.strip import build_strip_problem, solve_modes
from meshes.strip import strip_mesh

#: Options prefixes of the SLEPc objects: block solves, cross-section model, spatial roots.
PETSC_PREFIXES = ("block_", "xs_", "kroots_")
#: Files this workflow writes.
OUTPUTS = ("finite_block.csv", "finite_block.png", "block_mode.png", "finite_block.json")
COLUMNS = ["L", "re_lambda", "im_lambda", "residual", "candidates", "re_lambda_inf",
           "im_lambda_inf", "k_inf"]


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
    p.add_argument("--no-kulikovskii", action="store_true",
                   help="skip the long-block limit from the cross-section model")
    p.add_argument("--resume", action="store_true",
                   help="keep the rows already in the CSV (same parameters required; --lengths"
                        " may differ: only the missing lengths are computed)")
    p.add_argument("--out", default="out/finite_block", help="output directory")
    return p


def validate(args: argparse.Namespace):
    """Check every option before anything collective or any file is created."""
    params = _cli.params_from_args(args)
    require_rigid(params, "finite_block.py (rigid substrate)")
    if math.isinf(params.H):
        raise _cli.ParameterError("H = inf is outside its allowed range here (a finite block)")
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
    return params, np.unique(lengths), branches, k_scan


def _read_done(path: str) -> dict[float, dict]:
    if not os.path.exists(path):
        return {}
    with open(path) as f:
        return {float(r["L"]): r for r in csv.DictReader(f)}


def extrapolate(L: np.ndarray, values: np.ndarray) -> tuple[float, float]:
    """Limit ``L -> infinity`` from the three largest lengths (Richardson, observed order).

    With ``L`` in a geometric ratio ``r`` and monotone differences, the order ``p`` comes from
    ``(v2 - v1)/(v3 - v2) = r^p`` and the limit is ``v3 + (v3 - v2)/(r^p - 1)``; otherwise a
    least-squares ``a + b/L``. Returns ``(limit, p)``.
    """
    order = np.argsort(L)
    L, v = np.asarray(L)[order], np.asarray(values)[order]
    if len(L) < 3:
        return float("nan"), float("nan")
    (l1, l2, l3), (v1, v2, v3) = L[-3:], v[-3:]
    r = l2 / l1
    d1, d2 = v2 - v1, v3 - v2
    if abs(l3 / l2 - r) < 1e-9 * r and d1 * d2 > 0 and abs(d1) > abs(d2):
        p = float(np.log(d1 / d2) / np.log(r))
        return float(v3 + d2 / (r**p - 1.0)), p
    b, a = np.polyfit(1.0 / L[-3:], v[-3:], 1)
    return float(a), 1.0


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
    g_inf, order_p = extrapolate(L, lam.real)
    fig, axes = plt.subplots(1, 2, figsize=(11.5, 4.3))
    ax = axes[0]
    ax.plot(L, lam.real, "o-", label="finite block: most unstable Re $\\Lambda$")
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
    fig.savefig(out_png, dpi=130, metadata=_cli.png_metadata(meta, title))
    plt.close(fig)


def run_parameters(args: argparse.Namespace, params, branches) -> dict:
    """What determines the rows (the folder's record; ``--resume`` must match it).

    Not ``--lengths``: every row is one length, so a resumed run may add lengths.
    """
    return {"params": params.as_dict(), "lateral": args.lateral,
            "branches": [list(b) for b in branches], "k_scan": args.k_scan,
            "cells_per_unit": args.cells_per_unit, "ny": args.ny, "degree": args.degree,
            "targets": args.targets, "nev": args.nev}


def main(comm=None, argv: list[str] | None = None) -> int:
    """Run the scan over block lengths; exit code 1 if some length had no converged mode."""
    args, comm = _cli.start(build_parser(), argv, comm)
    params, lengths, branches, k_scan = validate(args)
    with _cli.RunFolder(comm, args.out, "finite_block", run_parameters(args, params, branches),
                        resume=args.resume, resumable=True, outputs=OUTPUTS) as run:
        return _run(comm, args, run, params, lengths, branches, k_scan)


def _run(comm, args: argparse.Namespace, run: _cli.RunFolder, params, lengths, branches,
         k_scan) -> int:
    t_start = time.perf_counter()
    # Infinite strip, per branch: most unstable k on the grid, refined on a finer grid; the
    # reference is the most unstable branch. The block's operators are real, so its spectrum is
    # symmetric under conjugation: every target is taken in Im Lambda < 0.
    dk = (k_scan[-1] - k_scan[0]) / max(len(k_scan) - 1, 1)
    per_branch = []
    targets = []
    for nb in branches:
        b = Branch(*nb)

        def wg(k: float, b: Branch = b) -> complex:
            return waveguide_lambda(params, b, k)

        k0, lam0 = most_unstable_k(params, wg, k_scan)
        fine = np.linspace(k0, k0 + dk, 11)
        kb, lb = most_unstable_k(params, lambda k, z=lam0: z, fine)
        fine = np.linspace(k0, max(k0 - dk, 1e-3), 11)
        kb2, lb2 = most_unstable_k(params, lambda k, z=lam0: z, fine)
        if lb2.real > lb.real:
            kb, lb = kb2, lb2
        per_branch.append((b.label, kb, lb))
        if lb.real <= 0 and len(branches) > 1:
            continue  # a stable branch seeds no targets
        # shift targets: the branch itself on both sides of its most unstable k
        for ks in (np.linspace(kb, 1.5 * kb, args.targets), np.linspace(kb, 0.5 * kb,
                                                                       args.targets)):
            for z in follow_branch(params, lambda k, z=lb: z, ks):
                if np.isfinite(z):
                    targets.append(z if z.imag <= 0 else z.conjugate())
    # distinct targets only
    uniq: list[complex] = []
    for z in targets:
        if all(abs(z - w) > 1e-6 * abs(z) for w in uniq):
            uniq.append(z)
    targets = uniq
    label, k_inf, lam_inf = max(per_branch, key=lambda t: t[2].real)
    label, k_inf, lam_inf, targets = comm.bcast((label, k_inf, lam_inf, targets), root=0)

    csv_path = os.path.join(args.out, "finite_block.csv")
    done = _read_done(csv_path) if (run.resumed and comm.rank == 0) else {}
    done = comm.bcast(done, root=0)
    if comm.rank == 0:
        if not done:
            with open(csv_path, "w", newline="") as f:
                csv.writer(f).writerow(COLUMNS)
        for lb_, kb_, zb_ in per_branch:
            print(f"infinite strip, branch {lb_}: max Re Lambda = {zb_:.8g} at k = {kb_:.6g}",
                  flush=True)
    todo = [L for L in lengths if float(L) not in done]
    bar = None
    if comm.rank == 0:
        from tqdm import tqdm

        bar = tqdm(total=len(todo), desc="block lengths", file=sys.stderr)
    failed = 0
    timings: dict[str, float] = {}
    json_path = os.path.join(args.out, "finite_block.json")
    if done and comm.rank == 0 and os.path.exists(json_path):
        with open(json_path) as f:  # per-L times of the lengths kept from the earlier run
            old = json.load(f).get("timings", {})
        timings.update({key: v for key, v in old.items() if key != "total"})
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
            "branches": [t[0] for t in per_branch], "reference_branch": label,
            "per_branch": [[t[0], t[1], t[2].real, t[2].imag] for t in per_branch],
            "k_inf": k_inf, "lambda_inf": [lam_inf.real, lam_inf.imag],
            "targets": [[t.real, t.imag] for t in targets], "cells_per_unit": args.cells_per_unit,
            "ny": args.ny, "degree": args.degree, "ranks": comm.size, "timings": timings,
            "versions": _cli.versions(), "command": _cli.command()}
    title = (f"finite block ({args.lateral} ends, bc = {params.bc}, H = {params.H:g}),"
             f" P{args.degree} strip FE")
    interface = None
    if last is not None:
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
                print(f"long-block limit ({kul['type']}, cross-section): Lambda ="
                      f" {kul['lambda'][0]:.6f} {kul['lambda'][1]:+.6f}i (k1 ="
                      f" {complex(*kul['k1_at_block']):.4f}, k2 ="
                      f" {complex(*kul['k2_at_block']):.4f})", flush=True)
        if rows:
            L_all = np.array([float(r["L"]) for r in rows])
            g_all = np.array([float(r["re_lambda"]) for r in rows])
            meta["extrapolated_growth"], meta["extrapolation_order"] = extrapolate(L_all, g_all)
            plot_convergence(rows, lam_inf, k_inf, os.path.join(args.out, "finite_block.png"),
                             title, meta, kul)
        if interface is not None:
            _, lam_b, L_b = last
            _plots.plot_interface(
                interface, os.path.join(args.out, "block_mode.png"),
                f"most unstable mode of a block, L = {L_b:g}, {args.lateral} ends:"
                f" Lambda = {lam_b.real:.5f} {lam_b.imag:+.5f}i", meta)
        meta["timings"]["total (this run)"] = time.perf_counter() - t_start
        with open(json_path, "w") as f:
            json.dump(meta, f, indent=2)
        print(f"wrote {args.out}/", flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    _cli.run(main)
