"""High-frequency tail of the spectrum at fixed ``k``: a bound on ``Re Lambda`` beyond ``|Im| = W``.

Derivation (docs/design.md section 8.1). At fixed ``k`` and ``|Im Lambda| = omega -> inf`` the
roots approach the strip's dilatational thickness resonances ``cosh(beta H Lambda) = 0`` (the
shear-thickness modes are damped by the direct effect at a rate that stays finite). Around such a
resonance the interface impedances expand exactly as in :mod:`analytic.physics.smallk`, with the
expansion parameter ``k / omega`` instead of ``k`` (``k_s = Lambda + O(k^2/omega)``,
``k_d = beta Lambda + O(k^2/omega)``; the phases of ``cosh``, ``sinh`` at the root are kept
arbitrary, so the phase shifts ``k^2 H / omega`` are covered). The first-order shift is
``dLambda = k c(Lambda)`` with ``c`` the small-k slope evaluated at the root's own frequency::

    velocity: c = -i f_eff ch / (beta^2 H L [(1 + alpha_pc L) ch + (F_0/L) sh])
    stress:   c =  i f_eff (2 beta sd - sh) / (beta^2 H L [(1 + alpha_pc L) sh + (F_0/L) ch])

With ``L = i omega``: ``ch = cos(H omega) = a``, ``sh = i sin(H omega) = i s``, ``|sd| = 1`` at a
resonance, ``F_0/L = (1 + e)/gamma`` with ``|e| = |(Delta - 1)/(L + 1)| <= |Delta - 1|/omega``,
``|f_eff| = |f - alpha_ld + alpha_ld/(L + 1)| <= |f - alpha_ld| + alpha_ld/omega``. For
``alpha_pc = 0``::

    |Re Lambda| <= k |f_eff| G / (beta^2 H omega),
    G_velocity = sup_s |a| / (sqrt(a^2 + s^2/gamma^2) - eps |s|/gamma)
    G_stress   = sup_s (2 beta + |s|) / (sqrt(s^2 + a^2/gamma^2) - eps |a|/gamma)

(``a = cos theta``, ``s = sin theta``, ``eps = |Delta - 1| / W``; the supremum is taken on a fine
grid of ``theta`` and
increased by the grid's resolution). ``G_velocity -> 1`` as ``eps -> 0``; at ``beta = 1/2`` the
velocity bound is the paper's ``4 f k / ((2n+1) pi)`` itself. The neglected terms are relative
``O(k/omega)`` (``k_s/Lambda - 1``, ``P/Lambda^2 - 1``, the second-order shift through the
``H``-dependence of ``sh``): the bound carries the factor ``(1 + k/W)`` for them. This factor is a
margin, not derived; tests/test_tail.py checks the bound against every root computed with the
exact determinant in bands ``W < |Im| < 3 W`` and states the measured ratios.

Prakash-Clifton (``alpha_pc = alpha > 0``), velocity top: the denominator is ``den = a (1 + i
alpha omega) + i s (1 + e)/gamma``. Where ``a`` and ``s`` have the same sign,
``|a + i (alpha omega a + s/gamma)| >= sqrt(a^2 + s^2/gamma^2)`` and the ``alpha_pc = 0`` factor
bounds ``|a| / |den|``. Where they differ (``a >= 0 > s`` after the symmetry ``(a, s) -> (-a,
-s)``), with ``y = alpha omega a``, ``b = |s|/gamma``, ``d = |Delta - 1|``:
``|a| / |den| <= y / (sqrt(y^2 + (alpha omega)^2 (y - b)^2) - alpha d b)``, which is at most
``1/(1 - alpha d / lam)`` for ``y >= lam b`` and at most ``lam / (alpha ((1 - lam) omega - d))``
for ``y <= lam b``, for any ``lam`` in ``(alpha d, 1)`` with ``(1 - lam) W > d`` (the second
term falls with ``omega``: ``W`` bounds it). So ``G_velocity(alpha) = max(G_velocity(0),
min_lam max(...))``: finite iff ``alpha |Delta - 1| < 1``; it tends to ``1/(1 - alpha
|Delta - 1|)``. The minimum over a grid of ``lam`` is a bound as it stands (every ``lam``
gives one). The supremum is attained only where the phase tunes ``alpha omega a + s/gamma``
to 0, which the resonances' own phases seldom do: the bound is loose by up to 1e4 at
``alpha_pc = 1`` (tests/test_tail.py), and proves the fastest mode only for small ``alpha_pc``
(about ``<= 0.1`` at the defaults). So from ``alpha_pc = 0.01`` (:data:`PC_VELOCITY_FROM`,
session 32) the bound is the smaller of it and :func:`pc_velocity_bound` (below).

Prakash-Clifton, stress top (:func:`pc_stress_bound`, session 29). The first-order shift's
denominator ``D = (1 + i alpha omega) i s + (1 + e) a/gamma`` vanishes to ``O(1/omega)`` where
``s ~ a/(gamma alpha_pc omega)``: the shear thickness modes are nearly undamped at high frequency
(their ``Re`` is ``-1/(gamma alpha_pc^2 omega^2 H)``), and where one meets a dilatational
resonance the first-order shift does not decay with ``omega`` and the pair hybridises (the
``alpha_pc = 0`` bound does not hold there, tests/test_tail.py). Multiplying the shift out,
``cosh(beta H L) D(L) = k i f_eff sd (2 beta sd - sh)/(beta L)`` holds both roots of the pair;
with ``|cosh/sinh(beta H L)| >= tanh(beta H rho)`` at any rod phase and the shear phase free,
a root ``rho + i omega`` needs ``tanh(beta H rho) |D| <= k |f_eff| (2 beta cosh(beta H rho) +
|sh|)/(beta omega)``, and the largest such ``rho`` is the bound: ``O(k)`` away from a
coincidence, ``O(sqrt(k f_eff/(alpha_pc beta))/(H omega))`` at one (the pair splits by the
square root of the coupling, ``Re omega`` stays bounded). Asymptotic, made safe by
measurement as the others (tests/test_tail.py).

Prakash-Clifton, velocity top with ``alpha_pc |Delta - 1| >= 1`` (:func:`pc_velocity_bound`,
session 32), where ``G_velocity(alpha)`` is not finite: the same multiplied-out exclusion,
``cosh(beta H L) D(L) = -i k f_eff sd ch/(beta L)`` with ``D = (1 + alpha_pc L) ch + (F_0/L)
sh``; a root needs ``tanh(beta H rho) |D| <= k |f_eff| (1 + k/W) |ch|/(beta omega)`` for some
free shear phase. ``D = 0`` are the shear thickness modes, whose ``Re`` is about ``(alpha_pc
(Delta - 1) - 1)/(gamma alpha_pc^2 omega^2 H)``: with ``alpha_pc (Delta - 1) > 1`` they grow at
every high frequency (falling as ``omega^-2``), and the bound holds them.
Two bodies with ``alpha_pc > 0``: :mod:`analytic.physics.tail_stack_pc` (the
first-order equation multiplied out, roots excluded by moduli at complex ``L``).

A deformable substrate (finite ``mu2``): the resonances are those of the stack's dilatational
rod; :mod:`analytic.physics.tail_stack` derives the first-order shift there and bounds it over
the stack's own phases (not over independent phases, on which it is unbounded). Phase rates
that are not commensurate (:func:`analytic.physics.tail_stack.period` ``None``, any
``alpha_pc``): :mod:`analytic.physics.tail_stack_pc`'s exclusion, exact phases up to ``Omega``
and every real part of the phases beyond. A half-space substrate (``H2`` infinite, any
``alpha_pc``): the same exclusion in the substrate's radiating limit (its sines and cosines
``-i`` and 1), on the slider's phases alone (the free torus of those two beyond ``Omega`` for
an irrational ``beta``). Not derived for a half-space slider (``H`` infinite).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from analytic.params import Params
from analytic.physics import tail_stack, tail_stack_pc

#: Grid points in the phase ``H omega`` (on ``[0, pi/2]``) for the supremum over it.
_N_PHASE = 4001


#: Cap on :func:`velocity_scale`, in units of the slider's ``c_d``.
SCALE_CAP = 4.0


def velocity_scale(p: Params) -> float:
    """The largest dilatational wave speed of the stack, in units of the slider's ``c_s``.

    ``1/beta`` for the rigid substrate; with a deformable substrate also the substrate's
    ``c_d2 = sqrt(mu2/rho2)/beta2``, capped at :data:`SCALE_CAP` times the slider's ``c_d``
    (a cost rule, not a proof: a nearly rigid substrate would otherwise start the ladder at
    ``4 c_d2``). The proof does not depend on it: the stack's tail bound
    (:func:`analytic.physics.tail_stack.stack_tail_bound`) is ``inf`` until ``W > 2 k c_d`` of
    every layer, so the adaptive region climbs past the cap where it must (e.g. ``mu2 = 100``,
    ``k = 2``: proven at ``c_max = 12`` of the capped scale, 96 slider ``c_d``).
    """
    c = 1.0 / p.beta
    if p.two_body:
        c = min(max(c, math.sqrt(p.mu2 / p.rho2) / p.substrate_beta), SCALE_CAP / p.beta)
    return c


def why_no_tail_bound(p: Params) -> str:
    """Why :func:`tail_bound` has no bound for ``p`` ("" if it has one)."""
    if p.two_body and not math.isfinite(p.H):
        return ("no tail bound derived for a half-space slider (H = inf): no thickness "
                "resonances; the region is not proven to hold the fastest mode")
    return ""


def loose_tail_bound(p: Params) -> bool:
    """The bound exists but is far above the roots it bounds (``alpha_pc > 0``, two bodies).

    ``alpha_pc > 0`` in any model, a half-space substrate, or two bodies whose phase rates are
    not commensurate (beyond ``Omega`` the free torus's bound, 0.015-0.08 of it far out).
    Measured (tests/test_tail.py): the fastest root beyond ``W`` reaches 1e-4 .. 0.7 of the
    bound (velocity top), 1e-3 .. 0.8 (stress top), 3e-6 .. 0.75 (two bodies, 87 random
    stacks with a root of positive ``Re`` in the band, docs/design.md 8.1), against
    0.11 .. 0.84 for ``alpha_pc = 0``. Over a half-space substrate the roots beyond ``W`` are
    damped by radiation into it: of 456 random stacks 44 had a root of positive ``Re`` there
    (mostly stress tops with ``alpha_pc > 0``), at most 0.43 of the bound at ``W`` and 0.60 at
    its own frequency.
    The adaptive region does not climb to its top rung for such a bound unless the top rung's
    bound is below the fastest value already found
    (:func:`analytic.numerics.spectrum.provable_region`).
    """
    return (p.alpha_pc > 0 or _by_exclusion(p)) and not why_no_tail_bound(p)


def _by_exclusion(p: Params) -> bool:
    """Two bodies whose bound is :func:`analytic.physics.tail_stack_pc.stack_pc_bound`'s.

    ``alpha_pc > 0``, or phase rates without a common period
    (:func:`analytic.physics.tail_stack.period` ``None``): not commensurate, or a half-space
    substrate, whose rates are infinite.
    """
    return p.two_body and (p.alpha_pc > 0 or tail_stack.period(p) is None)


def phase_factor(p: Params, W: float) -> float:
    """The supremum ``G`` over the resonance phase (module docstring), for ``omega >= W``.

    Returns ``inf`` when ``eps = |Delta - 1| / W`` is too large for the bound (``W`` too small).
    """
    return _phase_factor(p.bc, p.beta, p.gamma, p.Delta, p.alpha_pc, float(W))


@functools.lru_cache(maxsize=1024)
def _phase_factor(bc: str, beta: float, gamma: float, delta: float, alpha_pc: float, W: float
                  ) -> float:
    """:func:`phase_factor` of the parameters it depends on, remembered.

    Session 26: the adaptive region asked for the same rungs' bounds four to five times per
    ``k`` (0.2 ms each).
    """
    eps = abs(delta - 1.0) / W
    g = gamma
    theta = np.linspace(0.0, 0.5 * math.pi, _N_PHASE)  # H omega modulo pi, folded
    s, a = np.sin(theta), np.cos(theta)
    if bc == "velocity":
        num = a
        den = np.sqrt(a * a + (s / g) ** 2) - eps * s / g
    else:
        num = 2.0 * beta + s
        den = np.sqrt(s * s + (a / g) ** 2) - eps * a / g
    if np.any(den <= 0):
        return math.inf
    r = num / den
    # the grid's resolution: r is smooth in theta; one grid step's change bounds the gap to sup
    g0 = float(r.max() + np.abs(np.diff(r)).max())
    if alpha_pc == 0 or bc != "velocity":
        return g0
    return max(g0, _prakash_clifton_factor(alpha_pc, abs(delta - 1.0), W))


def _prakash_clifton_factor(alpha: float, d: float, W: float) -> float:
    """``min_lam max(1/(1 - alpha d/lam), lam/(alpha ((1 - lam) W - d)))`` (module docstring).

    Every ``lam`` in ``(alpha d, 1)`` with ``(1 - lam) W > d`` gives a bound, so the minimum
    over a grid is one; ``inf`` if no ``lam`` qualifies.
    """
    lam = alpha * d + (1.0 - alpha * d) * np.linspace(0.0, 1.0, 20001)[1:-1]
    lam = lam[(1.0 - lam) * W > d]
    if lam.size == 0:
        return math.inf
    return float(np.max([1.0 / (1.0 - alpha * d / lam),
                         lam / (alpha * ((1.0 - lam) * W - d))], axis=0).min())


#: Phase grid (``H omega`` on ``[0, pi)``) of the Prakash-Clifton stress bound, refined twice
#: around each minimum (:func:`_pc_min_ratio`).
_PC_THETA = np.linspace(0.0, math.pi, 256, endpoint=False)
_PC_COS, _PC_SIN = np.cos(_PC_THETA), np.sin(_PC_THETA)

#: Frequencies, in units of ``W``, at which :func:`pc_stress_bound` takes its supremum over
#: ``omega >= W`` (``rho*(omega) omega`` stays within about 20 % of a constant beyond ``W``,
#: measured: so past ``10 W`` the bound is below its value at ``10 W``).
PC_OMEGA = (1.0, 1.1, 1.25, 1.5, 2.0, 3.0, 5.0, 10.0)

#: Growth rates scanned (geometric, ratio 2, 1e-7 .. 13) before the bisection of
#: :func:`pc_stress_bound` (the set of ``rho`` that pass is an interval from 0: checked against a
#: scan with ratio 1.02, tests/test_tail.py).
_PC_RHO = 1e-7 * 2.0 ** np.arange(28)


def _pc_ratio(c: tuple[float, ...], rho: np.ndarray, om: np.ndarray, cos: np.ndarray,
              sin: np.ndarray, bc: str = "stress") -> np.ndarray:
    """``tanh(beta H rho) |D| / RHS`` of :func:`pc_stress_bound` (broadcast over the arrays).

    ``c = (H, beta, alpha_pc, gamma, Delta, K)``; ``rho``, ``om`` the growth rate and frequency
    of ``L = rho + i omega``; ``cos``, ``sin`` of the shear phase ``theta`` (``H omega`` taken
    as free). ``bc = "velocity"``: :func:`pc_velocity_bound`'s, ``D = (1 + alpha_pc L) ch +
    (F_0/L) sh`` against ``K |ch| / (beta omega)``.
    """
    H, beta, alpha, gamma, delta, K = c
    x = H * rho
    shx, chx = np.sinh(x), np.cosh(x)
    sh = shx * cos + 1j * chx * sin  # sinh(x + i theta)
    ch = chx * cos + 1j * shx * sin  # cosh(x + i theta)
    L = rho + 1j * om
    f0 = (L + delta) / (gamma * (L + 1.0))  # F_0 / L
    if bc == "velocity":
        D = (1.0 + alpha * L) * ch + f0 * sh
        rhs = K * np.abs(ch)
    else:
        D = (1.0 + alpha * L) * sh + f0 * ch
        rhs = K * (2.0 * beta * np.cosh(beta * H * rho) + np.abs(sh))
    lhs = np.tanh(beta * H * rho) * np.abs(D)
    return lhs * (beta * om) / rhs


def _pc_min_ratio(c: tuple[float, ...], rho: np.ndarray, om: np.ndarray, bc: str = "stress"
                  ) -> np.ndarray:
    """Minimum of :func:`_pc_ratio` over the phase, for each pair ``(rho[i], om[i])``.

    The grid's minimum is refined twice on finer grids around it (the dip of ``|D|`` is as
    narrow as ``H rho`` where the shear mode is nearly undamped).
    """
    rho, om = rho[:, None], om[:, None]
    r = _pc_ratio(c, rho, om, _PC_COS, _PC_SIN, bc)
    best = r.min(axis=1)
    t0 = _PC_THETA[np.argmin(r, axis=1)][:, None]
    for half in (2.0 * math.pi / _PC_THETA.size, 0.1 * math.pi / _PC_THETA.size):
        th = t0 + np.linspace(-half, half, 41)[None, :]
        r = _pc_ratio(c, rho, om, np.cos(th), np.sin(th), bc)
        best = np.minimum(best, r.min(axis=1))
        t0 = np.take_along_axis(th, np.argmin(r, axis=1)[:, None], 1)
    return best


def f_eff_bound(p: Params, W: float) -> float:
    """``|f_eff| <= |f - alpha_ld| + alpha_ld/W`` beyond ``W`` (both rigid bounds)."""
    return abs(p.f - p.alpha_ld) + p.alpha_ld / W


def pc_constants(p: Params, k: float, W: float) -> tuple[float, ...]:
    """``(H, beta, alpha_pc, gamma, Delta, K)`` of :func:`_pc_ratio`.

    ``K = k |f_eff| (1 + k/W)``: the coupling with the rigid bound's margin.
    """
    return (p.H, p.beta, p.alpha_pc, p.gamma, p.Delta,
            k * f_eff_bound(p, W) * (1.0 + k / W))


@functools.lru_cache(maxsize=4096)
def _pc_bound(c: tuple[float, ...], W: float, bc: str = "stress") -> float:
    """:func:`pc_stress_bound` (or :func:`pc_velocity_bound`) of its constants, remembered.

    ``c``: :func:`pc_constants`.
    """
    om = W * np.asarray(PC_OMEGA)
    rho_g, om_g = np.meshgrid(_PC_RHO, om)
    holds = (_pc_min_ratio(c, rho_g.ravel(), om_g.ravel(), bc) <= 1.0).reshape(rho_g.shape)
    if holds[:, -1].any():
        return math.inf
    last = np.array([np.nonzero(h)[0][-1] if h.any() else -1 for h in holds])
    lo = np.where(last >= 0, _PC_RHO[np.maximum(last, 0)], 0.0)
    hi = _PC_RHO[last + 1]
    for _ in range(14):  # hi / lo from 2 to 2^(1/16384)
        mid = np.where(lo > 0, np.sqrt(lo * hi), 0.5 * hi)
        ok = _pc_min_ratio(c, mid, om, bc) <= 1.0
        lo, hi = np.where(ok, mid, lo), np.where(ok, hi, mid)
    return float(hi.max())


def pc_stress_bound(p: Params, k: float, W: float) -> float:
    """Bound on ``Re Lambda`` beyond ``|Im| = W``: stress top, ``alpha_pc > 0``, rigid substrate.

    The hybridised pair (module docstring; docs/design.md 8.1): near a dilatational resonance
    the roots solve, to first order in ``k/omega``,
    ``cosh(beta H L) D(L) = k i f_eff sd (2 beta sd - sh)/(beta L)`` with the shear factor
    ``D = (1 + alpha_pc L) sh + (F_0/L) ch`` (the first-order shift ``c`` of the module
    docstring multiplied out, so that a zero of ``D`` near the resonance, a nearly undamped
    shear mode, is a second root of the pair, not a pole). A root at ``L = rho + i omega``,
    ``rho > 0``, needs ``tanh(beta H rho) |D| <= k |f_eff| (2 beta cosh(beta H rho) + |sh|)/
    (beta omega)`` (``|cosh/sinh|(beta H L) >= tanh(beta H rho)`` at any rod phase) for some
    shear phase ``theta = H omega``, taken as free. The bound is the largest such ``rho`` over
    ``omega`` in ``W`` times :data:`PC_OMEGA`, with the margin ``(1 + k/W)`` of the rigid bound.
    Near a coincidence of the two resonances it is ``O(sqrt(k f/(alpha_pc beta))/(H omega))``,
    not ``O(k)``: the pair splits by the square root of the coupling.

    Args:
        p: Parameters (stress top; any ``alpha_pc >= 0``, ``alpha_ld``).
        k: Wavenumber ``> 0``.
        W: Frequency beyond which the bound holds.

    Returns:
        The bound, ``inf`` when ``W <= max(k, 1, |Delta - 1|)`` or when it exceeds the scanned
        range (``rho`` about 7).
    """
    return _pc_checked(p, k, W, "stress")


#: Smallest ``alpha_pc`` from which the velocity top's bound is also :func:`pc_velocity_bound`
#: (the smaller of the two) where ``G(alpha_pc)`` is finite. Measured (session 32, 70 random
#: stacks, ``alpha_pc |Delta - 1| < 1``, bands ``W .. 2 W``): the exclusion bound is as tight
#: as the first-order one at small ``alpha_pc`` (a root at 0.998 of it at ``alpha_pc = 8e-4``,
#: 0.985 at 0.0027), at most 0.945 of it from 0.01 on (0.91 at 0.018, 0.86 at 0.027, at most
#: 0.68 from 0.05 on), and far below the ``G`` bound there (``alpha_pc = 0.1``, ``k = 5``:
#: 0.055 against 0.205).
PC_VELOCITY_FROM = 0.01


def pc_velocity_bound(p: Params, k: float, W: float) -> float:
    """Bound on ``Re Lambda`` beyond ``|Im| = W``: velocity top, ``alpha_pc |Delta - 1| >= 1``.

    The velocity top's first-order shift multiplied out as :func:`pc_stress_bound`'s:
    ``cosh(beta H L) D(L) = -i k f_eff sd ch/(beta L)`` with ``D = (1 + alpha_pc L) ch + (F_0/L)
    sh``, so a root ``rho + i omega``, ``rho > 0``, needs ``tanh(beta H rho) |D| <= k |f_eff|
    |ch|/(beta omega)`` for some free shear phase; the largest such ``rho`` over ``omega`` in
    ``W`` times :data:`PC_OMEGA`, with the margin ``(1 + k/W)``. A zero of ``D`` is a shear
    thickness mode: with ``alpha_pc (Delta - 1) > 1`` they grow at every high frequency (``Re``
    about ``(alpha_pc (Delta - 1) - 1)/(gamma alpha_pc^2 omega^2 H)``), and the bound holds
    them too (docs/design.md 8.1). Arguments and value as :func:`pc_stress_bound`'s (a velocity
    top, any ``alpha_pc > 0``).
    """
    return _pc_checked(p, k, W, "velocity")


def _pc_checked(p: Params, k: float, W: float, bc: str) -> float:
    """:func:`_pc_bound` of ``p``, ``inf`` when ``W <= max(k, 1, |Delta - 1|)``."""
    k, W = float(k), float(W)
    if not (W > max(k, 1.0, abs(p.Delta - 1.0))):
        return math.inf
    return _pc_bound(pc_constants(p, k, W), W, bc)


def tail_bound(p: Params, k: float, W: float) -> float | None:
    """Upper bound on ``Re Lambda`` of every root with ``|Im Lambda| > W`` at wavenumber ``k``.

    Args:
        p: Parameters (see the module docstring for what is derived).
        k: Wavenumber ``> 0``.
        W: Frequency ``> 0`` beyond which the bound holds (the region's ``im_max``).

    Returns:
        ``k |f_eff| G (1 + k/W) / (beta^2 H W)`` (module docstring), ``inf`` when ``W`` is too
        small for the expansion (``W <= max(k, 1, |Delta - 1|)``), or ``None`` when no bound is
        derived for ``p`` (:func:`why_no_tail_bound`). Two bodies:
        :func:`analytic.physics.tail_stack.stack_tail_bound`, with ``alpha_pc > 0``, over a
        half-space or for phase rates not commensurate
        :func:`analytic.physics.tail_stack_pc.stack_pc_bound`.
    """
    if why_no_tail_bound(p):
        return None
    k = float(k)
    W = float(W)
    if p.two_body:
        if _by_exclusion(p):
            return tail_stack_pc.stack_pc_bound(p, k, W)
        return tail_stack.stack_tail_bound(p, k, W)
    if p.bc == "stress" and p.alpha_pc > 0:
        return pc_stress_bound(p, k, W)
    if p.alpha_pc * abs(p.Delta - 1.0) >= 1.0:  # velocity top: G(alpha_pc) is not finite
        return pc_velocity_bound(p, k, W)
    if not (W > max(k, 1.0, abs(p.Delta - 1.0))):
        return math.inf
    f_eff = f_eff_bound(p, W)
    G = phase_factor(p, W)
    first = k * f_eff * G * (1.0 + k / W) / (p.beta**2 * p.H * W)
    if p.alpha_pc >= PC_VELOCITY_FROM:  # both hold; the exclusion is the tighter one mostly
        return min(first, pc_velocity_bound(p, k, W))
    return first
