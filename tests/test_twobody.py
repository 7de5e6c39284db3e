"""Two-body exact spectrum (issue 9): formulation checks and physics checks (pure numpy)."""

import json
import math

import numpy as np
import pytest
import scipy.linalg

from analytic.cli import main
from analytic.numerics.branches import follow_branch, polish_root, roots_in_box, spectrum_function
from analytic.numerics.roots import count_zeros, polish, zeros_in_box
from analytic.params import ParameterError, Params
from analytic.physics.finite_h import det_M
from analytic.physics.twobody import (
    _layer,
    _regular_pair,
    _state_matrix,
    cutoff_twobody,
    det_twobody,
    det_twobody_even,
    det_twobody_propagator,
    generalized_rayleigh,
    rayleigh_speed,
)

pytestmark = pytest.mark.serial

TWO_BODY = dict(mu2=3.0, rho2=1.5, beta2=0.45, H2=0.7)


@pytest.mark.parametrize(
    "field,value,needle",
    [
        ("mu2", 0.0, "mu2"),
        ("mu2", -2.0, "mu2"),
        ("mu2", math.nan, "mu2"),
        ("rho2", 0.0, "rho2"),
        ("rho2", math.inf, "rho2"),
        ("beta2", 0.0, "beta2"),
        ("beta2", 1 / math.sqrt(2), "beta2"),
        ("H2", 0.0, "H2"),
        ("H2", -1.0, "H2"),
        ("bc2", "free", "bc2"),
    ],
)
def test_bad_substrate_parameter_is_one_line_naming_it(field, value, needle):
    with pytest.raises(ParameterError, match=needle) as err:
        Params(**{field: value})
    assert "\n" not in str(err.value)


def test_rigid_default_is_unchanged():
    p = Params()
    assert not p.two_body and p.mu2 == math.inf and p.substrate_beta == p.beta
    assert set(Params().as_dict()) >= {"f", "gamma", "beta", "Delta", "H", "bc", "mu2", "H2"}
    f = spectrum_function(p, 1.0)
    z = np.array([0.3 - 6.0j, 1.0 + 2.0j])
    # the same function, not a re-derivation; two calls of LAPACK on the same input may differ
    # in the last bit (alignment-dependent kernels: seen 1 ulp), hence not array_equal
    assert np.allclose(f(z), det_M(z, 1.0, p), rtol=1e-14, atol=0)
    with pytest.raises(ParameterError, match="mu2"):
        det_M(1.0 + 1.0j, 1.0, Params(mu2=2.0))  # rigid-only code refuses two bodies


@pytest.mark.parametrize("bc2", ["velocity", "stress"])
@pytest.mark.parametrize("bc", ["velocity", "stress"])
@pytest.mark.parametrize("extra", [dict(), dict(alpha_pc=0.2, alpha_ld=0.3, Delta=-0.3)])
def test_roots_agree_with_propagator_and_even_basis(bc, bc2, extra):
    p = Params(bc=bc, bc2=bc2, **TWO_BODY, **extra)
    k = 0.8
    roots = [r.value for r in roots_in_box(p, k, (-1.5, 1.0, 0.5, 9.0))]
    assert len(roots) >= 2
    for z in roots:
        for other in (np.vectorize(lambda L: det_twobody_propagator(L, k, p)),
                      lambda L: det_twobody_even(L, k, p)):
            r = polish(other, z)
            assert r.converged, r.reason
            # measured <= 3e-16 on 2026-11-22 (propagator: scipy expm; even basis)
            assert abs(r.value - z) / abs(z) < 1e-11


@pytest.mark.parametrize("bc2", ["velocity", "stress"])
@pytest.mark.parametrize("box", [(-3.0, 0.4, -7.0, 7.3), (-2.0, 1.0, -10.0, -0.3)])
def test_argument_principle_counts_agree_with_entire_propagator(box, bc2):
    """det_twobody is single-valued: its count equals that of the entire propagator form.

    The first box holds Lambda = 0 and crosses the imaginary axis beyond the branch points.
    """
    p = Params(bc2=bc2, alpha_pc=0.1, **TWO_BODY)
    k = 0.8
    n = count_zeros(lambda L: det_twobody(L, k, p), box)
    n_prop = count_zeros(np.vectorize(lambda L: det_twobody_propagator(L, k, p)), box)
    assert n == n_prop and n > 0


def test_spurious_order_of_the_even_basis_is_eight():
    """det(M_even) vanishes like Lambda^8 at 0 (Lambda^4 per layer), det_twobody does not."""
    from analytic.physics.twobody import matrix_twobody

    p = Params(**TWO_BODY)
    d = [abs(np.linalg.det(matrix_twobody(e * (1 + 0.3j), 0.8, p, "even"))) for e in (1e-3, 5e-4)]
    # measured log2 ratio 8.001 on 2026-11-22
    assert math.log2(d[0] / d[1]) == pytest.approx(8.0, abs=0.01)
    v = abs(det_twobody(np.array([1e-3, 5e-4]) * (1 + 0.3j), 0.8, p))
    assert v[0] / v[1] == pytest.approx(1.0, abs=0.01)  # no spurious zero in the regular basis


@pytest.mark.parametrize("bc2", ["velocity", "stress"])
@pytest.mark.parametrize("kw", [dict(), dict(bc="stress"),
                                dict(alpha_pc=0.3, alpha_ld=0.5, beta=0.45)])
def test_stiff_substrate_converges_to_the_rigid_roots(kw, bc2):
    """mu2 -> inf: every rigid root is reached as 1/mu2; Richardson removes the 1/mu2 term."""
    pr = Params(**kw)
    k = 1.0
    rigid = zeros_in_box(lambda L: det_M(L, k, pr), (-1.0, 1.0, -12.0, -0.5))
    assert rigid
    for r in rigid:
        L = {m: polish_root(pr.replace(mu2=m, H2=0.5, bc2=bc2), k, r.value).value
             for m in (1e8, 1e9)}
        e8, e9 = abs(L[1e8] - r.value), abs(L[1e9] - r.value)
        # measured: relative distance 4e-10 .. 3e-7 at mu2 = 1e9, ratio 10.0000 .. 10.0001
        assert e9 / abs(r.value) < 1e-6
        assert e8 / e9 == pytest.approx(10.0, rel=1e-3)
        extrapolated = (10.0 * L[1e9] - L[1e8]) / 9.0
        # measured <= 1.7e-12 on 2026-11-22 (18 roots)
        assert abs(extrapolated - r.value) / abs(r.value) < 1e-10


@pytest.mark.parametrize("kw", [TWO_BODY, dict(mu2=0.3, rho2=0.8, H2=1.0, bc="stress",
                                               bc2="stress")])
def test_branch_starts_at_composite_rod_cutoff_and_matches_box_roots(kw):
    p = Params(**kw)
    L0 = cutoff_twobody(0, -1, p)
    assert L0.real == 0 and L0.imag < 0
    dist = []
    for k in (1e-6, 1e-7):
        near = roots_in_box(p, k, (-0.01, 0.01, L0.imag - 0.01, L0.imag + 0.01))
        assert len(near) == 1
        dist.append(abs(near[0].value - L0))
    # the root leaves the cut-off linearly in k: measured |Lambda - Lambda_0| = 0.092 k and
    # 0.196 k, ratio 10.0000 between the two k
    assert dist[0] < 1.0 * 1e-6
    assert dist[0] / dist[1] == pytest.approx(10.0, rel=1e-3)
    b = follow_branch(p, 0, -1, [0.5, 1.0])
    assert b.ok.all(), b.note
    z = b.Lambda[-1]
    box = (z.real - 0.05, z.real + 0.05, z.imag - 0.05, z.imag + 0.05)
    found = roots_in_box(p, 1.0, box)
    assert len(found) == 1 and abs(found[0].value - z) < 1e-12 * abs(z)


def _half_layer_symmetric_det(L, k, p):
    """Body 1 alone with u_y(0) = 0 and s_xy(0) = 0 (the mirror-symmetric, no-slip modes)."""
    T = scipy.linalg.expm(-_state_matrix(L, k, p.slider) * p.H)
    free = [1, 2] if p.bc == "velocity" else [0, 1]
    return np.linalg.det(T[[1, 2]][:, free])


@pytest.mark.parametrize("bc", ["velocity", "stress"])
@pytest.mark.parametrize("Delta", [0.0, 0.7])
def test_symmetric_stack_has_no_growth_and_neutral_no_slip_modes(bc, Delta):
    """Identical materials, H2 = H, bc2 = bc: no root with Re Lambda > 0 for Delta >= 0.

    Mirror-symmetric modes have no slip and u_y(0) = s_xy(0) = 0: purely elastic, exactly
    neutral (the zeros of the half-layer problem); antisymmetric modes have s_yy(0) = 0, so
    normal stress does not enter the friction law, and (Lambda + Delta)/(Lambda + 1) is
    positive real for Delta >= 0: they are damped.
    """
    p = Params(mu2=1.0, rho2=1.0, beta2=0.5, H2=0.5, bc=bc, bc2=bc, Delta=Delta)
    for k in (0.3, 1.0, 3.0):
        assert count_zeros(lambda L, k=k: det_twobody(L, k, p), (1e-6, 2.0, -15.3, 15.1)) == 0
    k = 1.0
    roots = [r.value for r in roots_in_box(p, k, (-0.7, 0.5, -10.3, 10.1))]
    neutral = [z for z in roots if abs(z.real) < 1e-10]
    damped = [z for z in roots if abs(z.real) >= 1e-10]
    assert neutral and damped
    # measured |Re| <= 1.7e-15 for the 6 neutral ones; the others Re <= -1.8e-3 (stress top,
    # Delta = 0: the least damped), -1.3e-2 (velocity, 0), -2.6e-2 (stress, 0.7), -7.8e-2
    assert max(z.real for z in damped) < -5e-4
    n_half = count_zeros(np.vectorize(lambda L: _half_layer_symmetric_det(L, k, p)),
                         (-0.1, 0.1, -10.3, 10.1))
    assert n_half == len(neutral)
    for z in neutral:
        r = polish(np.vectorize(lambda L: _half_layer_symmetric_det(L, k, p)), z)
        assert abs(r.value - z) < 1e-11 * abs(z)  # measured 1e-15


def test_symmetric_stack_is_unstable_for_velocity_weakening():
    """The test above can fail: Delta < 0 makes the antisymmetric (slip) modes grow."""
    p = Params(mu2=1.0, rho2=1.0, H2=0.5, Delta=-0.5)
    assert count_zeros(lambda L: det_twobody(L, 1.0, p), (1e-6, 2.0, -15.3, 15.1)) > 0


@pytest.mark.parametrize("bc", ["velocity", "stress"])
@pytest.mark.parametrize("H2", [0.25, 1.0])
def test_broken_symmetry_is_unstable_for_velocity_strengthening(bc, H2):
    """Identical materials, H2 != H (Aldam et al. 2016): slip couples to normal stress."""
    p = Params(mu2=1.0, rho2=1.0, H2=H2, bc=bc, bc2=bc, Delta=0.7)
    assert count_zeros(lambda L: det_twobody(L, 1.0, p), (1e-6, 2.0, -20.3, 20.1)) > 0


def _coulomb(mu2, alpha_pc=0.0):
    return Params(H=math.inf, H2=math.inf, mu2=mu2, rho2=1.0, gamma=1e8, f=0.3, Delta=0.7,
                  alpha_pc=alpha_pc)


def _most_unstable(p, k, box):
    rs = roots_in_box(p, k, box)
    return max(rs, key=lambda r: r.value.real).value if rs else None


def test_coulomb_limit_grows_like_k_where_the_gr_wave_exists():
    """Two half-spaces, gamma = 1e8, alpha_pc = 0 (Ranjith & Rice 2001): Re Lambda ~ k."""
    gr = generalized_rayleigh(1.2, 1.0, 0.5)
    assert gr.exists
    p = _coulomb(1.2)
    z = {k: _most_unstable(p, k, (1e-3 * k, 0.5 * k, -1.5 * k, 1.5 * k)) for k in (10.0, 100.0)}
    assert z[10.0] is not None and z[10.0].real > 0
    # measured Re Lambda / k = 0.00756682 at both k (relative difference 1e-9)
    assert z[100.0].real / 100.0 == pytest.approx(z[10.0].real / 10.0, rel=1e-6)
    # the unstable mode travels near the generalized Rayleigh speed (measured 0.96937 vs
    # 0.96949: the friction coupling shifts it by 1.2e-4)
    assert z[100.0].imag / 100.0 == pytest.approx(gr.speed, rel=1e-3)


def test_coulomb_limit_prakash_clifton_bounds_the_growth():
    p = _coulomb(1.2, alpha_pc=0.1)
    growth = [_most_unstable(p, k, (1e-5, 2.0, 0.5 * k, 1.5 * k)) for k in (10.0, 100.0, 1000.0)]
    assert all(z is not None for z in growth)
    re = [z.real for z in growth]
    # measured 0.0386, 0.0080, 0.00081: bounded, decaying like 1/k at large k
    assert re[0] > re[1] > re[2] > 0
    assert re[1] / re[2] == pytest.approx(10.0, rel=0.05)


def test_coulomb_limit_stable_at_small_f_without_gr_wave():
    assert not generalized_rayleigh(3.0, 1.0, 0.5).exists
    p = _coulomb(3.0)
    for k in (10.0, 100.0):
        assert count_zeros(spectrum_function(p, k), (1e-3 * k, 0.5 * k, -1.5 * k, 1.5 * k)) == 0


# --------------------------------------------------------------------------------------------
# Generalized Rayleigh wave
# --------------------------------------------------------------------------------------------
def _gr_det(c, p):
    """Independent form: the 4x4 frictionless-contact determinant of the two half-spaces."""
    L = np.array(1j * c)  # k = 1, Lambda = i k c
    k = np.array(1.0)
    in1, _ = _layer(L, k, p.slider, math.inf, +1, "waves")
    in2, _ = _layer(L, k, p.substrate, math.inf, -1, "waves")
    z = np.zeros(2)
    M = np.array([np.concatenate([in1[1], -in2[1]]), np.concatenate([in1[3], -in2[3]]),
                  np.concatenate([in1[2], z]), np.concatenate([z, in2[2]])])
    return np.linalg.det(M)


def test_gr_identical_materials_is_the_rayleigh_speed():
    b = 1.0 / math.sqrt(3.0)  # nu = 1/4
    g = generalized_rayleigh(1.0, 1.0, b)
    assert g.exists
    assert g.speed == pytest.approx(rayleigh_speed(b), rel=1e-13)
    assert g.speed == pytest.approx(0.9194, abs=5e-5)  # the textbook value for nu = 1/4
    g2 = generalized_rayleigh(2.0, 2.0, b)  # equal wave speeds, other impedance
    assert g2.speed == pytest.approx(rayleigh_speed(b), rel=1e-13)


@pytest.mark.parametrize("mu2,rho2,beta2", [(1.2, 1.0, None), (0.5, 0.6, 0.45),
                                            (3.0, 4.0, 0.4)])
def test_gr_speed_zero_of_independent_determinant_and_swap_symmetric(mu2, rho2, beta2):
    g = generalized_rayleigh(mu2, rho2, 0.5, beta2)
    assert g.exists and g.speed < g.c_max
    p = Params(beta=0.5, mu2=mu2, rho2=rho2, beta2=beta2)
    # phase of the 4x4 determinant at real c: its modulus has a zero at the GR speed
    d0 = abs(_gr_det(g.speed, p))
    d1 = abs(_gr_det(g.speed * (1 - 1e-6), p))
    d2 = abs(_gr_det(g.speed * (1 + 1e-6), p))
    assert d0 < 1e-6 * min(d1, d2) * 1e3  # measured d0/d1 ~ 1e-9 .. 1e-10
    swapped = generalized_rayleigh(1 / mu2, 1 / rho2, p.substrate_beta, 0.5)
    c_s2 = math.sqrt(mu2 / rho2)
    assert swapped.speed * c_s2 == pytest.approx(g.speed, rel=1e-12)


def test_gr_disappears_at_large_contrast_through_the_shear_speed():
    """Exists for moderate contrast only; at the existence edge the speed reaches c_max."""
    assert not generalized_rayleigh(3.0, 1.0, 0.5).exists
    assert not generalized_rayleigh(0.3, 1.0, 0.5).exists
    lo, hi = 1.0, 3.0  # bisect the edge along rho2 = 1
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if generalized_rayleigh(mid, 1.0, 0.5).exists else (lo, mid)
    g = generalized_rayleigh(lo, 1.0, 0.5)
    # measured edge mu2 = 1.6843 (c_s2/c_s1 = 1.2978 for nu = 1/3); speed 1 - 6e-8 there
    assert 1.0 - g.speed < 1e-5


def test_gr_command_line(capsys):
    assert main(["gr", "--mu2", "1", "--rho2", "1", "--beta", "0.5"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["exists"] is True and out["speed"] == pytest.approx(rayleigh_speed(0.5))
    assert main(["gr", "--mu2", "3"]) == 0
    assert json.loads(capsys.readouterr().out) == {"exists": False, "speed": None}
    for bad in (["gr", "--mu2", "0"], ["gr", "--mu2", "1", "--beta2", "0.8"],
                ["gr", "--mu2", "1", "--rho2", "-1"]):
        assert main(bad) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and err.startswith("error:")


def test_substrate_options_reach_params():
    from analytic.cli import OneLineParser, add_param_arguments, params_from_args

    ap = OneLineParser()
    add_param_arguments(ap)
    p = params_from_args(ap.parse_args(["--mu2", "2.5", "--rho2", "1.5", "--beta2", "0.4",
                                        "--H2", "0.8", "--bc2", "stress"]))
    assert (p.mu2, p.rho2, p.beta2, p.H2, p.bc2) == (2.5, 1.5, 0.4, 0.8, "stress")
    assert params_from_args(ap.parse_args([])) == Params()
    with pytest.raises(ParameterError, match="H2"):
        params_from_args(ap.parse_args(["--mu2", "2", "--H2", "0"]))


def test_worked_examples_pmma_on_steel_is_close_to_rigid():
    from analytic.units import PMMA_ON_STEEL_DEFORMABLE, to_dimensionless

    phys, sub = PMMA_ON_STEEL_DEFORMABLE
    p2 = to_dimensionless(phys, substrate=sub).params
    p1 = to_dimensionless(phys).params
    assert p2.two_body and not p1.two_body and p2.mu2 > 30
    k = 10.0  # k H = 0.74; at k H << 1 the stiff plate bends (flexural regime), not rigid
    rigid = zeros_in_box(lambda L: det_M(L, k, p1), (-10.0, 5.0, -60.0, -1.0))
    assert len(rigid) == 2
    moved = []
    for r in rigid:
        z = polish_root(p2, k, r.value)
        assert z.converged
        # measured: relative shift 2.2 % and 2.3 % (mu2 = 37.8, rho2 = 6.7)
        assert abs(z.value - r.value) < 0.05 * abs(r.value)
        moved.append(z.value)
    assert abs(moved[0] - moved[1]) > 1.0  # two distinct two-body roots


# --------------------------------------------------------------------------------------------
# Half-space substrate: physical sheet and the outgoing (radiating) continuation
# --------------------------------------------------------------------------------------------
HALF = dict(mu2=37.8, rho2=6.7, beta2=0.54, H2=math.inf)  # PMMA-like slider on steel-like


def test_outgoing_continuation_equals_physical_sheet_for_growth_and_is_continuous():
    p = Params(**HALF)
    z = np.array([0.3 + 8.0j, 1e-3 - 30.0j, 2.0 + 0.5j])
    a, b = det_twobody(z, 1.0, p, "physical"), det_twobody(z, 1.0, p, "outgoing")
    assert np.allclose(a, b, rtol=1e-13, atol=0)  # measured: identical (same principal roots)
    for y in (3.0, -5.0, 30.0):  # the imaginary axis beyond +-i c k: a cut of the physical sheet
        lhs = det_twobody(1e-9 + 1j * y, 1.0, p, "outgoing")
        rhs = det_twobody(-1e-9 + 1j * y, 1.0, p, "outgoing")
        # phase continuous (measured <= 1e-7 rad); the modulus of the finite slider's
        # Hadamard-normalised regular determinant may jump (measured <= 14 %, see below)
        assert abs(np.angle(lhs / rhs)) < 1e-5
        phys = det_twobody(np.array([1e-9, -1e-9]) + 1j * y, 1.0, p, "physical")
        assert abs(np.angle(phys[0] / phys[1])) > 1e-3  # the physical sheet's phase jumps


@pytest.mark.parametrize("k", [0.1, 1.0, 10.0])
@pytest.mark.parametrize("kw", [TWO_BODY, dict(mu2=1.0, H2=0.5, beta=0.2, beta2=0.65)])
def test_finite_stack_phase_is_continuous_across_the_imaginary_axis(kw, k):
    """Single-valued phase (what the argument principle uses); the modulus jumps a little."""
    p = Params(**kw)
    y = np.linspace(-60.0, 60.0, 2401)
    a = det_twobody(1e-10 + 1j * y, k, p)
    b = det_twobody(-1e-10 + 1j * y, k, p)
    assert np.abs(np.angle(a / b)).max() < 1e-5  # measured <= 6e-7 rad
    # measured <= 0.14 relative: far below the 0.8 that analytic.numerics.roots.winding_number
    # allows
    # between samples (a larger jump would raise ContourError, not miscount)
    assert np.abs(np.abs(a) / np.abs(b) - 1).max() < 0.3


@pytest.mark.parametrize("kw", [HALF, dict(mu2=0.3, rho2=0.8, H2=math.inf, bc="stress")])
def test_half_space_substrate_branch_is_leaky_then_followed_continuously(kw):
    p = Params(**kw)
    L0 = cutoff_twobody(0, -1, p)
    assert L0.real < 0  # radiation at k = 0
    k = 1e-7
    near = roots_in_box(p, k, (L0.real - 0.01, L0.real + 0.01, L0.imag - 0.01, L0.imag + 0.01),
                        sheet="outgoing")
    assert len(near) == 1 and abs(near[0].value - L0) < 1e-6  # measured ~1e-8
    # (beyond k ~ 1.6 the root of the first case passes the branch point -i c_d2 k at a
    # distance ~0.07: the counting boxes meet it and the point is flagged "ambiguous")
    b = follow_branch(p, 0, -1, [0.1, 0.5, 1.0])
    assert b.ok.all(), b.note
    from analytic.physics.twobody import root_sheet

    sheets = [root_sheet(L, kk, p) for L, kk in zip(b.Lambda, b.k, strict=True)]
    assert sheets[0] == "leaky"
    for L, kk, sh in zip(b.Lambda, b.k, sheets, strict=True):
        if L.real > 0:  # a growing root is an eigenvalue: found on the physical sheet too
            assert sh == "physical"
            found = roots_in_box(p, kk, (L.real / 2, L.real * 2, L.imag - 0.1, L.imag + 0.1))
            assert len(found) == 1 and abs(found[0].value - L) < 1e-12 * abs(L)


@pytest.mark.serial
@pytest.mark.parametrize("beta, sigma", [(0.5, 1.0), (0.6, -1.0)])
def test_regular_pairs_in_one_call_equal_each_pair_alone(beta: float, sigma: float) -> None:
    """`_layer` evaluates the four partial-wave pairs of a finite layer in one call of
    `_regular_pair` (sigma, t broadcast): the same fields, bit for bit, as one call per pair,
    including near Lambda = 0 where the divided difference switches to its series."""
    rng = np.random.default_rng(3)
    L = np.concatenate([rng.normal(size=50) * 2 + 1j * rng.normal(size=50) * 20,
                        [1e-9 + 1e-9j, 0.3j, 1e-4]])
    k, H = 1.7, 0.8
    ks, kd = np.sqrt(L * L + k * k), np.sqrt(beta * beta * L * L + k * k)
    P, eps = L * L + 2 * k * k, L * L
    sig = [sigma, -sigma, sigma, -sigma]
    at = [0.0, -sigma * H, sigma * H, 0.0]
    ex = (Ellipsis, None)
    together = _regular_pair(ks[ex], kd[ex], np.full_like(ks, k)[ex], P[ex], eps[ex], beta,
                             np.array(sig), np.array(at))
    assert together.shape == L.shape + (4, 2, 4)
    for j, (s, t) in enumerate(zip(sig, at, strict=True)):
        alone = _regular_pair(ks, kd, np.full_like(ks, k), P, eps, beta, s, t)
        assert np.array_equal(together[:, j], alone)
