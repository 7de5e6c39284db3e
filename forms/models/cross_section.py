"""Cross-section model: the strip reduced to ``0 < y < H`` for fields ``u_hat(y) exp(-i k x)``.

docs/design.md section 5. ``d/dx -> -i k`` (:func:`forms.elasticity.cross_section_gradients`), so
the stiffness is ``K(k) = K0 + k K1 + k^2 K2``; the three blocks, the mass ``M`` and the
interface mass ``B`` are assembled once per mesh. The friction row operation
(:mod:`forms.friction`) is linear in ``K``, so it is applied once per block and ``T(L; k)`` is
recombined per ``k`` by two ``axpy`` of matrices that share one nonzero pattern.

Strong conditions: ``u_y(0) = 0``; ``bc = "velocity"``: ``u_x(H) = 0``. Natural: the rest
(``sigma_yy(H) = 0``, and ``sigma_xy(H) = 0`` for ``bc = "stress"``).
"""

from __future__ import annotations

import numpy as np

import dolfinx
import dolfinx.fem.petsc
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from analytic.params import Params
from forms.elasticity import cross_section_gradients, mass_density, stiffness_density
from forms.friction import (
    DIRICHLET_DIAGONAL,
    FrictionLaw,
    FrictionOperator,
    apply_dirichlet,
    friction_operator,
)
from meshes.interval import default_cells, grading_ratio, interval_mesh


def stiffness_blocks(
    u: ufl.Argument, w: ufl.Argument, lmbda: float, mu: float = 1.0
) -> tuple[ufl.Form, ufl.Form, ufl.Form]:
    """UFL forms ``(K0, K1, K2)`` of ``inner(sigma(u), eps(w))`` with ``grad = G0 + k G1``."""
    g0u, g1u = cross_section_gradients(u)
    g0w, g1w = cross_section_gradients(w)
    dx = ufl.dx
    k0 = stiffness_density(g0u, g0w, lmbda, mu) * dx
    k1 = (stiffness_density(g1u, g0w, lmbda, mu) + stiffness_density(g0u, g1w, lmbda, mu)) * dx
    k2 = stiffness_density(g1u, g1w, lmbda, mu) * dx
    return k0, k1, k2


def owned_global_rows(V: dolfinx.fem.FunctionSpace, local_dofs: np.ndarray) -> np.ndarray:
    """Unrolled local dof indices -> owned global PETSc rows (ghosts dropped).

    For the row arguments of :func:`forms.friction.friction_operator` and
    :func:`forms.friction.apply_dirichlet` on any 1D model (also :mod:`forms.models.pml`).
    """
    bs = V.dofmap.index_map_bs
    imap = V.dofmap.index_map
    local_dofs = np.asarray(local_dofs, dtype=np.int64)
    nodes, comps = local_dofs // bs, local_dofs % bs
    owned = nodes < imap.size_local
    return (bs * (imap.local_range[0] + nodes[owned]) + comps[owned]).astype(np.int64)


class KOperator:
    """``T(Lambda; k) = T0 + k T1 + k^2 T2`` combined from three k-blocks of one pattern.

    Shared by :class:`CrossSectionModel` and :class:`forms.models.layered.LayeredModel`: the blocks
    are checked to share one nonzero pattern once, and :meth:`at` recombines them in place by
    two ``axpy`` per matrix (skipped when ``k`` is unchanged).

    Args:
        parts: ``[T0, T1, T2]`` (owned: destroyed by :meth:`destroy`).
        law: The friction law of the blocks.
    """

    def __init__(self, parts: list[FrictionOperator], law: FrictionLaw) -> None:
        base = parts[0]
        for part in parts[1:]:
            for a, b in zip(base.matrices, part.matrices, strict=True):
                if a.getInfo()["nz_used"] != b.getInfo()["nz_used"]:
                    raise RuntimeError("k-blocks do not share one nonzero pattern")
        self.parts = parts
        self.op = FrictionOperator(
            matrices=[a.duplicate(copy=True) for a in base.matrices],
            functions=list(base.functions), form=base.form, constant_term=base.constant_term,
            law=law,
        )
        self._k: float | None = None

    def at(self, k: float) -> FrictionOperator:
        """The operator at ``k`` (its matrices are reused between calls)."""
        k = float(k)
        if self._k != k:
            same = PETSc.Mat.Structure.SAME_NONZERO_PATTERN
            for j, a in enumerate(self.op.matrices):
                self.parts[0].matrices[j].copy(a, structure=same)
                a.axpy(k, self.parts[1].matrices[j], structure=same)
                a.axpy(k * k, self.parts[2].matrices[j], structure=same)
            self._k = k
        return self.op

    def destroy(self) -> None:
        """Destroy the blocks and the combined operator."""
        for part in self.parts:
            part.destroy()
        self.op.destroy()


class CrossSectionModel:
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
        self.comm = comm
        self.params = params
        self.degree = int(degree)
        self.cells = int(cells) if cells else default_cells(k_max, params.H, degree, n_max,
                                                             params.beta)
        self.ratio = float(ratio) if ratio else grading_ratio(k_max, params.H)
        self.form = form
        self.law = FrictionLaw.from_params(params)
        self.mesh = interval_mesh(comm, params.H, self.cells, self.ratio)
        msh = self.mesh
        element = ufl.VectorElement("Lagrange", msh.ufl_cell(), self.degree, dim=2)
        self.V = V = dolfinx.fem.FunctionSpace(msh, element)

        fdim = 0
        bottom = dolfinx.mesh.locate_entities_boundary(msh, fdim, lambda x: np.isclose(x[0], 0.0))
        top = dolfinx.mesh.locate_entities_boundary(
            msh, fdim, lambda x: np.isclose(x[0], params.H)
        )
        tags = dolfinx.mesh.meshtags(msh, fdim, bottom, np.full(len(bottom), 1, dtype=np.int32))
        ds = ufl.Measure("ds", domain=msh, subdomain_data=tags)

        u, w = ufl.TrialFunction(V), ufl.TestFunction(V)
        lmbda = params.lame_lambda
        k_forms = stiffness_blocks(u, w, lmbda)
        m_form = mass_density(u, w) * ufl.dx
        b_form = ufl.inner(u[0], w[0]) * ds(1)
        assemble = dolfinx.fem.petsc.assemble_matrix
        blocks = [assemble(dolfinx.fem.form(a)) for a in k_forms]
        mass = assemble(dolfinx.fem.form(m_form))
        imass = assemble(dolfinx.fem.form(b_form))
        for a in (*blocks, mass, imass):
            a.assemble()

        x_bottom = owned_global_rows(V, dolfinx.fem.locate_dofs_topological(V.sub(0), fdim, bottom))
        y_bottom = owned_global_rows(V, dolfinx.fem.locate_dofs_topological(V.sub(1), fdim, bottom))
        dirichlet = [y_bottom]
        if params.bc == "velocity":
            dirichlet.append(
                owned_global_rows(V, dolfinx.fem.locate_dofs_topological(V.sub(0), fdim, top))
            )
        self.interface_x, self.interface_y = x_bottom, y_bottom
        self.dirichlet_dofs = np.concatenate(dirichlet)

        self._parts: list[FrictionOperator] = []
        for m, kb in enumerate(blocks):
            op = friction_operator(
                self.law, kb, mass if m == 0 else None, imass if m == 0 else None,
                x_bottom, y_bottom, form=form,
            )
            apply_dirichlet(op.matrices, self.dirichlet_dofs, op.constant_term,
                            DIRICHLET_DIAGONAL if m == 0 else 0.0)
            self._parts.append(op)
        for a in (*blocks, mass, imass):
            a.destroy()
        self._kop = KOperator(self._parts, self.law)
        # Dof coordinates of the owned nodes, for canonical (partition-independent) vectors.
        n_owned = V.dofmap.index_map.size_local
        self._y_owned = V.tabulate_dof_coordinates()[:n_owned, 0].copy()

    @property
    def size(self) -> int:
        """Global number of unknowns."""
        return self._kop.op.matrices[0].getSize()[0]

    def operator(self, k: float) -> FrictionOperator:
        """``T(Lambda; k)`` as a :class:`FrictionOperator` (matrices reused between calls)."""
        return self._kop.at(k)

    def k_blocks(self) -> tuple[FrictionOperator, FrictionOperator, FrictionOperator]:
        """The three parts of ``T(Lambda; k) = T0(Lambda) + k T1(Lambda) + k^2 T2(Lambda)``.

        Each ``Tm`` is a :class:`~forms.friction.FrictionOperator` in :attr:`form`: the friction
        row operation applied to the stiffness block ``Km`` (``T0`` also holds the mass ``M`` and
        the interface mass ``B``), with the Dirichlet rows applied (diagonal
        :data:`forms.friction.DIRICHLET_DIAGONAL` in the constant term of ``T0`` only). All
        matrices share one nonzero pattern. :meth:`operator` combines them for one ``k``; at
        fixed ``Lambda`` they give a quadratic eigenproblem in ``k``
        (:func:`forms.solvers.spatial_stability.spatial_roots`).

        Returns:
            ``(T0, T1, T2)``, owned by the model: read them, do not modify or destroy them.
        """
        t0, t1, t2 = self._parts
        return t0, t1, t2

    def canonical(self, vec: PETSc.Vec) -> np.ndarray | None:
        """Gather a solution vector on rank 0 in a partition-independent order.

        Returns:
            On rank 0 of :attr:`comm`: array ``(n_nodes, 3)``: ``y``, ``u_x``, ``u_y`` (complex),
            sorted by ``y``; ``None`` on the other ranks.
        """
        vals = vec.getArray(readonly=True).reshape(-1, 2)
        local = np.column_stack([self._y_owned.astype(complex), vals])
        parts = self.comm.gather(local, root=0)
        if self.comm.rank != 0:
            return None
        allv = np.concatenate(parts)
        return allv[np.argsort(allv[:, 0].real, kind="stable")]

    def destroy(self) -> None:
        """Destroy the PETSc matrices."""
        self._kop.destroy()
