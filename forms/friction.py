"""Friction at the interface as a row operation, without a Lagrange multiplier.

docs/design.md sections 3 (the law) and 5.3 (the row operation).

With ``u_y = 0`` imposed strongly at ``y = 0``, the discrete reaction ``R = (K + L^2 M) u`` of an
interface node is the traction the substrate applies on the body: ``R_x = -sxy``,
``R_y = -syy``. The linearised friction law (docs/design.md section 3)::

    (1 + apc L) sxy + (f - ald L/(L+1)) syy - (1/gamma) L (L + Delta)/(L + 1) ux = 0

becomes, in the x-row of every interface node (``B`` is the interface "mass" of ``u_x``: the
nodal value in the 1D cross-section model, the consistent boundary mass ``int_G u_x w_x ds``
in the 2D strip)::

    rx(L)/d(L) R_x + ry(L)/d(L) R_y + ux(L)/d(L) (B u)_x = 0,
    rx = (1 + apc L)(L + 1),  ry = f (L + 1) - ald L,  ux = L (L + Delta)/gamma,  d = L + 1,

and the y-row of the interface node keeps ``u_y = 0``. All other rows are ``(K + L^2 M) u = 0``.

**Two deformable bodies (the general case).** With a substrate, the interface carries two
nodes per point, slider side ``(u_x1, u_y1)`` and substrate side ``(u_x2, u_y2)``. The model
(:mod:`forms.models.section`) eliminates ``u_y2 = u_y1`` and writes ``u_x1 = s + u_x2`` (``s`` the
slip) by a map ``P`` and reduces ``P^H A P``: the reduced row of ``u_y`` is then
``R_y1 + R_y2 = 0`` (normal traction continuous), the row of ``u_x2`` is ``R_x1 + R_x2 = 0``
(shear traction continuous) and the row of ``s`` is ``R_x1``. The friction law replaces the
row of ``s``::

    rx(L)/d(L) R_x1 + ry(L)/d(L) R_y1 + ux(L)/d(L) (B s)_x = 0,

with the reactions ``R_1`` of the *slider alone* (``reactions=`` below: the reduced matrices of
the slider's part of ``K`` and ``M``), and nothing is constrained at the interface. The rigid
substrate is the special case without substrate nodes: ``s = u_x1``, the slider is the whole
mesh (``reactions`` = the matrices themselves, the default) and the tie ``u_y2 = u_y1``
becomes the Dirichlet row ``u_y1 = 0``.

Two equivalent matrix forms of ``T(L) u = 0`` are produced by :func:`friction_operator`:

- ``"polynomial"``: multiply the x-rows by ``d(L)``: ``T(L) = sum_j L^j A_j`` with degree 3
  (4 with ``alpha_pc > 0``), for a SLEPc PEP. Clearing the denominator can add the spurious
  roots in :attr:`FrictionLaw.spurious` (``Lambda = -1``, ``-1/alpha_pc``): solvers drop them.
- ``"split"``: keep the rational functions: ``T(L) = sum_j L^j P_j + Q / d(L)`` (partial
  fractions, ``d`` is linear), for a SLEPc NEP in split form, without spurious roots.

Typical use (any model; the matrices may already be reduced, e.g. ``P^H A P``)::

    law = FrictionLaw.from_params(params)
    op = friction_operator(law, K, M, B, x_dofs, y_dofs, form="polynomial")
    apply_dirichlet(op.matrices, dirichlet_dofs, op.constant_term)
    ... solve with forms.solvers.slepc ...;  op.destroy()

``x_dofs[i]`` and ``y_dofs[i]`` are the global PETSc row indices of the ``u_x`` and ``u_y`` of
interface node ``i``; each rank passes the pairs whose rows it owns (both rows of a pair must
be owned by the same rank; dolfinx blocked dofmaps guarantee this). Dirichlet rows (``u_y = 0``
at the interface and any other strong condition) are applied afterwards by
:func:`apply_dirichlet`: 1 on the diagonal of the constant term only, so that these rows read
``u_d = 0`` for every ``Lambda``; the spurious eigenvalues they add are at infinity (``theta = 0``
under shift-and-invert), far from every finite target.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from petsc4py import PETSc

from analytic.law import FrictionLaw, ScalarFunction

__all__ = [
    "DIRICHLET_DIAGONAL", "FrictionLaw", "FrictionOperator", "ScalarFunction",
    "apply_dirichlet", "friction_operator",
]

#: Diagonal put in the Dirichlet rows of the constant term (:func:`apply_dirichlet`): these rows
#: read ``u_d = 0`` for every Lambda; their eigenvalues are at infinity. Every model uses this one.
DIRICHLET_DIAGONAL = 1.0


@dataclass
class FrictionOperator:
    """``T(L) = sum_i phi_i(L) matrices[i]`` with the scalar functions described by ``functions``.

    Attributes:
        matrices: PETSc matrices (owned: call :meth:`destroy`).
        functions: Per matrix, its scalar function (``L^j``, or ``1/(L + 1)`` in the split form).
        form: ``"polynomial"`` or ``"split"``.
        constant_term: Index of the ``L^0`` matrix (where Dirichlet rows get their diagonal).
        law: The friction law used.
        cleared_rows: Rows multiplied by the law's denominator (polynomial form; global over
            the communicator): ``det T = prod_s (L - s)^cleared_rows det T_rational`` up to a
            constant, ``s`` in ``law.spurious`` (0: not known).
    """

    matrices: list[PETSc.Mat]
    functions: list[ScalarFunction]
    form: str
    constant_term: int
    law: FrictionLaw
    cleared_rows: int = 0

    def scalars(self, lam: complex) -> np.ndarray:
        """Values ``phi_i(lam)`` of the scalar functions."""
        return np.array([fn(lam) for fn in self.functions], dtype=complex)

    def destroy(self) -> None:
        """Destroy the PETSc matrices."""
        for a in self.matrices:
            a.destroy()
        self.matrices = []


def _local_rows(mat: PETSc.Mat | None, row: int) -> dict[int, complex]:
    if mat is None:
        return {}
    cols, vals = mat.getRow(row)
    return dict(zip(cols.tolist(), vals.tolist(), strict=True))


def friction_operator(
    law: FrictionLaw,
    stiffness: PETSc.Mat,
    mass: PETSc.Mat | None,
    interface_mass: PETSc.Mat | None,
    x_dofs: np.ndarray,
    y_dofs: np.ndarray,
    form: str = "polynomial",
    reactions: tuple[PETSc.Mat, PETSc.Mat | None] | None = None,
) -> FrictionOperator:
    """Build ``T(L)`` from assembled (unconstrained) ``K``, ``M`` and interface mass ``B``.

    The operator is linear in ``(K, M, B)``: the cross-section model calls it once per power of
    ``k`` (``K0`` with ``M`` and ``B``; ``K1`` and ``K2`` alone with ``mass=None``,
    ``interface_mass=None``) and adds the results.

    Args:
        law: Friction law (:meth:`FrictionLaw.from_params`).
        stiffness: Assembled ``K`` (no Dirichlet rows applied; the interface y-rows must be the
            unconstrained ones: they give ``R_y``). Its nonzero pattern is used for every
            output matrix, and must contain those of ``mass`` and ``interface_mass``.
        mass: Assembled ``M`` or ``None``.
        interface_mass: Assembled ``B`` (nonzero only in interface x-rows/columns) or ``None``.
        x_dofs: Global row indices (owned by this rank) of the interface ``u_x``.
        y_dofs: Global row indices of the matching ``u_y`` (same order, same owner).
        form: ``"polynomial"`` (PEP) or ``"split"`` (NEP).
        reactions: ``(K_1, M_1)`` whose rows at ``x_dofs``/``y_dofs`` are the slider's
            reactions ``R_1 = (K_1 + L^2 M_1) u`` (two deformable bodies: the slider's part of
            ``K``, ``M``; their patterns within ``stiffness``'s). Default ``(stiffness, mass)``:
            the rigid substrate.

    Returns:
        The :class:`FrictionOperator`; apply Dirichlet rows with :func:`apply_dirichlet`.
    """
    src_k, src_m = (stiffness, mass) if reactions is None else reactions
    x_dofs = np.asarray(x_dofs, dtype=np.int64)
    y_dofs = np.asarray(y_dofs, dtype=np.int64)
    if x_dofs.shape != y_dofs.shape:
        raise ValueError("x_dofs and y_dofs must pair up")
    functions, x_terms, interior = _law_terms(law, form)
    for m in (stiffness, mass, interface_mass, src_k, src_m):
        if m is not None:
            m.assemble()
    # Rows needed for the x-row replacement (read before anything is modified).
    old_cols = {ix: _local_rows(stiffness, ix) for ix in x_dofs.tolist()}  # entries to clear
    rows = [_SourceRows(_local_rows(src_k, ix), _local_rows(src_m, ix), _local_rows(src_k, iy),
                        _local_rows(src_m, iy), _local_rows(interface_mass, ix))
            for ix, iy in zip(x_dofs.tolist(), y_dofs.tolist(), strict=True)]
    matrices = [_term_matrix(stiffness, mass, ck, cm, x_terms[t], x_dofs, rows, old_cols)
                for t, (ck, cm) in enumerate(interior)]
    cleared = stiffness.getComm().tompi4py().allreduce(len(x_dofs)) if form == "polynomial" else 0
    return FrictionOperator(
        matrices=matrices, functions=functions, form=form, constant_term=0, law=law,
        cleared_rows=cleared,
    )


@dataclass(frozen=True)
class _SourceRows:
    """The rows an interface x-row is rebuilt from.

    The reactions ``K``, ``M`` of its ``u_x`` (``kx``, ``mx``) and ``u_y`` (``ky``, ``my``) rows
    and the interface mass row ``bx``; the law's coefficients are keyed by these names.
    """

    kx: dict[int, complex]
    mx: dict[int, complex]
    ky: dict[int, complex]
    my: dict[int, complex]
    bx: dict[int, complex]

    def items(self) -> list[tuple[str, dict[int, complex]]]:
        """``(key, row)`` pairs with the law's keys (``"Kx"``, ``"Mx"``, ...)."""
        return [("Kx", self.kx), ("Mx", self.mx), ("Ky", self.ky), ("My", self.my),
                ("Bx", self.bx)]


def _law_terms(law: FrictionLaw, form: str
               ) -> tuple[list[ScalarFunction], list[dict[str, float]], list[tuple[float, float]]]:
    """Scalar functions, x-row coefficients per term and interior ``(K, M)`` weights per term."""
    deg = law.degree
    if form == "polynomial":
        xcoef = law.polynomial_coefficients()
        n_poly = deg + 1
        functions = [ScalarFunction.power(j) for j in range(n_poly)]
        x_terms = [{key: xcoef[key][j] for key in xcoef} for j in range(n_poly)]
    elif form == "split":
        pcoef, rcoef = law.split_coefficients()
        n_poly = max(deg, 3)  # interior rows need L^2; quotient degree <= deg - 1
        functions = [ScalarFunction.power(j) for j in range(n_poly)]
        functions.append(ScalarFunction(num=(1.0,), den=law.den))
        x_terms = [
            {key: (pcoef[key][j] if j < len(pcoef[key]) else 0.0) for key in pcoef}
            for j in range(n_poly)
        ]
        x_terms.append(dict(rcoef))
    else:
        raise ValueError(f"form = {form!r} is not 'polynomial' or 'split'")
    # Interior rows: K in L^0, M in L^2 (not multiplied by the denominator).
    interior = [(1.0 if j == 0 else 0.0, 1.0 if j == 2 else 0.0) for j in range(n_poly)]
    if form == "split":
        interior.append((0.0, 0.0))
    return functions, x_terms, interior


def _term_matrix(stiffness: PETSc.Mat, mass: PETSc.Mat | None, ck: float, cm: float,
                 coef: dict[str, float], x_dofs: np.ndarray, rows: list[_SourceRows],
                 old_cols: dict[int, dict[int, complex]]) -> PETSc.Mat:
    """One term's matrix: ``ck K + cm M``, the interface x-rows replaced by the law's row."""
    a = stiffness.duplicate(copy=False)
    a.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, True)
    if ck != 0.0:
        a.axpy(ck, stiffness, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
    if cm != 0.0 and mass is not None:
        a.axpy(cm, mass, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
    for ix, src in zip(x_dofs.tolist(), rows, strict=True):
        new: dict[int, complex] = {c: 0.0 for c in old_cols[ix]}
        for key, row in src.items():
            c = coef.get(key, 0.0)
            if c == 0.0:
                continue
            for col, v in row.items():
                if v != 0.0:  # structural zeros (a slider part) may lie outside the row
                    new[col] = new.get(col, 0.0) + c * v
        if new:
            cols = np.fromiter(new.keys(), dtype=PETSc.IntType, count=len(new))
            vals = np.fromiter(new.values(), dtype=PETSc.ScalarType, count=len(new))
            a.setValues([ix], cols, vals, addv=PETSc.InsertMode.INSERT_VALUES)
    a.assemble()
    return a


def apply_dirichlet(
    matrices: list[PETSc.Mat], dofs: np.ndarray, constant_term: int = 0,
    diagonal: float = DIRICHLET_DIAGONAL,
) -> None:
    """Impose ``u_d = 0`` on the global rows ``dofs`` (rows and columns zeroed, pattern kept).

    ``diagonal`` goes on the diagonal of ``matrices[constant_term]`` only (0 in the others), so
    each constrained row reads ``diagonal * u_d = 0`` for every ``Lambda``: no finite spurious
    eigenvalue; the spurious ones are at infinity (``theta = 0`` under shift-and-invert), far
    from every finite target. Pass the owned rows of each rank (collective call).
    """
    rows = np.asarray(dofs, dtype=PETSc.IntType)
    for i, a in enumerate(matrices):
        a.setOption(PETSc.Mat.Option.KEEP_NONZERO_PATTERN, True)
        a.zeroRowsColumns(rows, diag=diagonal if i == constant_term else 0.0)
