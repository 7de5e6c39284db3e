"""Envelope of the growth rate over every mode, max Re Lambda(k), out to large k H (exact roots).

    mpirun -n N python workflows/envelope.py [--bc velocity] [--k 0.05:100:48log] [--out DIR]

At every k the argument principle counts every exact root in the region R of the sweep
(``analytic.numerics.spectrum.Region``: phase velocities up to ``--c-max`` c_d) and the fastest one
is
kept; the largest local maxima of the samples are refined along their root's family.
Answers: where is the global maximum of the growth rate over k, and what does the envelope do
as k H grows? The half-space (k H -> infinity) maximum of the dilatational family
(``analytic.physics.halfspace``) is drawn for comparison. Writes ``envelope.csv``, ``summary.json``,
``envelope.png``. ``--k`` accepts ``start:stop:count`` (linear), ``start:stop:countlog``
(geometric) or a comma list. Exit code 1 if the root count failed at some k (each is reported,
and left out of the maximum).
"""

from __future__ import annotations

import argparse
import csv
import math
import os

import _cli
import numpy as np

from analytic.numerics.roots import ContourError
from analytic.numerics.spectrum import Region, fastest_root
from analytic.params import require_rigid
from analytic.physics import halfspace
from analytic.studies.growth import envelope_maximum

PETSC_PREFIXES: tuple[str, ...] = ()
OUTPUTS = ("envelope.csv", "summary.json", "envelope.png", "run.json", "run.lock")


def build_parser() -> argparse.ArgumentParser:
    """Command-line options."""
    ap = _cli.make_parser(__doc__, PETSC_PREFIXES, petsc=False)
    _cli.add_param_arguments(ap)
    ap.add_argument("--k", default="0.05:100:48log", help="k grid (see above)")
    ap.add_argument("--c-max", type=float, default=Region().c_max,
                    help="region: largest phase velocity, in units of c_d")
    ap.add_argument("--re-min", type=float, default=Region().re_min, help="region: smallest Re")
    ap.add_argument("--out", default=os.path.join("out", "envelope"), help="output folder")
    return ap


def main(comm: object = None, argv: list[str] | None = None) -> int:
    """Compute the envelope (k values shared over the ranks by cost)."""
    args, comm = _cli.start(build_parser(), argv, comm)
    p = _cli.params_from_args(args)
    if not math.isfinite(p.H):
        raise _cli.ParameterError("H = inf is outside its allowed range here (a finite strip)")
    require_rigid(p, "envelope.py")
    k = _cli.parse_grid(args.k)
    region = Region(args.re_min, 2.0, args.c_max)
    config = {"params": p.as_dict(), "k": args.k, "region": region.as_dict(p)}
    with _cli.RunFolder(comm, args.out, "envelope", config, outputs=OUTPUTS) as run:

        def fastest(i: int) -> tuple[complex | None, int, str]:
            try:
                z, n, _ = fastest_root(p, float(k[i]), region)
            except ContourError as err:  # reported (by rank 0, below), the run goes on
                return None, -1, str(err)
            return z, n, ""

        rows = _cli.map_shared(comm, [region.im_max(p, kk) ** 1.5 for kk in k], fastest)
        failed = [i for i in range(len(k)) if rows[i][1] < 0]
        for i in failed:
            _cli.say(f"k = {k[i]:g}: no count ({rows[i][2]})", err=True)
        ks = [float(v) for v in k]
        re = np.array([rows[i][0].real if rows[i][0] is not None else np.nan
                       for i in range(len(k))])
        if comm.rank == 0:
            best = envelope_maximum(p, region, ks, [rows[i][0] for i in range(len(k))])
            hs = halfspace.max_growth("dilatational", p.replace(H=math.inf))
            with _cli.atomic_open(run.file("envelope.csv"), "w", newline="") as fh:
                w = csv.writer(fh)
                w.writerow(["k", "kH", "re_lambda_max", "im_lambda", "roots_in_region"])
                for i, kk in enumerate(ks):
                    z, n, _ = rows[i]
                    w.writerow([repr(kk), repr(kk * p.H), repr(z.real) if z else "",
                                repr(z.imag) if z else "", n])  # n = -1: count failed
            summary = {"parameters": p.as_dict(), "region": region.as_dict(p),
                       "global_max_on_grid": best,
                       "halfspace_dilatational_max": {"growth": hs.growth, "q": hs.q_growth},
                       "large_kH": {"kH": ks[-1] * p.H, "re_lambda_max":
                                    float(re[-1]) if np.isfinite(re[-1]) else None},
                       "failed_counts_k": [ks[i] for i in failed],
                       "versions": _cli.versions(), "command": _cli.command()}
            with _cli.atomic_open(run.file("summary.json"), "w") as fh:
                _cli.json_dump(summary, fh, indent=1)
            plot(run.file("envelope.png"), p, np.array(ks), re, best, hs.growth, config)
            if best is None:
                _cli.say(f"no root in the region (Re Lambda >= {region.re_min:g}) at any k of "
                         f"[{ks[0]:g}, {ks[-1]:g}]")
            else:
                _cli.say(f"global maximum on [{ks[0]:g}, {ks[-1]:g}]: Re Lambda = "
                         f"{best['re_lambda']:.6f} at k = {best['k']:.5g} (k H = "
                         f"{best['kH']:.4g}), Im Lambda = {best['im_lambda']:.6g}; at k H = "
                         f"{ks[-1] * p.H:g}: {re[-1]:.6f}")
            if failed:
                _cli.say(f"warning: the count failed at {len(failed)} of {len(ks)} k value(s) "
                         "(no value there; the maximum is over the others); see "
                         "failed_counts_k in summary.json", err=True)
    return 1 if failed else 0


def plot(path: str, p: object, k: np.ndarray, re: np.ndarray, best: dict | None, hs: float,
         meta: dict) -> None:
    """envelope.png: max Re Lambda against k H (log axis)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4.5))
    ax.semilogx(k * p.H, re, "o-", ms=3, color="k", label="max Re Lambda over every mode in R")
    if best is not None:
        ax.plot([best["kH"]], [best["re_lambda"]], "*", ms=15, color="gold", mec="k",
                label=f"maximum: {best['re_lambda']:.5f} at k H = {best['kH']:.3g}")
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


if __name__ == "__main__":
    _cli.run(main)
