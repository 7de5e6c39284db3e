"""The one continuation engine and the one maximiser, on synthetic problems."""

import math
from dataclasses import dataclass, field

import numpy as np
import pytest

from analytic.numerics.continuation import Path, Trial, march
from analytic.numerics.maximise import maximise
from analytic.numerics.roots import polish

pytestmark = pytest.mark.serial  # pure numpy


def test_predictor_is_exact_on_polynomials_of_its_order():
    path = Path([0.5, 1.0, 2.0], [2 + 0.5**2, 2 + 1.0, 2 + 4.0])  # 2 + k^2
    assert abs(path.predict(3.0, order=2) - 11.0) < 1e-13
    assert path.predict(3.0, order=1) == 9.0  # secant through (1, 3) and (2, 6)
    assert path.predict(3.0, order=0) == 6.0
    # a third point at k = 0 (a cut-off) is not used for the curvature
    assert Path([0.0, 1.0, 2.0], [5.0, 3.0, 6.0]).predict(3.0, order=2) == 9.0
    assert Path([0.0], [1.0], slope=2.0).predict(0.25) == 1.5


@dataclass
class Stepper:
    """Root of z^2 - k (positive branch); refuses steps longer than ``h_max``."""

    h_max: float
    give_up: bool = False
    calls: list = field(default_factory=list)

    def attempt(self, path, k_new):
        self.calls.append(k_new)
        r = polish(lambda z: z * z - k_new, path.predict(k_new, order=1))
        ok = r.converged and abs(k_new - path.k[-1]) <= self.h_max
        return Trial(k_new, r.value, ok, r)

    def rescue(self, path, trial, k_target):
        if self.give_up:
            return None
        trial.flag = "forced"
        return trial

    def next_step(self, path, h, trial, clamped, dk):
        return 2.0 * h


@pytest.mark.parametrize("targets", [[1.0, 2.0, 4.0], [0.5, 0.25]])
def test_march_reaches_every_target_with_halving(targets):
    st = Stepper(h_max=0.3)
    path = Path([0.75, 0.8], [math.sqrt(0.75), math.sqrt(0.8)])
    run = march(st, path, np.array(targets), dk=1.0, dk_min=1e-3)
    assert [t.k for t in run.trials] == targets
    for t in run.trials:
        assert abs(t.value - math.sqrt(t.k)) < 1e-14 and t.flag == ""
    assert np.all(np.abs(np.diff(path.k[1:])) <= 0.3 + 1e-15)
    assert run.steps > len(targets)  # some steps were refused and halved


def test_refused_at_the_smallest_step_rescue_or_stop():
    st = Stepper(h_max=0.0)  # refuses everything: halved 3 times, then rescued, step doubled
    run = march(st, Path([1.0], [1.0]), np.array([2.0]), dk=1.0, max_halvings=3)
    assert st.calls == [2.0, 1.5, 1.25, 1.125, 1.375, 1.875, 2.0]
    assert run.trials[0].k == 2.0 and run.trials[0].flag == "forced" and not run.stopped
    st = Stepper(h_max=0.0, give_up=True)
    run = march(st, Path([1.0], [1.0]), np.array([2.0, 3.0]), dk=1.0, max_halvings=2)
    assert run.stopped and run.trials == [None, None] and len(st.calls) == 3


def test_skip_and_closing_rescue():
    st = Stepper(h_max=10.0)
    run = march(st, Path([1.0, 1.1], [1.0, math.sqrt(1.1)]), np.array([2.0, 3.0, 4.0]),
                skip=lambda path, k: k == 3.0)
    assert run.skipped == [False, True, False] and run.trials[1] is None
    assert 3.0 not in st.calls and run.trials[2].k == 4.0


def test_maximise_finds_the_peak_and_steps_around_nan():
    x, v = maximise(lambda x: -(x - 0.3) ** 2 + 1.0, 0.0, 1.0, xatol=1e-10)
    assert abs(x - 0.3) < 1e-8 and abs(v - 1.0) < 1e-15  # xatol 1e-10: |dx| ~ 1e-10
    x, v = maximise(lambda x: math.nan if x > 0.5 else x, 0.0, 1.0, xatol=1e-10)
    assert 0.49 < x <= 0.5 and abs(v - x) == 0.0
    assert maximise(lambda x: math.nan, 0.0, 1.0, xatol=1e-6)[1] == -math.inf
