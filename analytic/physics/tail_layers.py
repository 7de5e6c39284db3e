"""First-order shift of a layered slider's dilatational resonances on a rigid substrate.

A first step towards a tail bound for layered sliders (docs/design.md section 8.1): no bound
yet, and nothing uses it in the sweep.

Piecewise-constant layers (:class:`analytic.physics.layered_exact.ExactLayer` with constant
coefficients) on a rigid substrate. At ``k = 0`` the ``x`` and ``y`` motions decouple; the
``y`` part is a rod clamped at ``y = 0`` (``u_y = 0``) and free at the top, with resonances
``v(0; Lambda) = 0`` (``v``: the rod's solution with ``s_yy = 0`` at the top). As in
:mod:`analytic.physics.tail_stack`, with the slider's interface compliances ``C`` (``u`` from
``(s_xy, s_yy)`` at ``y = 0``) the conditions are ``C_21 b - C_22 (a - F_0 C_11) = 0`` to first
order, ``C_22 = v(0)/s_v(0)`` vanishes at the resonance, and by reciprocity against ``v``
(the state ``(u_x, u_y, s_xy, s_yy)`` is continuous across welded layers, so the boundary terms
telescope)::

    C_21 = i k / (s_v(0) tau) * sum over layers of integral (s_xy v - lambda_j v' u_x) dy

with ``u_x, s_xy`` the shear solution of the top condition and ``tau = s_xy(0)``. So
``dLambda/dk = b C_21 / (k C_22' (a - F_0 C_11))``, ``C_22' = dC_22/dLambda`` (a central
difference here). Each layer's integral is in closed form (exponentials). Checked against
:func:`analytic.physics.layered_exact.det_layered` (tests/test_tail.py); for one layer it is
:func:`analytic.physics.smallk.slope`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import scipy.optimize

from analytic.law import FrictionLaw
from analytic.params import ParameterError, Params
from analytic.physics.layered_exact import ExactLayer


def _materials(layers: Sequence[ExactLayer]) -> list[tuple[float, float, float, float, float]]:
    """Per layer ``(h, mu, c_s, M, c_d)``, top layer last; constant layers only."""
    out = []
    for lay in layers:
        if not lay.constant:
            raise ParameterError("a graded (profiled) layer: tail_layers needs constant layers")
        mu, rho, beta = lay.values(lay.bottom)
        cs = math.sqrt(mu / rho)
        out.append((lay.top - lay.bottom, mu, cs, mu / beta**2, cs / beta))
    return out


def _down(state: tuple[complex, complex], q: complex, stiff: float, h: float
          ) -> tuple[complex, complex]:
    """``(u, s)`` at a layer's bottom from its top (``u'' = q^2 u``, ``s = stiff u'``)."""
    u, s = state
    ch, sh = np.cosh(q * h), np.sinh(q * h)
    return u * ch - s * sh / (stiff * q), s * ch - stiff * q * u * sh


def _layer_integral(shear: tuple[complex, complex], rod: tuple[complex, complex], q: complex,
                    p: complex, mu: float, M: float, h: float) -> complex:
    """``integral_0^h (s_xy v - lambda v' u_x) dy`` from the states at the layer's bottom."""
    lam = M - 2.0 * mu
    a, a_ = 0.5 * (shear[0] + shear[1] / (mu * q)), 0.5 * (shear[0] - shear[1] / (mu * q))
    b, b_ = 0.5 * (rod[0] + rod[1] / (M * p)), 0.5 * (rod[0] - rod[1] / (M * p))

    def E(s: complex) -> complex:  # noqa: N802
        return complex(np.expm1(s * h) / s)

    plus, minus = mu * q - lam * p, mu * q + lam * p
    return (a * b * plus * E(q + p) + a * b_ * minus * E(q - p)
            - a_ * b * minus * E(p - q) - a_ * b_ * plus * E(-q - p))


def compliances(L: complex, p: Params, layers: Sequence[ExactLayer]
                ) -> tuple[complex, complex, complex]:
    """``(C_11, C_22, C_21 / k)`` of the layered slider at ``k = 0`` (module docstring)."""
    mats = _materials(layers)
    shear = (0.0 + 0j, 1.0 + 0j) if p.bc == "velocity" else (1.0 + 0j, 0.0 + 0j)
    rod = (1.0 + 0j, 0.0 + 0j)
    total = 0j
    for h, mu, cs, M, cd in reversed(mats):
        q, pd = L / cs, L / cd
        shear = _down(shear, q, mu, h)
        rod = _down(rod, pd, M, h)
        total += _layer_integral(shear, rod, q, pd, mu, M, h)
    return shear[0] / shear[1], rod[0] / rod[1], 1j * total / (rod[1] * shear[1])


def rod_resonances(p: Params, layers: Sequence[ExactLayer], w_max: float, n_grid: int = 20001
                   ) -> np.ndarray:
    """Frequencies ``0 < omega < w_max`` where the clamped-free rod resonates (``v(0) = 0``)."""
    def v0(w: float) -> float:
        return _rod_v0(1j * w, layers)

    ws = np.linspace(1e-6 * w_max, w_max, n_grid)
    vals = np.array([v0(w) for w in ws])
    i = np.nonzero(np.sign(vals[:-1]) * np.sign(vals[1:]) < 0)[0]
    return np.array([scipy.optimize.brentq(v0, ws[j], ws[j + 1], xtol=1e-14) for j in i])


def _rod_v0(L: complex, layers: Sequence[ExactLayer]) -> float:
    """``v(0)`` of the rod free at the top (``v = 1`` there), real on the imaginary axis."""
    rod = (1.0 + 0j, 0.0 + 0j)
    for h, _mu, _cs, M, cd in reversed(_materials(layers)):
        rod = _down(rod, L / cd, M, h)
    return float(rod[0].real)


def first_order_slope(L0: complex, p: Params, layers: Sequence[ExactLayer]) -> complex:
    """``dLambda/dk`` at ``k = 0`` of the root at the rod resonance ``L0`` (``alpha_pc`` any)."""
    law = FrictionLaw.from_params(p)
    C11, _, C21k = compliances(L0, p, layers)
    d = 1e-6 * abs(L0)
    dC22 = (compliances(L0 + d, p, layers)[1] - compliances(L0 - d, p, layers)[1]) / (2.0 * d)
    return complex(law.normal(L0) * C21k / (dC22 * (law.shear(L0) - law.slip(L0) * C11)))
