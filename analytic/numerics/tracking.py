"""Waveguide branches: labels and k-independent targets.

Used for SLEPc targets of one branch (mode shapes, finite block, tests). The dispersion sweep
labels its roots by exact continuation (:mod:`analytic.numerics.branches` on
:mod:`analytic.numerics.continuation`) and proves completeness by root counts
(:mod:`analytic.numerics.spectrum`, :mod:`forms.solvers.certified`).

A branch ``(n, sign)`` starts at the dilatational waveguide cut-off
``Lambda_0 = sign * i (2n+1) pi / (2 beta H)`` as ``k -> 0`` (docs/design.md section 4); its
label is ``f"{n}{'+' if sign > 0 else '-'}"`` (``"0-"`` is the unstable partner of ``n = 0`` for the
paper's defaults). A target at any ``k`` is the frictionless waveguide dispersion
``Lambda_wg = sign * i sqrt(((2n+1) pi/(2H))**2 + k**2) / beta`` (:func:`waveguide_lambda`),
which does not depend on the previous ``k``. :func:`normalized` fixes an eigenvector's norm and
phase (for overlaps between discretisations).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from analytic.numerics.branches import parse_branch_label
from analytic.params import Params


@dataclass(frozen=True)
class Branch:
    """A waveguide branch: ``n >= 0`` and the sign of ``Im Lambda_0`` (``+1`` or ``-1``)."""

    n: int
    sign: int

    @property
    def label(self) -> str:
        """``"0-"``, ``"0+"``, ``"1-"`` ..."""
        return f"{self.n}{'+' if self.sign > 0 else '-'}"

    @classmethod
    def parse(cls, label: str) -> Branch:
        """Inverse of :attr:`label` (:func:`analytic.numerics.branches.parse_branch_label`)."""
        return cls(*parse_branch_label(label))


def branches(count: int) -> list[Branch]:
    """Branches ``n = 0 .. count-1``, both partners: ``0-, 0+, 1-, 1+, ...``."""
    return [Branch(n, s) for n in range(count) for s in (-1, 1)]


def waveguide_lambda(p: Params, b: Branch, k: float) -> complex:
    """Frictionless dilatational waveguide dispersion ``sign i sqrt(ky**2 + k**2) / beta``."""
    ky = (2 * b.n + 1) * math.pi / (2.0 * p.H)
    return complex(0.0, b.sign * math.hypot(ky, k) / p.beta)


def normalized(vec: np.ndarray) -> np.ndarray:
    """Unit 2-norm vector with its largest entry real and positive (deterministic phase)."""
    v = np.asarray(vec, dtype=complex).ravel()
    nrm = np.linalg.norm(v)
    if nrm == 0:
        return v
    i = int(np.argmax(np.abs(v)))
    return v * (abs(v[i]) / v[i]) / nrm
