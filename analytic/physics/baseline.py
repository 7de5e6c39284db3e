"""The paper's own method, as a speed baseline: Newton continuation on the closed form ``S``.

One root per branch, plain numpy: from the cut-off, at every requested ``k`` the previous two
roots give a linear predictor and Newton's method on ``S(Lambda, k, H)`` (Eqs. 20-21 of the
paper, :func:`analytic.physics.finite_h.spectrum_S`, velocity top) corrects it, with a
central-difference
derivative. No root count, no check against jumping to a neighbouring root: exactly what the
certified continuation (:func:`analytic.numerics.branches.follow_branch`) adds, and what it is
measured
against in ``workflows/benchmark.py``.
"""

from __future__ import annotations

import numpy as np

from analytic.params import Params
from analytic.physics.finite_h import cutoff, spectrum_S
from analytic.physics.smallk import slope


def newton_S(p: Params, k: float, z0: complex, tol: float = 1e-14, maxit: int = 40
             ) -> tuple[complex, int]:
    """Newton on ``S(., k)`` from ``z0``: ``(root, iterations)`` (no convergence guarantee)."""
    z = complex(z0)
    it = 0
    for it in range(1, maxit + 1):  # noqa: B007 - reported
        h = 1e-7 * max(abs(z), 1.0)
        f = complex(spectrum_S(z, k, p))
        d = complex(spectrum_S(z + h, k, p) - spectrum_S(z - h, k, p)) / (2 * h)
        dz = -f / d
        z += dz
        if abs(dz) <= tol * max(abs(z), 1.0):
            break
    return z, it


def continue_S(p: Params, n: int, sign: int, ks: np.ndarray) -> tuple[np.ndarray, int]:
    """Branch ``(n, sign)`` at the sorted ``ks``: ``(roots, total Newton iterations)``."""
    ks = np.asarray(ks, dtype=float)
    out = np.empty(ks.size, dtype=complex)
    z_prev, k_prev = cutoff(n, sign, p), 0.0
    z_cur = z_prev + slope(n, sign, p) * ks[0]
    k_cur = None
    total = 0
    for i, k in enumerate(ks):
        if k_cur is None:
            guess = z_cur
        else:
            guess = z_cur + (z_cur - z_prev) / (k_cur - k_prev) * (k - k_cur)
        z, it = newton_S(p, float(k), guess)
        total += it
        if k_cur is not None:
            z_prev, k_prev = z_cur, k_cur
        z_cur, k_cur = z, float(k)
        out[i] = z
    return out, total
