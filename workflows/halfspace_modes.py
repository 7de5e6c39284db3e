"""Half-space modes: FE with a PML layer vs plain truncated strips vs the roots of s(z, q).

    mpirun -n N python workflows/halfspace_modes.py [options] --out DIR

For every ``k`` the root of the half-space spectrum (``analytic.physics.halfspace``: the
dilatational
family near ``z = 1/beta``, continued in ``k`` through ``q_c`` onto the ``s~`` sheet of
Appendix C, or the shear family near ``z = -1``) is the reference. The FE computes it

- with the PML layer of :mod:`forms.models.pml` (two layer settings, failure flags), and
- with plain strips of the heights ``--H-trunc`` and the top conditions ``--bc-trunc``
  (the cross-section model of :mod:`forms.models.cross_section`; flag: reflection estimate at the
  top).

Every row says whether the code trusted its number (``trusted``, ``flags``) and how far it is
from the analytic root; ``summary.json`` counts the *silent failures* (trusted but wrong by
more than ``--silent-rtol``), which must be zero. The rows and the checks are computed by
:mod:`forms.studies.halfspace_modes`. Ranks share the ``k`` values (one mesh per
rank). Writes ``DIR/halfspace_modes.csv``, ``DIR/summary.json``, ``DIR/halfspace_modes.png``.

A deformable substrate of finite height (``--mu2 --rho2 --beta2 --H2 --bc2``): a half-space
slider on it; the references are every exact two-body root under the slider's shear cut
(``--family``, ``--branch`` ignored) and the FE rows are PML rows of the layered 1D model
(:func:`forms.studies.halfspace_modes.solve_two_body_k`); no truncated strips.

Exit codes: 0 fine; 1 some silent failure; 2 bad input (nothing written).
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import math
import os

import _cli
import numpy as np

from mpi4py import MPI

from analytic.params import Params
from analytic.physics.halfspace import follow
from forms.studies import halfspace_modes
from forms.studies.halfspace_modes import COLUMNS
from meshes.interval import default_cells

#: Options prefixes of the SLEPc objects: the PML solves and the truncated strips.
PETSC_PREFIXES = ("pml_", "trunc_")

OUTPUT_FILES = ("halfspace_modes.csv", "summary.json", "halfspace_modes.png")
#: Cells of the largest plain truncated strip (``meshes.interval.default_cells`` at the largest
#: ``k``). Measured on the 2-core machine, P4, one rank, 6 GB address-space limit: 14 324 cells
#: (the default run's ``k = 3, H = 1000``) 12 s, 47 747 (``k = 10``) 25 s; 143 240 (``k = 30``)
#: failed (PETSc error 371) and ``--k 1e7`` grew to 21.6 GB before it was killed.
MAX_TRUNC_CELLS = 50_000
FAMILIES = ("dilatational", "shear")
BRANCHES = ("unstable", "stable")


def build_parser() -> argparse.ArgumentParser:
    """Command-line options (``--H`` and ``--bc`` of the shared group are ignored)."""
    ap = _cli.make_parser(__doc__, PETSC_PREFIXES, formatter_class=argparse.HelpFormatter)
    _cli.add_param_arguments(ap)
    ap.add_argument("--family", choices=FAMILIES, default="dilatational")
    ap.add_argument("--branch", default="unstable",
                    help="dilatational kappa_d function(s), comma list of unstable, stable "
                    "(%(default)s; the shear family has one)")
    ap.add_argument("--k", default="0.02,0.05,0.1,0.2,0.3,0.5,0.7,0.75,1,1.5,3",
                    help="start:stop:count or k1,k2,... (%(default)s)")
    ap.add_argument("--degree", type=int, default=4, help="element degree 1..6 (%(default)s)")
    ap.add_argument("--attenuation", type=float, default=16.0,
                    help="e-folds of the slower wave across the PML (%(default)s)")
    ap.add_argument("--H-trunc", default="100,1000",
                    help="heights of the plain truncated strips, comma list ('' for none)")
    ap.add_argument("--bc-trunc", default="velocity,stress",
                    help="top conditions of the truncated strips (%(default)s)")
    ap.add_argument("--tol", type=float, default=1e-8,
                    help="relative disagreement / reflection accepted (%(default)s)")
    ap.add_argument("--silent-rtol", type=float, default=1e-6,
                    help="a trusted value farther than this from the root is a silent failure")
    ap.add_argument("--overlay-name", default="overlay",
                    help="also write DIR/NAME.csv (x = k, y = Re Lambda, label) of the trusted "
                    "PML roots, for figures.py --overlay DIR (e.g. NAME = gaps)")
    ap.add_argument("--out", default="out/halfspace_modes", help="output folder")
    return ap


def _check(args: argparse.Namespace) -> tuple:
    """Validate everything before any output or collective call."""
    base = _cli.params_from_args(args)
    if base.two_body and math.isinf(base.H2):
        raise _cli.ParameterError("H2 = inf is outside its allowed range here (the slider is"
                                  " the half-space; the substrate must be finite)")
    p = base.replace(H=math.inf) if base.two_body else Params(
        f=base.f, gamma=base.gamma, beta=base.beta, Delta=base.Delta, H=math.inf,
        alpha_pc=base.alpha_pc, alpha_ld=base.alpha_ld)
    ks = np.unique(_cli.parse_k(args.k))  # sorted, duplicates merged
    _cli.positive_int("--degree", args.degree, 1, 6)
    if not (math.isfinite(args.attenuation) and args.attenuation > 0):
        raise _cli.ParameterError(f"--attenuation = {args.attenuation} must be > 0")
    hs = _cli.parse_k(args.H_trunc, name="--H-trunc") if args.H_trunc.strip() else np.array([])
    cells = default_cells(float(ks[-1]), float(hs.max()), args.degree, 0, p.beta) if len(
        hs) else 0
    if cells > MAX_TRUNC_CELLS:
        raise _cli.ParameterError(
            f"--k = {ks[-1]:g} with --H-trunc = {hs.max():g}: the plain truncated strip would "
            f"need {cells} cells, above the limit {MAX_TRUNC_CELLS} (its memory and time grow "
            "with k*H); lower --k or --H-trunc, or give --H-trunc '' for the PML rows only")
    bcs = [b.strip() for b in args.bc_trunc.split(",") if b.strip()]
    for b in bcs:
        if b not in ("velocity", "stress"):
            raise _cli.ParameterError(f"--bc-trunc: {b!r} is not 'velocity' or 'stress'")
    branches = [b.strip() for b in args.branch.split(",") if b.strip()]
    if not branches or any(b not in BRANCHES for b in branches):
        raise _cli.ParameterError(f"--branch = {args.branch!r}: comma list of unstable, stable")
    if args.family == "shear":
        branches = ["unstable"]
    if not args.overlay_name.replace("_", "").replace("-", "").isalnum():
        raise _cli.ParameterError(f"--overlay-name = {args.overlay_name!r} must be a plain name")
    for name in ("tol", "silent_rtol"):
        v = getattr(args, name)
        if not (0 < v < 1):
            raise _cli.ParameterError(f"--{name.replace('_', '-')} = {v} must be in (0, 1)")
    return p, ks, hs, bcs, branches


def plot(rows: list[dict], roots: list, path: str, title: str, meta: dict) -> None:
    """Growth rate and relative error vs k (PML, truncated strips, analytic)."""
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 4.8))
    gr = np.array([r.Lambda.real for r in roots])
    for sheet, ls in (("physical", "-"), ("s_tilde", "--")):
        first = True
        for b in dict.fromkeys(r.branch for r in roots):
            sel = [r for r in roots if r.branch == b]
            y = np.array([r.Lambda.real if r.sheet == sheet else np.nan for r in sel])
            if np.isfinite(y).any():
                ax1.plot([r.q for r in sel], y, ls, color="k", lw=1, marker=".",
                         label=f"analytic root of {'s' if sheet == 'physical' else 's~'}"
                         if first else None)
                first = False
    styles = {}
    for r in rows:
        key = ("pml", "", 0.0) if r["method"] == "pml" else ("truncated", r["bc"], r["H"])
        styles.setdefault(key, len(styles))
    markers = "os^vDP*X"
    for key, i in styles.items():
        sel = [r for r in rows if (r["method"], r["bc"], r["H"] if r["method"] != "pml" else 0.0)
               == key]
        lab = "PML" if key[0] == "pml" else f"strip H={key[2]:g} ({key[1]} top)"
        col = f"C{i}"
        for trusted in (True, False):
            s = [r for r in sel if r["trusted"] == trusted]
            if not s:
                continue
            x = [r["k"] for r in s]
            face = col if trusted else "none"
            ax1.plot(x, [r["re_lambda"] for r in s], markers[i % 8], ms=6, mfc=face, mec=col,
                     ls="none", label=lab + ("" if trusted else " (flagged)"))
            ax2.loglog(x, [max(r["rel_error"], 1e-17) for r in s], markers[i % 8], ms=6,
                       mfc=face, mec=col, ls="none", label=lab + ("" if trusted else " (flagged)"))
    ax1.set_xscale("log")
    small = np.abs(gr[np.abs(gr) > 0])
    ax1.set_yscale("symlog", linthresh=float(max(small.min(), 1e-300)) if small.size else 1e-12)
    ax1.axhline(0, color="0.6", lw=0.5)
    ax1.set_xlabel("k (= paper's q)")
    ax1.set_ylabel("Re Lambda (symlog)")
    ax1.set_title(title, fontsize=9)
    ax1.legend(fontsize=7)
    ax2.set_xlabel("k")
    ax2.set_ylabel("|Lambda_FE - Lambda_exact| / |Lambda_exact|")
    ax2.set_title("filled: trusted by the code; hollow: flagged", fontsize=9)
    ax2.legend(fontsize=7)
    fig.tight_layout()
    _cli.save_figure(fig, path, dpi=110, metadata=_cli.png_metadata(meta, title))
    plt.close(fig)


def main(comm=None, argv: list[str] | None = None) -> int:
    """Entry point (``comm``: communicator whose ranks share the k values)."""
    args, comm = _cli.start(build_parser(), argv, comm)
    p, ks, hs, bcs, branches = _check(args)
    parameters = {"params": dataclasses.asdict(p), "family": args.family, "branches": branches,
                  "k": ks.tolist(), "degree": args.degree, "attenuation": args.attenuation,
                  "H_trunc": hs.tolist(), "bc_trunc": bcs, "tol": args.tol,
                  "silent_rtol": args.silent_rtol, "overlay_name": args.overlay_name}
    outputs = (*OUTPUT_FILES, f"{args.overlay_name}.csv")
    with _cli.RunFolder(comm, args.out, "halfspace_modes", parameters, outputs=outputs):
        return _run(comm, args, p, ks, hs, bcs, branches)


def _run(comm, args: argparse.Namespace, p: Params, ks, hs, bcs, branches) -> int:
    if p.two_body:
        roots = comm.bcast(halfspace_modes.two_body_roots(p, ks) if comm.rank == 0 else None)
        hs, bcs = np.array([]), []
    else:
        roots = [r for b in branches for r in follow(args.family, ks, p, branch=b)]
    # cost of one k: the PML solve (two layer settings) plus one solve per truncated strip
    costs = [2.0 + len(hs) * len(bcs) for _ in roots]
    _cli.say_plan(comm, f"{len(roots)} root(s) x (PML + {len(hs) * len(bcs)} truncated strips)",
                  halfspace_modes.estimate_seconds(costs, args.degree, comm.size))
    mine = []
    for i in _cli.my_share(comm, costs):
        extra = {} if p.two_body else {"heights": hs, "bcs": bcs}
        mine.extend((halfspace_modes.solve_two_body_k if p.two_body else halfspace_modes.solve_k)(
            MPI.COMM_SELF, p, roots[i], args.family, degree=args.degree,
            attenuation=args.attenuation, tol=args.tol, **extra))
    parts = comm.gather(mine, root=0)
    code = 0
    if comm.rank == 0:
        rows = halfspace_modes.merge_rows(parts)
        silent = halfspace_modes.silent_failures(rows, args.silent_rtol)
        with _cli.atomic_open(os.path.join(args.out, OUTPUT_FILES[0]), "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=COLUMNS)
            w.writeheader()
            for r in rows:
                w.writerow({c: r[c] for c in COLUMNS})
        overlay = os.path.join(args.out, f"{args.overlay_name}.csv")
        with _cli.atomic_open(overlay, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["x", "y", "label"])
            for r in rows:
                if r["method"] == "pml" and r["trusted"]:
                    w.writerow([r["k"], r["re_lambda"], f"FE P{args.degree} + PML (trusted)"])
        meta = {"command": _cli.command(), "params": dataclasses.asdict(p),
                "family": args.family, "branches": branches, "k": ks.tolist(),
                "degree": args.degree,
                "attenuation": args.attenuation, "H_trunc": hs.tolist(), "bc_trunc": bcs,
                "tol": args.tol, "silent_rtol": args.silent_rtol, "ranks": comm.size,
                "versions": _cli.versions()}
        meta["params"] = {k: (v if not isinstance(v, float) or math.isfinite(v) else str(v))
                          for k, v in meta["params"].items()}
        summary = {**meta, **halfspace_modes.failure_summary(rows, silent)}
        with _cli.atomic_open(os.path.join(args.out, OUTPUT_FILES[1]), "w") as fh:
            _cli.json_dump(summary, fh, indent=1, default=str)
        what = f"half-space on mu2={p.mu2:g}, H2={p.H2:g}" if p.two_body else args.family
        title = (f"{what} family, f={p.f}, gamma={p.gamma}, beta={p.beta}, "
                 f"Delta={p.Delta}, P{args.degree}")
        plot(rows, roots, os.path.join(args.out, OUTPUT_FILES[2]), title, meta)
        print(f"{len(rows)} rows, {summary['flagged']} flagged, "
              f"{len(silent)} silent failures -> {args.out}", flush=True)
        code = 1 if silent else 0
    return comm.bcast(code, root=0)


if __name__ == "__main__":
    _cli.run(main)
