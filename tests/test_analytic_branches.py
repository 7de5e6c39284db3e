import numpy as np
import pytest

from analytic.numerics.branches import (
    branch_label,
    follow_branch,
    follow_branches,
    follow_root,
    parse_branch_label,
    roots_in_box,
)
from analytic.params import ParameterError, Params

# Pure numpy (no MPI, no FE): the serial pass is enough.
pytestmark = pytest.mark.serial


@pytest.mark.parametrize(
    "kw,n,sign,kmax",
    [
        (dict(H=5.0), 0, -1, 4.0),
        (dict(H=2.0, bc="stress"), 2, 1, 5.0),  # (to 10: a near-collision at k = 5.378)
        (dict(Delta=-0.5), 2, 1, 20.0),
    ],
)
def test_continuation_does_not_depend_on_the_requested_grid(kw, n, sign, kmax):
    """A sparse and a dense set of requested k follow the same branch (no silent jumps)."""
    p = Params(**kw)
    ks = np.array([0.1, 0.5, 1.0]) * kmax
    sparse = follow_branch(p, n, sign, ks)
    dense_k = np.union1d(np.linspace(0.002 * kmax, kmax, 150), ks)
    dense = follow_branch(p, n, sign, dense_k)
    assert sparse.ok.all() and dense.ok.all(), (sparse.note, dense.note)
    idx = np.searchsorted(dense_k, ks)
    # measured <= 2e-16 on 2026-11-21 (same roots, polished to rounding)
    np.testing.assert_allclose(dense.Lambda[idx], sparse.Lambda, rtol=1e-12)


def test_every_point_is_an_isolated_root():
    p = Params()
    b = follow_branch(p, 1, -1, [0.7, 3.0])
    for k, L in zip(b.k, b.Lambda, strict=True):
        r = 0.05
        assert len(roots_in_box(p, k, (L.real - r, L.real + r, L.imag - r, L.imag + r))) == 1


def test_near_collision_is_flagged_not_hidden():
    # Generalized model, H = 1: two roots of branch 2+ meet near k = 4.15 (found 2026-11-21 by
    # comparing sparse and dense continuations, which then pick different roots).
    b = follow_branch(Params(alpha_pc=1.0, alpha_ld=1.0, H=1.0), 2, 1, [2.0, 10.0])
    assert b.ok[0] and not b.ok[1]
    assert "ambiguous" in b.flag[1] and "not isolated" in b.note


def test_labels_and_order():
    res = follow_branches(Params(), 2, [0.3])
    assert [r.label for r in res] == ["0+", "0-", "1+", "1-"]
    assert [parse_branch_label(r.label) for r in res] == [(0, 1), (0, -1), (1, 1), (1, -1)]
    assert branch_label(3, -1) == "3-"
    # universal instability (paper section 4): one partner of each pair grows
    for plus, minus in (res[0:2], res[2:4]):
        assert plus.Lambda[0].real < 0 < minus.Lambda[0].real
    with pytest.raises(ParameterError, match="branch"):
        parse_branch_label("0x")
    with pytest.raises(ParameterError, match="branches"):
        follow_branches(Params(), 0, [1.0])


def test_follow_root_with_a_requested_k_equal_to_k0():
    """k0 among the requested k: its value is the start (this divided by zero before)."""
    p = Params()
    ref = follow_branch(p, 0, -1, [0.5, 1.0, 2.0])
    r = follow_root(p, "0-", 1.0, ref.Lambda[1], [0.5, 1.0, 2.0])
    assert r.flag[0] == "lost" and np.isnan(r.Lambda[0])
    assert r.ok[1:].all(), r.note
    # the same roots, polished twice (measured 1e-15 relative)
    assert np.allclose(r.Lambda[1:], ref.Lambda[1:], rtol=1e-12, atol=0)
