"""The files of ``python -m analytic``: dispersion curves and the generalized-Rayleigh map.

The command line's writers (CSV + JSON + PNG); the physics and the root machinery of
:mod:`analytic` write nothing.
"""

from __future__ import annotations

import csv
import math
import os
import shlex
import sys

import numpy as np

from analytic.cli import dumps, versions, world_size
from analytic.numerics.branches import BranchResult, follow_branches
from analytic.params import Params
from analytic.physics.smallk import lambda_smallk
from analytic.physics.twobody import gr_existence_map, rayleigh_speed


def plot_dispersion(p: Params, results: list[BranchResult], path: str,
                    metadata: dict[str, str] | None = None) -> None:
    """Two panels: ``Re Lambda`` and ``Im Lambda`` vs ``k`` for each branch, saved as PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, r in enumerate(results):
        c = colors[(i // 2) % len(colors)]
        ls = "-" if r.sign < 0 else "--"
        ok = np.asarray(r.ok)
        L = np.where(ok, r.Lambda, np.nan)
        ax1.plot(r.k, L.real, ls, color=c, label=f"branch {r.label}")
        ax2.plot(r.k, L.imag, ls, color=c, label=f"branch {r.label}")
        kk = r.k[r.k <= 0.25 * r.k.max()]
        if kk.size and not p.two_body:
            ax1.plot(kk, lambda_smallk(kk, r.n, r.sign, p).real, ":", color="k", lw=1)
    if not p.two_body:
        ax1.plot([], [], ":", color="k", lw=1, label="small-k slope (Eq. Hspectrum)")
    ax1.axhline(0.0, color="0.6", lw=0.8)
    ax1.set_xlabel("k  [1 / (c_s t0)]")
    ax1.set_ylabel("growth rate Re Lambda  [1 / t0]")
    ax2.set_xlabel("k  [1 / (c_s t0)]")
    ax2.set_ylabel("frequency Im Lambda  [1 / t0]")
    title = (f"exact finite-H spectrum, bc = {p.bc}: f = {p.f:g}, gamma = {p.gamma:g}, "
             f"beta = {p.beta:g}, Delta = {p.Delta:g}, H = {p.H:g}")
    if p.generalized:
        title += f", alpha_pc = {p.alpha_pc:g}, alpha_ld = {p.alpha_ld:g}"
    if p.two_body:
        title += (f"\nsubstrate: mu2 = {p.mu2:g}, rho2 = {p.rho2:g}, beta2 = "
                  f"{p.substrate_beta:g}, H2 = {p.H2:g}, bc2 = {p.bc2}")
    fig.suptitle(title, fontsize=10)
    ax1.legend(fontsize=8)
    ax1.set_title("Re Lambda > 0: unstable", fontsize=9)
    ax2.set_title("branches start at the composite-rod cut-offs (two bodies)" if p.two_body
                  else "branches start at Lambda_0 = +-i(2n+1) pi/(2 beta H)", fontsize=9)
    fig.savefig(path, dpi=120, metadata=metadata or {})
    plt.close(fig)


def write_dispersion(p: Params, k: np.ndarray, n_branches: int, out: str) -> list[str]:
    """Follow ``n_branches`` cut-off pairs over ``k``; write CSV, JSON and PNG into ``out``.

    Args:
        p: Parameters (finite ``H``).
        k: Wavenumbers (validated, ascending).
        n_branches: Number of cut-off indices ``n`` (each gives ``n+`` and ``n-``).
        out: Output directory (created if missing).

    Returns:
        The paths written.
    """
    results = follow_branches(p, n_branches, k)  # all computing before any file is written
    os.makedirs(out, exist_ok=True)
    csv_path = os.path.join(out, "dispersion.csv")
    with open(csv_path, "w", newline="") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(["k", "branch", "re_lambda", "im_lambda", "residual", "ok"])
        for r in results:
            for i, kv in enumerate(r.k):
                L = r.Lambda[i]
                w.writerow([f"{kv:.12g}", r.label, f"{L.real:.16g}", f"{L.imag:.16g}",
                            f"{r.residual[i]:.3e}", int(bool(r.ok[i]))])
    command = shlex.join([sys.executable, "-m", "analytic", *sys.argv[1:]])
    if world_size() > 1:
        command = f"mpirun -n {world_size()} {command}"
    info = {
        "what": "exact roots of det M(Lambda, k, H) = 0 followed from the waveguide cut-offs",
        "params": p.as_dict(),
        "branches": [r.label for r in results],
        "k": {"min": float(k.min()), "max": float(k.max()), "count": int(k.size)},
        "max_growth": {r.label: (None if not np.any(r.ok) else
                                 {"re_lambda": float(np.nanmax(np.where(r.ok, r.Lambda.real,
                                                                        np.nan))),
                                  "at_k": float(r.k[np.nanargmax(np.where(r.ok, r.Lambda.real,
                                                                          np.nan))])})
                       for r in results},
        "notes": [r.note for r in results if r.note],
        "command": command,
        "versions": versions(),
    }
    json_path = os.path.join(out, "dispersion.json")
    with open(json_path, "w") as fh:
        fh.write(dumps(info, indent=2))  # strict JSON: inf -> "inf", NaN -> null
    png_path = os.path.join(out, "dispersion.png")
    plot_dispersion(p, results, png_path,
                    metadata={"Title": "analytic dispersion curve", "Description": command,
                              "Comment": dumps(p.as_dict()),
                              "Software": "bimaterial-stability " + dumps(versions())})
    return [csv_path, json_path, png_path]


def write_gr_map(out: str, beta: float = 0.5, beta2: float | None = None,
                 mu2_range: tuple[float, float] = (0.01, 100.0),
                 rho2_range: tuple[float, float] = (0.1, 10.0), n: int = 121) -> list[str]:
    """Where the generalized Rayleigh wave exists in the ``(mu2, rho2)`` plane: CSV, JSON, PNG.

    Log-spaced ``n x n`` grid; the colour is the speed relative to ``c_max = min(c_s1, c_s2)``
    (1: the wave merges into the slower shear wave at the existence boundary); the lines of
    equal shear wave speed (``mu2 = rho2``: speed = Rayleigh speed) and of equal shear
    impedance (``mu2 rho2 = 1``) are drawn. Returns the written paths.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    os.makedirs(out, exist_ok=True)
    mu2s = np.logspace(math.log10(mu2_range[0]), math.log10(mu2_range[1]), n)
    rho2s = np.logspace(math.log10(rho2_range[0]), math.log10(rho2_range[1]), n)
    speed = gr_existence_map(mu2s, rho2s, beta, beta2)
    c_max = np.minimum(1.0, np.sqrt(mu2s[None, :] / rho2s[:, None]))
    paths = [os.path.join(out, f"gr_map.{ext}") for ext in ("csv", "json", "png")]
    with open(paths[0], "w", newline="") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(["mu2", "rho2", "exists", "speed", "speed_over_cmax"])
        for i, r in enumerate(rho2s):
            for j, m in enumerate(mu2s):
                s = speed[i, j]
                w.writerow([f"{m:.8g}", f"{r:.8g}", int(np.isfinite(s)),
                            "" if not np.isfinite(s) else f"{s:.12g}",
                            "" if not np.isfinite(s) else f"{s / c_max[i, j]:.12g}"])
    b2 = beta if beta2 is None else beta2
    meta = {"beta": beta, "beta2": b2, "mu2_range": list(mu2_range),
            "rho2_range": list(rho2_range), "n": n,
            "fraction_exists": float(np.isfinite(speed).mean()),
            "rayleigh_speed_body1": rayleigh_speed(beta),
            "model": "two half-spaces, frictionless contact without opening (Weertman 1963)"}
    with open(paths[1], "w") as fh:
        fh.write(dumps(meta, indent=2) + "\n")
    fig, ax = plt.subplots(figsize=(6.2, 5.0), constrained_layout=True)
    pc = ax.pcolormesh(mu2s, rho2s, speed / c_max, shading="auto", cmap="viridis")
    fig.colorbar(pc, ax=ax, label="GR speed / min(c_s1, c_s2)")
    ax.plot(mu2s, mu2s, "w--", lw=1, label="c_s2 = c_s1")
    ax.plot(mu2s, 1.0 / mu2s, "w:", lw=1, label="rho2 c_s2 = rho1 c_s1")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(*mu2_range)
    ax.set_ylim(*rho2_range)
    ax.set_xlabel("mu2 / mu1")
    ax.set_ylabel("rho2 / rho1")
    ax.set_title(f"generalized Rayleigh wave exists (coloured); beta = {beta:g}, beta2 = {b2:g}",
                 fontsize=9)
    ax.legend(loc="lower right", fontsize=8)
    fig.savefig(paths[2], dpi=110)
    plt.close(fig)
    return paths
