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
from forms.periodic import BlochMap, bloch_map, reduce_matrix
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


# --- Until forms.friction / forms.solvers (issue 3) land: thin stand-ins, to be replaced. ---
def _row(A: PETSc.Mat, i: int) -> tuple[np.ndarray, np.ndarray]:
    cols, vals = A.getRow(int(i))
    return np.asarray(cols, dtype=PETSc.IntType), np.asarray(vals)


def polynomial_matrices(problem: StripProblem) -> list[PETSc.Mat]:
    """Coefficients ``A_0 .. A_d`` of ``T(Lambda) = sum Lambda^j A_j`` with the interface rows.

    Interface ``x``-rows: ``a R_x + b R_y + c (M_Gamma u)_x`` with ``R = (K + L^2 M) u`` and
    ``a = (1 + alpha_pc L)(L + 1)``, ``b = f (L + 1) - alpha_ld L``, ``c = L (L + Delta)/gamma``.
    Interface ``y``-rows and Dirichlet rows: ``u_i = 0`` in ``A_0`` only (their eigenvalues sit
    at infinity, far from every finite target).
    """
    p = problem.params
    K, M, G = problem.stiffness, problem.mass, problem.interface_mass
    apc, ald, f, g, d = p.alpha_pc, p.alpha_ld, p.f, p.gamma, p.Delta
    # coefficient of Lambda^j: (K_x, K_y, M_x, M_y, G_x) weights
    weights = [
        (1.0, f, 0.0, 0.0, 0.0),
        (1.0 + apc, f - ald, 0.0, 0.0, d / g),
        (apc, 0.0, 1.0, f, 1.0 / g),
        (0.0, 0.0, 1.0 + apc, f - ald, 0.0),
        (0.0, 0.0, apc, 0.0, 0.0),
    ]
    degree = 4 if apc > 0 else 3
    new_rows: list[list[tuple[int, np.ndarray, np.ndarray]]] = [[] for _ in range(degree + 1)]
    for ix, iy in zip(problem.interface_x, problem.interface_y, strict=True):
        parts = [_row(K, ix), _row(K, iy), _row(M, ix), _row(M, iy), _row(G, ix)]
        for j in range(degree + 1):
            acc: dict[int, complex] = {}
            for wgt, (cols, vals) in zip(weights[j], parts, strict=True):
                if wgt == 0.0:
                    continue
                for c, v in zip(cols, vals, strict=True):
                    acc[int(c)] = acc.get(int(c), 0.0) + wgt * v
            cols = np.fromiter(acc.keys(), dtype=PETSc.IntType, count=len(acc))
            vals = np.fromiter(acc.values(), dtype=PETSc.ScalarType, count=len(acc))
            new_rows[j].append((int(ix), cols, vals))
    mats = []
    for j in range(degree + 1):
        A = K.copy() if j == 0 else M.copy() if j == 2 else K.duplicate(copy=False)
        A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
        constrained = np.concatenate([problem.interface_x, problem.interface_y,
                                      problem.dirichlet]).astype(PETSc.IntType)
        A.zeroRows(constrained, diag=1.0 if j == 0 else 0.0)
        A.zeroRows(problem.interface_x, diag=0.0)
        for ix, cols, vals in new_rows[j]:
            A.setValues([ix], cols, vals, addv=PETSc.InsertMode.INSERT_VALUES)
        A.assemble()
        mats.append(A)
    return mats


def solve_pep(matrices: list[PETSc.Mat], target: complex, nev: int = 4,
              prefix: str = "strip_") -> list[tuple[complex, PETSc.Vec, float]]:
    """TOAR + shift-and-invert (MUMPS) near ``target``; returns ``(Lambda, x, error)``."""
    from slepc4py import SLEPc

    pep = SLEPc.PEP().create(matrices[0].getComm())
    pep.setOptionsPrefix(prefix)
    pep.setOperators(matrices)
    pep.setType(SLEPc.PEP.Type.TOAR)
    pep.setProblemType(SLEPc.PEP.ProblemType.GENERAL)
    pep.setDimensions(nev=nev)
    pep.setTarget(target)
    pep.setWhichEigenpairs(SLEPc.PEP.Which.TARGET_MAGNITUDE)
    pep.setScale(SLEPc.PEP.Scale.SCALAR)
    st = pep.getST()
    st.setType(SLEPc.ST.Type.SINVERT)
    ksp = st.getKSP()
    ksp.setType("preonly")
    ksp.getPC().setType("lu")
    ksp.getPC().setFactorSolverType("mumps")
    pep.setFromOptions()
    pep.solve()
    out = []
    for i in range(pep.getConverged()):
        x = matrices[0].createVecRight()
        lam = pep.getEigenpair(i, x)
        out.append((complex(lam), x, pep.computeError(i, SLEPc.PEP.ErrorType.BACKWARD)))
    pep.destroy()
    return out


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
    """Scale ``u`` in place so that its largest nodal entry is ``1`` (real, positive)."""
    n = u.function_space.dofmap.index_map.size_local * u.function_space.dofmap.index_map_bs
    owned = u.x.array[:n]
    i = int(np.argmax(np.abs(owned))) if n else 0
    candidate = (float(abs(owned[i])) if n else 0.0, complex(owned[i]) if n else 0j)
    best = max(u.function_space.mesh.comm.allgather(candidate), key=lambda c: c[0])
    if best[0] > 0:
        u.x.array[:] /= best[1]
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


def interface_stresses(problem: StripProblem, u: dolfinx.fem.Function
                       ) -> dict[str, np.ndarray]:
    """Stress perturbations ``sxy``, ``syy`` and slip ``u_x`` along the interface ``y = 0``.

    The stress comes from the finite-element field, interpolated into discontinuous Lagrange of
    degree ``p - 1`` (exact for simplices); values of neighbouring cells at a shared point are
    averaged. Collective; every rank gets the same arrays, sorted by ``x``.

    Returns:
        ``{"x", "sxy", "syy"}`` at the stress points and ``{"x_slip", "ux"}`` at the
        displacement nodes (``x`` real, the rest complex).
    """
    V = problem.V
    msh = V.mesh
    degree = V.ufl_element().degree()
    W = dolfinx.fem.FunctionSpace(msh, ufl.VectorElement("DG", msh.ufl_cell(), degree - 1))
    s = sigma(u, problem.params.lame_lambda, 1.0)
    t = dolfinx.fem.Function(W)
    t.interpolate(dolfinx.fem.Expression(ufl.as_vector([s[0, 1], s[1, 1]]),
                                         W.element.interpolation_points()))
    tol = 1e-10 * problem.strip.height
    st = _edge_values(problem.comm, t, tol)
    sl = _edge_values(problem.comm, u, tol)
    return {"x": st[:, 0].real, "sxy": st[:, 1], "syy": st[:, 2],
            "x_slip": sl[:, 0].real, "ux": sl[:, 1]}


@dataclass
class StripMode:
    """One eigenpair of a strip problem.

    Attributes:
        eigenvalue: ``Lambda``.
        vector: Eigenvector in the operator numbering (reduced on a Bloch cell).
        error: Backward error reported by SLEPc.
        harmonics: :func:`harmonic_content` of the mode (Bloch cell only).
    """

    eigenvalue: complex
    vector: PETSc.Vec
    error: float
    harmonics: dict[int, float] | None = None

    @property
    def harmonic(self) -> int | None:
        """Dominant ``m`` (wavenumber ``k + 2 pi m / L``), or ``None`` on a finite block."""
        if not self.harmonics:
            return None
        return max(self.harmonics, key=self.harmonics.get)


def solve_modes(problem: StripProblem, target: complex, nev: int = 6,
                prefix: str = "strip_") -> list[StripMode]:
    """Eigenpairs nearest ``target``, with their harmonic content, sorted by distance.

    Collective. Destroy the vectors (``mode.vector.destroy()``) when done.
    """
    mats = polynomial_matrices(problem)
    try:
        pairs = solve_pep(mats, target, nev=nev, prefix=prefix)
    finally:
        for A in mats:
            A.destroy()
    modes = []
    for lam, x, err in pairs:
        harmonics = None
        if problem.k is not None:
            harmonics = harmonic_content(problem, problem.to_function(x))
        modes.append(StripMode(lam, x, err, harmonics))
    modes.sort(key=lambda m: abs(m.eigenvalue - target))
    return modes
