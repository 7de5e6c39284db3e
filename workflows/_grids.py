"""Grids of the scenes' options (``--k``, ``--mu2-grid``, ...): :func:`parse_grid`."""

from __future__ import annotations

import math

import numpy as np

from analytic.cli import parse_k
from analytic.params import ParameterError

__all__ = ["parse_grid"]


def parse_grid(spec: str, name: str = "--k", max_count: int = 100000) -> np.ndarray:
    """A sorted grid without duplicates: ``start:stop:countlog`` (geometric) or :func:`parse_k`.

    Raises:
        ParameterError: One line naming ``name`` (malformed, ``start >= stop``, a count outside
            ``2 .. max_count``, a value that is not finite and positive).
    """
    if spec.endswith("log") and spec.count(":") == 2:
        a, b, n = spec[:-3].split(":")
        try:
            a, b, n = float(a), float(b), int(n)
        except ValueError:
            raise ParameterError(f"{name} = {spec!r} is not start:stop:countlog") from None
        if not (0 < a < b and math.isfinite(b) and 2 <= n <= max_count):
            raise ParameterError(f"{name} = {spec!r}: need 0 < start < stop, "
                                 f"2 <= count <= {max_count}")
        return np.geomspace(a, b, n)
    return np.unique(parse_k(spec, name=name))
