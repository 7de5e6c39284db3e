"""Pictures of a strip mode (``mode_shape.py``): deformed strip, phase frames, both bodies."""

from __future__ import annotations

import numpy as np


def plot_mode(gathered: dict, frames: list[tuple[np.ndarray, np.ndarray]], out_png: str,
              title: str, color: str, lam: complex, k: float, height: float, length: float,
              fractions: tuple[float, ...] = (0.0,), depth: float = 0.0) -> None:
    """Deformed strip coloured by ``|u|`` or ``sigma_yy``, with direction arrows (rank 0).

    ``gathered`` is :func:`forms.studies.strip_mode.gather_mode`'s grid and ``frames`` its fields at
    ``t = fraction * period`` (:func:`forms.studies.strip_mode.phase_frames`, growth factored out):
    each
    row of the picture is one frame, so successive rows step forward in time and the pattern
    moves with the phase velocity ``Im(Lambda) / k``. ``depth``: the substrate's height ``H2``
    when it is part of the grid (two bodies; else a grey band stands for the rigid one).
    """
    import pyvista as pv

    pv.OFF_SCREEN = True
    grid = pv.UnstructuredGrid(gathered["cells"], gathered["cell_types"], gathered["points"])
    rows = len(fractions)
    # World-space layout: strip (deformation drawn up to `amp`), substrate below it, a band of
    # direction arrows under the substrate, room on top for the title and the colour bar.
    m = 0.06 * max(height, length / 6)
    amp = 0.2 * min(height, length / 4)
    y_arrow = -depth - 3.2 * m
    y_lo = y_arrow - 1.6 * m
    y_hi = height + amp + 0.25 * (height + amp - y_lo)  # title band
    row_px = int(np.clip(1600 * (y_hi - y_lo) / (length + 2 * amp), 220, 760))
    plotter = pv.Plotter(off_screen=True, shape=(rows, 1), window_size=(1600, row_px * rows),
                         border=False)
    data = gathered["point_data"]
    umax = float(np.max(np.linalg.norm(data["u_re"] + 1j * data["u_im"], axis=1)))
    scale = amp / max(umax, 1e-300)
    c_phase = lam.imag / k
    smax = float(np.max(np.abs(data["syy_re"] + 1j * data["syy_im"])))
    for r, (frac, (u, syy)) in enumerate(zip(fractions, frames, strict=True)):
        plotter.subplot(r, 0)
        g = grid.copy()
        g.point_data["u"] = u
        if color == "displacement":
            g.point_data["|u|"] = np.linalg.norm(u, axis=1)
            scalars, label, cmap, clim = "|u|", "displacement magnitude", "viridis", (0.0, umax)
        else:
            g.point_data["sigma_yy"] = syy
            scalars, label, cmap = "sigma_yy", "normal stress sigma_yy", "RdBu_r"
            clim = (-smax, smax)
        warped = g.warp_by_vector("u", factor=scale).extract_surface(
            algorithm="dataset_surface", nonlinear_subdivision=3)
        plotter.add_mesh(warped, scalars=scalars, cmap=cmap, clim=clim, show_edges=False,
                         scalar_bar_args={"title": label, "vertical": False, "position_x": 0.76,
                                          "position_y": 0.03, "width": 0.22, "height": 0.15,
                                          "title_font_size": 14, "label_font_size": 11,
                                          "n_labels": 3, "fmt": "%.2g"})
        outline = pv.Rectangle([[0, -depth, 0], [length, -depth, 0], [length, height, 0]])
        plotter.add_mesh(outline.extract_feature_edges(), color="grey", line_width=1)
        if depth == 0:
            plotter.add_mesh(pv.Rectangle([[0, -m, 0], [length, -m, 0], [length, 0, 0]]),
                             color="#b0b0b0")
        # sliding direction (+x: the body moves at v0 > 0) and phase velocity direction
        alen = min(0.1 * length, 0.4 * max(height, length / 6))
        arrow = dict(scale=alen, shaft_radius=0.05, tip_radius=0.14, tip_length=0.3)
        plotter.add_mesh(pv.Arrow(start=(0.0, y_arrow, 0), direction=(1, 0, 0), **arrow),
                         color="black")
        sgn = 1.0 if c_phase >= 0 else -1.0
        x0 = 0.5 * length if sgn > 0 else 0.5 * length + alen
        plotter.add_mesh(pv.Arrow(start=(x0, y_arrow, 0), direction=(sgn, 0, 0), **arrow),
                         color="crimson")
        plotter.add_point_labels(
            np.array([[alen, y_arrow, 0], [0.5 * length + alen, y_arrow, 0]]),
            ["  sliding, v0 > 0", f"  phase velocity Im(Lambda)/k = {c_phase:+.3g}"],
            font_size=15, show_points=False, shape=None, text_color="black",
            justification_horizontal="left", justification_vertical="center",
            always_visible=True)
        plotter.add_text(f"t = {frac:.2f} T" if rows > 1 else "t = 0", position="upper_right",
                         font_size=10)
        if r == 0:
            plotter.add_text(title, position="upper_left", font_size=10)
        # camera framing exactly [0, L] x [y_lo, y_hi] (a little margin), whatever the aspect
        cx, cy = 0.5 * length, 0.5 * (y_lo + y_hi)
        cam = plotter.camera
        cam.focal_point = (cx, cy, 0.0)
        cam.position = (cx, cy, 10.0 * max(length, y_hi - y_lo))
        cam.up = (0.0, 1.0, 0.0)
        plotter.enable_parallel_projection()
        cam.parallel_scale = 0.52 * max(y_hi - y_lo, (length + 2 * amp) * row_px / 1600)
        cam.clipping_range = (1e-3 * max(length, height), 100.0 * max(length, y_hi - y_lo))
    plotter.screenshot(out_png)
    plotter.close()
