"""Bloch-periodic reduction of a strip as a PETSc matrix ``P`` (docs/design.md section 5.6).

Fields go as ``exp(Lambda t - i k x)``, so a mode on a cell of length ``L`` satisfies
``u(L, y) = exp(-i k L) u(0, y)``. The reduced unknowns are all degrees of freedom except those on
the right edge ``x = L``; ``P`` maps them to the full vector::

    u_full = P u_red,   P[i, i'] = 1 (i not on the right edge, i' its reduced index),
                        P[j, l'] = exp(-i k L) (j on the right edge, l' its left partner).

A weak form ``w^H A u`` restricted to Bloch fields ``u = P u_red``, ``w = P w_red`` becomes
``w_red^H (P^H A P) u_red``: the reduced operator is ``P^H A P`` (conjugate transpose, since the
complex forms conjugate the test side). Every row of ``P^H A P`` belonging to a left-edge node
sums the contributions of that node and of its right-edge image, so boundary "reactions" at
the corners of the interface come out right without special cases.

Pairing across ranks: the owner of a right-edge dof may not own (or even see) its left partner.
Every rank contributes the ``(y, reduced block index)`` list of its owned left-edge nodes to an
``allgather``; each rank then pairs its owned right-edge nodes by ``y``. The mesh carries
matching nodes on both edges (:mod:`meshes.strip` uses gmsh's periodic constraint).
"""

from __future__ import annotations

import cmath
from dataclasses import dataclass

import numpy as np

import dolfinx.fem
from mpi4py import MPI
from petsc4py import PETSc

from meshes.strip import LEFT, RIGHT, StripMesh, edge_dofs


@dataclass
class BlochMap:
    """The periodic map ``P`` and the reduced numbering.

    Attributes:
        P: ``(N_full, N_red)`` PETSc matrix, rows distributed like the assembled matrices.
        phase: ``exp(-i k L)``.
        reduced_block: For every owned block (node) of ``V``, its global reduced block index,
            or ``-1`` for a right-edge node (eliminated).
        bs: Block size (2 for a 2D displacement).
        num_owned_reduced: Number of owned reduced blocks on this rank.
    """

    P: PETSc.Mat
    phase: complex
    reduced_block: np.ndarray
    bs: int
    num_owned_reduced: int

    def reduced_dofs(self, owned_blocks: np.ndarray, component: int) -> np.ndarray:
        """Global reduced dof indices of owned blocks (right-edge blocks are dropped)."""
        rb = self.reduced_block[owned_blocks]
        rb = rb[rb >= 0]
        return (self.bs * rb + component).astype(PETSc.IntType)

    def destroy(self) -> None:
        """Free the PETSc matrix."""
        self.P.destroy()


def bloch_map(V: dolfinx.fem.FunctionSpace, strip: StripMesh, k: float) -> BlochMap:
    """Assemble ``P`` for Bloch wavenumber ``k`` on ``strip`` (collective on ``strip.comm``).

    Args:
        V: A blocked Lagrange space (vector displacement) on ``strip.mesh``.
        strip: The strip (its length ``L`` sets the phase ``exp(-i k L)``).
        k: Wavenumber; ``k L`` a multiple of ``2 pi`` makes ``P`` plainly periodic.

    Returns:
        The :class:`BlochMap`.

    Raises:
        RuntimeError: (on every rank) if some right-edge node has no left partner at equal y.
    """
    comm = strip.comm
    imap = V.dofmap.index_map
    bs = V.dofmap.index_map_bs
    n_owned = imap.size_local
    x = V.tabulate_dof_coordinates()
    right = edge_dofs(strip, x, RIGHT)
    right = right[right < n_owned]
    left = edge_dofs(strip, x, LEFT)
    left = left[left < n_owned]

    keep = np.ones(n_owned, dtype=bool)
    keep[right] = False
    num_red = int(keep.sum())
    offset = comm.exscan(num_red, op=MPI.SUM) or 0  # None on rank 0
    reduced_block = np.full(n_owned, -1, dtype=np.int64)
    reduced_block[keep] = offset + np.arange(num_red)

    # Pair right-edge nodes with left-edge nodes of equal y, across ranks.
    mine = np.column_stack([x[left, 1], reduced_block[left].astype(float)])
    everyone = np.vstack(comm.allgather(mine))
    order = np.argsort(everyone[:, 0])
    ys, partners = everyone[order, 0], everyone[order, 1].astype(np.int64)
    yr = x[right, 1]
    pos = np.clip(np.searchsorted(ys, yr), 0, max(len(ys) - 1, 0))
    cand = np.stack([np.clip(pos - 1, 0, None), pos]) if len(ys) else np.zeros((2, 0), int)
    tol = 1e-9 * strip.height
    if len(yr):
        best = np.where(np.abs(ys[cand[0]] - yr) <= np.abs(ys[cand[1]] - yr), cand[0], cand[1])
        ok = np.abs(ys[best] - yr) < tol
        partner_block = partners[best]
    else:
        ok = np.ones(0, dtype=bool)
        partner_block = np.zeros(0, dtype=np.int64)
    failed = comm.allreduce(int((~ok).sum()), op=MPI.SUM)
    if failed:
        raise RuntimeError(f"Bloch map: {failed} right-edge node(s) have no left partner at equal y"
                           " (the mesh must have matching nodes on x = 0 and x = L)")

    phase = cmath.exp(-1j * k * strip.length)
    num_red_global = comm.allreduce(num_red, op=MPI.SUM)
    # One entry per owned row: its reduced column (own index, or the left partner's) and value.
    col_block = reduced_block.copy()
    col_block[right] = partner_block
    value = np.ones(n_owned, dtype=PETSc.ScalarType)
    value[right] = phase
    cols = (bs * np.repeat(col_block, bs) + np.tile(np.arange(bs), n_owned)).astype(PETSc.IntType)
    indptr = np.arange(bs * n_owned + 1, dtype=PETSc.IntType)
    P = PETSc.Mat().createAIJ(((bs * n_owned, bs * imap.size_global),
                               (bs * num_red, bs * num_red_global)),
                              csr=(indptr, cols, np.repeat(value, bs)), comm=comm)
    P.assemble()
    return BlochMap(P, phase, reduced_block, bs, num_red)


def reduce_matrix(A: PETSc.Mat, P: PETSc.Mat) -> PETSc.Mat:
    """Return ``P^H A P`` (a new matrix; ``A`` and ``P`` are left unchanged)."""
    AP = A.matMult(P)
    PH = P.copy()
    PH.conjugate()
    reduced = PH.transposeMatMult(AP)
    AP.destroy()
    PH.destroy()
    return reduced
