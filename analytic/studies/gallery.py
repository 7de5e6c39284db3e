"""Data of the paper's gallery figures (``workflows/figures.py``): curves and FE check points.

One function per figure (:data:`MAKERS`) returns a :class:`FigureData`: the analytic curves as
:class:`Series` (arrays plus their line style, in drawing order), the figure's parameters (for
``figures.json`` and the PNG metadata) and the FE check points (:class:`FETask`) at up to
``fe_points`` points per curve, with the exact root as reference. Pure numpy/scipy: the FE
solves of these tasks are in :mod:`forms.studies.gallery`.

Curves: half-space roots of ``s(z, q)`` (:mod:`analytic.physics.halfspace`), the large-``kH`` closed
forms (:mod:`analytic.physics.largek`), waveguide branches from the cut-offs at finite ``H``
(:mod:`analytic.numerics.branches`) with their small-``k`` slopes (:mod:`analytic.physics.smallk`),
and the
stability boundaries (:mod:`analytic.physics.phase_diagram`).
"""

from __future__ import annotations

import csv
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from analytic.numerics.branches import BranchResult, follow_branch
from analytic.params import Params
from analytic.physics import halfspace as hs
from analytic.physics import largek as lk
from analytic.physics import phase_diagram as pd
from analytic.physics.halfspace import dilatational_tracks, physical_curve
from analytic.physics.smallk import lambda_smallk

#: The gallery's figure names, in their default order.
FIGURES = ("finiteH", "comparison", "both", "phase_diagram", "modified1", "modified2",
           "stress_top", "gaps")
#: Rough cost of each figure's analytic part, for sharing the figures over ranks (measured
#: order of magnitude: the phase diagram and the finite-H continuations are the slow ones).
FIGURE_COST = {"finiteH": 6.0, "comparison": 2.0, "both": 2.0, "phase_diagram": 8.0,
               "modified1": 2.0, "modified2": 2.0, "stress_top": 3.0, "gaps": 2.0}

#: Seconds per unit of :data:`FIGURE_COST` at the default resolution (``n_q = 240``,
#: ``n_gamma = 16``), one rank, analytic part; the FE points add :data:`FE_SHARE` of it.
#: Measured on this 2-core machine (every figure, 27 units): workflows/results/figures (2
#: ranks) 50.5 s of analytic work over both ranks, 1.9 s per unit, FE points about 10 s; the
#: default on one rank at a load of 7-8 (2026-11-25): analytic 257 s, 9.5 s per unit, FE 49 s
#: (0.19 of it), 316 s in all (model 130 s); ``--only both --no-fe --n-q 20`` about 1.2 s
#: at a load of 3 (model 0.7 s).
SECONDS_PER_COST = 4.0
FE_SHARE = 0.2

Draw = tuple[tuple[int, str], ...]


@dataclass(frozen=True)
class Settings:
    """Resolution of the gallery.

    Attributes:
        n_q: Wavenumbers per curve (finite-H curves: ``max(n_q // 4, 12)``).
        n_gamma: ``Gamma`` points of the phase diagram.
        fe_points: FE check points per curve (some curves: half of it, at least 2).
    """

    n_q: int = 240
    n_gamma: int = 16
    fe_points: int = 10


def estimate_seconds(names: Sequence[str], settings: Settings, fe: bool, ranks: int) -> float:
    """Estimated seconds of the figures ``names`` on ``ranks`` (shared by :data:`FIGURE_COST`).

    Curves scale with ``n_q``, the phase diagram with ``n_gamma``; the largest figure sets a
    floor (figures are not split).
    """
    costs = [FIGURE_COST[n] * (settings.n_gamma / 16 if n == "phase_diagram" else
                               settings.n_q / 240) for n in names]
    work = max(sum(costs) / max(1, ranks), max(costs, default=0.0))
    return SECONDS_PER_COST * work * (1.0 + (FE_SHARE if fe else 0.0))


@dataclass(frozen=True)
class Series:
    """One line of a figure: ``ax.plot(x, y, fmt, color=color, lw=lw, label=label, alpha=alpha)``.

    Attributes:
        panel: Index of the axes (0-based).
        x: Abscissae.
        y: Ordinates (NaN: not drawn).
        fmt: Matplotlib format string.
        color: Colour.
        lw: Line width.
        label: Legend label (``None``: none).
        alpha: Opacity (``None``: opaque).
    """

    panel: int
    x: np.ndarray
    y: np.ndarray
    fmt: str
    color: str
    lw: float
    label: str | None = None
    alpha: float | None = None


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
    draw: Draw
    sheet: str = "physical"
    n_max: int = 0


@dataclass
class FigureData:
    """Everything a gallery figure shows, computed.

    Attributes:
        name: Figure name (one of :data:`FIGURES`).
        series: Curves, in drawing order.
        params: The figure's parameters (JSON-able; ``figures.json``, PNG metadata).
        tasks: FE check points of its curves.
        extra: Figure-specific data (phase diagram: ``rows``, ``records``, ``window``).
    """

    name: str
    series: list[Series]
    params: dict[str, Any]
    tasks: list[FETask] = field(default_factory=list)
    extra: dict[str, Any] = field(default_factory=dict)


def sample(valid: np.ndarray, n: int) -> np.ndarray:
    """Up to ``n`` indices spread evenly over the True entries of ``valid`` (ends included).

    Args:
        valid: Boolean mask.
        n: Largest number of indices.

    Returns:
        Indices into ``valid``, increasing.
    """
    idx = np.flatnonzero(valid)
    if len(idx) <= n:
        return idx
    return idx[np.unique(np.round(np.linspace(0, len(idx) - 1, n)).astype(int))]


def fe_value(lam: complex, task: FETask, quantity: str) -> float:
    """Plotted quantity of ``Lambda`` for ``task``.

    Args:
        lam: Eigenvalue ``Lambda``.
        task: The task (its ``params.H`` and ``k``).
        quantity: ``"growth"``, ``"H_growth"`` or ``"re_z"`` (:class:`FETask`).

    Returns:
        The ordinate drawn.

    Raises:
        ValueError: Unknown quantity.
    """
    if quantity == "growth":
        return lam.real
    if quantity == "H_growth":
        return task.params.H * lam.real
    if quantity == "re_z":
        return (1j * lam / task.k).real
    raise ValueError(f"unknown quantity {quantity!r}")


def read_overlay(folder: str | None, name: str) -> dict[int, dict[str, np.ndarray]]:
    """Points of ``folder/<name>.csv`` (columns ``x, y, label[, panel]``) to overlay.

    Args:
        folder: Overlay folder (``None``: no overlay).
        name: Figure name.

    Returns:
        ``{panel: {label: array of shape (2, n)}}`` (rows ``x``, ``y``); empty if there is
        no folder or no such file.
    """
    if not folder:
        return {}
    path = os.path.join(folder, f"{name}.csv")
    if not os.path.exists(path):
        return {}
    groups: dict[int, dict[str, list[tuple[float, float]]]] = {}
    with open(path) as fh:
        for row in csv.DictReader(fh):
            panel = int(row.get("panel", 0) or 0)
            groups.setdefault(panel, {}).setdefault(row.get("label", "overlay"), []).append(
                (float(row["x"]), float(row["y"])))
    return {panel: {label: np.array(pts).T for label, pts in g.items()}
            for panel, g in groups.items()}


def halfspace_tasks(figure: str, curve: str, color: str, p: Params,
                    roots: list[hs.HalfSpaceRoot], valid: np.ndarray, n: int,
                    draw: Draw = ((0, "growth"),)) -> list[FETask]:
    """PML tasks at up to ``n`` of the drawn points (``valid``) of a half-space curve.

    Args:
        figure: Figure name.
        curve: Curve label.
        color: Curve colour.
        p: Parameters.
        roots: The curve's roots, one per ``q``.
        valid: Mask of the drawn points.
        n: Largest number of tasks.
        draw: Where and what to draw (:class:`FETask`).

    Returns:
        The tasks (abscissa ``q``).
    """
    return [FETask(figure, curve, color, "pml", p, float(roots[i].q), complex(roots[i].Lambda),
                   float(roots[i].q), draw, sheet=roots[i].sheet) for i in sample(valid, n)]


def finite_h_tasks(figure: str, curve: str, color: str, p: Params, n: int, res: BranchResult,
                   panel: int, count: int) -> list[FETask]:
    """Cross-section tasks at up to ``count`` trusted points of a finite-H branch.

    Args:
        figure: Figure name.
        curve: Curve label.
        color: Curve colour.
        p: Parameters.
        n: Cut-off of the branch (highest waveguide branch the mesh must resolve).
        res: The followed branch.
        panel: Axes index; the quantity drawn is ``H Re Lambda`` against ``Hk``.
        count: Largest number of tasks.

    Returns:
        The tasks.
    """
    lam = np.asarray(res.Lambda)
    return [FETask(figure, curve, color, "cross_section", p, float(res.k[i]), complex(lam[i]),
                   float(res.k[i] * p.H), ((panel, "H_growth"),), n_max=n)
            for i in sample(np.asarray(res.ok) & np.isfinite(lam), count)]


def unstable_branch(p: Params, n: int, hk: np.ndarray) -> tuple[np.ndarray, int, BranchResult]:
    """``H Re Lambda`` on the partner of cut-off ``n`` that grows at small ``k``.

    Args:
        p: Parameters (finite ``H``).
        n: Cut-off.
        hk: Grid of ``H k``.

    Returns:
        ``(H Re Lambda`` (NaN where not followed), the partner's sign, the followed branch).
    """
    best = None
    for sign in (-1, 1):
        res = follow_branch(p, n, sign, hk / p.H)
        g = np.where(res.ok, res.Lambda.real, np.nan) * p.H
        if best is None or np.nanmax(np.r_[g[:3], -np.inf]) > np.nanmax(np.r_[best[0][:3],
                                                                              -np.inf]):
            best = (g, sign, res)
    return best


def _q_range(qs: np.ndarray) -> list:
    return [qs[0], qs[-1], len(qs)]


def comparison(s: Settings) -> FigureData:
    """Fig. comparison: ``Re lambda`` (panel 0) and ``Re z`` (panel 1) vs ``q``.

    Exact roots of ``s(z, q)`` (both ``kappa_d`` functions, physical sheet) and Eqs.
    (analytic_spectrum), (kappa_d)+(kappa_d1), for several ``gamma f``.

    Args:
        s: Resolution.

    Returns:
        The figure's data.
    """
    base = Params(f=0.3, beta=0.5, Delta=0.7)
    gfs = (0.6, 0.75, 0.84, 0.96, 1.2)
    qs = np.logspace(-2, 2, s.n_q)
    series: list[Series] = []
    tasks: list[FETask] = []
    for i, gf in enumerate(gfs):
        c = f"C{i}"
        p = base.replace(gamma=gf / base.f)
        tr = dilatational_tracks(qs, p)
        for j, b in enumerate(("unstable", "stable")):
            lab = f"gamma f = {gf:g}" if j == 0 else None
            growth = physical_curve(tr[b], lambda r: r.growth)
            series.append(Series(0, qs, growth, "-", c, 1.6, lab))
            series.append(Series(1, qs, physical_curve(tr[b], lambda r: r.z.real), "-", c, 1.6,
                                 lab))
            tasks += halfspace_tasks("comparison", f"gamma f = {gf:g} ({b})", c, p, tr[b],
                                     np.isfinite(growth), max(2, s.fe_points // 2),
                                     ((0, "growth"), (1, "re_z")))
        series.append(Series(0, qs, lk.growth_rate_dilatational_physical(qs, p), ":", c, 1.4))
        zl = np.where(lk.growth_rate_dilatational(qs, p) > 0, lk.z_linear(qs, p, "unstable"),
                      lk.z_linear(qs, p, "stable"))
        series.append(Series(1, qs, zl.real, ":", c, 1.4))
    params = {"f": base.f, "beta": base.beta, "Delta": base.Delta, "gamma_f": gfs,
              "q": _q_range(qs)}
    return FigureData("comparison", series, params, tasks)


def gaps(s: Settings) -> FigureData:
    """Appendix C (Fig. gaps): roots of ``s`` and of ``s~`` join into continuous curves.

    Args:
        s: Resolution.

    Returns:
        The figure's data: per ``kappa_d`` function its physical part, its ``s~`` part and
        the whole continued root.
    """
    p = Params(f=0.3, beta=0.5, Delta=0.7, gamma=0.96 / 0.3)
    qs = np.logspace(-2, 2, s.n_q)
    tr = dilatational_tracks(qs, p)
    series: list[Series] = []
    tasks: list[FETask] = []
    for b, c in (("unstable", "C0"), ("stable", "C1")):
        series.append(Series(0, qs, physical_curve(tr[b], lambda r: r.growth), "-", "tab:red", 2))
        series.append(Series(0, qs, physical_curve(tr[b], lambda r: r.growth, "s_tilde"), "--",
                             "tab:green", 2))
        series.append(Series(0, qs, np.array([r.growth for r in tr[b]]), "-", c, 0.6,
                             f"continued root, kappa_d function '{b}'", 0.8))
        for sheet, col in (("physical", "tab:red"), ("s_tilde", "tab:green")):
            tasks += halfspace_tasks("gaps", f"{b} ({sheet})", col, p, tr[b],
                                     np.isfinite(physical_curve(tr[b], lambda r: r.growth, sheet)),
                                     max(2, s.fe_points // 2))
    return FigureData("gaps", series, {**p.as_dict(), "q": _q_range(qs)}, tasks)


def both(s: Settings) -> FigureData:
    """Fig. both: dilatational and shear growth rates at small ``Delta``, ``gamma = 0.25``.

    Args:
        s: Resolution.

    Returns:
        The figure's data; ``params`` holds ``qc_shear``, ``delta_s`` and ``delta_m``.
    """
    f, beta, gamma = 0.3, 0.5, 0.25
    deltas = (0.0, 0.01, 0.02, 0.026, 0.035)
    qs = np.unique(np.concatenate([np.logspace(-2.5, 1, s.n_q),
                                   np.linspace(0.03, 0.08, s.n_q // 2),
                                   np.linspace(0.18, 0.32, s.n_q // 2)]))
    series: list[Series] = []
    tasks: list[FETask] = []
    for i, d in enumerate(deltas):
        p = Params(f=f, beta=beta, gamma=gamma, Delta=d)
        dil = hs.follow("dilatational", qs, p)
        she = [hs.shear_root(float(q), p) for q in qs]
        gd = np.array([r.growth if (r.physical and r.growth > 0) else np.nan for r in dil])
        gs = np.array([r.growth if (r.physical and hs.in_family(r) and r.growth > 0)
                       else np.nan for r in she])
        series.append(Series(0, qs, gd, "-", f"C{i}", 1.6, f"Delta = {d:g} dilatational"))
        series.append(Series(0, qs, gs, "--", f"C{i}", 1.6, f"Delta = {d:g} shear"))
        tasks += halfspace_tasks("both", f"Delta = {d:g} dilatational", f"C{i}", p, dil,
                                 np.isfinite(gd), s.fe_points)
        tasks += halfspace_tasks("both", f"Delta = {d:g} shear", f"C{i}", p, she,
                                 np.isfinite(gs), s.fe_points)
    params = {"f": f, "beta": beta, "gamma": gamma, "Delta": deltas, "q": _q_range(qs),
              "qc_shear": lk.qc_shear(gamma, f, beta),
              "delta_s": float(lk.delta_s(gamma * f, f, beta)), "delta_m": lk.delta_m(f, beta)}
    return FigureData("both", series, params, tasks)


def modified(s: Settings, name: str, key: str, values: tuple[float, ...]) -> FigureData:
    """Figs. modified1/2: effect of ``alpha_PC`` or ``alpha_LD`` at ``gamma = 3.2`` and 4.

    Args:
        s: Resolution.
        name: Figure name.
        key: ``"alpha_pc"`` or ``"alpha_ld"``.
        values: Its values.

    Returns:
        The figure's data: panel 0 ``gamma = 3.2``, panel 1 ``gamma = 4``; exact growth
        (thick) and Eq. kappa_d2 (thin).
    """
    qs = np.logspace(-2, 3, s.n_q)
    series: list[Series] = []
    tasks: list[FETask] = []
    for panel, gamma in enumerate((3.2, 4.0)):
        for i, v in enumerate(values):
            p = Params(f=0.3, beta=0.5, Delta=0.7, gamma=gamma, **{key: v})
            roots = hs.follow("dilatational", qs, p)
            ex = np.array([r.growth if (r.physical and r.growth > 0) else np.nan for r in roots])
            an = lk.growth_linear(qs, p)
            series.append(Series(panel, qs, ex, "-", f"C{i}", 2.2, f"{key} = {v:g} exact"))
            series.append(Series(panel, qs, np.where(an > 0, an, np.nan), "-", f"C{i}", 0.8,
                                 f"{key} = {v:g} Eq. kappa_d2"))
            tasks += halfspace_tasks(name, f"gamma = {gamma}, {key} = {v:g}", f"C{i}", p, roots,
                                     np.isfinite(ex), s.fe_points, ((panel, "growth"),))
    params = {"f": 0.3, "beta": 0.5, "Delta": 0.7, "gamma": [3.2, 4.0], key: values,
              "q": _q_range(qs)}
    return FigureData(name, series, params, tasks)


def modified1(s: Settings) -> FigureData:
    """Fig. modified1: ``alpha_PC`` (``alpha_LD = 0``); see :func:`modified`."""
    return modified(s, "modified1", "alpha_pc", (0.0, 0.5, 1.0, 2.0, 5.0))


def modified2(s: Settings) -> FigureData:
    """Fig. modified2: ``alpha_LD`` (``alpha_PC = 0``), including ``alpha_LD > f``."""
    return modified(s, "modified2", "alpha_ld", (0.0, 0.1, 0.2, 0.4))


def phase_diagram(s: Settings) -> FigureData:
    """Fig. stability_diagram (:mod:`analytic.physics.phase_diagram`; analytic spectrum, no FE).

    The paper's rows on the default window, as ``workflows/phase_diagram.py --n-gamma N``.

    Args:
        s: Resolution (``n_gamma``).

    Returns:
        The figure's data: no series; ``extra`` holds ``rows``, ``records`` (kept boundary
        records) and ``window``.
    """
    rows, window = list(pd.PAPER_ROWS), pd.Window()
    grid = pd.gamma_grid(window.gamma_min, window.gamma_max, s.n_gamma)
    records = [r for f, b, fam, g in pd.tasks(rows, grid)
               for r in pd.boundary_records(f, b, fam, g, window.delta_max)
               if "dropped" not in r]
    params = {"rows": rows, "n_gamma": s.n_gamma,
              "closed_form_vs_numerical": pd.measured_differences(records, rows)}
    return FigureData("phase_diagram", [], params,
                      extra={"rows": rows, "records": records, "window": window})


def finite_h(s: Settings) -> FigureData:
    """Fig. finiteH: ``H Re Lambda`` vs ``Hk``, velocity top.

    Panel 0: ``H = 0.5``, several ``gamma f`` (``n = 0``) and ``n`` (``gamma f = 0.9``), each
    with its small-``k`` slope (Eq. Hspectrum, black dashed, ``Hk < 0.8``); panel 1:
    ``n = 0``, ``gamma = 3``, several ``H``.

    Args:
        s: Resolution.

    Returns:
        The figure's data; ``params["signs"]`` holds the partner chosen per ``gamma f``.
    """
    hk = np.linspace(0.02, 3.0, max(s.n_q // 4, 12))
    small = hk < 0.8
    base = Params(f=0.3, beta=0.5, Delta=0.7, H=0.5)
    series: list[Series] = []
    tasks: list[FETask] = []
    gfs = (0.3, 0.6, 0.9, 1.2)
    # (colour, style, parameters, cut-off n, label, key of the chosen partner's sign)
    cases = [(f"C{i}", "-", base.replace(gamma=gf / base.f), 0, f"gamma f = {gf:g}", f"gf={gf}")
             for i, gf in enumerate(gfs)]
    cases += [("C2", ls, base.replace(gamma=0.9 / base.f), n, "gamma f = 0.9", None)
              for n, ls in ((1, "--"), (2, ":"))]
    signs = {}
    for c, ls, p, n, lab, key in cases:
        g, sign, res = unstable_branch(p, n, hk)
        if key is not None:
            signs[key] = sign
        series.append(Series(0, hk, g, ls, c, 1.6, f"{lab}, n = {n}"))
        tasks += finite_h_tasks("finiteH", f"{lab}, n = {n}", c, p, n, res, 0, s.fe_points)
        series.append(Series(0, hk[small], p.H * lambda_smallk(hk[small] / p.H, n, sign,
                                                               p).real, "--", "k", 0.8))
    hs_ = (0.5, 1.0, 2.0, 5.0, 10.0)
    for i, h in enumerate(hs_):
        p = base.replace(H=h, gamma=3.0)
        g, _, res = unstable_branch(p, 0, hk)
        series.append(Series(1, hk, g, "-", f"C{i}", 1.6, f"H = {h:g}"))
        tasks += finite_h_tasks("finiteH", f"H = {h:g}, n = 0", f"C{i}", p, 0, res, 1,
                                s.fe_points)
    params = {**base.as_dict(), "gamma_f": gfs, "n": [0, 1, 2], "H_right": hs_,
              "gamma_right": 3.0, "Hk": [hk[0], hk[-1], len(hk)], "signs": signs}
    return FigureData("finiteH", series, params, tasks)


def stress_top(s: Settings) -> FigureData:
    """Appendix B figure: velocity vs stress top, ``gamma f = 0.9``, ``n = 0``, ``H = 0.5``.

    Args:
        s: Resolution.

    Returns:
        The figure's data; ``params["cases"]`` holds the parameters of each top condition.
    """
    hk = np.linspace(0.02, 2.0, max(s.n_q // 4, 12))
    series: list[Series] = []
    tasks: list[FETask] = []
    cases = {}
    for bc, c in (("velocity", "tab:red"), ("stress", "tab:green")):
        p = Params(f=0.3, beta=0.5, Delta=0.7, H=0.5, gamma=3.0, bc=bc)
        g, sign, res = unstable_branch(p, 0, hk)
        series.append(Series(0, hk, g, "-", c, 1.8,
                             f"{bc} controlled top (branch 0{'+-'[sign < 0]})"))
        tasks += finite_h_tasks("stress_top", f"{bc} top", c, p, 0, res, 0, s.fe_points)
        cases[bc] = p.as_dict()
    return FigureData("stress_top", series, {"cases": cases, "Hk": [hk[0], hk[-1], len(hk)]},
                      tasks)


#: Data function of each figure.
MAKERS: dict[str, Callable[[Settings], FigureData]] = {
    "finiteH": finite_h, "comparison": comparison, "both": both,
    "phase_diagram": phase_diagram, "modified1": modified1, "modified2": modified2,
    "stress_top": stress_top, "gaps": gaps,
}
