"""One continuation engine in ``k``: predictor, corrector callback, step control, acceptance.

A root ``Lambda(k)`` of some function is followed from the points already known (a
:class:`Path`) to every requested ``k`` (the targets, ascending or descending) by
:func:`march`. The caller supplies a :class:`Stepper`:

- :meth:`Stepper.attempt` predicts (usually :meth:`Path.predict`), corrects (a Newton
  polish, :func:`analytic.numerics.roots.polish`) and says whether the step is accepted (its
  own test: a root count, a bound on the jump, or nothing);
- :meth:`Stepper.rescue` decides what happens when a step is still refused at the smallest
  step: another trial to take instead (e.g. a longer step across a near-collision, or the
  refused root itself, flagged), or ``None`` to stop;
- :meth:`Stepper.next_step` sets the next step size from the accepted one.

The engine holds the loop common to all: steps end exactly on each target (never leaving a
sliver before it), a refused step is halved down to ``dk_min`` (or at most ``max_halvings``
times per target), a target the caller does not need is skipped.

:func:`march_steps` is the engine as a step-wise algorithm (:mod:`analytic.numerics.steps`):
a stepper whose ``attempt`` and ``rescue`` are generators passes their requests through (the
exact branches, followed many side by side); :func:`march` runs it for a plain stepper.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from types import GeneratorType
from typing import Generic, Protocol, TypeVar

import numpy as np

from analytic.numerics.steps import Steps, no_requests, run_steps

R = TypeVar("R")


@dataclass
class Path:
    """The points ``(k, Lambda)`` of a continuation so far, oldest first.

    Attributes:
        k: Wavenumbers.
        value: Roots at ``k``.
        slope: ``dLambda/dk`` at the only point, for the first prediction (None: constant).
    """

    k: list[float]
    value: list[complex]
    slope: complex | None = None

    def append(self, k: float, value: complex) -> None:
        """Add an accepted point."""
        self.k.append(float(k))
        self.value.append(complex(value))

    def secant(self) -> complex:
        """``dLambda/dk`` between the last two points."""
        return (self.value[-1] - self.value[-2]) / (self.k[-1] - self.k[-2])

    def predict(self, k_new: float, order: int = 2) -> complex:
        """Polynomial extrapolation to ``k_new`` through the last ``order + 1`` points.

        Order 0 is the last value; order 1 the secant (or :attr:`slope` with a single point);
        order 2 the quadratic through three points, where the third oldest has ``k > 0`` (a
        cut-off at ``k = 0`` need not lie on the branch's parabola), else the secant.
        """
        if order == 0 or (len(self.k) == 1 and self.slope is None):
            return self.value[-1]
        h = k_new - self.k[-1]
        if len(self.k) == 1:
            return self.value[-1] + self.slope * h
        d1 = self.secant()
        pred = self.value[-1] + d1 * h
        if order >= 2 and len(self.k) >= 3 and self.k[-3] > 0:
            k2, l2 = self.k[-3], self.value[-3]
            d2 = (d1 - (self.value[-2] - l2) / (self.k[-2] - k2)) / (self.k[-1] - k2)
            pred = pred + d2 * h * (k_new - self.k[-2])
        return pred


@dataclass
class Trial(Generic[R]):
    """One corrected step.

    Attributes:
        k: Wavenumber of the step.
        value: The corrected root.
        accepted: The stepper's acceptance test passed.
        result: The stepper's own record of the root (e.g. a
            :class:`~analytic.numerics.roots.Root`).
        flag: ``""`` or why the point is in doubt (kept with the point).
        closes_target: Record it for the current target even if ``k`` differs (a rescue that
            gives up on reaching the target).
    """

    k: float
    value: complex
    accepted: bool
    result: R
    flag: str = ""
    closes_target: bool = False


class Stepper(Protocol[R]):
    """The problem-specific half of a continuation (see the module docstring)."""

    def attempt(self, path: Path, k_new: float) -> Trial[R]:
        """Predict, correct and test one step from the end of ``path`` to ``k_new``."""

    def rescue(self, path: Path, trial: Trial[R], k_target: float) -> Trial[R] | None:
        """A refused step at the smallest step size: the trial to take instead, or None."""

    def next_step(self, path: Path, h: float, trial: Trial[R], clamped: bool, dk: float
                  ) -> float:
        """The next step size after ``trial`` (already appended to ``path``), step ``h``."""


#: ``skip(path, k_target) -> bool``: True when the root is not wanted at ``k_target``.
SkipTarget = Callable[[Path, float], bool]


@dataclass
class March(Generic[R]):
    """What :func:`march` returns.

    Attributes:
        trials: Per target, the trial recorded there (None: skipped or not reached).
        skipped: Per target, True when ``skip`` declined it.
        stopped: The stepper's rescue returned None (the root was lost).
        steps: Steps taken (refused ones included).
    """

    trials: list[Trial[R] | None]
    skipped: list[bool]
    stopped: bool = False
    steps: int = 0
    notes: list[str] = field(default_factory=list)


def march(stepper: Stepper[R], path: Path, targets: np.ndarray, *, dk: float = math.inf,
          dk_min: float = 0.0, max_halvings: int | None = None, max_steps: int = 20000,
          skip: SkipTarget | None = None) -> March[R]:
    """Continue the root at the end of ``path`` to every ``targets[i]`` (see module docstring).

    Args:
        stepper: The problem's :class:`Stepper`.
        path: The known points (at least one); accepted points are appended.
        targets: Wavenumbers where the root is wanted, in the direction of the march.
        dk: First step size (``inf``: straight to each target).
        dk_min: No halving at or below this step.
        max_halvings: At most this many halvings per target (None: down to ``dk_min``).
        max_steps: Safety limit on the number of steps.
        skip: Targets not wanted (no step has to end there).

    Returns:
        The :class:`March`.
    """
    return run_steps(march_steps(stepper, path, targets, dk=dk, dk_min=dk_min,
                                 max_halvings=max_halvings, max_steps=max_steps, skip=skip),
                     no_requests)


def march_steps(stepper: Stepper[R], path: Path, targets: np.ndarray, *, dk: float = math.inf,
                dk_min: float = 0.0, max_halvings: int | None = None, max_steps: int = 20000,
                skip: SkipTarget | None = None) -> Steps[March[R]]:
    """:func:`march` as a step-wise algorithm (:mod:`analytic.numerics.steps`).

    For a stepper whose :meth:`Stepper.attempt` and :meth:`Stepper.rescue` are step-wise
    themselves (return generators): their requests pass through. The arguments are
    :func:`march`'s.
    """
    n = len(targets)
    out = March(trials=[None] * n, skipped=[False] * n)
    i, halvings, sgn = 0, 0, 1.0
    while i < n and out.steps < max_steps:
        k_target, k_cur = float(targets[i]), path.k[-1]
        sgn = 1.0 if k_target >= k_cur else -1.0
        if skip is not None and k_target > k_cur and skip(path, k_target):
            out.skipped[i] = True
            i += 1
            continue
        out.steps += 1
        reach = k_cur + sgn * dk * (1.0 + 1e-6)
        clamped = reach >= k_target if sgn > 0 else reach <= k_target
        k_new = k_target if clamped else k_cur + sgn * dk
        h = abs(k_new - k_cur)
        trial = yield from _outcome(stepper.attempt(path, k_new))
        if not trial.accepted and h > dk_min and (max_halvings is None
                                                 or halvings < max_halvings):
            dk, halvings = 0.5 * h, halvings + 1
            continue
        if not trial.accepted:
            rescued = yield from _outcome(stepper.rescue(path, trial, k_target))
            if rescued is None:
                out.stopped = True
                break
            trial = rescued
        path.append(trial.k, trial.value)
        if trial.k == k_target or trial.closes_target:
            out.trials[i] = trial
            i, halvings = i + 1, 0
        dk = stepper.next_step(path, abs(trial.k - k_cur), trial, clamped, dk)
    return out


def _outcome(x: object) -> Steps:
    """A stepper method's result: itself, or what its generator returns (requests pass)."""
    if isinstance(x, GeneratorType):
        return (yield from x)
    return x
