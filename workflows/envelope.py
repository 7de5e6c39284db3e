"""Envelope of the growth rate over every mode, max Re Lambda(k), out to large k H (exact roots).

    mpirun -n N python workflows/envelope.py [--bc velocity] [--k 0.05:100:48log] [--out DIR]

At every k the argument principle counts every exact root in the region R of the sweep
(``analytic.numerics.spectrum.Region``: phase velocities up to ``--c-max`` c_d) and the fastest
one is kept. The grid is refined around every local extremum of the samples, maxima and dips alike,
and wherever the fastest root changes family (geometric midpoints until neighbours there are
within ``--min-ratio``, at most ``--refine-rounds`` rounds:
``analytic.studies.growth.refinement_points``), and the largest local maxima are refined
along their root's family.
Answers: where is the global maximum of the growth rate over k, and what does the envelope do
as k H grows (the trapped-wave plateau, about 0.17 / H: docs/envelope.md)? The half-space
maximum of the dilatational family (``analytic.physics.halfspace``: H -> infinity at fixed k, a
different limit from k H -> infinity at fixed H) is drawn for comparison. Writes
``envelope.csv``, ``summary.json``, ``envelope.png``. ``--k`` accepts ``start:stop:count``
(linear), ``start:stop:countlog`` (geometric) or a comma list. Exit code 1 if the root count
failed at some k (each is reported, and left out of the maximum), and with ``--fe-check yes``
(each local maximum) or ``all`` (every sample with a root) where the FE's count did not close or
its fastest eigenvalue is not the exact point's (``workflows/_points.py``): with ``all`` the
envelope is found by the finite elements on their own at every sample, the exact roots its
referee, and so is its maximum: the largest local maxima of the FE's own samples are refined
along their FE modes and certified at the ``k`` found (``forms.studies.peaks``), giving the FE's
own maximum (``summary.json`` ``fe_maximum``, a red cross-shaped marker), set against the exact
one (exit code 1 if it is another mode). The samples themselves are placed by the exact
envelope's refinement; ``fe_maximum`` ``local_maxima_as_exact`` says whether the FE's values
have their local maxima at the same samples.
"""

from __future__ import annotations

import argparse
import csv
import math
import os

import _cli
import _plots
import numpy as np
from _points import envelope_fe, fastest_on, fe_maximum_line, fe_ready

from analytic.numerics.spectrum import Region
from analytic.params import require_rigid
from analytic.physics import halfspace
from analytic.studies.growth import (
    counts_seconds,
    envelope_maximum,
    local_extrema,
    plateau_dependence,
    refinement_points,
)

PETSC_PREFIXES: tuple[str, ...] = ()
#: summary.json ``fastest_proven``: what its counts mean.
FASTEST_PROVEN = ("proven_k: samples at which the tail bound (analytic.physics.tail) at the "
                  "region's edge is below the fastest root inside, so no root outside R grows "
                  "faster; elsewhere the value is the largest in R only")
OUTPUTS = ("envelope.csv", "summary.json", "envelope.png", "dependence.png", "run.json",
           "run.lock")


def build_parser() -> argparse.ArgumentParser:
    """Command-line options."""
    ap = _cli.make_parser(__doc__, PETSC_PREFIXES, petsc=False)
    _cli.add_param_arguments(ap)
    ap.add_argument("--k", default="0.05:100:48log", help="k grid (see above)")
    ap.add_argument("--c-max", default="auto",
                    help="region: largest phase velocity, in units of the largest c_d, or auto "
                    "(grown per k until it provably holds the fastest mode)")
    ap.add_argument("--re-min", type=float, default=Region().re_min, help="region: smallest Re")
    ap.add_argument("--min-ratio", type=float, default=1.02,
                    help="refinement: samples around every local extremum until neighbours "
                    "are within this k ratio")
    ap.add_argument("--refine-rounds", type=int, default=8,
                    help="refinement: at most this many rounds of new samples (0: the grid)")
    ap.add_argument("--dependence", action="store_true",
                    help="also follow the fastest sample at k H >= 5 (a plateau mode) in "
                    "alpha_pc, f gamma and H: dependence.png, summary.json plateau_dependence")
    ap.add_argument("--fe-check", choices=("no", "yes", "all"), default="no",
                    help="yes: each local maximum found again by the finite elements at its k; "
                    "all: every sample with a root (summary.json fe_check), and the maximum "
                    "refined by the FE on its own (summary.json fe_maximum)")
    ap.add_argument("--out", default=os.path.join("out", "envelope"), help="output folder")
    return ap


def main(comm: object = None, argv: list[str] | None = None) -> int:
    """Compute the envelope (k values shared over the ranks by cost)."""
    args, comm = _cli.start(build_parser(), argv, comm)
    p = _cli.params_from_args(args)
    _cli.require_finite_heights(p, "a finite strip")
    require_rigid(p, "envelope.py")
    k = _cli.parse_grid(args.k)
    if not (args.min_ratio > 1.0 and math.isfinite(args.min_ratio)):
        raise _cli.ParameterError(f"--min-ratio = {args.min_ratio} is outside its allowed range "
                                  "> 1")
    if not 0 <= args.refine_rounds <= 50:
        raise _cli.ParameterError(f"--refine-rounds = {args.refine_rounds} is outside its "
                                  "allowed range 0 .. 50")
    region = _cli.region_from_args(args.c_max, args.re_min)
    if args.fe_check != "no":
        fe_ready()  # collective: PETSc's initialisation
    _cli.check_roots_region(p, float(k[-1]), region, "k or --c-max")
    config = {"params": p.as_dict(), "k": args.k, "region": region.as_dict(p),
              "min_ratio": args.min_ratio, "refine_rounds": args.refine_rounds}
    with _cli.RunFolder(comm, args.out, "envelope", config, outputs=OUTPUTS) as run:
        _cli.say_plan(comm, f"{len(k)} k values, then up to {args.refine_rounds} rounds of "
                      "refinement,", counts_seconds([[(p, float(v))] for v in k], region,
                                                    comm.size), "for the grid")

        found = fastest_on(comm, p, region, [float(v) for v in k])
        for _ in range(args.refine_rounds):  # no grid hides an extremum (growth.py)
            ks = sorted(found)
            new = refinement_points(p, ks, [found[kk][0] for kk in ks], args.min_ratio)
            if not new:
                break
            found.update(fastest_on(comm, p, region, new))
        ks = sorted(found)
        rows = [found[kk] for kk in ks]
        failed = [i for i in range(len(ks)) if rows[i][1] < 0]
        for i in failed:
            _cli.say(f"k = {ks[i]:g}: no count ({rows[i][2]})", err=True)
        re = np.array([r[0].real if r[0] is not None else np.nan for r in rows])
        best = comm.bcast(envelope_maximum(p, region, ks, [r[0] for r in rows])
                          if comm.rank == 0 else None)
        fe, fe_line, fe_failed, fe_best = envelope_fe(comm, p, region, args.fe_check, ks,
                                                      [r[0] for r in rows], best, re)
        if comm.rank == 0:
            hs = halfspace.max_growth("dilatational", p.replace(H=math.inf))
            with _cli.atomic_open(run.file("envelope.csv"), "w", newline="") as fh:
                w = csv.writer(fh)
                w.writerow(["k", "kH", "re_lambda_max", "im_lambda", "roots_in_region",
                            "fastest_proven"])
                for i, kk in enumerate(ks):
                    z, n, _, proof = rows[i]
                    w.writerow([repr(kk), repr(kk * p.H), repr(z.real) if z else "",
                                repr(z.imag) if z else "", n,  # n = -1: count failed
                                int(proof)])
            with_root = sum(r[0] is not None for r in rows)
            proven = sum(r[3] for r in rows)
            summary = {"parameters": p.as_dict(), "region": region.as_dict(p),
                       "global_max_on_grid": best,
                       "fastest_proven": {"k_with_root": with_root, "proven_k": proven,
                                          "meaning": FASTEST_PROVEN},
                       "halfspace_dilatational_max": {"growth": hs.growth, "q": hs.q_growth},
                       "large_kH": {"kH": ks[-1] * p.H, "re_lambda_max":
                                    float(re[-1]) if np.isfinite(re[-1]) else None},
                       "samples": len(ks), "grid_samples": len(k),
                       "local_minima": [{"k": ks[j], "kH": ks[j] * p.H, "re_lambda": re[j]}
                                        for j in local_extrema(re)
                                        if re[j] <= min(re[j - 1], re[j + 1])],
                       "failed_counts_k": [ks[i] for i in failed],
                       **({"fe_check": fe} if fe else {}),
                       **({"fe_maximum": fe_best} if fe_best else {}),
                       "versions": _cli.versions(), "command": _cli.command()}
            large = [i for i in range(len(ks)) if ks[i] * p.H >= 5 and np.isfinite(re[i])]
            if args.dependence and large:
                i = max(large, key=lambda j: re[j])
                summary["plateau_dependence"] = plateau_dependence(p, ks[i], rows[i][0])
                plot_dependence(run.file("dependence.png"), p, summary["plateau_dependence"],
                                config)
            with _cli.atomic_open(run.file("summary.json"), "w") as fh:
                _cli.json_dump(summary, fh, indent=1)
            plot(run.file("envelope.png"), p, np.array(ks), re, best, hs.growth, config, fe,
                 fe_best)
            if best is None:
                _cli.say(f"no root in the region (Re Lambda >= {region.re_min:g}) at any k of "
                         f"[{ks[0]:g}, {ks[-1]:g}]")
            else:
                _cli.say(f"global maximum on [{ks[0]:g}, {ks[-1]:g}]: Re Lambda = "
                         f"{best['re_lambda']:.6f} at k = {best['k']:.5g} (k H = "
                         f"{best['kH']:.4g}), Im Lambda = {best['im_lambda']:.6g}; at k H = "
                         f"{ks[-1] * p.H:g}: {re[-1]:.6f}; {_cli.proof_clause(proven, with_root)}")
            if fe_line:
                _cli.say(fe_line)
            if fe_best:
                _cli.say(fe_maximum_line(fe_best))
            if failed:
                _cli.say(f"warning: the count failed at {len(failed)} of {len(ks)} k value(s) "
                         "(no value there; the maximum is over the others); see "
                         "failed_counts_k in summary.json", err=True)
        comm.Barrier()  # a rank leaving with code 1 first would make mpirun stop rank 0's writing
    return 1 if failed or fe_failed else 0


def plot(path: str, p: object, k: np.ndarray, re: np.ndarray, best: dict | None, hs: float,
         meta: dict, fe: list[dict] | None = None, fe_best: dict | None = None) -> None:
    """envelope.png: max Re Lambda against k H (log axis); ``fe``, ``fe_best``: the FE's own."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4.5))
    ax.semilogx(k * p.H, re, "o-", ms=3, color="k", label="max Re Lambda over every mode in R")
    fe_pts = [(r["k"] * p.H, r["fe_re_lambda"]) for r in fe or ()
              if r.get("fe_re_lambda") is not None]
    if fe_pts:
        ax.plot(*zip(*fe_pts, strict=True), "x", ms=5, color="tab:red",
                label=f"finite elements on their own ({len(fe_pts)} points)")
    if best is not None:
        ax.plot([best["kH"]], [best["re_lambda"]], "*", ms=15, color="gold", mec="k",
                label=f"maximum: {best['re_lambda']:.5f} at k H = {best['kH']:.3g}")
    if fe_best is not None and fe_best["re_lambda"] is not None:
        ax.plot([fe_best["k"] * p.H], [fe_best["re_lambda"]], "P", ms=9, color="tab:red",
                mec="k", label=f"FE's own maximum: {fe_best['re_lambda']:.5f} at k H = "
                f"{fe_best['k'] * p.H:.3g}")
    ax.axhline(hs, color="tab:blue", ls="--", lw=1,
               label=f"half-space dilatational maximum {hs:.2g}")
    ax.axhline(0, color="0.5", lw=0.6)
    ax.set_xlabel("k H")
    ax.set_ylabel(r"growth rate max Re $\Lambda$")
    ax.set_title(f"bc={p.bc}, f={p.f:g}, gamma={p.gamma:g}, beta={p.beta:g}, "
                 f"Delta={p.Delta:g}, H={p.H:g}", fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    _cli.save_figure(fig, path, dpi=130, metadata=_cli.png_metadata(meta, "growth-rate envelope"))
    plt.close(fig)


def plot_dependence(path: str, p: object, dep: dict, meta: dict) -> None:
    """dependence.png: H Re Lambda of one plateau mode against alpha_pc, f gamma and H."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axs = plt.subplots(1, 3, figsize=(11, 3.6), sharey=True)
    for ax, key, label, log in zip(axs, ("alpha_pc", "f_gamma", "H"),
                                   ("alpha_pc (Prakash-Clifton)", "f gamma (gamma varied)",
                                    "H (same k H)"), ("symlog", "log", "log"), strict=True):
        pts = [(v, w) for v, w in dep[key] if w is not None]
        ax.plot(*zip(*pts, strict=True), "o-", ms=4, color="k")
        ax.axhline(0, color="0.5", lw=0.6)
        ax.set_xlabel(label)
        if log == "symlog":
            ax.set_xscale("symlog", linthresh=1e-4)
            ax.set_xlim(0.0, 1.5)
        else:
            ax.set_xscale(log)
    axs[0].set_ylabel(r"$H$ Re $\Lambda$ of the plateau mode")
    fig.suptitle(f"bc={p.bc}: mode at k H = {dep['kH']:.4g} (Lambda = {dep['Lambda'][0]:.4g} "
                 f"{dep['Lambda'][1]:+.4g} i), followed; f={p.f:g}, gamma={p.gamma:g}, "
                 f"Delta={p.Delta:g}, H={p.H:g}", fontsize=9)
    fig.tight_layout()
    _plots.save_png(fig, path, meta)
    plt.close(fig)


if __name__ == "__main__":
    _cli.run(main)
