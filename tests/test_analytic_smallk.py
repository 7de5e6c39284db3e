import math

import numpy as np
import pytest

from analytic.numerics.branches import follow_branch
from analytic.params import ParameterError, Params
from analytic.physics.finite_h import cutoff
from analytic.physics.smallk import growth_rate_beta_half, growth_rate_paper, lambda_smallk, slope

# Pure numpy (no MPI, no FE): the serial pass is enough.
pytestmark = pytest.mark.serial

# Parameter sets: paper defaults (beta = 1/2), beta != 1/2, stress top, generalized model.
CASES = [
    dict(),
    dict(beta=0.4),
    dict(bc="stress"),
    dict(bc="stress", beta=0.4),
    dict(alpha_pc=0.2, alpha_ld=0.3, beta=0.4),
]


@pytest.mark.parametrize("n,sign", [(0, -1), (1, 1)])
@pytest.mark.parametrize("kw", CASES)
def test_slope_against_exact_roots(kw, n, sign):
    """Lambda(k) - Lambda_0 - slope k = O(k^2), checked on the exact branch."""
    p = Params(**kw)
    ks = np.array([1e-3, 2e-3])
    b = follow_branch(p, n, sign, ks, k_start=1e-4)
    assert b.ok.all(), b.note
    err = np.abs(b.Lambda - lambda_smallk(ks, n, sign, p))
    # measured on 2026-11-21: err(1e-3)/k^2 between 0.107 and 1.39 for these 10 cases, and
    # err(2e-3)/err(1e-3) = 4.000 +- 0.003 (quadratic)
    assert err[0] < 2.0 * ks[0] ** 2
    assert err[1] / err[0] == pytest.approx(4.0, rel=0.01)


@pytest.mark.parametrize("n", [0, 1, 2])
def test_beta_half_limit_is_4f_over_2n_plus_1_pi(n):
    p = Params()  # beta = 1/2
    c = slope(n, -1, p)
    assert c.real == pytest.approx(4 * p.f / ((2 * n + 1) * math.pi), rel=1e-13)
    assert growth_rate_beta_half(1.0, n, p)[0] == pytest.approx(c.real, rel=1e-13)
    assert slope(n, 1, p).real == pytest.approx(-c.real, rel=1e-13)  # the stable partner
    with pytest.raises(ParameterError, match="beta"):
        growth_rate_paper(0.1, n, p)  # the literal Eq. (Hspectrum) is 0/0 at beta = 1/2


@pytest.mark.parametrize("sign", [1, -1])
@pytest.mark.parametrize("kw", [dict(beta=0.4), dict(beta=0.45, H=2.0, Delta=0.2, gamma=1.0)])
def test_paper_formula_is_the_real_part_of_the_slope(kw, sign):
    p = Params(**kw)
    for n in (0, 1):
        assert growth_rate_paper(1.0, n, p, sign)[0] == pytest.approx(
            slope(n, sign, p).real, rel=1e-12)


def test_universal_instability_one_branch_of_each_pair_grows():
    p = Params(beta=0.4, Delta=0.9, gamma=0.5)
    for n in range(3):
        assert slope(n, 1, p).real * slope(n, -1, p).real < 0
        assert slope(n, 1, p).imag == pytest.approx(slope(n, -1, p).imag, rel=1e-12)


def test_branch_starts_at_cutoff():
    p = Params(H=0.7, beta=0.3)
    b = follow_branch(p, 1, 1, [1e-3])
    assert abs(b.Lambda[0] - cutoff(1, 1, p)) < 2 * abs(slope(1, 1, p)) * 1e-3
