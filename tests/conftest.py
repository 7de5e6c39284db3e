import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
for p in (ROOT, os.path.join(ROOT, "workflows")):
    if p not in sys.path:
        sys.path.insert(0, p)


import pytest  # noqa: E402


@pytest.fixture
def count_calls(monkeypatch):
    """A list that grows by one at every argument-principle count (``roots.count_zeros``)."""
    from analytic.numerics import roots

    calls: list[int] = []
    real = roots.count_zeros

    def counting(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(roots, "count_zeros", counting)
    return calls
