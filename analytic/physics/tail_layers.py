"""First-order shift of a layered slider's dilatational resonances on a rigid substrate.

A first step towards a tail bound for layered sliders (docs/design.md section 8.1): no bound
(the two-body method carried over failed its measurement, up to 1.47 of the bound), and
nothing uses it in the sweep.

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


def _down(state: tuple[np.ndarray, np.ndarray], amp: np.ndarray, phase: np.ndarray
          ) -> tuple[np.ndarray, np.ndarray]:
    """``(u, s)`` at a layer's bottom from its top: ``u'' = q^2 u``, ``s = stiff u'``.

    ``amp = stiff q`` and ``phase = q h`` are given separately (the bound uses the exact
    ``k``-dependent phase with the ``k = 0`` amplitude).
    """
    u, s = state
    ch, sh = np.cosh(phase), np.sinh(phase)
    return u * ch - s * sh / amp, s * ch - amp * u * sh


def _layer_integral(shear: tuple, rod: tuple, q: np.ndarray, p: np.ndarray, ph: tuple,
                    mu: float, M: float) -> np.ndarray:
    """``integral (s_xy v - lambda v' u_x) dy`` over one layer from the states at its bottom."""
    lam = M - 2.0 * mu
    a, a_ = 0.5 * (shear[0] + shear[1] / (mu * q)), 0.5 * (shear[0] - shear[1] / (mu * q))
    b, b_ = 0.5 * (rod[0] + rod[1] / (M * p)), 0.5 * (rod[0] - rod[1] / (M * p))
    fs, fd = ph

    def E(s: np.ndarray, phase: np.ndarray) -> np.ndarray:  # noqa: N802
        return np.expm1(phase) / s

    plus, minus = mu * q - lam * p, mu * q + lam * p
    return (a * b * plus * E(q + p, fs + fd) + a * b_ * minus * E(q - p, fs - fd)
            - a_ * b * minus * E(p - q, fd - fs) - a_ * b_ * plus * E(-q - p, -fs - fd))


def _response(L: np.ndarray, p: Params, layers: Sequence[ExactLayer],
              phases: np.ndarray | None = None) -> tuple[np.ndarray, ...]:
    """``(u_x(0), s_xy(0), v(0), s_v(0), I)`` of the shear and rod solutions (module docstring).

    ``phases``: shape ``(n_layers, 2, ...)`` shear and dilatational phases ``q h`` per layer
    (bottom layer first); default ``L h / c``.
    """
    mats = _materials(layers)
    L = np.asarray(L, dtype=complex)
    one, zero = np.ones_like(L), np.zeros_like(L)
    shear = (zero, one) if p.bc == "velocity" else (one, zero)
    rod = (one, zero)
    total = np.zeros_like(L)
    for j in reversed(range(len(mats))):
        h, mu, cs, M, cd = mats[j]
        q, pd = L / cs, L / cd
        ph = (q * h, pd * h) if phases is None else (phases[j, 0], phases[j, 1])
        shear = _down(shear, mu * q, ph[0])
        rod = _down(rod, M * pd, ph[1])
        total = total + _layer_integral(shear, rod, q, pd, ph, mu, M)
    return shear[0], shear[1], rod[0], rod[1], total


def compliances(L: complex, p: Params, layers: Sequence[ExactLayer]
                ) -> tuple[complex, complex, complex]:
    """``(C_11, C_22, C_21 / k)`` of the layered slider at ``k = 0`` (module docstring)."""
    u, tau, v, sv, total = (complex(x) for x in _response(np.asarray(L), p, layers))
    return u / tau, v / sv, 1j * total / (sv * tau)


def rod_resonances(p: Params, layers: Sequence[ExactLayer], w_max: float, n_grid: int = 20001
                   ) -> np.ndarray:
    """Frequencies ``0 < omega < w_max`` where the clamped-free rod resonates (``v(0) = 0``)."""
    def v0(w: float) -> float:
        return float(_response(np.asarray(1j * w), p, layers)[2].real)

    ws = np.linspace(1e-6 * w_max, w_max, n_grid)
    vals = np.array([v0(w) for w in ws])
    i = np.nonzero(np.sign(vals[:-1]) * np.sign(vals[1:]) < 0)[0]
    return np.array([scipy.optimize.brentq(v0, ws[j], ws[j + 1], xtol=1e-14) for j in i])


def first_order_slope(L0: complex, p: Params, layers: Sequence[ExactLayer]) -> complex:
    """``dLambda/dk`` at ``k = 0`` of the root at the rod resonance ``L0`` (``alpha_pc`` any)."""
    law = FrictionLaw.from_params(p)
    C11, _, C21k = compliances(L0, p, layers)
    d = 1e-6 * abs(L0)
    dC22 = (compliances(L0 + d, p, layers)[1] - compliances(L0 - d, p, layers)[1]) / (2.0 * d)
    return complex(law.normal(L0) * C21k / (dC22 * (law.shear(L0) - law.slip(L0) * C11)))
