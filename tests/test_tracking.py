"""Branch tracking by eigenvector overlap (analytic.numerics.tracking), on synthetic candidates."""

import numpy as np
import pytest

from analytic.numerics.tracking import Branch, branches, normalized, track_branch, waveguide_lambda
from analytic.params import Params

pytestmark = pytest.mark.serial  # pure numpy: once is enough


def _vec(theta, n=6):
    """Unit vectors rotating slowly with theta; a 'branch' is a continuous theta(k)."""
    v = np.zeros(n, complex)
    v[0], v[1] = np.cos(theta), np.sin(theta)
    return normalized(v * np.exp(0.3j))


def test_labels_and_waveguide_prediction():
    assert [b.label for b in branches(2)] == ["0-", "0+", "1-", "1+"]
    assert Branch.parse("2+") == Branch(2, 1)
    p = Params()
    # k -> 0: the cut-off -i (2n+1) pi / (2 beta H) = -2 pi i for n = 0 and the defaults
    assert abs(waveguide_lambda(p, Branch(0, -1), 1e-12) + 2j * np.pi) < 1e-12


def test_follows_vectors_not_nearest_values():
    k = np.linspace(0, 1, 5)
    other = np.zeros(6, complex)
    other[3] = 1.0
    values, vectors = [], []
    for kk in k:
        # the branch value crosses the other mode's value; nearest-value would jump
        values.append(np.array([1.0 - kk, 0.5 + 0j]))
        vectors.append(np.array([_vec(0.2 * kk), other]))
    tr = track_branch(values, vectors, start_target=1.0)
    assert tr.choice == [0] * 5 and all(s == "ok" for s in tr.status)


def test_lost_point_is_reported_then_repaired_by_resolve():
    k = np.linspace(0, 1, 5)
    other = np.zeros(6, complex)
    other[4] = 1.0
    values = [np.array([1.0 + kk]) for kk in k]
    vectors = [np.array([_vec(0.1 * kk)]) for kk in k]
    values[3], vectors[3] = np.array([7.0]), np.array([other])  # branch missing at k[3]
    tr = track_branch([v.copy() for v in values], [v.copy() for v in vectors], 1.0)
    assert tr.choice[3] == -1 and tr.status[3].startswith("lost")
    assert tr.choice[4] == 0  # picked up again after the gap

    calls = []

    def resolve(m, target):
        calls.append((m, target))
        return np.array([1.0 + k[m]]), np.array([_vec(0.1 * k[m])])

    tr = track_branch(values, vectors, 1.0, k=k, resolve=resolve)
    assert tr.status == ["ok"] * 5 and tr.choice[3] == 1
    # target extrapolated linearly from k[1], k[2]: 1 + k[3]
    assert len(calls) == 1 and abs(calls[0][1] - (1.0 + k[3])) < 1e-12


def test_jump_to_a_far_root_with_a_similar_vector_is_not_accepted():
    """Overlap alone would accept the jump at k[3]; the eigenvalue guard reports it as lost."""
    k = np.linspace(0, 1, 5)
    values = [np.array([1.0 + 0.1 * kk]) for kk in k]
    vectors = [np.array([_vec(0.05 * kk)]) for kk in k]
    values[3] = np.array([5.0 + 0j])  # far from the path 1 + 0.1 k, same-looking vector
    tr = track_branch(values, vectors, 1.0, k=k)
    assert tr.status[3].startswith("lost: best overlapping candidate jumps")
    assert tr.choice[:3] == [0, 0, 0] and tr.choice[4] == 0
    # without k (no eigenvalue guard) the jump is taken: the guard is what catches it
    assert track_branch(values, vectors, 1.0).choice[3] == 0
