"""Periodic (Bloch) strip: the map P, the check value, the harmonics of a one-wavelength cell."""

import math
import sys

import numpy as np
import pytest

import slepc4py

slepc4py.init(sys.argv[:1])

from mpi4py import MPI  # noqa: E402

from analytic.params import ParameterError, Params  # noqa: E402
from forms.models.periodic import reduction_map  # noqa: E402
from forms.models.strip import build_strip_problem, solve_modes  # noqa: E402
from meshes.strip import LEFT, RIGHT, edge_dofs, strip_mesh, wavelength  # noqa: E402

# docs/design.md section 4: velocity top, paper defaults, H = 0.5, k = 1, branch 0- (exact root).
CHECK_VALUE = 0.2716852879456 - 6.5866951866228j
COMM = MPI.COMM_WORLD


@pytest.mark.parametrize("cell", ["triangle", "quadrilateral"])
@pytest.mark.parametrize("length", [wavelength(1.0), 1.3])
def test_bloch_map_pairs_edges(length, cell):
    """u = P x satisfies u(L, y) = exp(-i k L) u(0, y) at every node, across ranks."""
    import dolfinx.fem
    import ufl

    strip = strip_mesh(COMM, length, 0.5, 6, 5, grading=3.0, cell=cell)
    V = dolfinx.fem.FunctionSpace(strip.mesh, ufl.VectorElement("Lagrange",
                                                                strip.mesh.ufl_cell(), 2))
    k = 1.0
    bm = reduction_map(V, strip, k, np.ones(V.dofmap.index_map.size_local, dtype=int))
    x = bm.P.createVecRight()
    rng = np.random.default_rng(COMM.rank)
    x.setArray(rng.standard_normal(x.getLocalSize()) + 1j * rng.standard_normal(x.getLocalSize()))
    u = dolfinx.fem.Function(V)
    bm.P.mult(x, u.vector)
    u.x.scatter_forward()
    coords = V.tabulate_dof_coordinates()
    rows = []
    for which in (LEFT, RIGHT):
        b = edge_dofs(strip, coords, which)
        rows.append(np.column_stack([coords[b, 1], u.x.array.reshape(-1, 2)[b]]))
    left, right = (np.vstack(COMM.allgather(r)) for r in rows)
    left = left[np.argsort(left[:, 0].real)]
    right = right[np.argsort(right[:, 0].real)]
    _, il = np.unique(np.round(left[:, 0].real, 12), return_index=True)
    _, ir = np.unique(np.round(right[:, 0].real, 12), return_index=True)
    left, right = left[il], right[ir]
    assert len(left) == len(right) == 2 * 5 + 1
    np.testing.assert_allclose(right[:, 0].real, left[:, 0].real, atol=1e-12)
    np.testing.assert_allclose(right[:, 1:], np.exp(-1j * k * length) * left[:, 1:], atol=1e-12)
    if COMM.size > 1:  # the partition really separates partners (measured: all 22 rows on 2 ranks)
        lo, hi = bm.P.getOwnershipRangeColumn()
        r0, r1 = bm.P.getOwnershipRange()
        elsewhere = sum(int(np.any((c < lo) | (c >= hi)))
                        for c in (bm.P.getRow(r)[0] for r in range(r0, r1)))
        assert COMM.allreduce(elsewhere, op=MPI.SUM) > 0
    x.destroy()
    bm.destroy()


# Relative errors measured on 2026-11-21 (this machine, serial and mpirun -n 2 identical):
# P2, 32 x 8 cells on one wavelength (h_x = 2 pi/32, h_y = H/8, no grading): 7.04e-6;
# the same cells on a quarter-wavelength Bloch cell: 7.04e-6 (same element size, same mode);
# P3, 16 x 4 cells on one wavelength: 3.94e-7. P2 converges as h^4 (1.07e-4, 7.04e-6, 4.47e-7
# for 16x4, 32x8, 64x16), P3 as h^6.
@pytest.mark.parametrize("case", [
    dict(cells=(32, 8), degree=2, fraction=1.0, measured=7.04e-6),
    dict(cells=(8, 8), degree=2, fraction=0.25, measured=7.04e-6),
    dict(cells=(16, 4), degree=3, fraction=1.0, measured=3.94e-7),
])
def test_check_value_velocity_top(case):
    k, params = 1.0, Params()
    nx, ny = case["cells"]
    strip = strip_mesh(COMM, case["fraction"] * wavelength(k), params.H, nx, ny)
    problem = build_strip_problem(strip, params, k=k, degree=case["degree"])
    modes = solve_modes(problem, CHECK_VALUE, nev=3)
    lam = modes[0].eigenvalue
    assert modes[0].harmonic == 0
    rel = abs(lam - CHECK_VALUE) / abs(CHECK_VALUE)
    assert rel < 1.05 * case["measured"]
    assert rel > 0.5 * case["measured"]  # the discretisation error is what was measured
    for m in modes:
        m.vector.destroy()
    problem.destroy()


def test_one_wavelength_cell_holds_harmonics():
    """On a one-wavelength cell the k = 0 harmonic (m = -1) sits at the cut-off -i pi/(2 beta H)."""
    params = Params()
    strip = strip_mesh(COMM, wavelength(1.0), params.H, 32, 8)
    problem = build_strip_problem(strip, params, k=1.0, degree=2)
    cutoff = -1j * math.pi / (2 * params.beta * params.H)
    modes = solve_modes(problem, cutoff, nev=4)
    by_m = {m.harmonic: m for m in modes}
    assert set(by_m) >= {-1, 0}
    # measured 7.1e-7 (P2, 32 x 8): discretisation error of the k = 0 standing wave
    assert abs(by_m[-1].eigenvalue - cutoff) / abs(cutoff) < 1e-6
    assert by_m[-1].harmonics[-1] > 0.999
    assert abs(by_m[0].eigenvalue - CHECK_VALUE) / abs(CHECK_VALUE) < 1e-5
    for m in modes:
        m.vector.destroy()
    problem.destroy()


@pytest.mark.parametrize("bad", [dict(length=-1.0), dict(nx=0), dict(grading=0.5),
                                 dict(cell="hexagon")])
def test_bad_strip_arguments(bad):
    args = dict(length=1.0, height=0.5, nx=2, ny=2, grading=1.0, cell="triangle") | bad
    with pytest.raises(ParameterError):
        strip_mesh(COMM, **args)


# Relative differences strip vs cross-section (P3, 20 cells: itself within 6e-12 of the exact
# root), measured 2026-11-21 on a quarter-wavelength Bloch cell, k = 1, P2, no grading:
#   8 x 8 cells -> 16 x 16 cells: velocity 0- 7.04e-6 -> 4.47e-7, velocity 0+ 3.89e-6 -> 2.45e-7,
#   stress 0- 1.79e-5 -> 1.14e-6, stress 0+ 1.69e-5 -> 1.07e-6 (order 3.98, 3.99, 3.97, 3.97).
@pytest.mark.parametrize("bc,branch,measured", [
    ("velocity", "0-", 7.04e-6), ("velocity", "0+", 3.89e-6),
    ("stress", "0-", 1.79e-5), ("stress", "0+", 1.69e-5),
])
def test_strip_matches_cross_section(bc, branch, measured):
    import logging

    from analytic.numerics.tracking import Branch, waveguide_lambda
    from forms.models.cross_section import CrossSectionModel
    from forms.solvers.slepc import PolynomialSolver

    logging.disable(logging.INFO)
    k, params = 1.0, Params(bc=bc)
    model = CrossSectionModel(COMM, params, degree=3, cells=20)
    solver = PolynomialSolver(COMM, nev=1)
    res = solver.solve(model.operator(k), waveguide_lambda(params, Branch.parse(branch), k))
    reference = res.pairs[0].value
    res.destroy()
    solver.destroy()
    model.destroy()
    if bc == "velocity" and branch == "0-":
        assert abs(reference - CHECK_VALUE) < 1e-10 * abs(CHECK_VALUE)
    from analytic.numerics.branches import polish_root

    exact = polish_root(params, k, reference)
    assert exact.converged
    # cross-section (P3, 20 cells) vs exact root of det M: measured 2e-12 .. 6e-11
    assert abs(reference - exact.value) < 1e-10 * abs(exact.value)

    errors = []
    for n in (8, 16):
        strip = strip_mesh(COMM, 0.25 * wavelength(k), params.H, n, n)
        problem = build_strip_problem(strip, params, k=k, degree=2)
        modes = solve_modes(problem, reference, nev=2)
        mode = next(m for m in modes if m.harmonic == 0)
        errors.append(abs(mode.eigenvalue - reference) / abs(reference))
        # the same against the exact root (they differ by < 1e-10, well below these errors)
        assert abs(abs(mode.eigenvalue - exact.value) / abs(exact.value) - errors[-1]) < 1e-9
        assert mode.residual < 1e-10  # measured ~1e-15 .. 1e-13
        for m in modes:
            m.vector.destroy()
        problem.destroy()
    assert errors[0] < 1.05 * measured
    assert abs(np.log2(errors[0] / errors[1]) - 4.0) < 0.1  # P2: eigenvalue error ~ h^4


def test_follow_branch_stays_on_stress_top_0plus():
    """Continuation keeps the stress-top 0+ branch past k = 1.4, where a waveguide target jumps.

    The branch peaks at Re Lambda = 0.23294 near k = 1.545 (checked against the exact root).
    """
    from analytic.numerics.branches import polish_root
    from analytic.numerics.tracking import Branch, waveguide_lambda
    from forms.solvers.continuation import follow_fe_branch

    params = Params(bc="stress")
    b = Branch.parse("0+")
    ks = np.linspace(1.0, 2.0, 21)
    lam = follow_fe_branch(params, lambda k: waveguide_lambda(params, b, k), ks, comm=MPI.COMM_SELF)
    assert np.all(np.isfinite(lam))
    # smooth: neighbouring steps (dk = 0.05) move by less than 0.02 (measured max 0.016); a
    # k-wise waveguide target lands on -1.113 + 7.707i at k = 1.6 instead
    assert np.max(np.abs(np.diff(lam))) < 0.02
    i = int(np.argmax(lam.real))
    assert abs(ks[i] - 1.55) < 0.051
    exact = polish_root(params, ks[i], lam[i]).value
    assert abs(lam[i] - exact) < 1e-9 * abs(exact)  # measured 8.9e-11 (P3, default mesh)
    assert abs(exact.real - 0.23294) < 1e-4
