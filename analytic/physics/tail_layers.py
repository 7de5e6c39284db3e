"""Tail bound of a layered slider on a rigid substrate, from its first-order shift.

The first-order shift of the dilatational resonances (below, :func:`first_order_slope`), and
from it (session 32) :func:`layered_bound`: the shift multiplied out and roots excluded by
moduli, as :mod:`analytic.physics.tail_stack_pc` does for two bodies (the first-order bound
carried over from two bodies had failed its measurement, up to 1.47 of the bound; the
exclusion holds there, docs/design.md section 8.1). ``sweep_k.py --layers-bound yes`` uses it.

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

import functools
import math
from collections.abc import Sequence

import numpy as np
import scipy.optimize

from analytic.law import FrictionLaw
from analytic.params import ParameterError, Params
from analytic.physics import tail_stack_pc as tp
from analytic.physics.layered_exact import ExactLayer
from analytic.physics.tail_stack import TUBE_EPS, period_of_rates


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


# ------------------------------------------------------------------------------------------
# The bound (session 32): tail_stack_pc's exclusion by moduli, carried over to the layers
# ------------------------------------------------------------------------------------------
# Its grid (STEPS_PER_PI), tube (TUBE_POINTS), size limit (MAX_POINTS), dips and test are
# tail_stack_pc's (_OrbitExclusion).


def layer_rates(layers: Sequence[ExactLayer]) -> tuple[np.ndarray, np.ndarray]:
    """``(h, c)`` of every phase, shape ``(n_layers, 2)``: shear and dilatational of each layer."""
    mats = _materials(layers)
    h = np.array([[m[0], m[0]] for m in mats])
    c = np.array([[m[2], m[4]] for m in mats])
    return h, c


def layered_period(layers: Sequence[ExactLayer]) -> float | None:
    """Period in ``omega`` of the ``k = 0`` phases ``h_j omega / c_j``, or ``None``."""
    h, c = layer_rates(layers)
    return period_of_rates((h / c).ravel())


#: Why a graded (profiled) slider has no tail bound (:func:`why_no_layered_bound`).
NO_BOUND_GRADED = ("no tail bound derived for a graded (profiled) layer: its phases have no "
                   "period; the region is not proven to hold the fastest mode")


def why_no_layered_bound(layers: Sequence[ExactLayer]) -> str:
    """Why :func:`layered_bound` has no bound for ``layers`` ("" if it has one)."""
    if not all(lay.constant for lay in layers):
        return NO_BOUND_GRADED
    if layered_period(layers) is None:
        return ("no tail bound derived for layers whose phase rates h/c_s, h/c_d are not "
                "commensurate; the region is not proven to hold the fastest mode")
    return ""


def _grid(layers: Sequence[ExactLayer], k: float, W: float) -> tuple[float, float, float]:
    """``(Omega, step, period)``: where the orbit takes over, the grid step, its period."""
    h, c = layer_rates(layers)
    omega = max(2.0 * W, float(np.max(h * c)) * k * k / TUBE_EPS)
    return (omega, math.pi / (tp.STEPS_PER_PI * float((h / c).sum())),
            float(layered_period(layers)))


def _points(layers: Sequence[ExactLayer], k: float, W: float) -> float:
    """Grid points of :class:`_LayeredExclusion` (exact part, and the orbit at every offset)."""
    omega, step, T = _grid(layers, k, W)
    return (omega - W) / step + T / step * tp.TUBE_POINTS ** (2 * len(layers))


class _LayeredExclusion(tp._OrbitExclusion):
    """The samples of one ``(p, layers, k, W)`` and the exclusion test at a given ``rho``.

    A root ``L = rho + i omega`` of the layered slider solves, to first order in ``k/omega``,
    ``v (a tau - F_0 u) = i k b I`` (:func:`first_order_slope` multiplied out: ``v``, ``s_v``
    the rod's state at the interface, ``u``, ``tau`` the shear solution's, ``I`` the
    reciprocity sum; ``a, F_0, b`` the friction law's shear, slip and normal multipliers). It
    is excluded where ``|v| |a tau - F_0 u| > (1 + 2 c_max k/W) k |b| |I|``.
    """

    def __init__(self, p: Params, layers: Sequence[ExactLayer], k: float, W: float) -> None:
        self.p, self.layers, self.k, self.W = p, list(layers), float(k), float(W)
        self.law = FrictionLaw.from_params(p)
        heights, c = layer_rates(layers)
        self.heights, self.c, self.rates = heights, c, heights / c
        self.margin = 1.0 + 2.0 * float(c.max()) * k / W
        self.omega, self.h, T = _grid(layers, k, W)
        n = int(math.ceil((self.omega - W) / self.h)) + 2
        self.w = np.linspace(W, self.omega, n)
        alpha, gamma = p.alpha_pc, p.gamma

        def axis(which: int):  # noqa: ANN202
            def fun(x: np.ndarray, row: np.ndarray) -> np.ndarray:
                u, tau, v, _, _ = self._states(1j * x, self._exact(1j * x))
                return np.real((v, alpha * tau - u / gamma)[which])
            return fun

        self._axis_dips([axis(q) for q in range(2)])

        # beyond Omega: one period of the k = 0 orbit, the phases lowered by 0 .. h c k^2/Omega
        def orbit(which: int):  # noqa: ANN202
            def fun(t: np.ndarray, row: np.ndarray) -> np.ndarray:
                u, tau, v, _, _ = self._states(1j * self.omega, self._orbit(0.0, t, row))
                return np.real((v, alpha * tau - u / gamma)[which])
            return fun

        self._orbit_samples((heights * c * k * k / self.omega).ravel(), T,
                            [orbit(q) for q in range(2)])

    def _exact(self, L: np.ndarray) -> np.ndarray:
        """The exact phases ``h sqrt(L^2/c^2 + k^2)`` at ``L``, shape ``(n_layers, 2, ...)``."""
        L = np.asarray(L, dtype=complex)
        return self.heights[:, :, None] * np.sqrt((L[None, None, :] / self.c[:, :, None]) ** 2
                                                  + self.k * self.k)

    def _orbit(self, rho: float, x: np.ndarray, row: np.ndarray) -> np.ndarray:
        """The ``k = 0`` phases ``rates (rho + i x)`` lowered by the offsets of ``row``."""
        off = self.offs[row].T.reshape(self.heights.shape + (-1,))
        return self.rates[:, :, None] * (rho + 1j * x)[None, None, :] - 1j * off

    def _states(self, L: np.ndarray, phases: np.ndarray) -> tuple[np.ndarray, ...]:
        """:func:`_response` at amplitude ``L`` (broadcast) and the given phases."""
        L = np.broadcast_to(np.asarray(L, dtype=complex), phases.shape[2:])
        return _response(L, self.p, self.layers, phases)

    def _direct(self, rho: float, w: np.ndarray) -> np.ndarray:
        L = rho + 1j * w
        u, tau, v, _, total = self._states(L, self._exact(L))
        law = self.law
        return (np.abs(v) * np.abs(law.shear(L) * tau - law.slip(L) * u)
                - self.margin * self.k * np.abs(law.normal(L)) * np.abs(total))

    def _tube(self, rho: float, x: np.ndarray, row: np.ndarray) -> np.ndarray:
        """Beyond ``Omega`` at the orbit's phases, for every ``omega >= Omega``.

        At the amplitude ``L0 = i Omega`` (the states are homogeneous in the amplitude: ``v``,
        ``L u`` and the velocity top's ``tau`` do not change with it, the stress top's ``tau``
        and ``L u`` grow with ``|L|``, ``I`` falls as ``1/|L|`` or stays), ``|a tau - F_0 u| >=
        A |L0 u| dist(i tau/(L0 u), sector of i (1 + e)/(gamma a))``.
        """
        p = self.p
        L0 = 1j * self.omega
        u, tau, v, _, total = self._states(L0, self._orbit(rho, x, row))
        r, phi1, phi2, A = tp._sector(p, self.omega, rho)
        lu = L0 * u
        with np.errstate(divide="ignore", invalid="ignore"):
            y = np.where(lu != 0, np.abs(lu) * tp.sector_distance(1j * tau / lu, r, phi1, phi2),
                         np.abs(tau))
        b = abs(p.f - p.alpha_ld) + p.alpha_ld / self.omega
        return np.abs(v) * A * y - self.margin * self.k * b * np.abs(total)

def layered_bound(p: Params, layers: Sequence[ExactLayer], k: float, W: float) -> float | None:
    """Bound on ``Re Lambda`` of every root with ``|Im Lambda| > W``: a layered slider.

    Constant layers on a rigid substrate whose phase rates are commensurate
    (:func:`why_no_layered_bound` otherwise: ``None``). The exclusion of
    :class:`_LayeredExclusion` on the exact phases from ``W`` to ``Omega`` and on one period
    of the ``k = 0`` orbit beyond (docs/design.md 8.1); asymptotic, made safe by measurement
    (tests/test_tail.py against :func:`analytic.physics.layered_exact.det_layered`'s roots).

    Returns:
        The largest ``rho`` not excluded; ``inf`` when ``W <= 2 k c_d`` of a layer (or
        ``max(1, |Delta - 1|)``), when the grids would exceed tail_stack_pc's ``MAX_POINTS``,
        or when ``rho = 4`` is not excluded; ``None`` as said.
    """
    if why_no_layered_bound(layers):
        return None
    k, W = float(k), float(W)
    _, c = layer_rates(layers)
    if not (W > max(2.0 * k * float(c.max()), 1.0, abs(p.Delta - 1.0))):
        return math.inf
    if _points(layers, k, W) > tp.MAX_POINTS:
        return math.inf
    ex = _LayeredExclusion(p, layers, k, W)
    # the whole search on every _SUBSET-th point (its "not excluded" is final), then the whole
    # grid at the result only: one evaluation of the whole grid instead of about seven (a long
    # orbit, 160 000 points: 2.5-5 s a call before); where the whole grid disagrees there, the
    # search of tail_stack_pc (halving on the subset, bisection on the whole grid)
    subset = functools.partial(ex.excluded, every=tp._SUBSET)
    hi = tp._search(subset)
    if hi == 0.0 or not math.isfinite(hi) or ex.excluded(hi):
        return hi
    return tp._search(ex.excluded, subset)
