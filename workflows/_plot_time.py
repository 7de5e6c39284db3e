"""Pictures of a time-domain run (``time_domain.py``).

Growth and frequency against the prediction, space-time maps.
"""

from __future__ import annotations

import os

import _cli
import numpy as np


def _plot_save(fig, path: str, summary: dict) -> None:  # noqa: ANN001
    """Save ``fig`` with the run's command and parameters as PNG metadata."""
    meta = _cli.png_metadata(summary["parameters"], os.path.basename(path))
    _cli.save_figure(fig, path, dpi=120, metadata=meta)


def plot_all(out: str, fig_data: dict, frames: dict, summary: dict, exact: complex,
             title: str) -> None:
    """growth.png, energy.png, spacetime_linear.png, spacetime.png, spacetime_nonlinear.png.

    Args:
        out: Output folder.
        fig_data: :func:`analytic.studies.growth_fit.figure_data` of the run.
        frames: Interface frames (``t``, ``x``, ``v``, ``tau``, ``sigma``).
        summary: The run's summary record.
        exact: The predicted eigenvalue.
        title: Figure title (the run's parameters).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t, c, w = fig_data["t"], fig_data["abs_c"], summary["window"]
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.semilogy(t, c, label="|c_k(t)| (simulation)")
    if fig_data["growth"] is not None:
        m, g = summary["measured"], fig_data["growth"]
        ax.semilogy(g["t"], g["fit"], "k--",
                    label=f"fit Re Lambda = {m['re_lambda']:.5f} +- {m['re_uncertainty']:.1e}")
        ax.semilogy(g["t"], g["exact"], "r:", label=f"exact Re Lambda = {exact.real:.5f}")
        ax.axvspan(w["t_start"], w["t_end"], color="0.9")
    ax.set_xlabel("t (units D/v0)")
    ax.set_ylabel("|Fourier component of v/v0 at k|")
    ax.set_title(title, fontsize=8)
    ax.legend(fontsize=8)
    fig.tight_layout()
    _plot_save(fig, os.path.join(out, "growth.png"), summary)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(7, 4))
    ax.plot(t, fig_data["energy"], label="kinetic + strain (perturbation)")
    ax.plot(t, fig_data["work_friction"], label="work of friction on the body")
    ax.plot(t, fig_data["balance"], label="balance residual")
    ax.set_xlabel("t")
    ax.set_ylabel("energy (units mu (c_s t0)^2 per unit depth)")
    ax.set_yscale("symlog", linthresh=fig_data["linthresh"])
    ax.set_title(title, fontsize=8)
    ax.legend(fontsize=8)
    fig.tight_layout()
    _plot_save(fig, os.path.join(out, "energy.png"), summary)
    plt.close(fig)

    if fig_data["linear"] is not None:
        lin = fig_data["linear"]
        fig, ax = plt.subplots(figsize=(6, 5))
        im = ax.pcolormesh(lin["x"], lin["t"], lin["scaled"], cmap="RdBu_r", shading="nearest",
                           vmin=-1, vmax=1)
        fig.colorbar(im, ax=ax, label="(v/v0 - 1) exp(-Re Lambda t), normalised")
        ax.set_xlabel("x")
        ax.set_ylabel("t")
        ax.set_title("linear window: slip-rate perturbation, exact growth divided out\n"
                     + title, fontsize=8)
        fig.tight_layout()
        _plot_save(fig, os.path.join(out, "spacetime_linear.png"), summary)
        plt.close(fig)
    end = f"; end: {summary['end']['reason']}"
    if fig_data["whole"] is not None:
        plot_spacetime(plt, frames, fig_data["whole"], summary,
                       "interface, whole run: " + title + end,
                       os.path.join(out, "spacetime.png"), log_v=False)
    if fig_data["late"] is not None:
        plot_spacetime(plt, frames, fig_data["late"], summary,
                       "nonlinear regime, last periods: " + title + end,
                       os.path.join(out, "spacetime_nonlinear.png"), log_v=True)


def plot_spacetime(plt: object, frames: dict, sel: np.ndarray, summary: dict, suptitle: str,
                   path: str, log_v: bool) -> None:
    """Three space-time panels of the frames ``sel``: slip rate, shear and normal tractions."""
    from matplotlib.colors import LogNorm

    ft, x = frames["t"][sel], frames["x"]
    fig, axes = plt.subplots(1, 3, figsize=(13, 5), sharey=True)
    for ax, key, lab, cmap in ((axes[0], "v", "v/v0", "viridis"),
                               (axes[1], "tau", "(tau - tau0)/sigma0", "RdBu_r"),
                               (axes[2], "sigma", "(sigma - sigma0)/sigma0", "RdBu_r")):
        vals = frames[key][sel]
        if cmap == "RdBu_r":
            lim = max(float(np.max(np.abs(vals))), 1e-300)
            im = ax.pcolormesh(x, ft, vals, cmap=cmap, shading="nearest", vmin=-lim, vmax=lim)
        elif log_v:
            pos = np.clip(vals, 1e-6, None)
            im = ax.pcolormesh(x, ft, pos, cmap=cmap, shading="nearest",
                               norm=LogNorm(vmin=1e-6, vmax=float(pos.max())))
            lab += " (log, clipped at 1e-6)"
        else:
            im = ax.pcolormesh(x, ft, vals, cmap=cmap, shading="nearest")
        fig.colorbar(im, ax=ax, label=lab)
        ax.set_xlabel("x (sliding towards +x)")
    axes[0].set_ylabel("t")
    fig.suptitle(suptitle, fontsize=9)
    fig.tight_layout()
    _plot_save(fig, path, summary)
    plt.close(fig)
