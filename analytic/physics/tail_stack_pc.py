"""Tail bound of a two-body stack with a Prakash-Clifton term (``alpha_pc > 0``) at fixed ``k``.

Derivation (docs/design.md section 8.1). With ``a = 1 + alpha_pc L`` multiplying ``d1 d2`` in
the stack's shear factor ``Y`` (:mod:`analytic.physics.tail_stack`), the first-order shift of a
rod resonance, multiplied out, is the equation::

    R(L) Y(L) = (k / L) b Z1 Z2 X(L),   Y = a d1 d2 + i (1 + e) N / gamma

(``R`` the composite rod's resonance function, ``X``, ``N``, ``d_j`` as in ``tail_stack``, all
of the stack's partial-wave phases ``psi_j = H_j sqrt(-L^2/c_j^2 - k^2)`` continued to complex
``L``). It holds both members of a hybridised pair: a rod resonance and a shear thickness mode
that ``a`` makes nearly undamped at high frequency (``Y`` small), for which the first-order
shift ``X / (R' Y)`` is not small and the ``alpha_pc = 0`` stack bound does not hold. No phase
is taken as free here (on free phases ``Y`` vanishes at ``rho > 0`` and the stack's shear
coincidences make every bound infinite): a root ``L = rho + i omega`` is **excluded** wherever

    |R(L)| |Y(L)| > (1 + 2 c_max k/W) k |b(L)| Z1 Z2 |X(L)| / |L|

(moduli only). The margin ``(1 + 2 c_max k/W)``, ``c_max`` the stack's largest wave speed, is
for the terms left out, relative ``O(k c_j/omega)`` in a layer of speed ``c_j``; it is not
derived, its coefficient is measured. With the other bounds' ``(1 + k/W)`` a root reached 1.09
of the bound (``mu2 = 9``, ``c_d2 = 6``, ``alpha_pc = 0.0138``, ``k = 1.6``, a hybridised pair
at ``0.2975 + 33.04 i``, where ``k c_d2/omega = 0.29``), with ``(1 + c_max k/W)`` 1.13 (the same
stack, stress top, velocity bottom, ``alpha_pc = 0.0195``, ``k = 1.58``: the root ``0.2252 +
33.043 i`` needs the margin 1.39 where ``k c_d2/omega = 0.29``). The bound is the largest
``rho`` not excluded at some ``omega >= W``:

- ``W <= omega <= Omega``: the exact phases at ``k`` on a grid of ``omega`` (40 points per
  ``pi`` of the summed phase rates), plus 13 points within ``3 min(rho, h)/2`` of every real
  zero of ``d1``, ``d2``, ``R`` and ``alpha_pc omega d1 d2 + N/gamma`` on the axis (where the
  narrow dips of ``|R|``, ``|Y|`` lie: their width is ``rho``; 7 points instead of 13 missed
  the bottom of one by 1 %, 25 points and a grid twice as fine changed nothing);
- ``omega > Omega``: one period of the ``k = 0`` phases ``rates (x - i rho)`` lowered by offsets
  ``0 .. H_j c_j k^2 / Omega`` (both ends, each phase independently), with ``|L| >= Omega``,
  ``|a| >= A = |1 + alpha_pc rho + i alpha_pc Omega|``, ``|b| <= |f - alpha_ld| + alpha_ld/Omega``
  and ``Y / a = d1 d2 + c N`` where ``c = i (1 + e)/(gamma a)`` ranges over the sector ``|c| <=
  (1 + |Delta - 1|/Omega)/(gamma A)``, ``arg c`` in ``[-asin(|Delta - 1|/Omega), pi/2 -
  atan(alpha_pc Omega/(1 + alpha_pc rho)) + asin(...)]`` (``|d1 d2 + c N| >= |N|`` times the
  distance of ``-d1 d2/N`` to the sector). That needs commensurate phase rates
  (:func:`analytic.physics.tail_stack.period`).

**A half-space substrate** (``H2 = inf``, any ``alpha_pc`` including 0; :func:`half_space`):
at ``Re L > 0`` the substrate's partial waves decay into it, and as ``H2 -> inf`` each of its
sines and cosines is ``exp(i psi)`` times ``-i/2`` and ``1/2``. Every term of the equation
carries one factor of each substrate phase, so that factor drops out of the exclusion and the
substrate enters by its radiating limit: ``sin -> -i``, ``cos -> 1``, the velocity end's form
whatever ``bc2`` (:func:`_parts`). The exclusion then runs on the slider's two phases alone
(periodic for a rational ``beta``); the margin keeps the substrate's ``c_d2`` in ``c_max``.
Measured: in 456 random stacks (``mu2`` 0.1-100, ``W`` 1.02-1.3 times ``2 k c_max``) the
roots of ``W < |Im| < 2 W`` reach at most 0.43 of the bound at ``W`` and 0.60 at their own
frequency; far out (``|Im|`` 400 and 3000) 0.77-0.86.

``rho`` is scanned down from 4 by halving to the first ``rho`` not excluded (on every 8th grid
point and all the dips' points: a ``rho`` not excluded there is not excluded), then up on the
whole grid to the first one excluded, then bisected 6 times (the bound is the upper end: 1.1 %
above the edge at most). Asymptotic and checked by
measurement, as the other bounds: tests/test_tail.py compares it with exact roots of
:func:`analytic.physics.twobody.det_twobody` beyond ``W``.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from analytic.params import Params
from analytic.physics import tail_stack as ts

#: Largest number of grid points (both parts) before the bound gives up (``inf``); measured
#: 9 s for 535 000 points, 15 s for 580 000 (the machine loaded by two other processes).
MAX_POINTS = 1_000_000
#: Coefficient of the margin ``1 + MARGIN c_max k / W`` (measured, module docstring).
MARGIN = 2.0
#: Grid points per ``pi`` of the summed phase rates.
STEPS_PER_PI = 40
#: Offsets per phase beyond ``Omega`` (0 and the largest): 2, 3 (``tail_stack``'s), 4 gave the
#: same bounds to 5 digits in four stacks, 2 in a third of the time.
TUBE_POINTS = 2
#: Largest ``rho`` scanned (if it is not excluded, the bound is ``inf``).
RHO_MAX = 4.0
#: Halvings below :data:`RHO_MAX` before the bound is taken as 0.
_HALVINGS = 40
#: The halving's grid subset (every ``_SUBSET``-th point): only the bisection takes them all.
_SUBSET = 8
#: Bisections between the last excluded ``rho`` and the first one not excluded.
_BISECTIONS = 6
#: Offsets (in units of ``min(rho, h)/2``) of the points placed at each dip.
_DIP = np.linspace(-3.0, 3.0, 13)
#: Bisection steps locating a dip on the axis.
_ZERO_STEPS = 32


def half_space(p: Params) -> bool:
    """A half-space substrate (``H2 = inf``) under a slider of finite height."""
    return p.two_body and not math.isfinite(p.H2) and math.isfinite(p.H)


def stack_constants(p: Params) -> dict[str, np.ndarray | float]:
    """:func:`analytic.physics.tail_stack.stack_constants`, for a half-space substrate too.

    A half-space substrate's phases do not turn (height and rates 0: its radiating limit,
    :func:`_parts`).
    """
    s = ts.stack_constants(p)
    if half_space(p):
        s = dict(s)
        s["H"] = np.array([p.H, p.H, 0.0, 0.0])
        s["rates"] = s["H"] / s["c"]
    return s


def period(p: Params) -> float | None:
    """Period in ``omega`` of the ``k = 0`` phases that turn, or ``None`` (not commensurate).

    Over a half-space substrate the slider's alone.
    """
    return ts.period_of_rates(stack_constants(p)["rates"])


def _parts(p: Params, ph: np.ndarray) -> tuple[np.ndarray, ...]:
    """``R``, ``X``, ``d1 d2``, ``N``, ``d1``, ``d2`` of the phases ``ph`` (shape ``(4, ...)``).

    Over a half-space substrate its rows of ``ph`` are ignored: at ``Re L > 0`` its partial
    waves decay into it, and as ``H2 -> inf`` each of its sines and cosines is ``exp(i psi)``
    times ``-i/2`` and ``1/2``; every term here carries one factor of each substrate phase (the
    stress end's ``1 - cos cos`` to leading order), so the common factor drops out of the
    exclusion and the substrate is the velocity end with ``sin -> -i``, ``cos -> 1`` whatever
    ``bc2`` (the stress end's ``d``, ``n``, ``G`` are ``-i`` times those).
    """
    if not half_space(p):
        return ts.stack_parts(p, np.sin(ph), np.cos(ph))
    sn, cs = np.sin(ph[:2]), np.cos(ph[:2])
    one = np.ones_like(sn[0])
    return ts.stack_parts(p, np.stack([sn[0], sn[1], -1j * one, -1j * one]),
                          np.stack([cs[0], cs[1], one, one]), bc2="velocity")


def _segment_distance(z: np.ndarray, end: complex) -> np.ndarray:
    """Distance from the points ``z`` to the segment ``[0, end]``."""
    t = np.clip((z * np.conj(end)).real / abs(end) ** 2, 0.0, 1.0) if end != 0 else 0.0
    return np.abs(z - t * end)


def sector_distance(z: np.ndarray, r: float, phi1: float, phi2: float) -> np.ndarray:
    """Distance from ``z`` to the sector ``|c| <= r``, ``phi1 <= arg c <= phi2`` (``< pi`` wide)."""
    ang = np.angle(z)
    arc = np.where((ang >= phi1) & (ang <= phi2), np.maximum(np.abs(z) - r, 0.0), np.inf)
    return np.minimum(arc, np.minimum(_segment_distance(z, r * np.exp(1j * phi1)),
                                      _segment_distance(z, r * np.exp(1j * phi2))))


def _grid(p: Params, k: float, W: float) -> tuple[float, float]:
    """``(Omega, h)``: where the orbit takes over, and the grid step in ``omega``."""
    s = stack_constants(p)
    omega = max(2.0 * W, float(np.max(s["H"] * s["c"])) * k * k / ts.TUBE_EPS)
    return omega, math.pi / (STEPS_PER_PI * float(np.sum(s["rates"])))


def _points(p: Params, k: float, W: float) -> float:
    """Grid points of :class:`_Exclusion` (the ``omega`` grid and the orbit's, every offset)."""
    omega, h = _grid(p, k, W)
    return (omega - W) / h + float(period(p)) / h * TUBE_POINTS**4


class _Exclusion:
    """The samples of one ``(p, k, W)`` and the exclusion test at a given ``rho``."""

    def __init__(self, p: Params, k: float, W: float) -> None:
        s = stack_constants(p)
        self.p, self.k, self.W, self.s = p, k, W, s
        self.omega, self.h = _grid(p, k, W)
        # the margin for the terms left out: relative O(k c_j / omega) in the layer of speed
        # c_j (its vertical wavenumber's k c_j / omega), with the coefficient 2 measured
        # (module docstring)
        self.margin = 1.0 + MARGIN * float(np.max(s["c"])) * k / W
        n = int(math.ceil((self.omega - W) / self.h)) + 2
        self.w = np.linspace(W, self.omega, n)

        def axis(which: int):  # noqa: ANN202
            def fun(x: np.ndarray, row: np.ndarray) -> np.ndarray:
                P = _parts(p, ts.exact_phases(p, k, x)[0])
                # real on the axis; over a half-space the real parts (of R: Z1 sin t1)
                return np.real((P[4], P[5], P[0], p.alpha_pc * x * P[2] + P[3] / p.gamma)[which])
            return fun

        self.w_dips = np.concatenate([ts.roots_on_grid_rows(axis(q), self.w, 1, _ZERO_STEPS)[0]
                                      for q in range(4)])
        # beyond Omega: one period of the k = 0 orbit, every offset at once (rows)
        eps = s["H"] * s["c"] * k * k / self.omega
        grid = np.linspace(0.0, 1.0, TUBE_POINTS)
        self.offs = np.stack(np.meshgrid(*([grid] * 4), indexing="ij"), -1).reshape(-1, 4) * eps
        self.T = float(period(p))
        x = np.linspace(0.0, self.T, int(math.ceil(self.T / self.h)) + 2)
        r0 = self._sector(0.0)[0]
        offs, rates = self.offs, s["rates"][:, None]

        def orbit(which: int):  # noqa: ANN202
            def fun(t: np.ndarray, row: np.ndarray) -> np.ndarray:
                P = _parts(p, rates * t[None, :] - offs[row].T)
                return np.real((P[4], P[5], P[0], P[2] + r0 * P[3])[which])
            return fun

        dips = [ts.roots_on_grid_rows(orbit(q), x, len(offs), _ZERO_STEPS) for q in range(4)]
        self.x = np.tile(x, len(offs))
        self.x_row = np.repeat(np.arange(len(offs)), len(x))
        self.x_dips = np.concatenate([d[0] for d in dips])
        self.x_dip_row = np.concatenate([d[1] for d in dips])

    def _sector(self, rho: float) -> tuple[float, float, float, float]:
        """``(r, phi1, phi2, A)``: the sector of ``c`` beyond ``Omega`` and ``|a| >= A``."""
        p, om = self.p, self.omega
        A = math.hypot(1.0 + p.alpha_pc * rho, p.alpha_pc * om)
        de = abs(p.Delta - 1.0) / om
        th = math.asin(min(de, 1.0))
        top = 0.5 * math.pi - math.atan2(p.alpha_pc * om, 1.0 + p.alpha_pc * rho)
        return (1.0 + de) / (p.gamma * A), -th, top + th, A

    def _direct(self, rho: float, w: np.ndarray) -> np.ndarray:
        p, s = self.p, self.s
        L = rho + 1j * w
        ph = s["H"][:, None] * np.sqrt(((w - 1j * rho)[None, :] / s["c"][:, None]) ** 2
                                       - self.k**2)
        R, X, Dd, N, _, _ = _parts(p, ph)
        Y = (1.0 + p.alpha_pc * L) * Dd + 1j * (1.0 + (p.Delta - 1.0) / (L + 1.0)) * N / p.gamma
        b = p.f - p.alpha_ld * L / (L + 1.0)
        return (np.abs(R) * np.abs(Y)
                - self.margin * self.k * np.abs(b) * s["Z1"] * s["Z2"] * np.abs(X) / np.abs(L))

    def _tube(self, rho: float, x: np.ndarray, row: np.ndarray) -> np.ndarray:
        p, s = self.p, self.s
        ph = s["rates"][:, None] * (x - 1j * rho)[None, :] - self.offs[row].T
        R, X, Dd, N, _, _ = _parts(p, ph)
        r, phi1, phi2, A = self._sector(rho)
        with np.errstate(divide="ignore", invalid="ignore"):
            y = np.where(N != 0, np.abs(N) * sector_distance(-Dd / N, r, phi1, phi2),
                         np.abs(Dd))
        b = abs(p.f - p.alpha_ld) + p.alpha_ld / self.omega
        return (np.abs(R) * y
                - self.margin * self.k * b * s["Z1"] * s["Z2"] * np.abs(X) / (self.omega * A))

    def excluded(self, rho: float, every: int = 1) -> bool:
        """No root with this ``rho`` at any ``omega >= W`` (module docstring).

        ``every > 1`` takes only every ``every``-th grid point (the dips' points all): a
        ``False`` is then final, a ``True`` is not.
        """
        step = 0.5 * min(rho, self.h)
        w = np.concatenate([self.w[::every], (self.w_dips[:, None] + step * _DIP).ravel()])
        if not np.min(self._direct(rho, w[w >= self.W])) > 0:
            return False
        x = np.concatenate([self.x[::every],
                            (self.x_dips[:, None] + step * _DIP).ravel() % self.T])
        row = np.concatenate([self.x_row[::every], np.repeat(self.x_dip_row, len(_DIP))])
        return bool(np.min(self._tube(rho, x, row)) > 0)


@lru_cache(maxsize=4096)
def stack_pc_bound(p: Params, k: float, W: float) -> float:
    """Bound on ``Re Lambda`` of every root with ``|Im| > W``: two bodies, ``alpha_pc > 0``.

    Args:
        p: Parameters (finite ``mu2`` and ``H``; finite ``H2`` or a half-space substrate;
            commensurate phase rates, :func:`period`).
        k: Wavenumber ``> 0``.
        W: Frequency beyond which the bound holds.

    Returns:
        The largest ``rho`` not excluded (module docstring); ``inf`` when ``W <= 2 k c_d`` of
        either layer (or ``max(1, |Delta - 1|)``), when the phase rates are not commensurate,
        when the grids would exceed :data:`MAX_POINTS` (large ``k``: ``Omega`` grows as
        ``k^2``) or when :data:`RHO_MAX` is not excluded. 0.3-0.5 s a call for ``Omega`` up to 800,
        9 s for 5 500 (measured), cached. The stress top, ``mu2 = 4, rho2 = 1, H2 = 0.5``,
        ``W`` of 4 ``c_d2``: ``inf`` from ``k = 27`` on (the grids' size).
    """
    k, W = float(k), float(W)
    cmax = float(np.max(stack_constants(p)["c"]))
    if not (W > max(2.0 * k * cmax, 1.0, abs(p.Delta - 1.0))) or period(p) is None:
        return math.inf
    if _points(p, k, W) > MAX_POINTS:
        return math.inf
    ex = _Exclusion(p, k, W)
    # halve on a subset of the grid (its "not excluded" is final) to the first rho not excluded
    lo = RHO_MAX
    for _ in range(_HALVINGS):
        if not ex.excluded(lo, _SUBSET):
            break
        lo *= 0.5
    else:
        return 0.0
    if lo == RHO_MAX:
        return math.inf
    # then on the whole grid: up from there to the first rho excluded, and bisect
    while not ex.excluded(2.0 * lo):
        lo *= 2.0
        if lo >= RHO_MAX:
            return math.inf
    hi = 2.0 * lo
    for _ in range(_BISECTIONS):
        mid = math.sqrt(lo * hi)
        if ex.excluded(mid):
            hi = mid
        else:
            lo = mid
    return hi
