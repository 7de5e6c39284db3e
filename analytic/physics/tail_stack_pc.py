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
  (:func:`period`). Otherwise (session 31) the orbit is dense on the torus, and beyond
  ``Omega`` every real part of the four phases is taken (:func:`free_excluded`: the
  coefficients of ``X`` on the dilatational phases' monomials over the sector bound on
  ``|Y / a|`` maximised on a grid of the two shear phases, ``|R|`` minimised in closed form
  over ``t2``). On free phases the stack's shear coincidences (``d1 = d2 = 0``) keep ``|Y|``
  down to order ``rho`` (the decay of the phases), and ``|R|`` too, so this bound falls
  only as ``Omega^(-1/2)``: ``Omega`` is pushed out (:func:`_free_bound`) until it is below
  the exact phases' bound from ``W`` or the grid reaches :data:`FREE_MAX_POINTS`.

**A half-space substrate** (``H2 = inf``, any ``alpha_pc`` including 0; :func:`half_space`):
at ``Re L > 0`` the substrate's partial waves decay into it, and as ``H2 -> inf`` each of its
sines and cosines is ``exp(i psi)`` times ``-i/2`` and ``1/2``. Every term of the equation
carries one factor of each substrate phase, so that factor drops out of the exclusion and the
substrate enters by its radiating limit: ``sin -> -i``, ``cos -> 1``, the velocity end's form
whatever ``bc2`` (:func:`_parts`). The exclusion then runs on the slider's two phases alone
(periodic for a rational ``beta``); the margin keeps the substrate's ``c_d2`` in ``c_max``.
Measured: in 456 random stacks (``mu2`` 0.1-100, ``W`` 1.02-1.3 times ``2 k c_max``) the
roots of ``W < |Im| < 2 W`` reach at most 0.43 of the bound at ``W`` and 0.60 at their own
frequency; far out (``|Im|`` 400 and 3000) 0.77-0.86. For an irrational ``beta`` (session 32;
a Poisson solid, ``beta = 1/sqrt 3``) the free torus of the slider's two phases beyond
``Omega``, as for two finite bodies: ``X`` on the monomials ``(1, st1, ct1)`` and ``R = Z1 sin
t1 - i Z2 cos t1`` (:func:`_free_coefficients`, :func:`_min_resonance`). Radiation keeps
``|R|`` (at least ``min(Z1, Z2)`` on the real axis) and ``|Y|`` off zero, so this part falls
as ``1/Omega``, not as ``Omega^(-1/2)``. Measured in 120 random stacks (``beta`` 0.3-0.68,
``W`` 1.02-1.5 times ``2 k c_max``): 13 with a root of positive ``Re`` in ``W .. 2 W``, at
most 0.49 of the bound at ``W`` and 0.58 at its own frequency.

``rho`` is scanned down from 4 by halving to the first ``rho`` not excluded (on every 8th grid
point and all the dips' points: a ``rho`` not excluded there is not excluded), then up on the
whole grid to the first one excluded, then bisected 6 times (the bound is the upper end: 1.1 %
above the edge at most). Asymptotic and checked by
measurement, as the other bounds: tests/test_tail.py compares it with exact roots of
:func:`analytic.physics.twobody.det_twobody` beyond ``W``.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from functools import lru_cache

import numpy as np

from analytic.params import Params
from analytic.physics import tail_stack as ts

#: Largest number of grid points (both parts) before the bound gives up (``inf``); measured
#: 9 s for 535 000 points, 15 s for 580 000 (the machine loaded by two other processes).
MAX_POINTS = 1_000_000
#: Largest exact-phase grid an incommensurate stack's Omega is pushed out to (the free torus's
#: bound falls as Omega^(-1/2), its cost grows as Omega). Measured, stress top, mu2 = 0.3,
#: rho2 = 1, H2 = 0.5, k = 5, W = 500: 5e4 points 0.093 in 2.3 s, 2.5e5 0.046 in 6 s, 1e6 0.024
#: in 22 s; mu2 = 0.1, H2 = 0.5, the 4 and 16 c_d2 rungs at k = 1, 5, 20: 0.029-0.14 in
#: 1.1-1.7 s at 6e4 points against 0.014-0.072 in 4.7-11.5 s at 2.5e5. An adaptive region
#: asks for several rungs' bounds at each k: the cheaper, larger bound.
FREE_MAX_POINTS = 60_000
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
    """``(Omega, h)``: where the orbit (or the free torus) takes over, and the grid step."""
    s = stack_constants(p)
    omega = max(2.0 * W, float(np.max(s["H"] * s["c"])) * k * k / ts.TUBE_EPS)
    return omega, math.pi / (STEPS_PER_PI * float(np.sum(s["rates"])))


def _points(p: Params, k: float, W: float) -> float:
    """Grid points of :class:`_Exclusion` (the ``omega`` grid and the orbit's, every offset)."""
    omega, h = _grid(p, k, W)
    return (omega - W) / h + float(period(p)) / h * TUBE_POINTS**4


class _OrbitExclusion:
    """The samples and the test of an exclusion by moduli (two bodies, layered sliders).

    Two bodies here (:class:`_Exclusion`), layered sliders in
    :mod:`analytic.physics.tail_layers`. A subclass sets the exact-phase grid ``w`` (step
    ``h``, from its lowest ``omega``) and calls :meth:`_axis_dips`, and, unless ``free`` (no
    periodic orbit: its own test beyond), :meth:`_orbit_samples`; it defines ``_direct(rho,
    w)`` (the exact phases) and ``_tube(rho, x, row)`` (the orbit), each positive where a root
    is excluded.
    """

    free = False

    def _axis_dips(self, funs: list[Callable]) -> None:
        """``w_dips``: the zeros on ``w`` of the real functions ``fun(x, row)`` of ``funs``."""
        self.w_dips = np.concatenate([ts.zeros_on_grid_rows(f, self.w, 1, _ZERO_STEPS)[0]
                                      for f in funs])

    def _orbit_samples(self, eps: np.ndarray, T: float, funs: list[Callable]) -> None:
        """One period ``T`` of the ``k = 0`` orbit and the zeros of ``funs`` on it (``x_dips``).

        Each row a corner of the tube of phases lowered by ``0 .. eps`` (``offs``).
        """
        grid = np.linspace(0.0, 1.0, TUBE_POINTS)
        m = eps.size
        self.offs = np.stack(np.meshgrid(*([grid] * m), indexing="ij"), -1).reshape(-1, m) * eps
        self.T = T
        x = np.linspace(0.0, T, int(math.ceil(T / self.h)) + 2)
        dips = [ts.zeros_on_grid_rows(f, x, len(self.offs), _ZERO_STEPS) for f in funs]
        self.x = np.tile(x, len(self.offs))
        self.x_row = np.repeat(np.arange(len(self.offs)), len(x))
        self.x_dips = np.concatenate([d[0] for d in dips])
        self.x_dip_row = np.concatenate([d[1] for d in dips])

    def excluded(self, rho: float, every: int = 1) -> bool:
        """No root with this ``rho`` at any ``omega >= w[0]`` (module docstring).

        ``every > 1`` takes only every ``every``-th grid point (the dips' points all): a
        ``False`` is then final, a ``True`` is not.
        """
        step = 0.5 * min(rho, self.h)
        w = np.concatenate([self.w[::every], (self.w_dips[:, None] + step * _DIP).ravel()])
        with np.errstate(over="ignore", invalid="ignore"):  # overflow: nan, not excluded
            if not np.min(self._direct(rho, w[w >= self.w[0]])) > 0:
                return False
            if self.free:
                return True
            x = np.concatenate([self.x[::every],
                                (self.x_dips[:, None] + step * _DIP).ravel() % self.T])
            row = np.concatenate([self.x_row[::every], np.repeat(self.x_dip_row, len(_DIP))])
            return bool(np.min(self._tube(rho, x, row)) > 0)


class _Exclusion(_OrbitExclusion):
    """The samples of one ``(p, k, W)`` and the exclusion test at a given ``rho``.

    ``omega`` overrides where the exact phases stop and ``start`` where they begin (default
    ``W``); for phase rates that are not commensurate :meth:`excluded` tests the exact phases
    only (the free torus beyond ``omega``: :func:`free_excluded`).
    """

    def __init__(self, p: Params, k: float, W: float, omega: float | None = None,
                 start: float | None = None) -> None:
        s = stack_constants(p)
        self.p, self.k, self.W, self.s = p, k, W, s
        self.omega, self.h = _grid(p, k, W)
        if omega is not None:
            self.omega = omega
        self.free = period(p) is None  # not commensurate: the free torus beyond omega
        # the margin for the terms left out: relative O(k c_j / omega) in the layer of speed
        # c_j (its vertical wavenumber's k c_j / omega), with the coefficient 2 measured
        # (module docstring)
        self.margin = 1.0 + MARGIN * float(np.max(s["c"])) * k / W
        start = W if start is None else start
        n = int(math.ceil((self.omega - start) / self.h)) + 2
        self.w = np.linspace(start, self.omega, n)

        def axis(which: int):  # noqa: ANN202
            def fun(x: np.ndarray, row: np.ndarray) -> np.ndarray:
                P = _parts(p, ts.exact_phases(p, k, x)[0])
                # real on the axis; over a half-space the real parts (of R: Z1 sin t1)
                return np.real((P[4], P[5], P[0], p.alpha_pc * x * P[2] + P[3] / p.gamma)[which])
            return fun

        self._axis_dips([axis(q) for q in range(4)])
        if self.free:
            return
        # beyond Omega: one period of the k = 0 orbit, every offset at once (rows)
        r0 = self._sector(0.0)[0]
        rates = s["rates"][:, None]

        def orbit(which: int):  # noqa: ANN202
            def fun(t: np.ndarray, row: np.ndarray) -> np.ndarray:
                P = _parts(p, rates * t[None, :] - self.offs[row].T)
                return np.real((P[4], P[5], P[0], P[2] + r0 * P[3])[which])
            return fun

        self._orbit_samples(s["H"] * s["c"] * k * k / self.omega, float(period(p)),
                            [orbit(q) for q in range(4)])

    def _sector(self, rho: float) -> tuple[float, float, float, float]:
        return _sector(self.p, self.omega, rho)

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

def _sector(p: Params, om: float, rho: float) -> tuple[float, float, float, float]:
    """``(r, phi1, phi2, A)``: the sector of ``c`` beyond ``om`` and ``|a| >= A``."""
    A = math.hypot(1.0 + p.alpha_pc * rho, p.alpha_pc * om)
    de = abs(p.Delta - 1.0) / om
    th = math.asin(min(de, 1.0))
    top = 0.5 * math.pi - math.atan2(p.alpha_pc * om, 1.0 + p.alpha_pc * rho)
    return (1.0 + de) / (p.gamma * A), -th, top + th, A


def free_excluded(p: Params, k: float, W: float, omega: float, rho: float) -> bool:
    """No root with this ``rho`` beyond ``omega`` wherever the four phases' real parts are.

    For phase rates that are not commensurate: the ``k = 0`` orbit is dense on the torus,
    so every real part is taken (imaginary parts ``-rates rho``). ``X`` is a sum of five
    products of a function of the shear phases and a monomial in the dilatational phases'
    sines and cosines (:func:`_free_coefficients`); each monomial is at most its
    ``cosh(Im)`` product, each coefficient over the sector bound on ``|Y / a|`` is
    maximised on a grid of the two shear phases (dense where ``d1``, ``d2`` vanish), and
    ``|R|`` is minimised in closed form over ``t2`` and on a grid over ``t1``. Excluded
    where ``min |R| > margin k |b| Z1 Z2 / (omega A) * sum_m U_m max |c_m| / |Y / a|``
    (the margin of ``W``, as :class:`_Exclusion`'s). Over a half-space substrate the slider's
    two phases alone (its radiating limit, :func:`_parts`).
    """
    s = stack_constants(p)
    # the phases' decay at omega >= Omega: rates rho times 1 .. 1/sqrt(1 - (k c_j/Omega)^2)
    # (both ends are tested)
    stretch = 1.0 / np.sqrt(1.0 - np.minimum((k * s["c"] / omega) ** 2, 0.25))
    return all(_free_test(p, k, W, omega, rho, s["rates"] * rho * f) for f in (1.0, stretch))


def _free_test(p: Params, k: float, W: float, omega: float, rho: float, y: np.ndarray) -> bool:
    """:func:`free_excluded` at the phases' decays ``y`` (non-finite values: not excluded)."""
    s = stack_constants(p)
    r, phi1, phi2, A = _sector(p, omega, rho)
    with np.errstate(all="ignore"):  # overflow at a large decay: not excluded, below
        coefs, units, d1, d2, N = _free_coefficients(p, y)
        ylow = np.where(N != 0, np.abs(N) * sector_distance(-d1 * d2 / N, r, phi1, phi2),
                        np.abs(d1 * d2))
        M = sum(float(np.max(np.abs(c) / ylow)) * u for c, u in zip(coefs, units, strict=True))
        margin = 1.0 + MARGIN * float(np.max(s["c"])) * k / W
        b = abs(p.f - p.alpha_ld) + p.alpha_ld / omega
        kappa = margin * k * b * s["Z1"] * s["Z2"] / (omega * A)
        return bool(np.isfinite(M) and _min_resonance(p, y) > kappa * M)


#: Uniform grid points per shear phase of the free torus (plus :data:`_FREE_DENSE` points on
#: each zero of its ``d``); 128, 256 and 1024 (and 161 dense points) gave the same bounds to 5
#: digits in four stacks.
_FREE_GRID = 128
#: Points placed within six decay lengths ``Im psi`` of each zero of ``d`` (two per period).
_FREE_DENSE = 41
#: Grid points in ``t1`` for the minimum of ``|R|`` (then refined around the 8 smallest).
_R_GRID = 2048


def _shear_grid(bc: str, y: float) -> np.ndarray:
    """Real parts of a shear phase: uniform, and dense around the zeros of its ``d``."""
    base = (0.5 * math.pi if bc == "velocity" else 0.0) + np.array([0.0, math.pi])
    dense = (base[:, None] + np.linspace(-6.0, 6.0, _FREE_DENSE)[None, :] * max(y, 1e-12))
    return np.concatenate([np.linspace(0.0, 2.0 * math.pi, _FREE_GRID, endpoint=False),
                           dense.ravel() % (2.0 * math.pi)])


def _free_coefficients(p: Params, y: np.ndarray
                       ) -> tuple[list[np.ndarray], list[float], np.ndarray, np.ndarray,
                                  np.ndarray]:
    """``X``'s coefficients on monomials of the dilatational phases, their bounds, ``d1, d2, N``.

    Two finite bodies: the monomials ``(st2, st1 st2, ct1 st2, st1, st1 ct2)`` of the
    dilatational phases ``t1``, ``t2`` (imaginary parts ``-y[1]``, ``-y[3]``), each at most its
    ``cosh`` product. Over a half-space substrate (its radiating limit, :func:`_parts`: ``st2 =
    -i``, ``ct2 = 1``, the velocity end's form) the monomials ``(1, st1, ct1)``. The
    coefficients on the grid of the shear phases (:func:`_shear_grid`; imaginary parts
    ``-y[0]``, ``-y[2]``; the half-space's has none).
    """
    s = stack_constants(p)
    z1 = _shear_grid(p.bc, y[0])[:, None] - 1j * y[0]
    d1, n1, a0, as1, ac1 = ts.end_coefficients(p.bc, p.beta, np.sin(z1), np.cos(z1))
    r2 = p.rho2
    ch1 = math.cosh(min(y[1], 700.0))
    if half_space(p):
        one = np.ones((1, 1), dtype=complex)
        d2, n2, b0, bs2, bc2 = ts.end_coefficients("velocity", p.substrate_beta, -1j * one, one)
        g2 = b0 - 1j * bs2 + bc2
        # X = -i d2 G1 - G2 d1 st1 / rho2 on (1, st1, ct1)
        coefs = [-1j * d2 * a0, -1j * d2 * as1 - d1 * g2 / r2, -1j * d2 * ac1]
        return coefs, [1.0, ch1, ch1], d1, d2, n1 * d2 + n2 * d1 / s["Zs"]
    z2 = _shear_grid(p.bc2, y[2])[None, :] - 1j * y[2]
    d2, n2, b0, bs2, bc2 = ts.end_coefficients(p.bc2, p.substrate_beta, np.sin(z2), np.cos(z2))
    # X = G1 d2 st2 - G2 d1 st1 / rho2, G1 = a0 + as1 st1 + ac1 ct1, G2 = b0 + bs2 st2 + bc2 ct2
    coefs = [d2 * a0, d2 * as1 - d1 * bs2 / r2, d2 * ac1, -d1 * b0 / r2, -d1 * bc2 / r2]
    ch3 = math.cosh(min(y[3], 700.0))
    units = [ch3, ch1 * ch3, ch1 * ch3, ch1, ch1 * ch3]
    return coefs, units, d1, d2, n1 * d2 + n2 * d1 / s["Zs"]


def _min_resonance(p: Params, y: np.ndarray) -> float:
    """Smallest ``|R|`` over the real parts of ``t1``, ``t2`` (imaginary parts ``-y[1, 3]``).

    ``R = S sin(t2 + phi)`` with ``S cos phi = Z2 cos t1``, ``S sin phi = Z1 sin t1``, whose
    smallest modulus over real ``t2`` is ``|S| |sinh(Im phi - y3)|``; ``t1`` on a grid,
    refined around its smallest values. Over a half-space substrate ``R = Z1 sin t1 - i Z2 cos
    t1`` (``sin t2 -> -i``, ``cos t2 -> 1``: :func:`_parts`) on the same grid of ``t1``.
    """
    s = stack_constants(p)
    hs = half_space(p)

    def f(x: np.ndarray) -> np.ndarray:
        t1 = x - 1j * y[1]
        A, B = s["Z2"] * np.cos(t1), s["Z1"] * np.sin(t1)
        if hs:
            return np.abs(B - 1j * A)
        phi = np.arctan(B / A)
        return np.abs(A / np.cos(phi)) * np.abs(np.sinh(phi.imag - y[3]))

    x = np.linspace(0.0, 2.0 * math.pi, _R_GRID, endpoint=False)
    return refined_min(f, x, f(x))


def refined_min(f: Callable[[np.ndarray], np.ndarray], x: np.ndarray, v: np.ndarray) -> float:
    """Smallest of ``v = f(x)`` on a uniform grid ``x``, refined around its 8 smallest.

    65 points of ``f`` over the two neighbouring steps of each.
    """
    dx = x[1] - x[0]
    near = x[np.argsort(v)[:8]]
    fine = (near[:, None] + np.linspace(-dx, dx, 65)[None, :]).ravel()
    return float(min(v.min(), f(fine).min()))


def _search(full: Callable[[float], bool], subset: Callable[[float], bool] | None = None
            ) -> float:
    """The largest ``rho`` not excluded (module docstring), ``inf`` at :data:`RHO_MAX`.

    ``subset`` (default ``full``) is the test on a subset of the grid, whose "not excluded" is
    final: the halving uses it, the climb and the bisection ``full``.
    """
    subset = subset or full
    # halve on a subset of the grid to the first rho not excluded
    lo = RHO_MAX
    for _ in range(_HALVINGS):
        if not subset(lo):
            break
        lo *= 0.5
    else:
        return 0.0
    if lo == RHO_MAX:
        return math.inf
    # then on the whole grid: up from there to the first rho excluded, and bisect
    while not full(2.0 * lo):
        lo *= 2.0
        if lo >= RHO_MAX:
            return math.inf
    hi = 2.0 * lo
    for _ in range(_BISECTIONS):
        mid = math.sqrt(lo * hi)
        if full(mid):
            hi = mid
        else:
            lo = mid
    return hi


def _search_grid(ex: _OrbitExclusion) -> float:
    """:func:`_search` with ``ex``'s test (every :data:`_SUBSET`-th point while halving)."""
    return _search(ex.excluded, lambda rho: ex.excluded(rho, _SUBSET))


#: Smallest factor between the successive ``Omega`` of an incommensurate stack, squared
#: (:func:`_free_bound`).
_FREE_STEP = 4.0


@lru_cache(maxsize=4096)
def stack_pc_bound(p: Params, k: float, W: float) -> float:
    """Bound on ``Re Lambda`` of every root with ``|Im| > W``: two bodies by exclusion.

    ``alpha_pc > 0``, a half-space substrate, or phase rates that are not commensurate.

    Args:
        p: Parameters (finite ``mu2`` and ``H``; finite ``H2`` or a half-space substrate).
        k: Wavenumber ``> 0``.
        W: Frequency beyond which the bound holds.

    Returns:
        The largest ``rho`` not excluded (module docstring); ``inf`` when ``W <= 2 k c_d`` of
        either layer (or ``max(1, |Delta - 1|)``) or when :data:`RHO_MAX` is not excluded.
        Where the grids would exceed :data:`MAX_POINTS` (large ``k``: ``Omega`` grows as
        ``k^2``; session 33, ``inf`` before) the free torus beyond ``Omega``, as for rates
        that are not commensurate (it holds every orbit). 0.3-0.5 s a call for ``Omega`` up
        to 800, 9 s for 5 500 (measured); not commensurate: 0.8-1.8 s (``mu2 = 0.1, 3``,
        ``rho2 = 1``, ``H2 = 0.5``); cached. The stress top, ``mu2 = 4, rho2 = 1, H2 = 0.5``,
        ``alpha_pc = 0.02``, ``W`` of 4 ``c_d2``: from ``k = 27`` on the free torus (0.17 at
        ``k = 27``, 0.075 at 50, 0.080 at 100).
    """
    k, W = float(k), float(W)
    cmax = float(np.max(stack_constants(p)["c"]))
    if not (W > max(2.0 * k * cmax, 1.0, abs(p.Delta - 1.0))):
        return math.inf
    if period(p) is None or _points(p, k, W) > MAX_POINTS:
        # the free torus holds every orbit: also a commensurate one too long to sample (large
        # k, Omega growing as k^2; session 33: inf before)
        return _free_bound(p, k, W)
    return _search_grid(_Exclusion(p, k, W))


def _free_bound(p: Params, k: float, W: float) -> float:
    """:func:`stack_pc_bound` for phase rates that are not commensurate.

    Exact phases from ``W`` to ``Omega`` (:class:`_Exclusion`), the free torus beyond
    (:func:`free_excluded`): :func:`free_bound_of`.
    """
    return free_bound_of(_grid(p, k, W)[1], W,
                         lambda omega, start=None: _Exclusion(p, k, W, omega, start=start),
                         functools.partial(free_excluded, p, k, W))


def free_bound_of(h: float, W: float, exact: Callable[..., _OrbitExclusion],
                  free: Callable[[float, float], bool], target: float | None = None) -> float:
    """The bound of phase rates that are not commensurate (two bodies, layered sliders).

    Exact phases from ``W`` to ``Omega``, the free torus beyond, whose bound falls as
    ``Omega^(-1/2)``: the exact phases' bound ``rho_d`` on the first ``Omega = 2 W``, then
    ``Omega`` grown until the free torus's bound is at most ``rho_d`` (or the grid would
    exceed :data:`FREE_MAX_POINTS`), and the exact phases from ``2 W`` to the last ``Omega``
    checked at the larger of the two bounds (and its doublings up to :data:`RHO_MAX`); if a
    ``rho`` there is not excluded, the whole search on ``W .. Omega``.

    With a ``target`` (an adaptive region asks only whether a rung proves) the free torus
    is not searched to its smallest bound: where ``rho_d`` is below ``target``,
    :func:`_below_target` (a bound below ``target``, not the smallest, or ``inf``); where it
    is not, ``inf``: no bound below it exists, and none is sought (a climb asks several rungs
    whose bounds it does not keep).

    Args:
        h: The exact phases' grid step.
        W: Frequency beyond which the bound holds.
        exact: ``exact(omega, start=None)``: the exclusion on the exact phases from ``start``
            (default ``W``) to ``omega``.
        free: ``free(omega, rho)``: the free torus beyond ``omega`` excludes ``rho``.
        target: See above (``None``: the smallest bound).
    """
    # the free torus takes every real part, so the k-offsets of the commensurate tube do not
    # set Omega here
    omega0 = 2.0 * W
    if (omega0 - W) / h > FREE_MAX_POINTS:
        return math.inf
    rho_d = _search_grid(exact(omega0))
    if not math.isfinite(rho_d):
        return math.inf
    omega_max = W + FREE_MAX_POINTS * h
    if target is not None:  # rho_d not below it: no bound below target, none sought
        return (math.inf if rho_d >= target
                else _below_target(exact, free, W, omega_max, rho_d, target))
    omega = omega0
    while True:
        rho_f = _search(functools.partial(free, omega))
        if rho_f <= rho_d or omega >= omega_max:
            break
        # the free torus's bound falls as omega^(-1/2): jump to where it would be rho_d (a
        # third beyond), at least by _FREE_STEP's square root
        omega = min(omega_max, omega * max(math.sqrt(_FREE_STEP),
                                           1.3 * (rho_f / rho_d) ** 2 if rho_d > 0 else 1e9))
    rho = max(rho_d, rho_f)
    if not math.isfinite(rho) or omega == omega0:
        return rho
    if _excluded_up(exact(omega, start=omega0).excluded, rho):
        return rho
    return _search(functools.partial(_both, exact(omega), free, omega))


#: :func:`free_bound_of` with a target: the ``rho`` tested first and last, as fractions of it.
FREE_TARGET = (0.8, 0.99)


def _below_target(exact: Callable[..., _OrbitExclusion], free: Callable[[float, float], bool],
                  W: float, omega_max: float, rho_d: float, target: float) -> float:
    """:func:`free_bound_of` with a ``target`` above ``rho_d``: a bound below it, or ``inf``.

    ``rho = max(rho_d, 0.8 target)`` and its doublings on the free torus beyond ``Omega = 2 W,
    4 W, ...`` until excluded (at the largest ``Omega``, ``0.99 target`` instead), then on the
    exact phases from ``2 W`` to that ``Omega`` (where they do not exclude it, their own bound,
    if below the target and excluded beyond). ``inf``: no bound below the target found.
    """
    omega0 = 2.0 * W
    rho, omega = max(rho_d, FREE_TARGET[0] * target), omega0
    while not _excluded_up(functools.partial(free, omega), rho):
        if omega >= omega_max:
            rho = max(rho_d, FREE_TARGET[1] * target)
            if not _excluded_up(functools.partial(free, omega), rho):
                return math.inf
            break
        omega = min(omega_max, 2.0 * omega)  # its bound falls by sqrt 2
    if omega == omega0:
        return rho
    ext = exact(omega, start=omega0)
    # the doublings (the excluded rho form an interval up to RHO_MAX: a check) on every
    # _SUBSET-th point and all the dips' points, where the dips are wider than at rho
    if _excluded_up(ext.excluded, rho, functools.partial(ext.excluded, every=_SUBSET)):
        return rho
    rho = max(rho, _search_grid(ext))
    return rho if rho < target and _excluded_up(functools.partial(free, omega), rho) else math.inf


def _excluded_up(test: Callable[[float], bool], rho: float,
                 doublings: Callable[[float], bool] | None = None) -> bool:
    """``test`` excludes ``rho``, and ``doublings`` (default ``test``) its doublings.

    Up to :data:`RHO_MAX`.
    """
    if not test(rho):
        return False
    r = 2.0 * rho
    while r < RHO_MAX:
        if not (doublings or test)(r):
            return False
        r *= 2.0
    return True


def _both(ex: _OrbitExclusion, free: Callable[[float, float], bool], omega: float,
          rho: float) -> bool:
    """``ex``'s exact phases and the free torus beyond ``omega`` both exclude ``rho``."""
    return ex.excluded(rho) and free(omega, rho)
