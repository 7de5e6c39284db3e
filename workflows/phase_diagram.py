"""Stability phase diagram in the Delta-Gamma plane, kH -> infinity (Fig. stability_diagram).

For each ``(f, beta)`` row (default: the paper's two rows, ``(0.3, 0.45)`` and ``(0.3, 0.6)``):

- the three boundaries of Eq. (stability_boundaries) from the closed forms
  (:mod:`analytic.largek`), and
- the same three boundaries located numerically from the spectrum ``s(z, q)``
  (:func:`analytic.halfspace.threshold_delta`: Brent bisection in ``Delta`` on the sign of the
  largest growth rate over ``q`` of each root family; the bracket is found by doubling, not
  from the closed form),

the regions where each instability exists, the upper stability boundary and the
all-dilatational-modes-unstable line (Eq. all_modes), on linear and logarithmic axes.
Parallel over the (row, family, Gamma) tasks with MPI; rank 0 writes
``DIR/boundaries.csv`` (columns ``boundary, source, f, beta, Gamma, Delta``),
``DIR/phase_diagram.json`` (parameters, versions, measured closed-form vs numerical
differences) and ``DIR/phase_diagram.png``.

    python workflows/phase_diagram.py --out out/phase_diagram
    mpirun -n 2 python workflows/phase_diagram.py --f 0.3 --beta 0.5 --n-gamma 12 --out DIR
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import sys
import time

import _cli
import numpy as np

from mpi4py import MPI

from analytic import halfspace as hs
from analytic import largek as lk
from analytic.params import ParameterError, Params

PAPER_ROWS = ((0.3, 0.45), (0.3, 0.6))
FAMILIES = ("dilatational", "shear", "quasistatic")
COLORS = {"dilatational": "tab:blue", "shear": "tab:red", "quasistatic": "tab:green"}


# ----------------------------------------------------------------------------- run metadata
def save_png(fig, path: str, parameters: dict) -> None:  # noqa: ANN001
    """Save a matplotlib figure as PNG with :func:`_cli.png_metadata` (command, parameters)."""
    fig.savefig(path, dpi=130, metadata=_cli.png_metadata(parameters, os.path.basename(path)))


# ------------------------------------------------------------------------------- the physics
def bracket_and_threshold(family: str, gamma_f: float, f: float, beta: float,
                          delta_cap: float) -> float:
    """Numerical boundary ``Delta(Gamma)`` of one family, NaN if none in ``(0, delta_cap]``.

    The bracket is found from the spectrum alone: ``Delta = 1e-12`` must be unstable, then the
    upper end is doubled from ``1e-4`` until the family is stable (at most up to
    ``delta_cap``).
    """
    gamma = gamma_f / f

    def unstable(delta: float) -> bool:
        p = Params(f=f, gamma=gamma, beta=beta, Delta=delta, H=math.inf)
        return hs.max_growth(family, p).unstable

    lo = 1e-12
    if not unstable(lo):
        return math.nan
    hi = 1e-4
    while unstable(hi):
        lo = hi
        hi *= 2.0
        if hi > delta_cap:
            return math.nan
    return hs.threshold_delta(family, gamma_f, f, beta, (lo, hi), xtol=1e-13)


def closed_form(family: str, gamma_f: float, f: float, beta: float) -> float:
    """Eq. (stability_boundaries) for one family (NaN where ``Delta_s <= 0`` or ``Gamma >= 1``)."""
    if family == "dilatational":
        return float(lk.delta_d(gamma_f, beta))
    if family == "shear":
        if gamma_f >= 1.0:
            return math.nan
        v = float(lk.delta_s(gamma_f, f, beta))
        return v if v > 0 else math.nan
    return lk.delta_qs(f, beta)


def boundary_records(f: float, beta: float, family: str, gamma_f: float,
                     delta_cap: float) -> list[dict]:
    """CSV rows (closed form and numerical, where they exist) for one task.

    A numerical threshold at which the most unstable root sits on the edge of its family's
    region (``not MaxGrowth.interior`` just below the threshold) marks where the root leaves
    the region, not a change of stability: it is returned with a ``"dropped"`` reason
    instead (kept out of the CSV, listed in the JSON).
    """
    out = []
    closed = closed_form(family, gamma_f, f, beta)
    if math.isfinite(closed):
        out.append({"boundary": family, "source": "closed_form", "f": f, "beta": beta,
                    "Gamma": gamma_f, "Delta": closed})
    num = bracket_and_threshold(family, gamma_f, f, beta, delta_cap)
    if math.isfinite(num):
        rec = {"boundary": family, "source": "numerical", "f": f, "beta": beta,
               "Gamma": gamma_f, "Delta": num}
        below = hs.max_growth(family, Params(f=f, gamma=gamma_f / f, beta=beta,
                                             Delta=num * (1 - 1e-6), H=math.inf))
        if not below.interior:
            z = below.root_margin.z if below.root_margin is not None else math.nan
            rec["dropped"] = (f"most unstable root at the edge of the {family} region "
                              f"(z = {complex(z):.4g}): not a stability change")
        out.append(rec)
    return out


def gamma_grid(gmin: float, gmax: float, n: int) -> np.ndarray:
    """Log-spaced points for the log panels plus linear ones for the linear panels."""
    g = np.concatenate([np.logspace(math.log10(gmin), math.log10(gmax), n),
                        np.linspace(gmax / n, gmax, max(n // 2, 2))])
    return np.unique(np.round(g, 14))


# ------------------------------------------------------------------------------------ output
def plot(rows: list[tuple[float, float]], records: list[dict], opts: argparse.Namespace,
         path: str, parameters: dict) -> None:
    """Draw (:func:`draw`) and save the phase diagram with its metadata."""
    import matplotlib.pyplot as plt

    fig = draw(rows, records, opts)
    save_png(fig, path, parameters)
    plt.close(fig)


def draw(rows: list[tuple[float, float]], records: list[dict], opts: argparse.Namespace):  # noqa: ANN201
    """Two columns (linear, log) per ``(f, beta)`` row, as in the paper; returns the figure."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(rows), 2, figsize=(12, 4.6 * len(rows)), squeeze=False)
    for irow, (f, beta) in enumerate(rows):
        g_fine = np.logspace(math.log10(opts.gamma_min), math.log10(opts.gamma_max), 800)
        g_fine = np.unique(np.concatenate([g_fine, np.linspace(0, opts.gamma_max, 800)[1:]]))
        bnd = lk.stability_boundaries(g_fine, f, beta)
        g_x = lk.qs_truncation_gamma(f, beta)
        num = {fam: sorted((r["Gamma"], r["Delta"]) for r in records
                           if r["f"] == f and r["beta"] == beta and r["boundary"] == fam
                           and r["source"] == "numerical") for fam in FAMILIES}
        for icol, ax in enumerate(axes[irow]):
            logax = icol == 1
            for fam in FAMILIES:
                y = bnd[fam].copy()
                if fam == "quasistatic":
                    y = np.where(g_fine <= g_x, y, np.nan)
                y = np.where(y > 0, y, np.nan)
                ax.fill_between(g_fine, 0 if not logax else opts.delta_min, y,
                                where=np.isfinite(y), color=COLORS[fam], alpha=0.22, lw=0)
                ax.plot(g_fine, y, color=COLORS[fam], lw=1.2,
                        label=f"{fam} (closed form)")
                if num[fam]:
                    gx, dy = np.array(num[fam]).T
                    ax.plot(gx, dy, "o", ms=3.5, mfc="none", color=COLORS[fam],
                            label=f"{fam} (numerical, s(z,q))")
            ax.plot(g_fine, lk.upper_boundary(g_fine, f, beta), "k--", lw=1.0,
                    label="upper stability boundary")
            g_all = lk.all_modes_gamma(beta)
            if g_all < opts.gamma_max:
                ax.axvline(g_all, color="k", ls=":", lw=1.0, label="all dilatational q unstable")
            if logax:
                ax.set_xscale("log")
                ax.set_yscale("log")
                ax.set_xlim(opts.gamma_min, opts.gamma_max)
                ax.set_ylim(opts.delta_min, opts.delta_max)
            else:
                ax.set_xlim(0, opts.gamma_max)
                ax.set_ylim(0, opts.delta_max)
            ax.set_xlabel(r"$\Gamma = \gamma f$")
            ax.set_ylabel(r"$\Delta$")
            ax.set_title(f"f = {f:g}, beta = {beta:g} ({'log' if logax else 'linear'} axes)")
            ax.grid(alpha=0.3, which="both" if logax else "major")
            if irow == 0 and icol == 1:
                ax.legend(fontsize=7, loc="upper left")
    fig.suptitle("Stability phase diagram, kH -> infinity: unstable below each line "
                 "(shaded: where each instability exists)")
    fig.tight_layout()
    return fig


def measured_differences(records: list[dict], rows: list[tuple[float, float]]) -> dict:
    """Largest |numerical / closed form - 1| per row and boundary (the README quotes these)."""
    out = {}
    for f, beta in rows:
        key = f"f={f:g},beta={beta:g}"
        out[key] = {}
        for fam in FAMILIES:
            pairs = {}
            for r in records:
                if r["f"] == f and r["beta"] == beta and r["boundary"] == fam:
                    pairs.setdefault(r["Gamma"], {})[r["source"]] = r["Delta"]
            rel = [abs(v["numerical"] / v["closed_form"] - 1) for v in pairs.values()
                   if "numerical" in v and "closed_form" in v and v["closed_form"] > 0]
            entry = {"n_numerical": sum("numerical" in v for v in pairs.values()),
                     "max_rel_diff": max(rel) if rel else None}
            if fam == "quasistatic":
                lim = lk.delta_qs_limit(f, beta)
                num = sorted((g, v["numerical"]) for g, v in pairs.items() if "numerical" in v)
                entry["delta_qs_leading"] = lk.delta_qs(f, beta)
                entry["delta_qs_limit"] = lim
                entry["numerical_at_smallest_gamma"] = num[0] if num else None
                entry["numerical_gamma_range"] = [num[0][0], num[-1][0]] if num else None
            out[key][fam] = entry
    return out


# -------------------------------------------------------------------------------------- main
def build_parser() -> argparse.ArgumentParser:
    """Command-line options (no PETSc/SLEPc object here: single-dash options are errors)."""
    ap = _cli.make_parser(__doc__, petsc=False)
    ap.add_argument("--f", type=str, default=None,
                    help="friction coefficient(s) f > 0, comma list (default: paper rows)")
    ap.add_argument("--beta", type=str, default=None,
                    help="beta = c_s/c_d in (0, 1/sqrt 2), comma list matching --f")
    ap.add_argument("--gamma-min", type=float, default=1e-5, help="smallest Gamma (log axes)")
    ap.add_argument("--gamma-max", type=float, default=1.0, help="largest Gamma")
    ap.add_argument("--delta-min", type=float, default=1e-5, help="smallest Delta (log axes)")
    ap.add_argument("--delta-max", type=float, default=1.0, help="largest Delta shown")
    ap.add_argument("--n-gamma", type=int, default=24,
                    help="log-spaced Gamma points per boundary (plus n/2 linear ones)")
    ap.add_argument("--out", default="out/phase_diagram", help="output folder")
    return ap


def parse(argv: list[str] | None = None) -> argparse.Namespace:
    """Command line (usage errors raise :class:`ParameterError`)."""
    return build_parser().parse_args(argv)


def rows_from(opts: argparse.Namespace) -> list[tuple[float, float]]:
    """Validate and return the ``(f, beta)`` rows (raises ParameterError)."""
    if opts.f is None and opts.beta is None:
        return list(PAPER_ROWS)
    fs = [0.3] if opts.f is None else [_num("f", v) for v in opts.f.split(",")]
    bs = [0.5] if opts.beta is None else [_num("beta", v) for v in opts.beta.split(",")]
    if len(fs) == 1 and len(bs) > 1:
        fs = fs * len(bs)
    if len(bs) == 1 and len(fs) > 1:
        bs = bs * len(fs)
    if len(fs) != len(bs):
        raise ParameterError(f"--f has {len(fs)} values but --beta has {len(bs)}")
    for f, b in zip(fs, bs, strict=True):
        Params(f=f, beta=b)  # range checks with the shared messages
        if f <= 0:
            raise ParameterError(f"f = {f!r} is outside its allowed range f > 0 "
                                 "(Gamma = gamma f needs f > 0)")
    return list(zip(fs, bs, strict=True))


def _num(name: str, text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise ParameterError(f"{name} = {text!r} is not a number") from None


def check(opts: argparse.Namespace) -> list[tuple[float, float]]:
    """All input checks, before any collective call or output."""
    rows = rows_from(opts)
    for name in ("gamma_min", "gamma_max", "delta_min", "delta_max"):
        v = getattr(opts, name)
        if not (math.isfinite(v) and v > 0):
            raise ParameterError(f"--{name.replace('_', '-')} = {v!r} is outside its allowed "
                                 "range > 0 (finite)")
    if opts.gamma_min >= opts.gamma_max:
        raise ParameterError(f"--gamma-min = {opts.gamma_min} must be < --gamma-max = "
                             f"{opts.gamma_max}")
    if opts.delta_min >= opts.delta_max:
        raise ParameterError(f"--delta-min = {opts.delta_min} must be < --delta-max = "
                             f"{opts.delta_max}")
    _cli.positive_int("--n-gamma", opts.n_gamma, minimum=2, maximum=2000)
    return rows


def main(comm: MPI.Comm | None = None, argv: list[str] | None = None) -> int:
    """Compute and (rank 0) write the phase diagram; returns 0."""
    opts, comm = _cli.start(build_parser(), argv, comm)
    rows = check(opts)  # every rank validates the same input: all raise or none
    parameters = {"rows": [[f, b] for f, b in rows], "gamma_min": opts.gamma_min,
                  "gamma_max": opts.gamma_max, "delta_min": opts.delta_min,
                  "delta_max": opts.delta_max, "n_gamma": opts.n_gamma}
    with _cli.RunFolder(comm, opts.out, "phase_diagram", parameters,
                        outputs=("boundaries.csv", "phase_diagram.json", "phase_diagram.png")):
        return _run(comm, opts, rows)


def _run(comm: MPI.Comm, opts: argparse.Namespace, rows: list[tuple[float, float]]) -> int:
    grid = gamma_grid(opts.gamma_min, opts.gamma_max, opts.n_gamma)
    tasks = [(f, b, fam, float(g)) for f, b in rows for fam in FAMILIES for g in grid]
    mine = [tasks[i] for i in _cli.my_share(comm, [1.0] * len(tasks))]
    t0 = time.perf_counter()
    cap = opts.delta_max
    iterator = mine
    if comm.rank == 0:
        try:
            from tqdm import tqdm

            iterator = tqdm(mine, desc="phase diagram (rank 0 share)", file=sys.stderr)
        except ImportError:
            pass
    local = [r for f, b, fam, g in iterator for r in boundary_records(f, b, fam, g, cap)]
    gathered = comm.gather(local, root=0)
    elapsed = comm.reduce(time.perf_counter() - t0, op=MPI.MAX, root=0)
    if comm.rank != 0:
        return 0
    everything = [r for part in gathered for r in part]
    dropped = [r for r in everything if "dropped" in r]
    records = sorted((r for r in everything if "dropped" not in r),
                     key=lambda r: (r["f"], r["beta"], FAMILIES.index(r["boundary"]),
                                    r["source"], r["Gamma"]))
    with open(os.path.join(opts.out, "boundaries.csv"), "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=["boundary", "source", "f", "beta", "Gamma", "Delta"])
        w.writeheader()
        for r in records:
            w.writerow({k: (f"{v:.15g}" if isinstance(v, float) else v) for k, v in r.items()})
    parameters = {"rows": [{"f": f, "beta": b} for f, b in rows],
                  "gamma_min": opts.gamma_min, "gamma_max": opts.gamma_max,
                  "delta_min": opts.delta_min, "delta_max": opts.delta_max,
                  "n_gamma": opts.n_gamma, "ranks": comm.size,
                  "method": "Brent bisection in Delta on the sign of max_q of the unstable margin"
                            " (analytic.halfspace.max_growth, q grids of"
                            " analytic.halfspace.default_qgrid)"}
    summary = {"parameters": parameters, "versions": _cli.versions(),
               "command": _cli.command(),
               "wall_time_s": elapsed,
               "closed_form_vs_numerical": measured_differences(records, rows),
               "dropped_numerical_points": dropped,
               "closed_form_points": {
                   f"f={f:g},beta={b:g}": {
                       "all_modes_gamma": lk.all_modes_gamma(b),
                       "delta_m": lk.delta_m(f, b), "delta_m_gamma": lk.delta_m_gamma(f, b),
                       "shear_zero_gamma": lk.delta_s_zero_gamma(f, b),
                       "qs_truncation_gamma": lk.qs_truncation_gamma(f, b)}
                   for f, b in rows}}
    with open(os.path.join(opts.out, "phase_diagram.json"), "w") as fh:
        json.dump(summary, fh, indent=2)
    plot(rows, records, opts, os.path.join(opts.out, "phase_diagram.png"), parameters)
    print(f"phase diagram: {len(records)} boundary points, {elapsed:.1f} s on {comm.size} "
          f"rank(s) -> {opts.out}", flush=True)
    return 0


if __name__ == "__main__":
    _cli.run(main)
