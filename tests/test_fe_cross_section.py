"""Cross-section FE model: check value, convergence order, friction row operation, MPI.

Runs serially and under ``mpirun -n 2 python -m mpi4py -m pytest`` (the ``COMM_WORLD`` cases then
use a mesh distributed over both ranks; the ``COMM_SELF`` cases one mesh per rank).
"""

import logging

import numpy as np
import pytest

from mpi4py import MPI
from petsc4py import PETSc

from analytic.numerics.tracking import branches, normalized, waveguide_lambda
from analytic.params import Params
from forms.friction import FrictionLaw
from forms.models.cross_section import CrossSectionModel
from forms.solvers.slepc import PolynomialSolver, SplitSolver, relative_residual

logging.disable(logging.INFO)

# docs/design.md section 4: velocity top, paper defaults, H = 0.5, k = 1, branch 0-.
CHECK_VALUE = 0.2716852879456 - 6.5866951866228j
COMMS = {"world": MPI.COMM_WORLD, "self": MPI.COMM_SELF}


def _solve(model, k, target, nev=1, solver_cls=PolynomialSolver):
    solver = solver_cls(model.comm, nev=nev)
    res = solver.solve(model.operator(k), target)
    solver.destroy()
    return res


@pytest.mark.parametrize("comm_name", ["world", "self"])
def test_check_value_p3_20_cells(comm_name):
    model = CrossSectionModel(COMMS[comm_name], Params(), degree=3, cells=20)
    res = _solve(model, 1.0, -6.6j)
    lam = res.pairs[0].value
    # measured 5.9e-12 (serial and distributed over 2 ranks), 2026-11-21, P3 20 cells.
    assert abs(lam - CHECK_VALUE) / abs(CHECK_VALUE) < 2e-11
    # backward error of a converged SLEPc pair: measured ~2e-16.
    assert res.pairs[0].residual < 1e-13
    assert res.ok
    res.destroy()
    model.destroy()


@pytest.mark.parametrize("degree,cells", [(1, (40, 80)), (2, (8, 16)), (3, (4, 8))])
def test_convergence_order_is_2p(degree, cells):
    errs = []
    for c in cells:
        model = CrossSectionModel(MPI.COMM_SELF, Params(), degree=degree, cells=c)
        res = _solve(model, 1.0, CHECK_VALUE)
        errs.append(abs(res.pairs[0].value - CHECK_VALUE) / abs(CHECK_VALUE))
        res.destroy()
        model.destroy()
    order = np.log2(errs[0] / errs[1])
    # measured orders 2.00, 3.99, 5.97 on these meshes (uniform, 2026-11-21).
    assert abs(order - 2 * degree) < 0.15


@pytest.mark.parametrize("p", [Params(), Params(alpha_pc=0.3, alpha_ld=0.1)])
def test_split_and_polynomial_forms_agree(p):
    """x-rows of the polynomial form are d(L) times the split form; other rows equal."""
    law = FrictionLaw.from_params(p)
    rng = np.random.default_rng(1)
    m_poly = CrossSectionModel(MPI.COMM_SELF, p, degree=2, cells=6, form="polynomial")
    m_split = CrossSectionModel(MPI.COMM_SELF, p, degree=2, cells=6, form="split")
    op_p, op_s = m_poly.operator(1.3), m_split.operator(1.3)
    x = op_p.matrices[0].createVecRight()
    x.setArray(rng.normal(size=x.getLocalSize()) + 1j * rng.normal(size=x.getLocalSize()))
    for lam in (0.3 - 2.0j, -0.7 + 5.1j):
        yp, ys, tmp = x.duplicate(), x.duplicate(), x.duplicate()
        yp.set(0.0)
        ys.set(0.0)
        for c, a in zip(op_p.scalars(lam), op_p.matrices, strict=True):
            a.mult(x, tmp)
            yp.axpy(c, tmp)
        for c, a in zip(op_s.scalars(lam), op_s.matrices, strict=True):
            a.mult(x, tmp)
            ys.axpy(c, tmp)
        d = np.polynomial.polynomial.polyval(lam, law.den)
        ap, as_ = yp.getArray().copy(), ys.getArray().copy()
        ix = m_poly.interface_x
        as_[ix] *= d
        assert np.allclose(ap, as_, rtol=1e-12, atol=1e-12 * np.abs(ap).max())
        for v in (yp, ys, tmp):
            v.destroy()
    x.destroy()
    m_poly.destroy()
    m_split.destroy()


def test_friction_law_coefficients():
    p = Params(f=0.4, gamma=2.0, Delta=-0.3, alpha_pc=0.25, alpha_ld=0.1)
    law = FrictionLaw.from_params(p)
    assert law.degree == 4
    assert FrictionLaw.from_params(Params()).degree == 3
    lam = 0.37 - 1.9j
    mult = law.multipliers(lam)
    # docs/design.md section 3, in reactions R = -traction.
    assert np.isclose(mult["Kx"], 1 + p.alpha_pc * lam)
    assert np.isclose(mult["Ky"], p.f - p.alpha_ld * lam / (lam + 1))
    assert np.isclose(mult["Bx"], lam * (lam + p.Delta) / (p.gamma * (lam + 1)))
    poly, rat = law.split_coefficients()
    for key, num in law.x_row_numerators().items():
        split_val = np.polynomial.polynomial.polyval(lam, poly[key]) + rat[key] / (lam + 1)
        assert np.isclose(split_val, np.polynomial.polynomial.polyval(lam, num) / (lam + 1))
    assert law.is_spurious(-1.0 + 1e-9j) and law.is_spurious(-4.0)
    assert not law.is_spurious(-1.0 + 1e-3j)


def test_distributed_and_serial_meshes_agree():
    """Same eigenpair on a mesh over COMM_WORLD and over COMM_SELF (canonical vectors)."""
    out = {}
    for name, comm in COMMS.items():
        model = CrossSectionModel(comm, Params(bc="stress"), degree=3, cells=16)
        res = _solve(model, 2.0, waveguide_lambda(model.params, branches(1)[0], 2.0))
        vec = model.canonical(res.pairs[0].vector)
        out[name] = (res.pairs[0].value, vec)
        res.destroy()
        model.destroy()
    if MPI.COMM_WORLD.rank == 0:
        (lw, vw), (ls, vs) = out["world"], out["self"]
        # measured |difference| 2e-14 (2 ranks), 2026-11-21.
        assert abs(lw - ls) < 1e-11 * abs(ls)
        assert np.allclose(vw[:, 0].real, vs[:, 0].real)
        overlap = abs(np.vdot(normalized(vw[:, 1:]), normalized(vs[:, 1:])))
        assert overlap > 1 - 1e-10


def test_nep_split_form_matches_pep():
    p = Params(alpha_ld=0.2)
    lam = {}
    for form, cls in (("polynomial", PolynomialSolver), ("split", SplitSolver)):
        model = CrossSectionModel(MPI.COMM_SELF, p, degree=3, cells=16, form=form)
        res = _solve(model, 1.0, -6.6j, nev=1, solver_cls=cls)
        lam[form] = res.pairs[0].value
        assert res.pairs[0].residual < 1e-13  # measured ~2e-17 (NEP), ~2e-16 (PEP)
        res.destroy()
        model.destroy()
    # same discretisation, different algebra: measured difference 1e-14, 2026-11-21.
    assert abs(lam["polynomial"] - lam["split"]) < 1e-11 * abs(lam["split"])


def test_relative_residual_detects_a_wrong_eigenvalue():
    model = CrossSectionModel(MPI.COMM_SELF, Params(), degree=2, cells=8)
    op = model.operator(1.0)
    res = _solve(model, 1.0, -6.6j)
    good = res.pairs[0]
    bad = relative_residual(op, good.value + 1e-3, good.vector)
    # a shift of 1e-3 gives a backward error of 2.4e-7 (measured), a converged pair ~1e-16.
    assert good.residual < 1e-13 and bad > 1e-8
    assert isinstance(good.vector, PETSc.Vec)
    res.destroy()
    model.destroy()


def test_spurious_root_of_cleared_denominator_is_dropped():
    """Delta = 1 makes the x-row vanish at Lambda = -1: the PEP finds -1, the solver drops it."""
    model = CrossSectionModel(MPI.COMM_SELF, Params(Delta=1.0), degree=2, cells=8)
    res = _solve(model, 1.0, -1.0 + 0.01j, nev=3)
    assert len(res.dropped) == 1 and abs(res.dropped[0] + 1.0) < 1e-10
    assert all(abs(p.value + 1.0) > 1e-3 for p in res.pairs)
    res.destroy()
    model.destroy()


def test_one_solver_reused_for_operators_of_different_degree():
    """PEP degree 3 -> 4 -> 3 with one solver object (SLEPc needs a reset in between)."""
    solver = PolynomialSolver(MPI.COMM_SELF, nev=1)
    values = []
    for p in (Params(), Params(alpha_pc=0.3), Params()):
        model = CrossSectionModel(MPI.COMM_SELF, p, degree=3, cells=12)
        for _ in range(2):
            res = solver.solve(model.operator(1.0), -6.6j)
            values.append(res.pairs[0].value)
            res.destroy()
        model.destroy()
    solver.destroy()
    assert values[0] == pytest.approx(values[4], rel=1e-12)
    assert abs(values[2] - values[0]) > 1e-3  # alpha_pc changes the root
