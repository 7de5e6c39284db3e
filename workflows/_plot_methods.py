"""Chart of the methods study (:mod:`forms.studies.methods`): found fraction, spurious, cost."""

from __future__ import annotations

from typing import Any

import _cli

METHOD_STYLE = {"tiling": ("C0", "o"), "dense": ("C3", "s"), "linear": ("C5", "P"),
                "moments": ("k", "D"),
                "ciss": ("C2", "^"), "nleigs": ("C1", "v"), "newton": ("C4", "x")}


def plot_methods(rows: list[dict], path: str, meta: dict[str, Any]) -> None:
    """Three panels vs k, one line per (method, c_max): found / count, spurious, seconds."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6))
    c_maxes = sorted({r["c_max"] for r in rows})
    styles = ("-", "--", ":", "-.")
    for m, (color, marker) in METHOD_STYLE.items():
        for j, c in enumerate(c_maxes):
            sel = sorted((r for r in rows if r["method"] == m and r["c_max"] == c),
                         key=lambda r: r["k"])
            if not sel:
                continue
            ks = [r["k"] for r in sel]
            frac = [r["found"] / r["count"] if r["count"] else 1.0 for r in sel]
            kw = {"color": color, "marker": marker, "ls": styles[j % len(styles)],
                  "mfc": "none", "label": f"{m}, c_max = {c:g}"}
            axes[0].plot(ks, frac, **kw)
            axes[1].plot(ks, [r["spurious"] for r in sel], **kw)
            ok = [(r["k"], r["seconds"]) for r in sel if not r["failed"].startswith("raised")]
            if ok:
                axes[2].semilogy(*zip(*ok, strict=True), **kw)
    for ax, lab in zip(axes, ("found / counted (failed = 0)", "spurious in R",
                              "wall seconds (runs that raised left out)"), strict=True):
        ax.set_xlabel("k")
        ax.set_ylabel(lab)
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=6, ncol=2)
    fig.suptitle(f"methods vs the banded count; {meta['machine']}, {meta['ranks']} rank(s)",
                 fontsize=8)
    fig.tight_layout()
    _cli.save_figure(fig, path, dpi=110, metadata=_cli.png_metadata(meta, "methods chart"))
    plt.close(fig)
