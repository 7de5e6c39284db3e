"""Exact reference spectrum of the linearised frictional-sliding problem (DESIGN.md section 4)."""

from analytic.params import ParameterError, Params, check_k
from analytic.roots import ContourError, Root, count_zeros, polish, winding_number, zeros_in_box

__all__ = [
    "ContourError",
    "Params",
    "ParameterError",
    "Root",
    "check_k",
    "count_zeros",
    "polish",
    "winding_number",
    "zeros_in_box",
]
