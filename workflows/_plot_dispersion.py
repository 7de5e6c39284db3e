"""The certified sweep's picture (sweep_k.py): every eigenvalue in the region against k."""

from __future__ import annotations

import time
from collections.abc import Sequence

import _cli
import numpy as np

from analytic.numerics.spectrum import Region
from analytic.params import Params
from forms.solvers.certified import (
    KResult,
)


def preload() -> float:
    """Import matplotlib (Agg) now; returns the seconds it took (about 0.5 s here).

    The sweep's rank 0 calls it before the exact families and the ``k`` values (the last rank
    plans the families meanwhile, ``forms.studies.sweep.family_plan``; the ranks take their
    ``k`` whenever free, ``_cli.EndClaims``), so the picture's import is not part of the serial
    tail everyone waits on. (Before session 27 rank 0 called it after
    its own share, while the others finished theirs; with the ranks finishing together that
    overlap was gone.)
    """
    t0 = time.perf_counter()
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot  # noqa: F401

    return time.perf_counter() - t0


def plot_dispersion(path: str, params: Params, region: Region, results: list[KResult],
                    fams: list, most: dict | None, parameters: dict,
                    colour_by: str | None = None, title: str | None = None,
                    marks: Sequence[tuple[float, complex, str]] = (),
                    box_edges: Sequence[tuple[float, float]] = ()) -> None:
    """dispersion.png: growth rate and frequency against k; exact lines, FE points, envelope.

    ``colour_by``: a column of the rows (``harmonic`` for the 2D strip) whose values colour the
    ``ok`` points, one legend entry each (no exact-line legend then); ``title`` replaces the
    region's title. ``marks``: ``(k, Lambda, label)`` drawn as diamonds, one legend entry per
    label (the strip: each harmonic's fastest mode by the 1D model); ``box_edges``: ``(k,
    |Im| bound)`` of a box drawn as dashes on the frequency panel.
    """
    preload()  # matplotlib with Agg (already imported when the sweep preloaded it)
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(10, 8), sharex=True)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    kmin, kmax = results[0].k, results[-1].k
    w0, w1 = region.im_max(params, 0.0), region.im_max(params, 1.0)  # |Im| bound: linear in k
    by_colour: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {}
    for f in fams:  # exact continuation paths, inside the region only
        kp, lp = np.asarray(f.k_path, dtype=float), np.asarray(f.Lambda_path, dtype=complex)
        if kp.size == 0:
            continue
        inside = ((region.re_min <= lp.real) & (lp.real <= region.re_max)
                  & (np.abs(lp.imag) <= w0 + (w1 - w0) * kp) & (kmin <= kp) & (kp <= kmax))
        c = colors[f.n % len(colors)] if f.n >= 0 else "0.55"
        by_colour.setdefault(c, []).append((kp, np.where(inside, lp, complex(np.nan, np.nan))))
    # one line per colour, its families apart by a NaN (session 35: a line per family, 450 on
    # the stress top's checked sweep, made the picture's lines most of its time)
    for c, paths in by_colour.items():
        kp = np.concatenate([np.append(x, np.nan) for x, _ in paths])
        lp = np.concatenate([np.append(z, complex(np.nan, np.nan)) for _, z in paths])
        ax1.plot(kp, lp.real, "-", color=c, lw=0.9, alpha=0.8, zorder=1)
        ax2.plot(kp, lp.imag, "-", color=c, lw=0.9, alpha=0.8, zorder=1)
    ok = [(r["k"], r["re_lambda"], r["im_lambda"]) for res in results for r in res.rows
          if r["status"] == "ok" and colour_by is None]
    groups = sorted({r[colour_by] for res in results for r in res.rows
                     if colour_by is not None and r["status"] == "ok"})
    for i, g in enumerate(groups):  # coloured ok points, one legend entry per value
        a = np.array([(r["k"], r["re_lambda"], r["im_lambda"]) for res in results
                      for r in res.rows if r["status"] == "ok" and r[colour_by] == g])
        style = {"marker": "o", "ms": 3.6, "mfc": "none", "mew": 0.9, "ls": "none",
                 "color": colors[i % len(colors)], "zorder": 3}
        ax1.plot(a[:, 0], a[:, 1], label=f"FE, ok, {colour_by} {g:g}", **style)
        ax2.plot(a[:, 0], a[:, 2], **style)
    bad = [(r["k"], r["re_lambda"], r["im_lambda"]) for res in results for r in res.rows
           if r["status"] != "ok"]
    # hollow markers above the lines: both stay visible on dense grids
    for pts, style in ((ok, {"marker": "o", "ms": 3.2, "mfc": "none", "mew": 0.6, "color": "k",
                             "label": "FE, ok"}),
                       (bad, {"marker": "x", "ms": 6, "color": "crimson",
                              "label": "FE, flagged"})):
        if pts:
            a = np.array(pts)
            ax1.plot(a[:, 0], a[:, 1], ls="none", zorder=3, **style)
            ax2.plot(a[:, 0], a[:, 2], ls="none", zorder=3, **{**style, "label": None})
    env = [(res.k, max(r["re_lambda"] for r in res.rows)) for res in results if res.rows]
    if env:
        e = np.array(env)
        ax1.plot(e[:, 0], e[:, 1], "-", color="k", lw=2.2, alpha=0.45, zorder=2,
                 label="envelope max Re Lambda(k)")
    if most is not None:
        ax1.plot([most["k"]], [most["re_lambda"]], "*", ms=17, color="gold", mec="k", zorder=4,
                 label=f"most unstable: {most['branch']}, k = {most['k']:.4g},\n"
                 f"Lambda = {most['re_lambda']:.6g} {most['im_lambda']:+.6g}i")
        ax2.plot([most["k"]], [most["im_lambda"]], "*", ms=17, color="gold", mec="k", zorder=4)
    for i, label in enumerate(dict.fromkeys(m[2] for m in marks)):
        a = np.array([(k, z.real, z.imag) for k, z, lab in marks if lab == label])
        style = {"marker": "D", "ms": 7, "mfc": "none", "mew": 1.3, "ls": "none", "zorder": 4,
                 "color": colors[(i + 4) % len(colors)]}
        ax1.plot(a[:, 0], a[:, 1], label=label, **style)
        ax2.plot(a[:, 0], a[:, 2], **style)
    if len(box_edges):
        e = np.array(box_edges, dtype=float)
        for sign, label in ((1.0, "box |Im| bound"), (-1.0, None)):
            ax2.plot(e[:, 0], sign * e[:, 1], "--", marker="_", ms=14, color="0.35", lw=0.9,
                     zorder=2, label=label)
        ax2.legend(fontsize=7.5, loc="upper left", bbox_to_anchor=(1.01, 1.0),
                   borderaxespad=0.0)
    if colour_by is None and fams:  # the exact lines' legend, where there are exact lines
        ax1.plot([], [], "-", color=colors[0], lw=0.9,
                 label="exact, waveguide n+/n- (colour: n)")
        ax1.plot([], [], "-", color="0.55", lw=0.9, label="exact, other families (s, r)")
    ax1.axhline(0.0, color="k", lw=0.6)
    ax1.set_ylim(region.re_min, None)
    ax1.set_ylabel("growth rate Re Λ")  # no mathtext: its parser took 0.15 s
    ax2.set_ylabel("frequency Im Λ")
    ax2.set_xlabel("k")
    ax1.legend(fontsize=7.5, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    p = params
    title = title or (f"every eigenvalue in R: Re >= {region.re_min:g}, |Im| <= c_max k c_d "
             f"+ {region.omega_0(p):.3g}\nf={p.f:g}, gamma={p.gamma:g}, beta={p.beta:g}, "
             f"Delta={p.Delta:g}, H={p.H:g}, bc={p.bc}")
    if p.generalized:
        title += f", alpha_pc={p.alpha_pc:g}, alpha_ld={p.alpha_ld:g}"
    ax1.set_title(title, fontsize=9)
    # fixed margins, the legend in the right 27 %: tight_layout measured every text twice and
    # took 42 % of the picture's time (1.11 of 2.64 s in a profile of the default velocity
    # sweep's picture, session 17)
    fig.subplots_adjust(left=0.08, right=0.72, bottom=0.07, top=0.92, hspace=0.06)
    _cli.save_figure(fig, path, dpi=130,
                     metadata=_cli.png_metadata(parameters, "certified dispersion"))
    plt.close(fig)
