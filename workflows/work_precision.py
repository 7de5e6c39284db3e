"""Work-precision diagram: relative error of one eigenvalue against wall time per k.

    python workflows/work_precision.py [--out DIR] [--repeats 3] [--tiny]
    mpirun -n 2 python workflows/work_precision.py ...   # the points are shared out

Cases (parameters in ``summary.json``):

- ``finite_H``: velocity top, paper defaults (``f=0.3, gamma=3, beta=0.5, Delta=0.7,
  H=0.5``), ``k = 1``, branch ``0-``; reference: the exact root
  (``analytic.branches.polish_root``, = the check value of docs/design.md section 4,
  ``0.2716852879456 - 6.5866951866228i``). Cross-section FE, P1..P4, several uniform meshes.
- ``halfspace``: the same ``f, gamma, beta, Delta``, ``H = inf``, ``k = 0.3``: the
  dilatational instability; reference ``analytic.halfspace.dilatational_root``. Cross-section
  FE with the PML layer of :mod:`forms.pml` (one layer setting, i.e. without the second,
  checking solve, which doubles the cost), P2..P4, the layer's cell size scaled.

Methods: SLEPc PEP (TOAR, shift-and-invert, MUMPS) on the polynomial form, SLEPc NEP
(NLEIGS) on the split form, a dense baseline (the same polynomial matrices as dense arrays,
linearised into the first companion pencil of size ``d n`` and solved by
``scipy.linalg.eig``: all eigenvalues, the one nearest the target kept), and the analytic
root itself (Newton on ``det M`` / on ``s`` from a generic start). Time per k: the best of
``--repeats`` runs of "operator at this k + solve" (finite H: the k-independent blocks are
assembled once and not counted; half-space: the layer depends on k, so assembly is counted).
The Pareto front (no other point both faster and more accurate) is marked.

Writes ``DIR/work_precision.csv``, ``DIR/summary.json``, ``DIR/work_precision.png``.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import time

import _cli
import numpy as np

from mpi4py import MPI

from analytic.branches import polish_root
from analytic.halfspace import dilatational_root
from analytic.largek import z_linear
from analytic.params import Params
from forms.cross_section import CrossSectionModel
from forms.pml import RESOLUTION, HalfSpaceModel, design_layer
from forms.solvers import PolynomialSolver, SplitSolver, dense_companion_eig

#: Options prefixes of the SLEPc objects (PEP and NEP solvers).
PETSC_PREFIXES = ("wp_pep_", "wp_nep_")

OUTPUT_FILES = ("work_precision.csv", "summary.json", "work_precision.png")
COLUMNS = ("case", "method", "degree", "cells", "dofs", "seconds", "rel_error", "re_lambda",
           "im_lambda", "pareto", "pareto_fe", "note")
K_FINITE, TARGET_FINITE = 1.0, 0.3 - 6.6j
K_HALF = 0.3
#: Meshes per degree (finite H, uniform cells on H = 0.5).
FINITE_CELLS = {1: (16, 32, 64, 128, 256, 512), 2: (3, 4, 6, 8, 12, 16, 24),
                3: (2, 3, 4, 6, 8, 12), 4: (1, 2, 3, 4, 6, 8)}
#: PML cell size factors (times forms.pml.RESOLUTION[degree]).
HALF_SCALES = {2: (2.0, 1.4, 1.0, 0.7, 0.5), 3: (2.0, 1.4, 1.0, 0.7, 0.5),
               4: (2.5, 2.0, 1.4, 1.0, 0.7, 0.5)}
TINY_FINITE = {2: (4, 8), 3: (4,)}
TINY_HALF = {2: (2.0,)}
#: Errors within this factor count as equal for the Pareto front.
PARETO_SLACK = 1.25
#: Largest companion pencil (d n) handed to the dense eigensolver (--tiny: 300). With
#: Debian's reference LAPACK, d n = 774 takes ~14 s.
DENSE_MAX = 900


def build_parser() -> argparse.ArgumentParser:
    """Command-line options."""
    ap = _cli.make_parser(__doc__, PETSC_PREFIXES)
    ap.add_argument("--out", default="out/work_precision", help="output folder")
    ap.add_argument("--repeats", type=int, default=3, help="timing repeats, best kept")
    ap.add_argument("--tiny", action="store_true", help="a few points only (smoke test)")
    ap.add_argument("--no-dense", action="store_true", help="skip the dense baseline")
    return ap


def _best(fn, repeats: int, budget: float = 5.0):
    """``(best wall time, last result)`` of ``fn()`` over ``repeats`` runs.

    Stops repeating once ``budget`` seconds have been spent (slow points vary little).
    """
    best, out, spent = math.inf, None, 0.0
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        dt = time.perf_counter() - t
        best, spent = min(best, dt), spent + dt
        if spent > budget:
            break
    return best, out


def finite_points(comm, p, cells: dict, repeats: int, dense: bool, lam_ref: complex,
                  dense_max: int = DENSE_MAX) -> list[dict]:
    """FE points of the finite-H case: every (degree, cells), PEP, NEP, dense."""
    rows = []
    for deg, cell_list in cells.items():
        for n in cell_list:
            for form, method in (("polynomial", "PEP"), ("split", "NEP")):
                model = CrossSectionModel(comm, p, degree=deg, cells=n, ratio=1.0, form=form)
                solver = (PolynomialSolver(comm, nev=1, prefix="wp_pep_") if form == "polynomial"
                          else SplitSolver(comm, nev=1, prefix="wp_nep_"))

                def run(model=model, solver=solver):
                    model._k = None  # recombine the k blocks every time (counted)
                    res = solver.solve(model.operator(K_FINITE), TARGET_FINITE)
                    lam = res.pairs[0].value if res.pairs else complex("nan")
                    res.destroy()
                    return lam

                sec, lam = _best(run, repeats)
                rows.append(_row("finite_H", method, deg, n, model.size, sec, lam, lam_ref))
                if form == "polynomial" and dense and 3 * model.size <= dense_max:
                    def run_dense(model=model):
                        model._k = None
                        return dense_companion_eig(model.operator(K_FINITE), TARGET_FINITE)

                    sec, lam = _best(run_dense, repeats)
                    rows.append(_row("finite_H", "dense", deg, n, model.size, sec, lam, lam_ref,
                                     "scipy.linalg.eig on the companion pencil"))
                solver.destroy()
                model.destroy()
    return rows


def half_points(comm, p, scales: dict, repeats: int, dense: bool, lam_ref: complex,
                target: complex, dense_max: int = DENSE_MAX) -> list[dict]:
    """FE points of the half-space case: PML model per (degree, cell-size factor)."""
    rows = []
    for deg, factors in scales.items():
        for c in factors:
            design = design_layer(K_HALF, target, p.beta, deg,
                                  resolution=c * RESOLUTION[deg])
            for form, method in (("polynomial", "PEP"), ("split", "NEP")):
                def run(design=design, form=form, deg=deg):
                    model = HalfSpaceModel(comm, p, design, deg, form)
                    solver = (PolynomialSolver(comm, nev=1, prefix="wp_pep_")
                              if form == "polynomial" else
                              SplitSolver(comm, nev=1, radius=0.3, prefix="wp_nep_"))
                    res = solver.solve(model.op, target)
                    lam = res.pairs[0].value if res.pairs else complex("nan")
                    res.destroy()
                    solver.destroy()
                    size = model.size
                    model.destroy()
                    return lam, size

                sec, (lam, size) = _best(run, repeats)
                rows.append(_row("halfspace", f"PML {method}", deg, design.cells, size, sec,
                                 lam, lam_ref, f"cell size x{c}"))
                if form == "polynomial" and dense and 3 * size <= dense_max:
                    def run_dense(design=design, deg=deg):
                        model = HalfSpaceModel(comm, p, design, deg, "polynomial")
                        lam = dense_companion_eig(model.op, target)
                        model.destroy()
                        return lam

                    sec, lam = _best(run_dense, repeats)
                    rows.append(_row("halfspace", "PML dense", deg, design.cells, size, sec,
                                     lam, lam_ref, "scipy.linalg.eig on the companion pencil"))
    return rows


def _row(case, method, degree, cells, dofs, sec, lam, ref, note="") -> dict:
    err = abs(lam - ref) / abs(ref) if np.isfinite(lam) else math.inf
    return {"case": case, "method": method, "degree": degree, "cells": cells, "dofs": dofs,
            "seconds": sec, "rel_error": err, "re_lambda": complex(lam).real,
            "im_lambda": complex(lam).imag, "pareto": False, "pareto_fe": False, "note": note}


def mark_pareto(rows: list[dict], key: str = "pareto", fe_only: bool = False) -> None:
    """``row[key] = True`` for the points no other point of the case beats in time and error.

    ``fe_only``: among the finite-element points only (the analytic root left out). A point
    is dominated by a faster (or equally fast) one whose error is at most ``PARETO_SLACK``
    times its own (errors that close are the same digits).
    """
    for case in {r["case"] for r in rows}:
        pts = [r for r in rows if r["case"] == case and math.isfinite(r["rel_error"])
               and not (fe_only and r["method"] == "analytic")]
        for r in pts:
            e = max(r["rel_error"], 1e-16)
            r[key] = not any(
                o is not r and o["seconds"] <= r["seconds"]
                and max(o["rel_error"], 1e-16) <= PARETO_SLACK * e for o in pts)


def plot(rows: list[dict], path: str, meta: dict) -> None:
    """Log-log error vs time, one panel per case, Pareto front as a step line."""
    import matplotlib.pyplot as plt

    cases = [c for c in ("finite_H", "halfspace") if any(r["case"] == c for r in rows)]
    fig, axes = plt.subplots(1, len(cases), figsize=(6.4 * len(cases), 5.2), squeeze=False)
    markers = {1: "v", 2: "s", 3: "o", 4: "D"}
    colors = {"PEP": "C0", "NEP": "C1", "dense": "C3", "analytic": "k"}
    titles = {"finite_H": f"finite H = 0.5, velocity top, k = {K_FINITE} (branch 0-)",
              "halfspace": f"half-space (PML), k = {K_HALF}, dilatational root"}
    for ax, case in zip(axes[0], cases, strict=True):
        sel = [r for r in rows if r["case"] == case and math.isfinite(r["rel_error"])]
        seen = set()
        for r in sel:
            kind = r["method"].split()[-1]
            lab = f"{r['method']} P{r['degree']}" if kind != "analytic" else r["method"]
            ax.loglog(r["seconds"], max(r["rel_error"], 1e-16), markers.get(r["degree"], "*"),
                      color=colors.get(kind, "C2"), ms=6, mfc="none" if kind == "NEP" else None,
                      ls="none", label=None if lab in seen else lab)
            seen.add(lab)
        for key, ls, lab in (("pareto", "--", "Pareto front"),
                             ("pareto_fe", ":", "Pareto front, FE only")):
            front = sorted((r for r in sel if r[key]), key=lambda r: r["seconds"])
            if len(front) > 1:
                ax.step([r["seconds"] for r in front],
                        [max(r["rel_error"], 1e-16) for r in front],
                        where="post", color="0.3", lw=1.2, ls=ls, label=lab)
        ax.set_xlabel("wall time per k [s] (best of repeats)")
        ax.set_ylabel("relative error of Lambda")
        ax.set_title(titles[case], fontsize=9)
        ax.grid(True, which="major", alpha=0.3)
        ax.legend(fontsize=6, ncol=2)
    fig.suptitle(f"{meta['machine']}, {meta['ranks']} rank(s); errors clipped at 1e-16",
                 fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110, metadata=_cli.png_metadata(meta, "work-precision"))
    plt.close(fig)


def job_cost(kind: str, degree: int, sub: tuple) -> float:
    """Rough cost of one job for :func:`_cli.share_by_cost` (unknowns; PML layers are larger)."""
    if kind == "finite":
        return 2.0 * (degree * sub[0] + 1)
    if kind == "half":
        return 400.0 * degree / sub[0]
    return 1.0


def main(comm=None, argv: list[str] | None = None) -> int:
    """Entry point; the points are shared out over the ranks of ``comm`` (one rank each)."""
    args, comm = _cli.start(build_parser(), argv, comm)
    _cli.positive_int("--repeats", args.repeats, 1, 100)
    parameters = {"repeats": args.repeats, "tiny": args.tiny, "dense": not args.no_dense}
    with _cli.RunFolder(comm, args.out, "work_precision", parameters, outputs=OUTPUT_FILES):
        return _run(comm, args)


def _run(comm, args: argparse.Namespace) -> int:
    p_fin = Params()
    p_half = Params(H=math.inf)
    ref_fin = polish_root(p_fin, K_FINITE, TARGET_FINITE)
    ref_half = dilatational_root(K_HALF, p_half)
    lam_fin, lam_half = complex(ref_fin.value), ref_half.Lambda
    target_half = complex(-1j * K_HALF * z_linear(K_HALF, p_half))  # Eq. kappa_d1
    cells = TINY_FINITE if args.tiny else FINITE_CELLS
    scales = TINY_HALF if args.tiny else HALF_SCALES
    dense_max = 300 if args.tiny else DENSE_MAX
    jobs = [("finite", d, (n,)) for d, ns in cells.items() for n in ns]
    jobs += [("half", d, (c,)) for d, cs in scales.items() for c in cs]
    jobs += [("analytic", 0, ())]
    mine: list[dict] = []
    for i in _cli.my_share(comm, [job_cost(*job) for job in jobs]):
        kind, d, sub = jobs[i]
        if kind == "finite":
            mine += finite_points(MPI.COMM_SELF, p_fin, {d: sub}, args.repeats,
                                  not args.no_dense, lam_fin, dense_max)
        elif kind == "half":
            mine += half_points(MPI.COMM_SELF, p_half, {d: sub}, args.repeats,
                                not args.no_dense, lam_half, target_half, dense_max)
        else:
            sec, r = _best(lambda: polish_root(p_fin, K_FINITE, TARGET_FINITE), args.repeats)
            mine.append(_row("finite_H", "analytic", 0, 0, 0, sec, complex(r.value),
                             0.2716852879456 - 6.5866951866228j,
                             "Newton on det M; error vs the check value of docs/design.md"
                             " section 4 (13 digits)"))
            sec, r = _best(lambda: dilatational_root(K_HALF, p_half), args.repeats)
            ref2 = dilatational_root(K_HALF, p_half, guess=complex(
                np.sqrt(1 - (p_half.beta * target_half / (-1j * K_HALF)) ** 2)))
            mine.append(_row("halfspace", "analytic", 0, 0, 0, sec, r.Lambda, ref2.Lambda,
                             "Newton in kappa_d; error vs a second start"))
    parts = comm.gather(mine, root=0)
    if comm.rank == 0:
        rows = [r for part in parts for r in part]
        rows.sort(key=lambda r: (r["case"], r["method"], r["degree"], r["dofs"]))
        mark_pareto(rows)
        mark_pareto(rows, "pareto_fe", fe_only=True)
        with open(os.path.join(args.out, OUTPUT_FILES[0]), "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=COLUMNS)
            w.writeheader()
            for r in rows:
                w.writerow(r)
        meta = {"command": _cli.command(), **_cli.versions(), "ranks": comm.size,
                "repeats": args.repeats,
                "finite_H": {"params": "paper defaults, H=0.5, bc=velocity", "k": K_FINITE,
                             "target": str(TARGET_FINITE), "reference": str(lam_fin)},
                "halfspace": {"params": "paper defaults, H=inf", "k": K_HALF,
                              "target": str(target_half), "reference": str(lam_half)}}
        fastest = {}
        for case in ("finite_H", "halfspace"):
            for thr in (1e-6, 1e-10):
                for m in {r["method"] for r in rows if r["case"] == case}:
                    ok = [r["seconds"] for r in rows if r["case"] == case and r["method"] == m
                          and r["rel_error"] <= thr]
                    if ok:
                        fastest[f"{case} {m} err<={thr:g}"] = min(ok)
        with open(os.path.join(args.out, OUTPUT_FILES[1]), "w") as fh:
            json.dump({**meta, "fastest_seconds": fastest, "points": len(rows)}, fh, indent=1)
        plot(rows, os.path.join(args.out, OUTPUT_FILES[2]), meta)
        print(f"{len(rows)} points -> {args.out}", flush=True)
    comm.Barrier()
    return 0


if __name__ == "__main__":
    _cli.run(main)
