"""Cross-section model: the strip reduced to ``0 < y < H`` for fields ``u_hat(y) exp(-i k x)``.

docs/design.md section 5. A constructor of the one 1D model
(:class:`forms.models.section.SectionModel`): one homogeneous layer ``mu = rho = 1`` of height
``H`` on a rigid substrate, meshed by :func:`meshes.interval.interval_vertices` (graded towards
``y = 0``). ``d/dx -> -i k``, so ``K(k) = K0 + k K1 + k^2 K2``; ``T(L; k)`` is recombined per
``k`` from three friction operators of one pattern (:class:`forms.models.section.KOperator`).

Strong conditions: ``u_y(0) = 0``; ``bc = "velocity"``: ``u_x(H) = 0``. Natural: the rest
(``sigma_yy(H) = 0``, and ``sigma_xy(H) = 0`` for ``bc = "stress"``).
"""

from __future__ import annotations

import numpy as np

from mpi4py import MPI
from petsc4py import PETSc

from analytic.params import Params
from forms.models.section import KOperator, Layer, SectionModel, Stack, owned_global_rows
from meshes.interval import default_cells, grading_ratio, interval_vertices

__all__ = ["CrossSectionModel", "KOperator", "owned_global_rows"]


class CrossSectionModel(SectionModel):
    """Assembled cross-section operator ``T(Lambda; k)`` for one mesh and one parameter set.

    Args:
        comm: Communicator of the mesh and matrices (``MPI.COMM_SELF`` for one rank per k).
        params: Physical parameters (finite ``H``).
        degree: Lagrange degree ``p`` (vector ``P_p``).
        cells: Number of cells (default: :func:`meshes.interval.default_cells`).
        k_max: Largest wavenumber the mesh is made for (sets grading and default cells).
        n_max: Highest waveguide branch wanted (sets the default cells).
        ratio: ``h_max/h_min`` (default: :func:`meshes.interval.grading_ratio`).
        form: ``"polynomial"`` (PEP) or ``"split"`` (NEP), see :mod:`forms.friction`.

    Call :meth:`operator` for ``T`` at a given ``k`` (:meth:`k_blocks` for its three parts in
    powers of ``k``), and :meth:`destroy` at the end.
    """

    def __init__(
        self,
        comm: MPI.Comm,
        params: Params,
        degree: int = 3,
        cells: int | None = None,
        k_max: float = 1.0,
        n_max: int = 0,
        ratio: float | None = None,
        form: str = "polynomial",
    ) -> None:
        if not np.isfinite(params.H):
            raise ValueError("the cross-section model needs a finite H")
        self.cells = int(cells) if cells else default_cells(k_max, params.H, degree, n_max,
                                                             params.beta)
        self.ratio = float(ratio) if ratio else grading_ratio(k_max, params.H)
        slider = Layer(interval_vertices(params.H, self.cells, self.ratio), 1.0, 1.0,
                       params.beta)
        super().__init__(comm, Stack((slider,), (), top=params.bc), params, degree, form)

    def canonical(self, vec: PETSc.Vec) -> np.ndarray | None:
        """Gather a solution vector on rank 0 in a partition-independent order.

        Returns:
            On rank 0 of :attr:`comm`: array ``(n_nodes, 3)``: ``y``, ``u_x``, ``u_y`` (complex),
            sorted by ``y``; ``None`` on the other ranks.
        """
        arr = super().canonical(vec)
        return None if arr is None else arr[:, [0, 2, 3]]
