"""Gallery: every figure of the paper that has data, regenerated into one folder.

    python workflows/figures.py --out out/figures
    mpirun -n 2 python workflows/figures.py --out out/figures   # figures split over ranks

Figures (``--only`` takes a comma list of these names):

- ``finiteH``: waveguide growth ``H Re Lambda`` vs ``Hk`` for several ``gamma f`` and ``n``,
  and for several ``H`` (Fig. finiteH), with the small-``k`` slope of Eq. (Hspectrum)
  (``analytic.numerics.branches``, ``analytic.physics.smallk``);
- ``comparison``: ``Re lambda`` and ``Re z`` vs ``q`` for several ``gamma f``, exact roots of
  ``s(z, q)`` and Eqs. (analytic_spectrum), (kappa_d)+(kappa_d1) (Fig. comparison);
- ``both``: dilatational and shear instabilities at small ``Delta`` (Fig. both);
- ``phase_diagram``: Fig. stability_diagram (:mod:`analytic.physics.phase_diagram`, as
  ``workflows/phase_diagram.py``);
- ``modified1`` / ``modified2``: effect of ``alpha_PC`` / ``alpha_LD`` (Figs. modified1/2);
- ``stress_top``: velocity vs stress top condition at finite ``H`` (Appendix B figure),
  ``analytic.numerics.branches``;
- ``gaps``: the gaps of the spectrum closed by ``s~`` (Appendix C, Fig. gaps).

Every PNG carries its command line and parameters in the PNG metadata (``Description``,
``Comment``); ``DIR/figures.json`` lists what was made.

FE points: every figure except the phase diagram gets FE eigenvalues computed here, at up to
``--fe-points`` points per curve, with the exact root as reference: the cross-section model
(finite H) and the PML half-space model (``forms.models.pml.solve_halfspace``, including
``alpha_PC``/``alpha_LD``: the friction row carries them). Only points the FE itself trusts
are drawn (cross-section: converged, backward error < 1e-10; PML: no flag); ``figures.json``
lists per figure the number of points, the largest relative deviation from the exact root and
every skipped point with its reason. ``--no-fe``: analytic curves only.

Overlaying other data (e.g. FE eigenvalues): with ``--overlay DIR``, a file
``DIR/<figure>.csv`` with columns ``x, y, label`` (and optionally ``panel``, 0-based) is plotted
as markers on that figure (``x, y`` in the figure's axes units: ``q`` or ``Hk``, growth rate).
"""

from __future__ import annotations

import argparse
import os
import time

import _cli
import _plots
import numpy as np

from mpi4py import MPI

from analytic.params import ParameterError
from analytic.studies import gallery
from analytic.studies.gallery import FETask, FigureData, Series
from forms.studies import gallery as fe_gallery
from forms.studies.gallery import CS_DEGREE, PML_DEGREE, Marker

#: Options prefixes of the SLEPc objects: cross-section solves, PML solves.
PETSC_PREFIXES = (fe_gallery.CS_PREFIX, "pml_")
FE_LEGEND = {"cross_section": f"FE, cross-section P{CS_DEGREE}",
             "pml": f"FE, half-space PML P{PML_DEGREE}"}
FE_MARKER = {"cross_section": "o", "pml": "D"}


# ---------------------------------------------------------------------------------- drawing
def plot_series(axes, series: list[Series]) -> None:  # noqa: ANN001
    """Draw computed curves on their panels, in order."""
    for s in series:
        axes[s.panel].plot(s.x, s.y, s.fmt, color=s.color, lw=s.lw, label=s.label,
                           alpha=s.alpha)


def plot_overlay(ax, overlay: dict[int, dict[str, np.ndarray]],  # noqa: ANN001
                 panel: int = 0) -> None:
    """Draw the overlay points of ``panel`` (``analytic.studies.gallery.read_overlay``)."""
    for label, (x, y) in overlay.get(panel, {}).items():
        ax.plot(x, y, "s", ms=4, mfc="none", label=label)


def plot_fe(fig, markers: list[Marker]) -> None:  # noqa: ANN001
    """Draw the trusted FE points on ``fig`` and add their models to the panels' legends."""
    axes = fig.axes
    used: dict[int, set[str]] = {}
    for m in markers:
        axes[m.panel].plot([m.x], [m.y], FE_MARKER[m.model], color=m.color, mfc="none", ms=6,
                           mew=1.2, zorder=5)
        used.setdefault(m.panel, set()).add(m.model)
    for panel, models in used.items():
        ax = axes[panel]
        leg = ax.get_legend()
        size = leg.get_texts()[0].get_fontsize() if leg and leg.get_texts() else 8
        ncol = getattr(leg, "_ncols", 1) if leg else 1
        for m in sorted(models):
            ax.plot([], [], FE_MARKER[m], color="k", mfc="none", ms=6, mew=1.2,
                    label=f"{FE_LEGEND[m]} (trusted points)")
        ax.legend(fontsize=size, ncol=ncol)


def plot_comparison(d: FigureData, overlay: dict):  # noqa: ANN201
    """Fig. comparison: Re lambda (left) and Re z (right) vs q, exact and analytic."""
    import matplotlib.pyplot as plt

    p = d.params
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 4.6))
    plot_series((a1, a2), d.series)
    a1.axhline(0, color="k", lw=0.6)
    a1.set_yscale("symlog", linthresh=1e-4, linscale=1.5)
    a1.set(xscale="log", xlabel="q", ylabel=r"Re $\lambda$ = q Im z  (symlog, linear below 1e-4)")
    a1.set_title("growth rate: exact s(z,q) roots (solid), Eq. analytic_spectrum (dotted)",
                 fontsize=10)
    a2.set(xscale="log", xlabel="q", ylabel="Re z")
    a2.set_title("Re z: exact (solid), Eq. kappa_d with kappa_d1 (dotted)", fontsize=10)
    a2.axhline(1 / p["beta"], color="k", lw=0.6, ls="--")
    plot_overlay(a1, overlay, 0)
    plot_overlay(a2, overlay, 1)
    for a in (a1, a2):
        a.grid(alpha=0.3)
        a.legend(fontsize=8)
    fig.suptitle(f"dilatational branch, f = {p['f']}, beta = {p['beta']}, Delta = {p['Delta']} "
                 "(gaps: Appendix C)")
    fig.tight_layout()
    return fig


def plot_gaps(d: FigureData, overlay: dict):  # noqa: ANN201
    """Appendix C: roots of s (solid) and of s~ (dashed) join into continuous curves."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    plot_series([ax], d.series)
    ax.plot([], [], "-", color="tab:red", lw=2, label="roots of s (physical sheet)")
    ax.plot([], [], "--", color="tab:green", lw=2, label="roots of s~ (Eq. spectrum_dimless_gap)")
    ax.axhline(0, color="k", lw=0.6)
    plot_overlay(ax, overlay)
    ax.set(xscale="log", xlabel="q", ylabel=r"Re $\lambda$",
           title="gamma f = 0.96: the gap of s(z,q) is filled by s~ (Appendix C)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def plot_both(d: FigureData, overlay: dict):  # noqa: ANN201
    """Fig. both: dilatational and shear growth rates at small Delta, gamma = 0.25."""
    import matplotlib.pyplot as plt

    p = d.params
    fig, ax = plt.subplots(figsize=(8, 5))
    plot_series([ax], d.series)
    qc = p["qc_shear"]
    ax.annotate(f"q_c^(s) = {qc:.3f}", xy=(qc, 0), xytext=(0.6 * qc, 6e-4),
                arrowprops={"arrowstyle": "->"}, ha="center", fontsize=8)
    plot_overlay(ax, overlay)
    ax.set(xscale="log", xlabel="q", ylabel=r"Re $\lambda$ > 0")
    ax.set_title(f"gamma = {p['gamma']}, f = {p['f']}, beta = {p['beta']}: shear threshold at "
                 f"this gamma Delta_s = {p['delta_s']:.4f};\nEq. Delta_m: Delta^(m) = "
                 f"{p['delta_m']:.4f} (paper's caption: 0.024); solid dilatational, dashed shear",
                 fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    return fig


def plot_modified(d: FigureData, overlay: dict):  # noqa: ANN201
    """Figs. modified1/2: alpha_PC or alpha_LD, gamma = 3.2 (left) and 4 (right)."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 4.6))
    plot_series(axes, d.series)
    for panel, (ax, gamma) in enumerate(zip(axes, d.params["gamma"], strict=True)):
        plot_overlay(ax, overlay, panel)
        ax.set(xscale="log", xlabel="q", ylabel=r"Re $\lambda$ > 0")
        ax.set_title(f"gamma = {gamma} (Gamma = {0.3 * gamma:.2f}), f = 0.3, beta = 0.5, "
                     "Delta = 0.7\nthick: exact, thin: Eq. kappa_d2", fontsize=10)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def plot_phase_diagram(d: FigureData, overlay: dict):  # noqa: ANN201, ARG001
    """Fig. stability_diagram (the shared drawing of ``workflows/phase_diagram.py``)."""
    return _plots.draw_phase_diagram(d.extra["rows"], d.extra["records"], d.extra["window"])


def plot_finite_h(d: FigureData, overlay: dict):  # noqa: ANN201
    """Fig. finiteH: H Re Lambda vs Hk; left: gamma f and n (H = 0.5), right: H (n = 0)."""
    import matplotlib.pyplot as plt

    fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 4.6))
    plot_series((a1, a2), d.series)
    a1.plot([], [], "--", color="k", lw=0.8, label="Eq. Hspectrum (small k)")
    for ax, title in ((a1, "H = 0.5: several gamma f (n = 0) and n (gamma f = 0.9)"),
                      (a2, "n = 0, gamma = 3: several H (saturation at large H)")):
        ax.axhline(0, color="k", lw=0.6)
        ax.set(xlabel="H k", ylabel=r"H Re $\Lambda$  (units of $c_s/H$)")
        ax.set_title(title, fontsize=10)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    plot_overlay(a1, overlay, 0)
    plot_overlay(a2, overlay, 1)
    fig.suptitle("waveguide branches from the cut-offs, velocity top (f = 0.3, beta = 0.5, "
                 "Delta = 0.7)")
    fig.tight_layout()
    return fig


def plot_stress_top(d: FigureData, overlay: dict):  # noqa: ANN201
    """Appendix B figure: velocity vs stress top, gamma f = 0.9, n = 0, H = 0.5."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    plot_series([ax], d.series)
    plot_overlay(ax, overlay)
    ax.axhline(0, color="k", lw=0.6)
    ax.set(xlabel="H k", ylabel=r"H Re $\Lambda$")
    ax.set_title("gamma f = 0.9, n = 0, H = 0.5: velocity vs stress top condition", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


PLOTTERS = {"finiteH": plot_finite_h, "comparison": plot_comparison, "both": plot_both,
            "phase_diagram": plot_phase_diagram, "modified1": plot_modified,
            "modified2": plot_modified, "stress_top": plot_stress_top, "gaps": plot_gaps}


# -------------------------------------------------------------------------------------- main
def build_parser() -> argparse.ArgumentParser:
    """Command line."""
    ap = _cli.make_parser(__doc__, PETSC_PREFIXES, formatter_class=argparse.HelpFormatter)
    ap.add_argument("--out", default="out/figures", help="output folder")
    ap.add_argument("--only", default=None, help=f"comma list of {', '.join(gallery.FIGURES)}")
    ap.add_argument("--n-q", type=int, default=240, help="wavenumbers per curve")
    ap.add_argument("--n-gamma", type=int, default=16, help="Gamma points, phase diagram")
    ap.add_argument("--overlay", default=None,
                    help="folder with <figure>.csv (x, y, label[, panel]) to overlay")
    ap.add_argument("--fe-points", type=int, default=10,
                    help="FE points per curve (%(default)s)")
    ap.add_argument("--no-fe", action="store_true",
                    help="analytic curves only (no FE points)")
    return ap


def validate(opts: argparse.Namespace) -> list[str]:
    """Validate options before anything is written; returns the figure names."""
    names = list(gallery.FIGURES) if opts.only is None else [
        n.strip() for n in opts.only.split(",") if n.strip()]
    bad = [n for n in names if n not in gallery.FIGURES]
    if bad or not names:
        raise ParameterError(f"--only = {opts.only!r}: unknown figure {bad[0] if bad else ''!r};"
                             f" allowed: {', '.join(gallery.FIGURES)}")
    _cli.positive_int("--n-q", opts.n_q, minimum=10, maximum=100000)
    _cli.positive_int("--n-gamma", opts.n_gamma, minimum=2, maximum=2000)
    _cli.positive_int("--fe-points", opts.fe_points, minimum=2, maximum=1000)
    if opts.overlay is not None and not os.path.isdir(opts.overlay):
        raise ParameterError(f"--overlay = {opts.overlay!r} is not a folder")
    return names


def main(comm: MPI.Comm | None = None, argv: list[str] | None = None) -> int:
    """Make the figures and their FE points (both split over ranks); rank 0 writes the index."""
    opts, comm = _cli.start(build_parser(), argv, comm)
    names = validate(opts)  # every rank: same input, same verdict, before any collective
    parameters = {"figures": names, "n_q": opts.n_q, "n_gamma": opts.n_gamma,
                  "overlay": opts.overlay, "fe_points": opts.fe_points, "fe": not opts.no_fe}
    with _cli.RunFolder(comm, opts.out, "figures", parameters,
                        outputs=("*.png", "figures.json")):
        return _run(comm, opts, names)


def _run(comm: MPI.Comm, opts: argparse.Namespace, names: list[str]) -> int:
    """Figures' data split over ranks, FE checks split over ranks, each rank writes its PNGs."""
    t_start = time.perf_counter()
    settings = gallery.Settings(n_q=opts.n_q, n_gamma=opts.n_gamma, fe_points=opts.fe_points)
    mine = _cli.my_share(comm, [gallery.FIGURE_COST[n] for n in names])
    data = [gallery.MAKERS[names[i]](settings) for i in mine]
    t_analytic = time.perf_counter() - t_start
    # FE: every rank sees every figure's tasks and solves its share of the units (collective).
    tasks = [] if opts.no_fe else [t for part in comm.allgather([t for d in data for t in d.tasks])
                                   for t in part]
    units = fe_gallery.fe_units(tasks)
    share = _cli.my_share(comm, [cost for cost, _ in units])
    results = fe_gallery.solve_fe(comm, tasks, units, share) if tasks else []
    t_fe = time.perf_counter() - t_start - t_analytic
    command = _cli.command()
    done = {d.name: _write_figure(opts, d, tasks, results) for d in data}
    parts = comm.gather(done, root=0)
    times = comm.gather((t_analytic, t_fe), root=0)
    if comm.rank == 0:
        index = {k: v for part in parts for k, v in part.items()}
        wall = time.perf_counter() - t_start
        with _cli.atomic_open(os.path.join(opts.out, "figures.json"), "w") as fh:
            _cli.json_dump({"command": command, "versions": _cli.versions(),
                       "ranks": comm.size, "fe_points_per_curve": opts.fe_points,
                       "fe": not opts.no_fe,
                       "seconds": {"wall": wall,
                                   "analytic_per_rank": [t[0] for t in times],
                                   "fe_per_rank": [t[1] for t in times]},
                       "figures": index}, fh, indent=2, default=str)
        for k in names:
            print(_index_line(k, index[k]), flush=True)
        print(f"wall time {wall:.1f} s on {comm.size} rank(s)", flush=True)
    return 0


def _write_figure(opts: argparse.Namespace, data: FigureData, tasks: list[FETask],
                  results: list[dict]) -> dict:
    """Draw one figure with its trusted FE points, save the PNG; its ``figures.json`` entry."""
    import matplotlib.pyplot as plt

    fig = PLOTTERS[data.name](data, gallery.read_overlay(opts.overlay, data.name))
    fe_info, markers = (("off (--no-fe)", []) if opts.no_fe else
                        fe_gallery.figure_check(data.name, tasks, results))
    plot_fe(fig, markers)
    path = os.path.join(opts.out, f"{data.name}.png")
    meta = {"figure": data.name, **data.params}
    if isinstance(fe_info, dict):
        meta["fe"] = {k: v for k, v in fe_info.items() if k != "skipped"}
    _cli.save_figure(fig, path, dpi=130, metadata=_cli.png_metadata(meta, os.path.basename(path)))
    plt.close(fig)
    return {"status": "written", "file": os.path.basename(path), "parameters": data.params,
            "fe": fe_info}


def _index_line(name: str, entry: dict) -> str:
    """The printed line of one figure: status and FE points."""
    line = f"{name}: {entry['status']}" + (f" ({entry['reason']})" if "reason" in entry else "")
    fe_info = entry.get("fe")
    if not isinstance(fe_info, dict):
        return line
    dev = fe_info["max_rel_deviation"]
    if dev is None:
        return line + f"; FE 0/{fe_info['requested']} points"
    return line + (f"; FE {fe_info['points']}/{fe_info['requested']} points, max rel. "
                   f"deviation {dev:.1e}")


if __name__ == "__main__":
    _cli.run(main)
