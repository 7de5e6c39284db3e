"""Plots shared by the scenes (a helper module of ``workflows/``, not a scene).

- :func:`draw_phase_diagram` / :func:`plot_phase_diagram`: Fig. stability_diagram
  (``phase_diagram.py``, and the gallery ``figures.py``);
- :func:`plot_interface`: stresses and slip along the interface (``mode_shape.py``,
  ``finite_block.py``);
- :func:`save_png`: a figure as PNG with :func:`_cli.png_metadata` (command, parameters).

matplotlib is imported inside the functions (only the ranks that draw load it). No pyvista
here: a scene that renders with it imports it before dolfinx itself (see ``mode_shape.py``).
"""

from __future__ import annotations

import math
import os

import _cli
import numpy as np

from analytic.physics import largek as lk
from analytic.physics.phase_diagram import FAMILIES, Window

#: Colour of each root family in the phase diagram.
COLORS = {"dilatational": "tab:blue", "shear": "tab:red", "quasistatic": "tab:green"}


def save_png(fig, path: str, parameters: dict) -> None:  # noqa: ANN001
    """Save a matplotlib figure as PNG with :func:`_cli.png_metadata` (command, parameters).

    Args:
        fig: The figure.
        path: PNG file.
        parameters: Run parameters for the ``Comment`` chunk.
    """
    _cli.save_figure(fig, path, dpi=130,
                     metadata=_cli.png_metadata(parameters, os.path.basename(path)))


def plot_phase_diagram(rows: list[tuple[float, float]], records: list[dict], window: Window,
                       path: str, parameters: dict) -> None:
    """Draw (:func:`draw_phase_diagram`) and save the phase diagram with its metadata.

    Args:
        rows: ``(f, beta)`` rows.
        records: Kept boundary records.
        window: Axes extent.
        path: PNG file.
        parameters: Run parameters for the PNG metadata.
    """
    import matplotlib.pyplot as plt

    fig = draw_phase_diagram(rows, records, window)
    save_png(fig, path, parameters)
    plt.close(fig)


def draw_phase_diagram(rows: list[tuple[float, float]], records: list[dict],
                       window: Window):  # noqa: ANN201
    """The phase diagram: two columns (linear, log axes) per ``(f, beta)`` row, as in the paper.

    Args:
        rows: ``(f, beta)`` rows.
        records: Kept boundary records (:func:`analytic.physics.phase_diagram.sort_records`); the
            numerical ones are drawn as markers over the closed-form lines.
        window: Axes extent (:class:`analytic.physics.phase_diagram.Window`).

    Returns:
        The matplotlib figure (the caller saves and closes it).
    """
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(rows), 2, figsize=(12, 4.6 * len(rows)), squeeze=False)
    for irow, (f, beta) in enumerate(rows):
        g_fine = np.logspace(math.log10(window.gamma_min), math.log10(window.gamma_max), 800)
        g_fine = np.unique(np.concatenate([g_fine, np.linspace(0, window.gamma_max, 800)[1:]]))
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
                ax.fill_between(g_fine, 0 if not logax else window.delta_min, y,
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
            if g_all < window.gamma_max:
                ax.axvline(g_all, color="k", ls=":", lw=1.0, label="all dilatational q unstable")
            if logax:
                ax.set_xscale("log")
                ax.set_yscale("log")
                ax.set_xlim(window.gamma_min, window.gamma_max)
                ax.set_ylim(window.delta_min, window.delta_max)
            else:
                ax.set_xlim(0, window.gamma_max)
                ax.set_ylim(0, window.delta_max)
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



def plot_interface(data: dict[str, np.ndarray], out_png: str, title: str, meta: dict) -> None:
    """Shear/normal stress perturbation and slip along the interface at phase 0 (rank 0).

    The legends stand right of the axes, so they never hide a peak.

    Args:
        data: ``x, sxy, syy`` (stresses at the interface points) and ``x_slip, ux`` (slip),
            complex arrays (:func:`forms.mode_postprocessing.interface_stresses`).
        out_png: PNG file.
        title: Figure title (also the PNG ``Title``).
        meta: Run parameters for the PNG metadata.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x = data["x"]
    fig, axes = plt.subplots(2, 1, figsize=(11.5, 6), sharex=True)
    ax = axes[0]
    for key, label, col in (("sxy", r"shear $\delta\sigma_{xy}$", "tab:blue"),
                            ("syy", r"normal $\delta\sigma_{yy}$", "tab:red")):
        ax.plot(x, data[key].real, color=col, label=label + " (Re, phase 0)")
        ax.plot(x, np.abs(data[key]), color=col, ls=":", lw=1, label=label + " envelope")
    ax.axhline(0, color="k", lw=0.5)
    ax.set_ylabel(r"stress / $\max|u|$ ($\mu = 1$)")
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    ax.set_title(title, fontsize=10)
    ax = axes[1]
    ax.plot(data["x_slip"], data["ux"].real, color="k", label=r"slip $\delta u_x$ (Re)")
    ax.plot(data["x_slip"], np.abs(data["ux"]), color="k", ls=":", lw=1, label="envelope")
    ax.axhline(0, color="k", lw=0.5)
    ax.set_xlabel(r"$x$ (units $c_s t_0$)")
    ax.set_ylabel(r"$\delta u_x(y=0)$")
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    fig.tight_layout()
    _cli.save_figure(fig, out_png, dpi=130, metadata=_cli.png_metadata(meta, title))
    plt.close(fig)

