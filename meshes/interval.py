"""Graded interval meshes ``0 < y < H`` for the cross-section model (docs/design.md section 5).

The vertices are an exact geometric progression (:func:`interval_vertices`, numpy: no mesh
generator, every rank computes the same numbers); :mod:`meshes.layered` turns them into dolfinx
meshes. Cells shrink geometrically towards the interface ``y = 0``: modes with ``k H >> 1``
live within about ``1/k`` of it, so the ratio between the largest and the smallest cell is
chosen from ``k H`` (:func:`grading_ratio`); the number of cells from ``k``, ``H``, the
element degree and the highest waveguide branch wanted (:func:`default_cells`).
"""

from __future__ import annotations

import math

import numpy as np

#: Largest ratio between the biggest (top) and smallest (interface) cell.
MAX_GRADING = 20.0


def grading_ratio(k_max: float, H: float) -> float:
    """Ratio ``h_max / h_min`` of the graded mesh for wavenumbers up to ``k_max``.

    Uniform for ``k_max H <= 4`` (waveguide modes fill the whole strip), then ``k_max H / 4``
    (modes decay over ``~1/k`` above the interface), capped at :data:`MAX_GRADING`. For a
    half-space-like strip (``H`` very large) the cap applies.
    """
    kh = k_max * H
    return float(min(max(kh / 4.0, 1.0), MAX_GRADING))


def default_cells(k_max: float, H: float, degree: int, n_max: int = 0, beta: float = 0.5) -> int:
    """Number of cells for a relative eigenvalue error of about ``1e-10`` with P``degree >= 2``.

    The transverse wavenumber of waveguide branch ``n`` is at most
    ``sqrt(((2n+1) pi / (2H))**2 + k**2) / beta`` (shear part of the mode, ``c_s = 1``); a
    P``p`` element needs about ``per_wave(p)`` cells per wavelength of it (plus the ``k``
    part). Measured (P3, paper defaults, 20 cells on ``H = 0.5``, ``k = 1``): relative error
    ``6e-12``; the errors go as ``h^(2p)``. P1 needs ``~1e4`` cells for ``1e-8``.
    """
    kt = math.hypot((2 * n_max + 1) * math.pi / (2.0 * H), k_max) / beta
    waves = kt * H / (2.0 * math.pi) + k_max * H / (2.0 * math.pi)
    per_wave = {1: 2000.0, 2: 80.0, 3: 20.0, 4: 10.0}.get(degree, 8.0)
    return int(max(8, math.ceil(per_wave * waves)))


def interval_vertices(H: float, cells: int, ratio: float = 1.0) -> np.ndarray:
    """The ``cells + 1`` increasing vertices of ``0 < y < H``, graded towards ``y = 0``.

    Cell sizes grow geometrically from ``y = 0`` with factor ``r = ratio ** (1 / (cells - 1))``
    (``h_max / h_min = ratio``): ``y_i = H (r^i - 1) / (r^cells - 1)``, evaluated as
    ``expm1(i log r) / expm1(cells log r)`` (no cancellation for ``r`` near 1), so ``y_0 = 0``
    and ``y_cells = H`` exactly. Every 1D model (:mod:`forms.models.section`, its layers and
    stacks) takes its vertices from here. This replaced gmsh's transfinite "Progression" line,
    whose nodes differ from the exact progression by up to ``1.1e-8 H`` (gmsh places them by
    integrating the size field) and whose import cost 0.3-0.5 s per process. The default
    velocity sweep's 559 eigenvalues moved by at most 2.9e-12 relative (their error estimates
    reach 2.6e-10).

    Args:
        H: Height, finite and ``> 0``.
        cells: Number of cells, ``>= 1``.
        ratio: ``h_max / h_min``, ``>= 1`` (``1``: uniform).

    Returns:
        The vertices, shape ``(cells + 1,)``.

    Raises:
        ValueError: A bad ``H``, ``cells`` or ``ratio``.
    """
    if not (math.isfinite(H) and H > 0) or cells < 1 or not ratio >= 1.0:
        raise ValueError(f"bad interval: H={H!r}, cells={cells!r}, ratio={ratio!r}")
    i = np.arange(cells + 1, dtype=float)
    log_r = math.log(ratio) / (cells - 1) if cells > 1 else 0.0
    if log_r == 0.0:
        return H * (i / cells)
    e = np.expm1(i * log_r)
    return H * (e / e[-1])
