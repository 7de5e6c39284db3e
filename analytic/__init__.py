"""Exact reference spectrum of the linearised frictional-sliding problem (docs/design.md section 4).

Finite H (this package's ``finite_h``, ``branches``, ``smallk``): the spectrum
``det M(Lambda, k, H) = 0``, branches followed from the waveguide cut-offs, small-k asymptotics.
Generic root tools: ``roots``. Physical units: ``units``. Half-space: ``halfspace``, ``largek``.
Deformable substrate (finite ``mu2``): ``twobody`` (the branch tools dispatch on it).
"""

from analytic.numerics.branches import (
    BranchResult,
    branch_label,
    follow_branch,
    follow_branches,
    parse_branch_label,
    polish_root,
    roots_in_box,
)
from analytic.numerics.roots import (
    ContourError,
    Root,
    count_zeros,
    polish,
    winding_number,
    zeros_in_box,
)
from analytic.params import ParameterError, Params, check_k
from analytic.physics import halfspace, largek, twobody
from analytic.physics.finite_h import cutoff, det_M, matrix_M, spectrum_S
from analytic.physics.halfspace import (
    HalfSpaceRoot,
    dilatational_root,
    max_growth,
    s,
    s_tilde,
    shear_root,
)
from analytic.physics.smallk import lambda_smallk, slope
from analytic.physics.twobody import det_twobody, generalized_rayleigh
from analytic.units import Conversion, Physical, to_dimensionless, to_physical

__all__ = [
    "BranchResult",
    "HalfSpaceRoot",
    "dilatational_root",
    "halfspace",
    "largek",
    "twobody",
    "det_twobody",
    "generalized_rayleigh",
    "max_growth",
    "s",
    "s_tilde",
    "shear_root",
    "ContourError",
    "Conversion",
    "ParameterError",
    "Params",
    "Physical",
    "Root",
    "branch_label",
    "check_k",
    "count_zeros",
    "cutoff",
    "det_M",
    "follow_branch",
    "follow_branches",
    "lambda_smallk",
    "matrix_M",
    "parse_branch_label",
    "polish",
    "polish_root",
    "roots_in_box",
    "slope",
    "spectrum_S",
    "to_dimensionless",
    "to_physical",
    "winding_number",
    "zeros_in_box",
]
