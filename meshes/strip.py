"""A 2D strip ``0 < x < L``, ``0 < y < H`` for the real-space model (docs/design.md section 5).

The mesh is a structured (transfinite) gmsh mesh, built on one rank and distributed by
:func:`dolfinx.io.gmshio.model_to_mesh`. Cells are graded towards the sliding interface
``y = 0`` (modes with ``k H >> 1`` live within ``~1/k`` of it). The left and right edges carry
matching nodes (gmsh's periodic mesh constraint), so a periodic or Bloch map can pair their
degrees of freedom by ``y`` alone. Facet tags: :data:`INTERFACE` (``y = 0``), :data:`TOP`
(``y = H``), :data:`LEFT` (``x = 0``), :data:`RIGHT` (``x = L``).

Two bodies (:func:`two_body_strip_mesh`): the slider ``0 < y < H`` on a substrate
``-H2 < y < 0``, each a structured grid of triangles graded towards ``y = 0``, with *separate*
nodes for the two bodies at ``y = 0`` (the slider may slip on the substrate) and matching nodes
on ``x = 0`` and ``x = L``. Extra facet tags :data:`BOTTOM` (``y = -H2``) and :data:`INTERFACE2`
(the substrate's side of ``y = 0``; :data:`INTERFACE` is the slider's); cell tags
:data:`SLIDER` and :data:`SUBSTRATE`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

import dolfinx.mesh
import ufl
from mpi4py import MPI

from analytic.params import ParameterError
from meshes.interval import interval_vertices

INTERFACE, TOP, LEFT, RIGHT, BOTTOM, INTERFACE2 = 1, 2, 3, 4, 5, 6
FACET_NAMES = {INTERFACE: "interface", TOP: "top", LEFT: "left", RIGHT: "right",
               BOTTOM: "bottom", INTERFACE2: "interface2"}
#: Cell tags of the two bodies (:func:`two_body_strip_mesh`).
SLIDER, SUBSTRATE = 1, 2
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
        depth: Substrate height ``H2`` (0: no substrate mesh, a rigid substrate).
        ny2: Cells along y in the substrate.
        cell_tags: :data:`SLIDER` / :data:`SUBSTRATE` cell markers (two bodies), else ``None``.
    """

    mesh: dolfinx.mesh.Mesh
    facet_tags: dolfinx.mesh.MeshTags
    length: float
    height: float
    nx: int
    ny: int
    grading: float
    depth: float = 0.0
    ny2: int = 0
    cell_tags: dolfinx.mesh.MeshTags | None = None

    @property
    def comm(self) -> MPI.Comm:
        """The mesh communicator."""
        return self.mesh.comm

    @property
    def two_body(self) -> bool:
        """True if the mesh holds a substrate below ``y = 0``."""
        return self.depth > 0


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


def _gmsh() -> tuple[object, object]:
    """``gmsh`` and ``dolfinx.io.gmshio``, imported on first use, SIGINT's handler kept.

    Importing gmsh costs 0.3-0.5 s, which the 1D models (all of :mod:`forms.models.section`)
    never need. gmsh's import sets SIGINT to ``SIG_DFL`` (and ``gmsh.finalize`` restores the
    handler found at the import): the handler in place before it (e.g.
    ``workflows/_supervise.py``'s one line on Ctrl-C) is put back at once.
    """
    import signal
    import threading

    main = threading.current_thread() is threading.main_thread()
    before = signal.getsignal(signal.SIGINT) if main else None
    import gmsh
    from dolfinx.io import gmshio

    if main and before is not None and signal.getsignal(signal.SIGINT) is not before:
        signal.signal(signal.SIGINT, before)
    return gmsh, gmshio


def _build_gmsh_model(gmsh: object, length: float, height: float, nx: int, ny: int,
                      grading: float, cell: str) -> None:
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
    gmsh, gmshio = _gmsh()
    if comm.rank == rank:
        gmsh.initialize()  # gmsh 4.8 cannot tell whether it is initialised: own the session
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("strip")
        try:
            _build_gmsh_model(gmsh, length, height, nx, ny, grading, cell)
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
        which: :data:`INTERFACE`, :data:`TOP`, :data:`LEFT`, :data:`RIGHT` or :data:`BOTTOM`
            (on a two-body mesh, :data:`INTERFACE` finds the nodes of both bodies at ``y = 0``).

    Returns:
        Sorted local block indices on that edge (owned and ghosts).
    """
    tol = 1e-10 * max(mesh.length, mesh.height + mesh.depth)
    axis, value = {INTERFACE: (1, 0.0), TOP: (1, mesh.height), LEFT: (0, 0.0),
                   RIGHT: (0, mesh.length), BOTTOM: (1, -mesh.depth)}[which]
    return np.flatnonzero(np.abs(x_coordinates[:, axis] - value) < tol).astype(np.int32)


def _two_body_grid(length: float, pieces: list[np.ndarray], nx: int
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and triangles of structured grids ``[0, L] x piece`` with their own nodes each."""
    coords, cells, start = [], [], 0
    xs = np.linspace(0.0, length, int(nx) + 1)
    for ys in pieces:
        ny = len(ys) - 1
        X, Y = np.meshgrid(xs, ys, indexing="ij")  # noqa: N806 - node (i, j) -> i (ny+1) + j
        coords.append(np.column_stack([X.ravel(), Y.ravel()]))
        i, j = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
        n00 = start + i.ravel() * (ny + 1) + j.ravel()
        n10, n01 = n00 + ny + 1, n00 + 1
        cells += [np.column_stack([n00, n10, n10 + 1]), np.column_stack([n00, n10 + 1, n01])]
        start += (nx + 1) * (ny + 1)
    return np.vstack(coords), np.vstack(cells).astype(np.int64)


def _two_body_tags(msh: dolfinx.mesh.Mesh, length: float, height: float, depth: float
                   ) -> tuple[dolfinx.mesh.MeshTags, dolfinx.mesh.MeshTags]:
    """Facet tags (:data:`FACET_NAMES`) and cell tags (:data:`SLIDER`, :data:`SUBSTRATE`)."""
    tdim = msh.topology.dim
    cmap = msh.topology.index_map(tdim)
    n_cells = cmap.size_local + cmap.num_ghosts
    mid = dolfinx.mesh.compute_midpoints(msh, tdim, np.arange(n_cells, dtype=np.int32))
    body = np.where(mid[:, 1] > 0, SLIDER, SUBSTRATE).astype(np.int32)
    cell_tags = dolfinx.mesh.meshtags(msh, tdim, np.arange(n_cells, dtype=np.int32), body)
    msh.topology.create_connectivity(tdim - 1, tdim)
    f2c = msh.topology.connectivity(tdim - 1, tdim)
    tol = 1e-10 * max(length, height + depth)
    entities, values = [], []
    for tag, axis, value in ((TOP, 1, height), (LEFT, 0, 0.0), (RIGHT, 0, length),
                             (BOTTOM, 1, -depth), (INTERFACE, 1, 0.0)):
        found = dolfinx.mesh.locate_entities(
            msh, tdim - 1, lambda x, a=axis, v=value: np.abs(x[a] - v) < tol)
        tags = np.full(len(found), tag, dtype=np.int32)
        if tag == INTERFACE:  # the side is the body of the facet's (only) cell
            side = np.array([body[f2c.links(f)[0]] for f in found], dtype=np.int32)
            tags = np.where(side == SLIDER, INTERFACE, INTERFACE2).astype(np.int32)
        entities.append(found)
        values.append(tags)
    entities, values = np.concatenate(entities), np.concatenate(values)
    order = np.argsort(entities, kind="stable")
    # A corner facet is never on two edges (every facet lies on one side of the rectangle).
    return dolfinx.mesh.meshtags(msh, tdim - 1, entities[order], values[order]), cell_tags


def two_body_strip_mesh(comm: MPI.Comm, length: float, height: float, depth: float, nx: int,
                        ny: int, ny2: int, grading: float = 1.0, grading2: float = 1.0
                        ) -> StripMesh:
    """The slider ``[0, L] x [0, H]`` on the substrate ``[0, L] x [-H2, 0]`` (two bodies).

    Each body is a structured grid of ``nx`` columns, every quadrilateral cut into two
    triangles, graded towards ``y = 0`` (``grading``: the far cell over the cell at the
    interface, as :func:`strip_mesh`); the bodies get separate nodes at ``y = 0``. Built on
    rank 0 and distributed over ``comm`` (collective).

    Args:
        comm: Communicator of the mesh.
        length: ``L``.
        height: ``H`` (slider).
        depth: ``H2`` (substrate), finite.
        nx: Cells along x.
        ny: Cells along y in the slider.
        ny2: Cells along y in the substrate.
        grading: Slider's top/bottom cell-height ratio, ``>= 1``.
        grading2: Substrate's bottom/top cell-height ratio, ``>= 1``.

    Returns:
        The :class:`StripMesh` with ``depth = H2``, facet and cell tags.
    """
    check_strip_arguments(length, height, nx, ny, grading, "triangle")
    check_strip_arguments(length, depth, nx, ny2, grading2, "triangle")
    if comm.rank == 0:
        # the 1D models' progression (the last cell `grading` times the one at y = 0)
        pieces = [-interval_vertices(depth, ny2, grading2)[::-1],
                  interval_vertices(height, ny, grading)]
        coord_arr, cell_arr = _two_body_grid(length, pieces, nx)
    else:
        cell_arr = np.empty((0, 3), dtype=np.int64)
        coord_arr = np.empty((0, 2), dtype=np.float64)
    domain = ufl.Mesh(ufl.VectorElement("Lagrange", ufl.triangle, 1, dim=2))
    msh = dolfinx.mesh.create_mesh(comm, cell_arr, coord_arr, domain)
    msh.name = "strip"
    facet_tags, cell_tags = _two_body_tags(msh, float(length), float(height), float(depth))
    facet_tags.name = "facets"
    return StripMesh(msh, facet_tags, float(length), float(height), int(nx), int(ny),
                     float(grading), float(depth), int(ny2), cell_tags)
