"""The periodic (Bloch) strip and the finite block as polynomial eigenproblems.

Physics: :mod:`forms.elasticity` (the one definition of stress and strain), assembled on a 2D
mesh from :mod:`meshes.strip`:

- ``stiffness``: ``inner(sigma(u), eps(w)) dx``; ``mass``: ``inner(u, w) dx``;
- ``interface_mass``: ``inner(u_x, w_x) ds(INTERFACE)``, the consistent boundary mass that turns
  the friction law's pointwise ``u_x`` term into a nodal one matching the consistent reaction
  ``R = (K + Lambda^2 M) u`` (DESIGN.md section 5).

On a Bloch cell (wavenumber ``k``), the three matrices are reduced by ``P^H A P``
(:mod:`forms.periodic`) *before* any row operation, so every reduced row is the row of a node of
the periodic strip (a left-edge node carries its right-edge image). The interface rows and the
Dirichlet rows are then those of the reduced nodes on ``y = 0`` / ``y = H``, corners included.
On a finite block there is no ``P``; the lateral ends are free, rollers (``u_x = 0``) or clamped.
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
from forms.elasticity import mass_density, sigma, stiffness_density
from forms.friction import FrictionLaw, FrictionOperator, apply_dirichlet, friction_operator
from forms.periodic import BlochMap, bloch_map, reduce_matrix
from forms.solvers import PolynomialSolver
from meshes.strip import INTERFACE, LEFT, RIGHT, TOP, StripMesh, edge_dofs

LATERAL_CONDITIONS = ("free", "roller", "clamped")
#: Diagonal of the Dirichlet rows in the constant term (their eigenvalues are at infinity).
DIRICHLET_DIAGONAL = 1.0


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


# --- Post-processing of a mode: which wavenumber it carries, normalisation, interface stresses.
def _allgather_rows(comm: MPI.Comm, rows: np.ndarray) -> np.ndarray:
    return np.vstack(comm.allgather(rows))


def harmonic_content(problem: StripProblem, u: dolfinx.fem.Function, m_max: int | None = None
                     ) -> dict[int, float]:
    """Share of ``|u|^2`` carried by each wavenumber ``k + 2 pi m / L`` (``|m| <= m_max``).

    A Bloch cell of one wavelength also holds the modes of ``0, -k, 2k, ...`` (``m = -1, -2,
    1``); this tells them apart. Along every line ``y = const`` the dofs of the structured strip
    sit on a uniform grid in ``x`` (right edge excluded), where the discrete Fourier sums are
    orthogonal. Collective; the same dict on every rank.

    Args:
        problem: A Bloch problem (``problem.k`` set).
        u: A full field on ``problem.V``.
        m_max: Largest ``|m|``; default: all that a line of ``degree * nx`` points resolves.

    Returns:
        ``{m: fraction}``, fractions summing to at most 1.
    """
    if problem.k is None:
        raise ValueError("harmonic content needs a Bloch cell (k set)")
    strip, V = problem.strip, problem.V
    n_owned = V.dofmap.index_map.size_local
    bs = V.dofmap.index_map_bs
    x = V.tabulate_dof_coordinates()[:n_owned]
    keep = np.abs(x[:, 0] - strip.length) > 1e-10 * strip.length
    vals = u.x.array[: bs * n_owned].reshape(n_owned, bs)[keep]
    rows = np.column_stack([x[keep, 0], x[keep, 1], vals]).astype(complex)
    rows = _allgather_rows(problem.comm, rows)
    if m_max is None:
        m_max = max(1, (V.ufl_element().degree() * strip.nx - 1) // 2)
    xs, ys, vals = rows[:, 0].real, rows[:, 1].real, rows[:, 2:]
    keys = np.round(ys / strip.height, 9)
    total = float(np.sum(np.abs(vals) ** 2))
    content = {}
    for m in range(-m_max, m_max + 1):
        q = problem.k + 2.0 * np.pi * m / strip.length
        energy = 0.0
        for key in np.unique(keys):
            on = keys == key
            coef = (vals[on] * np.exp(1j * q * xs[on])[:, None]).sum(axis=0) / on.sum()
            energy += on.sum() * float(np.sum(np.abs(coef) ** 2))
        content[m] = energy / total if total > 0 else 0.0
    return content


def normalise(u: dolfinx.fem.Function) -> None:
    """Scale ``u`` in place: largest nodal ``|u|`` equal to 1, slip ``u_x`` real at the origin.

    The phase reference is the interface node at ``x = y = 0`` (if its ``u_x`` vanishes, the
    entry of largest modulus), so modes from different models or runs look alike. Collective.
    """
    V = u.function_space
    comm = V.mesh.comm
    n = V.dofmap.index_map.size_local
    bs = V.dofmap.index_map_bs
    vals = u.x.array[: bs * n].reshape(n, bs)
    x = V.tabulate_dof_coordinates()[:n]
    at_origin = np.flatnonzero(np.hypot(x[:, 0], x[:, 1]) < 1e-12)
    origin = complex(vals[at_origin[0], 0]) if len(at_origin) else 0j
    origin = comm.allreduce(origin, op=MPI.SUM) if comm.size > 1 else origin
    i = int(np.argmax(np.abs(vals[:, 0]))) if n else 0
    largest = (float(abs(vals[i, 0])), complex(vals[i, 0])) if n else (0.0, 0j)
    largest = max(comm.allgather(largest), key=lambda c: c[0])
    ref = origin if abs(origin) > 1e-8 * largest[0] else largest[1]
    amp = float(np.max(np.linalg.norm(vals, axis=1))) if n else 0.0
    amp = comm.allreduce(amp, op=MPI.MAX)
    if amp > 0 and ref != 0:
        u.x.array[:] *= (abs(ref) / ref) / amp
    u.x.scatter_forward()


def _edge_values(comm: MPI.Comm, f: dolfinx.fem.Function, tol: float) -> np.ndarray:
    """``(x, values...)`` of the owned dofs of ``f`` on ``y = 0``, gathered, averaged per x."""
    W = f.function_space
    n = W.dofmap.index_map.size_local
    bs = W.dofmap.index_map_bs
    xw = W.tabulate_dof_coordinates()[:n]
    on = np.flatnonzero(np.abs(xw[:, 1]) < tol)
    rows = np.column_stack([xw[on, 0], f.x.array[: bs * n].reshape(n, bs)[on]]).astype(complex)
    rows = _allgather_rows(comm, rows)
    xs, inverse = np.unique(np.round(rows[:, 0].real, 12), return_inverse=True)
    counts = np.bincount(inverse)
    out = [xs.astype(complex)]
    for c in range(1, rows.shape[1]):
        re = np.bincount(inverse, rows[:, c].real)
        im = np.bincount(inverse, rows[:, c].imag)
        out.append((re + 1j * im) / counts)
    return np.column_stack(out)


def interface_stresses(u: dolfinx.fem.Function, lame_lambda: float, height: float
                       ) -> dict[str, np.ndarray]:
    """Stress perturbations ``sxy``, ``syy`` and slip ``u_x`` along the interface ``y = 0``.

    The stress comes from the finite-element field ``u`` on the strip (any source: a strip
    eigenvector, or the cross-section mode interpolated), interpolated into discontinuous
    Lagrange of degree ``p - 1`` (exact on simplices); values of neighbouring cells at a shared
    point are averaged. Collective; every rank gets the same arrays, sorted by ``x``.

    Returns:
        ``{"x", "sxy", "syy"}`` at the stress points and ``{"x_slip", "ux"}`` at the
        displacement nodes (``x`` real, the rest complex).
    """
    V = u.function_space
    msh = V.mesh
    degree = V.ufl_element().degree()
    W = dolfinx.fem.FunctionSpace(msh, ufl.VectorElement("DG", msh.ufl_cell(), degree - 1))
    s = sigma(u, lame_lambda, 1.0)
    t = dolfinx.fem.Function(W)
    t.interpolate(dolfinx.fem.Expression(ufl.as_vector([s[0, 1], s[1, 1]]),
                                         W.element.interpolation_points()))
    tol = 1e-10 * height
    st = _edge_values(msh.comm, t, tol)
    sl = _edge_values(msh.comm, u, tol)
    return {"x": st[:, 0].real, "sxy": st[:, 1], "syy": st[:, 2],
            "x_slip": sl[:, 0].real, "ux": sl[:, 1]}


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
    """Eigenpairs nearest ``target`` (SLEPc PEP of :mod:`forms.solvers`), sorted by distance.

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


# --- The cross-section model's mode in real space (no strip solve), and its most unstable k.
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
        import dolfinx.geometry

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
    """Solve the cross-section model (:mod:`forms.cross_section`) near ``target`` at ``k``.

    Solved on ``comm`` (default: each rank its own copy; the 1D problem is tiny and the result
    the same everywhere). Returns ``None`` if nothing converged.
    """
    from forms.cross_section import CrossSectionModel

    model = CrossSectionModel(comm, params, degree=degree, cells=cells, k_max=max(k, 1.0))
    solver = PolynomialSolver(comm, nev=1, prefix="xs_")
    try:
        res = solver.solve(model.operator(k), target)
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


def most_unstable_k(params: Params, target_of_k, ks: np.ndarray, degree: int = 3,
                    comm: MPI.Comm = MPI.COMM_SELF) -> tuple[float, complex]:
    """Largest growth rate of one branch on a grid of ``k`` (cross-section model).

    Args:
        params: Physical parameters.
        target_of_k: ``k -> target`` (e.g. :func:`forms.tracking.waveguide_lambda` of a branch).
        ks: Wavenumbers (increasing).
        degree: Lagrange degree of the 1D model.
        comm: Communicator of the 1D solves.

    Returns:
        ``(k, Lambda)`` at the grid point of largest ``Re Lambda``.
    """
    from forms.cross_section import CrossSectionModel

    model = CrossSectionModel(comm, params, degree=degree, k_max=float(np.max(ks)))
    solver = PolynomialSolver(comm, nev=1, prefix="xs_")
    best: tuple[float, complex] | None = None
    try:
        for k in ks:
            res = solver.solve(model.operator(float(k)), target_of_k(float(k)))
            if res.pairs and (best is None or res.pairs[0].value.real > best[1].real):
                best = (float(k), res.pairs[0].value)
            res.destroy()
    finally:
        solver.destroy()
        model.destroy()
    if best is None:
        raise RuntimeError("no converged cross-section eigenvalue on the k grid")
    return best


# --- Spatial roots k(Lambda) and the long-block limit (Kulikovskii's condition).
def spatial_roots(model, lam: complex, target: complex, nev: int = 1) -> list[complex]:
    """Wavenumbers ``k`` (complex) with ``T(lam; k) u = 0``: a quadratic eigenproblem in ``k``.

    The cross-section operator is ``T(L; k) = T0(L) + k T1(L) + k^2 T2(L)`` with each ``Tj`` a
    polynomial in ``L`` (:class:`forms.cross_section.CrossSectionModel` keeps the three parts);
    at fixed ``lam`` this is a SLEPc PEP in ``k``, solved by shift-and-invert near ``target``.

    Args:
        model: A polynomial-form ``CrossSectionModel`` (its per-``k``-power parts are read).
        lam: Growth rate ``Lambda``.
        target: Shift for ``k``.
        nev: Number of roots wanted.

    Returns:
        The converged roots sorted by distance to ``target``.
    """
    from slepc4py import SLEPc

    same = PETSc.Mat.Structure.SAME_NONZERO_PATTERN
    coeffs = []
    for part in model._parts:  # T0, T1, T2: one FrictionOperator per power of k
        A = part.matrices[0].duplicate(copy=True)
        for i in range(1, len(part.matrices)):
            A.axpy(lam**i, part.matrices[i], structure=same)
        coeffs.append(A)
    pep = SLEPc.PEP().create(model.comm)
    pep.setOptionsPrefix("kroots_")
    pep.setOperators(coeffs)
    pep.setProblemType(SLEPc.PEP.ProblemType.GENERAL)
    pep.setDimensions(nev=nev)
    pep.setTolerances(tol=1e-12)
    pep.setTarget(target)
    pep.setWhichEigenpairs(SLEPc.PEP.Which.TARGET_MAGNITUDE)
    st = pep.getST()
    st.setType(SLEPc.ST.Type.SINVERT)
    st.getKSP().setType("preonly")
    st.getKSP().getPC().setType("lu")
    st.getKSP().getPC().setFactorSolverType("mumps")
    pep.setFromOptions()
    pep.solve()
    roots = [complex(pep.getEigenpair(i)) for i in range(pep.getConverged())]
    pep.destroy()
    for A in coeffs:
        A.destroy()
    return sorted(roots, key=lambda z: abs(z - target))


def kulikovskii_growth(model, omega: float, sigma0: float, k1: complex, k2: complex,
                       tol: float = 1e-10, max_it: int = 30) -> tuple[complex, complex, complex]:
    """Growth rate ``sigma`` at frequency ``omega`` where ``Im k1(Lambda) = Im k2(Lambda)``.

    Kulikovskii's condition: in a long finite domain, global modes built from two spatial
    waves ``k1, k2`` (reflected into each other at the ends) accumulate, as ``L -> infinity``,
    on the curve where both waves have the same spatial growth ``Im k``. Secant iteration on
    ``sigma`` with ``Lambda = sigma + i omega``; ``k1``, ``k2`` are followed by
    shift-and-invert from the previous values.

    Returns:
        ``(Lambda, k1, k2)`` at convergence.

    Raises:
        RuntimeError: If the iteration does not converge or a root is lost.
    """
    def gap(sigma: float) -> tuple[float, complex, complex]:
        lam = complex(sigma, omega)
        r1 = spatial_roots(model, lam, k1)
        r2 = spatial_roots(model, lam, k2)
        if not r1 or not r2:
            raise RuntimeError(f"spatial root lost at Lambda = {lam}")
        return r1[0].imag - r2[0].imag, r1[0], r2[0]

    s0, s1 = sigma0, sigma0 + 1e-3
    g0, k1, k2 = gap(s0)
    for _ in range(max_it):
        g1, k1, k2 = gap(s1)
        if abs(g1) < tol or g1 == g0:
            return complex(s1, omega), k1, k2
        s0, s1, g0 = s1, s1 - g1 * (s1 - s0) / (g1 - g0), g1
    raise RuntimeError("Kulikovskii iteration did not converge")


def kulikovskii_limit(params: Params, lam_block: complex, span: float = 0.15, points: int = 7
                      ) -> dict | None:
    """Long-block limit from the cross-section model alone (Kulikovskii's condition).

    At the block eigenvalue of the largest ``L``, the two spatial roots ``k1, k2`` with the
    closest ``Im k`` are taken as the wave pair the block's global mode is made of; the curve
    ``Im k1 = Im k2`` is then followed over ``omega`` in ``Im(lam_block) +- span`` and its
    largest growth rate found by a parabola through the best three points. Runs on one rank.
    """
    from forms.cross_section import CrossSectionModel

    model = CrossSectionModel(MPI.COMM_SELF, params, degree=3, k_max=8.0)
    try:
        roots = [r for r in spatial_roots(model, lam_block, 0.0, nev=16) if abs(r) < 10]
        if len(roots) < 2:
            return None
        k1, k2 = min(((a, b) for i, a in enumerate(roots) for b in roots[i + 1:]),
                     key=lambda ab: abs(ab[0].imag - ab[1].imag))
        curve = []
        for om in np.linspace(lam_block.imag - span, lam_block.imag + span, points):
            lam, a, b = kulikovskii_growth(model, float(om), lam_block.real, k1, k2)
            curve.append((lam, a, b))
    finally:
        model.destroy()
    sig = np.array([c[0].real for c in curve])
    om = np.array([c[0].imag for c in curve])
    j = int(np.clip(np.argmax(sig), 1, len(sig) - 2))
    a2, a1, a0 = np.polyfit(om[j - 1:j + 2], sig[j - 1:j + 2], 2)
    om_max = -a1 / (2 * a2) if a2 < 0 else om[j]
    return {"lambda": [float(np.polyval([a2, a1, a0], om_max)), float(om_max)],
            "k1_at_block": [k1.real, k1.imag], "k2_at_block": [k2.real, k2.imag],
            "curve": [[c[0].real, c[0].imag, c[1].real, c[1].imag, c[2].real, c[2].imag]
                      for c in curve]}
