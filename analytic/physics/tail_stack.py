"""High-frequency tail of a two-body stack (slider on a deformable substrate) at fixed ``k``.

Derivation (docs/design.md section 8.1, docs/twobody.md). At ``k = 0`` the ``x`` and ``y``
motions of both layers decouple. The ``y`` (dilatational) part is a free-free composite rod
(``s_yy = 0`` at both outer boundaries for every ``bc``, ``bc2``; ``u_y``, ``s_yy``
continuous at ``y = 0``) with resonances ``R = Z1 sin t1 cos t2 + Z2 cos t1 sin t2 = 0``
(``t1 = beta H omega``, ``t2 = H2 omega / c_d2``, ``Z1 = 1/beta``, ``Z2 = rho2 c_d2``): these
carry the instability through ``f s_yy``. Write each body's interface displacements as
compliances of the interface stresses ``(s_xy, s_yy)``: ``dC = C1 - C2`` (slider minus
substrate). The friction law and ``[u_y] = 0`` give the 2x2 determinant::

    dC_21 (b - F_0 dC_12) - dC_22 (a - F_0 dC_11) = 0

(``a = 1 + alpha_pc L``, ``b = f_eff``). ``dC_22 = 0`` is the rod's resonance; ``dC_21`` is
first order in ``k`` (the ``i k`` coupling of ``u_x`` to ``u_y`` in the bulk, by reciprocity
against the homogeneous rod solution). The first-order shift of a resonance root (``L = i
omega``, real phases ``p1 = H omega``, ``p2 = H2 omega / c_s2`` of the shear waves) is::

    dLambda = (k / omega) b Z1 Z2 X / (R' Y)

    X  = G1 d2 sin t2 - G2 d1 sin t1 / rho2
    Y  = d1 d2 + i (1 + e) (n1 d2 + n2 d1 / (rho2 c_s2)) / gamma
    R' = dR/domega,   e = (Delta - 1)/(L + 1)

per body (``beta_j``, shear phase ``p``, dilatational phase ``t``): velocity end ``d = cos p,
n = sin p, G = cos p sin t - 2 beta_j sin p cos t``; stress end ``d = sin p, n = -cos p,
G = sin p sin t - 2 beta_j (1 - cos p cos t)``. Checked against ``-D_k/D_Lambda`` of
:func:`analytic.physics.twobody.det_twobody` at small ``k`` (tests/test_tail.py). With the
substrate's compliances set to zero (a rigid substrate) the compliance form reduces to
:mod:`analytic.physics.smallk`'s slope (by hand, not tested).

**Why no sup over independent phases.** ``|Re dLambda| omega / k`` is unbounded on the torus
of independent phases: at ``d1 = d2 = 0`` (both bodies at a shear resonance at the same
frequency, so an undamped stack shear mode without slip) both ``X`` and ``Y`` vanish and
``X / Y`` takes any value along ``n1 d2 + n2 d1 / (rho2 c_s2) = 0`` (unless ``mu2 = 1``).
The first-order theory breaks down there (three nearly degenerate roots). So the bound uses
the phases the stack really has: at frequency ``omega`` and wavenumber ``k`` the partial waves
of layer ``j`` turn by ``psi_j = H_j sqrt(omega^2/c_j^2 - k^2)``. The bound at ``W`` is the
largest first-order ``|Re dLambda|`` over

- every resonance of these exact phases with ``omega <= Omega`` whose root may lie beyond
  ``W`` (``omega >= W``, or below ``W`` by less than twice the first-order ``|dLambda|``;
  found on a fine grid, bisected), and
- for ``omega > Omega``: the resonances of the ``k = 0`` phases ``a_j omega`` shifted by
  ``0 <= a_j omega - psi_j <= eps_j = H_j c_j k^2 / Omega`` (each independently, a grid of
  :data:`TUBE_POINTS` per phase and the grid's spread added), over one period of the ``k = 0``
  phases. That needs commensurate phase rates ``a_j = (H, beta H, H2/c_s2, H2/c_d2)`` (ratios
  rational with denominators up to :data:`MAX_DENOMINATOR`); otherwise the ``k = 0`` phases
  come arbitrarily close to a shear coincidence and no bound is given.

The terms left out are relative ``O(k/omega)`` (as for the rigid bound): the factor
``(1 + k/W)`` is a margin, not derived, checked against exact roots (tests/test_tail.py).
Not covered by the derivation, and only measured: the near-neutral stack shear modes (both
bodies near a shear resonance, little slip), whose shift is not first order in ``f s_yy``.
"""

from __future__ import annotations

import math
from fractions import Fraction
from functools import lru_cache

import numpy as np

from analytic.params import Params

#: Largest denominator accepted for the ratios of the stack's phase rates.
MAX_DENOMINATOR = 64
#: Grid points per phase offset in the tube beyond ``Omega``.
TUBE_POINTS = 3
#: Largest phase offset allowed beyond ``Omega`` (radians); sets ``Omega``.
TUBE_EPS = 0.02
#: Grid steps per ``pi`` of the fastest resonance phase when searching resonances.
_STEPS_PER_PI = 40
#: Largest number of grid points spent on the exact-phase part (they grow as ``k^2``: 4.77
#: million at ``k = 100`` for ``mu2 = 4, rho2 = 1, H2 = 0.5``, 0.8-2.2 s a bound; session 36:
#: 4 million before, ``inf`` there). Evaluated in chunks of :data:`_CHUNK`.
_MAX_SAMPLES = 20_000_000
#: Grid points of the exact-phase part evaluated at once (:func:`exact_resonances`): the whole
#: grid at once took 720 MB at 4.77 million points.
_CHUNK = 500_000
#: Largest number of grid points per offset spent on one period of the ``k = 0`` phases.
_MAX_PERIOD_SAMPLES = 100_000


def stack_constants(p: Params) -> dict[str, np.ndarray | float]:
    """Heights, wave speeds and phase rates of ``(p1, t1, p2, t2)``; impedances ``Z1, Z2``."""
    m2 = p.substrate
    H = np.array([p.H, p.H, p.H2, p.H2])
    c = np.array([1.0, 1.0 / p.beta, m2.c_s, m2.c_d])
    return {"H": H, "c": c, "rates": H / c, "Z1": 1.0 / p.beta, "Z2": p.rho2 * m2.c_d,
            "Zs": p.rho2 * m2.c_s}


def exact_phases(p: Params, k: float, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``psi_j(omega)`` and ``d psi_j / d omega`` (shape ``(4, n)``) for ``omega > k c_j``."""
    s = stack_constants(p)
    H, c = s["H"][:, None], s["c"][:, None]
    q = np.sqrt((w[None, :] / c) ** 2 - k * k)
    return H * q, H * w[None, :] / (c * c * q)


def resonance(p: Params, phases: np.ndarray, rates: np.ndarray | None = None
              ) -> tuple[np.ndarray, np.ndarray | None]:
    """``R`` of the dilatational rod and ``dR/domega`` (when the phase rates are given)."""
    s = stack_constants(p)
    Z1, Z2 = s["Z1"], s["Z2"]
    s1, c1, s2, c2 = np.sin(phases[1]), np.cos(phases[1]), np.sin(phases[3]), np.cos(phases[3])
    R = Z1 * s1 * c2 + Z2 * c1 * s2
    if rates is None:
        return R, None
    r1, r2 = rates[1], rates[3]
    dR = (Z1 * r1 + Z2 * r2) * c1 * c2 - (Z1 * r2 + Z2 * r1) * s1 * s2
    return R, dR


def _end(bc: str, beta: float, ps: np.ndarray, t: np.ndarray
         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(d, n, G)`` of one body's outer end (module docstring)."""
    return _end_trig(bc, beta, np.sin(ps), np.cos(ps), np.sin(t), np.cos(t))


def _end_trig(bc: str, beta: float, sp: np.ndarray, cp: np.ndarray, st: np.ndarray,
              ct: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`_end` of the shear phase's and the dilatational phase's sines and cosines."""
    if bc == "velocity":
        return cp, sp, cp * st - 2.0 * beta * sp * ct
    return sp, -cp, sp * st - 2.0 * beta * (1.0 - cp * ct)


def end_coefficients(bc: str, beta: float, sp: np.ndarray, cp: np.ndarray
                     ) -> tuple[np.ndarray, ...]:
    """``(d, n, g0, gs, gc)`` of one body's end, ``G = g0 + gs sin t + gc cos t``.

    :func:`_end_trig` with ``G`` split by the dilatational phase's sine and cosine, for a
    bound taken over that phase separately (:mod:`analytic.physics.tail_stack_pc`'s free
    torus); equal to it to rounding (tests/test_tail.py).
    """
    if bc == "velocity":
        return cp, sp, np.zeros_like(sp), cp, -2.0 * beta * sp
    return sp, -cp, np.full_like(sp, -2.0 * beta), sp, 2.0 * beta * cp


def stack_parts(p: Params, sn: np.ndarray, cs: np.ndarray, bc2: str | None = None
                ) -> tuple[np.ndarray, ...]:
    """``R``, ``X``, ``d1 d2``, ``N``, ``d1``, ``d2`` of the phases' sines and cosines.

    One pass (each phase's sine and cosine given once, shape ``(4, ...)``): :func:`resonance`'s
    ``R`` and :func:`_xyn`'s ``X``, ``d1 d2``, ``N`` (module docstring), for the callers that
    need them all (:mod:`analytic.physics.tail_stack_pc`). ``bc2`` overrides ``p.bc2`` (the
    half-space substrate's radiating limit takes the velocity end's form).
    """
    s = stack_constants(p)
    d1, n1, G1 = _end_trig(p.bc, p.beta, sn[0], cs[0], sn[1], cs[1])
    d2, n2, G2 = _end_trig(bc2 or p.bc2, p.substrate_beta, sn[2], cs[2], sn[3], cs[3])
    R = s["Z1"] * sn[1] * cs[3] + s["Z2"] * cs[1] * sn[3]
    X = G1 * d2 * sn[3] - G2 * d1 * sn[1] / p.rho2
    return R, X, d1 * d2, n1 * d2 + n2 * d1 / s["Zs"], d1, d2


def first_order_shift(p: Params, k: float, w: np.ndarray, phases: np.ndarray,
                      dR: np.ndarray) -> np.ndarray:
    """The first-order shift ``dLambda`` of the resonance root at ``Lambda ~ i omega``.

    Complex, with the friction law's ``b``, ``e`` and ``a = 1 + alpha_pc L`` (which multiplies
    ``d1 d2`` in ``Y``) at ``L = i omega`` exactly (a check of the closed form against the
    determinant; the ``alpha_pc = 0`` bound uses :func:`growth_factor`, the ``alpha_pc > 0``
    one :mod:`analytic.physics.tail_stack_pc`).
    """
    X, Dd, N = _xyn(p, phases)
    L = 1j * w
    s = stack_constants(p)
    e = (p.Delta - 1.0) / (L + 1.0)
    b = p.f - p.alpha_ld * L / (L + 1.0)
    Y = (1.0 + p.alpha_pc * L) * Dd + 1j * (1.0 + e) * N / p.gamma
    return (k / w) * b * s["Z1"] * s["Z2"] * X / (dR * Y)


def _xyn(p: Params, phases: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``X``, ``d1 d2`` and ``n1 d2 + n2 d1 / (rho2 c_s2)`` (module docstring)."""
    return stack_parts(p, np.sin(phases), np.cos(phases))[1:4]


def growth_factor(p: Params, w: np.ndarray | float, phases: np.ndarray, dR: np.ndarray
                  ) -> np.ndarray:
    """``K`` with ``|Re dLambda| <= k K / omega`` at a resonance, for every ``omega >= w``.

    ``|Re(b / Y)| <= |Re b| |Re Y| / |Y|^2 + |Im b| / |Y|`` with ``|Re b| <= |f - alpha_ld| +
    alpha_ld / omega``, ``|Im b| <= alpha_ld / omega``, ``|e| <= |Delta - 1| / omega``.
    ``inf`` where the lower bound on ``|Y|`` is not positive.
    """
    X, Dd, N = _xyn(p, phases)
    s = stack_constants(p)
    w = np.asarray(w, dtype=float)
    eps = abs(p.Delta - 1.0) / w
    br = abs(p.f - p.alpha_ld) + p.alpha_ld / w
    bi = p.alpha_ld / w
    ymin = np.sqrt(Dd * Dd + (N / p.gamma) ** 2) - eps * np.abs(N) / p.gamma
    with np.errstate(divide="ignore", invalid="ignore"):
        rb = br * (np.abs(Dd) + eps * np.abs(N) / p.gamma) / ymin**2 + bi / ymin
        K = s["Z1"] * s["Z2"] * np.abs(X) / np.abs(dR) * rb
    return np.where((ymin > 0) & np.isfinite(K), K, math.inf)


def _roots_on_grid(fun, t: np.ndarray) -> np.ndarray:  # noqa: ANN001
    """Every sign change of ``fun`` on the grid ``t``, bisected to rounding (vectorised)."""
    return roots_on_grid_rows(lambda x, row: fun(x), t, 1, 60)[0]


def _sign_changes(fun, t: np.ndarray, rows: int  # noqa: ANN001
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``fun(x, row)`` on the grid ``t`` for each row, and where it changes sign (or is 0).

    Returns ``(i, j, v)``: a sign change between ``t[j]`` and ``t[j + 1]`` on row ``i``, and
    the values ``v`` (rows x grid).
    """
    X = np.broadcast_to(t[None, :], (rows, len(t)))
    v = fun(X.ravel(), np.broadcast_to(np.arange(rows)[:, None], X.shape).ravel())
    v = v.reshape(X.shape)
    i, j = np.nonzero(np.sign(v[:, :-1]) * np.sign(v[:, 1:]) <= 0)
    return i, j, v


def roots_on_grid_rows(fun, t: np.ndarray, rows: int, steps: int  # noqa: ANN001
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Every sign change of ``fun(x, row)`` on the grid ``t``, for each of ``rows`` rows.

    Vectorised bisection, ``steps`` halvings. Returns ``(x, row)`` of every zero found.
    """
    i, j, v = _sign_changes(fun, t, rows)
    lo, hi, flo = t[j], t[j + 1], v[i, j]
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        fm = fun(mid, i)
        left = np.sign(flo) * np.sign(fm) <= 0
        hi = np.where(left, mid, hi)
        lo = np.where(left, lo, mid)
        flo = np.where(left, flo, fm)
    return 0.5 * (lo + hi), i


def zeros_on_grid_rows(fun, t: np.ndarray, rows: int, steps: int  # noqa: ANN001
                       ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`roots_on_grid_rows` by the Illinois method instead of bisection.

    Each bracket of a sign change on the grid ``t`` is narrowed by regula falsi with the
    Illinois halving (both ends move; superlinear) until every bracket is at most ``steps``
    bisections' width, ``(t[1] - t[0]) 2^-steps``, or after ``steps`` iterations (then the
    bracket's midpoint). The same zeros as the bisection to that width, in fewer evaluations
    (the layered tail bound's dips: 8-12 instead of 32, session 35).
    """
    i, j, v = _sign_changes(fun, t, rows)
    a, b, fa, fb = t[j], t[j + 1], v[i, j], v[i, j + 1]
    tol = (float(t[1] - t[0]) if len(t) > 1 else 0.0) * 2.0 ** -steps
    done = (fa == 0) | (fb == 0)
    root = np.where(fa == 0, a, b)
    for _ in range(steps):
        todo = ~done & (np.abs(b - a) > tol)
        if not todo.any():
            break
        den = np.where(todo, fb - fa, 1.0)
        c = np.where(todo & (den != 0), b - fb * (b - a) / np.where(den != 0, den, 1.0),
                     0.5 * (a + b))
        fc = np.zeros_like(fb)
        fc[todo] = fun(c[todo], i[todo])
        hit = todo & (fc == 0)
        root = np.where(hit, c, root)
        done = done | hit
        flip = todo & ~hit & (np.sign(fc) != np.sign(fb))  # the zero between c and b
        a, fa = np.where(flip, b, a), np.where(flip, fb, np.where(todo & ~hit, 0.5 * fa, fa))
        b, fb = np.where(todo & ~hit, c, b), np.where(todo & ~hit, fc, fb)
    return np.where(done, root, 0.5 * (a + b)), i


def exact_resonances(p: Params, k: float, w1: float, w2: float) -> np.ndarray:
    """Frequencies ``w1 <= omega <= w2`` where the exact phases at ``k`` make ``R = 0``."""
    rates = stack_constants(p)["rates"]
    h = math.pi / (_STEPS_PER_PI * (rates[1] + rates[3]))
    n = int(math.ceil((w2 - w1) / h)) + 1
    w = np.linspace(w1, w2, max(n, 2))

    def fun(x: np.ndarray) -> np.ndarray:
        return resonance(p, exact_phases(p, k, x)[0])[0]

    # chunks sharing their end points: every interval of the grid in exactly one chunk
    return np.concatenate([_roots_on_grid(fun, w[a:a + _CHUNK + 1])
                           for a in range(0, len(w) - 1, _CHUNK)])


def period(p: Params) -> float | None:
    """Period in ``omega`` of the ``k = 0`` phases (all ``2 pi`` periodic), or ``None``."""
    return period_of_rates(stack_constants(p)["rates"])


def period_of_rates(a: np.ndarray) -> float | None:
    """Common period in ``omega`` of the phases ``a_j omega`` (``a_0 > 0``), or ``None``.

    A rate of 0 (a phase that does not turn) leaves the period alone.
    """
    if not np.all(np.isfinite(a)):
        return None
    den = 1
    for r in a[1:] / a[0]:
        q = Fraction(float(r)).limit_denominator(MAX_DENOMINATOR)
        if abs(float(q) - r) > 1e-12 * r:
            return None
        den = den * q.denominator // math.gcd(den, q.denominator)
    return 2.0 * math.pi * den / a[0]


def _tube_factor(p: Params, omega: float, eps: np.ndarray) -> float:
    """Sup of ``K`` over the ``k = 0`` orbit's resonances, phases lowered by up to ``eps``."""
    T = period(p)
    rates = stack_constants(p)["rates"]
    grid = np.linspace(0.0, 1.0, TUBE_POINTS)
    offs = np.stack(np.meshgrid(*([grid] * 4), indexing="ij"), -1).reshape(-1, 4) * eps
    h = math.pi / (_STEPS_PER_PI * (rates[1] + rates[3]))
    if T / h > _MAX_PERIOD_SAMPLES:
        return math.inf  # a very long period: not sampled
    t = np.linspace(0.0, T, int(math.ceil(T / h)) + 2)
    per_res = []
    for off in offs:
        def fun(x: np.ndarray, off: np.ndarray = off) -> np.ndarray:
            return resonance(p, rates[:, None] * x[None, :] - off[:, None])[0]
        x = _roots_on_grid(fun, t)
        x = x[x < T]
        ph = rates[:, None] * x[None, :] - off[:, None]
        per_res.append(growth_factor(p, omega, ph, resonance(p, ph, rates)[1]))
    if len({len(v) for v in per_res}) != 1:
        return math.inf  # the offsets change the resonance count: too coarse a grid
    K = np.array(per_res)
    if not np.all(np.isfinite(K)):
        return math.inf
    return float(K.max() + (K.max(axis=0) - K.min(axis=0)).max())


def shift_modulus(p: Params, w: np.ndarray | float, phases: np.ndarray, dR: np.ndarray
                  ) -> np.ndarray:
    """``M`` with ``|dLambda| <= k M / omega`` at a resonance (how far its root moves)."""
    X, Dd, N = _xyn(p, phases)
    s = stack_constants(p)
    w = np.asarray(w, dtype=float)
    eps = abs(p.Delta - 1.0) / w
    ymin = np.sqrt(Dd * Dd + (N / p.gamma) ** 2) - eps * np.abs(N) / p.gamma
    with np.errstate(divide="ignore", invalid="ignore"):
        M = (s["Z1"] * s["Z2"] * np.abs(X) / np.abs(dR)
             * (abs(p.f - p.alpha_ld) + p.alpha_ld / w) / ymin)
    return np.where((ymin > 0) & np.isfinite(M), M, math.inf)


@lru_cache(maxsize=4096)
def stack_tail_bound(p: Params, k: float, W: float) -> float:
    """``k (1 + k/W) max K / omega`` over the resonances whose roots may lie beyond ``W``.

    Those are the resonances ``omega >= W`` and those below ``W`` whose root may move above it
    (``omega + 2 k (1 + k/W) M / omega >= W``, :func:`shift_modulus`); module docstring.
    ``inf`` when ``W <= 2 k c_d`` of either layer, when the ``k = 0`` phases are not
    commensurate (:func:`period`), when such a shift reaches far below ``W`` (the expansion
    does not hold), or when the bound is not finite. Cached (0.3-0.9 s a call for
    ``k <= 40``; the adaptive region asks for the same ``(p, k, W)`` several times).
    """
    s = stack_constants(p)
    cmax = float(np.max(s["c"]))
    if not (W > max(2.0 * k * cmax, 1.0, abs(p.Delta - 1.0))) or period(p) is None:
        return math.inf
    margin = 1.0 + k / W
    omega = max(W, float(np.max(s["H"] * s["c"])) * k * k / TUBE_EPS)
    lo = max(0.8 * W, 1.5 * k * cmax)
    n = (omega - lo) * _STEPS_PER_PI * (s["rates"][1] + s["rates"][3]) / math.pi
    if n > _MAX_SAMPLES:
        return math.inf
    w = exact_resonances(p, k, lo, omega)
    ph, dph = exact_phases(p, k, w)
    dR = resonance(p, ph, dph)[1]
    reach = w + 2.0 * k * margin * shift_modulus(p, w, ph, dR) / w
    keep = reach >= W
    if np.any(keep & (w < lo + 0.25 * (W - lo))):
        return math.inf  # a root may move by a good part of W: no expansion
    K = growth_factor(p, w[keep], ph[:, keep], dR[keep])
    best = float(np.max(K / w[keep], initial=0.0))
    eps = s["H"] * s["c"] * k * k / omega
    best = max(best, _tube_factor(p, omega, eps) / omega)
    return k * margin * best
