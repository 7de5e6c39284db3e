"""Analytic-vs-FE regression: cross-section FE eigenvalues are exact roots of det M = 0.

Velocity and stress tops, standard and generalized friction, several (beta, f, gamma, Delta, H),
branches n = 0, 1, 2, both partners, two k. Serially and under mpirun -n 2 (the mesh is then
distributed over both ranks: COMM_WORLD).
"""

import logging

import numpy as np
import pytest

from mpi4py import MPI

from analytic.numerics.branches import follow_branch, polish_root
from analytic.numerics.tracking import Branch, waveguide_lambda
from analytic.params import Params
from forms.models.cross_section import CrossSectionModel
from forms.solvers.slepc import PolynomialSolver

logging.disable(logging.INFO)

PARAMS = {
    "default-velocity": Params(),
    "default-stress": Params(bc="stress"),
    "soft-thick": Params(beta=0.3, f=0.5, gamma=1.5, Delta=0.4, H=1.2),
    "stiff-thin-stress": Params(beta=0.6, f=0.2, gamma=5.0, Delta=0.9, H=0.3, bc="stress"),
    "prakash-clifton": Params(alpha_pc=0.3),
    "generalized-stress": Params(alpha_pc=0.2, alpha_ld=0.1, bc="stress"),
    "weakening-ld": Params(Delta=-0.2, alpha_ld=0.15),
}
K_VALUES = (0.5, 2.0)
# Default discretisation (P3, cells from meshes.interval.default_cells for k <= 2, n <= 2).
# Largest relative error over all cases below, measured 2026-11-21 against an independent 4x4
# determinant: 2.3e-9 (n = 2, stress top, generalized); n = 0: <= 1e-11.
RTOL = 1e-8
_models: dict[str, CrossSectionModel] = {}


def _model(name: str) -> CrossSectionModel:
    if name not in _models:
        _models[name] = CrossSectionModel(MPI.COMM_WORLD, PARAMS[name], degree=3,
                                          k_max=max(K_VALUES), n_max=2)
    return _models[name]


@pytest.fixture(scope="module")
def solver():
    s = PolynomialSolver(MPI.COMM_WORLD, nev=1)
    yield s
    s.destroy()
    for m in _models.values():
        m.destroy()
    _models.clear()


@pytest.mark.parametrize("name", list(PARAMS))
@pytest.mark.parametrize("n", [0, 1, 2])
@pytest.mark.parametrize("sign", [-1, 1])
@pytest.mark.parametrize("k", K_VALUES)
def test_fe_eigenvalue_is_exact_root(solver, name, n, sign, k):
    p = PARAMS[name]
    model = _model(name)
    res = solver.solve(model.operator(k), waveguide_lambda(p, Branch(n, sign), k))
    assert res.pairs, res.reason
    lam = res.pairs[0].value
    assert res.pairs[0].residual < 1e-12  # backward error, measured <= 1e-15
    res.destroy()
    root = polish_root(p, k, lam)
    assert root.converged
    assert abs(root.value - lam) <= RTOL * abs(root.value)


@pytest.mark.parametrize("name", ["default-velocity", "default-stress", "generalized-stress"])
@pytest.mark.parametrize("n", [0, 1, 2])
@pytest.mark.parametrize("sign", [-1, 1])
def test_fe_follows_exact_branch_from_cutoff(solver, name, n, sign):
    """The exact branch (continued from the cut-off) has an FE eigenvalue on it."""
    p = PARAMS[name]
    r = follow_branch(p, n, sign, np.array(K_VALUES))
    assert np.all(r.ok)
    model = _model(name)
    for k, exact in zip(K_VALUES, r.Lambda, strict=True):
        res = solver.solve(model.operator(k), complex(exact))
        lam = res.pairs[0].value
        res.destroy()
        assert abs(lam - exact) <= RTOL * abs(exact)
