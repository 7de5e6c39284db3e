"""A 2D strip ``0 < x < L``, ``0 < y < H`` for the real-space model (docs/design.md section 5).

The mesh is a structured (transfinite) gmsh mesh, built on one rank and distributed by
:func:`dolfinx.io.gmshio.model_to_mesh`. Cells are graded towards the sliding interface
``y = 0`` (modes with ``k H >> 1`` live within ``~1/k`` of it). The left and right edges carry
matching nodes (gmsh's periodic mesh constraint), so a periodic or Bloch map can pair their
degrees of freedom by ``y`` alone. Facet tags: :data:`INTERFACE` (``y = 0``), :data:`TOP`
(``y = H``), :data:`LEFT` (``x = 0``), :data:`RIGHT` (``x = L``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

import dolfinx.mesh
import gmsh
import ufl
from dolfinx.io import gmshio
from mpi4py import MPI

from analytic.params import ParameterError

INTERFACE, TOP, LEFT, RIGHT = 1, 2, 3, 4
FACET_NAMES = {INTERFACE: "interface", TOP: "top", LEFT: "left", RIGHT: "right"}
CELL_TYPES = ("triangle", "quadrilateral")


@dataclass
class StripMesh:
    """A distributed strip mesh and what the forms need to know about it.

    Attributes:
        mesh: The dolfinx mesh (on ``mesh.comm``).
        facet_tags: Facet markers :data:`INTERFACE`, :data:`TOP`, :data:`LEFT`, :data:`RIGHT`.
        length: ``L`` (extent in x).
        height: ``H`` (extent in y).
        nx: Cells along x.
        ny: Cells along y.
        grading: Ratio of the top cell height to the bottom cell height.
    """

    mesh: dolfinx.mesh.Mesh
    facet_tags: dolfinx.mesh.MeshTags
    length: float
    height: float
    nx: int
    ny: int
    grading: float

    @property
    def comm(self) -> MPI.Comm:
        """The mesh communicator."""
        return self.mesh.comm


def wavelength(k: float) -> float:
    """One wavelength ``2 pi / k``, the default strip length."""
    return 2.0 * math.pi / k


def check_strip_arguments(length: float, height: float, nx: int, ny: int, grading: float,
                          cell: str) -> None:
    """Validate the strip geometry and resolution (raises :class:`ParameterError`)."""
    for name, value in (("length", length), ("H", height)):
        if not (math.isfinite(value) and value > 0):
            raise ParameterError(f"{name} = {value!r} is outside its allowed range (finite, > 0)")
    for name, value in (("nx", nx), ("ny", ny)):
        if int(value) != value or value < 1:
            raise ParameterError(f"{name} = {value!r} is outside its allowed range (integer >= 1)")
    if not (math.isfinite(grading) and grading >= 1.0):
        raise ParameterError(f"grading = {grading!r} is outside its allowed range (finite, >= 1)")
    if cell not in CELL_TYPES:
        raise ParameterError(f"cell = {cell!r} is not one of {', '.join(CELL_TYPES)}")


def _build_gmsh_model(length: float, height: float, nx: int, ny: int, grading: float,
                      cell: str) -> None:
    """Create the strip in the current gmsh model (rank 0 only)."""
    geo = gmsh.model.geo
    p00 = geo.addPoint(0.0, 0.0, 0.0)
    p10 = geo.addPoint(length, 0.0, 0.0)
    p11 = geo.addPoint(length, height, 0.0)
    p01 = geo.addPoint(0.0, height, 0.0)
    bottom = geo.addLine(p00, p10)
    right = geo.addLine(p10, p11)  # upwards, like `left`: the progression grows with y on both
    top = geo.addLine(p01, p11)
    left = geo.addLine(p00, p01)
    loop = geo.addCurveLoop([bottom, right, -top, -left])
    surface = geo.addPlaneSurface([loop])
    geo.synchronize()

    ratio = grading ** (1.0 / (ny - 1)) if ny > 1 else 1.0
    mesh = gmsh.model.mesh
    for line in (bottom, top):
        mesh.setTransfiniteCurve(line, nx + 1)
    for line in (left, right):
        mesh.setTransfiniteCurve(line, ny + 1, "Progression", ratio)
    mesh.setTransfiniteSurface(surface, "Alternate", [p00, p10, p11, p01])
    if cell == "quadrilateral":
        mesh.setRecombine(2, surface)
    # Right-edge nodes are the left-edge nodes translated by (L, 0): matching y coordinates.
    translation = [1, 0, 0, length, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]
    mesh.setPeriodic(1, [right], [left], translation)

    gmsh.model.addPhysicalGroup(2, [surface], 1)
    for tag, line in ((INTERFACE, bottom), (TOP, top), (LEFT, left), (RIGHT, right)):
        gmsh.model.addPhysicalGroup(1, [line], tag)
        gmsh.model.setPhysicalName(1, tag, FACET_NAMES[tag])
    mesh.generate(2)


def strip_mesh(comm: MPI.Comm, length: float, height: float, nx: int, ny: int,
               grading: float = 1.0, cell: str = "triangle", rank: int = 0) -> StripMesh:
    """Build the strip on ``rank`` with gmsh and distribute it over ``comm``.

    Args:
        comm: Communicator of the mesh (collective).
        length: ``L``, e.g. :func:`wavelength` ``(k)``.
        height: ``H``.
        nx: Cells along x (a transfinite line of ``nx + 1`` nodes).
        ny: Cells along y.
        grading: Top-to-bottom cell-height ratio (geometric progression), ``>= 1``.
        cell: ``"triangle"`` or ``"quadrilateral"``.
        rank: Rank on which gmsh builds the model.

    Returns:
        The distributed :class:`StripMesh`.
    """
    check_strip_arguments(length, height, nx, ny, grading, cell)
    if comm.rank == rank:
        gmsh.initialize()  # gmsh 4.8 cannot tell whether it is initialised: own the session
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("strip")
        try:
            _build_gmsh_model(length, height, nx, ny, grading, cell)
            msh, _, facet_tags = gmshio.model_to_mesh(gmsh.model, comm, rank, gdim=2)
        finally:
            gmsh.finalize()
    else:
        msh, _, facet_tags = gmshio.model_to_mesh(gmsh.model, comm, rank, gdim=2)
    msh.name = "strip"
    facet_tags.name = "facets"
    return StripMesh(msh, facet_tags, float(length), float(height), int(nx), int(ny),
                     float(grading))


def edge_dofs(mesh: StripMesh, x_coordinates: np.ndarray, which: int) -> np.ndarray:
    """Local indices (blocks) whose coordinate lies on one edge of the strip.

    Args:
        mesh: The strip.
        x_coordinates: ``(n, 3)`` dof coordinates (``V.tabulate_dof_coordinates()``).
        which: :data:`INTERFACE`, :data:`TOP`, :data:`LEFT` or :data:`RIGHT`.

    Returns:
        Sorted local block indices on that edge (owned and ghosts).
    """
    tol = 1e-10 * max(mesh.length, mesh.height)
    axis, value = {INTERFACE: (1, 0.0), TOP: (1, mesh.height), LEFT: (0, 0.0),
                   RIGHT: (0, mesh.length)}[which]
    return np.flatnonzero(np.abs(x_coordinates[:, axis] - value) < tol).astype(np.int32)


def layered_strip_mesh(comm: MPI.Comm, length: float, pieces: list[np.ndarray], nx: int
                       ) -> dolfinx.mesh.Mesh:
    """Triangles on ``0 < x < length`` times the bodies of a layered stack (two-body strip).

    Each piece (increasing ``y`` vertices of one body, e.g.
    :meth:`forms.models.layered.Stack.pieces`)
    becomes a structured grid of ``nx`` columns, every quadrilateral cut into two triangles;
    the bodies get *separate* nodes where they touch (``y = 0``), as in
    :func:`meshes.layered.interval_from_pieces`, so the slider may slip on the substrate. The
    left and right edges carry matching nodes (same ``y``). Built on rank 0 of ``comm``.

    Args:
        comm: Communicator of the mesh (collective).
        length: ``L`` (extent in x).
        pieces: Vertex ``y`` arrays of the bodies (only rank 0's are used).
        nx: Columns of cells along x.

    Returns:
        The dolfinx mesh (geometric dimension 2, triangles, no facet tags: locate by
        coordinates and by the body of the adjacent cell).
    """
    if not (math.isfinite(length) and length > 0) or int(nx) != nx or nx < 1:
        raise ParameterError(f"bad strip: length = {length!r}, nx = {nx!r}")
    if comm.rank == 0:
        coords, cells, start = [], [], 0
        xs = np.linspace(0.0, length, int(nx) + 1)
        for piece in pieces:
            ys = np.asarray(piece, dtype=float)
            ny = len(ys) - 1
            X, Y = np.meshgrid(xs, ys, indexing="ij")  # node (i, j) -> i * (ny + 1) + j
            coords.append(np.column_stack([X.ravel(), Y.ravel()]))
            i, j = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
            n00 = start + i.ravel() * (ny + 1) + j.ravel()
            n10, n01 = n00 + ny + 1, n00 + 1
            n11 = n10 + 1
            cells.append(np.column_stack([n00, n10, n11]))
            cells.append(np.column_stack([n00, n11, n01]))
            start += (nx + 1) * (ny + 1)
        cell_arr = np.vstack(cells).astype(np.int64)
        coord_arr = np.vstack(coords)
    else:
        cell_arr = np.empty((0, 3), dtype=np.int64)
        coord_arr = np.empty((0, 2), dtype=np.float64)
    domain = ufl.Mesh(ufl.VectorElement("Lagrange", ufl.triangle, 1, dim=2))
    return dolfinx.mesh.create_mesh(comm, cell_arr, coord_arr, domain)
