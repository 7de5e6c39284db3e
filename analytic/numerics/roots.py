"""Generic root tools for a scalar function of one complex variable.

Three tools, for any function ``F`` analytic (or meromorphic) in a region:

- :func:`polish`: Newton's method (finite-difference derivative unless ``dfun`` is given), with
  damped steps and a secant fall-back; never raises on non-convergence, reports it in a
  :class:`Root`.
- :func:`count_zeros`: the argument principle on a rectangle, with adaptive sampling of the
  contour so that the winding number is reliable; it counts *zeros minus poles*, so known poles
  can be passed in (``poles=``) and are added back.
- :func:`zeros_in_box`: all zeros inside a rectangle, by recursive subdivision + counting +
  polishing; the total is checked against the count of the whole box, so "all roots in this
  region" is a checked statement.

The argument principle only needs the *phase* of ``F`` on the contour. A function ``G = rho F``
with ``rho > 0`` real and continuous (e.g. a determinant normalised by row norms, or a scaling
``exp(-H Re k)`` that prevents overflow) has the same winding number as ``F`` and the same zeros,
and Newton's method still converges quadratically on it (the derivative is taken as the Wirtinger
derivative ``dG/dz``, equal to ``rho F'`` at a root). Such phase-faithful functions are accepted.

Functions are called with a 1D complex numpy array and must return an array of the same shape
(vectorised). Wrap a scalar function with ``np.vectorize`` otherwise.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from analytic.numerics.steps import Steps, run_steps

ComplexFunction = Callable[[np.ndarray], np.ndarray]
Box = tuple[float, float, float, float]

_EPS = np.finfo(float).eps


class ContourError(RuntimeError):
    """The argument principle cannot be trusted on this contour (zero/pole on or near it)."""


@dataclass
class Root:
    """A polished root and how much to trust it.

    Attributes:
        value: The root ``z``.
        residual: ``|F(z)| / scale``: the function value relative to its typical magnitude
            ``scale`` (an argument of :func:`polish`; 1 for functions normalised to ``|F| <= 1``
            such as :func:`analytic.physics.finite_h.det_M`).
        cond: Relative condition number ``scale / (|F'(z)| max(|z|, 1e-300))``: a perturbation of
            ``F`` of relative size ``e`` (relative to ``scale``) moves the root by about
            ``cond * e * |z|``. With ``e`` ~ 1e-16 it estimates the attainable relative accuracy.
        iterations: Newton iterations used.
        converged: True if the last Newton correction was below ``tol * max(|z|, 1)``, or the
            residual reached the rounding level of ``F``.
        reason: Why the iteration stopped (human-readable).
        step: Size of the last Newton correction ``|dz|`` (a forward-error estimate).
    """

    value: complex
    residual: float
    cond: float
    iterations: int
    converged: bool
    reason: str
    step: float = math.nan


def _call(fun: ComplexFunction, z: np.ndarray) -> np.ndarray:
    out = np.asarray(fun(np.asarray(z, dtype=complex)), dtype=complex)
    if out.shape != np.shape(z):
        out = np.broadcast_to(out, np.shape(z)).astype(complex)
    return out


def _stencil(z: complex | np.ndarray) -> tuple[float | np.ndarray, np.ndarray]:
    """Step and points of the central-difference derivative at ``z``.

    ``z`` a point or an array (the points are then ``(4,) + z.shape``).
    """
    h = 6e-6 * np.maximum(np.abs(z), 1e-3)  # ~ eps**(1/3): balances truncation and rounding
    return h, np.array([z + h, z - h, z + 1j * h, z - 1j * h])


def _wirtinger(f: np.ndarray, h: float | np.ndarray) -> complex | np.ndarray:
    """dF/dz from ``F`` at the four points of :func:`_stencil` (``f[0..3]``)."""
    dx = (f[0] - f[1]) / (2 * h)
    dy = (f[2] - f[3]) / (2 * h)
    return 0.5 * (dx - 1j * dy)


def _derivative(fun: ComplexFunction, z: complex, dfun: ComplexFunction | None) -> complex:
    """``dfun(z)``, or the Wirtinger derivative dF/dz by central differences (one batch of 4)."""
    if dfun is not None:
        return complex(_call(dfun, np.array([z]))[0])
    h, pts = _stencil(z)
    return complex(_wirtinger(_call(fun, pts), h))


def _value_and_derivative(fun: ComplexFunction, z: complex, dfun: ComplexFunction | None
                          ) -> tuple[complex, complex]:
    """``(F(z), F'(z))`` in one call of ``fun`` (with the difference stencil)."""
    if dfun is not None:
        return complex(_call(fun, np.array([z]))[0]), _derivative(fun, z, dfun)
    h, pts = _stencil(z)
    f = _call(fun, np.concatenate([[z], pts]))
    return complex(f[0]), complex(_wirtinger(f[1:], h))


def stencil_request(kind: str, z: complex) -> tuple[np.ndarray, float]:
    """The points where ``F`` answers a ``("vd", z)`` or ``("d", z)`` request, and the step.

    For answering many requests in one vectorised call; :func:`stencil_answer` makes the
    answer from ``F`` at those points (as :func:`point_answers` does with ``fun``).
    """
    h, pts = _stencil(z)
    return (np.concatenate([[z], pts]) if kind == "vd" else pts), h


def stencil_answer(kind: str, f: np.ndarray, h: float) -> complex | tuple[complex, complex]:
    """The answer to a ``("vd", z)`` or ``("d", z)`` request from ``F`` at its points."""
    if kind == "vd":
        return complex(f[0]), complex(_wirtinger(f[1:], h))
    return complex(_wirtinger(f, h))


def point_answers(fun: ComplexFunction, dfun: ComplexFunction | None = None
                  ) -> Callable[[tuple[str, Any]], Any]:
    """The answers of ``fun`` (and ``dfun``) to the requests of this module's step-wise algorithms.

    ``("vd", z)``: ``(F(z), F'(z))`` (:func:`_value_and_derivative`); ``("d", z)``: ``F'(z)``;
    ``("f", z)``: ``fun(z)`` at the points ``z`` (an array; rows for several functions).
    """

    def answer(req: tuple[str, Any]) -> Any:
        kind, z = req
        if kind == "vd":
            return _value_and_derivative(fun, z, dfun)
        if kind == "d":
            return _derivative(fun, z, dfun)
        return fun(z)

    return answer


def polish(
    fun: ComplexFunction,
    z0: complex,
    *,
    dfun: ComplexFunction | None = None,
    tol: float = 1e-14,
    maxiter: int = 60,
    scale: float = 1.0,
    unwanted: Callable[[complex, float], bool] | None = None,
) -> Root:
    """Polish a root of ``fun`` starting from ``z0`` (Newton, damped, secant fall-back).

    Args:
        fun: Vectorised complex function (see module docstring).
        z0: Starting guess.
        dfun: Derivative of ``fun`` (vectorised); finite differences if None.
        tol: Relative step tolerance: converged when ``|dz| <= tol * max(|z|, 1)``.
        maxiter: Maximum number of Newton iterations.
        scale: Typical magnitude of ``fun`` (defines :attr:`Root.residual` and :attr:`Root.cond`).
        unwanted: ``unwanted(w, r)``: no root within ``r`` of ``w`` is wanted (e.g. ``w`` is
            farther than ``r`` from a box, or next to a root already found). Asked once the
            steps contract (a step at most half the one before): with ``dz`` the step from
            ``z``, ``w = z + dz`` and ``r = ABANDON_RADIUS |dz|``; ``True`` stops the iteration,
            not converged (:data:`ABANDONED`).

    Returns:
        A :class:`Root`; check :attr:`Root.converged` and :attr:`Root.reason`.
    """
    return run_steps(polish_steps(z0, tol=tol, maxiter=maxiter, scale=scale, unwanted=unwanted),
                     point_answers(fun, dfun))


def polish_steps(z0: complex, *, tol: float = 1e-14, maxiter: int = 60, scale: float = 1.0,
                 unwanted: Callable[[complex, float], bool] | None = None,
                 ask: Callable[[str, complex], Any] = lambda kind, z: (kind, z)
                 ) -> Steps[Root]:
    """:func:`polish` as a step-wise algorithm (:mod:`analytic.numerics.steps`).

    It yields ``ask("vd", z)`` for ``(F(z), F'(z))`` and ``ask("d", z)`` for ``F'(z)``
    (:func:`point_answers` answers ``(kind, z)``, the default ``ask``) and returns the
    :class:`Root`. The other arguments are :func:`polish`'s.
    """
    z = complex(z0)
    # F(z0) and the first derivative in one call; later ones come with each accepted step
    fz, pending = yield ask("vd", z)
    prev: tuple[complex, complex] | None = None
    step = math.inf
    reason = f"maximum number of iterations ({maxiter}) reached"
    converged = False
    it = 0
    dfz = complex("nan")
    if not np.isfinite(fz):
        return Root(z, math.inf, math.inf, 0, False, "function not finite at the start point")
    for _ in range(maxiter):
        it += 1
        if fz == 0:
            converged, reason, step = True, "exact zero", 0.0
            dfz = pending if pending is not None else complex("nan")  # at this z
            break
        if pending is not None:
            dfz, pending = pending, None
        else:
            dfz = yield ask("d", z)
        dz = _direction(z, fz, dfz, prev)
        last, step = step, abs(dz)
        if step <= tol * max(abs(z), 1.0):
            z += dz
            fz, dfz = yield ask("vd", z)  # dfz: for cond, at the final z
            converged, reason = True, "Newton step below tolerance"
            break
        if (unwanted is not None and step <= 0.5 * last < math.inf
                and unwanted(z + dz, ABANDON_RADIUS * step)):
            reason = ABANDONED
            break
        zn, fn, pending = yield from _damped_steps(z, fz, dz, ask)
        if zn is None:
            if step <= 1e3 * tol * max(abs(z), 1.0) or abs(fz) <= 1e3 * _EPS * scale:
                converged, reason = True, "residual at the rounding level of the function"
            else:
                reason = "no decrease of |F| along the Newton direction (stagnation)"
            break
        prev = (z, fz)
        z, fz = zn, fn
    # (on every exit above dfz is already the derivative at the final z, unless not finite)
    if not np.isfinite(dfz) or dfz == 0:
        dfz = yield ask("d", z)
    absd = abs(dfz) if np.isfinite(dfz) else 0.0
    cond = scale / (absd * max(abs(z), 1e-300)) if absd > 0 else math.inf
    residual = abs(fz) / scale if np.isfinite(fz) else math.inf
    return Root(z, residual, cond, it, converged, reason, step)


#: :func:`polish`'s ``unwanted`` radius in units of the step. Once Newton's steps contract
#: (each at most half the one before) the root lies within about one step of ``z + dz`` (the
#: steps that follow add up to at most ``|dz|`` for a ratio of 1/2); four steps leave a margin.
ABANDON_RADIUS = 4.0
#: :attr:`Root.reason` of a polish stopped by ``unwanted``.
ABANDONED = "abandoned: converging to a root not wanted (outside the box or already found)"


def _direction(z: complex, fz: complex, dfz: complex, prev: tuple[complex, complex] | None
               ) -> complex:
    """Newton step; the secant step (or a nudge off a critical point) where ``F' = 0``."""
    if np.isfinite(dfz) and dfz != 0:
        return -fz / dfz
    if prev is not None and prev[1] != fz:  # secant fall-back
        return -fz * (z - prev[0]) / (fz - prev[1])
    return 1e-6 * max(abs(z), 1.0) * (1 + 1j)  # nudge off a critical point


def _damped_steps(z: complex, fz: complex, dz: complex, ask: Callable[[str, complex], Any]
                  ) -> Steps[tuple[complex | None, complex, complex | None]]:
    """Halve the step until ``|F|`` decreases: ``(z_new, F(z_new), F'(z_new))``.

    ``z_new`` is None when twelve halvings did not decrease ``|F|``. The value and the next
    derivative come in one request (one request per Newton step).
    """
    lam = 1.0
    fn: complex = fz
    for _ in range(12):
        zn = z + lam * dz
        fn, pending = yield ask("vd", zn)
        if np.isfinite(fn) and abs(fn) < abs(fz):
            return zn, fn, pending
        lam *= 0.5
    return None, fn, None


def _box_checked(box: Sequence[float]) -> Box:
    if len(box) != 4:
        raise ValueError(f"box = {box!r} must be (re_min, re_max, im_min, im_max)")
    a, b, c, d = (float(v) for v in box)
    if not all(math.isfinite(v) for v in (a, b, c, d)) or not (b > a and d > c):
        raise ValueError(f"box = {box!r} must be finite with re_max > re_min, im_max > im_min")
    return a, b, c, d


def _perimeter_point(box: Box, t: np.ndarray) -> np.ndarray:
    """Counter-clockwise boundary parametrised by t in [0, 4): one unit per side."""
    a, b, c, d = box
    t = np.asarray(t, dtype=float)
    side = np.minimum(np.floor(t).astype(int), 3)
    s = t - side
    # corner + s * edge, side by side: the same operations on each part as the four masked
    # assignments this replaced (tests/test_analytic_roots.py), without their masks
    corner = np.array([complex(a, c), complex(b, c), complex(b, d), complex(a, d)])
    edge = np.array([complex(b - a, 0.0), complex(0.0, d - c), complex(-(b - a), 0.0),
                     complex(0.0, -(d - c))])
    return corner[side] + s * edge[side]


def winding_number(
    fun: ComplexFunction,
    box: Sequence[float],
    *,
    n_initial: int = 32,
    max_dphase: float = math.pi / 3,
    max_rel: float = 0.8,
    max_points: int = 50000,
    zero_tol: float = 1e-12,
    log: bool = False,
) -> int:
    """Winding number of ``fun`` around 0 along the boundary of ``box`` (counter-clockwise).

    The boundary is sampled adaptively: an interval is bisected until the phase of ``fun``
    changes by less than ``max_dphase`` across it *and* ``|F(t_{i+1}) - F(t_i)| <= max_rel *
    min(|F(t_i)|, |F(t_{i+1})|)``. The second rule makes the sample spacing smaller than the
    distance to a zero near the contour (estimated as ``|F| / |F'|``), so a zero just inside and
    another just outside the contour between two samples cannot cancel unseen. When both rules
    hold, every interval is bisected once more and checked again (a verification pass): a
    function that turned by a full ``2 pi`` between two samples (aliasing) is caught there. For
    rapidly rotating functions, ``n_initial`` should still resolve the rotation roughly.

    Args:
        fun: Vectorised complex function, continuous and non-zero on the contour.
        box: ``(re_min, re_max, im_min, im_max)``.
        n_initial: Initial number of samples on the longest side (the others in proportion,
            at least ``min(n_initial, 16)``: :func:`_initial_samples`).
        max_dphase: Largest allowed phase change between neighbouring samples.
        max_rel: Largest allowed relative change of ``F`` between neighbouring samples.
        max_points: Largest number of samples before giving up; at least ``32 n_initial``
            (8 times the initial samples: a tall box's initial samples alone can exceed
            50 000, e.g. stress top, ``k = 100``, 32 ``c_d``: 77 000).
        zero_tol: A sample with ``|F| < zero_tol * median|F|`` is taken as a zero on the contour
            (not used with ``log=True``, where ``|F|`` may span thousands of decades along the
            contour, e.g. a finite-element determinant: the local rules above find zeros on it).
        log: ``fun`` returns the complex logarithm ``log|F| + i arg F`` (any branch of the
            argument) instead of ``F``: for functions whose modulus over- or underflows.

    Returns:
        Zeros minus poles (counted with multiplicity) inside the box.

    Raises:
        ContourError: If ``fun`` is not finite on the contour, (numerically) vanishes on it, or
            its phase cannot be resolved (a zero or pole on or extremely near the contour).
        ValueError: On a malformed box.
    """
    def one_row(z: np.ndarray) -> np.ndarray:
        return _call(fun, z)[None, :]

    return winding_numbers(one_row, box, 1, n_initial=n_initial, max_dphase=max_dphase,
                           max_rel=max_rel, max_points=max_points, zero_tol=zero_tol,
                           log=log)[0]


def winding_numbers(fun: Callable[[np.ndarray], np.ndarray], box: Sequence[float], m: int, *,
                    n_initial: int = 32, max_dphase: float = math.pi / 3,
                    max_rel: float = 0.8, max_points: int = 50000,
                    zero_tol: float = 1e-12, log: bool = False,
                    samples: bool = False, values: bool = False) -> list[int] | tuple:
    """:func:`winding_number` of ``m`` functions on one contour, sampled together.

    ``fun(z)`` returns an array of shape ``(m, len(z))`` (e.g. one determinant at ``m``
    wavenumbers in one vectorised call). The samples are refined where *any* row needs it, with
    the rules and the verification pass of :func:`winding_number` (which is this with
    ``m = 1``), so each row's count is as reliable; the point is one call of ``fun`` per
    refinement instead of ``m``. With ``samples=True`` the final contour parameters ``t``
    (sorted, in ``[0, 4)``; ``t = 0, 1, 2, 3`` are the corners, the points of odd index are
    those of the verification pass) are returned too, as ``(counts, t)``; with ``values=True``
    also the samples ``fun(z(t))`` (``m x len(t)``), as ``(counts, t, f)``.

    Raises:
        ContourError: As :func:`winding_number`, if any row's contour is unusable.
    """
    return run_steps(winding_steps(box, m, n_initial=n_initial, max_dphase=max_dphase,
                                   max_rel=max_rel, max_points=max_points, zero_tol=zero_tol,
                                   log=log, samples=samples, values=values),
                     point_answers(fun))


def winding_steps(box: Sequence[float], m: int, *, n_initial: int = 32,
                  max_dphase: float = math.pi / 3, max_rel: float = 0.8,
                  max_points: int = 50000, zero_tol: float = 1e-12, log: bool = False,
                  samples: bool = False, values: bool = False,
                  ask: Callable[[str, np.ndarray], Any] = lambda kind, z: (kind, z)
                  ) -> Steps[list[int] | tuple]:
    """:func:`winding_numbers` as a step-wise algorithm (:mod:`analytic.numerics.steps`).

    It yields ``ask("f", z)`` for the ``m`` functions' values at the contour points ``z`` (an
    array ``m x len(z)``, or anything of that size) and returns what :func:`winding_numbers`
    returns; the other arguments are its.
    """
    bx = _box_checked(box)
    # the guard scales with the box's own sampling (n_initial from the root spacing): with a
    # fixed 50 000 every tall box failed by construction (stress top k = 51.8 at 12 c_d: 15 264
    # initial samples, 75 398 in the end). Up to 8 times the initial samples: the stress
    # envelope's tallest counts took 2.5-5.0 times (k = 35.7, 51.8, 100)
    max_points = max(max_points, 32 * n_initial)
    t = _initial_samples(bx, n_initial)

    def call(tt: np.ndarray) -> Steps[np.ndarray]:
        z = _perimeter_point(bx, tt)
        return np.asarray((yield ask("f", z)), dtype=complex).reshape(m, z.size)

    f = yield from call(t)
    min_dt = 4.0 * 1e-12
    verified = False
    while True:
        dph = np.empty(f.shape)
        bad = np.zeros(t.size, dtype=bool)
        for r, row in enumerate(f):
            if log:
                d, b = _log_increments(row, max_dphase, max_rel)
                if b is None:
                    zbad = _perimeter_point(bx, t[~np.isfinite(row.real)][:1])[0]
                    raise ContourError(f"log F not finite on the contour at z = {zbad:.6g}")
            else:
                d, b = _increments(row, bx, t, max_dphase, max_rel, zero_tol)
            dph[r], bad = d, bad | b
        t_next = _next(t)
        t_next[-1] = 4.0  # last interval closes the loop
        dt = t_next - t
        if not bad.any():
            if verified:
                totals = dph.sum(axis=1) / (2 * math.pi)
                counts = [int(round(v)) for v in totals]
                for v, c in zip(totals, counts, strict=True):
                    if abs(v - c) > 1e-6:  # cannot happen for a closed sampled loop; a guard
                        raise ContourError(f"winding number {v} is not an integer")
                return (counts, t, f) if values else (counts, t) if samples else counts
            # Verification pass: bisect every interval once more. A function that turned by
            # about 2 pi between two samples (aliasing) shows up as a bad interval here.
            bad = dt > 2 * min_dt
            verified = True
        elif np.any(dt[bad] < min_dt):
            zbad = _perimeter_point(bx, t[bad & (dt < min_dt)][:1])[0]
            raise ContourError(
                f"phase of the function jumps on the contour near z = {zbad:.6g}"
                " (zero, pole or branch cut on the contour): move the box edge"
            )
        else:
            verified = False
        tm = 0.5 * (t[bad] + t_next[bad])
        if t.size + tm.size > max_points:
            zbad = _perimeter_point(bx, tm[:1])[0]
            raise ContourError(
                f"contour needs more than max_points = {max_points} samples (near z = {zbad:.6g})"
            )
        t = np.concatenate([t, tm])
        f = np.concatenate([f, (yield from call(tm))], axis=1)
        order = np.argsort(t)
        t, f = t[order], f[:, order]

def samples_for_turn(turn: float, box: Sequence[float], base: int = 8) -> int:
    """``n_initial`` for a function whose phase turns by about ``turn`` per unit length.

    ``base + ceil(2 turn side)`` on the longest side ``side`` of ``box``: about two samples per
    radian before the refinement. The one rule of the exact count
    (:func:`analytic.numerics.branches._n_initial`) and the FE count
    (:func:`forms.models.section.contour_samples`).
    """
    side = max(box[1] - box[0], box[3] - box[2])
    return base + int(math.ceil(2.0 * turn * side))


def _initial_samples(box: Box, n_initial: int) -> np.ndarray:
    """First contour parameters: ``n_initial`` on the longest side, the others in proportion.

    A side of length ``l`` gets ``ceil(n_initial l / l_max)`` samples, at least
    ``min(n_initial, 16)``, evenly spaced in its unit of ``t`` (the corners ``t = 0, 1, 2, 3``
    included). Every rule of ``n_initial`` (``analytic.numerics.branches._n_initial``,
    ``forms.models.section.contour_samples``) sizes it for the longest side; on a tall box
    (``Re`` 0..2, ``|Im|`` up to thousands) the two short sides took half the samples of the
    uniform start, and then half of the verification pass, for nothing: their phase turns as
    little as their length says (``|d log F/dz|`` does not depend on the direction), and where
    it turns faster the refinement bisects there.
    """
    a, b, c, d = box
    lengths = np.array([b - a, d - c, b - a, d - c])
    m = np.maximum(np.ceil(n_initial * lengths / lengths.max()), min(n_initial, 16)).astype(int)
    return np.concatenate([j + np.arange(mj) / mj for j, mj in enumerate(m)])


def _next(x: np.ndarray) -> np.ndarray:
    """``np.roll(x, -1)`` of a 1-D array: the next sample around the loop (no roll overhead)."""
    return np.concatenate((x[1:], x[:1]))


def _increments(f: np.ndarray, bx: Box, t: np.ndarray, max_dphase: float, max_rel: float,
                zero_tol: float) -> tuple[np.ndarray, np.ndarray]:
    """Wrapped phase increments ``t_i -> t_{i+1}`` of samples ``f`` and the intervals to refine."""
    if not np.all(np.isfinite(f)):
        zbad = _perimeter_point(bx, t[~np.isfinite(f)][:1])[0]
        raise ContourError(f"function not finite on the contour at z = {zbad:.6g} (a pole?)")
    absf = np.abs(f)
    # The scale is the median sample, not the largest: a normalised determinant can span many
    # decades along one contour (det_M at H = 0.01, k = 1: 1e-3 .. 4e11, its weight near the
    # origin), where a fixed fraction of the largest value calls ordinary samples zeros.
    # (median <= max: the median is only computed where the cheap test fires)
    fmax, fmin = absf.max(), absf.min()
    if fmax == 0 or (fmin < zero_tol * fmax and fmin < zero_tol * np.median(absf)):
        zbad = _perimeter_point(bx, t[np.argmin(absf):][:1])[0]
        raise ContourError(
            f"function vanishes on the contour near z = {zbad:.6g}: move the box edge"
        )
    ph = np.angle(f)
    # wrapped increments t_i -> t_{i+1}, in [-pi, pi) (angle(exp(i x)) before session 25: the
    # same to rounding, at twice the cost)
    dph = np.remainder(_next(ph) - ph + math.pi, 2.0 * math.pi) - math.pi
    df = np.abs(_next(f) - f)
    bad = (np.abs(dph) > max_dphase) | (df > max_rel * np.minimum(absf, _next(absf)))
    return dph, bad


def _log_increments(logf: np.ndarray, max_dphase: float, max_rel: float
                    ) -> tuple[np.ndarray, np.ndarray | None]:
    """As :func:`_increments` for samples of ``log F`` (``None`` if one is not finite).

    The relative-change rule ``|F_{i+1} - F_i| <= max_rel min(|F_i|, |F_{i+1}|)`` is evaluated
    from ``r = F_{i+1}/F_i = exp(log F_{i+1} - log F_i)`` as ``|r - 1| <= max_rel min(1, |r|)``.
    """
    if not np.all(np.isfinite(logf)):
        return np.zeros(0), None
    d = _next(logf) - logf
    dph = np.angle(np.exp(1j * d.imag))
    with np.errstate(over="ignore", invalid="ignore"):
        r = np.exp(np.minimum(d.real, 700.0)) * np.exp(1j * dph)
        bad = (np.abs(dph) > max_dphase) | ~(np.abs(r - 1.0) <= max_rel * np.minimum(1.0,
                                                                                  np.abs(r)))
    return dph, bad


def _poles_inside(box: Box, poles: Sequence[complex | tuple[complex, int]]) -> int:
    a, b, c, d = box
    total = 0
    for p in poles:
        z, order = (p if isinstance(p, tuple) else (p, 1))
        z = complex(z)
        h = 1e-12 * max(b - a, d - c)
        on_edge = (
            (abs(z.real - a) < h or abs(z.real - b) < h) and c - h <= z.imag <= d + h
        ) or ((abs(z.imag - c) < h or abs(z.imag - d) < h) and a - h <= z.real <= b + h)
        if on_edge:
            raise ContourError(f"known pole z = {z:.6g} lies on the contour: move the box edge")
        if a < z.real < b and c < z.imag < d:
            total += int(order)
    return total


def count_zeros(
    fun: ComplexFunction,
    box: Sequence[float],
    *,
    poles: Sequence[complex | tuple[complex, int]] = (),
    **kwargs: float,
) -> int:
    """Number of zeros of ``fun`` inside ``box`` (with multiplicity), by the argument principle.

    The argument principle gives *zeros minus poles*. For a meromorphic ``fun`` pass its known
    poles (locations, or ``(location, order)`` pairs); those inside the box are added back. (Or
    multiply ``fun`` by its known denominators so it has no poles.)

    Args:
        fun: Vectorised complex function (see module docstring).
        box: ``(re_min, re_max, im_min, im_max)``.
        poles: Known poles of ``fun``.
        **kwargs: Passed to :func:`winding_number` (``n_initial``, ``max_dphase``, ...).

    Returns:
        The number of zeros inside the box.

    Raises:
        ContourError: See :func:`winding_number`; also if a known pole lies on the contour or
            the count comes out negative (an unknown pole inside the box).
    """
    bx = _box_checked(box)
    n = winding_number(fun, bx, **kwargs) + _poles_inside(bx, poles)
    if n < 0:
        raise ContourError(f"negative zero count {n} in box {bx}: unlisted poles inside the box")
    return n


def _split(box: Box, frac: float) -> tuple[Box, Box]:
    a, b, c, d = box
    if (b - a) >= (d - c):
        m = a + frac * (b - a)
        return (a, m, c, d), (m, b, c, d)
    m = c + frac * (d - c)
    return (a, b, c, m), (a, b, m, d)


#: :func:`zeros_in_box` scans a box holding at most this many zeros before bisecting it.
SCAN_ZEROS = 4
#: Points along each scan line, at most.
SCAN_POINTS = 4096
#: Deepest dips of a scan followed by Newton, and the vectorised Newton steps.
SCAN_STARTS, SCAN_NEWTON = 256, 12


def _inside(z: complex, b: Box) -> bool:
    """``z`` in the closed box ``b``."""
    return b[0] <= z.real <= b[1] and b[2] <= z.imag <= b[3]


def _scan(fun: ComplexFunction, b: Box, n: int, polish_at: Callable[[complex], Root]
          ) -> list[Root] | None:
    """``n`` distinct zeros inside the box ``b`` by Newton from the dips of ``|fun|``.

    ``|fun|`` on lines along the long side (across it at 2 % .. 98 %, points a quarter of the
    short side apart, one vectorised call); Newton from every local minimum at once
    (:data:`SCAN_NEWTON` vectorised steps, central differences); the distinct end points inside
    ``b`` are polished (:func:`polish`) until ``n`` distinct converged zeros lie inside ``b``.
    With the box's count ``n`` they are all its zeros. ``None``: not found that way (the caller
    bisects). Most dips belong to zeros just outside the box (the tall bands of the fastest-root
    search have rows of slower zeros along their left edge), hence every dip at once. Session
    13: those bands took about ten bisections of two counts each, and zeros next to an edge or
    to each other twenty and more.
    """
    a0, b0, c0, d0 = b
    tall = (d0 - c0) >= (b0 - a0)
    short, long_ = (b0 - a0, d0 - c0) if tall else (d0 - c0, b0 - a0)
    m = int(min(SCAN_POINTS, max(64, math.ceil(4.0 * long_ / short) + 1)))
    across = np.array([0.001, 0.02, 0.25, 0.5, 0.75, 0.98])
    along = np.linspace(0.0, 1.0, m)
    if tall:
        z = (a0 + across[:, None] * short) + 1j * (c0 + along[None, :] * long_)
    else:
        z = (a0 + along[None, :] * long_) + 1j * (c0 + across[:, None] * short)
    f = np.abs(_call(fun, z.ravel())).reshape(z.shape)
    f = np.where(np.isfinite(f), f, np.inf)
    dips = (f[:, 1:-1] <= f[:, :-2]) & (f[:, 1:-1] <= f[:, 2:])
    rows, cols = np.nonzero(dips)
    zz = z[rows, cols + 1][np.argsort(f[rows, cols + 1])][:SCAN_STARTS]
    for _ in range(SCAN_NEWTON):  # every start at once: 5 points each per call
        h, pts = _stencil(zz)
        fv = _call(fun, np.concatenate([zz, pts.ravel()])).reshape(5, zz.size)
        f0, d = fv[0], _wirtinger(fv[1:], h)
        with np.errstate(all="ignore"):
            step = np.where(d != 0, f0 / d, 0.0)
        big = np.abs(step) > 0.25 * short  # damped: at most a quarter of the short side
        step[big] *= 0.25 * short / np.abs(step[big])
        zz = np.where(np.isfinite(step), zz - step, zz)
    return _distinct_zeros(polish_at, b, zz[np.array([_inside(z, b) for z in zz], dtype=bool)],
                           n)


def _reached_zeros(polish_at: Callable[[complex], Root], b: Box, starts: Sequence[complex],
                   n: int | None = None) -> list[Root]:
    """The distinct converged zeros inside ``b`` polished from ``starts`` in turn.

    A start within ``1e-6`` (relative) of a zero already found is skipped; the polishing stops
    as soon as ``n`` are found (``None``: every start is tried). A Newton iteration converging
    to a zero farther than its radius outside ``b``, or to one within ``1e-6`` of a zero found
    (the start's rule), is abandoned there (:func:`polish`'s ``unwanted``): its end would be
    dropped anyway. Session 26's count in the stress 5 x 5 map: of 22 453 iterations from
    starts, 12 546 went to zeros outside the band and 2 595 to zeros already found. An
    iteration wrongly abandoned leaves a zero unreached: the caller's count then exceeds the
    zeros reached and the box is searched (the count decides, never this rule).
    """
    found: list[Root] = []

    def near_found(w: complex) -> bool:  # the one rule for starts and for iterates
        return any(abs(w - q.value) <= 1e-6 * max(1.0, abs(w)) for q in found)

    def unwanted(w: complex, r: float) -> bool:
        dx = max(b[0] - w.real, 0.0, w.real - b[1])
        dy = max(b[2] - w.imag, 0.0, w.imag - b[3])
        return math.hypot(dx, dy) > r or near_found(w)

    for z0 in starts:
        if near_found(complex(z0)):
            continue
        r = polish_at(complex(z0), unwanted=unwanted)
        if r.converged and _inside(r.value, b) and all(
                abs(r.value - q.value) > 1e-9 * max(1.0, abs(r.value)) for q in found):
            found.append(r)
            if len(found) == n:
                break
    return found


def _distinct_zeros(polish_at: Callable[[complex], Root], b: Box, starts: Sequence[complex],
                    n: int) -> list[Root] | None:
    """``n`` distinct converged zeros inside ``b`` polished from ``starts``, or ``None``."""
    found = _reached_zeros(polish_at, b, starts, n)
    return found if len(found) == n else None


def zeros_reached(fun: ComplexFunction, box: Sequence[float], starts: Sequence[complex],
                  **kwargs: float) -> list[Root]:
    """The distinct zeros of ``fun`` inside ``box`` that Newton reaches from ``starts``.

    No count: some of the box's zeros, not necessarily all (:func:`zeros_from_starts` when the
    count is known). Each start is polished (:func:`polish`, ``kwargs``) unless it lies next to
    a zero already found.
    """
    return _reached_zeros(functools.partial(polish, fun, **kwargs), _box_checked(box), starts)


def zeros_from_starts(fun: ComplexFunction, box: Sequence[float], total: int,
                      starts: Sequence[complex], **kwargs: float) -> list[Root] | None:
    """All ``total`` zeros of ``fun`` in ``box`` if Newton reaches them from ``starts``.

    ``total``: the box's count (:func:`count_zeros`). The starts are polished in turn
    (:func:`polish`, ``kwargs``; the rule of :func:`_scan`'s dips, :func:`_distinct_zeros`)
    until ``total`` distinct converged zeros lie inside the box: then they are all the box's
    zeros (sorted as :func:`zeros_in_box` sorts them); otherwise ``None`` (search the box:
    :func:`zeros_in_box`). Guesses from a neighbouring parameter value spare
    :func:`zeros_in_box`'s scan lines when they are good.
    """
    if total == 0:
        return None
    polish_at = functools.partial(polish, fun, **kwargs)
    found = _distinct_zeros(polish_at, _box_checked(box), starts, total)
    return None if found is None else sorted(found, key=lambda r: (r.value.real, r.value.imag))


def _for_part(kwargs: dict, outer: Box, part: Box) -> dict:
    """:func:`count_zeros`' keywords for a part of ``outer``: ``n_initial`` scaled to its side.

    ``n_initial`` is sized for the longest side of the box it was given for (samples per unit
    length: :func:`samples_for_turn`); a part gets the same density on its own longest side
    (at least 16), not the whole box's samples again. Session 26: every part of a tall band's
    bisection took 3 600-4 200 samples, the band's own number, down to parts 1/60 its height.
    """
    if "n_initial" not in kwargs:
        return kwargs
    side = max(outer[1] - outer[0], outer[3] - outer[2])
    frac = max(part[1] - part[0], part[3] - part[2]) / side
    return {**kwargs, "n_initial": max(16, int(math.ceil(kwargs["n_initial"] * frac)))}


def zeros_in_box(
    fun: ComplexFunction,
    box: Sequence[float],
    *,
    poles: Sequence[complex | tuple[complex, int]] = (),
    dfun: ComplexFunction | None = None,
    tol: float = 1e-14,
    scale: float = 1.0,
    min_size: float = 1e-9,
    total: int | None = None,
    **kwargs: float,
) -> list[Root]:
    """All zeros of ``fun`` inside ``box``, each polished; the total is checked.

    The box is counted (:func:`count_zeros`); a box holding one zero is polished from its centre
    (accepted if Newton converges to a point inside it), one holding up to :data:`SCAN_ZEROS`
    is scanned (:func:`_scan`), otherwise (or if that fails) it is bisected along its longer side
    (the cut is moved if it runs through a zero) and the halves are treated the same way. A box
    smaller than ``min_size`` (relative) that still holds ``m > 1`` zeros is reported as one
    :class:`Root` with ``reason`` naming the cluster (a multiple root).

    Args:
        fun: Vectorised complex function (see module docstring).
        box: ``(re_min, re_max, im_min, im_max)``.
        poles: Known poles of ``fun`` (see :func:`count_zeros`).
        dfun: Derivative of ``fun`` (optional).
        tol: Newton tolerance (see :func:`polish`).
        scale: Typical magnitude of ``fun`` (see :func:`polish`).
        min_size: Smallest box edge relative to ``max(|z|, 1)`` before giving up subdividing.
        total: The count of ``box`` if just made with these ``poles``, ``kwargs`` (or None).
        **kwargs: Passed to :func:`count_zeros`.

    Returns:
        The roots by real, then imaginary part; a cluster's ``reason`` says how many it holds.

    Raises:
        ContourError: The outer contour is unusable, or the roots do not add up to the count.
    """
    bx = _box_checked(box)
    if total is None:
        total = count_zeros(fun, bx, poles=poles, **kwargs)
    found: list[tuple[Root, int]] = []
    polish_at = functools.partial(polish, fun, dfun=dfun, tol=tol, scale=scale)

    def solve(b: Box, n: int, scan: bool = True) -> None:
        if n == 0:
            return
        centre = complex(0.5 * (b[0] + b[1]), 0.5 * (b[2] + b[3]))
        size = max(b[1] - b[0], b[3] - b[2])
        if n == 1 and (r := polish_at(centre)).converged and _inside(r.value, b):
            found.append((r, 1))
            return
        if scan and n <= SCAN_ZEROS:
            if (roots := _scan(fun, b, n, polish_at)) is not None:
                found.extend((r, 1) for r in roots)
                return
            scan = False  # a scan failed: its halves are bisected, not scanned again
        if size < min_size * max(abs(centre), 1.0):
            r = polish_at(centre)
            r.reason = f"cluster of {n} zeros within a box of size {size:.3g}; " + r.reason
            found.append((r, n))
            return
        for frac in (0.5, 0.4617, 0.5383, 0.4209, 0.5791):
            halves = _split(b, frac)
            try:
                counts = [count_zeros(fun, h, poles=poles, **_for_part(kwargs, bx, h))
                          for h in halves]
            except ContourError:
                continue
            if sum(counts) == n:
                for h, m in zip(halves, counts, strict=True):
                    solve(h, m, scan)
                return
        raise ContourError(f"could not split box {b} holding {n} zeros consistently")

    solve(bx, total)
    nfound = sum(m for _, m in found)
    if nfound != total:
        raise ContourError(f"found {nfound} zeros but the argument principle counts {total}")
    return sorted((r for r, _ in found), key=lambda r: (r.value.real, r.value.imag))
