"""Graded interval meshes ``0 < y < H`` for the cross-section model (docs/design.md section 5).

The mesh is made by gmsh on rank 0 of the given communicator (a transfinite line with a
geometric "Progression"), then read and distributed by ``dolfinx.io.gmshio.model_to_mesh``.
Cells shrink geometrically towards the interface ``y = 0``: modes with ``k H >> 1`` live within
about ``1/k`` of it, so the ratio between the largest and the smallest cell is chosen from
``k H`` (:func:`grading_ratio`); the number of cells from ``k``, ``H``, the element degree and
the highest waveguide branch wanted (:func:`default_cells`).
"""

from __future__ import annotations

import math

import numpy as np

import dolfinx
import dolfinx.io.gmshio
import gmsh
from mpi4py import MPI

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


def interval_mesh(
    comm: MPI.Comm, H: float, cells: int, ratio: float = 1.0
) -> dolfinx.mesh.Mesh:
    """Create the interval ``0 < y < H`` with ``cells`` cells, graded towards ``y = 0``.

    Args:
        comm: Communicator the mesh is distributed over (gmsh runs on its rank 0).
        H: Strip height, ``> 0`` and finite.
        cells: Number of cells, ``>= 1``.
        ratio: ``h_max / h_min`` (``1`` is uniform); sizes grow geometrically from ``y = 0``.

    Returns:
        The dolfinx mesh (geometric dimension 1, coordinate ``y``).
    """
    if not (math.isfinite(H) and H > 0):
        raise ValueError(f"H = {H!r} must be finite and > 0")
    if cells < 1:
        raise ValueError(f"cells = {cells!r} must be >= 1")
    if ratio < 1.0:
        raise ValueError(f"ratio = {ratio!r} must be >= 1")
    if comm.rank == 0:
        # gmsh 4.8 has no isInitialized(): own a gmsh session for the duration of this call.
        gmsh.initialize()
        _gmsh_interval(H, cells, ratio)
    msh, _, _ = dolfinx.io.gmshio.model_to_mesh(gmsh.model, comm, 0, gdim=1)
    if comm.rank == 0:
        gmsh.finalize()
    return msh


def _gmsh_interval(H: float, cells: int, ratio: float) -> None:
    """Mesh the graded line ``0 < y < H`` in the current gmsh session."""
    progression = ratio ** (1.0 / (cells - 1)) if cells > 1 else 1.0
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("interval")
    p0 = gmsh.model.geo.addPoint(0.0, 0.0, 0.0)
    p1 = gmsh.model.geo.addPoint(H, 0.0, 0.0)
    line = gmsh.model.geo.addLine(p0, p1)
    gmsh.model.geo.mesh.setTransfiniteCurve(line, cells + 1, "Progression", progression)
    gmsh.model.geo.synchronize()
    gmsh.model.addPhysicalGroup(1, [line], 1)
    gmsh.model.mesh.generate(1)


def interval_vertices(H: float, cells: int, ratio: float = 1.0) -> np.ndarray:
    """The increasing vertex coordinates :func:`interval_mesh` uses (gmsh, on the calling rank).

    For layered stacks (:mod:`forms.models.section`) that must reproduce the cross-section model's
    mesh exactly (the same gmsh nodes, not a re-computed progression).
    """
    if not (math.isfinite(H) and H > 0) or cells < 1 or ratio < 1.0:
        raise ValueError(f"bad interval: H={H!r}, cells={cells!r}, ratio={ratio!r}")
    gmsh.initialize()
    try:
        _gmsh_interval(H, cells, ratio)
        _, coords, _ = gmsh.model.mesh.getNodes()
    finally:
        gmsh.finalize()
    return np.sort(np.asarray(coords, dtype=float).reshape(-1, 3)[:, 0])

