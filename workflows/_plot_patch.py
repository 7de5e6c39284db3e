"""Plots of the friction-patch scene: growth against the patch length (rank 0 only)."""

from __future__ import annotations

import _cli
import numpy as np


def plot_growth(lp: np.ndarray, growth: np.ndarray, closed: np.ndarray, lc: float | None,
                estimates: dict[str, float], out_png: str, title: str, meta: dict) -> None:
    """``max Re Lambda`` against ``Lp``, the critical length and the published estimates.

    Args:
        lp: Patch lengths.
        growth: Fastest ``Re Lambda`` at each (``nan``: none in the box).
        closed: Whether each length's count closed (open markers where not).
        lc: Critical length (``None``: no crossing on the grid).
        estimates: Label -> length of the published nucleation estimates (drawn as lines).
        out_png: PNG file.
        title: Figure title.
        meta: Run parameters for the PNG metadata.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4.5))
    ax.plot(lp, growth, "-", color="tab:blue", lw=1)
    ax.plot(lp[closed], growth[closed], "o", color="tab:blue",
            label="fastest mode in the box, count closed")
    if (~closed).any():
        ax.plot(lp[~closed], growth[~closed], "o", mfc="none", color="tab:red",
                label="count NOT closed")
    ax.axhline(0, color="k", lw=0.6)
    if lc is not None:
        ax.axvline(lc, color="tab:blue", ls="--", label=f"$L_c$ = {lc:.4g} (interpolated)")
    for (label, value), ls in zip(estimates.items(), (":", "-.", (0, (5, 2)), (0, (1, 3))),
                                  strict=False):
        if np.isfinite(value) and lp.min() / 2 < value < 2 * lp.max():
            ax.axvline(value, color="gray", ls=ls, lw=1, label=f"{label} = {value:.4g}")
    ax.set_xlabel("patch length $L_p$ (units $c_s t_0$)")
    ax.set_ylabel(r"max Re $\Lambda$ (units $1/t_0$)")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    _cli.save_figure(fig, out_png, dpi=120, metadata=_cli.png_metadata(meta, title))
    plt.close(fig)
