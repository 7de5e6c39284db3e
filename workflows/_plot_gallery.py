"""Panels of the paper's figures (figures.py): curves, FE markers, overlays."""

from __future__ import annotations

import _plots
import numpy as np

from analytic.studies.gallery import FigureData, Series
from forms.studies.gallery import CS_DEGREE, PML_DEGREE, Marker

FE_LEGEND = {"cross_section": f"FE, cross-section P{CS_DEGREE}",
             "pml": f"FE, half-space PML P{PML_DEGREE}"}
FE_MARKER = {"cross_section": "o", "pml": "D"}


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
