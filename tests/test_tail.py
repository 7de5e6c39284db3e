"""The high-frequency tail bound (analytic.physics.tail) against roots computed beyond it, and the
adaptive region that uses it (analytic.numerics.spectrum.provable_region, fastest_mode).

Every check is against the exact determinant (``zeros_in_box`` on ``det_M``), never against
stored numbers.
"""

import math

import numpy as np
import pytest

from analytic.numerics.roots import zeros_in_box
from analytic.numerics.spectrum import C_LADDER, Region, fastest_mode, provable_region
from analytic.params import Params
from analytic.physics.tail import tail_bound, velocity_scale, why_no_tail_bound

pytestmark = pytest.mark.serial

#: Parameters and wavenumbers of the band checks: both tops at the paper's defaults, and
#: non-default friction, Poisson ratio, height and a Linker-Dieterich term.
CASES = {
    "velocity": (Params(bc="velocity"), (5.0, 26.5)),
    "stress": (Params(bc="stress"), (5.0, 26.5)),
    "stress-other": (Params(bc="stress", beta=0.35, gamma=1.5, Delta=-0.5, f=0.5, H=1.0),
                     (3.0, 12.0)),
    "velocity-other": (Params(bc="velocity", beta=0.6, gamma=0.8, Delta=2.0, f=0.4, H=2.0,
                              alpha_ld=0.3), (2.0, 8.0)),
}


def _band_roots(p, k, w1, w2):
    """Every exact root with ``w1 < |Im| < w2`` and ``Re > -2`` (both half-planes)."""
    from analytic.numerics.branches import _n_initial, spectrum_function

    fun = spectrum_function(p, k)
    out = []
    for box in ((-2.0, 2.0, w1, w2), (-2.0, 2.0, -w2, -w1)):
        out += [r.value for r in zeros_in_box(fun, box, n_initial=_n_initial(p, box))]
    return np.array(out)


@pytest.mark.slow  # 13-90 s per case on the loaded 2-core machine (up to 270 roots per band)
@pytest.mark.parametrize("case", list(CASES))
def test_tail_bound_above_every_root_beyond_w(case):
    p, ks = CASES[case]
    for k in ks:
        w = Region(c_max=4.0).im_max(p, k)
        z = _band_roots(p, k, w, 3.0 * w)
        assert len(z) > 10  # the band holds resonances (else the check is empty)
        tb = tail_bound(p, k, w)
        assert np.all(z.real < tb), (k, z[np.argmax(z.real)], tb)
        # the stronger form: each root below the bound at its own frequency
        own = np.array([tail_bound(p, k, abs(v.imag)) for v in z])
        assert np.all(z.real < own)
        # not absurdly loose: the fastest root beyond W reaches a fair part of the bound
        # (measured max Re / bound at W: 0.11-0.76 over these cases, docs/design.md 8.1)
        assert z.real.max() / tb > 0.1


def test_tail_bound_decreases_and_is_none_where_not_derived():
    p = Params(bc="stress")
    ws = [300.0, 600.0, 1200.0]
    tb = [tail_bound(p, 26.5, w) for w in ws]
    assert tb[0] > tb[1] > tb[2] > 0
    # first order: ~ 1/W, with the (1 + k/W) margin
    assert tb[1] / tb[2] == pytest.approx(2.0 * (1 + 26.5 / 600) / (1 + 26.5 / 1200), rel=1e-3)
    assert tail_bound(p, 26.5, 10.0) == math.inf  # W below k: no expansion
    for q in (Params(mu2=4.0), Params(alpha_pc=1.0)):
        assert tail_bound(q, 5.0, 500.0) is None and why_no_tail_bound(q)


def test_velocity_scale_is_the_largest_c_d():
    assert velocity_scale(Params(beta=0.5)) == 2.0
    # stiff substrate: c_d2 = sqrt(mu2/rho2)/beta2 = sqrt(9)/0.5
    assert velocity_scale(Params(beta=0.5, mu2=9.0, rho2=1.0)) == pytest.approx(6.0)
    assert velocity_scale(Params(beta=0.5, mu2=0.25, rho2=1.0)) == 2.0
    # capped at 4 slider c_d (a nearly rigid substrate)
    assert velocity_scale(Params(beta=0.5, mu2=1e6, rho2=1.0)) == pytest.approx(8.0)


def test_provable_region_climbs_until_the_bound_is_below():
    p, k, region = Params(bc="stress"), 26.5, Region(c_max=None)
    calls = []

    def inside(c):
        calls.append(c)
        return 0.3

    c, tb = provable_region(p, k, region, inside)
    assert tb < 0.3
    # the rung below would not do
    below = C_LADDER[C_LADDER.index(c) - 1]
    assert tail_bound(p, k, region.fixed(below).im_max(p, k)) >= 0.3
    # skipped rungs are not evaluated: the first rung and the accepted one
    assert calls == [C_LADDER[0], c]
    # a fixed region is used as it is
    assert provable_region(p, k, Region(c_max=4.0), inside)[0] == 4.0


@pytest.mark.slow  # 12-44 s on the loaded 2-core machine
def test_fastest_mode_stress_top_k26_5_beyond_4_c_d():
    """The issue's case: the fixed 4 c_d region misses the fastest root; the adaptive one holds
    it and proves it, and a plain search of a wider fixed region agrees."""
    p, k = Params(bc="stress"), 26.5
    m4 = fastest_mode(p, k, Region(c_max=4.0))
    m = fastest_mode(p, k, Region(c_max=None))
    assert m.proven and m.c_max > 4.0 and m.tail_bound < m.root.real
    assert m.root.real > m4.root.real and not m4.proven
    assert abs(m.root.imag) * p.beta / k > 4.0  # beyond 4 c_d
    # independent: every root of the adaptive region's box, by zeros_in_box
    from analytic.numerics.branches import _n_initial, spectrum_function

    fun = spectrum_function(p, k)
    box = (m.root.real - 0.05, 2.0, m.box[2], m.box[3])
    z = [r.value for r in zeros_in_box(fun, box, n_initial=_n_initial(p, box))]
    best = max(z, key=lambda v: v.real)
    # same root: polished by Newton to ~1e-14 both times (measured difference 3e-16)
    assert abs(best - m.root) < 1e-10 * abs(m.root)


def test_fastest_mode_near_12_c_d():
    """Stress top, beta = 0.6, gamma = 1, k = 4: the fastest mode runs at 11.8 c_d (found by a
    search with the exact determinant); the adaptive region proves it, the 4 c_d one misses it."""
    p, k = Params(bc="stress", beta=0.6, gamma=1.0), 4.0
    m = fastest_mode(p, k, Region(c_max=None))
    m4 = fastest_mode(p, k, Region(c_max=4.0))
    assert m.proven and m.tail_bound < m.root.real
    assert abs(m.root.imag) * p.beta / k > 10.0
    assert m4.root.real < m.root.real and not m4.proven
    # the tail bound of the rung used is below the fastest root, the rung below's is not
    below = C_LADDER[C_LADDER.index(m.c_max) - 1]
    assert not tail_bound(p, k, Region(c_max=below).im_max(p, k)) < m.root.real


@pytest.mark.slow  # 14-40 s on the loaded 2-core machine
def test_two_body_stiff_substrate_region_scaled_by_the_largest_c_d():
    """mu2 = 4 (c_d2 = 2 c_d of the slider), velocity top, k = 5: the fastest root runs at 6.9 c_d
    of the slider, outside the old region (4 c_d of the slider = Region(c_max=2) now), inside
    the new one (4 c_d2). No tail bound is derived for two bodies: not proven, and said so."""
    p, k = Params(bc="velocity", mu2=4.0, rho2=1.0, H2=0.5), 5.0
    assert velocity_scale(p) == pytest.approx(4.0)
    m = fastest_mode(p, k, Region(c_max=None))
    old = fastest_mode(p, k, Region(c_max=2.0))
    assert m.c_max == C_LADDER[0] and m.tail_bound is None and not m.proven
    assert abs(m.root.imag) * p.beta / k > 4.0 and m.root.real > old.root.real
