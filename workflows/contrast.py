"""Largest growth rate against the material contrast mu2 (two bodies, exact roots, counted).

    mpirun -n N python workflows/contrast.py [--mu2-grid 0.1:100:13log] [--H2s 0.5,inf] [--out DIR]

For every substrate stiffness ``mu2`` (density ``rho2 = --rho2 * (mu2)^--rho2-exponent``: 0 keeps
the density, 1 keeps the shear-wave speed) and every substrate height of ``--H2s``, the growth
rate is maximised over every mode and over k: at each k of ``--k`` the argument principle
counts every exact root of ``analytic.physics.twobody`` in the region R of the sweep (``Re >=
--re-min``, phase velocities up to ``--c-max`` c_d), the fastest is kept, and the largest grid
values are refined by sampling between their neighbours (as ``envelope.py``). For a half-space
substrate (``inf``) the region stays in ``Re > 0``, on the physical sheet. Is the curve
monotonic in mu2? Writes ``contrast.csv``, ``summary.json``, ``contrast.png``; parallel over the
(mu2, H2) pairs. Exit code 1 if the root count failed at some grid k (``failed_counts``).

``--fe-check yes``: at each finite-``H2`` point the finite elements find the fastest mode at the
point's ``k`` on their own (the certified sweep's FE path, ``sweep_k.py --check-exact no``, its
region climbed by the FE; no exact root consulted): columns ``fe_*``, ``fe_rel_diff`` against the
exact point; exit code 1 also where the FE's count did not close or its fastest eigenvalue is not
the point.
"""

from __future__ import annotations

import argparse
import csv
import math
import os

import _cli
import numpy as np
from _points import fe_point, fe_ready, fe_report

from analytic.studies.growth import best_over_k, counts_seconds, curve_shape

PETSC_PREFIXES: tuple[str, ...] = ()
OUTPUTS = ("contrast.csv", "summary.json", "contrast.png", "run.json", "run.lock")


def build_parser() -> argparse.ArgumentParser:
    """Command-line options."""
    ap = _cli.make_parser(__doc__, PETSC_PREFIXES, petsc=False)
    _cli.add_param_arguments(ap)
    ap.add_argument("--mu2-grid", default="0.1:100:13log", help="substrate stiffnesses mu2")
    ap.add_argument("--rho2-exponent", type=float, default=0.0,
                    help="material line rho2 = --rho2 * mu2^e (0: fixed density)")
    ap.add_argument("--H2s", default="H,inf",
                    help="substrate heights, comma list ('H': the slider's, 'inf': half-space)")
    ap.add_argument("--k", default="0.1:20:16log", help="k grid of the maximisation")
    ap.add_argument("--c-max", default="4",
                    help="region: largest phase velocity, in units of the largest c_d, or auto "
                    "(grown per k until it provably holds the fastest mode)")
    ap.add_argument("--re-min", type=float, default=1e-4,
                    help="region: smallest Re Lambda (> 0: unstable modes, physical sheet)")
    ap.add_argument("--fe-check", choices=("no", "yes"), default="no",
                    help="yes: the finite elements' own fastest mode at each finite-H2 point's k "
                    "(columns fe_*)")
    ap.add_argument("--out", default=os.path.join("out", "contrast"), help="output folder")
    return ap


def heights(spec: str, H: float) -> list[float]:
    """``--H2s`` as numbers."""
    out = []
    for tok in spec.split(","):
        tok = tok.strip()
        try:
            v = H if tok == "H" else float(tok)
        except ValueError:
            raise _cli.ParameterError(f"--H2s: {tok!r} is not a number, 'H' or 'inf'") from None
        if not v > 0:
            raise _cli.ParameterError(f"--H2s: {tok!r} is outside its allowed range > 0")
        out.append(v)
    return out


def main(comm: object = None, argv: list[str] | None = None) -> int:
    """Run the contrast scan."""
    args, comm = _cli.start(build_parser(), argv, comm)
    p0 = _cli.params_from_args(args)
    _cli.require_finite_heights(p0, "a finite slider")
    mus = _cli.parse_grid(args.mu2_grid, "--mu2-grid", max_count=10000)
    ks = _cli.parse_grid(args.k, "--k", max_count=10000)
    h2s = heights(args.H2s, p0.H)
    if not (math.isfinite(args.rho2_exponent) and abs(args.rho2_exponent) <= 4):
        raise _cli.ParameterError(f"--rho2-exponent = {args.rho2_exponent} is outside its "
                                  "allowed range -4..4")
    region = _cli.region_from_args(args.c_max, args.re_min)
    if args.fe_check == "yes":
        fe_ready()  # collective: PETSc's initialisation
    cases = [(m, h) for h in h2s for m in mus]
    params = [p0.replace(mu2=float(m), rho2=float(p0.rho2 * m ** args.rho2_exponent), H2=h)
              for m, h in cases]  # validates every case before any work
    for q in params:  # the largest c_d sets the region's height
        _cli.check_roots_region(q, float(ks[-1]), region, "--k or --c-max")
    config = {"params": p0.as_dict(), "mu2_grid": args.mu2_grid, "H2s": h2s, "k": args.k,
              "rho2_exponent": args.rho2_exponent, "region": region.as_dict(p0)}
    with _cli.RunFolder(comm, args.out, "contrast", config, outputs=OUTPUTS) as run:
        refine = 8 * min(2, len(ks))  # best_over_k: 8 samples around each of the best 2
        _cli.say_plan(comm, f"{len(cases)} (mu2, H2) case(s) x {len(ks)} k values + {refine}",
                      counts_seconds([[(q, k) for k in [*ks, *[ks[len(ks) // 2]] * refine]]
                                      for q in params], region, comm.size))

        def case(i: int) -> dict:  # the curve's point, and the FE's own check of it
            r = best_over_k(params[i], ks, region)
            if args.fe_check == "no":
                return r
            exact = None if r["re_lambda"] is None else complex(r["re_lambda"], r["im_lambda"])
            return r | fe_point(params[i], r["k"], exact, region)

        res = _cli.progress_mapper(comm, "(mu2, H2) cases", False, " cases")(
            [1.0 + (not math.isfinite(h)) for _, h in cases], case)  # a bar: minutes per case
        if comm.rank == 0:
            rows = [{"mu2": float(m), "rho2": params[i].rho2, "H2": h, **res[i]}
                    for i, (m, h) in enumerate(cases)]
            with _cli.atomic_open(run.file("contrast.csv"), "w", newline="") as fh:
                w = csv.DictWriter(fh, fieldnames=list(rows[0]))
                w.writeheader()
                w.writerows(rows)
            curves = {str(h): curve_shape(mus, [r["re_lambda"] if r["re_lambda"] is not None
                                                else 0.0 for r in rows if r["H2"] == h], "mu2")
                      for h in h2s}
            summary = {"config": config, "curves": curves, "rows": rows,
                       "note": "re_lambda None: no root in the region at any k of the grid",
                       "versions": _cli.versions(), "command": _cli.command()}
            with _cli.atomic_open(run.file("summary.json"), "w") as fh:
                _cli.json_dump(summary, fh, indent=1)
            plot(run.file("contrast.png"), p0, rows, h2s, config)
            for h, c in curves.items():
                mine = [r for r in rows if str(r["H2"]) == h]
                proof = _cli.proof_clause(sum(r["proven_k_count"] for r in mine),
                                          sum(r["k_with_root"] for r in mine))
                _cli.say(f"H2 = {h}: max growth {c['max_growth']:.4f} at mu2 = "
                         f"{c['mu2_at_max']:.3g}; monotonic in mu2: {c['monotonic']}; {proof}")
    failed = sum(r["failed_counts"] for r in res.values())
    line, fe_failed = fe_report(list(res.values()))
    if line:
        _cli.say(line)
    if fe_failed:
        _cli.say(f"warning: the FE check failed at {fe_failed} point(s); see fe_closed and "
                 "fe_rel_diff in contrast.csv", err=True)
    if failed:
        _cli.say(f"warning: the count failed at {failed} grid k value(s) (those k are left out "
                 "of the maximisation); see failed_counts in contrast.csv", err=True)
    return 1 if failed or fe_failed else 0


def plot(path: str, p: object, rows: list[dict], h2s: list[float], meta: dict) -> None:
    """contrast.png: largest growth rate against mu2 for each H2."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 4.5))
    for h in h2s:
        sel = [r for r in rows if r["H2"] == h]
        mu = [r["mu2"] for r in sel]
        g = [r["re_lambda"] if r["re_lambda"] is not None else np.nan for r in sel]
        ax.semilogx(mu, g, "o-", ms=4, label=f"H2 = {h:g}" if math.isfinite(h) else
                    "H2 = inf (half-space)")
    ax.axvline(1.0, color="0.6", lw=0.6, ls=":")
    ax.set_xlabel("substrate stiffness mu2 (slider: 1)")
    ax.set_ylabel(r"largest growth rate max Re $\Lambda$")
    ax.set_title(f"bc={p.bc}, bc2={p.bc2}, f={p.f:g}, gamma={p.gamma:g}, beta={p.beta:g}, "
                 f"Delta={p.Delta:g}, H={p.H:g}; rho2 = {p.rho2:g} mu2^"
                 f"{meta['rho2_exponent']:g}", fontsize=8)
    ax.legend(fontsize=8)
    fig.tight_layout()
    _cli.save_figure(fig, path, dpi=130,
                     metadata=_cli.png_metadata(meta, "growth rate vs contrast"))
    plt.close(fig)


if __name__ == "__main__":
    _cli.run(main)
