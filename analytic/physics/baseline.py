"""The paper's own method, as a speed baseline: Newton continuation on the closed form ``S``.

One root per branch, plain numpy: from the cut-off, at every requested ``k`` the previous two
roots give a linear predictor and Newton's method on ``S(Lambda, k, H)`` (Eqs. 20-21 of the
paper, :func:`analytic.physics.finite_h.spectrum_S`, velocity top) corrects it
(:func:`analytic.numerics.roots.polish`, central-difference derivative). No root count, no
check against jumping to a neighbouring root: exactly what the certified continuation
(:func:`analytic.numerics.branches.follow_branch`) adds, and what it is measured against in
``workflows/benchmark.py``. Both run on :func:`analytic.numerics.continuation.march`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from analytic.numerics.continuation import Path, Trial, march
from analytic.numerics.roots import Root, polish
from analytic.params import Params
from analytic.physics.finite_h import cutoff, spectrum_S
from analytic.physics.smallk import slope


@dataclass
class _PlainStepper:
    """Linear predictor, Newton on ``S``, every step accepted; counts Newton iterations."""

    p: Params
    iterations: int = 0

    def attempt(self, path: Path, k_new: float) -> Trial[Root]:
        """Secant predictor (the small-``k`` slope from the cut-off), Newton on ``S``."""
        r = polish(lambda z: spectrum_S(z, k_new, self.p), path.predict(k_new, order=1),
                   tol=1e-14, maxiter=40)
        self.iterations += r.iterations
        return Trial(k_new, r.value, True, r)

    def rescue(self, path: Path, trial: Trial[Root], k_target: float) -> Trial[Root]:
        """Never called: every step is accepted."""
        return trial

    def next_step(self, path: Path, h: float, trial: Trial[Root], clamped: bool, dk: float
                  ) -> float:
        """Straight to the next requested ``k``."""
        return math.inf


def continue_S(p: Params, n: int, sign: int, ks: np.ndarray) -> tuple[np.ndarray, int]:
    """Branch ``(n, sign)`` at the sorted ``ks``: ``(roots, total Newton iterations)``."""
    ks = np.asarray(ks, dtype=float)
    stepper = _PlainStepper(p)
    path = Path([0.0], [cutoff(n, sign, p)], slope=slope(n, sign, p))
    run = march(stepper, path, ks)
    out = np.array([t.value for t in run.trials], dtype=complex)
    return out, stepper.iterations
