"""Exact reference spectrum of the linearised frictional-sliding problem (DESIGN.md section 4)."""

from analytic.params import Params, ParameterError, check_k

__all__ = ["Params", "ParameterError", "check_k"]
