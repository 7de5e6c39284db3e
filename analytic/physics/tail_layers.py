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
    ch, sh = _cosh_sinh(phase)
    return u * ch - s * sh / amp, s * ch - amp * u * sh


def _cosh_sinh(phase: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``cosh`` and ``sinh`` of complex phases from four real functions of their parts.

    ``cosh(x + i y) = cosh x cos y + i sinh x sin y``, ``sinh(x + i y) = sinh x cos y + i cosh
    x sin y``: the bound's hot spot (session 35: numpy's complex ``cosh`` and ``sinh`` were 1.6
    of the damage zone's 4.9 s of bounds at 24 ``k``).
    """
    z = np.asarray(phase, dtype=complex)
    x, y = z.real, z.imag
    chx, shx, c, s = np.cosh(x), np.sinh(x), np.cos(y), np.sin(y)
    return chx * c + 1j * (shx * s), shx * c + 1j * (chx * s)


def _layer_integral(shear: tuple, rod: tuple, amps: tuple, ph: tuple, ratios: tuple[float, float]
                    ) -> np.ndarray:
    """``integral (s_xy v - lambda v' u_x) dy`` over one layer from the states at its bottom.

    ``amps = (mu q, M p)`` (:func:`_down`'s), ``ph`` the shear and dilatational phases,
    ``ratios`` the layer's :func:`_ratios`. In the up- and down-going amplitudes ``a, a_`` (shear)
    and ``b, b_`` (rod) it is ``(mu q - lam p) [a b E(q + p, fs + fd) - a_ b_ E(-q - p, -fs -
    fd)] + (mu q + lam p) [a b_ E(q - p, fs - fd) - a_ b E(p - q, fd - fs)]`` with ``E(s, f) =
    expm1(f)/s``; ``expm1(-f) = -expm1(f)/(1 + expm1(f))`` gives the four from two.
    """
    ts, td = shear[1] / amps[0], rod[1] / amps[1]
    a, a_ = 0.5 * (shear[0] + ts), 0.5 * (shear[0] - ts)
    b, b_ = 0.5 * (rod[0] + td), 0.5 * (rod[0] - td)
    e_sum, e_diff = np.expm1(ph[0] + ph[1]), np.expm1(ph[0] - ph[1])
    return (ratios[0] * e_sum * (a * b - a_ * b_ / (1.0 + e_sum))
            + ratios[1] * e_diff * (a * b_ - a_ * b / (1.0 + e_diff)))


def _ratios(mu: float, cs: float, M: float, cd: float) -> tuple[float, float]:
    """``(mu q - lam p)/(q + p)`` and ``(mu q + lam p)/(q - p)`` (``q = L/c_s``, ``p = L/c_d``)."""
    lam = M - 2.0 * mu
    return ((mu / cs - lam / cd) / (1.0 / cs + 1.0 / cd),
            (mu / cs + lam / cd) / (1.0 / cs - 1.0 / cd))


def _response(L: np.ndarray, p: Params, layers: Sequence[ExactLayer],
              phases: np.ndarray | None = None, integral: bool = True) -> tuple[np.ndarray, ...]:
    """``(u_x(0), s_xy(0), v(0), s_v(0), I)`` of the shear and rod solutions (module docstring).

    ``phases``: shape ``(n_layers, 2, ...)`` shear and dilatational phases ``q h`` per layer
    (bottom layer first); default ``L h / c``. ``integral=False``: ``I`` is not computed (0).
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
        amps = (mu * q, M * pd)
        shear = _down(shear, amps[0], ph[0])
        rod = _down(rod, amps[1], ph[1])
        if integral:
            total = total + _layer_integral(shear, rod, amps, ph, _ratios(mu, cs, M, cd))
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
    if layered_period(layers) is None and len(layers) > FREE_MAX_LAYERS:
        return (f"no tail bound derived for more than {FREE_MAX_LAYERS} layers whose phase "
                "rates h/c_s, h/c_d are not commensurate; the region is not proven to hold "
                "the fastest mode")
    return ""


def _grid(layers: Sequence[ExactLayer], k: float, W: float) -> tuple[float, float, float | None]:
    """``(Omega, step, period)``: where the orbit takes over, the grid step, its period.

    ``period`` is ``None`` for rates that are not commensurate (the free torus beyond
    ``Omega``: :func:`free_excluded`).
    """
    h, c = layer_rates(layers)
    omega = max(2.0 * W, float(np.max(h * c)) * k * k / TUBE_EPS)
    return (omega, math.pi / (tp.STEPS_PER_PI * float((h / c).sum())), layered_period(layers))


def _points(layers: Sequence[ExactLayer], k: float, W: float) -> float:
    """Grid points of :class:`_LayeredExclusion` (exact part, and the orbit at every offset).

    Rates that are not commensurate: the exact part to the first ``Omega`` only (the free
    torus's grids do not grow with it).
    """
    omega, step, T = _grid(layers, k, W)
    orbit = 0.0 if T is None else T / step * tp.TUBE_POINTS ** (2 * len(layers))
    return (omega - W) / step + orbit


class _LayeredExclusion(tp._OrbitExclusion):
    """The samples of one ``(p, layers, k, W)`` and the exclusion test at a given ``rho``.

    A root ``L = rho + i omega`` of the layered slider solves, to first order in ``k/omega``,
    ``v (a tau - F_0 u) = i k b I`` (:func:`first_order_slope` multiplied out: ``v``, ``s_v``
    the rod's state at the interface, ``u``, ``tau`` the shear solution's, ``I`` the
    reciprocity sum; ``a, F_0, b`` the friction law's shear, slip and normal multipliers). It
    is excluded where ``|v| |a tau - F_0 u| > (1 + 2 c_max k/W) k |b| |I|``.
    """

    def __init__(self, p: Params, layers: Sequence[ExactLayer], k: float, W: float,
                 omega: float | None = None, start: float | None = None) -> None:
        self.p, self.layers, self.k, self.W = p, list(layers), float(k), float(W)
        self.law = FrictionLaw.from_params(p)
        heights, c = layer_rates(layers)
        self.heights, self.c, self.rates = heights, c, heights / c
        self.margin = 1.0 + tp.MARGIN * float(c.max()) * k / W
        self.omega, self.h, T = _grid(layers, k, W)
        if omega is not None:
            self.omega = omega
        self.free = T is None  # not commensurate: the free torus beyond omega
        start = W if start is None else start
        n = int(math.ceil((self.omega - start) / self.h)) + 2
        self.w = np.linspace(start, self.omega, n)
        alpha, gamma = p.alpha_pc, p.gamma

        def axis(which: int):  # noqa: ANN202
            def fun(x: np.ndarray, row: np.ndarray) -> np.ndarray:
                u, tau, v, _, _ = self._states(1j * x, self._exact(1j * x), integral=False)
                return np.real((v, alpha * tau - u / gamma)[which])
            return fun

        self._axis_dips([axis(q) for q in range(2)])
        if self.free:
            return

        # beyond Omega: one period of the k = 0 orbit, the phases lowered by 0 .. h c k^2/Omega
        def orbit(which: int):  # noqa: ANN202
            def fun(t: np.ndarray, row: np.ndarray) -> np.ndarray:
                u, tau, v, _, _ = self._states(1j * self.omega, self._orbit(0.0, t, row),
                                               integral=False)
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

    def _states(self, L: np.ndarray, phases: np.ndarray, integral: bool = True
                ) -> tuple[np.ndarray, ...]:
        """:func:`_response` at amplitude ``L`` (broadcast) and the given phases.

        ``integral=False`` (the zeros of ``v`` and of the shear part: about half the bound's
        time went into reciprocity integrals those never read, session 35).
        """
        L = np.broadcast_to(np.asarray(L, dtype=complex), phases.shape[2:])
        return _response(L, self.p, self.layers, phases, integral)

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


# ------------------------------------------------------------------------------------------
# Rates that are not commensurate (session 33): the free torus beyond Omega
# ------------------------------------------------------------------------------------------
#: Most layers the free torus takes (its grids: the phases of every layer but the bottom one).
FREE_MAX_LAYERS = 2


def _waves(u: np.ndarray, s: np.ndarray, amp: complex) -> tuple[np.ndarray, np.ndarray]:
    """The up- and down-going amplitudes ``(u + s/amp)/2``, ``(u - s/amp)/2`` of a state.

    Down a layer of phase ``phi`` (:func:`_down`) they become ``c e^-phi`` and ``c_ e^phi``.
    """
    return 0.5 * (u + s / amp), 0.5 * (u - s / amp)


def _lowest(P: np.ndarray, Q: np.ndarray, y: float) -> np.ndarray:
    """``min over real t`` of ``|P e^(y + i t) + Q e^-(y + i t)|``: ``| |P| e^y - |Q| e^-y |``."""
    return np.abs(np.abs(P) * math.exp(y) - np.abs(Q) * math.exp(-y))


def _coefficient_moduli(mats: list[tuple[float, ...]], j: int) -> np.ndarray:
    """``|C|`` (4 x 4) of layer ``j``'s reciprocity integral on its wave amplitudes.

    :func:`_layer_integral` is ``sum C[al, be] S_al D_be`` with the shear amplitudes ``S =
    (a, a_, a e^fs, a_ e^-fs)`` and the rod's ``D = (b, b_, b e^fd, b_ e^-fd)`` (at the layer's
    bottom: ``E(s, phi) = (e^phi - 1)/s`` splits). The ratios ``(mu q -+ lambda p)/(q +- p)``
    do not depend on ``Lambda`` (:func:`_ratios`).
    """
    _, mu, cs, M, cd = mats[j]
    plus, minus = (abs(x) for x in _ratios(mu, cs, M, cd))
    C = np.zeros((4, 4))
    C[0, 0] = C[1, 1] = C[2, 2] = C[3, 3] = plus
    C[0, 1] = C[1, 0] = C[2, 3] = C[3, 2] = minus
    return C


def _top_states(amps: list[complex], top: tuple[complex, complex], y: np.ndarray, n: int
                ) -> tuple[list[list[np.ndarray]], tuple[np.ndarray, np.ndarray]]:
    """Over a grid of the phases' real parts of every layer but the bottom one.

    For two layers the top layer's phase ``y[1] + i t``, ``t`` on ``n`` uniform points (one
    layer: no grid). Returns each upper layer's amplitude moduli ``(|b|, |b_|, |b e^phi|,
    |b_ e^-phi|)`` at its bottom, and the state at the bottom layer's top.
    """
    u = np.full(n if len(amps) > 1 else 1, top[0], dtype=complex)
    s = np.full(u.shape, top[1], dtype=complex)
    moduli = []
    for j in range(len(amps) - 1, 0, -1):
        ph = y[j] + 1j * np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)
        u, s = _down((u, s), amps[j], ph)
        b, b_ = _waves(u, s, amps[j])
        moduli.append([np.abs(b), np.abs(b_), np.abs(b * np.exp(ph)), np.abs(b_ * np.exp(-ph))])
    return moduli, (u, s)


def _bottom_moduli(u: np.ndarray, s: np.ndarray, amp: complex, y: float) -> list[np.ndarray]:
    """The bottom layer's amplitude moduli at its bottom from its top's state (any ``Im``)."""
    c, c_ = _waves(u, s, amp)
    return [np.abs(c) * math.exp(-y), np.abs(c_) * math.exp(y), np.abs(c), np.abs(c_)]


def _rod_part(mats: list[tuple[float, ...]], L0: complex, yd: np.ndarray
              ) -> tuple[float, list[np.ndarray]]:
    """``(min |v|, Dmax)`` of the rod over the free torus of its phases' real parts.

    ``v`` (its displacement at the interface, free top) is ``P e^phi0 + Q e^-phi0`` in the
    bottom phase: its smallest modulus over that phase in closed form (:func:`_lowest`), over
    the upper one on a grid of :data:`tp._R_GRID` points refined around its 8 smallest.
    ``Dmax``: per layer (bottom first) the largest amplitude moduli.
    """
    amps = [m[3] * L0 / m[4] for m in mats]
    moduli, (u, s) = _top_states(amps, (1.0, 0.0), yd, tp._R_GRID)
    c, c_ = _waves(u, s, amps[0])
    vmin = _lowest(c_, c, yd[0])  # v = c e^-phi0 + c_ e^phi0
    dmax = [np.array([float(np.max(m)) for m in _bottom_moduli(u, s, amps[0], yd[0])])]
    dmax += [np.array([float(np.max(m)) for m in mod]) for mod in reversed(moduli)]
    if len(mats) == 1:
        return float(np.min(vmin)), dmax

    def lowest(t: np.ndarray) -> np.ndarray:  # over the bottom phase, at the upper one's t
        ph = yd[1] + 1j * t
        uf, sf = _down((np.ones_like(ph), np.zeros_like(ph)), amps[1], ph)
        cf, cf_ = _waves(uf, sf, amps[0])
        return _lowest(cf_, cf, yd[0])

    # refined around the upper phase grid's 8 smallest (_top_states' grid)
    return tp.refined_min(lowest, np.linspace(0.0, 2.0 * math.pi, tp._R_GRID, endpoint=False),
                          vmin), dmax


def _shear_part(p: Params, mats: list[tuple[float, ...]], L0: complex, ys: np.ndarray,
                weights: list[np.ndarray], r: float, phi1: float, phi2: float) -> float:
    """``max over the shear phases of sum S w / Yhat`` (``Yhat``: ``|a tau - F_0 u| / A``).

    ``weights[j] = |C_j| Dmax_j`` per layer. ``S`` (moduli of the shear amplitudes) does not
    depend on the bottom phase's real part; ``Yhat = |L0 u| dist(i tau/(L0 u), sector)`` does,
    and is minimised over it on :data:`tp._FREE_GRID` uniform points plus
    :data:`tp._FREE_DENSE` within six decay lengths of each zero of ``tau`` (where ``Yhat``
    dips to order ``rho``), for each point of the upper phase's grid.
    """
    amps = [m[1] * L0 / m[2] for m in mats]
    top = (0.0, 1.0) if p.bc == "velocity" else (1.0, 0.0)
    moduli, (u1, s1) = _top_states(amps, top, ys, tp._FREE_GRID)
    g = sum(m * w for m, w in zip(_bottom_moduli(u1, s1, amps[0], ys[0]), weights[0],
                                  strict=True))
    for mod, w in zip(reversed(moduli), weights[1:], strict=True):
        g = g + sum(m * x for m, x in zip(mod, w, strict=True))
    # tau = P e^phi0 + Q e^-phi0 in the bottom phase: |tau| is smallest at t where the two
    # terms are opposite, within about |y0 - log(|Q|/|P|)/2| of it
    P, Q = 0.5 * (s1 - amps[0] * u1), 0.5 * (s1 + amps[0] * u1)
    with np.errstate(divide="ignore", invalid="ignore"):
        tz = 0.5 * (np.angle(Q) - np.angle(P) + math.pi)
        width = np.abs(ys[0] - 0.5 * np.log(np.abs(Q) / np.abs(P)))
    width = np.where(np.isfinite(width), np.maximum(width, 1e-12), 0.0)
    dense = tz[:, None] + np.linspace(-6.0, 6.0, tp._FREE_DENSE)[None, :] * width[:, None]
    uni = np.broadcast_to(np.linspace(0.0, 2.0 * math.pi, tp._FREE_GRID, endpoint=False),
                          (tz.size, tp._FREE_GRID))
    t0 = np.concatenate([uni, dense, dense + math.pi], axis=1)
    u, tau = _down((u1[:, None], s1[:, None]), amps[0], ys[0] + 1j * t0)
    lu = L0 * u
    with np.errstate(divide="ignore", invalid="ignore"):
        yhat = np.where(lu != 0, np.abs(lu) * tp.sector_distance(1j * tau / lu, r, phi1, phi2),
                        np.abs(tau))
        return float(np.max(g / np.min(yhat, axis=1)))


def free_excluded(p: Params, layers: Sequence[ExactLayer], k: float, W: float, omega: float,
                  rho: float) -> bool:
    """No root with this ``rho`` beyond ``omega`` wherever the phases' real parts are.

    For phase rates that are not commensurate the ``k = 0`` orbit is dense on the torus, so
    every real part is taken (the decays ``rates rho`` times 1 .. ``1/sqrt(1 - (k c/omega)^2)``,
    both ends tested). With the reciprocity sum split into products of a shear and a rod
    factor (:func:`_coefficient_moduli`), ``|I| <= sum |C| |S| |D|``, and excluded where
    ``min |v| > margin k |b| / A * max sum_j S_j |C_j| Dmax_j / Yhat`` (the margin of ``W``,
    :class:`_LayeredExclusion`'s; ``A``, ``b``, ``Yhat`` as in its tube). At most
    :data:`FREE_MAX_LAYERS` layers.
    """
    mats = _materials(layers)
    h, c = layer_rates(layers)
    stretch = 1.0 / np.sqrt(1.0 - np.minimum((k * c / omega) ** 2, 0.25))
    return all(_free_test(p, mats, float(c.max()), k, W, omega, rho, (h / c) * rho * f)
               for f in (np.ones_like(c), stretch))


def _free_test(p: Params, mats: list[tuple[float, ...]], cmax: float, k: float, W: float,
               omega: float, rho: float, y: np.ndarray) -> bool:
    """:func:`free_excluded` at the decays ``y`` (``(n_layers, 2)``: shear, dilatational)."""
    L0 = 1j * omega
    r, phi1, phi2, A = tp._sector(p, omega, rho)
    with np.errstate(all="ignore"):  # overflow: not excluded (below)
        vmin, dmax = _rod_part(mats, L0, y[:, 1])
        weights = [_coefficient_moduli(mats, j) @ d for j, d in enumerate(dmax)]
        gmax = _shear_part(p, mats, L0, y[:, 0], weights, r, phi1, phi2)
        b = abs(p.f - p.alpha_ld) + p.alpha_ld / omega
        rhs = (1.0 + tp.MARGIN * cmax * k / W) * k * b / A * gmax
        return bool(np.isfinite(rhs) and vmin > rhs)


def layered_bound(p: Params, layers: Sequence[ExactLayer], k: float, W: float,
                  target: float | None = None) -> float | None:
    """Bound on ``Re Lambda`` of every root with ``|Im Lambda| > W``: a layered slider.

    Constant layers on a rigid substrate (:func:`why_no_layered_bound` otherwise: ``None``).
    Commensurate phase rates: the exclusion of :class:`_LayeredExclusion` on the exact phases
    from ``W`` to ``Omega`` and on one period of the ``k = 0`` orbit beyond (docs/design.md
    8.1); asymptotic, made safe by measurement (tests/test_tail.py against
    :func:`analytic.physics.layered_exact.det_layered`'s roots).

    Rates that are not commensurate (session 33; at most :data:`FREE_MAX_LAYERS` layers): the
    exact phases to ``Omega`` and the free torus beyond (:func:`free_excluded`,
    :func:`analytic.physics.tail_stack_pc.free_bound_of`; ``target``: stop once the bound is
    known to be below it or not to get there).

    Returns:
        The largest ``rho`` not excluded; ``inf`` when ``W <= 2 k c_d`` of a layer (or
        ``max(1, |Delta - 1|)``), when the orbit's grids would exceed tail_stack_pc's
        ``MAX_POINTS`` for more than two layers (two at most: the free torus instead), or
        when ``rho = 4`` is not excluded; ``None`` as said.
    """
    if why_no_layered_bound(layers):
        return None
    k, W = float(k), float(W)
    _, c = layer_rates(layers)
    if not (W > max(2.0 * k * float(c.max()), 1.0, abs(p.Delta - 1.0))):
        return math.inf
    too_long = _points(layers, k, W) > tp.MAX_POINTS  # the orbit's grids (Omega grows as k^2)
    if layered_period(layers) is None or (too_long and len(layers) <= FREE_MAX_LAYERS):
        # the free torus beyond Omega: it holds every orbit, a long commensurate one too
        return tp.free_bound_of(
            _grid(layers, k, W)[1], W,
            lambda omega, start=None: _LayeredExclusion(p, layers, k, W, omega, start),
            functools.partial(free_excluded, p, layers, k, W), target)
    if too_long:
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
