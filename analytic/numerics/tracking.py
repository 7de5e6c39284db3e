"""Waveguide branches: labels, k-independent targets and tracking by eigenvector overlap.

Used for SLEPc targets of one branch (mode shapes, finite block, tests). The dispersion sweep
does not track by overlap any more: its labels come from exact continuation and its
completeness from root counts (:mod:`analytic.numerics.spectrum`, :mod:`forms.solvers.certified`).

A branch ``(n, sign)`` starts at the dilatational waveguide cut-off
``Lambda_0 = sign * i (2n+1) pi / (2 beta H)`` as ``k -> 0`` (docs/design.md section 4); its
label is ``f"{n}{'+' if sign > 0 else '-'}"`` (``"0-"`` is the unstable partner of ``n = 0`` for the
paper's defaults). Each ``k`` is solved near the frictionless waveguide dispersion
``Lambda_wg = sign * i sqrt(((2n+1) pi/(2H))**2 + k**2) / beta`` (:func:`waveguide_lambda`),
which does not depend on the previous ``k``: solves are independent and deterministic, so a
sweep gives the same numbers on any number of ranks. The branch is then followed through the
candidates of all ``k`` afterwards (:func:`track_branch`): at the first ``k`` the candidate
nearest ``Lambda_wg``, then at each ``k`` the candidate whose eigenvector overlaps most with
the last accepted one; below :data:`MIN_OVERLAP` the branch is re-solved near the value
extrapolated from the previous accepted ``k`` values (optional ``resolve`` callback, run in one
process, so still deterministic), and if that fails too it is reported as lost at that ``k``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from analytic.numerics.branches import parse_branch_label
from analytic.params import Params

#: Smallest |<u_prev, u>| (unit vectors) accepted as the same branch at the next k.
MIN_OVERLAP = 0.7
#: Jump guard (see :func:`jump_tolerance`): multiple of the last step ...
JUMP_FACTOR = 3.0
#: ... plus this fraction of |Lambda|.
JUMP_RELATIVE = 0.02


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


@dataclass
class Tracked:
    """Result of :func:`track_branch` for one branch.

    Attributes:
        choice: Per k, the index of the chosen candidate, or -1.
        status: Per k, ``"ok"`` or the reason why no eigenvalue is reported.
        overlap: Per k, overlap with the previous accepted eigenvector (1 at the start).
    """

    choice: list[int]
    status: list[str]
    overlap: list[float]


def track_branch(
    values: list[np.ndarray],
    vectors: list[np.ndarray],
    start_target: complex,
    min_overlap: float = MIN_OVERLAP,
    k: np.ndarray | None = None,
    resolve: Callable[[int, complex], tuple[np.ndarray, np.ndarray]] | None = None,
) -> Tracked:
    """Follow one branch through per-k candidates (sorted by increasing k).

    A candidate continues the branch if its eigenvector overlaps the last accepted one by at
    least ``min_overlap`` and (when ``k`` is given and two points are accepted) its eigenvalue
    lies within :func:`jump_tolerance` of the linear extrapolation; among those the largest
    overlap wins. Otherwise ``resolve`` (if given) adds candidates near the extrapolated value;
    if still none qualifies, the point is reported as lost and the next k is tried.

    Args:
        values: Per k, the candidate eigenvalues (possibly empty: failed solve). Lists are
            extended in place when ``resolve`` adds candidates.
        vectors: Per k, the candidate eigenvectors, shape ``(n_candidates, n)``, already
            :func:`normalized` (same discretisation for every k).
        start_target: Where the branch is at the first k (e.g. :func:`waveguide_lambda`).
        min_overlap: Smallest overlap accepted as the continuation.
        k: The wavenumbers (enables the jump guard; needed with ``resolve``).
        resolve: Optional ``resolve(m, target) -> (values, vectors)``: new candidates at the
            m-th k near ``target``, the value extrapolated linearly from the last two accepted
            points ("predict from the previous k").

    Returns:
        The :class:`Tracked` choices.
    """
    choice: list[int] = []
    status: list[str] = []
    overlap: list[float] = []
    ref: np.ndarray | None = None
    accepted: list[tuple[float, complex]] = []

    def pick(vals: np.ndarray, vecs: np.ndarray, m: int) -> tuple[int, float, str]:
        """Best continuing candidate: (index or -1, its overlap, reason if none)."""
        if len(vals) == 0:
            return -1, float("nan"), "no converged eigenvalue near the target"
        ov = np.abs(np.asarray(vecs).conj() @ ref)
        ok = ov >= min_overlap
        reason = f"best eigenvector overlap {ov.max():.2f} < {min_overlap}"
        if k is not None and len(accepted) >= 2 and ok.any():
            pred = _extrapolate(accepted, float(k[m]))
            tol = jump_tolerance(accepted, float(k[m]))
            near = np.abs(np.asarray(vals) - pred) <= tol
            if not (ok & near).any():
                j = int(np.argmax(np.where(ok, ov, -1.0)))
                reason = (f"best overlapping candidate jumps by {abs(vals[j] - pred):.3g} "
                          f"> {tol:.3g} from the extrapolated value")
            ok &= near
        if not ok.any():
            return -1, float(ov.max()), reason
        i = int(np.argmax(np.where(ok, ov, -1.0)))
        return i, float(ov[i]), ""

    for m in range(len(values)):
        vals, vecs = values[m], vectors[m]
        if ref is None:
            if len(vals) == 0:
                choice.append(-1)
                status.append("no converged eigenvalue near the target")
                overlap.append(float("nan"))
                continue
            i = int(np.argmin(np.abs(np.asarray(vals) - start_target)))
            choice.append(i)
            status.append("ok")
            overlap.append(1.0)
            ref = vecs[i]
            if k is not None:
                accepted.append((float(k[m]), complex(vals[i])))
            continue
        i, ov, reason = pick(vals, vecs, m)
        if i < 0 and resolve is not None and accepted:
            new_vals, new_vecs = resolve(m, _extrapolate(accepted, float(k[m])))
            if len(new_vals):
                old = np.asarray(vecs).reshape(len(vals), -1)
                vals = np.concatenate([np.asarray(vals, dtype=complex), new_vals])
                vecs = np.vstack([old, new_vecs]) if len(old) else np.asarray(new_vecs)
                values[m], vectors[m] = vals, vecs
                i, ov, reason = pick(vals, vecs, m)
        if i < 0:
            choice.append(-1)
            status.append(f"lost: {reason}")
            overlap.append(ov)
            continue
        choice.append(i)
        status.append("ok")
        overlap.append(ov)
        ref = vecs[i]
        if k is not None:
            accepted.append((float(k[m]), complex(vals[i])))
    return Tracked(choice, status, overlap)


def jump_tolerance(accepted: list[tuple[float, complex]], k: float) -> float:
    """Largest accepted distance from the extrapolated value at ``k``.

    ``JUMP_FACTOR`` times the last step (scaled to the k spacing) plus :data:`JUMP_RELATIVE`
    of ``|Lambda|``: a kink in the path (a near-double root) passes, a switch to another root
    far from the path does not.
    """
    (k1, l1), (k2, l2) = accepted[-2], accepted[-1]
    scale = abs(k - k2) / abs(k2 - k1) if k2 != k1 else 1.0
    return JUMP_FACTOR * abs(l2 - l1) * scale + JUMP_RELATIVE * max(1.0, abs(l2))


def _extrapolate(accepted: list[tuple[float, complex]], k: float) -> complex:
    """Linear extrapolation of Lambda(k) from the last two accepted points (or the last one)."""
    if len(accepted) == 1:
        return accepted[-1][1]
    (k1, l1), (k2, l2) = accepted[-2], accepted[-1]
    if k2 == k1:
        return l2
    return l2 + (l2 - l1) * (k - k2) / (k2 - k1)
