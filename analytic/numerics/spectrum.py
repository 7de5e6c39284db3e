"""The complete spectrum in a stated region, with labels from continuation (docs/design.md 8).

Three pieces, all exact (``det_M`` of :mod:`analytic.physics.finite_h`), used by the sweep to
certify
its finite-element eigenvalues:

- :class:`Region`: the part of the ``Lambda`` plane where *every* eigenvalue is reported,
  ``re_min <= Re Lambda <= re_max``, ``|Im Lambda| <= c_max k c_d,max + omega0``: all phase
  velocities up to ``c_max`` times the largest ``c_d`` of the stack at every ``k``, plus the
  first few cut-off frequencies at small ``k``. With ``c_max = None`` the bound is chosen per
  ``k`` (:func:`provable_region`) until the tail bound of :mod:`analytic.physics.tail` shows
  that no root beyond grows faster than the fastest root inside (:func:`fastest_mode`).
- :func:`exact_roots`: every root in the region at one ``k``, certified by the argument
  principle (the edges are nudged if a root sits on one; the rectangle actually used is
  returned so that the FE count uses the same one).
- :func:`families`: labels by continuation in ``k``. The waveguide branches ``n+`` / ``n-``
  are followed from their cut-offs (:func:`analytic.numerics.branches.follow_branch`); every other
  root
  present at the seed wavenumber ``k_seed = 0.02 / H`` (shear-thickness modes damped by
  friction, real roots near ``Lambda = -1``, the stress top's pair near ``Lambda = 0``) is
  followed from there (:func:`analytic.numerics.branches.follow_root`) and labelled by its position
  at
  ``k_seed``: ``s0+, s1+, ...`` (``Im > 0``, by ``|Im|``), ``s0-, ...`` and ``r0, r1, ...``
  (real, by decreasing ``Re``). The continuation uses adaptive steps with a root count at every
  step, so labels and values do not depend on the requested ``k`` grid.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, replace
from typing import Any, TypeVar

import numpy as np

from analytic.numerics.branches import (
    BranchResult,
    branch_answers,
    branch_answers_all,
    branch_cutoff,
    follow_branch_steps,
    follow_root_steps,
    trace_back_steps,
)
from analytic.numerics.roots import Box, ContourError, Root, zeros_in_box
from analytic.numerics.steps import Steps, run_many, run_steps
from analytic.params import ParameterError, Params
from analytic.physics.tail import loose_tail_bound, tail_bound, velocity_scale

T = TypeVar("T")

#: Relative distance within which a continued family value and an exact root are one root.
SAME_ROOT_RTOL = 1e-7
#: Seed wavenumber of the non-waveguide families, times H.
SEED_KH = 0.02


#: Phase-velocity bounds tried by the adaptive region, in units of the largest ``c_d``.
C_LADDER = (4.0, 6.0, 8.0, 12.0, 16.0, 24.0, 32.0)
#: Box heights tried beyond the top rung of :data:`C_LADDER` when it does not prove, as
#: multiples of the top rung's height ``W`` at ``k``; each is solved only where its tail bound
#: is below the fastest value found (:func:`provable_region`). At small ``k`` the height is
#: mostly ``omega0``, so a box twice as tall is a phase velocity of hundreds of ``c_d``.
#: Measured (stress top, 5 x 5 map ``Delta`` -1 .. 1, ``H`` 0.1 .. 10, 24 ``kH``, session 23):
#: 42 of the 600 ``k`` with a root were not proven at 32 ``c_d``, all at small ``kH``; every one
#: is proven by a box at most 2.0x as tall (quantiles 1.02, 1.08, 1.29, 1.59, 1.98, 2.0).
TALLER = (1.25, 1.5, 2.0, 3.0, 4.0)


@dataclass(frozen=True)
class Region:
    """Region of the ``Lambda`` plane in which every eigenvalue is reported.

    Attributes:
        re_min: Smallest growth rate reported (default slightly below 0: modes at the
            stability threshold are kept, and the contour stays off ``Lambda = 0``).
        re_max: Largest growth rate searched.
        c_max: Largest phase velocity ``|Im Lambda| / k`` reported, in units of the largest
            ``c_d`` of the stack (:func:`analytic.physics.tail.velocity_scale`: ``c_d`` of the
            slider for the rigid substrate). ``None``: adaptive, chosen per ``k`` from
            :data:`C_LADDER` by :func:`provable_region` so that the region provably holds the
            fastest mode; resolve it with :meth:`fixed` before asking for a box.
        omega0: Frequency allowance at ``k -> 0``; ``None``: ``2 pi / (beta H)`` (the first two
            dilatational cut-offs of either top).
    """

    re_min: float = -0.01
    re_max: float = 2.0
    c_max: float | None = 4.0
    omega0: float | None = None

    def __post_init__(self) -> None:
        for name in ("re_min", "re_max") + (("c_max",) if self.c_max is not None else ()):
            v = getattr(self, name)
            if not math.isfinite(v):
                raise ParameterError(f"{name} = {v!r} must be a finite number")
        if not self.re_max > self.re_min:
            raise ParameterError(f"re_max = {self.re_max} must be > re_min = {self.re_min}")
        if self.re_min <= -1.0:
            raise ParameterError(
                f"re_min = {self.re_min} is outside its allowed range -1 < re_min: the "
                "polynomial FE form has a spurious root at Lambda = -1")
        if self.c_max is not None and self.c_max <= 0:
            raise ParameterError(f"c_max = {self.c_max} is outside its allowed range c_max > 0")
        if self.omega0 is not None and not (math.isfinite(self.omega0) and self.omega0 > 0):
            raise ParameterError(f"omega0 = {self.omega0!r} must be a finite number > 0")

    @property
    def adaptive(self) -> bool:
        """True when ``c_max`` is chosen per ``k`` (:func:`provable_region`)."""
        return self.c_max is None

    def fixed(self, c_max: float) -> Region:
        """This region with the phase-velocity bound ``c_max`` (a resolved adaptive region)."""
        return replace(self, c_max=float(c_max))

    def omega_0(self, p: Params) -> float:
        """The frequency allowance at ``k -> 0`` for parameters ``p``."""
        return self.omega0 if self.omega0 is not None else 2.0 * math.pi / (p.beta * p.H)

    def im_max(self, p: Params, k: float) -> float:
        """``|Im Lambda|`` bound at wavenumber ``k``.

        Raises:
            ParameterError: If the region is adaptive (resolve ``c_max`` first).
        """
        if self.c_max is None:
            raise ParameterError("c_max = None (adaptive): resolve it per k with "
                                 "provable_region and Region.fixed first")
        return self.c_max * float(k) * velocity_scale(p) + self.omega_0(p)

    def box(self, p: Params, k: float) -> Box:
        """The region at ``k`` as a rectangle ``(re_min, re_max, -W, W)``."""
        w = self.im_max(p, k)
        return (self.re_min, self.re_max, -w, w)

    def as_dict(self, p: Params) -> dict:
        """Description for summaries (with the resolved ``omega0``)."""
        d = asdict(self)
        d["omega0"] = self.omega_0(p)
        d["c_max"] = "auto" if self.c_max is None else self.c_max
        d["velocity_scale"] = velocity_scale(p)
        d["definition"] = ("re_min <= Re Lambda <= re_max and |Im Lambda| <= c_max * k * "
                           "velocity_scale + omega0 (phase velocities up to c_max times the "
                           "largest c_d of the stack, velocity_scale; c_max = auto: chosen per k "
                           f"from {list(C_LADDER)} until the tail bound, "
                           "analytic.physics.tail, is below the fastest root inside; beyond "
                           f"the top rung boxes {list(TALLER)} times as tall, each only where "
                           "its tail bound is below the fastest root found)")
        return d


def _ceil2(x: float) -> float:
    """``x`` rounded up to two significant digits (readable bounds: 140 rather than 134.77)."""
    e = 10.0 ** (math.floor(math.log10(x)) - 1)
    return math.ceil(x / e - 1e-9) * e


def taller_rungs(p: Params, k: float, region: Region) -> tuple[float, ...]:
    """The phase-velocity bounds of the boxes :data:`TALLER` times as tall as the top rung's.

    At ``k`` the top rung's height is ``W = C_LADDER[-1] k v + omega0`` (``v`` the velocity
    scale); the box ``f W`` tall has ``c = C_LADDER[-1] + (f - 1) W / (k v)``, rounded up to
    two significant digits (a box at least ``f W`` tall).
    """
    top = C_LADDER[-1]
    w = region.fixed(top).im_max(p, k)
    per_c = float(k) * velocity_scale(p)
    return tuple(_ceil2(top + (f - 1.0) * w / per_c) for f in TALLER)


def provable_region(p: Params, k: float, region: Region,
                    fastest_inside: Callable[[float], float | None], *,
                    bound: Callable[[float, float], float | None] | None = None,
                    ladder: Sequence[float] | None = None
                    ) -> tuple[float, float | None]:
    """The smallest phase-velocity bound that provably holds the fastest mode at ``k``.

    Climbs :data:`C_LADDER` (or uses ``region.c_max`` alone when it is fixed): at each rung
    ``c``, ``fastest_inside(c)`` is the largest ``Re Lambda`` in ``region.fixed(c)`` (``None``:
    no root there), found by any method (exact roots, FE eigenvalues); the rung is accepted when
    :func:`analytic.physics.tail.tail_bound` at ``W = region.fixed(c).im_max(p, k)`` is below it
    (below ``re_min`` when there is no root). Rungs whose tail bound is not below the current
    fastest value are skipped without calling ``fastest_inside``. When the top rung does not
    prove, the boxes of :func:`taller_rungs` are tried in turn, each solved only where its
    tail bound is below the fastest value found (so the first one solved proves; a taller box
    whose bound is not below is never solved).

    Returns:
        ``(c_max_used, tail_bound)``. The fastest mode is proven to be inside
        ``region.fixed(c_max_used)`` iff ``tail_bound`` is not ``None`` and below the fastest
        root's ``Re`` there (:func:`proven`). ``tail_bound`` is ``None`` when no bound is
        derived for ``p`` (then ``c_max_used`` is the first rung); at the top rung the tail
        bound may still be too large (not proven: even the tallest box's bound is not below
        the fastest value). A rung whose ``fastest_inside`` raises
        :class:`ContourError` is passed over for the next one (the error is raised only at
        the top rung or for a fixed region; a taller box's is passed over). Where the bound is
        known to be loose
        (:func:`analytic.physics.tail.loose_tail_bound`: ``alpha_pc > 0``, a half-space
        substrate, incommensurate bodies) the climb stops at the current rung, not proven,
        instead of solving a top rung whose bound is not below the fastest value found so far
        (``sweep_k.py --alpha-pc 1``: 22 s without a bound, 498 s climbing to 32 ``c_d`` for
        no proof; ``mu2 = 0.1``, ``rho2 = 1``, ``H2 = 0.5``: 8-16 s a ``k`` instead of 34-48 s).
        The top rung's bound is asked first.

    ``bound(W, target)`` (keyword; default :func:`analytic.physics.tail.tail_bound` at ``k``)
    and ``ladder`` (the rungs in ``region``'s units; default :data:`C_LADDER`) are another
    model's, e.g. a layered slider's (``forms.studies.sweep``): its bound may stop once it is
    known to be below ``target`` or not to get there (``bound(W, None)``: the smallest, asked
    at the top rung when it does not prove, so that the value returned is a bound the sweep's
    overall statement can use), and there are no boxes beyond its top rung. It is not taken
    as loose: the top rung is solved where no rung below proves (its fastest value may be
    larger than the lower rungs': a layered stress top's trapped waves).
    """
    own = bound is None
    ladder = ((region.c_max,) if region.c_max is not None else
              C_LADDER if ladder is None else tuple(ladder))

    def tail_at(c: float, target: float | None) -> float | None:
        w = region.fixed(c).im_max(p, k)
        return tail_bound(p, k, w) if own else bound(w, target)

    i = 0
    while True:
        c = ladder[i]
        try:
            re = fastest_inside(c)
        except ContourError:
            if i == len(ladder) - 1:
                raise
            # a rung whose contour cannot be used (a root on it): the next rung holds it, with
            # its edges elsewhere (tests/test_tail.py)
            i += 1
            continue
        target = re if re is not None else region.re_min
        tb = tail_at(c, target)
        if tb is None or tb < target:
            return c, tb
        if i == len(ladder) - 1:  # the top; a fixed region is never grown
            if not own:  # another model's bound: its smallest value there
                return c, tail_at(c, None)
            return (c, tb) if region.c_max is not None else _taller(p, k, region,
                                                                    fastest_inside, c, tb, target)
        # a loose bound: the rungs up to the top would be solved for nothing (not proven) if
        # even the top rung's bound is not below (asked first: each bound may cost seconds)
        if own and loose_tail_bound(p) and not tail_at(ladder[-1], target) < target:
            return c, tb
        # skip the rungs whose bound is not below the fastest value found so far
        i += 1
        while i < len(ladder) - 1 and not tail_at(ladder[i], target) < target:
            i += 1


def _taller(p: Params, k: float, region: Region, fastest_inside: Callable[[float], float | None],
            c: float, tb: float, target: float) -> tuple[float, float]:
    """:func:`provable_region` beyond the top rung ``c`` (bound ``tb`` not below ``target``).

    The first box of :func:`taller_rungs` whose tail bound is below ``target`` is solved: its
    fastest value is at least ``target`` (it holds the top rung's box), so it proves.
    """
    for cf in taller_rungs(p, k, region):
        tbf = tail_bound(p, k, region.fixed(cf).im_max(p, k))
        if not tbf < target:
            continue
        try:
            fastest_inside(cf)
        except ContourError:
            continue  # a root on its contour: the next taller box
        return cf, tbf
    return c, tb


def proven(tail: float | None, fastest: float | None, region: Region) -> bool:
    """The fastest mode is in the region: ``tail`` below the fastest ``Re`` (or ``re_min``)."""
    target = fastest if fastest is not None else region.re_min
    return tail is not None and tail < target


def nudged_boxes(box: Box) -> list[Box]:
    """The box and slightly moved copies (used when a root sits on an edge)."""
    a, b, c, d = box
    out = [box]
    # moves of 3 % of re_min (at least 3e-4) and 1e-4 of the height: a root closer than that
    # to an edge makes the contour too expensive to resolve (seen at k = 76.5, H = 0.5: a root
    # 1.3e-4 from Re = -0.01); the rectangle actually used is always reported
    # and 30 % for a row of roots along the edge (small k: the n+ branches all sit near
    # Re = -0.01 for the PMMA example of the README)
    for s in (1.0, -1.0, 2.0, -2.0, 10.0, -10.0):
        da = 0.03 * s * (abs(a) if a != 0 else 1e-2)  # never across Re = 0 for re_min > 0
        dw = 1e-4 * s * max(abs(c), abs(d))
        out.append((a - da, b, c - dw, d + dw))
    return out


def on_usable_box(box: Box, k: float, fn: Callable[[Box], T]) -> tuple[T, Box]:
    """``fn(bx)`` on the first of :func:`nudged_boxes` whose contour is usable, and that box.

    Raises:
        ContourError: If ``fn`` raises it on every nudged copy of the box.
    """
    err: ContourError | None = None
    for bx in nudged_boxes(box):
        try:
            return fn(bx), bx
        except ContourError as e:
            err = e
    raise ContourError(f"no usable contour near {box} at k = {k:g}: {err}")


def exact_roots(p: Params, k: float, box: Box) -> tuple[list[Root], Box]:
    """Every exact root in ``box`` at ``k`` (argument principle), and the box actually used.

    Raises:
        ContourError: If no nudged copy of the box gives a usable contour.
    """
    from analytic.numerics.branches import _n_initial, spectrum_function

    fun = spectrum_function(p, float(k))
    return on_usable_box(box, k, lambda bx: zeros_in_box(fun, bx, n_initial=_n_initial(p, bx)))


def in_box(z: complex, box: Box) -> bool:
    """``z`` inside the closed rectangle."""
    return box[0] <= z.real <= box[1] and box[2] <= z.imag <= box[3]


@dataclass
class FamilyPlan:
    """What to follow: waveguide branches and seeded families (cheap to compute, picklable).

    Attributes:
        waveguide: ``(n, sign)`` of the branches followed from their cut-offs.
        seeds: ``(label, Lambda)`` of the other roots at ``k_seed``.
        k_seed: Seed wavenumber.
        seed_box: Rectangle searched at ``k_seed``.
    """

    waveguide: list[tuple[int, int]]
    seeds: list[tuple[str, complex]]
    k_seed: float
    seed_box: Box


def plan_families(p: Params, region: Region, k_max: float, re_floor: float = -3.0
                  ) -> FamilyPlan:
    """Which families can reach the region for ``k <= k_max``.

    Waveguide branches: every cut-off with ``|Im| <= W(k_max)``. Seeds: every root at
    ``k_seed`` in ``re_floor <= Re <= re_max``, ``|Im| <= W(k_max)`` that is not a waveguide
    branch's (those start within ``1e-2`` of their cut-offs there).
    """
    w = region.im_max(p, k_max)
    waveguide = []
    n = 0
    while True:
        lam0 = branch_cutoff(n, 1, p)
        if abs(lam0.imag) > w:
            break
        waveguide += [(n, 1), (n, -1)]
        n += 1
    k_seed = SEED_KH / p.H
    box = (re_floor, region.re_max, -w, w)
    roots, box = exact_roots(p, k_seed, box)
    cut = [branch_cutoff(nn, s, p) for nn, s in waveguide]
    spacing = math.pi / (p.beta * p.H)
    others = [r.value for r in roots
              if not cut or min(abs(r.value - c) for c in cut) > 0.05 * spacing]
    real = sorted([z for z in others if abs(z.imag) <= 1e-3 * max(1.0, abs(z))],
                  key=lambda z: -z.real)
    seeds = [(f"r{i}", z) for i, z in enumerate(real)]
    for sign, tag in ((1, "+"), (-1, "-")):
        side = sorted([z for z in others if sign * z.imag > 1e-3 * max(1.0, abs(z))],
                      key=lambda z: (abs(z.imag), z.real))
        seeds += [(f"s{i}{tag}", z) for i, z in enumerate(side)]
    return FamilyPlan(waveguide, seeds, k_seed, box)


def region_skip(p: Params, region: Region, margin: float = 0.3,
                c_at: Mapping[float, float] | None = None):  # noqa: ANN201
    """A ``skip`` rule for the continuation: the predicted root is far outside the region.

    Far means farther than ``margin`` plus three times the predictor's own uncertainty; a root
    skipped wrongly would show up as an unlabelled root in the region (flagged), never as a
    silent gap. ``c_at`` (requested ``k`` -> bound): the region's box at each ``k`` with its
    own bound (an adaptive region resolved per ``k``) instead of ``region``'s.
    """
    boxes: dict[float, Box] = {}  # per k: the rule is asked at every step of every family

    def skip(k: float, lam: complex, unc: float) -> bool:
        if (a_b_c_d := boxes.get(k)) is None:
            a_b_c_d = boxes[k] = (region if c_at is None else region.fixed(c_at[float(k)])
                                  ).box(p, k)
        a, b, c, d = a_b_c_d
        dist = max(a - lam.real, lam.real - b, c - lam.imag, lam.imag - d, 0.0)
        return dist > margin + 3.0 * unc

    return skip


def follow_family(p: Params, plan: FamilyPlan, item: tuple, ks: np.ndarray,
                  region: Region | None = None, c_at: Mapping[float, float] | None = None
                  ) -> BranchResult:
    """Follow one item of a plan (``("w", n, sign)`` or ``("s", label, Lambda)``) to ``ks``.

    With a ``region``, requested ``k`` where the family is predicted far outside it are skipped
    (see :func:`region_skip`; ``c_at``: the region's bound per requested ``k``).
    """
    return run_steps(follow_family_steps(p, plan, item, ks, region, c_at), branch_answers(p))


def follow_family_steps(p: Params, plan: FamilyPlan, item: tuple, ks: np.ndarray,
                        region: Region | None = None, c_at: Mapping[float, float] | None = None
                        ) -> Steps[BranchResult]:
    """:func:`follow_family` as a step-wise algorithm (:mod:`analytic.numerics.steps`)."""
    skip = region_skip(p, region, c_at=c_at) if region is not None else None
    if item[0] == "w":
        return (yield from follow_branch_steps(p, int(item[1]), int(item[2]), ks, skip=skip))
    return (yield from follow_root_steps(p, str(item[1]), plan.k_seed, complex(item[2]), ks,
                                         skip=skip))


#: Families followed side by side by :func:`follow_many` (their determinant calls answered
#: together): ``det_M`` costs about 3 us a point in calls of 32 points and 0.8 us in calls of
#: 1 000 (stress top, session 37); the stress top's 225 families at the defaults ask for about
#: 30 points a request.
FAMILY_BATCH = 64


def follow_many(p: Params, plan: FamilyPlan, indices: Iterable[int], ks: np.ndarray,
                    region: Region | None = None, c_at: Mapping[float, float] | None = None,
                    width: int = FAMILY_BATCH) -> dict[int, BranchResult]:
    """:func:`follow_family` of the items ``indices`` of the plan, ``width`` side by side.

    The requests of the running families are answered in one vectorised call a round
    (:func:`analytic.numerics.branches.branch_answers_all`): the same continuations and checks
    as one by one, the determinant to rounding. ``indices`` is read lazily (a rank may claim
    them as it gets free).

    Returns:
        ``{index: BranchResult}``.
    """
    items = plan_items(plan)
    return run_many(((i, follow_family_steps(p, plan, items[i], ks, region, c_at))
                     for i in indices), branch_answers_all(p), width)


def plan_items(plan: FamilyPlan) -> list[tuple]:
    """The plan as a flat list of items for :func:`follow_family` (waveguide first)."""
    return [("w", n, s) for n, s in plan.waveguide] + [("s", lab, z) for lab, z in plan.seeds]


def families(p: Params, region: Region, ks: np.ndarray) -> list[BranchResult]:
    """Every family that can reach the region, followed to ``ks`` (serial; see the sweep)."""
    ks = np.unique(np.asarray(ks, dtype=float))
    plan = plan_families(p, region, float(ks[-1]))
    done = follow_many(p, plan, range(len(plan_items(plan))), ks, region)
    return [done[i] for i in range(len(done))]


@dataclass
class Labelled:
    """An exact root in the region with its label.

    Attributes:
        value: The exact root.
        label: Family label (``"?i"`` if no followed family reaches it).
        certified: The family was followed to this ``k`` without doubt, and exactly one
            family claims this root.
        note: Why not certified ("" if certified).
    """

    value: complex
    label: str
    certified: bool
    note: str


def _index_at(f: BranchResult, k: float) -> int | None:
    """Index of the requested ``k`` in ``f`` if the family has a value there, else ``None``."""
    i = int(np.searchsorted(f.k, k))
    return i if i < len(f.k) and f.k[i] == k and np.isfinite(f.Lambda[i]) else None


def _labelled(f: BranchResult, i: int, value: complex | None = None) -> Labelled:
    """The root of family ``f`` at its ``i``-th requested ``k`` (or ``value``), labelled."""
    z = complex(f.Lambda[i]) if value is None else value
    return Labelled(z, f.label, bool(f.ok[i]), "" if f.ok[i] else f.flag[i])


def label_roots(roots: list[Root], fams: list[BranchResult], k: float,
                p: Params | None = None) -> list[Labelled]:
    """Give every exact root the label of the family whose continued value it is.

    A root is claimed by a family when they agree to :data:`SAME_ROOT_RTOL`; a root claimed
    by two families, or by none, is not certified (``"?"`` labels for the latter). With ``p``,
    the roots no family reaches are traced back (:func:`trace_families`) first.
    """
    out = []
    unl = 0
    at_k = [(f, i) for f in fams for i in [_index_at(f, k)] if i is not None]
    claims = [[(f, i) for f, i in at_k
               if abs(f.Lambda[i] - r.value) <= SAME_ROOT_RTOL * max(1.0, abs(r.value))]
              for r in roots]
    unclaimed = [j for j, c in enumerate(claims) if not c]
    traced = (trace_families(p, k, [roots[j].value for j in unclaimed], fams)
              if p is not None and unclaimed else [None] * len(unclaimed))
    back = dict(zip(unclaimed, traced, strict=True))
    for j, r in enumerate(roots):
        z = r.value
        if len(claims[j]) == 1:
            out.append(_labelled(*claims[j][0], value=z))
        elif back.get(j) is not None:
            out.append(replace(back[j], value=z))
        elif not claims[j]:
            out.append(Labelled(z, f"?{unl}", False, "no followed family reaches this root"))
            unl += 1
        else:
            labs = "+".join(f.label for f, _ in claims[j])
            out.append(Labelled(z, labs, False, f"claimed by {len(claims[j])} families"))
    return out


def _start_of(f: BranchResult) -> tuple[float, complex] | None:
    """A family's first polished root ``(k, Lambda)``: its path's second point.

    The first is the cut-off at ``k = 0`` of a waveguide branch, or the secant point below a
    seed.
    """
    return ((float(f.k_path[1]), complex(f.Lambda_path[1])) if len(f.k_path) >= 2
            and np.isfinite(f.Lambda_path[1]) else None)


def trace_families(p: Params, k: float, values: Sequence[complex], fams: list[BranchResult]
                   ) -> list[Labelled | None]:
    """The family of each root ``values`` at ``k`` that no followed family reached, by tracing.

    A family is skipped at a requested ``k`` where the secant from its last point predicts it
    far outside the region (:func:`region_skip`); a lone ``k`` far from the seeds (the stress
    top at ``k = 26.5``: families at ``Re = -0.69`` from ``k = 0.04`` to 14 rise through a
    trapped-wave bump to ``Re = 0.24`` near ``k = 24``) is then reached by none. Each root is
    continued down in ``k`` (:func:`analytic.numerics.branches.trace_back_steps`, side by
    side) to every family's start (:func:`_start_of`); the family whose start it reaches (to
    :data:`SAME_ROOT_RTOL`), if exactly one, labels it, certified when no step was ambiguous
    and that family does not reach another root at ``k``.

    Returns:
        Per root, its :class:`Labelled` (value: the root at ``k``) or ``None`` (no single family).
    """
    starts = [(f, s) for f in fams for s in [_start_of(f)] if s is not None and s[0] < k]
    ks = sorted({s[0] for _, s in starts})
    if not ks or not values:
        return [None] * len(values)
    got = run_many(((j, trace_back_steps(p, float(k), z, ks)) for j, z in enumerate(values)),
                   branch_answers_all(p))
    out: list[Labelled | None] = []
    for j, z in enumerate(values):
        vals, flags = got[j]
        at = dict(zip(ks, zip(vals, flags, strict=True), strict=True))
        hit = [(f, at[s[0]][1]) for f, s in starts
               if abs(at[s[0]][0] - s[1]) <= SAME_ROOT_RTOL * max(1.0, abs(s[1]))]
        if len(hit) != 1:
            out.append(None)
            continue
        f, flag = hit[0]
        if _index_at(f, k) is not None:  # the family reaches another root here: one is wrong
            flag = flag or f"{f.label} itself reaches another root at this k"
        note = f"traced back to {f.label}'s start with doubt ({flag})" if flag else ""
        out.append(Labelled(complex(z), f.label, not flag, note))
    return out


def certified_roots(p: Params, k: float, region: Region, fams: list[BranchResult]
                    ) -> tuple[list[Labelled], Box, int]:
    """Every exact root in the region at ``k``, labelled; the box used; the exact count.

    The count is the argument principle on ``det_M``. When the followed families' values inside
    the box are as many as the count (and distinct), they *are* the roots; otherwise the box is
    searched (:func:`analytic.numerics.roots.zeros_in_box`) and the roots no family claims get
    ``"?"``
    labels.

    Raises:
        ContourError: If no nudged copy of the box gives a usable contour.
    """
    from analytic.numerics.branches import _n_initial, spectrum_function
    from analytic.numerics.roots import count_zeros

    fun = spectrum_function(p, float(k))
    n, bx = on_usable_box(region.box(p, k), k,
                          lambda b: count_zeros(fun, b, n_initial=_n_initial(p, b)))
    cand = [(f, i) for f in fams for i in [_index_at(f, k)]
            if i is not None and in_box(f.Lambda[i], bx)]
    vals = np.array([f.Lambda[i] for f, i in cand], dtype=complex)
    distinct = all(abs(vals[a] - vals[b]) > SAME_ROOT_RTOL * max(1.0, abs(vals[a]))
                   for a in range(len(vals)) for b in range(a))
    if len(cand) == n and distinct:
        out = [_labelled(f, i) for f, i in cand]
    else:
        roots = zeros_in_box(fun, bx, n_initial=_n_initial(p, bx))
        out = label_roots(roots, fams, k, p)
    return sorted(out, key=lambda r: (-r.value.real, r.value.imag)), bx, n


@dataclass
class FastestMode:
    """The fastest-growing exact root at one ``k`` and what proves it is the fastest.

    Attributes:
        root: The root (``None``: the region holds none).
        count: Roots in the region (argument principle; with ``whole = False`` only the roots
            of the bands counted: ``>= 1`` exactly when the region holds a root).
        box: The rectangle actually used.
        c_max: The phase-velocity bound used (:func:`provable_region`).
        tail_bound: Bound on ``Re Lambda`` beyond the region (``None``: none derived).
        proven: ``tail_bound`` is below ``root``'s growth rate (or ``re_min``): no root outside
            the region grows faster.
        located: The roots located in the first rung's fastest band (``root`` among them):
            starts for the next ``k`` (:func:`fastest_in_box`, ``starts``).
    """

    root: complex | None
    count: int
    box: Box
    c_max: float
    tail_bound: float | None
    proven: bool
    located: tuple[complex, ...] = ()


#: The fastest-first search locates every root of a box holding at most this many; otherwise it
#: narrows a band ``lo <= Re <= re_max`` until the band holds at most :data:`BAND_ROOTS`.
LOCATE_ALL = 4
#: See :data:`LOCATE_ALL`.
BAND_ROOTS = 2


#: Half-width of the band tried first around a hint (:func:`fastest_in_box`), relative.
HINT_WIDTH = 0.02


#: Width of the band left of the fastest root reached from starts (:func:`_band_from_starts`),
#: relative to its ``Re`` (at least :data:`START_FLOOR`).
START_WIDTH = 0.02
#: See :data:`START_WIDTH`.
START_FLOOR = 1e-3


def _band_from_starts(p: Params, fun: Callable, box: Box, starts: Sequence[complex]
                      ) -> tuple[complex, float, int, tuple[complex, ...]] | None:
    """The fastest root reached from Newton's ``starts`` and the count of a band left of it.

    ``fun``: the spectrum function at this ``k`` (:func:`fastest_in_box`'s). The starts are
    polished (:func:`analytic.numerics.roots.zeros_reached`); with ``z`` the
    fastest root reached, the band ``lo <= Re <= re_max`` of ``box``, ``lo = Re z - START_WIDTH
    max(|Re z|, START_FLOOR)`` (not below the box), is counted. When it holds exactly the
    roots reached in it, those are all its roots and ``z`` is the box's fastest (every root
    faster than ``lo`` is in the band).

    Returns:
        ``(z, lo, the band's count, the roots reached in the band)``; ``None``: no root
        reached, or the band's contour unusable.
    """
    from analytic.numerics.roots import zeros_reached

    reached = [complex(r.value) for r in zeros_reached(fun, box, starts)]
    if not reached:
        return None
    z = max(reached, key=lambda w: w.real)
    lo = _left_edge(box, z)
    m = _count_band(p, fun, box, lo)
    if m is None:
        return None
    return z, lo, m, tuple(w for w in reached if w.real >= lo)


def _left_edge(box: Box, z: complex) -> float:
    """``Re z - START_WIDTH max(|Re z|, START_FLOOR)``, not below ``box``: the band's left edge."""
    return max(box[0], z.real - START_WIDTH * max(abs(z.real), START_FLOOR))


def _count_band(p: Params, fun: Callable, box: Box, lo: float) -> int | None:
    """The count of the band ``lo <= Re <= re_max`` of ``box``; ``None``: contour unusable."""
    from analytic.numerics.branches import _n_initial
    from analytic.numerics.roots import count_zeros

    band = (lo, box[1], box[2], box[3])
    try:
        return count_zeros(fun, band, n_initial=_n_initial(p, band))
    except ContourError:
        return None


#: Newton starts :func:`_second_chance` tries at most (each about 0.5 ms; the band's search it
#: spares took 60 ms on average in the stress 5 x 5 map; 12, 20, 40 guesses gave the same CPU
#: time there, 20 the fewest ``det_M`` points but for 40).
SECOND_CHANCE_GUESSES = 20
#: Newton iterations per guess of :func:`_second_chance` (a guess that has not converged by
#: then is not near a root; most converge in 4-8).
GUESS_ITERATIONS = 15


def _second_chance(p: Params, fun: Callable, box: Box,
                   known: tuple[complex, float, int, tuple[complex, ...]]
                   ) -> tuple[complex, float, int, tuple[complex, ...]]:
    """:func:`_band_from_starts`'s result after Newton from guesses made of the roots reached.

    Called when the band ``lo <= Re <= re_max`` holds more roots than the starts reached. The
    guesses, in rounds while new roots turn up: the two lowest dilatational thickness
    resonances ``+-(n + 1/2) pi / (beta H)`` at the fastest root's ``Re`` (first round only);
    for each root reached, its mirror ``conj(z)`` (the mode travelling the other way) and the
    root moved by one and two resonance spacings ``pi / (beta H)`` in ``Im``; the spacing of
    neighbouring roots on one side continued (a chain of trapped-wave resonances). Session 25's
    profile of the stress 5 x 5 map: 132 of 625 bands held more roots than the starts reached,
    121 of them a root faster than every one reached (the next member of a chain, the other
    way, the first resonance); these guesses reach all of the band's roots in 72 of the 132,
    whose search (a scan and bisections, 60 ms each on average) is then not made. Only roots
    inside the band are kept, distinct from those already reached; the band and its count are
    unchanged, so when the roots reached number the count, they are all the band's roots and
    the fastest of them is the box's fastest (the same proof). Otherwise the caller searches
    the band as before, with these roots among its starts.
    """
    from analytic.numerics.roots import zeros_reached

    z, lo, m, inside = known
    band = (lo, box[1], box[2], box[3])
    step = math.pi / (p.beta * p.H) if math.isfinite(p.H) and p.H > 0 else 0.0
    found, new, seen = list(inside), list(inside), []
    # the lowest thickness resonances, (n + 1/2) pi / (beta H), either way (the 0+/0- pair)
    first = [complex(z.real, s * (n + 0.5) * step) for n in (0, 1) for s in (1, -1)] \
        if step > 0 else []
    while new and len(found) < m and len(seen) < SECOND_CHANCE_GUESSES:
        guesses, first = first, []
        for w in new:
            guesses.append(w.conjugate())
            if step > 0:
                guesses += [complex(w.real, w.imag + s * n * step) for n in (2, 1) for s in (1, -1)]
        # the spacing of the found roots along Im, continued (a chain of resonances)
        ims = sorted(found, key=lambda w: w.imag)
        for a, b in zip(ims[:-1], ims[1:], strict=True):
            if a.imag * b.imag > 0:
                guesses += [b + (b - a), a - (b - a)]
        guesses = [g for g in guesses
                   if all(abs(g - q) > 1e-6 * max(1.0, abs(g)) for q in [*found, *seen])]
        guesses = guesses[:SECOND_CHANCE_GUESSES - len(seen)]
        seen += guesses
        new = []
        for r in zeros_reached(fun, band, guesses, maxiter=GUESS_ITERATIONS):
            w = complex(r.value)
            if all(abs(w - q) > 1e-9 * max(1.0, abs(w)) for q in found):
                found.append(w)
                new.append(w)
    best = max(found, key=lambda w: w.real)
    return best, lo, m, tuple(found)


def _narrower_band(p: Params, fun: Callable, box: Box,
                   known: tuple[complex, float, int, tuple[complex, ...]]
                   ) -> tuple[complex, float, int, tuple[complex, ...]]:
    """:func:`_band_from_starts`'s band moved up to the fastest root reached so far.

    After :func:`_second_chance` the fastest root reached may lie well right of the band's left
    edge, and the roots still unreached may all be slower than it: the band ``lo' <= Re <=
    re_max`` left of it (the rule of :func:`_band_from_starts`) is counted, one count; it holds
    every root faster than ``lo'``, so when the roots reached in it number its count the
    fastest of them is the box's fastest, and otherwise the band's search is made in this
    narrower band (fewer roots to locate). Unchanged when ``lo'`` is not right of the band's
    edge or its contour is not usable.
    """
    z, lo, _, found = known
    lo2 = _left_edge(box, z)
    m = _count_band(p, fun, box, lo2) if lo2 > lo else None
    if m is None:
        return known
    return z, lo2, m, tuple(w for w in found if w.real >= lo2)


def _band_known(p: Params, fun: Callable, box: Box, starts: Sequence[complex]
                ) -> tuple[complex, float, int, tuple[complex, ...]] | None:
    """The band of the starts (:func:`_band_from_starts`), completed where it can be.

    While the band holds more roots than were reached: :func:`_second_chance`, then
    :func:`_narrower_band`.
    """
    known = _band_from_starts(p, fun, box, starts)
    if known is not None and known[2] > len(known[3]):
        known = _second_chance(p, fun, box, known)
        if known[2] > len(known[3]):
            known = _narrower_band(p, fun, box, known)
    return known


def fastest_in_box(p: Params, k: float, box: Box, hint: float | None = None,
                   starts: Sequence[complex] = (), *, whole: bool = True
                   ) -> tuple[complex | None, int, tuple[complex, ...]]:
    """The fastest exact root in ``box`` and the box's count, locating as few roots as possible.

    One argument-principle count of the whole box (the count reported). Up to
    :data:`LOCATE_ALL` roots: all located (:func:`analytic.numerics.roots.zeros_in_box`).
    More: bisection of a band ``lo <= Re <= re_max`` (one count each) until it holds at most
    :data:`BAND_ROOTS` roots, and only that band's roots located; the band holds the fastest
    root by construction (``count(lo..re_max) >= 1``). Locating and polishing every root of a
    tall box costs most of the time at large ``k`` (18 roots at ``k = 20``).
    tests/test_spectrum_fastest.py checks it against every root of the box.

    ``hint`` (a guess of the fastest ``Re``, e.g. the fastest root at a neighbouring ``k``):
    the bisection first cuts at ``hint (1 +- HINT_WIDTH)`` (``+- HINT_WIDTH`` near 0), so a good
    guess brackets the band in two counts instead of about ten; the invariant and so the root
    found are the same whatever the guess (a bad one costs two counts). ``starts`` (guesses of
    the roots, e.g. the last ``k``'s located roots moved to this ``k``): Newton's first starts
    in the band (:func:`analytic.numerics.roots.zeros_from_starts`); when they reach all its roots,
    the band is not scanned (the same roots: the band's count decides).

    ``whole = False`` (only the fastest root is wanted, and whether there is one): the starts
    are polished first and one count of a narrow band left of the fastest root reached proves
    it the fastest when that band holds only roots reached (:func:`_band_from_starts`);
    when it holds more, the search above continues in that band instead of the box. The
    count returned is then the band's (``>= 1``), not the box's. Without starts, or when none
    converges, the search above (a zero count is always the whole box's).

    Returns:
        ``(root, count, located)``: ``root`` is ``None`` when the count is 0; ``located``: the
        band's roots.

    Raises:
        ContourError: The box's contour is not usable (the caller nudges it:
            :func:`on_usable_box`), or no cut of a band is.
    """
    from analytic.numerics.branches import _n_initial, spectrum_function
    from analytic.numerics.roots import count_zeros, zeros_from_starts

    fun = spectrum_function(p, float(k))
    n_init = _n_initial(p, box)

    def band(a: float) -> Box:
        return (a, box[1], box[2], box[3])

    known = _band_known(p, fun, box, starts) if not whole and starts else None
    if known is not None and known[2] >= len(known[3]):
        z, lo, n, inside = known
        if n == len(inside):
            return z, n, inside
        starts = [*inside, *starts]  # the band's count is the one reported
    else:
        n = count_zeros(fun, box, n_initial=n_init)
        if n == 0:
            return None, 0, ()
        lo = box[0]
    up, n_lo = box[1], n  # count(lo..re_max) = n_lo >= 1, count(up..re_max) = 0
    first: list[float] = []
    if hint is not None and math.isfinite(hint) and n > LOCATE_ALL:
        width = HINT_WIDTH * max(abs(hint), 1.0)
        first = [hint + width, hint - width]
    while n > LOCATE_ALL and n_lo > BAND_ROOTS and up - lo > 1e-6 * max(1.0, abs(up)):
        cuts = [c for c in first[:1] if lo < c < up]
        first = first[1:]
        cuts += [lo + frac * (up - lo)  # off a root sitting on the cut
                 for frac in (0.5, 0.4617, 0.5383, 0.4209, 0.5791)]
        for mid in cuts:
            try:
                m = count_zeros(fun, band(mid), n_initial=n_init)
                break
            except ContourError as e:
                err = e
        else:
            raise ContourError(f"no usable cut of the band {band(lo)} at k = {k:g}: {err}")
        lo, n_lo, up = (mid, m, up) if m >= 1 else (lo, n_lo, mid)
    roots = zeros_from_starts(fun, band(lo), n_lo, starts) if starts else None
    if roots is None:
        roots = zeros_in_box(fun, band(lo), n_initial=n_init, total=n_lo)
    best = max(roots, key=lambda r: r.value.real)
    return complex(best.value), n, tuple(complex(r.value) for r in roots)


def _fastest_in(p: Params, k: float, region: Region, hint: float | None = None,
                starts: Sequence[complex] = (), whole: bool = True
                ) -> tuple[complex | None, int, Box, tuple[complex, ...]]:
    (z, n, located), bx = on_usable_box(
        region.box(p, k), k, lambda b: fastest_in_box(p, k, b, hint, starts, whole=whole))
    if bx[0] >= region.re_min or n == 0:
        return z, n, bx, located
    # a box nudged below re_min: report the region's roots only (every root located)
    roots, bx = exact_roots(p, k, bx)
    roots = [r for r in roots if r.value.real >= region.re_min]
    if not roots:
        return None, 0, bx, ()
    best = max(roots, key=lambda r: r.value.real)
    return complex(best.value), len(roots), bx, tuple(complex(r.value) for r in roots)


def fastest_mode(p: Params, k: float, region: Region, hint: float | None = None,
                 starts: Sequence[complex] = (), *, whole: bool = True) -> FastestMode:
    """The fastest-growing exact root at ``k`` with the region of :func:`provable_region`.

    ``hint``: a guess of its ``Re``; ``starts``: guesses of the roots near it
    (:func:`fastest_in_box`; the same root, fewer counts and scans). ``whole = False``: the
    same root and proof, but ``count`` only the roots of the bands counted (``>= 1`` exactly
    when the region holds a root; a zero is the whole region's count): the starts may prove
    the fastest root with one count of a narrow band, and the final region is not counted.

    For a fixed ``region.c_max`` the region is used as it is (the tail bound is still reported).
    An adaptive region is searched incrementally: every root of the first rung, then for each
    larger rung only the two bands ``W_prev < |Im| < W`` at ``Re >=`` the fastest value so far
    (one contour when they hold nothing faster); the count is one argument principle on the
    final region. A rung whose contour is unusable is passed over for the next one (see
    :func:`provable_region`; also when the final count fails).

    Raises:
        ContourError: If no nudged copy of a box gives a usable contour.
    """
    from analytic.numerics.branches import _n_initial, spectrum_function
    from analytic.numerics.roots import count_zeros

    fun = spectrum_function(p, float(k))
    state: dict = {"z": None, "w": None, "n": 0, "box": None, "located": (), "more": 0}

    def inside(c: float) -> float | None:
        w = region.fixed(c).im_max(p, k)
        if state["w"] is None:
            state["z"], state["n"], state["box"], state["located"] = _fastest_in(
                p, k, region.fixed(c), hint, starts, whole)
        else:
            z = state["z"]
            lo = region.re_min if z is None else max(region.re_min, z.real)
            for band in ((lo, region.re_max, state["w"], w), (lo, region.re_max, -w, -state["w"])):
                roots, _ = on_usable_box(band, k, lambda b: zeros_in_box(
                    fun, b, n_initial=_n_initial(p, b)))
                # the roots of the band as asked (a nudged copy may reach into the last rung)
                state["more"] += sum(in_box(complex(r.value), band) for r in roots)
                for r in roots:
                    if r.value.real >= lo and (state["z"] is None
                                               or r.value.real > state["z"].real):
                        state["z"] = complex(r.value)
            state["box"] = None  # counted at the end
        state["w"] = w
        return None if state["z"] is None else state["z"].real

    c, tail = provable_region(p, k, region, inside)
    n, bx = state["n"], state["box"]
    if not whole and bx is None:  # not recounted: the first rung's and the new bands' roots
        n, bx = n + state["more"], region.fixed(c).box(p, k)
    while bx is None:
        try:
            n, bx = on_usable_box(region.fixed(c).box(p, k), k,
                                  lambda b: count_zeros(fun, b, n_initial=_n_initial(p, b)))
        except ContourError:
            # the accepted rung's contour is unusable (a root on it): the next rung holds the
            # same proof (a smaller tail bound), searched in its new bands and counted with
            # its edges elsewhere
            if region.c_max is not None:
                raise
            above = [r for r in C_LADDER + taller_rungs(p, k, region) if r > c]
            if not above:
                raise
            c = above[0]
            inside(c)
            tail = tail_bound(p, k, region.fixed(c).im_max(p, k))
    z = state["z"]
    return FastestMode(z, n, bx, c, tail, proven(tail, None if z is None else z.real, region),
                       state["located"])


def fastest_root(p: Params, k: float, region: Region) -> tuple[complex | None, int, Box]:
    """The fastest-growing exact root in the region at ``k`` (no labels): ``(root, count, box)``.

    ``root`` is ``None`` when the region holds no root. The count is the argument principle's,
    so the maximum is over *every* root in the region. An adaptive region (``c_max = None``)
    is resolved by :func:`provable_region` (see :func:`fastest_mode` for the proof's data).
    """
    m = fastest_mode(p, k, region)
    return m.root, m.count, m.box


#: Resolution of :func:`family_peak` in ``k``, relative to ``hi``: ``Re Lambda`` at the peak
#: is then right to about ``(PEAK_XTOL)^2`` relative (a smooth maximum), below rounding.
PEAK_XTOL = 1e-8


def family_peak(p: Params, k0: float, z0: complex, lo: float, hi: float, *,
                dk: float = 0.05) -> tuple[float, complex]:
    """Largest ``Re Lambda`` of the root family through ``(k0, z0)`` for ``k`` in ``[lo, hi]``.

    :func:`peak_along` with a polish of ``det_M``'s root as its step (the family's growth rate
    is smooth, unlike the envelope, which jumps between families). Starting each evaluation
    from the nearest point instead of ``k0``: 1-2 polishes per evaluation once the search
    narrows. Measured on the stress 5 x 5 map: 597 evaluations for 50 peaks (about 12 each)
    where the golden section alone took 2 100 (42).

    Returns:
        ``(k, Lambda)`` at the largest value evaluated.
    """
    from analytic.numerics.branches import polish_root

    evaluated = peak_along(lambda k, guess, _: (polish_root(p, k, guess).value, None),
                           k0, (complex(z0), None), lo, hi, dk)
    k = max(evaluated, key=lambda q: evaluated[q].real)
    return k, evaluated[k]


def peak_along(step: Callable[[float, complex, Any], tuple[complex, Any] | None], k0: float,
               start: tuple[complex, Any], lo: float, hi: float, dk: float
               ) -> dict[float, complex]:
    """Brent's bounded search on ``k`` for the largest ``Re Lambda`` of one mode in ``[lo, hi]``.

    Golden section and parabolic steps (``scipy.optimize.minimize_scalar``, to
    :data:`PEAK_XTOL` ``hi``); the mode at each ``k`` is reached by ``step`` in steps of at
    most ``dk`` from the nearest ``k`` already reached (``k0`` with ``start``, or an earlier
    evaluation, each itself reached from ``k0`` that way). The exact roots'
    (:func:`family_peak`) and the finite elements' (``forms.studies.peaks``) searches.

    Args:
        step: ``(k, guess, state) -> (Lambda, state)`` at ``k`` from the predictor ``guess``
            and the ``state`` of the point it starts from (e.g. an eigenvector), or ``None``
            if it failed: the evaluation then tells the search ``-inf``.
        k0: Where the mode is known.
        start: Its ``(Lambda, state)`` there.
        lo: Left end of the interval.
        hi: Right end.
        dk: Largest step.

    Returns:
        ``{k: Lambda}`` of every evaluation that reached its ``k``.
    """
    from scipy.optimize import minimize_scalar

    reached: dict[float, tuple[complex, Any]] = {float(k0): start}
    evaluated: dict[float, complex] = {}

    def loss(k: float) -> float:
        k = float(k)
        ks = min(reached, key=lambda q: abs(q - k))
        z, state = reached[ks]
        n = max(1, int(math.ceil(abs(k - ks) / dk)))
        h = (k - ks) / n
        # the nearest other point within dk of ks gives the mode's slope: the first start is
        # on its secant, each later one on the secant of the last two steps
        near = min((q for q in reached if q != ks), key=lambda q: abs(q - ks), default=None)
        slope = (z - reached[near][0]) / (ks - near) \
            if near is not None and abs(near - ks) <= dk else 0.0
        for i in range(1, n + 1):
            got = step(ks + h * i, z + slope * h, state)
            if got is None:
                return math.inf
            w, state = got
            slope, z = (w - z) / h, w
        reached[k] = (z, state)
        evaluated[k] = z
        return -z.real

    minimize_scalar(loss, bounds=(lo, hi), method="bounded",
                    options={"xatol": PEAK_XTOL * abs(hi)})
    return evaluated
