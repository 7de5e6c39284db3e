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
from _plot_gallery import (  # noqa: E402
    plot_both,
    plot_comparison,
    plot_fe,
    plot_finite_h,
    plot_gaps,
    plot_modified,
    plot_phase_diagram,
    plot_stress_top,
)

from mpi4py import MPI

from analytic.params import ParameterError
from analytic.studies import gallery
from analytic.studies.gallery import FETask, FigureData
from forms.studies import gallery as fe_gallery
from forms.studies.gallery import CS_DEGREE, PML_DEGREE

#: Options prefixes of the SLEPc objects: cross-section solves, PML solves.
PETSC_PREFIXES = (fe_gallery.CS_PREFIX, "pml_")
FE_LEGEND = {"cross_section": f"FE, cross-section P{CS_DEGREE}",
             "pml": f"FE, half-space PML P{PML_DEGREE}"}
FE_MARKER = {"cross_section": "o", "pml": "D"}


# ---------------------------------------------------------------------------------- drawing


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
    _cli.say_plan(comm, f"{len(names)} figure(s)" + ("" if opts.no_fe else " with FE points"),
                  gallery.estimate_seconds(names, settings, not opts.no_fe, comm.size))
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
