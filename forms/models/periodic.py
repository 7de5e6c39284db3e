"""The reduction ``u_full = P u_red`` of the 2D model: Bloch condition and the two-body tie.

docs/design.md section 5.6. Fields go as ``exp(Lambda t - i k x)``, so a mode on a cell of
length ``L`` satisfies ``u(L, y) = exp(-i k L) u(0, y)``. One map ``P`` carries

- the Bloch condition (``k`` set): the right-edge nodes ``x = L`` are not unknowns; such a node
  is ``exp(-i k L)`` times its left partner (same ``y``, same body);
- the interface of two bodies (:attr:`meshes.strip.StripMesh.two_body`): the substrate's
  ``u_y2`` at ``y = 0`` is the slider's ``u_y1`` at the same ``x`` (not an unknown), and the
  slider's ``u_x1 = s + u_x2``: the reduced unknown in the slot of ``u_x1`` is the slip ``s``.

A weak form ``w^H A u`` restricted to ``u = P u_red``, ``w = P w_red`` becomes
``w_red^H (P^H A P) u_red`` (conjugate transpose, since the complex forms conjugate the test
side). Every reduced row of a left-edge node sums the contributions of the node and of its
right-edge image, and with two bodies the row of ``u_y`` sums both sides' normal reactions
(continuity of ``s_yy``), the row of ``u_x2`` both shear reactions (continuity of ``s_xy``), the
row of ``s`` the slider's: the friction row operation replaces it. :attr:`ReductionMap.Q` is ``P``
without the ``u_x2`` term in ``u_x1`` (for the interface mass of ``s``).

The reduced numbering keeps the owned nodes in order, ``(x, y)`` of each kept node; pairing
across ranks: every rank contributes the reduced indices of its owned left-edge and interface
nodes, keyed by ``(x, y, body)``, to an ``allgather``. The mesh carries matching nodes on both
edges (:mod:`meshes.strip`).
"""

from __future__ import annotations

import cmath
from dataclasses import dataclass

import numpy as np

import dolfinx.fem
from mpi4py import MPI
from petsc4py import PETSc

from meshes.strip import StripMesh


@dataclass
class ReductionMap:
    """The map ``P`` (and ``Q``), and the reduced numbering.

    Attributes:
        P: ``(N_full, N_red)`` PETSc matrix, rows distributed like the assembled matrices.
        Q: ``P`` without the ``u_x2`` term of ``u_x1 = s + u_x2`` (two bodies), else ``None``.
        phase: ``exp(-i k L)`` (1 on a finite block).
        reduced: ``(n_owned, 2)``: per owned node of ``V`` the global reduced index of its
            ``u_x`` (or slip) and ``u_y``; ``-1`` where it is not an unknown.
    """

    P: PETSc.Mat
    Q: PETSc.Mat | None
    phase: complex
    reduced: np.ndarray

    def destroy(self) -> None:
        """Free the PETSc matrices."""
        self.P.destroy()
        if self.Q is not None:
            self.Q.destroy()


def _numbering(comm: MPI.Comm, keep: np.ndarray) -> tuple[np.ndarray, int, int]:
    """Global reduced indices of the kept ``(node, component)`` slots, ``-1`` elsewhere."""
    n_red = int(keep.sum())
    offset = comm.exscan(n_red, op=MPI.SUM) or 0  # None on rank 0
    red = np.full(keep.shape, -1, dtype=np.int64)
    red[keep] = offset + np.arange(n_red)
    return red, n_red, comm.allreduce(n_red, op=MPI.SUM)


def _columns(comm: MPI.Comm, xy: np.ndarray, body: np.ndarray, red: np.ndarray,
             right: np.ndarray, listed: np.ndarray, two_body: bool, tol: float
             ) -> np.ndarray:
    """Per owned node the reduced columns ``[x, x2, y]`` of its full ``u_x, u_y`` (-1: none).

    ``x2`` is the substrate's ``u_x2`` in the slider's ``u_x1 = s + u_x2``; a right-edge node
    takes its left partner's columns (the caller multiplies its row by the Bloch phase).
    """
    def key(x: float, y: float, b: int) -> tuple[int, int, int]:
        return (int(round(x / tol)), int(round(y / tol)), int(b))

    mine = [(key(*xy[i], body[i]), int(red[i, 0]), int(red[i, 1]))
            for i in np.flatnonzero(listed)]
    table = {kk: (rx, ry) for part in comm.allgather(mine) for kk, rx, ry in part}
    cols = np.column_stack([red[:, 0], np.full(len(red), -1, np.int64), red[:, 1]])
    failed = 0
    at_interface = np.abs(xy[:, 1]) < tol
    for i in np.flatnonzero(right | (at_interface & two_body)):
        src = key(0.0 if right[i] else xy[i, 0], xy[i, 1], body[i])
        partner = (src[0], src[1], 3 - src[2])
        tied = two_body and at_interface[i]
        if src not in table or (tied and partner not in table):
            failed += 1
            continue
        rx, ry = table[src]
        cols[i] = (rx, -1, ry)
        if tied and body[i] == 1:
            cols[i, 1] = table[partner][0]
        elif tied:
            cols[i, 2] = table[partner][1]
    if comm.allreduce(failed, op=MPI.SUM):
        raise RuntimeError("reduction map: a right-edge or interface node has no partner (the"
                           " mesh must have matching nodes on x = 0, x = L and both sides of"
                           " y = 0)")
    return cols


def _matrix(comm: MPI.Comm, cols: np.ndarray, value: np.ndarray, n_full: tuple[int, int],
            n_red: tuple[int, int], slip: bool) -> PETSc.Mat:
    """CSR ``P``: rows ``u_x`` (1 or 2 entries) and ``u_y`` (1 entry) of every owned node."""
    mask = cols >= 0
    if not slip:
        mask[:, 1] = False
    counts = np.column_stack([mask[:, 0].astype(int) + mask[:, 1], mask[:, 2]]).ravel()
    indptr = np.concatenate([[0], np.cumsum(counts)]).astype(PETSc.IntType)
    vals = np.repeat(value[:, None], 3, axis=1)
    P = PETSc.Mat().createAIJ((n_full, n_red), csr=(indptr, cols[mask].astype(PETSc.IntType),
                                                    vals[mask].astype(PETSc.ScalarType)),
                              comm=comm)
    P.assemble()
    return P


def reduction_map(V: dolfinx.fem.FunctionSpace, strip: StripMesh, k: float | None,
                  body: np.ndarray) -> ReductionMap | None:
    """``P`` for Bloch wavenumber ``k`` (``None``: finite block) on ``strip`` (collective).

    Args:
        V: A blocked (2-component) Lagrange space on ``strip.mesh``.
        strip: The strip (one or two bodies; its length ``L`` sets ``exp(-i k L)``).
        k: Wavenumber; ``None`` for a finite block (no Bloch condition).
        body: Per owned node of ``V``: 1 (slider) or 2 (substrate).

    Returns:
        The :class:`ReductionMap`, or ``None`` when ``P`` would be the identity (one body, finite
        block).

    Raises:
        RuntimeError: (on every rank) if some node has no partner.
    """
    if k is None and not strip.two_body:
        return None
    comm = strip.comm
    imap = V.dofmap.index_map
    n_owned = imap.size_local
    xy = V.tabulate_dof_coordinates()[:n_owned, :2]
    tol = 1e-9 * max(strip.length, strip.height + strip.depth)
    bloch = k is not None
    right = bloch & (np.abs(xy[:, 0] - strip.length) < tol)
    left = bloch & (np.abs(xy[:, 0]) < tol)
    interface = strip.two_body & (np.abs(xy[:, 1]) < tol)
    if (left & right).any():
        raise RuntimeError("reduction map: the cell is too short")
    keep = np.ones((n_owned, 2), dtype=bool)
    keep[right, :] = False
    keep[interface & (body == 2), 1] = False
    red, n_red, n_red_global = _numbering(comm, keep)
    cols = _columns(comm, xy, body, red, right, (left | interface) & ~right, strip.two_body,
                    tol)
    phase = cmath.exp(-1j * k * strip.length) if bloch else 1.0 + 0j
    value = np.where(right, phase, 1.0 + 0j)
    sizes = ((2 * n_owned, 2 * imap.size_global), (n_red, n_red_global))
    P = _matrix(comm, cols, value, *sizes, slip=True)
    Q = _matrix(comm, cols, value, *sizes, slip=False) if strip.two_body else None
    return ReductionMap(P, Q, phase, red)


def reduce_matrix(A: PETSc.Mat, P: PETSc.Mat) -> PETSc.Mat:
    """Return ``P^H A P`` (a new matrix; ``A`` and ``P`` are left unchanged)."""
    AP = A.matMult(P)
    PH = P.copy()
    PH.conjugate()
    reduced = PH.transposeMatMult(AP)
    AP.destroy()
    PH.destroy()
    return reduced
