"""The banded, lazy interior modes (``forms.solvers.partial.NearModel``) against the dense ones.

``NearModel`` gives the condensed form's eigenvalues by LAPACK ``dsbgvx``, the near vectors by
inverse iteration and Rayleigh-Ritz, and the far modes' sums by deflated banded solves; the
reference is the dense decomposition of ``forms.solvers.condensed.CondensedModel`` (one
``eigh`` per ``k``), which shares none of that arithmetic. Serial and under mpirun -n 2.
"""

import numpy as np
import pytest

from analytic import Params
from analytic.numerics.spectrum import Region
from forms.solvers import certified, condensed
from forms.solvers.certified import CertifiedSolver, default_discretisation
from forms.solvers.condensed import CondensedModel
from forms.solvers.partial import NearModel

CASES = {
    "velocity": (Params(), 3.0, 4.0),
    "stress": (Params(bc="stress"), 5.0, 16.0),
    "two_body": (Params(mu2=4.0, rho2=1.0, H2=0.5), 2.0, 4.0),
    "small_k": (Params(), 0.05, 4.0),
}


@pytest.fixture(scope="module", params=list(CASES))
def pair(request):
    p, k, c_max = CASES[request.param]
    region = Region(c_max=c_max)
    deg, cells, ratio = default_discretisation(p, region, k, 1e-8)
    s = CertifiedSolver(p, region, deg, cells, ratio, k, 1e-8, check_exact=False)
    bm = s.banded[0]
    op = bm.operator(k)
    yield (NearModel(bm).operator(op, k), CondensedModel(bm).operator(op, k),
           region.box(p, k))
    s.destroy()


def test_eigenvalues_and_log_det_equal_the_dense_ones(pair):
    near, dense, box = pair
    assert near.partial and not dense.partial
    # measured (the cases above, 2026-11-28): |w| to 9.1e-11 relative (the smallest w, an
    # absolute error of rounding times the largest), log|det| to 9.9e-14, arg to 5.8e-10
    assert np.max(np.abs(near.w - dense.w) / np.abs(dense.w)) < 1e-9
    rng = np.random.default_rng(0)
    z = box[0] + (box[1] - box[0]) * rng.random(300) + 1j * (
        box[2] + (box[3] - box[2]) * rng.random(300))
    a, b = near.log_det_many(z), dense.log_det_many(z)
    assert np.max(np.abs(a.real - b.real) / np.maximum(1.0, np.abs(b.real))) < 1e-11
    assert np.max(np.abs(np.angle(np.exp(1j * (a.imag - b.imag))))) < 1e-8
    assert near.count_and_samples(box)[0] == dense.count_and_samples(box)[0]


def test_far_sums_and_predictors_equal_the_dense_ones(pair):
    near, dense, box = pair
    z = np.array([complex(x, y) for x in box[:2] for y in box[2:]])
    far = near._far(z)
    assert far.terms > 0 and 0 < far.j0 < near.w.size  # the deflated sums are used
    fa = near._far_coef(far.j0, far.terms, far.scale)
    fb = dense._far_coef(far.j0, far.terms, far.scale)
    # measured: 7.4e-14 of the largest coefficient
    assert np.max(np.abs(fa - fb)) <= 1e-11 * np.max(np.abs(fb))
    la, va = near.linear_eigs(box)
    lb, vb = dense.linear_eigs(box)
    assert la.size == lb.size > 0
    # measured: predictors to 6.2e-11 relative, vectors parallel to 1e-15
    for i, x in enumerate(la):
        j = int(np.argmin(np.abs(lb - x)))
        assert abs(lb[j] - x) <= 1e-9 * abs(x)
        cos = abs(np.vdot(va[:, i], vb[:, j])) / np.linalg.norm(va[:, i]) / np.linalg.norm(
            vb[:, j])
        assert cos > 1 - 1e-12


@pytest.mark.parametrize("how", ["dense", "banded"])
def test_moment_sums_fall_back_to_a_full_decomposition_or_banded_solves(pair, how, monkeypatch):
    near, dense, box = pair
    monkeypatch.setattr(near, "_dense", None)  # the module's operators are shared
    if how == "banded":  # above DENSE_MOMENTS_MAX: one banded LU per point
        monkeypatch.setattr(condensed, "DENSE_MOMENTS_MAX", 0)
    rng = np.random.default_rng(1)
    z = box[1] + 1j * np.linspace(box[2], box[3], 7)
    weights = rng.standard_normal((7, 2)) + 0j
    v = rng.standard_normal((near.bop.n, 3)) + 0j
    a, b = near.moment_sums(z, weights, v), dense.moment_sums(z, weights, v)
    # another decomposition (this k's own dense one, or banded LUs) than CondensedModel's
    # reduction: measured at most 5.1e-11 of the largest entry over the cases (stress top,
    # 800 interior rows)
    assert np.max(np.abs(a - b)) <= 1e-9 * np.max(np.abs(b))
    assert (near._dense is None) == (how == "banded")


@pytest.mark.parametrize("case", ["stress", "two_body"])
def test_certified_rows_do_not_depend_on_the_model(case, monkeypatch):
    p, k, c_max = CASES[case]
    region = Region(c_max=c_max)
    deg, cells, ratio = default_discretisation(p, region, k, 1e-8)
    out = {}
    for name, near_min in (("near", 0), ("dense", 10 ** 9)):
        monkeypatch.setattr(certified, "NEAR_MIN", near_min)
        s = CertifiedSolver(p, region, deg, cells, ratio, k, 1e-8, check_exact=False)
        try:
            out[name] = s.solve(k)
            assert isinstance(s._condensed_model(), NearModel if name == "near"
                              else CondensedModel)
        finally:
            s.destroy()
    a, b = out["near"], out["dense"]
    assert a.closed and b.closed and a.n_fe == b.n_fe == len(a.rows) > 0
    va = np.sort_complex(np.array([complex(r["re_lambda"], r["im_lambda"]) for r in a.rows]))
    vb = np.sort_complex(np.array([complex(r["re_lambda"], r["im_lambda"]) for r in b.rows]))
    # both Newton-polished on the same T_h: measured 1.6e-11 relative over the default stress
    # sweep (1 805 eigenvalues)
    assert np.max(np.abs(va - vb) / np.abs(vb)) < 1e-10


def test_a_k_dependent_mass_is_refused():
    p = Params(alpha_pc=1.0)  # the Prakash-Clifton term puts k into the z^2 part
    region = Region(c_max=4.0)
    deg, cells, ratio = default_discretisation(p, region, 3.0, 1e-8)
    s = CertifiedSolver(p, region, deg, cells, ratio, 3.0, 1e-8, check_exact=False)
    try:
        with pytest.raises(NotImplementedError, match="mass depends on k"):
            NearModel(s.banded[0])
    finally:
        s.destroy()
