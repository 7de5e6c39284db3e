"""One maximiser of a real function of one variable on an interval.

Bounded Brent search (:func:`scipy.optimize.minimize_scalar`, ``method="bounded"``) on
``-fun``; a non-finite value counts as a very low one, so the search steps away from where the
function is undefined (a root lost, a branch outside its family). Used for the maxima over
``k`` (or ``log q``) of growth rates.
"""

from __future__ import annotations

import math
from collections.abc import Callable

#: Stands for ``-fun`` where ``fun`` is not finite.
_PENALTY = 1e300


def maximise(fun: Callable[[float], float], lo: float, hi: float, *, xatol: float
             ) -> tuple[float, float]:
    """``(x, fun(x))`` at a local maximum of ``fun`` in ``[lo, hi]`` (bounded Brent).

    Args:
        fun: Real function; NaN or infinite values are treated as very low.
        lo: Left end.
        hi: Right end (``> lo``).
        xatol: Absolute tolerance on ``x``.

    Returns:
        The best point found and its value (``-inf`` if ``fun`` was never finite).
    """
    from scipy.optimize import minimize_scalar

    def neg(x: float) -> float:
        v = fun(x)
        return -v if math.isfinite(v) else _PENALTY

    res = minimize_scalar(neg, bounds=(lo, hi), method="bounded", options={"xatol": xatol})
    value = -float(res.fun) if res.fun != _PENALTY else -math.inf
    return float(res.x), value
