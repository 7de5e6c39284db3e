"""Stability map: the largest growth rate over every mode and every k H <= kH-max, on a 2-D grid.

    mpirun -n N python workflows/stability_map.py --x Delta:-1:1:41 --y H:0.1:10:41log
        [--kH-max 10] [--nk 24] [--bc velocity] [--out DIR] [--resume]

Each point of the grid of two parameters (``--x``, ``--y``: ``name:start:stop:count`` or
``...:countlog``, name one of ``analytic.studies.stability_map.AXES``) gets the fastest exact root
in the region (argument principle on ``det_M``; ``--re-min``, ``--c-max``: ``auto``, the
sweep's adaptive region (default), or a fixed bound such as 4 ``c_d``) at ``--nk`` values of
``k H`` from ``--kH-min`` to ``--kH-max`` (geometric), the largest local maxima refined along
their family (``analytic.studies.stability_map.map_point``). "Stable" means a certified zero count
at every grid ``k`` (nothing is proven between grid points). Points are shared over the ranks and
each is written at once to ``DIR/raw/p#####.json``, a part of :mod:`_parts` (``--resume``
continues a run with the same parameters: the points there are not computed again). Writes
``stability_map.csv``, ``summary.json``, ``stability_map.png`` (with the boundary
max Re Lambda = 0 and the closed-form k H -> infinity boundary of ``phase_diagram.py``).
Exit code 1 if a root count failed somewhere (the point is then not called stable).
``--fe-check yes``: the map's fastest point handed to the certified FE sweep's own path at its
``k`` (no exact root consulted; ``workflows/_points.py``), ``all``: every unstable point's fastest
mode: ``summary.json`` ``fe_check`` (with each point's ``x``, ``y``); exit code 1 also where the
FE's count did not close or its fastest eigenvalue is not that point's (``all`` leaves a
stable point unchecked). ``grid``: as ``all``,
and every point's value found by the finite elements alone: the FE's own fastest eigenvalue
(or its zero count: stable) at every ``k H`` of the grid, the largest local maxima of those
refined along the FE's modes and certified at their ``k`` (``forms.studies.peaks``), the
largest set against the exact point (``summary.json`` ``fe_grid``, every sample in
``fe_grid.csv``; exit code 1 where a count did not close or the FE's value is not the exact
point's mode or stability).
"""

from __future__ import annotations

import argparse
import csv
import math
import os

import _cli
import _plots
import numpy as np
from _points import GRID_COLUMNS, fe_points, fe_ready, fe_report, map_fe_grid, map_fe_line

from analytic.studies import stability_map as sm

PETSC_PREFIXES: tuple[str, ...] = ()
OUTPUTS = ("stability_map.csv", "summary.json", "stability_map.png", "fe_grid.csv", "run.json",
           "run.lock", "raw")
COLUMNS = ("ix", "iy", "x", "y", "re_lambda", "im_lambda", "k", "kH", "phase_velocity_over_c_d",
           "stable_on_grid", "unstable_k_count", "failed_counts", "proven_k_count",
           "c_max_largest", "delta_closed_form")


def build_parser() -> argparse.ArgumentParser:
    """Command-line options."""
    ap = _cli.make_parser(__doc__, PETSC_PREFIXES, petsc=False)
    _cli.add_param_arguments(ap)
    ap.add_argument("--x", default="Delta:-1:1:5", help="x axis: name:start:stop:count[log]")
    ap.add_argument("--y", default="H:0.1:10:5log", help="y axis: name:start:stop:count[log]")
    ap.add_argument("--kH-max", type=float, default=10.0, help="largest k H sampled")
    ap.add_argument("--kH-min", type=float, default=0.05, help="smallest k H sampled")
    ap.add_argument("--nk", type=int, default=24, help="k H samples per point (geometric)")
    # auto by default (session 12): the region that provably holds the fastest mode wherever
    # the tail bound can prove it. At a stable k nothing can be proven and the region climbs to
    # the ladder's top (32 c_d); the default 5 x 5 map took 29.9 s against 23.7 s with 4 c_d
    # (one rank each, side by side), the same values, 586 against 569 proven grid k. The counts
    # that failed there before (gamma = 0.01, H = 1, k = 0.05) were det_M's large dynamic range
    # on the contour taken for a zero (analytic.numerics.roots._increments), not a root.
    ap.add_argument("--c-max", default="auto",
                    help="region: largest phase velocity, in units of c_d, or 'auto': per k, "
                    "until the tail bound proves the region holds the fastest mode (or the "
                    "ladder's top)")
    ap.add_argument("--re-min", type=float, default=1e-6,
                    help="region: smallest Re Lambda counted as unstable (> 0: the contour "
                    "stays off Lambda = 0)")
    ap.add_argument("--fe-check", choices=("no", "yes", "all", "grid"), default="no",
                    help="yes: the map's fastest point found again by the finite elements at its "
                    "k; all: every unstable point's (summary.json fe_check); grid: as all, and "
                    "every point's value found by the FE alone: its fastest eigenvalue at every "
                    "k H of the grid, its peaks refined along its modes (summary.json fe_grid, "
                    "fe_grid.csv); not a parameter of the points: --resume keeps them")
    ap.add_argument("--resume", action="store_true", help="continue a run with the same "
                    "parameters in --out")
    ap.add_argument("--out", default=os.path.join("out", "stability_map"), help="output folder")
    return ap


def validate(args: argparse.Namespace) -> tuple:
    """Parameters, axes, k H grid and region; raises ParameterError (one line) on bad input."""
    base = _cli.params_from_args(args)
    x, y = sm.parse_axis(args.x, "--x"), sm.parse_axis(args.y, "--y")
    if x[0] == y[0]:
        raise _cli.ParameterError(f"--x and --y both vary {x[0]}: choose two parameters")
    if not (0 < args.kH_min < args.kH_max and math.isfinite(args.kH_max)):
        raise _cli.ParameterError(f"--kH-max = {args.kH_max} and --kH-min = {args.kH_min}: need "
                                  "0 < kH-min < kH-max (finite)")
    if not 2 <= args.nk <= 10000:
        raise _cli.ParameterError(f"--nk = {args.nk} is outside its allowed range 2 .. 10000")
    if not 0 < args.re_min < 1:
        raise _cli.ParameterError(f"--re-min = {args.re_min} is outside its allowed range "
                                  "0 < re-min < 1")
    region = _cli.region_from_args(args.c_max, args.re_min)
    for xv in x[1]:  # every point valid (finite H), before any file is written
        for yv in y[1]:
            p = sm.point_params(base, (x[0], xv), (y[0], yv))
            _cli.require_finite_heights(p, "a strip")
    return base, x, y, sm.kh_grid(args.kH_min, args.kH_max, args.nk), region


def main(comm: object = None, argv: list[str] | None = None) -> int:
    """Compute the map (points shared over the ranks; each written as it is done)."""
    args, comm = _cli.start(build_parser(), argv, comm)
    base, x, y, khs, region = validate(args)
    if args.fe_check != "no":
        fe_ready()  # collective: PETSc's initialisation
    nx, ny = len(x[1]), len(y[1])
    config = {"params": base.as_dict(), "x": args.x, "y": args.y, "kH": [float(v) for v in khs],
              "region": region.as_dict(base)}
    with _cli.RunFolder(comm, args.out, "stability_map", config, resume=args.resume,
                        resumable=True, outputs=OUTPUTS) as run:
        parts = run.parts("raw", "p{:05d}", count=nx * ny)  # cleared unless --resume
        todo = set(parts.todo)
        t_est = sm.estimate_seconds(base, x, y, khs, region, comm.size) * len(todo) / (nx * ny)
        _cli.say_plan(comm, f"{len(todo)} map point(s) x {len(khs)} k H values", t_est,
                      "(plus the refinement of each point's peaks)")

        def point(i: int) -> dict:
            if i not in todo:  # --resume: done by the interrupted run
                row = parts.load(i)  # strict JSON: no closed form (NaN) came back as null
                return {**row, "delta_closed_form": math.nan if row["delta_closed_form"] is None
                        else row["delta_closed_form"]}
            ix, iy = i % nx, i // nx
            p = sm.point_params(base, (x[0], x[1][ix]), (y[0], y[1][iy]))
            return parts.save(i, {"ix": ix, "iy": iy, "x": float(x[1][ix]), "y": float(y[1][iy]),
                                  **sm.map_point(p, khs, region),
                                  "delta_closed_form": sm.closed_form_delta(p)})

        rows = _cli.progress_mapper(comm, "map points", unit=" points")(  # a bar from the start
            [1.0] * (nx * ny), point)
        failed = sum(rows[i]["failed_counts"] for i in rows)
        rows = [rows[i] for i in range(nx * ny)]
        unstable = [r for r in rows if r["re_lambda"] is not None]
        fastest = max(unstable, key=lambda r: r["re_lambda"]) if unstable else None
        checked = [] if args.fe_check == "no" or fastest is None else (
            [fastest] if args.fe_check == "yes" else unstable)
        got = fe_points(
            comm, [sm.point_params(base, (x[0], r["x"]), (y[0], r["y"])) for r in checked],
            [(r["k"], complex(r["re_lambda"], r["im_lambda"])) for r in checked],
            region) if checked else []
        fe = [{"x": r["x"], "y": r["y"]} | g for r, g in zip(checked, got, strict=True)]
        fe_line, fe_failed = fe_report(fe)
        fe_grid, fe_samples = map_fe_grid(  # every point's value by the FE alone
            comm, [sm.point_params(base, (x[0], r["x"]), (y[0], r["y"])) for r in rows], khs,
            region, rows) if args.fe_check == "grid" else ([], [])
        grid_line, grid_failed = map_fe_line(fe_grid) if fe_grid else (None, 0)
        if comm.rank == 0:
            with _cli.atomic_open(run.file("stability_map.csv"), "w", newline="") as fh:
                w = csv.DictWriter(fh, fieldnames=COLUMNS, extrasaction="ignore")
                w.writeheader()
                w.writerows(rows)
            if fe_samples:
                with _cli.atomic_open(run.file("fe_grid.csv"), "w", newline="") as fh:
                    w = csv.DictWriter(fh, fieldnames=GRID_COLUMNS, extrasaction="ignore")
                    w.writeheader()
                    w.writerows(fe_samples)
            summary = {"parameters": base.as_dict(), "x": {"name": x[0], "spec": args.x},
                       "y": {"name": y[0], "spec": args.y}, "region": region.as_dict(base),
                       "kH_grid": {"min": args.kH_min, "max": args.kH_max, "count": args.nk,
                                   "ratio": float(khs[1] / khs[0])},
                       "coverage": COVERAGE, "points": nx * ny,
                       "stable_on_grid": sum(bool(r["stable_on_grid"]) for r in rows),
                       "fastest_point": fastest, **({"fe_check": fe} if fe else {}),
                       **({"fe_grid": fe_grid} if fe_grid else {}),
                       "failed_counts": failed,
                       "resumed": run.resumed, "mpi_ranks": comm.size,
                       "versions": _cli.versions(), "command": _cli.command()}
            _cli.write_json(run.file("summary.json"), summary)
            plot(run.file("stability_map.png"), rows, x, y, base, config)
            proof = _cli.proof_clause(sum(r["proven_k_count"] for r in rows),
                                      sum(r["unstable_k_count"] for r in rows))
            _cli.say(f"{summary['stable_on_grid']} of {nx * ny} points stable on the k H grid "
                     f"(kH <= {args.kH_max:g}); fastest: " + ("none" if fastest is None else
                     f"Re Lambda = {fastest['re_lambda']:.5g} at {x[0]} = {fastest['x']:g}, "
                     f"{y[0]} = {fastest['y']:g}, k H = {fastest['kH']:.4g}; {proof}"))
            for line in (fe_line, grid_line):
                if line:
                    _cli.say(line)
            if failed:
                _cli.say(f"warning: {failed} root count(s) failed (see failed_counts in "
                         "stability_map.csv)", err=True)
        comm.Barrier()  # a rank leaving with code 1 first would make mpirun stop rank 0's writing
    return 1 if failed or fe_failed or grid_failed else 0


#: What summary.json says about the coverage in k.
COVERAGE = ("at every k H of the geometric grid, certified counts (argument principle on det_M) "
            "proving the fastest root in the region: of a band left of the fastest root "
            "reached from the previous k's roots when that band holds only roots reached, "
            "else of the region and bands of it (a zero count, stable, is always the whole "
            "region's); the two largest local maxima of the samples refined "
            "along their root family; nothing is proven between grid points; proven_k_count: "
            "the grid k at which the tail bound proves that no root beyond the region grows "
            "faster (with c_max auto the region grows until it does: the ladder to 32 c_d, then "
            "boxes up to 4x as tall, each solved only where its tail bound proves)")


def plot(path: str, rows: list[dict], x: tuple, y: tuple, base: object, meta: dict) -> None:
    """stability_map.png: max Re Lambda, the boundary max Re Lambda = 0, the closed form."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    nx, ny = len(x[1]), len(y[1])
    g = np.zeros((ny, nx))
    dcf = np.full((ny, nx), np.nan)
    for r in rows:
        g[r["iy"], r["ix"]] = r["re_lambda"] if r["re_lambda"] is not None else 0.0
        dcf[r["iy"], r["ix"]] = r["delta_closed_form"]
    fig, ax = plt.subplots(figsize=(7, 5.5))
    from matplotlib.colors import LogNorm

    norm = LogNorm(g[g > 0].min(), g.max()) if (g > 0).sum() > 1 else None
    m = ax.pcolormesh(x[1], y[1], np.where(g > 0, g, np.nan), shading="nearest", cmap="magma_r",
                      norm=norm)
    fig.colorbar(m, ax=ax, label=r"max Re $\Lambda$ over modes and k H (blank: stable)")
    fast = [(x[1][r["ix"]], y[1][r["iy"]]) for r in rows
            if (r.get("phase_velocity_over_c_d") or 0.0) > 1.0]
    if fast:
        ax.plot(*zip(*fast, strict=True), "o", ms=3, mfc="none", mec="tab:blue",
                label="fastest mode: phase velocity > c_d (waves trapped in the strip)")
    stable = np.array([[0.0] * nx for _ in range(ny)])
    for r in rows:
        stable[r["iy"], r["ix"]] = 1.0 if r["stable_on_grid"] else 0.0
    if 0 < stable.sum() < stable.size:
        ax.contour(x[1], y[1], stable, levels=[0.5], colors="tab:cyan", linewidths=2)
        ax.plot([], [], color="tab:cyan", lw=2, label=r"max Re $\Lambda$ = 0 (computed)")
    delta = np.array([[sm.point_params(base, (x[0], xv), (y[0], yv)).Delta
                       for xv in x[1]] for yv in y[1]])
    if np.isfinite(dcf).any() and np.nanmin(delta - dcf) < 0 < np.nanmax(delta - dcf):
        ax.contour(x[1], y[1], delta - dcf, levels=[0.0], colors="tab:green", linestyles="--")
        ax.plot([], [], color="tab:green", ls="--", label="closed form, k H -> inf")
    for axis, (name, vals) in (("x", x), ("y", y)):
        if name in sm.LOG_AXES and vals[0] > 0 and vals[-1] / vals[0] > 20:
            getattr(ax, f"set_{axis}scale")("log")
    ax.set_xlabel(x[0])
    ax.set_ylabel(y[0])
    ax.set_title(f"bc={base.bc}, f={base.f:g}, gamma={base.gamma:g}, beta={base.beta:g}, "
                 f"alpha_pc={base.alpha_pc:g}; k H <= {meta['kH'][-1]:g}", fontsize=9)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    _plots.save_png(fig, path, meta)
    plt.close(fig)


if __name__ == "__main__":
    _cli.run(main)
