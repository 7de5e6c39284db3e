"""One branch of the cross-section model, solved in ``k`` by continuation, and its mode.

The 1D cross-section model (:class:`forms.models.cross_section.CrossSectionModel`) solved for single
eigenpairs, each near a target that follows the branch:

- :func:`follow_fe_branch`: ``Lambda(k)`` along a grid, each ``k`` solved near the linear
  extrapolation of the two previous eigenvalues (stays on the branch where a ``k``-wise target
  would jump);
- :func:`most_unstable_k`: the grid point of largest ``Re Lambda`` of that branch;
- :func:`cross_section_mode`: one eigenpair as a :class:`CrossSectionMode`, evaluable at any
  height and as ``u_hat(y) exp(-i k x)`` on a 2D mesh (for pictures without a strip solve).

Every shift goes through :func:`forms.solvers.slepc.shift_off` (a target may be an eigenvalue of the
same mesh). The 1D problem is tiny: by default each rank solves its own copy
(``MPI.COMM_SELF``) and gets the same numbers.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

import dolfinx.fem
import dolfinx.geometry
from mpi4py import MPI

from analytic.numerics.continuation import Path
from analytic.params import Params
from forms.models.cross_section import CrossSectionModel
from forms.solvers.slepc import PolynomialSolver, shift_off


@dataclass
class CrossSectionMode:
    """An eigenpair of the 1D cross-section model, evaluable at any height.

    Attributes:
        eigenvalue: ``Lambda``.
        residual: Relative residual of the 1D solve.
        k: Wavenumber.
        u_hat: The 1D field ``u_hat(y)`` (largest nodal entry 1, real).
    """

    eigenvalue: complex
    residual: float
    k: float
    u_hat: dolfinx.fem.Function

    def __call__(self, y: np.ndarray) -> np.ndarray:
        """``u_hat(y)`` at heights ``y`` (shape ``(n,)``), as an ``(n, 2)`` complex array."""
        msh = self.u_hat.function_space.mesh
        pts = np.zeros((len(y), 3))
        pts[:, 0] = y
        tree = dolfinx.geometry.BoundingBoxTree(msh, msh.topology.dim)
        cand = dolfinx.geometry.compute_collisions(tree, pts)
        cells = dolfinx.geometry.compute_colliding_cells(msh, cand, pts)
        first = np.array([cells.links(i)[0] if len(cells.links(i)) else -1
                          for i in range(len(y))], dtype=np.int32)
        if np.any(first < 0):
            raise ValueError("height outside the cross-section mesh")
        return self.u_hat.eval(pts, first).reshape(len(y), 2)

    def field(self, x: np.ndarray) -> np.ndarray:
        """``u_hat(y) exp(-i k x)`` at points ``x`` (shape ``(3, n)``, dolfinx interpolation)."""
        return (self(x[1]) * np.exp(-1j * self.k * x[0])[:, None]).T


def cross_section_mode(params: Params, k: float, target: complex, degree: int = 3,
                       cells: int | None = None, comm: MPI.Comm = MPI.COMM_SELF
                       ) -> CrossSectionMode | None:
    """Solve the cross-section model (:mod:`forms.models.cross_section`) near ``target`` at ``k``.

    Solved on ``comm`` (default: each rank its own copy; the 1D problem is tiny and the result
    the same everywhere). Returns ``None`` if nothing converged.
    """
    model = CrossSectionModel(comm, params, degree=degree, cells=cells, k_max=max(k, 1.0))
    solver = PolynomialSolver(comm, nev=1, prefix="xs_")
    try:
        # target may be an eigenvalue of this very mesh (from follow_fe_branch): shift off it
        res = solver.solve(model.operator(k), shift_off(target))
        if not res.pairs:
            return None
        pair = res.pairs[0]
        u = dolfinx.fem.Function(model.V)
        u.vector.array[:] = pair.vector.array
        u.x.scatter_forward()
        n = model.V.dofmap.index_map.size_local * model.V.dofmap.index_map_bs
        owned = u.x.array[:n]
        i = int(np.argmax(np.abs(owned)))
        cand = (float(abs(owned[i])), complex(owned[i]))
        best = max(comm.allgather(cand), key=lambda c: c[0])
        u.x.array[:] /= best[1]
        out = CrossSectionMode(pair.value, pair.residual, float(k), u)
        res.destroy()
        return out
    finally:
        solver.destroy()
        model.destroy()


def follow_fe_branch(params: Params, target_of_k: Callable[[float], complex], ks: np.ndarray,
                  degree: int = 3, comm: MPI.Comm = MPI.COMM_SELF) -> np.ndarray:
    """One branch of the cross-section model along ``ks``, by continuation.

    The first ``k`` is solved near ``target_of_k(k)`` (e.g. the waveguide estimate of
    :func:`analytic.numerics.tracking.waveguide_lambda`); every next one near the prediction of
    :meth:`analytic.numerics.continuation.Path.predict` (order 1: the linear extrapolation of
    the last two eigenvalues), so the branch is followed where a ``k``-wise target would jump
    to another one (it does for the stress top, ``0+``, near ``k = 1.4``). A ``k`` where
    nothing converged restarts the path.

    Returns:
        ``Lambda`` per ``k`` (``nan`` where nothing converged).
    """
    ks = np.asarray(ks, dtype=float)
    model = CrossSectionModel(comm, params, degree=degree, k_max=float(np.max(ks)))
    solver = PolynomialSolver(comm, nev=1, prefix="xs_")
    out = np.full(len(ks), complex("nan"))
    path: Path | None = None
    try:
        for i, k in enumerate(ks):
            target = target_of_k(float(k)) if path is None else path.predict(float(k), order=1)
            res = solver.solve(model.operator(float(k)), shift_off(target))
            if res.pairs:
                out[i] = res.pairs[0].value
                path = path or Path([], [])
                path.append(float(k), out[i])
            else:
                path = None
            res.destroy()
    finally:
        solver.destroy()
        model.destroy()
    return out


def most_unstable_k(params: Params, target_of_k: Callable[[float], complex], ks: np.ndarray,
                    degree: int = 3, comm: MPI.Comm = MPI.COMM_SELF) -> tuple[float, complex]:
    """Largest growth rate of one branch on a grid of ``k`` (:func:`follow_fe_branch`).

    Returns:
        ``(k, Lambda)`` at the grid point of largest ``Re Lambda``.
    """
    lam = follow_fe_branch(params, target_of_k, ks, degree, comm)
    ok = np.isfinite(lam)
    if not ok.any():
        raise RuntimeError("no converged cross-section eigenvalue on the k grid")
    i = int(np.nanargmax(np.where(ok, lam.real, np.nan)))
    return float(ks[i]), complex(lam[i])
