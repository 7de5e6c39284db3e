"""The periodic (Bloch) strip and the finite block: 2D assembly and the eigen-solve.

Physics: :mod:`forms.elasticity` (the one definition of stress and strain), assembled on a 2D
mesh from :mod:`meshes.strip`:

- ``stiffness``: ``inner(sigma(u), eps(w)) dx``; ``mass``: ``inner(u, w) dx``;
- ``interface_mass``: ``inner(u_x, w_x) ds(INTERFACE)``, the consistent boundary mass that turns
  the friction law's pointwise ``u_x`` term into a nodal one matching the consistent reaction
  ``R = (K + Lambda^2 M) u`` (docs/design.md section 5).

On a Bloch cell (wavenumber ``k``), the three matrices are reduced by ``P^H A P``
(:mod:`forms.models.periodic`) *before* any row operation, so every reduced row is the row of a
node of
the periodic strip (a left-edge node carries its right-edge image). The interface rows and the
Dirichlet rows are then those of the reduced nodes on ``y = 0`` / ``y = H``, corners included.
On a finite block there is no ``P``; the lateral ends are free, rollers (``u_x = 0``) or clamped.

Related modules: :mod:`forms.mode_postprocessing` (what to do with a computed mode: harmonic
content, normalisation, interface stresses), :mod:`forms.solvers.continuation` (the 1D
model's branch followed in ``k``, and its mode evaluated on this mesh) and
:mod:`forms.solvers.spatial_stability` (spatial roots ``k(Lambda)`` and the long-block limit).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

import dolfinx.fem
import dolfinx.fem.petsc
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from analytic.params import ParameterError, Params
from forms.elasticity import mass_density, stiffness_density
from forms.friction import (
    DIRICHLET_DIAGONAL,
    FrictionLaw,
    FrictionOperator,
    apply_dirichlet,
    friction_operator,
)
from forms.mode_postprocessing import harmonic_content
from forms.models.periodic import BlochMap, bloch_map, reduce_matrix
from forms.solvers.slepc import PolynomialSolver
from meshes.strip import INTERFACE, LEFT, RIGHT, TOP, StripMesh, edge_dofs

LATERAL_CONDITIONS = ("free", "roller", "clamped")


@dataclass
class StripProblem:
    """Assembled operators of a strip (Bloch cell if ``k`` is set, else a finite block).

    Attributes:
        strip: The mesh.
        params: Physical parameters.
        k: Bloch wavenumber, or ``None`` for a finite block.
        V: The displacement space (vector Lagrange).
        bloch: The periodic map, or ``None`` for a finite block.
        stiffness: ``K`` (reduced by ``P`` on a Bloch cell).
        mass: ``M`` (reduced).
        interface_mass: ``M_Gamma`` for the ``u_x`` term of the friction law (reduced).
        interface_x: Owned global rows (operator numbering) of ``u_x`` at interface nodes.
        interface_y: Owned global rows of ``u_y`` at the same nodes, in the same order.
        dirichlet: Owned global rows of the other constrained dofs (top, lateral ends).
        timings: Wall times of the set-up steps (s).
        last_solve: SLEPc outcome and settings of the last :func:`solve_modes`.
    """

    strip: StripMesh
    params: Params
    k: float | None
    V: dolfinx.fem.FunctionSpace
    bloch: BlochMap | None
    stiffness: PETSc.Mat
    mass: PETSc.Mat
    interface_mass: PETSc.Mat
    interface_x: np.ndarray
    interface_y: np.ndarray
    dirichlet: np.ndarray
    timings: dict[str, float] = field(default_factory=dict)
    last_solve: dict[str, object] = field(default_factory=dict)

    @property
    def comm(self) -> MPI.Comm:
        """Communicator of the mesh and of every matrix."""
        return self.strip.comm

    def to_function(self, x: PETSc.Vec, name: str = "u") -> dolfinx.fem.Function:
        """Full displacement field ``u = P x`` (or ``x`` on a finite block), ghosts updated."""
        u = dolfinx.fem.Function(self.V, name=name)
        if self.bloch is None:
            x.copy(u.vector)
        else:
            self.bloch.P.mult(x, u.vector)
        u.x.scatter_forward()
        return u

    def destroy(self) -> None:
        """Free the PETSc objects."""
        for A in (self.stiffness, self.mass, self.interface_mass):
            A.destroy()
        if self.bloch is not None:
            self.bloch.destroy()


def _owned_blocks_on(strip: StripMesh, V: dolfinx.fem.FunctionSpace, which: int) -> np.ndarray:
    n_owned = V.dofmap.index_map.size_local
    blocks = edge_dofs(strip, V.tabulate_dof_coordinates(), which)
    return blocks[blocks < n_owned]


def build_strip_problem(strip: StripMesh, params: Params, k: float | None = None,
                        degree: int = 2, lateral: str = "free") -> StripProblem:
    """Assemble ``K``, ``M``, ``M_Gamma`` on the strip and locate the constrained rows.

    Args:
        strip: Mesh from :func:`meshes.strip.strip_mesh`.
        params: Physical parameters (``bc`` chooses the top condition).
        k: Bloch wavenumber (``u(L) = exp(-i k L) u(0)``); ``None`` for a finite block.
        degree: Lagrange degree.
        lateral: Finite block only: lateral ends ``free``, ``roller`` (``u_x = 0``) or
            ``clamped`` (``u = 0``).

    Returns:
        The assembled :class:`StripProblem` (collective; destroy it when done).
    """
    if degree < 1:
        raise ParameterError(f"degree = {degree} is outside its allowed range >= 1")
    if lateral not in LATERAL_CONDITIONS:
        raise ParameterError(f"lateral = {lateral!r} is not one of {', '.join(LATERAL_CONDITIONS)}")
    if k is not None and not (np.isfinite(k) and k > 0):
        raise ParameterError(f"k = {k!r} is outside its allowed range k > 0 (finite)")
    timings: dict[str, float] = {}
    t0 = MPI.Wtime()
    msh = strip.mesh
    V = dolfinx.fem.FunctionSpace(msh, ufl.VectorElement("Lagrange", msh.ufl_cell(), degree))
    u, w = ufl.TrialFunction(V), ufl.TestFunction(V)
    ds = ufl.Measure("ds", domain=msh, subdomain_data=strip.facet_tags)
    lmbda = params.lame_lambda
    forms = {
        "stiffness": stiffness_density(ufl.grad(u), ufl.grad(w), lmbda, 1.0) * ufl.dx,
        "mass": mass_density(u, w) * ufl.dx,
        "interface_mass": ufl.inner(u[0], w[0]) * ds(INTERFACE),
    }
    mats = {}
    for name, a in forms.items():
        A = dolfinx.fem.petsc.assemble_matrix(dolfinx.fem.form(a))
        A.assemble()
        mats[name] = A
    timings["assemble"] = MPI.Wtime() - t0

    bloch = None
    if k is not None:
        t0 = MPI.Wtime()
        bloch = bloch_map(V, strip, k)
        timings["bloch_map"] = MPI.Wtime() - t0
        t0 = MPI.Wtime()
        for name in mats:
            full = mats[name]
            mats[name] = reduce_matrix(full, bloch.P)
            full.destroy()
        timings["reduce"] = MPI.Wtime() - t0

        def rows(blocks: np.ndarray, c: int) -> np.ndarray:
            return bloch.reduced_dofs(blocks, c)
    else:
        start = V.dofmap.index_map.local_range[0]
        bs = V.dofmap.index_map_bs

        def rows(blocks: np.ndarray, c: int) -> np.ndarray:
            return (bs * (start + blocks) + c).astype(PETSc.IntType)

    interface = _owned_blocks_on(strip, V, INTERFACE)
    dirichlet = []
    if params.bc == "velocity":
        dirichlet.append(rows(_owned_blocks_on(strip, V, TOP), 0))
    if k is None and lateral != "free":
        ends = np.union1d(_owned_blocks_on(strip, V, LEFT), _owned_blocks_on(strip, V, RIGHT))
        ends = np.setdiff1d(ends, interface)  # interface nodes keep the friction row
        dirichlet.append(rows(ends, 0))
        if lateral == "clamped":
            dirichlet.append(rows(ends, 1))
    dirichlet_rows = np.unique(np.concatenate(dirichlet)) if dirichlet else np.zeros(0, int)
    ix, iy = rows(interface, 0), rows(interface, 1)
    # A node on the interface and on a Dirichlet edge keeps its friction row.
    dirichlet_rows = np.setdiff1d(dirichlet_rows, ix).astype(PETSc.IntType)
    return StripProblem(strip, params, k, V, bloch, mats["stiffness"], mats["mass"],
                        mats["interface_mass"], ix, iy, dirichlet_rows, timings)


def friction_operator_for(problem: StripProblem, form: str = "polynomial") -> FrictionOperator:
    """``T(Lambda)`` of the strip: :mod:`forms.friction` rows on the (reduced) ``K, M, M_Gamma``.

    Interface ``x``-rows carry the friction law (consistent reactions of the reduced nodes);
    interface ``y``-rows, the top ``x``-rows (``bc = "velocity"``) and the lateral rows of a
    finite block read ``u_d = 0`` through :func:`forms.friction.apply_dirichlet` (diagonal 1 in
    the constant term only: their eigenvalues sit at infinity, far from every finite target).
    """
    law = FrictionLaw.from_params(problem.params)
    op = friction_operator(law, problem.stiffness, problem.mass, problem.interface_mass,
                           problem.interface_x, problem.interface_y, form=form)
    rows = np.concatenate([problem.interface_y, problem.dirichlet]).astype(np.int64)
    apply_dirichlet(op.matrices, rows, op.constant_term, DIRICHLET_DIAGONAL)
    return op


@dataclass
class StripMode:
    """One eigenpair of a strip problem.

    Attributes:
        eigenvalue: ``Lambda``.
        vector: Eigenvector in the operator numbering (reduced on a Bloch cell).
        residual: Relative residual ``||T u|| / (sum |phi_j| ||A_j|| ||u||)``.
        harmonics: :func:`harmonic_content` of the mode (Bloch cell only).
    """

    eigenvalue: complex
    vector: PETSc.Vec
    residual: float
    harmonics: dict[int, float] | None = None

    @property
    def harmonic(self) -> int | None:
        """Dominant ``m`` (wavenumber ``k + 2 pi m / L``), or ``None`` on a finite block."""
        if not self.harmonics:
            return None
        return max(self.harmonics, key=self.harmonics.get)


def solve_modes(problem: StripProblem, target: complex, nev: int = 6,
                prefix: str = "strip_") -> list[StripMode]:
    """Eigenpairs nearest ``target`` (SLEPc PEP of :mod:`forms.solvers.slepc`), sorted by distance.

    Each mode carries its relative residual and, on a Bloch cell, its harmonic content.
    Collective. Destroy the vectors (``mode.vector.destroy()``) when done. SLEPc options with
    ``prefix`` (default ``-strip_pep_*``, ``-strip_st_*``) reach the solver.
    """
    op = friction_operator_for(problem)
    solver = PolynomialSolver(problem.comm, nev=nev, prefix=prefix)
    try:
        settings = solver.settings()
        result = solver.solve(op, target)
    finally:
        solver.destroy()
        op.destroy()
    modes = []
    for pair in result.pairs:
        harmonics = None
        if problem.k is not None:
            harmonics = harmonic_content(problem, problem.to_function(pair.vector))
        modes.append(StripMode(pair.value, pair.vector, pair.residual, harmonics))
    problem.last_solve = {"reason": result.reason, "converged": result.converged,
                          "iterations": result.iterations,
                          "dropped": [str(z) for z in result.dropped], **settings}
    return modes
