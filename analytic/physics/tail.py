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

Not derived (:func:`tail_bound` returns ``None``): ``alpha_pc > 0`` (stress top: the
denominator ``-alpha_pc omega s + a/gamma`` can vanish, the first-order shift does not decay with
``omega``; velocity top: only ``|den| >= |a|`` holds, which the ``e`` term spoils).

A deformable substrate (finite ``mu2``): the resonances are those of the stack's dilatational
rod; :mod:`analytic.physics.tail_stack` derives the first-order shift there and bounds it over
the stack's own phases (not over independent phases, on which it is unbounded). Not derived for
a half-space substrate or slider (``H2`` or ``H`` infinite: no resonances, radiation) nor for
phase rates that are not commensurate (:func:`analytic.physics.tail_stack.period`).
"""

from __future__ import annotations

import math

import numpy as np

from analytic.params import Params
from analytic.physics import tail_stack

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
    if p.alpha_pc > 0:
        return ("no tail bound derived for alpha_pc > 0: the region is not proven to hold the "
                "fastest mode")
    if p.two_body and not (math.isfinite(p.H) and math.isfinite(p.H2)):
        return ("no tail bound derived for a half-space (H or H2 = inf): no thickness "
                "resonances; the region is not proven to hold the fastest mode")
    if p.two_body and tail_stack.period(p) is None:
        return ("no tail bound derived for two bodies whose phase rates H, beta H, H2/c_s2, "
                "H2/c_d2 are not commensurate (ratios p/q, q <= "
                f"{tail_stack.MAX_DENOMINATOR}): shear resonances of the two bodies come "
                "arbitrarily close at high frequency, where the first-order expansion behind the "
                "bound breaks down; "
                "the region is not proven to hold the fastest mode")
    return ""


def phase_factor(p: Params, W: float) -> float:
    """The supremum ``G`` over the resonance phase (module docstring), for ``omega >= W``.

    Returns ``inf`` when ``eps = |Delta - 1| / W`` is too large for the bound (``W`` too small).
    """
    eps = abs(p.Delta - 1.0) / W
    g = p.gamma
    theta = np.linspace(0.0, 0.5 * math.pi, _N_PHASE)  # H omega modulo pi, folded
    s, a = np.sin(theta), np.cos(theta)
    if p.bc == "velocity":
        num = a
        den = np.sqrt(a * a + (s / g) ** 2) - eps * s / g
    else:
        num = 2.0 * p.beta + s
        den = np.sqrt(s * s + (a / g) ** 2) - eps * a / g
    if np.any(den <= 0):
        return math.inf
    r = num / den
    # the grid's resolution: r is smooth in theta; one grid step's change bounds the gap to sup
    return float(r.max() + np.abs(np.diff(r)).max())


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
        :func:`analytic.physics.tail_stack.stack_tail_bound`.
    """
    if why_no_tail_bound(p):
        return None
    k = float(k)
    W = float(W)
    if p.two_body:
        return tail_stack.stack_tail_bound(p, k, W)
    if not (W > max(k, 1.0, abs(p.Delta - 1.0))):
        return math.inf
    f_eff = abs(p.f - p.alpha_ld) + p.alpha_ld / W
    G = phase_factor(p, W)
    return k * f_eff * G * (1.0 + k / W) / (p.beta**2 * p.H * W)
