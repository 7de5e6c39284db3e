"""Gallery: every figure of the paper that has data, regenerated into one folder.

    python workflows/figures.py --out out/figures
    mpirun -n 2 python workflows/figures.py --out out/figures   # figures split over ranks

Figures (``--only`` takes a comma list of these names):

- ``finiteH``: waveguide growth ``H Re Lambda`` vs ``Hk`` for several ``gamma f`` and ``n``,
  and for several ``H`` (Fig. finiteH), with the small-``k`` slope of Eq. (Hspectrum)
  (``analytic.branches``, ``analytic.smallk``);
- ``comparison``: ``Re lambda`` and ``Re z`` vs ``q`` for several ``gamma f``, exact roots of
  ``s(z, q)`` and Eqs. (analytic_spectrum), (kappa_d)+(kappa_d1) (Fig. comparison);
- ``both``: dilatational and shear instabilities at small ``Delta`` (Fig. both);
- ``phase_diagram``: Fig. stability_diagram (:mod:`analytic.phase_diagram`, as
  ``workflows/phase_diagram.py``);
- ``modified1`` / ``modified2``: effect of ``alpha_PC`` / ``alpha_LD`` (Figs. modified1/2);
- ``stress_top``: velocity vs stress top condition at finite ``H`` (Appendix B figure),
  ``analytic.branches``;
- ``gaps``: the gaps of the spectrum closed by ``s~`` (Appendix C, Fig. gaps).

Every PNG carries its command line and parameters in the PNG metadata (``Description``,
``Comment``); ``DIR/figures.json`` lists what was made.

FE points: every figure except the phase diagram gets FE eigenvalues computed here, at up to
``--fe-points`` points per curve, with the exact root as reference: the cross-section model
(finite H) and the PML half-space model (``forms.pml.solve_halfspace``, including
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
import csv
import json
import os
import time
from collections.abc import Callable
from dataclasses import dataclass

import _cli
import _plots
import numpy as np

from mpi4py import MPI

from analytic import halfspace as hs
from analytic import largek as lk
from analytic import phase_diagram as pd
from analytic.branches import follow_branch
from analytic.halfspace import dilatational_tracks, physical_curve
from analytic.params import ParameterError, Params
from analytic.smallk import lambda_smallk
from forms.cross_section import CrossSectionModel
from forms.pml import design_layer, solve_halfspace
from forms.solvers import PolynomialSolver, shift_off

#: Options prefixes of the SLEPc objects: cross-section solves, PML solves.
PETSC_PREFIXES = ("gallery_cs_", "pml_")
#: Rough cost of each figure's analytic part, for sharing the figures over ranks (measured
#: order of magnitude: the phase diagram and the finite-H continuations are the slow ones).
FIGURE_COST = {"finiteH": 6.0, "comparison": 2.0, "both": 2.0, "phase_diagram": 8.0,
               "modified1": 2.0, "modified2": 2.0, "stress_top": 3.0, "gaps": 2.0}
FIGURES = ("finiteH", "comparison", "both", "phase_diagram", "modified1", "modified2",
           "stress_top", "gaps")


# ------------------------------------------------------------------------------- data helpers
def overlay(ax, name: str, opts: argparse.Namespace, panel: int = 0) -> None:  # noqa: ANN001
    """Plot ``opts.overlay/<name>.csv`` (columns x, y, label[, panel]) as markers."""
    if not opts.overlay:
        return
    path = os.path.join(opts.overlay, f"{name}.csv")
    if not os.path.exists(path):
        return
    groups: dict[str, list[tuple[float, float]]] = {}
    with open(path) as fh:
        for row in csv.DictReader(fh):
            if int(row.get("panel", 0) or 0) != panel:
                continue
            groups.setdefault(row.get("label", "overlay"), []).append(
                (float(row["x"]), float(row["y"])))
    for label, pts in groups.items():
        x, y = np.array(pts).T
        ax.plot(x, y, "s", ms=4, mfc="none", label=label)


# ------------------------------------------------------------------------------ FE markers
#: Element degree of the cross-section model (finite H); cells from
#: :func:`meshes.interval.default_cells` (the sweep's default mesh).
CS_DEGREE = 3
#: Largest backward error of a cross-section eigenpair drawn as trusted. Converged PEP pairs of
#: this model have 1e-16 .. 1e-14 (measured 2026-11-21 on the gallery's points); a pair above
#: this is not a converged eigenpair of the discrete problem.
CS_RESIDUAL = 1e-10
#: Element degree of the half-space (PML) model, ``forms.pml.solve_halfspace``'s default.
PML_DEGREE = 4
FE_MODELS = {
    "cross_section": f"cross-section model P{CS_DEGREE} (forms.cross_section, SLEPc PEP), "
                     f"trusted if converged and backward error < {CS_RESIDUAL:g}",
    "pml": f"half-space PML model P{PML_DEGREE} (forms.pml.solve_halfspace: two layer "
           "settings), trusted if no flag",
}
FE_LEGEND = {"cross_section": f"FE, cross-section P{CS_DEGREE}",
             "pml": f"FE, half-space PML P{PML_DEGREE}"}
FE_MARKER = {"cross_section": "o", "pml": "D"}


@dataclass(frozen=True)
class FETask:
    """One FE eigenvalue to compute and draw on top of an analytic curve.

    Attributes:
        figure: Figure name.
        curve: Label of the analytic curve it checks.
        color: Colour of that curve.
        model: ``"cross_section"`` (finite H) or ``"pml"`` (half-space).
        params: Parameters.
        k: Wavenumber.
        target: The exact root (shift of the eigensolver, and the reference).
        x: Abscissa in the figure's units (``q`` or ``Hk``).
        draw: ``(panel, quantity)`` pairs, quantity ``"growth"`` (``Re Lambda``),
            ``"H_growth"`` (``H Re Lambda``) or ``"re_z"`` (``Re z = Re(i Lambda / k)``).
        sheet: Sheet of the exact root (PML).
        n_max: Highest waveguide branch on the cross-section mesh.
    """

    figure: str
    curve: str
    color: str
    model: str
    params: Params
    k: float
    target: complex
    x: float
    draw: tuple[tuple[int, str], ...]
    sheet: str = "physical"
    n_max: int = 0


def sample(valid: np.ndarray, n: int) -> np.ndarray:
    """Up to ``n`` indices spread evenly over the True entries of ``valid`` (ends included)."""
    idx = np.flatnonzero(valid)
    if len(idx) <= n:
        return idx
    return idx[np.unique(np.round(np.linspace(0, len(idx) - 1, n)).astype(int))]


def fe_value(lam: complex, task: FETask, quantity: str) -> float:
    """Plotted quantity of ``Lambda`` for ``task``."""
    if quantity == "growth":
        return lam.real
    if quantity == "H_growth":
        return task.params.H * lam.real
    if quantity == "re_z":
        return (1j * lam / task.k).real
    raise ValueError(f"unknown quantity {quantity!r}")


def _fail(err: Exception) -> str:
    return f"error: {type(err).__name__}: {err}".replace("\n", " ")[:200]


def solve_cross_section(comm: MPI.Comm, tasks: list[FETask]) -> list[dict]:
    """FE eigenvalues of tasks sharing one parameter set, on one cross-section mesh."""
    t0 = time.perf_counter()
    model = CrossSectionModel(comm, tasks[0].params, degree=CS_DEGREE,
                              k_max=max(t.k for t in tasks), n_max=max(t.n_max for t in tasks))
    solver = PolynomialSolver(comm, nev=2, prefix="gallery_cs_")
    out = []
    for t in tasks:
        row = {"Lambda": complex("nan"), "residual": float("nan"), "flags": [],
               "size": model.size}
        try:
            # the exact root is (nearly) an eigenvalue: shift off it (forms.solvers.shift_off)
            res = solver.solve(model.operator(t.k), shift_off(t.target))
        except Exception as err:  # noqa: BLE001 - one failed solve must not stop the gallery
            row["flags"].append(_fail(err))
            solver.destroy()
            solver = PolynomialSolver(comm, nev=2, prefix="gallery_cs_")
            out.append(row)
            continue
        if res.pairs:  # the converged eigenvalue nearest the exact root
            pair = min(res.pairs, key=lambda q: abs(q.value - t.target))
            row["Lambda"], row["residual"] = pair.value, pair.residual
            if not row["residual"] < CS_RESIDUAL:
                row["flags"].append("residual")
        else:
            row["flags"].append("no_root")
        if not res.ok:
            row["flags"].append(f"not_converged ({res.reason})")
        res.destroy()
        out.append(row)
    solver.destroy()
    model.destroy()
    dt = (time.perf_counter() - t0) / len(tasks)
    for row in out:
        row["seconds"] = dt
    return out


def solve_pml(comm: MPI.Comm, task: FETask) -> dict:
    """FE half-space root near the exact one (PML, with its own failure checks)."""
    t0 = time.perf_counter()
    try:
        r = solve_halfspace(comm, task.params, task.k, task.target, degree=PML_DEGREE,
                            sheet=task.sheet)
        row = {"Lambda": r.Lambda, "residual": r.residual, "flags": list(r.flags),
               "size": max(r.sizes)}
    except Exception as err:  # noqa: BLE001 - one failed solve must not stop the gallery
        row = {"Lambda": complex("nan"), "residual": float("nan"), "flags": [_fail(err)],
               "size": 0}
    row["seconds"] = time.perf_counter() - t0
    return row


def fe_units(tasks: list[FETask]) -> list[tuple[float, list[int]]]:
    """Work units ``(estimated cost, task indices)``.

    One unit per cross-section curve (one mesh), one per PML point (cost from the size of the
    layer :func:`forms.pml.design_layer` would build).
    """
    units: list[tuple[float, list[int]]] = []
    curves: dict[tuple, list[int]] = {}
    for i, t in enumerate(tasks):
        if t.model == "cross_section":
            curves.setdefault((t.figure, t.curve, t.params), []).append(i)
        else:
            try:
                cells = design_layer(t.k, t.target, t.params.beta, PML_DEGREE,
                                     sheet=t.sheet).cells
            except ValueError:
                cells = 100
            units.append((2.0 * cells, [i]))
    units += [(400.0 + 20.0 * len(idx), idx) for idx in curves.values()]
    return units


def distribute(units: list[tuple[float, list[int]]], size: int) -> list[list[int]]:
    """The work units' task indices over ``size`` ranks (:func:`_cli.share_by_cost`)."""
    share = _cli.share_by_cost([u[0] for u in units], size)
    return [[i for j in part for i in units[j][1]] for part in share]


def solve_fe(comm: MPI.Comm, tasks: list[FETask]) -> list[dict]:
    """Every task solved once, split over the ranks (each on ``MPI.COMM_SELF``).

    Collective; every rank gets every result, in the order of ``tasks``.
    """
    mine = distribute(fe_units(tasks), comm.size)[comm.rank]
    results: dict[int, dict] = {}
    curves: dict[tuple, list[int]] = {}
    for i in mine:
        t = tasks[i]
        if t.model == "cross_section":
            curves.setdefault((t.figure, t.curve, t.params), []).append(i)
        else:
            results[i] = solve_pml(MPI.COMM_SELF, t)
    for idx in curves.values():
        results.update(zip(idx, solve_cross_section(MPI.COMM_SELF, [tasks[i] for i in idx]),
                           strict=True))
    merged: dict[int, dict] = {}
    for part in comm.allgather(results):
        merged.update(part)
    return [merged[i] for i in range(len(tasks))]


def draw_fe(fig, tasks: list[FETask], results: list[dict]) -> dict:  # noqa: ANN001
    """Draw the trusted FE points on ``fig`` and return their summary for ``figures.json``."""
    axes = fig.axes
    used: dict[int, set[str]] = {}
    skipped, dev, dev_y, seconds = [], [], [], 0.0
    for t, r in zip(tasks, results, strict=True):
        seconds += r["seconds"]
        lam = r["Lambda"]
        if r["flags"] or not np.isfinite(lam):
            skipped.append({"curve": t.curve, "k": t.k, "x": t.x,
                            "reason": ";".join(r["flags"]) or "no value"})
            continue
        dev.append(abs(lam - t.target) / abs(t.target))
        for panel, quantity in t.draw:
            y = fe_value(lam, t, quantity)
            dev_y.append(abs(y - fe_value(t.target, t, quantity)))
            axes[panel].plot([t.x], [y], FE_MARKER[t.model], color=t.color, mfc="none", ms=6,
                             mew=1.2, zorder=5)
            used.setdefault(panel, set()).add(t.model)
    for panel, models in used.items():
        ax = axes[panel]
        leg = ax.get_legend()
        size = leg.get_texts()[0].get_fontsize() if leg and leg.get_texts() else 8
        ncol = getattr(leg, "_ncols", 1) if leg else 1
        for m in sorted(models):
            ax.plot([], [], FE_MARKER[m], color="k", mfc="none", ms=6, mew=1.2,
                    label=f"{FE_LEGEND[m]} (trusted points)")
        ax.legend(fontsize=size, ncol=ncol)
    models = sorted({t.model for t in tasks})
    return {"models": [FE_MODELS[m] for m in models], "requested": len(tasks),
            "points": len(dev), "max_rel_deviation": max(dev) if dev else None,
            "median_rel_deviation": float(np.median(dev)) if dev else None,
            "max_abs_deviation_plotted": max(dev_y) if dev_y else None,
            "seconds": seconds, "skipped": skipped}


# ---------------------------------------------------------------------------------- figures
def halfspace_tasks(fe: list[FETask], figure: str, curve: str, color: str, p: Params,
                    roots: list[hs.HalfSpaceRoot], valid: np.ndarray, n: int,
                    draw: tuple[tuple[int, str], ...] = ((0, "growth"),)) -> None:
    """Append PML tasks at up to ``n`` of the drawn points (``valid``) of a half-space curve."""
    for i in sample(valid, n):
        r = roots[i]
        fe.append(FETask(figure, curve, color, "pml", p, float(r.q), complex(r.Lambda),
                         float(r.q), draw, sheet=r.sheet))


def fig_comparison(opts: argparse.Namespace, fe: list[FETask]):  # noqa: ANN201
    """Fig. comparison: Re lambda (left) and Re z (right) vs q, exact and analytic."""
    import matplotlib.pyplot as plt

    base = Params(f=0.3, beta=0.5, Delta=0.7)
    gfs = (0.6, 0.75, 0.84, 0.96, 1.2)
    qs = np.logspace(-2, 2, opts.n_q)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 4.6))
    for i, gf in enumerate(gfs):
        c = f"C{i}"
        p = base.replace(gamma=gf / base.f)
        tr = dilatational_tracks(qs, p)
        for j, b in enumerate(("unstable", "stable")):
            lab = f"gamma f = {gf:g}" if j == 0 else None
            a1.plot(qs, physical_curve(tr[b], lambda r: r.growth), "-", color=c, lw=1.6,
                    label=lab)
            a2.plot(qs, physical_curve(tr[b], lambda r: r.z.real), "-", color=c, lw=1.6,
                    label=lab)
            halfspace_tasks(fe, "comparison", f"gamma f = {gf:g} ({b})", c, p, tr[b],
                            np.isfinite(physical_curve(tr[b], lambda r: r.growth)),
                            max(2, opts.fe_points // 2), ((0, "growth"), (1, "re_z")))
        a1.plot(qs, lk.growth_rate_dilatational_physical(qs, p), ":", color=c, lw=1.4)
        zl = np.where(lk.growth_rate_dilatational(qs, p) > 0, lk.z_linear(qs, p, "unstable"),
                      lk.z_linear(qs, p, "stable"))
        a2.plot(qs, zl.real, ":", color=c, lw=1.4)
    a1.axhline(0, color="k", lw=0.6)
    a1.set_yscale("symlog", linthresh=1e-4, linscale=1.5)
    a1.set(xscale="log", xlabel="q", ylabel=r"Re $\lambda$ = q Im z  (symlog, linear below 1e-4)")
    a1.set_title("growth rate: exact s(z,q) roots (solid), Eq. analytic_spectrum (dotted)",
                 fontsize=10)
    a2.set(xscale="log", xlabel="q", ylabel="Re z")
    a2.set_title("Re z: exact (solid), Eq. kappa_d with kappa_d1 (dotted)", fontsize=10)
    a2.axhline(1 / base.beta, color="k", lw=0.6, ls="--")
    overlay(a1, "comparison", opts, 0)
    overlay(a2, "comparison", opts, 1)
    for a in (a1, a2):
        a.grid(alpha=0.3)
        a.legend(fontsize=8)
    fig.suptitle(f"dilatational branch, f = {base.f}, beta = {base.beta}, Delta = {base.Delta} "
                 "(gaps: Appendix C)")
    fig.tight_layout()
    return fig, {"f": base.f, "beta": base.beta, "Delta": base.Delta, "gamma_f": gfs,
                 "q": [qs[0], qs[-1], len(qs)]}


def fig_gaps(opts: argparse.Namespace, fe: list[FETask]):  # noqa: ANN201
    """Appendix C: roots of s (solid) and of s~ (dashed) join into continuous curves."""
    import matplotlib.pyplot as plt

    p = Params(f=0.3, beta=0.5, Delta=0.7, gamma=0.96 / 0.3)
    qs = np.logspace(-2, 2, opts.n_q)
    tr = dilatational_tracks(qs, p)
    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    for b, c in (("unstable", "C0"), ("stable", "C1")):
        ax.plot(qs, physical_curve(tr[b], lambda r: r.growth), "-", color="tab:red", lw=2)
        ax.plot(qs, physical_curve(tr[b], lambda r: r.growth, "s_tilde"), "--",
                color="tab:green", lw=2)
        ax.plot(qs, [r.growth for r in tr[b]], "-", color=c, lw=0.6, alpha=0.8,
                label=f"continued root, kappa_d function '{b}'")
        for sheet, col in (("physical", "tab:red"), ("s_tilde", "tab:green")):
            halfspace_tasks(fe, "gaps", f"{b} ({sheet})", col, p, tr[b],
                            np.isfinite(physical_curve(tr[b], lambda r: r.growth, sheet)),
                            max(2, opts.fe_points // 2))
    ax.plot([], [], "-", color="tab:red", lw=2, label="roots of s (physical sheet)")
    ax.plot([], [], "--", color="tab:green", lw=2, label="roots of s~ (Eq. spectrum_dimless_gap)")
    ax.axhline(0, color="k", lw=0.6)
    overlay(ax, "gaps", opts)
    ax.set(xscale="log", xlabel="q", ylabel=r"Re $\lambda$",
           title="gamma f = 0.96: the gap of s(z,q) is filled by s~ (Appendix C)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig, {**p.as_dict(), "q": [qs[0], qs[-1], len(qs)]}


def fig_both(opts: argparse.Namespace, fe: list[FETask]):  # noqa: ANN201
    """Fig. both: dilatational and shear growth rates at small Delta, gamma = 0.25."""
    import matplotlib.pyplot as plt

    f, beta, gamma = 0.3, 0.5, 0.25
    deltas = (0.0, 0.01, 0.02, 0.026, 0.035)
    qs = np.unique(np.concatenate([np.logspace(-2.5, 1, opts.n_q),
                                   np.linspace(0.03, 0.08, opts.n_q // 2),
                                   np.linspace(0.18, 0.32, opts.n_q // 2)]))
    fig, ax = plt.subplots(figsize=(8, 5))
    for i, d in enumerate(deltas):
        p = Params(f=f, beta=beta, gamma=gamma, Delta=d)
        dil = hs.follow("dilatational", qs, p)
        she = [hs.shear_root(float(q), p) for q in qs]
        gd = np.array([r.growth if (r.physical and r.growth > 0) else np.nan for r in dil])
        gs = np.array([r.growth if (r.physical and hs.in_family(r) and r.growth > 0)
                       else np.nan for r in she])
        ax.plot(qs, gd, "-", color=f"C{i}", lw=1.6, label=f"Delta = {d:g} dilatational")
        ax.plot(qs, gs, "--", color=f"C{i}", lw=1.6, label=f"Delta = {d:g} shear")
        halfspace_tasks(fe, "both", f"Delta = {d:g} dilatational", f"C{i}", p, dil,
                        np.isfinite(gd), opts.fe_points)
        halfspace_tasks(fe, "both", f"Delta = {d:g} shear", f"C{i}", p, she, np.isfinite(gs),
                        opts.fe_points)
    qc = lk.qc_shear(gamma, f, beta)
    ax.annotate(f"q_c^(s) = {qc:.3f}", xy=(qc, 0), xytext=(0.6 * qc, 6e-4),
                arrowprops={"arrowstyle": "->"}, ha="center", fontsize=8)
    overlay(ax, "both", opts)
    dm, ds = lk.delta_m(f, beta), float(lk.delta_s(gamma * f, f, beta))
    ax.set(xscale="log", xlabel="q", ylabel=r"Re $\lambda$ > 0")
    ax.set_title(f"gamma = {gamma}, f = {f}, beta = {beta}: shear threshold at this gamma "
                 f"Delta_s = {ds:.4f};\nEq. Delta_m: Delta^(m) = {dm:.4f} (paper's caption: "
                 "0.024); solid dilatational, dashed shear", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    return fig, {"f": f, "beta": beta, "gamma": gamma, "Delta": deltas,
                 "q": [qs[0], qs[-1], len(qs)], "qc_shear": qc, "delta_s": ds,
                 "delta_m": dm}


def _modified(opts: argparse.Namespace, fe: list[FETask], name: str, key: str,  # noqa: ANN202
              values: tuple[float, ...]):
    import matplotlib.pyplot as plt

    qs = np.logspace(-2, 3, opts.n_q)
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.6))
    for panel, (ax, gamma) in enumerate(zip(axes, (3.2, 4.0), strict=True)):
        for i, v in enumerate(values):
            p = Params(f=0.3, beta=0.5, Delta=0.7, gamma=gamma, **{key: v})
            roots = hs.follow("dilatational", qs, p)
            ex = np.array([r.growth if (r.physical and r.growth > 0) else np.nan for r in roots])
            an = lk.growth_linear(qs, p)
            ax.plot(qs, ex, "-", color=f"C{i}", lw=2.2, label=f"{key} = {v:g} exact")
            ax.plot(qs, np.where(an > 0, an, np.nan), "-", color=f"C{i}", lw=0.8,
                    label=f"{key} = {v:g} Eq. kappa_d2")
            halfspace_tasks(fe, name, f"gamma = {gamma}, {key} = {v:g}", f"C{i}", p, roots,
                            np.isfinite(ex), opts.fe_points, ((panel, "growth"),))
        overlay(ax, name, opts, 0 if gamma == 3.2 else 1)
        ax.set(xscale="log", xlabel="q", ylabel=r"Re $\lambda$ > 0")
        ax.set_title(f"gamma = {gamma} (Gamma = {0.3 * gamma:.2f}), f = 0.3, beta = 0.5, "
                     "Delta = 0.7\nthick: exact, thin: Eq. kappa_d2", fontsize=10)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    return fig, {"f": 0.3, "beta": 0.5, "Delta": 0.7, "gamma": [3.2, 4.0], key: values,
                 "q": [qs[0], qs[-1], len(qs)]}


def fig_modified1(opts: argparse.Namespace, fe: list[FETask]):  # noqa: ANN201
    """Fig. modified1: alpha_PC (alpha_LD = 0)."""
    return _modified(opts, fe, "modified1", "alpha_pc", (0.0, 0.5, 1.0, 2.0, 5.0))


def fig_modified2(opts: argparse.Namespace, fe: list[FETask]):  # noqa: ANN201
    """Fig. modified2: alpha_LD (alpha_PC = 0), including alpha_LD > f."""
    return _modified(opts, fe, "modified2", "alpha_ld", (0.0, 0.1, 0.2, 0.4))


def fig_phase_diagram(opts: argparse.Namespace, fe: list[FETask]):  # noqa: ANN201, ARG001
    """Fig. stability_diagram (:mod:`analytic.phase_diagram`; analytic spectrum, no FE).

    The paper's rows on the default window, as ``workflows/phase_diagram.py --n-gamma N``.
    """
    rows, window = list(pd.PAPER_ROWS), pd.Window()
    grid = pd.gamma_grid(window.gamma_min, window.gamma_max, opts.n_gamma)
    records = [r for f, b, fam, g in pd.tasks(rows, grid)
               for r in pd.boundary_records(f, b, fam, g, window.delta_max)
               if "dropped" not in r]
    fig = _plots.draw_phase_diagram(rows, records, window)
    return fig, {"rows": rows, "n_gamma": opts.n_gamma,
                 "closed_form_vs_numerical": pd.measured_differences(records, rows)}


def _unstable_branch(p: Params, n: int, hk: np.ndarray):  # noqa: ANN202
    """``H Re Lambda`` on the partner of cut-off ``n`` that grows at small ``k``."""
    best = None
    for sign in (-1, 1):
        res = follow_branch(p, n, sign, hk / p.H)
        g = np.where(res.ok, res.Lambda.real, np.nan) * p.H
        if best is None or np.nanmax(np.r_[g[:3], -np.inf]) > np.nanmax(np.r_[best[0][:3],
                                                                              -np.inf]):
            best = (g, sign, res)
    return best


def finite_h_tasks(fe: list[FETask], figure: str, curve: str, color: str, p: Params, n: int,
                   res, panel: int, count: int) -> None:  # noqa: ANN001
    """Append cross-section tasks at up to ``count`` trusted points of a finite-H branch."""
    lam = np.asarray(res.Lambda)
    for i in sample(np.asarray(res.ok) & np.isfinite(lam), count):
        fe.append(FETask(figure, curve, color, "cross_section", p, float(res.k[i]),
                         complex(lam[i]), float(res.k[i] * p.H), ((panel, "H_growth"),),
                         n_max=n))


def fig_finiteH(opts: argparse.Namespace, fe: list[FETask]):  # noqa: ANN201, N802
    """Fig. finiteH: H Re Lambda vs Hk; left: gamma f and n (H = 0.5), right: H (n = 0)."""
    import matplotlib.pyplot as plt

    hk = np.linspace(0.02, 3.0, max(opts.n_q // 4, 12))
    base = Params(f=0.3, beta=0.5, Delta=0.7, H=0.5)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 4.6))
    gfs = (0.3, 0.6, 0.9, 1.2)
    signs = {}
    for i, gf in enumerate(gfs):
        p = base.replace(gamma=gf / base.f)
        g, sign, res = _unstable_branch(p, 0, hk)
        signs[f"gf={gf}"] = sign
        a1.plot(hk, g, "-", color=f"C{i}", lw=1.6, label=f"gamma f = {gf:g}, n = 0")
        finite_h_tasks(fe, "finiteH", f"gamma f = {gf:g}, n = 0", f"C{i}", p, 0, res, 0,
                       opts.fe_points)
        a1.plot(hk[hk < 0.8], p.H * lambda_smallk(hk[hk < 0.8] / p.H, 0, sign, p).real, "--",
                color="k", lw=0.8)
    p = base.replace(gamma=0.9 / base.f)
    for n, ls in ((1, "--"), (2, ":")):
        g, sign, res = _unstable_branch(p, n, hk)
        a1.plot(hk, g, ls, color="C2", lw=1.6, label=f"gamma f = 0.9, n = {n}")
        finite_h_tasks(fe, "finiteH", f"gamma f = 0.9, n = {n}", "C2", p, n, res, 0,
                       opts.fe_points)
        a1.plot(hk[hk < 0.8], p.H * lambda_smallk(hk[hk < 0.8] / p.H, n, sign, p).real, "--",
                color="k", lw=0.8)
    a1.plot([], [], "--", color="k", lw=0.8, label="Eq. Hspectrum (small k)")
    hs_ = (0.5, 1.0, 2.0, 5.0, 10.0)
    for i, h in enumerate(hs_):
        p = base.replace(H=h, gamma=3.0)
        g, _, res = _unstable_branch(p, 0, hk)
        a2.plot(hk, g, "-", color=f"C{i}", lw=1.6, label=f"H = {h:g}")
        finite_h_tasks(fe, "finiteH", f"H = {h:g}, n = 0", f"C{i}", p, 0, res, 1,
                       opts.fe_points)
    for ax, title in ((a1, "H = 0.5: several gamma f (n = 0) and n (gamma f = 0.9)"),
                      (a2, "n = 0, gamma = 3: several H (saturation at large H)")):
        ax.axhline(0, color="k", lw=0.6)
        ax.set(xlabel="H k", ylabel=r"H Re $\Lambda$  (units of $c_s/H$)")
        ax.set_title(title, fontsize=10)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    overlay(a1, "finiteH", opts, 0)
    overlay(a2, "finiteH", opts, 1)
    fig.suptitle("waveguide branches from the cut-offs, velocity top (f = 0.3, beta = 0.5, "
                 "Delta = 0.7)")
    fig.tight_layout()
    return fig, {**base.as_dict(), "gamma_f": gfs, "n": [0, 1, 2], "H_right": hs_,
                 "gamma_right": 3.0, "Hk": [hk[0], hk[-1], len(hk)], "signs": signs}


def fig_stress_top(opts: argparse.Namespace, fe: list[FETask]):  # noqa: ANN201
    """Appendix B figure: velocity vs stress top, gamma f = 0.9, n = 0, H = 0.5."""
    import matplotlib.pyplot as plt

    hk = np.linspace(0.02, 2.0, max(opts.n_q // 4, 12))
    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    params = {}
    for bc, c in (("velocity", "tab:red"), ("stress", "tab:green")):
        p = Params(f=0.3, beta=0.5, Delta=0.7, H=0.5, gamma=3.0, bc=bc)
        g, sign, res = _unstable_branch(p, 0, hk)
        ax.plot(hk, g, "-", color=c, lw=1.8,
                label=f"{bc} controlled top (branch 0{'+-'[sign < 0]})")
        finite_h_tasks(fe, "stress_top", f"{bc} top", c, p, 0, res, 0, opts.fe_points)
        params[bc] = p.as_dict()
    overlay(ax, "stress_top", opts)
    ax.axhline(0, color="k", lw=0.6)
    ax.set(xlabel="H k", ylabel=r"H Re $\Lambda$")
    ax.set_title("gamma f = 0.9, n = 0, H = 0.5: velocity vs stress top condition", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig, {"cases": params, "Hk": [hk[0], hk[-1], len(hk)]}


MAKERS: dict[str, Callable] = {
    "finiteH": fig_finiteH, "comparison": fig_comparison, "both": fig_both,
    "phase_diagram": fig_phase_diagram, "modified1": fig_modified1,
    "modified2": fig_modified2, "stress_top": fig_stress_top, "gaps": fig_gaps,
}


# -------------------------------------------------------------------------------------- main
def build_parser() -> argparse.ArgumentParser:
    """Command line."""
    ap = _cli.make_parser(__doc__, PETSC_PREFIXES, formatter_class=argparse.HelpFormatter)
    ap.add_argument("--out", default="out/figures", help="output folder")
    ap.add_argument("--only", default=None, help=f"comma list of {', '.join(FIGURES)}")
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
    names = list(FIGURES) if opts.only is None else [n.strip() for n in opts.only.split(",")
                                                      if n.strip()]
    bad = [n for n in names if n not in FIGURES]
    if bad or not names:
        raise ParameterError(f"--only = {opts.only!r}: unknown figure {bad[0] if bad else ''!r};"
                             f" allowed: {', '.join(FIGURES)}")
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
    t_start = time.perf_counter()
    done, figs = {}, {}
    tasks: list[FETask] = []
    mine = _cli.my_share(comm, [FIGURE_COST[n] for n in names])
    for name in [names[i] for i in mine]:
        fe: list[FETask] = []
        figs[name] = MAKERS[name](opts, fe)
        tasks += fe
    t_analytic = time.perf_counter() - t_start
    # FE: every rank sees every figure's tasks and solves its share (collective).
    all_tasks = [] if opts.no_fe else [t for part in comm.allgather(tasks) for t in part]
    results = solve_fe(comm, all_tasks) if all_tasks else []
    t_fe = time.perf_counter() - t_start - t_analytic
    import matplotlib.pyplot as plt

    command = _cli.command()
    for name, (fig, params) in figs.items():
        if opts.no_fe:
            fe_info: dict | str = "off (--no-fe)"
        else:
            mine = [(t, r) for t, r in zip(all_tasks, results, strict=True) if t.figure == name]
            fe_info = (draw_fe(fig, [t for t, _ in mine], [r for _, r in mine]) if mine else
                       "none: no FE counterpart (the boundaries come from the spectrum)"
                       if name == "phase_diagram" else "none: no curve points to check")
        path = os.path.join(opts.out, f"{name}.png")
        meta = {"figure": name, **params}
        if isinstance(fe_info, dict):
            meta["fe"] = {k: v for k, v in fe_info.items() if k != "skipped"}
        fig.savefig(path, dpi=130, metadata=_cli.png_metadata(meta, os.path.basename(path)))
        plt.close(fig)
        done[name] = {"status": "written", "file": os.path.basename(path),
                      "parameters": params, "fe": fe_info}
    parts = comm.gather(done, root=0)
    times = comm.gather((t_analytic, t_fe), root=0)
    if comm.rank == 0:
        index = {k: v for part in parts for k, v in part.items()}
        wall = time.perf_counter() - t_start
        with open(os.path.join(opts.out, "figures.json"), "w") as fh:
            json.dump({"command": command, "versions": _cli.versions(),
                       "ranks": comm.size, "fe_points_per_curve": opts.fe_points,
                       "fe": not opts.no_fe,
                       "seconds": {"wall": wall,
                                   "analytic_per_rank": [t[0] for t in times],
                                   "fe_per_rank": [t[1] for t in times]},
                       "figures": index}, fh, indent=2, default=str)
        for k in names:
            v = index[k]
            line = f"{k}: {v['status']}" + (f" ({v['reason']})" if "reason" in v else "")
            if isinstance(v.get("fe"), dict):
                fe_info = v["fe"]
                dev = fe_info["max_rel_deviation"]
                line += (f"; FE {fe_info['points']}/{fe_info['requested']} points, max rel. "
                         f"deviation {dev:.1e}" if dev is not None else
                         f"; FE 0/{fe_info['requested']} points")
            print(line, flush=True)
        print(f"wall time {wall:.1f} s on {comm.size} rank(s)", flush=True)
    return 0


if __name__ == "__main__":
    _cli.run(main)
