"""The 1D FE operator's fast paths equal the plain ones (forms.solvers.banded, condensed).

- ``BandedModel.operator(k)`` combines band stores precomputed once per model: the same band
  matrix, bit for bit, as building the operator from the scipy sum ``T0 + k T1 + k^2 T2``;
- ``BandedOperator.newton`` stops on the quadratic error estimate: the same value as iterating
  to ``maxit``;
- ``CondensedOperator`` sums the far modes as power series in ``z^2`` and ``CondensedModel``
  does the ``k``-independent work once: the same ``log det T`` and contour moments as summing
  every mode and condensing each ``k`` alone.
"""

from __future__ import annotations

import numpy as np
import pytest

from analytic import Params
from analytic.numerics.spectrum import Region
from forms.solvers import condensed
from forms.solvers.banded import BandedOperator, contour_rule
from forms.solvers.certified import CertifiedSolver
from forms.solvers.condensed import CondensedModel, CondensedOperator

pytestmark = pytest.mark.serial

REGION = Region(c_max=4.0)


@pytest.fixture(scope="module", params=["velocity", "stress"])
def solver(request: pytest.FixtureRequest) -> CertifiedSolver:
    s = CertifiedSolver(Params(bc=request.param), REGION, 4, 41, 1.0, 6.0, 1e-8,
                        check_exact=False)
    yield s
    s.destroy()


def _points(box: tuple, rng: np.random.Generator) -> np.ndarray:
    z = box[0] + (box[1] - box[0]) * rng.random(200) + 1j * (
        box[2] + (box[3] - box[2]) * rng.random(200))
    # the left edge, next to the poles of S at +-i sqrt(w_j) on the imaginary axis
    return np.concatenate([z, -0.01 + 1j * np.linspace(box[2], box[3], 200)])


@pytest.mark.parametrize("k", [0.05, 2.5, 6.0])
def test_band_stores_equal_the_sparse_sum(solver: CertifiedSolver, k: float) -> None:
    for model in solver.banded:
        fast = model.operator(k)
        a, b, c = model.parts
        plain = BandedOperator(mats=[x + k * y + (k * k) * z for x, y, z in zip(a, b, c,
                                                                               strict=True)],
                               functions=model.functions, perm=model.perm)
        assert (fast.kl, fast.ku) == (plain.kl, plain.ku)
        assert np.array_equal(fast._stack, plain._stack)
        for x, y in zip(fast.mats, plain.mats, strict=True):
            assert abs(x - y).max() == 0
        # Frobenius norms from the band entries: the same numbers summed in another order
        assert np.allclose(fast.norms, plain.norms, rtol=1e-14, atol=0)


@pytest.mark.parametrize("k", [0.05, 2.5, 6.0])
def test_products_and_combinations_on_the_pattern_equal_the_whole_band(solver: CertifiedSolver,
                                                                       k: float) -> None:
    """``_combine`` writes only the pattern's positions, ``_apply`` is one sparse product of
    the stacked ``A_i`` (session 34): the whole band's combination and the CSR products."""
    rng = np.random.default_rng(5)
    for model in solver.banded:
        op = model.operator(k)
        c = rng.standard_normal(len(op.functions)) + 1j * rng.standard_normal(len(op.functions))
        x = rng.standard_normal(op.n) + 1j * rng.standard_normal(op.n)
        whole = (c @ op._stack).reshape(op.n, op.rows).T
        plain = sum(ci * (m @ x) for ci, m in zip(c, op.mats, strict=True))
        # measured (P4/P5, 41 cells, both tops): the combination equal to 9.7e-17 relative
        # (bit for bit at most k: the same sums, another BLAS blocking), the product 1.7e-16
        assert np.max(np.abs(op._combine(c) - whole)) <= 1e-15 * np.max(np.abs(whole))
        assert np.max(np.abs(op._apply(c, x) - plain)) <= 1e-15 * np.max(np.abs(plain))


@pytest.mark.parametrize("seed", [0, 1])
def test_powers_and_derivatives_equal_numpys_bit_for_bit(solver: CertifiedSolver, seed: int
                                                         ) -> None:
    """``_phi_and_derivative`` in Python complex arithmetic: the bits of the vectorised form
    ``z ** j``, ``where(j > 0, j z ** max(j - 1, 0), 0)`` it replaced, on random points of the
    sweep's scale (``|Re| <= 3``, ``|Im| <= 2000``) and at small ``|z|``."""
    op = solver.banded[1].operator(2.5)
    j = op.power
    assert op.polynomial and set(j.tolist()) >= {0, 1, 2, 3}
    rng = np.random.default_rng(seed)
    zs = np.concatenate([3 * rng.standard_normal(2000) + 2000j * rng.uniform(-1, 1, 2000),
                         1e-3 * (rng.standard_normal(500) + 1j * rng.standard_normal(500))])
    for z in zs:
        value, derivative = op._phi_and_derivative(complex(z))
        assert np.array_equal(value, z ** j)
        assert np.array_equal(derivative, np.where(j > 0, j * z ** np.maximum(j - 1, 0), 0))


def test_newton_stops_at_the_value_of_a_full_run(solver: CertifiedSolver) -> None:
    k = 3.0
    op, fine = (b.operator(k) for b in solver.banded)
    box = REGION.box(solver.params, k)
    cond = CondensedOperator(op)
    n, t = cond.count_and_samples(box)
    found = op.moment_eigs(box, n, t, sums=cond.moment_sums)
    assert len(found) == n > 0
    for e in found:
        for bop, x0 in ((op, e.vector), (fine, None)):
            fast = bop.newton(e.value + 1e-6 * abs(e.value), x0)
            full = bop.newton(e.value + 1e-6 * abs(e.value), x0, tol=0.0, maxit=12)
            assert fast.converged and full.converged
            assert fast.iterations < full.iterations
            # measured (P4/P5, 41 cells, k = 3, both tops): at most 1.2e-12 relative, 2 steps
            # against 12; the full run's last steps wander at that level (rounding of z)
            assert abs(fast.value - full.value) <= 5e-12 * abs(full.value)


@pytest.mark.parametrize("k", [0.5, 6.0])
def test_far_mode_series_and_model_equal_every_mode_summed(
        solver: CertifiedSolver, k: float, monkeypatch: pytest.MonkeyPatch) -> None:
    op = solver.banded[0].operator(k)
    box = REGION.box(solver.params, k)
    series = CondensedOperator(op)
    model = CondensedModel(solver.banded[0]).operator(op, k)
    z = _points(box, np.random.default_rng(0))
    far = series._far(z)
    assert 0 < far.j0 < series.w.size and far.terms > 0  # the series is used
    monkeypatch.setattr(condensed, "SERIES_RATIOS", ())  # every mode summed one by one
    plain = CondensedOperator(op)
    assert plain._far(z).terms == 0
    ref = plain.log_det_many(z)
    for got in (series.log_det_many(z), model.log_det_many(z)):
        # measured (P4, 41 cells, k = 0.5 and 6, both tops): |d log|det|| <= 2.5e-13
        # relative, arg <= 7.4e-10 (the model: another eigh; the series alone: 8.2e-16 and
        # 2.8e-12), the level of tests/test_condensed.py against the banded LU
        assert np.max(np.abs(got.real - ref.real) / np.maximum(1.0, np.abs(ref.real))) < 1e-11
        assert np.max(np.abs(np.angle(np.exp(1j * (got.imag - ref.imag))))) < 1e-8
    n, t = plain.count_and_samples(box)
    assert series.count_and_samples(box)[0] == model.count_and_samples(box)[0] == n
    zz, w = contour_rule(box, t)
    weights = w[:, None] * ((zz - 0.5j * (box[2] + box[3])) / box[3])[:, None] ** np.arange(4)
    v = np.random.default_rng(1).standard_normal((op.n, 6)) + 0j
    ref = plain.moment_sums(zz, weights, v)
    for got in (series.moment_sums(zz, weights, v), model.moment_sums(zz, weights, v)):
        # measured: at most 1.3e-11 relative to the largest entry (the series alone 5.3e-13)
        assert np.abs(got - ref).max() < 1e-10 * np.abs(ref).max()
