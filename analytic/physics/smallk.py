"""Small-k waveguide asymptotics (the paper's section 4, Eq. Hspectrum, Appendix A).

Near the cut-off ``Lambda_0 = sign i (2n+1) pi / (2 beta H)`` a branch is
``Lambda(k) = Lambda_0 + c k + O(k^2)``. Expanding the interface impedances
(``s_xy = -Z_1 u_x``, ``s_yy = i k Z_2 u_x``) around ``(Lambda_0, k = 0)`` with ``dLambda ~ k``
(Appendix A; done with sympy for both top conditions) gives ``Z_1 -> Z_10`` and
``k Z_2 -> (k / dLambda) X / (beta^2 H)`` with, writing ``L = Lambda_0``, ``sh = sinh(H L)``,
``ch = cosh(H L)``, ``sd = sinh(beta H L)``:

- velocity top: ``Z_10 = L ch/sh``, ``X = -ch/sh``;
- stress top:   ``Z_10 = L sh/ch``, ``X = (-sh + 2 beta sd)/ch``.

Inserting into the friction law (docs/design.md section 3) and clearing ``sh``, ``ch``::

    velocity: c = -i f_eff ch / (beta^2 H [(1 + alpha_pc L) L ch + F_0 sh])
    stress:   c = i f_eff (2 beta sd - sh) / (beta^2 H [(1 + alpha_pc L) L sh + F_0 ch])

with ``F_0 = L (L + Delta) / (gamma (L + 1))`` and ``f_eff = f - alpha_ld L / (L + 1)``. These
forms have no apparent divergence. The real part of the velocity form is exactly the paper's
Eq. (Hspectrum) (standard model), which carries ``1/tan(H |Lambda_0|)`` factors that are 0/0 at
``beta = 1/2`` (``sh = 0`` there). At ``beta = 1/2``, ``c = -i f / (beta^2 H L) = -+ 4 f/((2n+1)
pi)``: the paper's ``Re Lambda = 4 f k / ((2n+1) pi)`` for the unstable (``sign = -1``) branch.
When ``ch = 0`` (``beta = (2n+1)/(2m+1)``, e.g. ``1/3``) the velocity-top slope vanishes.
"""

from __future__ import annotations

import math

import numpy as np

from analytic.law import FrictionLaw
from analytic.params import ParameterError, Params, check_k
from analytic.physics.finite_h import cutoff


def slope(n: int, sign: int, p: Params) -> complex:
    """``c = dLambda/dk`` at ``k = 0`` on branch ``(n, sign)`` (both top conditions).

    Args:
        n: Cut-off index ``n >= 0``.
        sign: ``+1`` or ``-1`` (sign of ``Im Lambda_0``).
        p: Parameters (finite ``H``; any ``bc``, ``alpha_pc``, ``alpha_ld``).

    Returns:
        The complex slope; ``Lambda(k) ~ cutoff(n, sign, p) + slope * k``.
    """
    L = cutoff(n, sign, p)
    H = p.H
    sh, ch = np.sinh(H * L), np.cosh(H * L)
    law = FrictionLaw.from_params(p)
    F0, f_eff, a0 = law.slip(L), law.normal(L), law.shear(L)
    if p.bc == "velocity":
        return complex(-1j * f_eff * ch / (p.beta**2 * H * (a0 * L * ch + F0 * sh)))
    sd = np.sinh(p.beta * H * L)
    den = p.beta**2 * H * (a0 * L * sh + F0 * ch)
    return complex(1j * f_eff * (2.0 * p.beta * sd - sh) / den)


def lambda_smallk(k: float | np.ndarray, n: int, sign: int, p: Params) -> np.ndarray:
    """Linear small-k approximation ``Lambda_0 + slope * k`` of branch ``(n, sign)``."""
    kk = check_k(k)
    return cutoff(n, sign, p) + slope(n, sign, p) * kk


def growth_rate_paper(k: float | np.ndarray, n: int, p: Params, sign: int = -1) -> np.ndarray:
    """The paper's Eq. (Hspectrum) literally: ``Re Lambda`` to O(k), velocity top, standard model.

    The paper's ``-+`` goes with ``Lambda_0 = +- i |Lambda_0|``: ``sign = -1`` (lower sign) is
    the unstable branch when the bracket is positive.

    Raises:
        ParameterError: If ``tan(H |Lambda_0|)`` vanishes (``beta (2n+1)`` makes
            ``H |Lambda_0|`` a multiple of ``pi``, e.g. ``beta = 1/2``): use :func:`slope`,
            which has no such apparent divergence.
    """
    kk = check_k(k)
    L0abs = (2 * n + 1) * math.pi / (2.0 * p.beta * p.H)
    T = math.tan(p.H * L0abs)
    if abs(T) < 1e-12:
        raise ParameterError(
            f"beta = {p.beta}: tan(H |Lambda_0|) = 0, Eq. (Hspectrum) is 0/0 here; use slope()"
        )
    lam0 = L0abs  # lambda_0 = Lambda_0 in these units
    A = L0abs / T
    B = L0abs / p.gamma * lam0 * (1.0 - p.Delta) / (1.0 + lam0**2)
    C = L0abs / p.gamma * (p.Delta + lam0**2) / (1.0 + lam0**2)
    pref = p.f * kk / (p.beta**2 * p.H * T)
    upper = -pref * (A - B) / ((A - B) ** 2 + C**2)  # the paper's upper sign: Lambda_0 = +i|.|
    return upper if sign > 0 else -upper


def growth_rate_beta_half(k: float | np.ndarray, n: int, p: Params) -> np.ndarray:
    """The paper's ``beta = 1/2`` limit ``Re Lambda = 4 f k / ((2n+1) pi)`` (unstable branch).

    Raises:
        ParameterError: If ``p.beta != 0.5`` or ``p.bc != 'velocity'`` or a generalized model.
    """
    if p.beta != 0.5 or p.bc != "velocity" or p.generalized:
        raise ParameterError("the 4 f k/((2n+1) pi) limit needs beta = 0.5, bc = velocity and"
                             " the standard model")
    return 4.0 * p.f * check_k(k) / ((2 * n + 1) * math.pi)
