import math

import numpy as np
import pytest

from analytic.params import ParameterError, Params
from analytic.units import (
    PMMA_ON_STEEL,
    Physical,
    beta_from_nu,
    nu_from_beta,
    to_dimensionless,
    to_physical,
)

# Pure numpy (no MPI, no FE): the serial pass is enough.
pytestmark = pytest.mark.serial

BASE = dict(mu=30e9, nu=0.25, rho=2700.0, sigma0=50e6, v0=1e-6, D=1e-5, f=0.6, a=0.015,
            b=0.01, H=10.0)


def test_formulas_by_hand():
    c = to_dimensionless(Physical(**BASE))
    c_s = math.sqrt(30e9 / 2700.0)
    assert c.c_s == pytest.approx(c_s, rel=1e-15)
    assert c.t0 == pytest.approx(10.0, rel=1e-15)  # D / v0
    assert c.length == pytest.approx(c_s * 10.0, rel=1e-15)
    p = c.params
    assert p.gamma == pytest.approx(30e9 * 1e-6 / (c_s * 50e6 * 0.015), rel=1e-14)
    assert p.Delta == pytest.approx((0.015 - 0.01) / 0.015, rel=1e-14)
    assert p.beta == pytest.approx(1 / math.sqrt(3), rel=1e-14)  # nu = 1/4 -> c_d = sqrt(3) c_s
    assert p.H == pytest.approx(10.0 / (c_s * 10.0), rel=1e-14)
    assert c.c_d == pytest.approx(c_s * math.sqrt(3), rel=1e-14)


def test_round_trip():
    p = Params(f=0.4, gamma=2.5, beta=0.45, Delta=0.6, H=0.8)
    phys = to_physical(p, mu=2e9, rho=1200.0, sigma0=3e6, v0=2e-3, D=1e-6)
    back = to_dimensionless(phys).params
    for name in ("f", "gamma", "beta", "Delta", "H"):
        assert getattr(back, name) == pytest.approx(getattr(p, name), rel=1e-13), name
    assert nu_from_beta(beta_from_nu(0.3)) == pytest.approx(0.3, rel=1e-14)


def test_back_to_physical_quantities():
    c = to_dimensionless(Physical(**BASE))
    L, k = 0.2 - 3.0j, 1.5
    assert c.growth_rate(L) == pytest.approx(0.2 / c.t0)
    assert c.angular_frequency(L) == pytest.approx(-3.0 / c.t0)
    assert c.wavelength(k) == pytest.approx(2 * math.pi * c.length / k)
    assert c.k_from_wavelength(c.wavelength(k)) == pytest.approx(k)
    assert c.phase_velocity(L, k) == pytest.approx(-3.0 / 1.5 * c.c_s)


def test_worked_example_is_in_range():
    c = to_dimensionless(PMMA_ON_STEEL)
    p = c.params
    assert 0 < p.beta < 1 / math.sqrt(2) and p.gamma > 0 and p.H > 0
    assert np.isfinite([p.f, p.gamma, p.beta, p.Delta, p.H]).all()


@pytest.mark.parametrize(
    "field,value",
    [("mu", 0.0), ("mu", -1.0), ("nu", 0.5), ("nu", 0.0), ("nu", math.nan), ("rho", -1.0),
     ("sigma0", 0.0), ("v0", -1e-3), ("D", 0.0), ("a", 0.0), ("f", -0.1), ("b", math.inf),
     ("H", 0.0), ("H", math.nan)],
)
def test_bad_physical_input_is_named(field, value):
    kw = dict(BASE)
    kw[field] = value
    with pytest.raises(ParameterError, match=field):
        Physical(**kw)
