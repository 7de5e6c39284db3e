"""Interval meshes from explicit vertex coordinates (PML layers, layered stacks of two bodies).

:func:`interval_from_pieces` builds a dolfinx interval mesh whose vertices are given (rank 0
of the communicator passes them, dolfinx distributes the cells): one piece is a plain interval,
several are disconnected (two bodies with their own nodes at the interface,
:mod:`forms.models.section`); :func:`geometric_sizes` makes cell sizes that grow geometrically
from ``h0`` to ``h_max`` (then stay) to fill a length.
"""

from __future__ import annotations

import math

import numpy as np

import dolfinx
import ufl
from mpi4py import MPI


def geometric_sizes(length: float, h0: float, h_max: float, growth: float) -> np.ndarray:
    """Cell sizes ``h0, h0 g, h0 g^2, ... <= h_max`` (then ``h_max``) summing to ``length``.

    The last cells are rescaled so the sizes add up to ``length`` exactly.

    Args:
        length: Total length ``> 0``.
        h0: First cell size ``> 0``.
        h_max: Largest cell size ``>= h0``.
        growth: Ratio between neighbouring cells ``>= 1``.
    """
    if not (length > 0 and h0 > 0 and h_max >= h0 and growth >= 1.0):
        raise ValueError(f"bad sizes: length={length}, h0={h0}, h_max={h_max}, growth={growth}")
    sizes: list[float] = []
    total, h = 0.0, h0
    while total + h < length:
        sizes.append(h)
        total += h
        h = min(h * growth, h_max)
    rest = length - total
    if sizes and rest < 0.5 * sizes[-1]:
        sizes[-1] += rest
    else:
        sizes.append(rest)
    return np.asarray(sizes)


def layer_count(length: float, h0: float, h_max: float, growth: float) -> int:
    """Number of cells :func:`geometric_sizes` makes (for budgets, without building them)."""
    if growth == 1.0 or h0 >= h_max:
        return max(1, math.ceil(length / h0))
    n_grow = math.ceil(math.log(h_max / h0) / math.log(growth))
    grown = h0 * (growth ** n_grow - 1.0) / (growth - 1.0)
    if grown >= length:
        return max(1, math.ceil(math.log(1 + length * (growth - 1.0) / h0) / math.log(growth)))
    return n_grow + math.ceil((length - grown) / h_max)


def interval_from_pieces(comm: MPI.Comm, pieces: list[np.ndarray]) -> dolfinx.mesh.Mesh:
    """Interval mesh made of disconnected pieces (read on rank 0 of ``comm``).

    Each piece is a strictly increasing vertex array; consecutive pieces may touch (the last
    vertex of one equal to the first of the next) but get *separate* vertices there, so a
    continuous Lagrange space has two independent nodes at the common point (the two sides of
    an interface that may slip).

    Args:
        comm: Communicator the mesh is distributed over.
        pieces: Vertex arrays (only rank 0's are used).

    Returns:
        The dolfinx mesh (geometric dimension 1).
    """
    if comm.rank == 0:
        coords, cells, start = [], [], 0
        for piece in pieces:
            x = np.asarray(piece, dtype=np.float64)
            if x.ndim != 1 or len(x) < 2 or not np.all(np.diff(x) > 0):
                raise ValueError("each piece must be a strictly increasing 1D array, length >= 2")
            idx = start + np.arange(len(x))
            cells.append(np.column_stack([idx[:-1], idx[1:]]))
            coords.append(x)
            start += len(x)
        cell_arr = np.vstack(cells).astype(np.int64)
        coord_arr = np.concatenate(coords).reshape(-1, 1)
    else:
        cell_arr = np.empty((0, 2), dtype=np.int64)
        coord_arr = np.empty((0, 1), dtype=np.float64)
    domain = ufl.Mesh(ufl.VectorElement("Lagrange", ufl.interval, 1, dim=1))
    return dolfinx.mesh.create_mesh(comm, cell_arr, coord_arr, domain)
