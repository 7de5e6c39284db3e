"""Half-space spectrum s(z, q), its companion s~, the branch-point variables and the roots."""

import math

import numpy as np
import pytest

from analytic.params import ParameterError, Params
from analytic.physics import halfspace as hs

# Pure numpy (no MPI, no FE): the serial pass is enough.
pytestmark = pytest.mark.serial

RNG = np.random.default_rng(20261121)


def paper_s(z, q, p):
    """Eqs. (spectrum_dimless_generalized)/(g12_dimless) typed literally from the paper."""
    a = np.sqrt(1 - z * z)
    b = np.sqrt(1 - p.beta**2 * z * z)
    g1 = z * z / (1 - a * b)
    g2 = 2 - g1
    return (p.gamma * (1 - 1j * q * z) * (b * g1 * (1 - 1j * p.alpha_pc * q * z) - 1j * p.f * g2)
            + p.gamma * q * p.alpha_ld * g2 * z - 1j * z * (p.Delta - 1j * q * z))


def paper_s_tilde(z, q, p):
    """Eqs. (spectrum_dimless_gap)/(g12_dimless_gap) typed literally (standard model)."""
    a = np.sqrt(1 - z * z)
    b = np.sqrt(1 - p.beta**2 * z * z)
    gt1 = -z * z / (1 + a * b)
    gt2 = 2 + gt1
    return (p.gamma * (1 - 1j * q * z) * (-b * gt1 - 1j * p.f * gt2)
            - 1j * z * (p.Delta - 1j * q * z))


def design_interface(z, q, p):
    """docs/design.md section 3 friction law with the half-space tractions of Eq. (g12).

    sxy = -k_d g1 ux, syy = i k g2 ux (Eq. pert_elastodynamics with G -> g, mu = 1).
    Returns the left-hand side per unit ux.
    """
    lam = -1j * q * z
    kd = q * np.sqrt(1 - p.beta**2 * z * z)
    a = np.sqrt(1 - z * z)
    b = np.sqrt(1 - p.beta**2 * z * z)
    g1 = z * z / (1 - a * b)
    g2 = 2 - g1
    sxy, syy = -kd * g1, 1j * q * g2
    return ((1 + p.alpha_pc * lam) * sxy + (p.f - p.alpha_ld * lam / (lam + 1)) * syy
            - (1 / p.gamma) * lam * (lam + p.Delta) / (lam + 1))


def random_points(n, sign=1.0):
    z = RNG.uniform(-3, 3, n) + 1j * sign * RNG.uniform(0.05, 2, n)
    return z


@pytest.mark.parametrize("apc", [0.0, 0.7])
@pytest.mark.parametrize("ald", [0.0, 0.2])
def test_s_matches_paper_and_design(apc, ald):
    p = Params(alpha_pc=apc, alpha_ld=ald, gamma=2.5)
    for q in (0.3, 4.0):
        z = np.concatenate([random_points(20), random_points(20, -1.0)])
        ref = paper_s(z, q, p)
        got = hs.s(z, q, p)
        # same formula, rearranged: round-off only (measured 3e-15 relative)
        assert np.max(np.abs(got - ref) / (1 + np.abs(ref))) < 1e-12
        # s = -(Lambda + 1) gamma / q * (interface condition of docs/design.md section 3):
        # independent of signs
        lam = -1j * q * z
        alt = -(lam + 1) * p.gamma / q * design_interface(z, q, p)
        assert np.max(np.abs(got - alt) / (1 + np.abs(alt))) < 1e-12


def test_s_tilde_matches_appendix_c():
    p = Params()
    z = np.concatenate([random_points(30), random_points(30, -1.0)])
    for q in (0.1, 2.0):
        ref = paper_s_tilde(z, q, p)
        assert np.max(np.abs(hs.s_tilde(z, q, p) - ref) / (1 + np.abs(ref))) < 1e-12


def test_g1_finite_at_origin():
    # g1(0) = 2/(1+beta^2) (removable singularity of Eq. g12_dimless)
    p = Params(beta=0.45)
    val = hs.g1(0.0, p.beta, hs.kappa_s(0.0), hs.kappa_d(0.0, p.beta))
    assert abs(val - 2 / (1 + p.beta**2)) < 1e-15
    z = 1e-5 + 1e-5j
    lit = z * z / (1 - hs.kappa_s(z) * hs.kappa_d(z, p.beta))
    assert abs(hs.g1(z, p.beta, hs.kappa_s(z), hs.kappa_d(z, p.beta)) - lit) < 1e-5


@pytest.mark.parametrize("branch", ["unstable", "stable"])
def test_kappa_d_functions_are_s_or_s_tilde(branch):
    """In the right half kappa_d-plane each function is s on one quadrant and s~ on the other."""
    p = Params(gamma=3.2, alpha_pc=0.3)
    q = 0.7
    kap = RNG.uniform(0.01, 0.4, 40) + 1j * RNG.uniform(0.01, 0.4, 40)
    below = kap.real - 1j * kap.imag  # 4th quadrant: Im z > 0
    above = kap  # 1st quadrant: Im z < 0
    z_b, z_a = hs.z_from_kappa_d(below, p.beta), hs.z_from_kappa_d(above, p.beta)
    assert np.all(z_b.imag > 0) and np.all(z_a.imag < 0)
    f_b = hs.s_dilatational(below, q, p, branch)
    f_a = hs.s_dilatational(above, q, p, branch)
    phys_b, phys_a = hs.s(z_b, q, p), hs.s(z_a, q, p)
    til_b, til_a = hs.s_tilde(z_b, q, p), hs.s_tilde(z_a, q, p)
    if branch == "unstable":
        np.testing.assert_allclose(f_b, phys_b, rtol=1e-12, atol=1e-13)
        np.testing.assert_allclose(f_a, til_a, rtol=1e-12, atol=1e-13)
    else:
        np.testing.assert_allclose(f_a, phys_a, rtol=1e-12, atol=1e-13)
        np.testing.assert_allclose(f_b, til_b, rtol=1e-12, atol=1e-13)


def test_kappa_s_function_is_s():
    p = Params(gamma=0.25, Delta=0.01)
    kap = RNG.uniform(0.01, 0.5, 30) + 1j * RNG.uniform(-0.5, 0.5, 30)
    z = hs.z_from_kappa_s(kap)
    np.testing.assert_allclose(hs.s_shear(kap, 0.3, p), hs.s(z, 0.3, p), rtol=1e-12, atol=1e-13)


def test_dilatational_roots_and_gap_closure():
    """Fig. comparison/gaps: each kappa_d root is continuous in q and changes sheet at a gap."""
    p = Params(gamma=3.2)  # Gamma = 0.96 (paper's Fig. gaps)
    qs = np.logspace(-3, 2, 60)
    for branch in ("unstable", "stable"):
        roots = hs.follow("dilatational", qs, p, branch=branch)
        assert all(r.converged for r in roots)
        # every root is a root of s or of s~ at the same z (measured <= 4e-14 relative)
        assert max(r.residual_s for r in roots) < 1e-12
        kap = np.array([r.kappa for r in roots])
        assert np.max(np.abs(np.diff(kap))) < 0.02  # continuous (measured 7e-3 per step)
        sheets = [r.sheet for r in roots]
        assert set(sheets) == {"physical", "s_tilde"}
        first_change = sheets.index(sheets[-1])
        assert all(sh == sheets[-1] for sh in sheets[first_change:])  # one change only
    unstable = hs.follow("dilatational", qs, p, branch="unstable")
    assert unstable[0].physical and unstable[0].growth > 0
    # decay depths: k_d = q kappa_d, k_s = q A (docs/design.md section 5, "Half-space")
    r = unstable[0]
    assert abs(r.decay_length_d - 1 / (r.q * r.kappa.real)) < 1e-9 * r.decay_length_d
    # near z = 1/beta both partial waves barely decay: q L_d = 1.5e4 and L_s / L_d = 15
    # (measured at q = 1e-3; the shear wave radiates: z > 1)
    assert r.decay_length_d * r.q > 1e3
    assert r.decay_length_s > 10 * r.decay_length_d
    assert unstable[-1].sheet == "s_tilde"
    # z stays next to 1/beta for every q
    assert max(abs(r.z - 1 / p.beta) for r in unstable) < 1e-3


def test_argument_principle_counts():
    """Checked statements: exactly one physical unstable dilatational/shear root near the branch
    points, none with Im z >= 0.05 in a large box."""
    from analytic.numerics.roots import count_zeros

    p = Params(gamma=4.0)
    q = 0.5
    r = hs.dilatational_root(q, p)
    assert r.physical and r.growth > 0
    box = (1e-9, 0.5, -0.5, -1e-9)  # Re kappa_d > 0, Im kappa_d < 0: physical and unstable
    n = count_zeros(lambda k: hs.s_dilatational(k, q, p, "unstable"), box)
    assert n == 1
    ps = Params(gamma=0.25, Delta=0.0)
    rs = hs.shear_root(0.24, ps)
    assert rs.physical and rs.growth > 0
    n = count_zeros(lambda k: hs.s_shear(k, 0.24, ps), (1e-9, 0.5, 1e-9, 0.5))
    assert n == 1
    assert hs.count_roots(1.0, Params(), (-5.0, 5.0, 0.05, 5.0)) == 0
    with pytest.raises(ParameterError, match="cut"):
        hs.count_roots(1.0, Params(), (-5.0, 5.0, -0.1, 5.0))


def test_shear_and_quasistatic_roots():
    p = Params(gamma=0.25, Delta=0.0)
    r = hs.shear_root(0.25, p)
    assert r.converged and r.physical and r.growth > 0 and abs(r.z + 1) < 0.01
    assert r.residual_s < 1e-14  # measured 8e-17
    pq = Params(f=0.3, beta=0.45, gamma=1e-4 / 0.3, Delta=5e-4)
    best = hs.max_growth("quasistatic", pq)
    assert best.unstable and best.growth > 0
    rq = hs.quasistatic_root(best.q_growth, pq)
    assert rq.physical and abs(rq.z) < 0.05 and rq.residual_s < 1e-13  # |z| measured 0.018


def test_failures_are_reported_not_hidden():
    p = Params()
    # Newton stagnates on the branch cut of w = sqrt(1 - beta^2 - kappa^2): reported, with why
    r = hs.dilatational_root(1.0, p, guess=0.95)
    assert not r.converged and "stagnation" in r.reason
    assert hs.unstable_margin(r) == -math.inf
    # from far away Newton lands on a genuine root of s~ near the imaginary z axis, outside the
    # disc where the kappa_d function describes the dilatational family: flagged as such
    r = hs.dilatational_root(1.0, p, guess=5 + 5j)
    assert r.converged and r.residual_s < 1e-14 and abs(r.kappa) > 1
    assert not hs.in_family(r) and hs.unstable_margin(r) == -math.inf
    assert hs.in_family(hs.dilatational_root(1.0, p))


def test_bad_input():
    with pytest.raises(ParameterError, match="branch"):
        hs.s_dilatational(0.1, 1.0, Params(), branch="up")
    with pytest.raises(ParameterError, match="family"):
        hs.max_growth("rayleigh", Params())
    assert math.isnan(hs.threshold_delta("dilatational", 0.5, 0.3, 0.5, (0.6, 0.9)))


@pytest.mark.parametrize("bc", ["velocity", "stress"])
@pytest.mark.parametrize("case", ["shear", "dilatational", "dilatational_generalized",
                                  "quasistatic"])
def test_finite_h_roots_tend_to_half_space_roots(bc, case):
    """Independent cross-check with det M(Lambda, k, H) (analytic.physics.finite_h): the
    finite-H root polished from the half-space root converges to it as H -> infinity, for both
    top conditions (the paper: they become equivalent for H -> infinity).

    Measured relative differences at H = 20 max(decay lengths): 3e-17 (shear), 2e-16
    (dilatational), 4e-19 (generalized), 5e-13 (quasi-static); at H = 5 max(...): 9e-7, 1.5e-6
    (shear), 1.4e-7, 1.1e-7 (dilatational), 2.8e-8, 2.6e-8 (generalized), so the agreement is
    the limit, not a coincidence.
    """
    from analytic.numerics.branches import polish_root

    if case == "shear":
        p, q, root = Params(gamma=0.25, Delta=0.0), 0.24, hs.shear_root
    elif case == "dilatational":
        p, q, root = Params(gamma=10.0), 1.0, hs.dilatational_root
    elif case == "dilatational_generalized":
        p, q, root = Params(gamma=10.0, alpha_pc=0.5, alpha_ld=0.1), 1.0, hs.dilatational_root
    else:
        p, q, root = Params(f=0.3, beta=0.45, gamma=1e-4 / 0.3, Delta=5e-4), 1.658, \
            hs.quasistatic_root
    r = root(q, p)
    assert r.physical and r.growth > 0
    depth = max(r.decay_length_s, r.decay_length_d)
    far = polish_root(p.replace(H=20 * depth, bc=bc), q, r.Lambda)
    assert far.converged
    assert abs(far.value - r.Lambda) < 1e-12 * abs(r.Lambda)
    if case != "quasistatic":  # the quasi-static root decays over 0.6: already exact at H = 3
        near = polish_root(p.replace(H=5 * depth, bc=bc), q, r.Lambda)
        assert abs(near.value - r.Lambda) > 1e-9 * abs(r.Lambda)


def test_family_edge_thresholds_are_flagged():
    """A 'threshold' where the most unstable root sits on the edge of its family's region is
    where the root leaves the region, not a stability change: MaxGrowth.interior says so.

    Measured (f 0.3, beta 0.45): quasi-static at Gamma = 1e-4 interior (room 0.96); at
    Gamma = 0.0067 the margin is maximal at |z| = 0.5 exactly (room 1e-8).
    """
    f, beta = 0.3, 0.45
    for gamma_f, interior in ((1e-4, True), (0.0067, False)):
        d = hs.threshold_delta("quasistatic", gamma_f, f, beta, (1e-9, 0.1))
        below = hs.max_growth("quasistatic", Params(f=f, beta=beta, gamma=gamma_f / f,
                                                    Delta=d * (1 - 1e-6)))
        assert below.unstable
        assert below.interior == interior
        assert (hs.family_room(below.root_margin) < 1e-3) == (not interior)


def test_gap_interval_fig_gaps():
    """gamma f = 0.96: the unstable root leaves the physical sheet at q = 1.2376 and the stable
    one enters it at q = 1.3529 (measured); in between no physical root near z = 1/beta."""
    from scipy.optimize import brentq

    p = Params(gamma=0.96 / 0.3)
    q_u = brentq(lambda q: hs.dilatational_root(q, p).growth, 0.5, 2.0, xtol=1e-14)
    q_s = brentq(lambda q: hs.dilatational_root(q, p, branch="stable").growth, 0.5, 2.0,
                 xtol=1e-14)
    assert abs(q_u - 1.2376) < 1e-4 and abs(q_s - 1.3529) < 1e-4
    for q in np.linspace(q_u, q_s, 7)[1:-1]:
        assert not hs.dilatational_root(q, p).physical
        assert not hs.dilatational_root(q, p, branch="stable").physical
