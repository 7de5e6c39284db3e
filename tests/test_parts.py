"""workflows/_parts.py: the one resume mechanism (parts written whole, loaded back, cleared)."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest
from _parts import Parts


class _OneRank:
    rank = 0

    @staticmethod
    def bcast(obj, root=0):  # noqa: ANN001, ANN205
        return obj


@pytest.mark.serial
def test_parts_round_trip_and_clear(tmp_path):
    """JSON parts (strict: NaN -> null) and array parts (exact) come back; clear keeps others."""
    parts = Parts(str(tmp_path / "raw"), "k{:05d}")
    assert parts.names() == [] and parts.load_all() == {} and parts.load(1) is None
    parts.save(1, {"k": 0.5, "rows": [{"re": math.nan, "im": math.inf}]})
    w = np.array([1.0 / 3.0, -2e-300, np.pi])
    parts.save("k00000", {"w": w, "step": 7})
    assert parts.names() == ["k00000", "k00001"]
    assert sorted(os.listdir(tmp_path / "raw")) == ["k00000.npz", "k00001.json"]
    assert parts.load("k00001") == {"k": 0.5, "rows": [{"re": None, "im": "inf"}]}
    got = parts.load_all()["k00000"]
    assert got["step"] == 7 and np.array_equal(got["w"], w) and got["w"].dtype == w.dtype
    (tmp_path / "raw" / "other.json").write_text("{}")  # not a part of this pattern
    parts.save(1, {"k": 1.5})  # a newer part replaces the older one
    assert parts.load(1) == {"k": 1.5}
    parts.clear()
    assert parts.names() == [] and sorted(os.listdir(tmp_path / "raw")) == ["other.json"]


@pytest.mark.serial
def test_begin_keeps_parts_only_when_resumed(tmp_path):
    """begin: without resume the earlier parts go; with it, todo lists the numbers left."""
    parts = Parts(str(tmp_path), "p{:05d}")
    for i in (0, 2):
        parts.save(i, {"i": i})
    assert parts.begin(_OneRank, True, count=4).todo == [1, 3]
    assert parts.present == ["p00000", "p00002"]
    assert parts.begin(_OneRank, True, payloads=True).present == {"p00000": {"i": 0},
                                                                   "p00002": {"i": 2}}
    assert parts.begin(_OneRank, False, count=4).todo == [0, 1, 2, 3]
    assert os.listdir(tmp_path) == []
    with pytest.raises(TypeError):
        Parts(str(tmp_path), "L*").save(3, {})  # not numbered: parts are named


@pytest.mark.serial
def test_failed_save_leaves_no_part(tmp_path, monkeypatch):
    """A write failing midway (a full disk) leaves no part and no partial file behind."""
    import _parts

    def full(*args, **kwargs):  # noqa: ANN002, ANN003, ANN202
        raise OSError(28, "No space left on device")

    parts = Parts(str(tmp_path))
    parts.save("old", {"x": 1})
    monkeypatch.setattr(_parts, "dumps", full)
    for payload in ({"x": 2}, {"x": 2, "w": np.zeros(3)}):
        with pytest.raises(OSError):
            parts.save("old", payload)
    assert os.listdir(tmp_path) == ["old.json"] and parts.load("old") == {"x": 1}
