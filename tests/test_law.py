"""The one friction law (analytic.law): its forms agree with each other and with the paper."""

import numpy as np
import pytest

from analytic.law import FrictionLaw, ScalarFunction
from analytic.params import Params

pytestmark = pytest.mark.serial

LAMBDAS = np.array([0.3 + 1.2j, -0.5 + 0.1j, 2.0 - 3.0j, -2.0 + 0.5j, 0.7])


def _pv(c, lam):
    return np.polynomial.polynomial.polyval(lam, c)


@pytest.mark.parametrize("kw", [dict(), dict(alpha_pc=0.7, alpha_ld=0.4, Delta=0.6),
                                dict(Delta=1.0, alpha_pc=0.3, f=0.2, gamma=3.0)])
def test_forms_agree(kw):
    law = FrictionLaw.from_params(Params(**kw))
    L = LAMBDAS
    a, b, c = law.cleared(L)
    # the rational form times (L + 1) is the cleared form (rounding only: measured < 1e-15)
    assert np.allclose(a, law.shear(L) * (L + 1), rtol=1e-14, atol=0)
    assert np.allclose(b, law.normal(L) * (L + 1), rtol=1e-14, atol=0)
    assert np.allclose(c, -law.slip(L) * (L + 1), rtol=1e-14, atol=0)
    # the polynomial coefficients are the same polynomials
    assert np.allclose(a, _pv(law.rx, L), rtol=1e-14, atol=0)
    assert np.allclose(b, _pv(law.ry, L), rtol=1e-14, atol=0)
    assert np.allclose(c, -_pv(law.ux, L), rtol=1e-14, atol=0)
    # the determinant row: the cleared form, or the rational one where L + 1 cancels
    ra, rb, rc = law.row(L)
    scale = 1.0 if law.cancels else L + 1
    assert np.allclose(ra, law.shear(L) * scale, rtol=1e-14, atol=0)
    assert np.allclose(rb, law.normal(L) * scale, rtol=1e-14, atol=0)
    assert np.allclose(rc, -law.slip(L) * scale, rtol=1e-14, atol=0)


def test_against_the_paper_written_independently():
    # docs/design.md section 3 literally: (1 + apc L) sxy + (f - ald L/(L+1)) syy
    # - (1/gamma) L (L + Delta)/(L + 1) ux, at sxy = 0.3, syy = -1.1j, ux = 2.0
    p = Params(alpha_pc=0.25, alpha_ld=0.5, Delta=0.3, f=0.4, gamma=2.5)
    law = FrictionLaw.from_params(p)
    for L in LAMBDAS:
        want = ((1 + 0.25 * L) * 0.3 + (0.4 - 0.5 * L / (L + 1)) * (-1.1j)
                - L * (L + 0.3) / (2.5 * (L + 1)) * 2.0)
        got = law.shear(L) * 0.3 + law.normal(L) * (-1.1j) - law.slip(L) * 2.0
        assert abs(got - want) <= 1e-14 * abs(want)


def test_spurious_and_degree():
    assert FrictionLaw.from_params(Params()).spurious == (-1.0 + 0j,)
    law = FrictionLaw.from_params(Params(alpha_pc=0.25))
    assert law.spurious == (-1.0 + 0j, -4.0 + 0j)
    assert law.degree == 4 and FrictionLaw.from_params(Params()).degree == 3
    assert FrictionLaw.from_params(Params(Delta=1.0, alpha_pc=0.25)).cancels
    assert not FrictionLaw.from_params(Params(Delta=0.5)).cancels
    assert not FrictionLaw.from_params(Params(Delta=1.0, alpha_ld=0.1)).cancels


@pytest.mark.parametrize("fn", [ScalarFunction.power(0), ScalarFunction.power(3),
                                ScalarFunction(num=(1.0,), den=(1.0, 1.0)),
                                ScalarFunction(num=(0.5, -2.0, 1.0), den=(2.0, 1.0))])
def test_scalar_function_value_and_derivative(fn):
    z, h = 0.4 - 0.9j, 1e-6
    v, d = fn.value_and_derivative(z)
    assert abs(v - fn(z)) <= 1e-15 * abs(v)
    fd = (fn(z + h) - fn(z - h)) / (2 * h)
    # central difference error ~ h^2 |phi'''| ~ 1e-12 here
    assert abs(d - fd) <= 1e-8 * max(1.0, abs(d))


def test_scalar_function_power_index():
    assert ScalarFunction.power(2).power_index == 2
    assert ScalarFunction.power(0).power_index == 0
    assert ScalarFunction(num=(1.0,), den=(1.0, 1.0)).power_index is None
    assert ScalarFunction(num=(1.0, 1.0)).power_index is None
