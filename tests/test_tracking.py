"""Waveguide branch labels and targets (analytic.numerics.tracking)."""

import numpy as np
import pytest

from analytic.numerics.tracking import Branch, branches, normalized, waveguide_lambda
from analytic.params import Params

pytestmark = pytest.mark.serial  # pure numpy: once is enough


def test_normalized_is_unit_with_a_real_positive_largest_entry():
    v = normalized(np.array([0.1j, -3.0 + 4.0j, 1.0]))
    assert abs(np.linalg.norm(v) - 1.0) < 1e-15
    i = int(np.argmax(np.abs(v)))
    assert abs(v[i].imag) <= 1e-15 and v[i].real > 0  # rounding of |v_i|/v_i only


def test_labels_and_waveguide_prediction():
    assert [b.label for b in branches(2)] == ["0-", "0+", "1-", "1+"]
    assert Branch.parse("2+") == Branch(2, 1)
    p = Params()
    # k -> 0: the cut-off -i (2n+1) pi / (2 beta H) = -2 pi i for n = 0 and the defaults
    assert abs(waveguide_lambda(p, Branch(0, -1), 1e-12) + 2j * np.pi) < 1e-12
