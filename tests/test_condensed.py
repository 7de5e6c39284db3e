"""The condensed ``log det T_h`` equals the banded one; counts and eigenvalues agree."""

from __future__ import annotations

import numpy as np
import pytest

from analytic import Params
from analytic.numerics.spectrum import Region
from forms.solvers.certified import CertifiedSolver
from forms.solvers.condensed import CondensedModel, CondensedOperator

pytestmark = pytest.mark.serial

REGION = Region(c_max=4.0)


def _operator(bc: str, k: float) -> tuple:
    p = Params(bc=bc)
    s = CertifiedSolver(p, REGION, 4, 41, 1.0, 6.0, 1e-8, check_exact=False)
    return s.banded[0].operator(k), REGION.box(p, k)


@pytest.mark.parametrize("bc", ["velocity", "stress"])
def test_log_det_matches_banded(bc: str) -> None:
    op, box = _operator(bc, 3.0)
    cond = CondensedOperator(op)
    rng = np.random.default_rng(0)
    z = box[0] + (box[1] - box[0]) * rng.random(200) + 1j * (
        box[2] + (box[3] - box[2]) * rng.random(200))
    # the left edge, next to the poles of S at +-i sqrt(w_j) on the imaginary axis
    z = np.concatenate([z, -0.01 + 1j * np.linspace(box[2], box[3], 200)])
    a, b = op.log_det_many(z), cond.log_det_many(z)
    # measured (P4, 41 cells, k = 0.5 and 3): |d log|det|| <= 9e-13 relative, arg <= 9e-10
    assert np.max(np.abs(a.real - b.real) / np.maximum(1.0, np.abs(a.real))) < 1e-11
    assert np.max(np.abs(np.angle(np.exp(1j * (a.imag - b.imag))))) < 1e-8


@pytest.mark.parametrize("bc", ["velocity", "stress"])
@pytest.mark.parametrize("k", [0.5, 3.0])
def test_count_and_eigenvalues_match_banded(bc: str, k: float) -> None:
    op, box = _operator(bc, k)
    cond = CondensedOperator(op)
    n_b, t_b = op.count_and_samples(box)
    n_c, t_c = cond.count_and_samples(box)
    assert n_c == n_b
    found = op.moment_eigs(box, n_c, t_c, sums=cond.moment_sums)
    assert len(found) == n_c
    ref = np.sort_complex(np.array([e.value for e in op.moment_eigs(box, n_b, t_b)]))
    vals = np.sort_complex(np.array([e.value for e in found]))
    # both Newton-polished on the same banded T: measured differences <= 3e-12
    assert np.max(np.abs(vals - ref)) < 1e-10 * np.max(np.abs(ref))


@pytest.mark.parametrize("bc", ["velocity", "stress"])
def test_real_banded_decomposition_equals_the_complex_one(bc: str, monkeypatch) -> None:
    """The interior pencil is made real by a diagonal phase scaling (the real, banded
    reduction is taken) and gives the log det of the complex ``eigh(K, M)``."""
    from forms.solvers import condensed

    op, box = _operator(bc, 3.0)
    k_ii = CondensedOperator(op)
    b = np.zeros(op.n, dtype=bool)
    b[k_ii.b_idx] = True
    ii = np.flatnonzero(~b)
    powers = [fn.power_index for fn in op.functions]
    kmat = op.mats[powers.index(0)].tocsr()[ii][:, ii].toarray()
    mmat = op.mats[powers.index(2)].tocsr()[ii][:, ii].toarray()
    assert condensed._real_phases(kmat, mmat) is not None
    monkeypatch.setattr(condensed, "_real_phases", lambda k, m: None)
    ref = CondensedOperator(op)
    z = -0.01 + 1j * np.linspace(box[2], box[3], 300)
    a, c = k_ii.log_det_many(z), ref.log_det_many(z)
    # measured (41 cells, k = 3, left edge): |d log|det|| <= 7.8e-13 relative, arg <= 2.0e-9
    # (stress top; velocity 7.6e-14, 8.9e-11), the same level as against the banded LU above
    assert np.max(np.abs(a.real - c.real) / np.maximum(1.0, np.abs(c.real))) < 1e-11
    assert np.max(np.abs(np.angle(np.exp(1j * (a.imag - c.imag))))) < 1e-8
    assert np.max(np.abs(np.sort(k_ii.w.real) - np.sort(ref.w.real))) \
        < 1e-12 * np.max(np.abs(ref.w))


@pytest.mark.parametrize("bc", ["velocity", "stress"])
def test_above_dense_max_the_solver_counts_banded(bc: str, monkeypatch) -> None:
    """Above ``DENSE_MAX`` the certified solve takes the banded count (no dense matrix) and gives
    the same count and eigenvalues as the condensed one."""
    from forms.solvers import condensed

    p, k = Params(bc=bc), 3.0
    dense = CertifiedSolver(p, REGION, 4, 41, 1.0, 6.0, 1e-8, check_exact=False)
    ref = dense.solve(k)
    assert dense._condensed_model() is not None
    monkeypatch.setattr(condensed, "DENSE_MAX", dense.unknowns // 2)
    with pytest.raises(NotImplementedError, match="DENSE_MAX"):
        CondensedOperator(dense.banded[0].operator(k))
    banded = CertifiedSolver(p, REGION, 4, 41, 1.0, 6.0, 1e-8, check_exact=False)
    got = banded.solve(k)
    assert banded._condensed_model() is None
    assert ref.closed and got.closed and got.n_fe == ref.n_fe == len(got.rows)

    def values(r):
        return np.sort_complex(np.array([complex(x["re_lambda"], x["im_lambda"])
                                         for x in r.rows]))

    # both Newton-polished on the same banded T (test above: differences <= 3e-12)
    assert np.max(np.abs(values(got) - values(ref))) < 1e-10 * np.max(np.abs(values(ref)))


def _sweep_form(bc: str, k: float) -> tuple:
    """The banded operator at ``k``, its condensed form as the sweep makes it (one
    ``CondensedModel`` per mesh), the region's box, and its eigenvalues by the banded path
    (moments, each Newton-polished on ``T_h``)."""
    p = Params(bc=bc)
    s = CertifiedSolver(p, REGION, 4, 41, 1.0, 6.0, 1e-8, check_exact=False)
    op = s.banded[0].operator(k)
    cond = CondensedModel(s.banded[0]).operator(op, k)
    box = REGION.box(p, k)
    n, t = cond.count_and_samples(box)
    ref = np.array([e.value for e in op.moment_eigs(box, n, t, sums=cond.moment_sums)])
    assert ref.size == n > 0
    return op, cond, box, ref


@pytest.mark.parametrize("bc", ["velocity", "stress"])
@pytest.mark.parametrize("k", [0.5, 3.0])
def test_condensed_newton_and_its_rayleigh_step_give_the_banded_values(bc: str, k: float
                                                                      ) -> None:
    """Newton on ``det S`` from every start at once, the null vectors on both sides, one
    two-sided Rayleigh step on ``T_h``: the banded Newton's values (certified._polisher)."""
    op, cond, _, ref = _sweep_form(bc, k)
    rng = np.random.default_rng(3)
    start = ref * (1 + 1e-3 * (rng.standard_normal(ref.size) + 1j * rng.standard_normal(
        ref.size)))
    z, conv, its, _ = cond.newton_many(start)
    assert conv.all() and its.max() <= 8
    x, y = cond.null_vector_pairs(z)
    left = []
    for j in range(z.size):  # y is T(z)^H's null vector: ||T^H y|| / (||T|| ||y||)
        phi = op._phi_and_derivative(z[j])[0]
        ty = sum(np.conj(c) * (m.conj().T @ y[:, j]) for c, m in zip(phi, op.mats, strict=True))
        left.append(np.linalg.norm(ty) / (np.sum(np.abs(phi) * op.norms)
                                          * np.linalg.norm(y[:, j])))
    zr, res = op.rayleigh_step(z, x, y)
    # the batched residuals are residual()'s: at this rounding level (1e-16) they differ in
    # the summation order only, by at most 1.3e-20 (measured)
    assert np.allclose(res, [op._residual(zr[j], x[:, j]) for j in range(z.size)], rtol=0,
                       atol=1e-18)
    # measured (P4, 41 cells, both tops, k = 0.5 and 3): ||T^H y|| <= 1.7e-16, residuals
    # <= 1.5e-16, values within 1.1e-12 of the banded Newton's (Newton on det S alone: 5.8e-12)
    assert max(left) < 1e-15
    assert res.max() < 1e-15
    assert np.max(np.abs(zr - ref) / np.abs(ref)) < 1e-11


@pytest.mark.parametrize("bc", ["velocity", "stress"])
@pytest.mark.parametrize("k", [0.5, 3.0])
def test_the_counts_power_sums_are_the_eigenvalues(bc: str, k: float) -> None:
    """``CondensedOperator.power_sums`` from the count's own samples (missing_roots' input)."""
    _, cond, box, ref = _sweep_form(bc, k)
    sums, c, r = cond.power_sums(box, ref.size, 3)
    u = (ref - c) / r
    err = np.abs(sums - np.array([np.sum(u ** p) for p in (1, 2, 3)]))
    # measured (P4, 41 cells, both tops, k = 0.5 and 3, 2-6 eigenvalues): at most 6.4e-5 (the
    # fewer the eigenvalues, the fewer the samples); P6, stress top, k = 2.8, 16 c_d, 24
    # eigenvalues: 1.5e-6
    assert err.max() < 5e-4
