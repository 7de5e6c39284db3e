"""Branches of the finite-H spectrum, followed in k from the waveguide cut-offs.

A branch ``(n, sign)`` (label ``"0-"``, ``"1+"``, ...) starts at
``Lambda_0 = sign i (2n+1) pi / (2 beta H)`` when ``k -> 0``. :func:`follow_branch`:

1. at a small ``k_start`` it isolates the single root near ``Lambda_0`` with the argument
   principle (a box around the small-k prediction :func:`analytic.smallk.lambda_smallk` must hold
   exactly one root), then polishes it;
2. marches in ``k`` with a secant predictor and a Newton corrector on :func:`det_M`;
3. accepts a step only if the corrector moved little compared with the step and a box around
   the new root (containing the predicted point, with margin) holds exactly one root: otherwise
   two roots are close and the step is halved ("halve the step on doubt"). If the step falls
   below ``dk_min`` while roots stay closer than the box, the point is kept with flag
   ``"ambiguous"`` (the root nearest the prediction) and the march continues.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from analytic.finite_h import cutoff, det_M
from analytic.params import ParameterError, Params, check_k
from analytic.roots import ContourError, Root, count_zeros, polish, zeros_in_box
from analytic.smallk import slope


def branch_label(n: int, sign: int) -> str:
    """``"0-"`` for ``n = 0, sign = -1`` etc."""
    return f"{n}{'+' if sign > 0 else '-'}"


def parse_branch_label(label: str) -> tuple[int, int]:
    """Inverse of :func:`branch_label`: ``"1+" -> (1, +1)``.

    Raises:
        ParameterError: On a malformed label.
    """
    s = label.strip()
    if len(s) < 2 or s[-1] not in "+-" or not s[:-1].isdigit():
        raise ParameterError(f"branch = {label!r} is not of the form '<n>+' or '<n>-' (n >= 0)")
    return int(s[:-1]), (1 if s[-1] == "+" else -1)


@dataclass
class BranchResult:
    """A branch sampled at the requested wavenumbers (plus the whole continuation path).

    Attributes:
        label: ``"0-"``, ``"1+"``, ...
        n: Cut-off index.
        sign: Sign of ``Im Lambda_0``.
        k: Requested wavenumbers (ascending, unique).
        Lambda: Root at each requested ``k`` (NaN where the branch was lost).
        residual: :attr:`analytic.roots.Root.residual` of each root (``|det_M|``).
        cond: :attr:`analytic.roots.Root.cond` of each root.
        ok: True where the root is converged and its isolation was checked.
        flag: ``""`` when ok, otherwise why not (``"ambiguous"``, ``"lost"``, ...).
        k_path: Every ``k`` of the continuation (for plots).
        Lambda_path: The root at every ``k_path``.
        note: Human-readable summary (where a branch could not be followed).
    """

    label: str
    n: int
    sign: int
    k: np.ndarray
    Lambda: np.ndarray
    residual: np.ndarray
    cond: np.ndarray
    ok: np.ndarray
    flag: list[str]
    k_path: np.ndarray = field(default_factory=lambda: np.empty(0))
    Lambda_path: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=complex))
    note: str = ""


def spectrum_function(p: Params, k: float):
    """``Lambda -> det_M(Lambda, k, p)`` (vectorised), the function all root finding uses."""
    return lambda L: det_M(L, k, p)


def polish_root(p: Params, k: float, Lambda_guess: complex, *, tol: float = 1e-14) -> Root:
    """Polish an arbitrary guess (e.g. a finite-element eigenvalue) onto the exact root.

    Newton on :func:`analytic.finite_h.det_M` (residual = ``|det_M|``, a relative residual).
    It converges to the root nearest the guess when the guess is closer to it than to any
    other root, roughly; use :func:`roots_in_box` when that is in doubt.

    Args:
        p: Parameters (finite ``H``).
        k: Wavenumber ``> 0``.
        Lambda_guess: Starting point.
        tol: Relative Newton step tolerance.

    Returns:
        The :class:`analytic.roots.Root` (check ``converged``).
    """
    kk = float(check_k(k)[0])
    return polish(spectrum_function(p, kk), complex(Lambda_guess), tol=tol)


def roots_in_box(p: Params, k: float, box: tuple[float, float, float, float]) -> list[Root]:
    """Every eigenvalue inside ``box = (re_min, re_max, im_min, im_max)`` at wavenumber ``k``.

    Checked by the argument principle (:func:`analytic.roots.zeros_in_box`); ``det_M`` has no
    poles. Keep the box edges off ``Lambda = 0``.
    """
    kk = float(check_k(k)[0])
    return zeros_in_box(spectrum_function(p, kk), box, n_initial=16)


def _box_around(z: complex, r: float) -> tuple[float, float, float, float]:
    return (z.real - r, z.real + r, z.imag - r, z.imag + r)


def _count(p: Params, k: float, z: complex, r: float) -> int:
    """Roots within the square of half-width ``r`` around ``z``; -1 if the contour is unusable."""
    fun = spectrum_function(p, k)
    for shrink in (1.0, 0.93, 1.07):
        try:
            return count_zeros(fun, _box_around(z, r * shrink), n_initial=8)
        except ContourError:
            continue
    return -1


def _start(p: Params, n: int, sign: int, k0: float) -> tuple[Root | None, str]:
    """The single root near the cut-off at small k0, isolated by counting."""
    L0 = cutoff(n, sign, p)
    guess = L0 + slope(n, sign, p) * k0
    fun = spectrum_function(p, k0)
    spacing = math.pi / (p.beta * p.H)  # distance between neighbouring cut-offs
    r = 0.3 * spacing
    for _ in range(12):
        try:
            roots = zeros_in_box(fun, _box_around(guess, r), n_initial=16)
        except ContourError:
            roots = None
        if roots is not None and len(roots) == 1 and roots[0].converged:
            return roots[0], ""
        r *= 0.3
    return None, f"no isolated root found near the cut-off {L0:.6g} at k = {k0:.3g}"


def follow_branch(
    p: Params,
    n: int,
    sign: int,
    k_values: float | np.ndarray,
    *,
    k_start: float | None = None,
    dk_min: float | None = None,
    max_steps: int = 20000,
) -> BranchResult:
    """Follow branch ``(n, sign)`` from its cut-off to every requested ``k``.

    Args:
        p: Parameters (finite ``H``; any ``bc`` and friction model).
        n: Cut-off index ``n >= 0``.
        sign: ``+1`` or ``-1``.
        k_values: Wavenumbers ``> 0`` where the root is wanted (sorted internally).
        k_start: First wavenumber of the continuation (default ``min(1e-3/H, k_min/2)``).
        dk_min: Smallest step before a point is accepted as ``"ambiguous"`` (default
            ``1e-6 * max(k_max, 1/H)``).
        max_steps: Safety limit on the number of continuation steps.

    Returns:
        A :class:`BranchResult`.

    Raises:
        ParameterError: On invalid ``k_values``, ``n`` or ``sign``.
    """
    if not math.isfinite(p.H):
        raise ParameterError("H = inf: branches start at finite-H cut-offs; use a finite H")
    cutoff(n, sign, p)  # validates n and sign
    ks = np.unique(check_k(k_values))
    k_max = float(ks[-1])
    label = branch_label(n, sign)
    if k_start is None:
        k_start = min(1e-3 / p.H, 0.5 * float(ks[0]))
    if dk_min is None:
        dk_min = 1e-6 * max(k_max, 1.0 / p.H)
    out_L = np.full(ks.shape, np.nan + 0j)
    out_res = np.full(ks.shape, np.nan)
    out_cond = np.full(ks.shape, np.nan)
    out_ok = np.zeros(ks.shape, dtype=bool)
    flags = ["lost"] * ks.size
    k_path: list[float] = []
    L_path: list[complex] = []

    root, note = _start(p, n, sign, k_start)
    if root is None:
        return BranchResult(label, n, sign, ks, out_L, out_res, out_cond, out_ok, flags,
                            np.array(k_path), np.array(L_path, dtype=complex), note)
    k_cur, L_cur = k_start, root.value
    k_prev, L_prev = 0.0, cutoff(n, sign, p)  # the cut-off is the k = 0 point of the branch
    k_path += [0.0, k_cur]
    L_path += [L_prev, L_cur]
    dk = k_start
    target_i = 0
    notes: list[str] = []
    steps = 0
    while target_i < ks.size and steps < max_steps:
        steps += 1
        k_target = float(ks[target_i])
        k_new = min(k_cur + dk, k_target)
        h = k_new - k_cur
        # secant predictor through the last two points
        L_pred = L_cur + (L_cur - L_prev) * h / (k_cur - k_prev)
        r = polish(spectrum_function(p, k_new), L_pred)
        dL = abs(r.value - L_cur)
        corr = abs(r.value - L_pred)
        good = r.converged and corr <= 0.25 * max(dL, 1e-12 * abs(L_cur))
        isolated = False
        if good:
            rad = max(2.0 * corr, 0.25 * dL, 1e-9 * abs(r.value))
            isolated = _count(p, k_new, r.value, rad) == 1
        if not (good and isolated) and h > dk_min:
            dk = 0.5 * h
            continue
        flag = "" if (good and isolated) else ("ambiguous" if r.converged else "lost")
        if flag == "lost":
            notes.append(f"branch {label} lost at k = {k_new:.6g} ({r.reason})")
            break
        if flag == "ambiguous":
            notes.append(f"branch {label}: root near k = {k_new:.6g} not isolated"
                         " (close roots or a crossing)")
        k_prev, L_prev, k_cur, L_cur = k_cur, L_cur, k_new, r.value
        k_path.append(k_cur)
        L_path.append(L_cur)
        if k_new == k_target:
            out_L[target_i] = r.value
            out_res[target_i] = r.residual
            out_cond[target_i] = r.cond
            out_ok[target_i] = flag == ""
            flags[target_i] = flag
            target_i += 1
        # step control: grow when the predictor was good
        if flag == "" and r.iterations <= 4 and corr < 0.05 * dL:
            dk = min(2.0 * h, max(0.25 * k_cur, dk_min), 0.1 / p.H + 0.1 * k_cur)
        else:
            dk = h
    if steps >= max_steps:
        notes.append(f"branch {label}: max_steps = {max_steps} reached at k = {k_cur:.6g}")
    return BranchResult(label, n, sign, ks, out_L, out_res, out_cond, out_ok, flags,
                        np.array(k_path), np.array(L_path, dtype=complex), "; ".join(notes))


def follow_branches(p: Params, n_branches: int, k_values: float | np.ndarray
                    ) -> list[BranchResult]:
    """Branches ``0+, 0-, 1+, 1-, ...`` (``n < n_branches``), each via :func:`follow_branch`."""
    if int(n_branches) != n_branches or n_branches < 1:
        raise ParameterError(f"branches = {n_branches!r} is outside its allowed range >= 1")
    return [follow_branch(p, n, s, k_values) for n in range(int(n_branches)) for s in (1, -1)]
