"""Branches of the finite-H spectrum, followed in k from the waveguide cut-offs.

A branch ``(n, sign)`` (label ``"0-"``, ``"1+"``, ...) starts at
``Lambda_0 = sign i (2n+1) pi / (2 beta H)`` when ``k -> 0``. :func:`follow_branch`:

1. at a small ``k_start`` it isolates the single root near ``Lambda_0`` with the argument
   principle (a box around the small-k prediction :func:`analytic.physics.smallk.lambda_smallk`
   must hold
   exactly one root), then polishes it;
2. marches in ``k`` with a quadratic (three-point) predictor and a Newton corrector on
   :func:`det_M`;
3. accepts a step only if the corrector moved less than a quarter of the step's move ``dL``
   and the square centred between the old and the new root, of half-width
   ``max((COUNT_MOVES + 1/2) dL, 2 * corrector)`` (:data:`COUNT_MOVES` = 2: it holds the disc
   of radius ``COUNT_MOVES dL`` around the root at either end), holds exactly one root
   both at the new and at the old ``k`` (argument principle): otherwise another root is close
   and the step is halved ("halve the step on doubt"). A silent jump to a neighbouring root
   would need a predictor error above ~3/4 of the move, and a root passing ours during the step
   is seen at one end (unless it moves much faster than ours). If the
   step falls below ``dk_min``, it is retried with the path's tangent (``-F_k / F_Lambda``) as
   the predictor, from the last undoubted size down (a long step can leave the three-point
   parabola's end slope far off); if that fails too, roots stay closer than the box (a
   near-collision): one step of 4x the last undoubted size is tried across it (accepted under
   the same checks; a note says so); failing that, the point is kept with flag ``"ambiguous"``
   (the root nearest the prediction) and the march continues.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from analytic.numerics.continuation import March, Path, SkipTarget, Trial, march_steps
from analytic.numerics.roots import (
    ContourError,
    Root,
    count_zeros,
    point_answers,
    polish,
    polish_steps,
    samples_for_turn,
    stencil_answer,
    stencil_request,
    winding_steps,
    zeros_in_box,
)
from analytic.numerics.steps import Steps, run_many, run_steps
from analytic.params import ParameterError, Params, check_k
from analytic.physics.finite_h import cutoff, det_M
from analytic.physics.smallk import slope
from analytic.physics.twobody import branch_sheet, cutoff_twobody, det_twobody

#: ``skip(k, Lambda_predicted, uncertainty) -> bool`` (see :func:`follow_branch`).
Skip = Callable[[float, complex, float], bool]


def branch_label(n: int, sign: int) -> str:
    """``"0-"`` for ``n = 0, sign = -1`` etc."""
    return f"{n}{'+' if sign > 0 else '-'}"


def parse_branch_label(label: str, name: str = "branch") -> tuple[int, int]:
    """Inverse of :func:`branch_label`: ``"1+" -> (1, +1)``. The one parser of branch labels.

    Args:
        label: ``"<n>+"`` or ``"<n>-"`` (surrounding blanks ignored).
        name: What the error message calls the input (e.g. ``"--branch"``).

    Raises:
        ParameterError: On a malformed label.
    """
    s = label.strip()
    if len(s) < 2 or s[-1] not in "+-" or not s[:-1].isdigit():
        raise ParameterError(f"{name} = {label!r} is not of the form '<n>+' or '<n>-' (n >= 0)")
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
        residual: :attr:`analytic.numerics.roots.Root.residual` of each root (``|det_M|``).
        cond: :attr:`analytic.numerics.roots.Root.cond` of each root.
        ok: True where the root is converged and its isolation was checked all the way from
            the cut-off.
        flag: ``""`` when ok, otherwise why not: ``"ambiguous"`` (not isolated here),
            ``"after an ambiguous point at k = ..."`` (the branch's identity is in doubt from
            there on), ``"lost"``.
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


def spectrum_function(p: Params, k: float, sheet: str = "physical"):
    """``Lambda -> det_M(Lambda, k, p)`` (vectorised), the function all root finding uses.

    For a deformable substrate (``p.two_body``, finite ``mu2``) it is
    :func:`analytic.physics.twobody.det_twobody` instead (same properties: single-valued for finite
    ``H, H2``, no poles, modulus a relative residual); ``sheet`` selects the continuation of a
    half-space's square roots (``"physical"`` or ``"outgoing"``; ignored otherwise).
    """
    if p.two_body:
        return lambda L: det_twobody(L, k, p, sheet)
    return lambda L: det_M(L, k, p)


def polish_root(p: Params, k: float, Lambda_guess: complex, *, tol: float = 1e-14,
                sheet: str = "physical") -> Root:
    """Polish an arbitrary guess (e.g. a finite-element eigenvalue) onto the exact root.

    Newton on :func:`analytic.physics.finite_h.det_M` (residual = ``|det_M|``, a relative residual);
    on :func:`analytic.physics.twobody.det_twobody` for a deformable substrate (``p.two_body``).
    It converges to the root nearest the guess when the guess is closer to it than to any
    other root, roughly; use :func:`roots_in_box` when that is in doubt.

    Args:
        p: Parameters (finite ``H``).
        k: Wavenumber ``> 0``.
        Lambda_guess: Starting point.
        tol: Relative Newton step tolerance.
        sheet: Two bodies with a half-space: ``"physical"`` or ``"outgoing"`` (leaky modes,
            what a PML sees; :func:`analytic.physics.twobody.layer_wavenumbers`).

    Returns:
        The :class:`analytic.numerics.roots.Root` (check ``converged``).
    """
    kk = float(check_k(k)[0])
    return polish(spectrum_function(p, kk, sheet), complex(Lambda_guess), tol=tol)


def roots_in_box(p: Params, k: float, box: tuple[float, float, float, float], *,
                 sheet: str = "physical") -> list[Root]:
    """Every eigenvalue inside ``box = (re_min, re_max, im_min, im_max)`` at wavenumber ``k``.

    Checked by the argument principle (:func:`analytic.numerics.roots.zeros_in_box`); ``det_M`` has
    no
    poles. Keep the box edges off ``Lambda = 0`` (rigid substrate). Two bodies
    (``p.two_body``): :func:`analytic.physics.twobody.det_twobody`; with ``H`` or ``H2`` infinite
    the
    box must not cross the imaginary axis beyond ``min(c_s1, c_s2) k`` (the physical sheet's
    cuts); with ``sheet="outgoing"`` it must not cross the horizontal cuts from ``+-i c k``
    (every ``c`` of a half-space) to the left.
    """
    kk = float(check_k(k)[0])
    return zeros_in_box(spectrum_function(p, kk, sheet), box, n_initial=_n_initial(p, box))


def _n_initial(p: Params, box: tuple[float, float, float, float]) -> int:
    """Initial contour samples, longest side: ``det_M`` turns by about ``H (1 + beta)`` per unit.

    Two bodies: plus ``H2 (1 + beta2) / c_s2`` for a finite substrate; a half-space (either
    body) adds no such rotation (its partial waves carry no ``exp(i H Im k)`` phase): 32
    samples per side then.
    """
    turn = p.H * (1.0 + p.beta) if math.isfinite(p.H) else 0.0
    if p.two_body and math.isfinite(p.H2):
        m2 = p.substrate
        turn += p.H2 * (1.0 + m2.beta) / m2.c_s
    halfspace = not math.isfinite(p.H) or (p.two_body and not math.isfinite(p.H2))
    return samples_for_turn(turn, box, 32 if halfspace else 8)


def _box_around(z: complex, r: float) -> tuple[float, float, float, float]:
    return (z.real - r, z.real + r, z.imag - r, z.imag + r)


def _count(p: Params, k: float, z: complex, r: float) -> Steps[int]:
    """Roots within the square of half-width ``r`` around ``z``; -1 if the contour is unusable.

    Step-wise (:class:`Ask` requests, :func:`branch_answers`).
    """
    sheet = branch_sheet(p)
    for shrink in (1.0, 0.93, 1.07):
        box = _box_around(z, r * shrink)
        try:
            n = (yield from winding_steps(box, 1, n_initial=_n_initial(p, box),
                                          ask=_asker((k,), sheet)))[0]
        except ContourError:
            continue
        if n >= 0:  # (a negative count: an unusable contour, as count_zeros says)
            return n
    return -1


def _count_pair(p: Params, k1: float, k2: float, z: complex, r: float
                ) -> Steps[tuple[int, int]]:
    """:func:`_count` at two wavenumbers; rigid substrate: one request per refinement."""
    if p.two_body:
        return (yield from _count(p, k1, z, r)), (yield from _count(p, k2, z, r))
    for shrink in (1.0, 0.93, 1.07):
        box = _box_around(z, r * shrink)
        try:
            c1, c2 = yield from winding_steps(box, 2, n_initial=_n_initial(p, box),
                                              ask=_asker((k1, k2), "physical"))
            return c1, c2
        except ContourError:
            continue
    return (yield from _count(p, k1, z, r)), (yield from _count(p, k2, z, r))


@dataclass(frozen=True)
class Ask:
    """A request of a branch's step-wise continuation (:mod:`analytic.numerics.steps`).

    Attributes:
        kind: ``"vd"``: the spectrum function and its derivative at the point ``z``;
            ``"d"``: its derivative there; ``"f"``: its values at the points ``z`` (an array),
            one row per wavenumber of ``k``.
        z: The point or points.
        k: The wavenumber (``"vd"``, ``"d"``: one), or wavenumbers (``"f"``: one or two).
        sheet: The continuation of a half-space's square roots (two bodies).
    """

    kind: str
    z: Any
    k: tuple[float, ...]
    sheet: str


def _asker(k: tuple[float, ...], sheet: str) -> Callable[[str, Any], Ask]:
    """The ``ask`` of :func:`analytic.numerics.roots.polish_steps` and ``winding_steps``."""
    return lambda kind, z: Ask(kind, z, k, sheet)


def branch_answers(p: Params) -> Callable[[Ask], Any]:
    """One :class:`Ask` answered at a time: the calls the plain continuation makes.

    One wavenumber: :func:`spectrum_function` (:func:`analytic.numerics.roots.point_answers`);
    two (rigid substrate): one :func:`det_M` call at both.
    """

    def answer(a: Ask) -> Any:
        if len(a.k) == 2:
            zz = a.z
            ks = np.concatenate([np.full(zz.shape, a.k[0]), np.full(zz.shape, a.k[1])])
            return det_M(np.concatenate([zz, zz]), ks, p).reshape(2, zz.size)
        return point_answers(spectrum_function(p, a.k[0], a.sheet))((a.kind, a.z))

    return answer


def branch_answers_all(p: Params) -> Callable[[Sequence[Ask]], list]:
    """Many :class:`Ask` answered together (:func:`analytic.numerics.steps.run_many`).

    Rigid substrate: every point of every request (a Newton step's five, a contour's samples at
    one or two wavenumbers) in one :func:`det_M` call, the wavenumbers as an array: the same
    function, to rounding (its few-point path rounds differently: tests/test_det_m_fast.py),
    without its per-call cost once per request. Two bodies: :func:`branch_answers`, one by one.
    """
    if p.two_body:
        one = branch_answers(p)
        return lambda asks: [one(a) for a in asks]

    def answer_all(asks: Sequence[Ask]) -> list:
        zs, ks, steps = [], [], []
        for a in asks:
            if a.kind == "f":
                z, h = np.asarray(a.z, dtype=complex), math.nan
                zs += [z] * len(a.k)
                ks += [np.full(z.size, kk) for kk in a.k]
            else:
                z, h = stencil_request(a.kind, a.z)
                zs.append(z)
                ks.append(np.full(z.size, a.k[0]))
            steps.append((z.size * (len(a.k) if a.kind == "f" else 1), h))
        vals = det_M(np.concatenate(zs), np.concatenate(ks), p)
        out, i = [], 0
        for a, (n, h) in zip(asks, steps, strict=True):
            f = vals[i:i + n]
            out.append(f.reshape(len(a.k), -1) if a.kind == "f" else stencil_answer(a.kind, f, h))
            i += n
        return out

    return answer_all


def branch_cutoff(n: int, sign: int, p: Params) -> complex:
    """The ``k -> 0`` start of branch ``(n, sign)``.

    Rigid substrate: :func:`analytic.physics.finite_h.cutoff`; two bodies:
    :func:`analytic.physics.twobody.cutoff_twobody` (the composite rod's ``n``-th mode).
    """
    return cutoff_twobody(n, sign, p) if p.two_body else cutoff(n, sign, p)


def _start(p: Params, n: int, sign: int, k0: float) -> tuple[Root | None, str]:
    """The single root near the cut-off at small k0, isolated by counting."""
    L0 = branch_cutoff(n, sign, p)
    fun = spectrum_function(p, k0, branch_sheet(p))
    if p.two_body:
        guess = L0
        # distance to the nearest other cut-off (or to the flexural root at 0)
        others = [0.0] + [branch_cutoff(m, sign, p) for m in (n - 1, n + 1) if m >= 0]
        spacing = min(abs(L0 - z) for z in others)
    else:
        guess = L0 + slope(n, sign, p) * k0
        spacing = math.pi / (p.beta * p.H)  # distance between neighbouring cut-offs
    r = 0.3 * spacing
    for _ in range(12):
        # counted first: a box of more roots than one is shrunk without searching it (the
        # stress top's 74 branches at the defaults: 148 searches of 2-4 roots, 0.4 s)
        try:
            box = _box_around(guess, r)
            n_initial = _n_initial(p, box)
            total = count_zeros(fun, box, n_initial=n_initial)
            roots = zeros_in_box(fun, box, n_initial=n_initial, total=total) if total == 1 \
                else None
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
    skip: Skip | None = None,
) -> BranchResult:
    """Follow branch ``(n, sign)`` from its cut-off to every requested ``k``.

    Two bodies (``p.two_body``): the branch starts at
    :func:`analytic.physics.twobody.cutoff_twobody` and is followed on
    :func:`analytic.physics.twobody.det_twobody` with the same checks. The flexural branch (from
    ``Lambda = 0`` at ``k = 0``, finite ``H2``) is not one of these; :func:`roots_in_box` finds
    it. With a half-space substrate (``H2 = inf``) the branches are leaky at small ``k`` and are
    followed on the ``"outgoing"`` continuation (:func:`analytic.physics.twobody.branch_sheet`); use
    :func:`analytic.physics.twobody.root_sheet` to tell a leaky point from an eigenvalue. Counting
    fails (flag ``"ambiguous"``) where a root meets a horizontal cut ``Im Lambda = +-c k``.

    Args:
        p: Parameters (finite ``H``; any ``bc`` and friction model).
        n: Cut-off index ``n >= 0``.
        sign: ``+1`` or ``-1``.
        k_values: Wavenumbers ``> 0`` where the root is wanted (sorted internally).
        k_start: First wavenumber of the continuation (default ``min(1e-3/H, k_min/2)``).
        dk_min: Smallest step before a point is accepted as ``"ambiguous"`` (default
            ``1e-6 * max(k_max, 1/H)``).
        max_steps: Safety limit on the number of continuation steps.
        skip: ``skip(k, Lambda_predicted, uncertainty)`` True when the root is not wanted at a
            requested ``k`` (e.g. predicted far outside a region): no value there (flag
            ``"outside"``), and no continuation step has to end there.

    Returns:
        A :class:`BranchResult`.

    Raises:
        ParameterError: On invalid ``k_values``, ``n`` or ``sign``.
    """
    return run_steps(follow_branch_steps(p, n, sign, k_values, k_start=k_start, dk_min=dk_min,
                                         max_steps=max_steps, skip=skip), branch_answers(p))


def follow_branch_steps(
    p: Params,
    n: int,
    sign: int,
    k_values: float | np.ndarray,
    *,
    k_start: float | None = None,
    dk_min: float | None = None,
    max_steps: int = 20000,
    skip: Skip | None = None,
) -> Steps[BranchResult]:
    """:func:`follow_branch` as a step-wise algorithm (:mod:`analytic.numerics.steps`).

    Its requests are :class:`Ask`; :func:`branch_answers` answers them one by one,
    :func:`branch_answers_all` many continuations' together. Same arguments and result.
    """
    if not math.isfinite(p.H):
        raise ParameterError("H = inf: branches start at finite-H cut-offs; use a finite H")
    branch_cutoff(n, sign, p)  # validates n and sign (and H2 for two bodies)
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
    # the cut-off is the k = 0 point of the branch
    return (yield from _continue(p, label, n, sign, ks, (0.0, branch_cutoff(n, sign, p)),
                                 (k_start, root.value), dk_min, max_steps, skip))


def follow_root(
    p: Params,
    label: str,
    k0: float,
    Lambda0: complex,
    k_values: float | np.ndarray,
    *,
    dk_min: float | None = None,
    max_steps: int = 20000,
    skip: Skip | None = None,
) -> BranchResult:
    """Follow the root at ``(k0, Lambda0)`` to every requested ``k >= k0``.

    As :func:`follow_branch` (same step control, root count at every step), for a root that
    does not start at a waveguide cut-off. The root is polished at ``k0`` (the value at a requested
    ``k = k0``), and a first point at ``k0 (1 - 1e-3)`` gives the secant predictor. Requested
    ``k < k0`` are reported lost.

    Returns:
        A :class:`BranchResult` with ``n = -1``, ``sign = 0``.
    """
    return run_steps(follow_root_steps(p, label, k0, Lambda0, k_values, dk_min=dk_min,
                                       max_steps=max_steps, skip=skip), branch_answers(p))


def _start_pair(Lambda0: complex, k0: float, k_a: float, sheet: str  # noqa: N803
                ) -> Steps[tuple[Root, Root] | None]:
    """``Lambda0`` polished at ``k0``, then that root at ``k_a`` (the secant's second point).

    ``None`` unless both converge within ``1e-2`` (relative) of each other: no root near
    ``Lambda0``. Step-wise (:func:`follow_root_steps`, :func:`trace_back_steps`).
    """
    r0 = yield from polish_steps(complex(Lambda0), ask=_asker((k0,), sheet))
    r_a = yield from polish_steps(r0.value, ask=_asker((k_a,), sheet))
    ok = r0.converged and r_a.converged and abs(r_a.value - r0.value) < 1e-2 * max(
        1.0, abs(r0.value))
    return (r0, r_a) if ok else None


def follow_root_steps(
    p: Params,
    label: str,
    k0: float,
    Lambda0: complex,
    k_values: float | np.ndarray,
    *,
    dk_min: float | None = None,
    max_steps: int = 20000,
    skip: Skip | None = None,
) -> Steps[BranchResult]:
    """:func:`follow_root` as a step-wise algorithm (as :func:`follow_branch_steps`)."""
    ks = np.unique(check_k(k_values))
    if dk_min is None:
        dk_min = 1e-6 * max(float(ks[-1]), 1.0 / p.H)
    k_a = k0 * (1.0 - 1e-3)
    pair = yield from _start_pair(Lambda0, k0, k_a, "physical")
    nan = np.full(ks.shape, np.nan + 0j)
    if pair is None:
        return BranchResult(label, -1, 0, ks, nan, np.full(ks.shape, np.nan),
                            np.full(ks.shape, np.nan), np.zeros(ks.shape, bool),
                            ["lost"] * ks.size, note=f"{label}: no root near {Lambda0} at k0")
    r0, r_a = pair
    # requested k below k0 are lost; one equal to k0 is the polished start itself
    first = int(np.searchsorted(ks, k0))
    at_k0 = int(first < ks.size and ks[first] == k0)
    res = yield from _continue(p, label, -1, 0, ks[first + at_k0:], (k_a, r_a.value),
                               (k0, r0.value), dk_min, max_steps, skip)
    if first + at_k0 == 0:
        return res
    head = [(np.nan + 0j, np.nan, np.nan, False, "lost")] * first
    head += [(r0.value, r0.residual, r0.cond, True, "")] * at_k0
    L_h, res_h, cond_h, ok_h, flag_h = (list(c) for c in zip(*head, strict=True))  # noqa: N806
    return BranchResult(label, -1, 0, ks, np.concatenate([np.array(L_h, complex), res.Lambda]),
                        np.concatenate([res_h, res.residual]), np.concatenate([cond_h, res.cond]),
                        np.concatenate([np.array(ok_h, bool), res.ok]), flag_h + list(res.flag),
                        res.k_path, res.Lambda_path, res.note)


def trace_back_steps(p: Params, k0: float, Lambda0: complex, k_targets: Sequence[float], *,
                     max_steps: int = 20000) -> Steps[tuple[np.ndarray, list[str]]]:
    """The root at ``(k0, Lambda0)`` continued *down* in ``k`` to each of ``k_targets``.

    The continuation of :func:`follow_root` run backwards (the same step control, corrector
    test and root count at both ends of every step): which family's start a root of a large
    ``k`` comes from (:func:`analytic.numerics.spectrum.label_roots`). Step-wise
    (:mod:`analytic.numerics.steps`).

    Returns:
        ``(values, flags)`` in the order of ``k_targets``: the root at each target (``nan``: not
        reached) and its flag (``""``; ``"ambiguous"`` or ``"after an ambiguous point ..."``: a
        step could not isolate the root; ``"lost"``: not reached).
    """
    kt = np.asarray(k_targets, dtype=float)
    order = np.argsort(-kt, kind="stable")
    values = np.full(kt.shape, np.nan + 0j)
    flags = ["lost"] * kt.size
    k_a = k0 * (1.0 + 1e-3)
    pair = yield from _start_pair(Lambda0, k0, k_a, branch_sheet(p))
    if pair is None or not kt.size:
        return values, flags
    r0, r_a = pair
    dk_min = 1e-6 * max(k0, 1.0 / p.H)
    stepper = _BranchStepper(p, "trace", dk_min, good_h=k_a - k0)
    run = yield from march_steps(stepper, Path([k_a, k0], [r_a.value, r0.value]), kt[order],
                                 dk=k_a - k0, dk_min=dk_min, max_steps=max_steps)
    for j, trial in zip(order, run.trials, strict=True):
        if trial is not None:
            values[j], flags[j] = trial.value, trial.flag
    return values, flags


#: :meth:`_BranchStepper.rescue`'s tangent step is accepted only with no other root, at both ends,
#: within this many times its move nor within the move of the last undoubted step along the
#: tangent: near a near-collision (two roots 0.01 apart, ``alpha_pc = alpha_ld = 1``, ``H = 1``,
#: branch ``2+`` at ``k = 4.155``) the tangent step passed the usual test and a sparse and a
#: dense list of ``k`` then ended on different roots.
ISOLATION = 10.0
#: Half-width of a step's counting square in units of the step's move ``dL`` (at least; twice the
#: corrector if larger). With 1 (until session 39) a step could jump across an avoided crossing:
#: the other root, 0.15 and 0.19 from ours at the step's ends, stayed outside both counts while
#: passing within 0.01 in between (``alpha_pc = alpha_ld = 1``, ``H = 1``, ``s4-`` from ``k =
#: 2.98`` to 3.38), and a sparse and a dense list of ``k`` then gave different roots the same
#: label at 23 of 135 points (``k = 5, 10``); with 2, at 1 (docs/design.md section 4).
#: Since session 40 the square is centred between the two roots with half-width
#: ``(COUNT_MOVES + 1/2) dL``, so that it holds the disc of ``COUNT_MOVES dL`` around the root at
#: *either* end: centred with ``COUNT_MOVES dL`` it reached only ``1.5 dL`` beyond an end root
#: along the step, and that one (``s18-``, same model, ``k = 7.43 -> 7.62``) missed by 0.0002 the
#: other root, 0.038 from ours at the start and 4x as fast, which then crossed it within the step
#: (an avoided crossing with a gap of 0.01): the lone list ``k = 5, 10`` ended on another root than
#: lists of 200 and 2 000 points, both certain. Measured roots move up to 23x ``c_d`` in ``k``
#: (real seeds, ``s11-`` there near ``k = 9.8``), so no bound on the other roots' speed sizes it.
COUNT_MOVES = 2.0


@dataclass
class _Step:
    """A corrected step of a branch: the polished root, the corrector and the move."""

    root: Root
    corr: float
    move: float


@dataclass
class _BranchStepper:
    """The branch-specific half of the continuation (:mod:`analytic.numerics.continuation`).

    Acceptance: a converged corrector that moved less than a quarter of the step's move (3/4
    until three points give the curvature) and one root, at both ends, in the square centred
    between the old and the new root (module docstring). ``good_h`` is the last step accepted
    without doubt; ``doubt`` the flag of every point after an ambiguous one.
    """

    p: Params
    label: str
    dk_min: float
    good_h: float
    notes: list[str] = field(default_factory=list)
    doubt: str = ""
    grow_from: float = 0.0  #: a step :meth:`rescue` took with the tangent: the next grows from it

    def attempt(self, path: Path, k_new: float, tangent: complex | None = None
                ) -> Steps[Trial[_Step]]:
        """Quadratic (or ``tangent``) predictor, Newton corrector, root count."""
        L_cur = path.value[-1]  # noqa: N806
        L_pred = (path.predict(k_new, order=2) if tangent is None  # noqa: N806
                  else L_cur + tangent * (k_new - path.k[-1]))
        r = yield from polish_steps(L_pred, ask=_asker((k_new,), branch_sheet(self.p)))
        dL = abs(r.value - L_cur)  # noqa: N806
        corr = abs(r.value - L_pred)
        # Until three points exist the secant cannot know the curvature (the linear term may
        # vanish at the cut-off, e.g. beta = 1/5): allow a larger corrector on those steps.
        ratio = 0.25 if len(path.k) >= 3 and path.k[-3] > 0 else 0.75
        ok = r.converged and corr <= ratio * max(dL, 1e-12 * abs(L_cur))
        if ok:
            # Counting between steps: the square centred between the old and the new root,
            # half-width max((COUNT_MOVES + 1/2) dL, 2 corr) (the disc of COUNT_MOVES dL around
            # either end's root), must hold exactly one root at k_new *and* at k_cur. A jump to
            # a neighbouring root would need a predictor error of ~3/4 of the move, and a root
            # passing ours within the step is seen at one end or the other unless it moves
            # much faster than ours (COUNT_MOVES).
            centre = 0.5 * (L_cur + r.value)
            rad = max(2.0 * corr, (COUNT_MOVES + 0.5) * dL, 1e-9 * abs(r.value))
            ok = (yield from _count_pair(self.p, k_new, path.k[-1], centre, rad)) == (1, 1)
        return Trial(k_new, r.value, ok, _Step(r, corr, dL), flag=self.doubt if ok else "")

    def _tangent(self, path: Path) -> Steps[complex | None]:
        """``dLambda/dk`` at the path's last point, ``-F_k / F_Lambda``.

        ``F_k`` by a central difference in ``k``, ``F_Lambda`` as the corrector's; ``None`` where
        ``F_Lambda`` is 0.
        """
        k, z = path.k[-1], path.value[-1]
        dk = 1e-5 * max(k, 1.0 / self.p.H)
        sheet = branch_sheet(self.p)
        f_up = np.ravel((yield Ask("f", np.array([z]), (k + dk,), sheet)))[0]
        f_down = np.ravel((yield Ask("f", np.array([z]), (k - dk,), sheet)))[0]
        _, d = yield Ask("vd", z, (k,), sheet)
        return None if d == 0 else -(f_up - f_down) / (2.0 * dk * d)

    def rescue(self, path: Path, trial: Trial[_Step], k_target: float
               ) -> Steps[Trial[_Step] | None]:
        """The step is below ``dk_min`` and still not accepted.

        First the step is retried with the path's own tangent as the predictor
        (:meth:`_tangent`), from the last undoubted size down to ``dk_min``, under the same
        acceptance test: after a long step the three-point parabola's slope at its end can be
        40 % off, and a corrector proportional to the step then fails the quarter test however
        short the step (velocity top, ``s8+`` at ``k = 26``); the tangent step must also find no
        other root within :data:`ISOLATION` times its move or the last undoubted step's move.
        Otherwise roots are closer than the step can resolve: one step over with 4x the last
        undoubted size, else the point is kept as ``"ambiguous"``.
        """
        k_cur = path.k[-1]
        tangent = yield from self._tangent(path)
        h = min(self.good_h, abs(k_target - k_cur))
        sgn = 1.0 if k_target >= k_cur else -1.0
        while tangent is not None and h >= self.dk_min:
            t = yield from self.attempt(path, k_cur + sgn * h, tangent)
            if t.accepted:  # and no other root within a normal step's move, nor ISOLATION moves
                st = t.result
                near = ISOLATION * max(st.move, 2.0 * st.corr)
                rad = max(self.good_h * abs(tangent), near)
                if (yield from _count_pair(self.p, t.k, k_cur, 0.5 * (path.value[-1]
                                                                    + t.value), rad)) == (1, 1):
                    self.grow_from = h
                    return t
                if near <= self.good_h * abs(tangent):
                    break  # a root within a normal step: a near-collision, not a poor predictor
            h *= 0.5
        over_h = max(4.0 * self.good_h, 100.0 * self.dk_min)
        k_over = (min(k_cur + over_h, k_target) if k_target >= k_cur  # forward, or back
                  else max(k_cur - over_h, k_target))
        over = yield from self.attempt(path, k_over)
        if over.accepted:
            self.notes.append(f"branch {self.label}: stepped over a near-collision of roots"
                              f" between k = {k_cur:.6g} and {k_over:.6g}")
            return over
        r = trial.result.root
        if not r.converged:
            self.notes.append(f"branch {self.label} lost at k = {trial.k:.6g} ({r.reason})")
            return None
        self.notes.append(f"branch {self.label}: root near k = {trial.k:.6g} not isolated"
                          " (close roots or a crossing)")
        if not self.doubt:
            self.doubt = f"after an ambiguous point at k = {trial.k:.6g}"
        trial.flag = "ambiguous"
        return trial

    def next_step(self, path: Path, h: float, trial: Trial[_Step], clamped: bool, dk: float
                  ) -> float:
        """Grow when the predictor was good; after doubt restart at a normal size."""
        if trial.flag == "ambiguous":
            return self.good_h
        if self.grow_from:  # a tangent step of the rescue: grow from its size
            h, self.grow_from = self.grow_from, 0.0
            return min(2.0 * h, self.good_h)
        if clamped and h < dk:
            return dk  # a short step onto a requested k says nothing about the step size
        self.good_h = h
        st = trial.result
        if st.root.iterations <= 4 and st.corr < 0.05 * st.move:
            k_cur = path.k[-1]
            return min(2.0 * h, max(0.25 * k_cur, self.dk_min), 0.1 / self.p.H + 0.1 * k_cur)
        return h


def _skip_target(skip: Skip) -> SkipTarget:
    """The engine's ``skip(path, k)`` from a branch ``skip(k, predicted, uncertainty)``."""

    def skip_target(path: Path, k_target: float) -> bool:
        d1 = path.secant()
        h = k_target - path.k[-1]
        return skip(k_target, path.value[-1] + d1 * h, abs(d1) * h)

    return skip_target


def _continue(p: Params, label: str, n: int, sign: int, ks: np.ndarray,
              prev: tuple[float, complex], cur: tuple[float, complex], dk_min: float,
              max_steps: int, skip: Skip | None = None) -> Steps[BranchResult]:
    """The continuation shared by :func:`follow_branch` and :func:`follow_root`.

    ``skip(k, Lambda_predicted, uncertainty)`` True: the requested ``k`` is not needed (flag
    ``"outside"``, no value); the continuation then does not stop there.
    """
    path = Path([prev[0], cur[0]], [prev[1], cur[1]])
    dk = cur[0] - prev[0] if prev[0] > 0 else cur[0]
    stepper = _BranchStepper(p, label, dk_min, good_h=dk)
    if ks.size == 0:
        return _branch_result(label, n, sign, ks, path, None, stepper.notes)
    run = yield from march_steps(stepper, path, ks, dk=dk, dk_min=dk_min, max_steps=max_steps,
                                 skip=None if skip is None else _skip_target(skip))
    if run.steps >= max_steps:
        stepper.notes.append(f"branch {label}: max_steps = {max_steps} reached at"
                             f" k = {path.k[-1]:.6g}")
    return _branch_result(label, n, sign, ks, path, run, stepper.notes)


def _branch_result(label: str, n: int, sign: int, ks: np.ndarray, path: Path,
                   run: March[_Step] | None, notes: list[str]) -> BranchResult:
    """The :class:`BranchResult` of a march (``run``: None before any step)."""
    out_L = np.full(ks.shape, np.nan + 0j)  # noqa: N806
    out_res = np.full(ks.shape, np.nan)
    out_cond = np.full(ks.shape, np.nan)
    out_ok = np.zeros(ks.shape, dtype=bool)
    flags = ["lost"] * ks.size
    for i, t in enumerate(run.trials if run is not None else []):
        if run.skipped[i]:
            flags[i] = "outside"
        elif t is not None:
            r = t.result.root
            out_L[i], out_res[i], out_cond[i] = t.value, r.residual, r.cond
            out_ok[i], flags[i] = t.flag == "", t.flag
    return BranchResult(label, n, sign, ks, out_L, out_res, out_cond, out_ok, flags,
                        np.array(path.k), np.array(path.value, dtype=complex), "; ".join(notes))


def follow_branches(p: Params, n_branches: int, k_values: float | np.ndarray
                    ) -> list[BranchResult]:
    """Branches ``0+, 0-, 1+, 1-, ...`` (``n < n_branches``), each as :func:`follow_branch`.

    The continuations run side by side (:func:`analytic.numerics.steps.run_many`), every point
    of a round in one :func:`det_M` call (:func:`branch_answers_all`): the same steps, checks
    and flags as one by one, the values to rounding (tests/test_steps.py).
    """
    if int(n_branches) != n_branches or n_branches < 1:
        raise ParameterError(f"branches = {n_branches!r} is outside its allowed range >= 1")
    pairs = [(n, s) for n in range(int(n_branches)) for s in (1, -1)]
    done = run_many(((i, follow_branch_steps(p, n, s, k_values))
                     for i, (n, s) in enumerate(pairs)), branch_answers_all(p))
    return [done[i] for i in range(len(pairs))]
