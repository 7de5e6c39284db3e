"""The certified dispersion sweep over many ``k``, shared over MPI ranks (``workflows/sweep_k.py``).

docs/design.md section 8. The steps of a sweep, each a call of the scene:

1. the scene's saved results (one per requested ``k``, kept as soon as it is finished) tell
   which ``k`` are still to compute, so that a resumed sweep continues where it stopped;
1b. :func:`region_at_k` (adaptive region, ``c_max = None``): at each ``k`` the phase-velocity
   bound that provably holds the fastest mode (:func:`analytic.numerics.spectrum.fastest_mode`,
   exact roots); the region holding all of them (:func:`largest_region`) sets the family plan;
2. :func:`family_plan` and :func:`follow_families` (only when the exact roots are checked,
   ``--check-exact yes``): every root family that can reach the region is followed in ``k`` by
   exact continuation; the families are shared over the ranks and gathered on all of them;
3. :func:`k_costs` and :func:`solve_k_values`: each rank solves its share of the pending ``k``
   with one :class:`forms.solvers.certified.CertifiedSolver` (its models live on ``COMM_SELF``;
   FE first by default) and hands each :class:`forms.solvers.certified.KResult` to the scene
   to keep (:func:`k_result_from_json` reads one back);
4. :func:`summarise` (rank 0): the rows of every ``k`` and the summary:
   certificate (counts closed, rows ok or flagged), accuracy, families, the most unstable
   eigenvalue with its certificate, per-``k`` counts and costs.

Sharing work over the ranks is left to the caller: the functions take this rank's indices
(for instance a cost-balanced split of :func:`k_costs`), so no rule for it lives here.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from analytic.numerics.branches import BranchResult
from analytic.numerics.roots import ContourError
from analytic.numerics.spectrum import (
    C_LADDER,
    FamilyPlan,
    Region,
    fastest_mode,
    follow_many,
    plan_families,
    plan_items,
    provable_region,
)
from analytic.params import ParameterError, Params
from analytic.physics.layered_exact import ExactLayer
from analytic.physics.tail import SCALE_CAP, tail_bound, velocity_scale, why_no_tail_bound
from analytic.physics.tail_layers import NO_BOUND_GRADED, layered_bound, why_no_layered_bound
from forms.models.profiles import SliderMaterial
from forms.solvers.certified import (
    CertifiedSolver,
    KResult,
    continue_fe,
    default_discretisation,
    substrate_cells,
)

#: What ``summary.json`` says the certificate of the most unstable eigenvalue states, per mode
#: ``(solver, check_exact)``.
CERTIFICATE_STATEMENTS = {
    True: ("largest Re Lambda over every eigenvalue in the region R at every swept k; at each k "
           "the FE eigenvalues found in R are as many as, and distinct, the FE argument-principle"
           " count of det T_h in R, which equals the exact argument-principle count, and every "
           "FE value is matched to a distinct exact root"),
    False: ("largest Re Lambda over every eigenvalue in the region R at every swept k; at each k "
            "the FE eigenvalues found in R are as many as, and distinct, the FE "
            "argument-principle count of det T_h in R (no exact reference consulted)"),
}
#: How the sweep's values are obtained (``summary.json``, key ``method``), per ``--solver``.
METHODS = {
    "linear": ("FE first: argument-principle count of det T_h in R; predictors from one dense "
               "linear eigenproblem of the condensed form (near modes and the interface rows), "
               "Newton-polished, contour-integral moments (Beyn) where they do not give the "
               "count; no exact root as input"),
    "moments": ("FE first: argument-principle count of det T_h in R and contour-integral moments"
                " (Beyn) on the same contour points, Newton-polished; no exact root as input"),
    "newton": ("exact continuation labels; FE Newton on the discrete NEP from the exact roots; "
               "FE and exact argument-principle counts in R"),
}
#: What ``most_unstable.certificate.fastest_mode`` states.
FASTEST_STATEMENT = (
    "at every swept k, every root outside R (|Im Lambda| > W(k)) has Re Lambda below the tail "
    "bound (analytic.physics.tail; a layered slider's analytic.physics.tail_layers; "
    "docs/design.md 8.1), and the largest tail bound is below the most unstable value: no mode "
    "outside R grows faster")
#: Flagged rows listed in the summary at most (all of them are in the CSV).
MAX_FLAGGED_LISTED = 200
#: Why a layered slider on a deformable substrate has no tail bound (``summary.json``).
LAYERED_TWO_BODY = (
    "no tail bound derived for layers on a deformable substrate (analytic.physics.tail_layers "
    "takes a rigid one): the region R is the box used at each k, not proven to hold the "
    "fastest mode")
#: How rows are labelled with ``track=True`` (``summary.json``, key ``labels``).
TRACK_STATEMENT = (
    "c0, c1, ...: continuation of the FE eigenpairs in k; each row at k_i is followed by Newton "
    "on the discrete NEP (eigenvector kept, secant predictor, 4 sub-steps) to k_(i+1) and "
    "linked to the row there that is the mutually nearest one and within 1e-6 relative; a row "
    "without such a link starts a new label (numbered by first appearance, then |Im Lambda|)")
#: Why a layered sweep's region is not proven with ``--layers-bound no``.
LAYERED_NOT_ASKED = (
    "the layers' tail bound was turned off (sweep_k.py --layers-bound no; the default asks for "
    "it: analytic.physics.tail_layers, constant layers on a rigid substrate, two at most when "
    "their phase rates are not commensurate; the region then climbs): the region R is its "
    "first rung at each k, not proven to hold the fastest mode")
#: The scene's one-line note for a layered/graded slider (stderr).
LAYERED_NOTE = ("note: several layers or profiles: FE only (--check-exact no), certificate 'fe'; "
                "the region climbs at each k until the layers' tail bound is below the fastest "
                "value (where a bound is derived, unless --layers-bound no; else its first "
                "rung, not proven to hold the fastest mode: summary.json)")
#: Sub-steps of the continuation from one swept ``k`` to the next (``track=True``).
TRACK_SUBSTEPS = 4
#: Largest relative gap between a continued value and the row it is linked to.
TRACK_LINK_RTOL = 1e-6


def slider_velocity_scale(params: Params, material: SliderMaterial) -> float:
    """The largest dilatational wave speed of a layered/graded stack (units of ``mu = rho = 1``).

    ``sqrt(mu/rho)/beta`` over every layer (a profiled coefficient at 2001 points of its layer);
    with a deformable substrate also its ``c_d2``, capped at
    :data:`analytic.physics.tail.SCALE_CAP` times the slider's (the rule of
    :func:`analytic.physics.tail.velocity_scale`).
    """
    prof, below, c = dict(material.profiles), 0.0, 0.0
    for row in material.layer_rows(params.H, params.beta):
        y = np.linspace(below, row.y_top, 2001)
        mu, rho, beta = (prof[n](y) if n in prof else np.full_like(y, getattr(row, n))
                         for n in ("mu", "rho", "beta"))
        c, below = max(c, float(np.max(np.sqrt(mu / rho) / beta))), row.y_top
    if params.two_body:
        c2 = math.sqrt(params.mu2 / params.rho2) / params.substrate_beta
        c = min(max(c, c2), SCALE_CAP * c)
    return c


def layered_region(params: Params, material: SliderMaterial, region: Region) -> Region:
    """``region`` for a layered slider: phase velocities in units of its largest ``c_d``.

    :class:`analytic.numerics.spectrum.Region` scales ``c_max`` by the homogeneous slider's
    :func:`analytic.physics.tail.velocity_scale` of ``params``; the copy returned has ``c_max``
    (``None``, adaptive, is its first rung :data:`analytic.numerics.spectrum.C_LADDER` ``[0]``,
    from which the climb of :func:`climb` with :func:`layered_tail` starts, where a bound is
    derived and asked for) rescaled so that ``im_max = c_max k c_d,max + omega0``, ``c_d,max`` of
    :func:`slider_velocity_scale`, and
    ``omega0`` (unless given) ``2 pi c_d,max / H`` with ``H`` the slider's height.
    """
    c = slider_velocity_scale(params, material)
    c_max = C_LADDER[0] if region.c_max is None else region.c_max
    height = material.layer_rows(params.H, params.beta)[-1].y_top
    omega0 = region.omega0 if region.omega0 is not None else 2.0 * math.pi * c / height
    return Region(region.re_min, region.re_max, c_max * c / velocity_scale(params), omega0)


@dataclass(frozen=True)
class LayeredTail:
    """A layered slider's adaptive region: its rungs and its tail bound (:func:`climb`).

    Attributes:
        params: The slider's parameters (``H``: its height).
        layers: Its constant layers (:func:`analytic.physics.tail_layers.layered_bound`).
        ladder: The rungs in the region's units (:func:`layered_region`: :data:`C_LADDER`
            times the stack's largest ``c_d`` over ``velocity_scale(params)``; one rung for a
            fixed ``--c-max``).
    """

    params: Params
    layers: tuple[ExactLayer, ...]
    ladder: tuple[float, ...]

    def bound(self, k: float) -> Callable[[float, float], float | None]:
        """The bound at ``k`` as :func:`analytic.numerics.spectrum.provable_region` asks it.

        A climb asks the rung it accepts twice: from the rung below, with that rung's fastest
        value as the target, and after solving it, with its own (the same value to rounding,
        or a larger one). A finite bound below the first target is a bound whatever the
        target it was sought for (:func:`analytic.physics.tail_layers.layered_bound`), so it is
        kept and given again where it is below the new target too (session 35: 18 of the 113
        bounds of the damage zone's stress top at 24 ``k``, 3.4 of their 8.1 s).
        """
        seen: dict[float, tuple[float | None, float | None]] = {}

        def at(w: float, target: float | None) -> float | None:
            if w in seen:
                t0, v0 = seen[w]
                if t0 == target or (v0 is not None and target is not None and t0 is not None
                                    and v0 < t0 and v0 < target):
                    return v0
            seen[w] = (target, layered_bound(self.params, self.layers, k, w, target))
            return seen[w][1]
        return at


def layered_tail(params: Params, material: SliderMaterial, region: Region) -> LayeredTail | None:
    """The :class:`LayeredTail` of a layered slider (``region`` as the user gave it).

    ``None`` where no bound is derived (profiles, a deformable substrate, more than two
    layers whose phase rates are not commensurate).
    """
    layers, why_not = layered_tail_layers(params, material)
    if why_not:
        return None
    scale = slider_velocity_scale(params, material) / velocity_scale(params)
    rungs = C_LADDER if region.c_max is None else (region.c_max,)
    return LayeredTail(params, tuple(_exact_layers(layers)), tuple(c * scale for c in rungs))


def layered_setup(params: Params, material: SliderMaterial, region: Region, bound: bool
                  ) -> tuple[dict, LayeredTail | None]:
    """:func:`layered_summary` and, with ``bound`` (``--layers-bound yes``), :func:`layered_tail`.

    ``region`` as the user gave it; the tail is ``None`` without ``bound`` or where no bound is
    derived (the region is then its first rung, not climbed).
    """
    return (layered_summary(params, material, region, bound),
            layered_tail(params, material, region) if bound else None)


def layered_params(params: Params, material: SliderMaterial, check_exact: str,
                   solver: str) -> Params:
    """``params`` of a layered/graded slider (``H``: its height); refuse an exact check.

    Raises:
        ParameterError: ``check_exact`` other than ``"auto"`` (default) or ``"no"``, or
            ``solver = "newton"`` (it starts from exact roots): one line.
    """
    if check_exact not in ("auto", "no") or solver == "newton":
        bad = ("--solver = newton", "linear, moments") if solver == "newton" else (
            f"--check-exact = {check_exact}", "no")
        raise ParameterError(f"{bad[0]} is outside its allowed values for several layers or "
                             f"profiles (no exact roots): {bad[1]}")
    return params.replace(H=material.layer_rows(params.H, params.beta)[-1].y_top)


def layered_tail_layers(params: Params, material: SliderMaterial
                        ) -> tuple[list[list[float]], str]:
    """The slider's constant layers ``[bottom, top, mu, rho, beta]`` for the tail bound.

    Returns:
        ``(layers, why_not)``: ``why_not`` says why no bound exists (profiles, a deformable
        substrate, phase rates not commensurate: :func:`analytic.physics.tail_layers.
        why_no_layered_bound`), ``""`` otherwise.
    """
    rows, below, out = material.layer_rows(params.H, params.beta), 0.0, []
    for row in rows:
        out.append([below, row.y_top, row.mu, row.rho, row.beta])
        below = row.y_top
    if params.two_body:
        return out, LAYERED_TWO_BODY
    if material.profiles:
        return out, NO_BOUND_GRADED
    return out, why_no_layered_bound(_exact_layers(out))


def _exact_layers(layers: list[list[float]]) -> list[ExactLayer]:
    """:class:`analytic.physics.layered_exact.ExactLayer` of :func:`layered_tail_layers`'s."""
    return [ExactLayer(*map(float, lay)) for lay in layers]


def layered_summary(params: Params, material: SliderMaterial, region: Region,
                    bound: bool = False) -> dict:
    """``summary.json`` keys of a layered slider's region (``region`` as given by the user).

    ``tail_layers``, ``why_not``: :func:`layered_tail_layers` (with ``bound``, the scene's
    ``--layers-bound yes``, the region climbs at each ``k`` (:func:`climb` with
    :func:`layered_tail`) and :func:`summarise` sets ``proven_to_hold_fastest_mode`` from the
    bounds it saved; without, ``why_not`` is :data:`LAYERED_NOT_ASKED`).
    """
    layers, why_not = layered_tail_layers(params, material)
    why_not = why_not if bound else LAYERED_NOT_ASKED
    climbs = not why_not and region.c_max is None
    c_max = "auto" if climbs else (C_LADDER[0] if region.c_max is None else region.c_max)
    how = (f"c_max = auto: chosen per k from {list(C_LADDER)} until the layers' tail bound, "
           "analytic.physics.tail_layers, is below the fastest FE eigenvalue inside (the top "
           "rung if none is)" if climbs else
           "c_max = auto is the first rung, 4: without the layers' tail bound the region does "
           "not climb")
    return {"velocity_scale": slider_velocity_scale(params, material),
            "c_max": c_max,
            "definition": ("re_min <= Re Lambda <= re_max and |Im Lambda| <= c_max * k * "
                           "velocity_scale + omega0 (velocity_scale: the largest c_d of the "
                           f"layered/graded stack, units of mu = rho = 1; {how})"),
            "proven_to_hold_fastest_mode": False, "why_not": why_not, "tail_layers": layers,
            "by": ("fe (the FE climbed its own region with the layers' tail bound; per_k: the "
                   "rung and the bound at each k)" if climbs else
                   "fixed (its tail bound, analytic.physics.tail_layers, where asked for, says "
                   "whether it holds the fastest mode)")}


def _float_back(v: object) -> object:
    """Inverse of the strict encoding of one number: ``None`` -> NaN, ``"inf"`` -> inf."""
    if v is None:
        return math.nan
    if v in ("inf", "-inf"):
        return float(v)  # type: ignore[arg-type]
    return v


def results_from_json(saved: Iterable[dict]) -> tuple[list[KResult], list[float]]:
    """The :class:`KResult` of each saved ``k`` (in order) and the bound ``c_max`` it used.

    Rows that carry their continued values (:func:`continue_rows`) are labelled by
    :func:`label_by_continuation`.
    """
    saved = list(saved)
    results = [k_result_from_json(d) for d in saved]
    if any("re_next" in r for res in results for r in res.rows):
        label_by_continuation(results)
    return results, [float(d["c_max"]) for d in saved]


def saved_tail_bounds(saved: Iterable[dict]) -> list[float | None]:
    """The tail bound each saved ``k``'s climb kept (:func:`solve_k_values` with a ``tail``)."""
    return [None if d["tail_bound"] is None else float(d["tail_bound"]) for d in saved]


def k_result_from_json(d: dict) -> KResult:
    """A :class:`KResult` from its ``as_dict()`` read back from strict JSON (NaN, inf restored)."""
    d = dict(d)
    d["rows"] = [{key: _float_back(v) for key, v in row.items()} for row in d["rows"]]
    d["box"] = [_float_back(v) for v in d["box"]]
    return KResult.from_dict(d)


def region_at_k(params: Params, region: Region, k: float, exact: bool = True,
                after: dict | None = None) -> float:
    """The phase-velocity bound used at ``k`` (not collective).

    ``region.c_max``, or for an adaptive region the
    rung of :func:`analytic.numerics.spectrum.provable_region` found with the exact roots (the
    first rung if the exact search fails, or without the exact roots (``exact=False``): the
    sweep's tail bound against the fastest FE value then says whether it proves).
    Share the ``k`` over the ranks as for :func:`k_costs`.

    ``after`` (a dict kept over calls at nearby ``k``, e.g. one rank's share in increasing
    order): the last fastest root and the roots located with it are the next search's hint and
    starts, and the region is not counted as a whole (``fastest_mode(whole=False)``: the same
    root and rung; only the rung is used here). Session 35: the default sweep's 120 ``k``
    2.45 -> 0.63 s (stress), 1.31 -> 0.30 s (velocity) on one rank, the same rung at each.
    """
    if region.c_max is not None:
        return region.c_max
    if not exact:
        return C_LADDER[0]
    last = (after or {}).get("mode")
    hint = None if last is None or last.root is None else last.root.real
    try:
        mode = fastest_mode(params, float(k), region, hint, () if last is None else last.located,
                            whole=after is None)
    except ContourError:
        return C_LADDER[0]
    if after is not None:
        after["mode"] = mode
    return mode.c_max


def regions_at_k(params: Params, region: Region, k: np.ndarray, exact: bool,
                 mapper: Callable[[list[float], Callable[[int], float]], list]
                 ) -> tuple[list[float], Region]:
    """:func:`region_at_k` at every ``k`` and :func:`largest_region` (collective via ``mapper``).

    Args:
        params: Parameters.
        region: The sweep's region (adaptive or fixed).
        k: The wavenumbers.
        exact: Whether the exact roots may be used (``--check-exact``).
        mapper: ``mapper(costs, fn)`` returns ``[fn(i) for every i]`` on every rank, the work
            shared over the ranks by ``costs`` (the scene's ``_cli.map_shared`` on its comm).
    """
    after: dict = {}  # this rank's last k: the next search's hint and starts
    got = mapper([1.0] * len(k), lambda i: region_at_k(params, region, float(k[i]), exact,
                                                        after))
    c_at_k = [float(got[i]) for i in range(len(k))]
    return c_at_k, largest_region(params, region, k, c_at_k)


def follow_all(comm: object, params: Params, plan: RegionPlan, region: Region, k: np.ndarray,
               share_of: Callable[[int], Iterable[int]]) -> list[BranchResult]:
    """:func:`family_plan` and :func:`follow_families`: ``share_of(n)`` is this rank's share.

    The families are planned in ``plan.big`` and followed where they may lie in the region of
    each ``k`` (``region`` with ``plan.c_at_k``; ``plan.big`` at every ``k`` without them):
    the stress top's default sweep climbs to 32 ``c_d`` at one ``k`` and to 8-16 at most, and
    following every family of the tallest box at every ``k`` took twice as long (7.9 against
    4.1 s, one rank, 225 families, 2026-12-01). A family skipped where the region's roots needed
    it would leave an unlabelled, flagged root
    (:func:`analytic.numerics.spectrum.follow_family`), not a gap.
    """
    fplan, items = family_plan(comm, params, plan.big, float(k[-1]))
    c_at = dict(zip(map(float, k), plan.c_at_k, strict=True)) if plan.c_at_k else None
    return follow_families(comm, params, region if c_at else plan.big, fplan, items, k,
                           share_of(len(items)), c_at)


def csv_row(row: dict, fields: Sequence[str]) -> dict:
    """One row for ``spectrum.csv``: ``fields`` only, floats as ``repr`` (full precision)."""
    return {f: (repr(v) if isinstance(v, float) else v) for f in fields for v in [row.get(f, "")]}


def csv_rows(results: list[KResult], fields: Sequence[str]) -> list[dict]:
    """The rows of every ``k`` for ``spectrum.csv`` (:func:`csv_row`)."""
    return [csv_row(r, fields) for res in results for r in res.rows]


def run_meta(params: Params, k_spec: str, k: np.ndarray, merged: int,
             discretisation: tuple[int, int, float], share: ShareRun, rtol: float, solver: str,
             check_exact: bool, mpi: dict, resumed: bool, computed: int) -> dict:
    """``summary.json``'s keys before the summary proper (the scene adds versions, command).

    Parameters, ``k``, discretisation, method, MPI timings, resume.
    """
    return {"parameters": params.as_dict(),
            "k": {"spec": k_spec, "count": len(k), "merged_duplicates": merged,
                  "min": float(k[0]), "max": float(k[-1])},
            **describe_discretisation(params, discretisation, share, rtol, solver, check_exact),
            "mpi": mpi, "resumed": resumed, "computed_this_run": computed}


#: CPU seconds of solving per ``k`` value per ``(W H)^2`` (``W`` the region's height at that
#: ``k``: eigenvalues and mesh cells both grow with ``W H``). Measured: the default velocity
#: sweep (120 k, ``--c-max 4 --check-exact no``, ``H = 0.5``, one rank) spent 4.56 s solving
#: (the sum of its ``per_k`` seconds), and its ``sum (W H)^2`` is 78 771 (2026-11-25, this
#: 2-core machine, idle; 27.7 s before the banded precomputation of 2026-11-25).
SECONDS_PER_WH2 = 5.8e-5


def estimate_seconds(params: Params, region: Region, k: Sequence[float], ranks: int) -> float:
    """Up-front estimate of the solving time (wall, ``ranks`` sharing the ``k``) at the first rung.

    An adaptive region is estimated at its first rung: where the region grows the run takes
    longer (the stress top's default sweep climbs to 8-32 ``c_d``).
    """
    reg = region if region.c_max is not None else region.fixed(C_LADDER[0])
    wh = np.array([reg.im_max(params, float(x)) * params.H for x in k])
    return float(SECONDS_PER_WH2 * np.sum(wh**2) / max(1, ranks))


@dataclass
class RegionPlan:
    """Who sets the region's bound at each ``k``, and the exact roots' bounds when consulted.

    Attributes:
        fe_climbs: The FE climbs its own bound per ``k`` (:func:`climb`; FE first, adaptive).
        c_at_k: The exact roots' bound at each ``k`` (:func:`regions_at_k`; empty when they are
            not consulted).
        big: The region the families are planned for and the ``k`` costs are read from.
    """

    fe_climbs: bool
    c_at_k: list[float]
    big: Region

    @property
    def given(self) -> list[float] | None:
        """The bounds :func:`solve_k_values` must use (``None``: the FE climbs)."""
        return None if self.fe_climbs else self.c_at_k

    def referee(self, k: np.ndarray, used: Sequence[float], check_exact: bool) -> dict:
        """:func:`region_referee` of a finished sweep that used the bounds ``used``."""
        return region_referee(k, used, self.c_at_k if self.fe_climbs and check_exact else [],
                              "fe" if self.fe_climbs else "exact")


def plan_regions(params: Params, region: Region, k: np.ndarray, check_exact: bool,
                 solver: str, mapper: Callable[[list[float], Callable[[int], float]], list]
                 ) -> RegionPlan:
    """The :class:`RegionPlan` of a sweep (collective via ``mapper``, see :func:`regions_at_k`).

    FE first with an adaptive region: the FE climbs; the exact roots climb their own ladder only
    when checked (to plan the families and referee the FE's bounds). Otherwise (exact-seeded, or
    a fixed region) the exact roots' bounds are used.
    """
    fe_climbs = solver != "newton" and region.c_max is None
    if fe_climbs and not check_exact:
        return RegionPlan(True, [], region.fixed(C_LADDER[0]))
    c_at_k, big = regions_at_k(params, region, k, check_exact, mapper)
    return RegionPlan(fe_climbs, c_at_k, big)


def sweep_meta(params: Params, k_spec: str, k: np.ndarray, merged: int, rungs: RungSolvers,
               used: Sequence[float], share: ShareRun, solver: str, check_exact: bool,
               per_rank: list[dict], resumed: bool, computed: int) -> dict:
    """:func:`run_meta` of a finished sweep, with the mesh of every rung used (:func:`rung_table`).

    Args:
        params: Parameters.
        k_spec: The ``--k`` text.
        k: The requested wavenumbers, sorted and unique.
        merged: Duplicate ``k`` values dropped.
        rungs: The solvers per bound (their rule gives the largest rung's mesh).
        used: The bound each ``k`` used.
        share: Rank 0's :class:`ShareRun`.
        solver: ``--solver``.
        check_exact: The exact roots were consulted.
        per_rank: Every rank's timings and rung sizes (gathered).
        resumed: The run continued an earlier one.
        computed: ``k`` values computed in this run.
    """
    # the largest ladder rung's mesh at k_max (a taller box beyond the ladder, at small k, has a
    # mesh planned for its small k: rung_table lists the meshes of every rung used)
    meta = run_meta(params, k_spec, k, merged,
                    rungs.discretisation(largest_rung(used)), share,
                    rungs.rtol, solver, check_exact, {"ranks": len(per_rank),
                                                      "per_rank": per_rank},
                    resumed, computed)
    meta["discretisation"] |= rung_table(rungs, used, per_rank)
    return meta


def largest_rung(c_max_at_k: Sequence[float]) -> float:
    """The largest bound used, leaving out taller boxes when a ladder rung was used too.

    The ladder is :data:`analytic.numerics.spectrum.C_LADDER`. When every bound is above its
    top (taller boxes at small ``k`` only, or a fixed ``--c-max`` above 32): the largest.
    """
    return max((c for c in c_max_at_k if c <= C_LADDER[-1]), default=max(c_max_at_k))


def largest_region(params: Params, region: Region, k: Sequence[float],
                   c_max_at_k: Sequence[float]) -> Region:
    """The smallest region of the sweep's form that holds the box used at every ``k``.

    The family plan and the plot use it. Its bound is the largest ladder rung used
    (:data:`analytic.numerics.spectrum.C_LADDER`); a taller box beyond the ladder's top
    (:func:`analytic.numerics.spectrum.taller_rungs`, small ``k``) raises its ``omega0``
    instead: its ``c_max`` (e.g. 190 ``c_d`` at ``kH = 0.05``) at the sweep's largest ``k`` would
    be a region many times too tall to plan families in. A fixed region: the largest bound
    used (itself, or a layered slider's climb from its first rung, :func:`climb`).
    """
    if region.c_max is not None:  # a fixed region, or a layered slider's climb (no taller box)
        return region.fixed(max(c_max_at_k, default=region.c_max))
    big = region.fixed(largest_rung(c_max_at_k))
    lift = max(region.fixed(c).im_max(params, float(x)) - big.im_max(params, float(x))
               for c, x in zip(c_max_at_k, k, strict=True))
    return big if lift <= 0.0 else replace(big, omega0=big.omega_0(params) + lift)


def family_plan(comm: object, params: Params, region: Region, k_max: float
                ) -> tuple[FamilyPlan, list[tuple]]:
    """The families that can reach the region up to ``k_max``, planned on one rank (collective).

    The last rank plans (the roots at the seed wavenumber in the tall box: 0.15-0.5 s at the
    defaults), so that rank 0 can meanwhile import the picture's matplotlib (``sweep_k.py``).

    Returns:
        ``(plan, items)``: :func:`analytic.numerics.spectrum.plan_families` and its items
        (:func:`analytic.numerics.spectrum.plan_items`), the same on every rank.
    """
    root = comm.size - 1
    plan = comm.bcast(plan_families(params, region, k_max) if comm.rank == root else None,
                      root=root)
    return plan, plan_items(plan)


def follow_families(comm: object, params: Params, region: Region, plan: FamilyPlan,
                    items: list[tuple], k: np.ndarray, mine: Iterable[int],
                    c_at: Mapping[float, float] | None = None) -> list[BranchResult]:
    """Every item of the plan followed to every ``k``; each rank follows ``mine`` (collective).

    Args:
        comm: The communicator of the sweep.
        params: Parameters.
        region: The region ``R``.
        plan: The plan of :func:`family_plan`.
        items: Its items.
        k: The requested wavenumbers, sorted.
        mine: This rank's indices into ``items`` (any iterable, e.g. claimed as the rank gets
            free); the ranks' shares together cover them once.
        c_at: The region's bound at each ``k`` (``region`` resolved per ``k``); None: ``region``
            at every ``k``.

    Returns:
        The followed families in the order of ``items``, on every rank.
    """
    done = follow_many(params, plan, mine, k, region, c_at)
    merged: dict[int, BranchResult] = {}
    for part in comm.allgather(done):
        merged.update(part)
    return [merged[i] for i in range(len(items))]


def k_costs(params: Params, region: Region, k: np.ndarray, indices: Sequence[int]
            ) -> list[float]:
    """Relative cost of solving at ``k[i]`` for each of ``indices``.

    The cost of a ``k`` goes with the number of roots in the region, i.e. with the region's
    height ``|Im Lambda| <= W(k)``.
    """
    return [region.im_max(params, float(k[i])) for i in indices]


@dataclass
class ShareRun:
    """What one rank spent on its share of the ``k`` values (:func:`solve_k_values`).

    Attributes:
        seconds: Wall time of the share, solver set-up included.
        k_values: Number of ``k`` solved.
        unknowns: Unknowns of the degree-``p`` model (the largest rung's used here).
        substrate_cells: Cells of the substrate mesh (0: rigid substrate).
        rungs: Unknowns of the degree-``p`` model per bound ``c`` used here (its largest
            mesh: :class:`RungSolvers` plans one per ``k``).
        rung_cells: Cells of that mesh per bound ``c``.
    """

    seconds: float
    k_values: int
    unknowns: int
    substrate_cells: int
    rungs: dict[float, int] = field(default_factory=dict)
    rung_cells: dict[float, int] = field(default_factory=dict)


#: Ratio between the wavenumbers a sweep's meshes are planned for (:meth:`RungSolvers.mesh_k`).
MESH_K_RATIO = 1.25
#: Cells below which a per-``k`` mesh is not made smaller (:meth:`RungSolvers.discretisation`):
#: a solve on so few cells takes 0.05-0.16 s (stress top, 16-48 cells) and a new mesh 0.07-0.1 s
#: to build, so smaller meshes cost more than they save (measured, session 13: the velocity
#: sweep, 40 cells at ``k_max``, took 0.82x the CPU with a mesh per ``k`` bucket down to 14 cells).
#: P4 cells; other degrees ``MIN_CELLS 4 / degree`` (about the same unknowns: P6's 32 made the
#: default stress sweep 9.4, 9.5 s against 48's 10.3, 10.0 s, side by side, session 16).
MIN_CELLS = 48


def min_cells(degree: int) -> int:
    """:data:`MIN_CELLS` for Lagrange degree ``degree`` (about the same unknowns as P4's)."""
    return math.ceil(MIN_CELLS * 4 / degree)


class RungSolvers:
    """The :class:`forms.solvers.certified.CertifiedSolver` of each rung ``c`` at each ``k``.

    The mesh of rung ``c`` at ``k`` is planned for that rung's region at ``k`` rounded up to
    the grid ``k_max MESH_K_RATIO^-j`` (:meth:`mesh_k`; ``default_discretisation``), but not
    below :data:`MIN_CELLS` cells (nor above the mesh of ``k_max``), unless the user fixed the
    degree or the cells: never coarser than the rule asks at ``k``, and the sweep's largest
    ``k`` gets the mesh of the rule at ``k_max`` itself. Planning every rung for ``k_max``
    instead (before session 13) solved ``k = 0.05`` of the stress top's 32 ``c_d`` rung on
    the 220 cells of ``k = 6`` where 16 meet the rule (2.2 s against 0.05 s). Solvers are
    shared by the ``(c, k)`` that plan the same mesh, built when first asked for, on
    ``COMM_SELF``. Not collective.

    Args:
        params: Parameters.
        region: The sweep's region (its ``fixed(c)`` copies are the rungs' regions).
        k_max: The sweep's largest ``k``.
        rtol: Relative accuracy a row must reach to be ``ok``.
        fixed: ``(degree, cells)`` given by the user (0: from the rule), and the grading ratio.
        material: The slider's layers/profiles (``None``: homogeneous).
        check_exact: Match the FE values to the exact roots.
        solver: ``"linear"``, ``"moments"`` or ``"newton"``.
    """

    def __init__(self, params: Params, region: Region, k_max: float, rtol: float,
                 fixed: tuple[int, int, float], material: SliderMaterial | None = None, *,
                 check_exact: bool = True, solver: str = "linear") -> None:
        self.params, self.region, self.k_max, self.rtol = params, region, k_max, rtol
        self.fixed, self.material = fixed, material
        self.check_exact, self.solver = check_exact, solver
        self.solvers: dict[tuple, CertifiedSolver] = {}
        #: The largest ``(cells, unknowns)`` used per rung ``c``.
        self.largest: dict[float, tuple[int, int]] = {}

    def mesh_k(self, k: float | None) -> float:
        """The wavenumber a mesh for ``k`` is planned for: ``k_max MESH_K_RATIO^-j >= k``."""
        if k is None or not k < self.k_max:
            return self.k_max
        j = math.floor(math.log(self.k_max / k) / math.log(MESH_K_RATIO) + 1e-12)
        return self.k_max * MESH_K_RATIO ** -j

    def discretisation(self, c: float, k: float | None = None) -> tuple[int, int, float]:
        """``(degree, cells, ratio)`` of rung ``c`` at ``k`` (``None``: the sweep's ``k_max``)."""
        reg = self.region.fixed(c)
        degree, cells, ratio = default_discretisation(self.params, reg, self.mesh_k(k), self.rtol,
                                                      self.fixed[0])  # degree: the fixed one
        top = default_discretisation(self.params, reg, self.k_max, self.rtol, degree)[1]
        cells = max(cells, min(top, min_cells(degree)))
        return degree, self.fixed[1] or cells, self.fixed[2] or ratio

    def __call__(self, c: float, k: float | None = None) -> CertifiedSolver:
        """The solver of rung ``c`` at ``k`` (``None``: the mesh of ``k_max``)."""
        km = self.mesh_k(k)
        disc = self.discretisation(c, k)
        cells2 = (substrate_cells(self.params, self.region.fixed(c), km, self.rtol, disc[0])
                  if self.params.two_body else 0)
        key = (*disc, cells2)
        if key not in self.solvers:
            self.solvers[key] = CertifiedSolver(
                self.params, self.region.fixed(c), *disc, km, self.rtol,
                self.material, check_exact=self.check_exact, solver=self.solver)
        cs = self.solvers[key]
        if disc[1] > self.largest.get(c, (0, 0))[0]:
            self.largest[c] = (disc[1], cs.unknowns)
        return cs

    def destroy(self) -> None:
        """Free every solver."""
        for cs in self.solvers.values():
            cs.destroy()
        self.solvers.clear()


def climb(params: Params, region: Region, k: float, fams: list[BranchResult],
          rungs: Callable[[float, float], CertifiedSolver], start: float | None = None,
          tail: LayeredTail | None = None) -> tuple[KResult, float, float | None]:
    """The FE's own provable region at ``k``: the certified spectrum of the rung it accepts.

    :func:`analytic.numerics.spectrum.provable_region` with the fastest FE eigenvalue of each
    rung (solved by ``rungs(c, k)``) as ``fastest_inside``: the FE decides how far the region
    grows, no exact root is consulted for it. A fixed region is solved once.

    ``start`` (a warm start, e.g. the rung accepted at the previous ``k``): that rung is solved
    first, and the climb then asks for the rungs below it as before, each answered from the
    start rung's eigenvalues with ``|Im| <= W(c)`` when its count closed (the same values to
    the discretisation error: the same decisions); only the rung accepted and any rung above
    the start are solved. The rung accepted is the one of the cold climb; on a run of ``k``
    that accept the same rung one solve per ``k`` instead of two (stress top, defaults: the
    4 ``c_d`` rung, then 12 or 16).

    ``tail`` (a layered slider): its rungs and bound instead of the homogeneous slider's
    (``region`` is then any of its rungs: the climb takes ``tail.ladder``).

    Returns:
        ``(result, c, tail_bound)``: the result at the accepted rung ``c`` and the tail bound
        there (``None``: none derived).
    """
    got: dict[float, KResult] = {}

    def solve(c: float) -> KResult:
        if c not in got:
            got[c] = rungs(c, k).solve(k, fams, region.fixed(c), follow=True)
        return got[c]

    def fastest_inside(c: float) -> float | None:
        above = [b for b in got if b > c and got[b].closed]
        if c not in got and above:
            w = region.fixed(c).im_max(params, k)
            return max((r["re_lambda"] for r in got[min(above)].rows
                        if abs(r["im_lambda"]) <= w), default=None)
        return max((r["re_lambda"] for r in solve(c).rows), default=None)

    more = {}
    if tail is not None:
        region = replace(region, c_max=None if len(tail.ladder) > 1 else tail.ladder[0])
        more = {"bound": tail.bound(k), "ladder": tail.ladder}
    if start is not None and region.c_max is None:
        solve(start)
    c, tb = provable_region(params, k, region, fastest_inside, **more)
    return solve(c), c, tb


def fe_fastest(params: Params, region: Region, k: float, rtol: float = 1e-8) -> dict:
    """The finite elements' own fastest eigenvalue at one ``k``, no exact root consulted.

    The certified FE spectrum of the rung the FE climbs to (:func:`climb` with
    ``check_exact=False``: the default sweep's path with ``--check-exact no``, the meshes of
    :class:`RungSolvers` planned for this ``k``) and its fastest row: a scene whose answer
    comes from the exact roots (``contrast.py``) asks it to find the same mode on its own.
    Not collective (``COMM_SELF`` solvers).

    Returns:
        ``fe_re_lambda``, ``fe_im_lambda`` (``None``: no FE eigenvalue in the region),
        ``fe_count`` (the FE's own count in the rung's region), ``fe_closed`` (found ==
        counted, every row within ``rtol`` of its estimate), ``fe_c_max`` (the rung) and
        ``fe_proven`` (its tail bound below the fastest: :func:`tail_entry`).
    """
    rungs = RungSolvers(params, region, float(k), rtol, (0, 0, 1.0), check_exact=False)
    try:
        res, c, tb = climb(params, region, float(k), [], rungs)
    finally:
        rungs.destroy()
    best = max(res.rows, key=lambda r: r["re_lambda"], default=None)
    return {"fe_re_lambda": None if best is None else best["re_lambda"],
            "fe_im_lambda": None if best is None else best["im_lambda"],
            "fe_count": res.n_fe, "fe_closed": bool(res.closed), "fe_c_max": c,
            "fe_proven": tail_entry(region, res, c, tb)["fastest_proven"]}


def solve_k_values(params: Params, region: Region, rungs: RungSolvers, k: np.ndarray,
                   mine: Iterable[int], fams: list[BranchResult],
                   save: Callable[[int, dict], object],
                   progress: Callable[[], object] | None = None,
                   c_max_at_k: Sequence[float] | None = None,
                   tail: LayeredTail | None = None) -> ShareRun:
    """The certified spectrum at ``k[i]`` for each ``i`` of ``mine``, each handed to ``save``.

    Each :class:`forms.solvers.certified.KResult` goes to ``save(i, result.as_dict() |
    {"c_max": c})`` (with the bound ``c_max`` it used) as soon as it is finished: the scene
    keeps it (a resumed sweep skips it). ``rungs`` is destroyed at the end. Not collective.

    Args:
        params: Parameters.
        region: The sweep's region ``R`` (adaptive: ``c_max = None``).
        rungs: The solvers per bound.
        k: Every requested wavenumber, sorted.
        mine: Indices into ``k`` to solve here, in the order they are solved (e.g. taken as
            the rank gets free: ``workflows/_sharing.EndClaims``, a run of neighbouring ``k``
            up or down).
        fams: The followed families (:func:`follow_families`; unused without the exact check).
        save: Called with ``(i, result dict)`` after every finished ``k``.
        progress: Called after every finished ``k`` (e.g. a progress bar's update).
        c_max_at_k: The bound to use at each ``k`` (indexed like ``k``; the exact-seeded
            sweep's :func:`region_at_k`); ``None``: the FE climbs its own (:func:`climb`).
        tail: A layered slider's rungs and tail bound (:func:`layered_tail`): its climb, and
            the bound saved with each ``k`` (``tail_bound``).

    With a ``material`` and no exact check (``rungs``), every row is also continued to the next
    swept ``k`` (:func:`continue_rows`), for the labels of :func:`label_by_continuation`.
    Every solve follows the earlier ones of its solver (``follow=True``: their eigenpairs,
    extrapolated in ``k``, are tried before the linearisation; the count decides).
    """
    t0 = time.perf_counter()
    track = rungs.material is not None and not rungs.check_exact
    start, done = None, 0
    try:
        for i in mine:  # each climb starts at the rung of the k solved before it
            done += 1
            extra: dict = {}
            if c_max_at_k is not None:
                c = c_max_at_k[i]
                res = rungs(c, float(k[i])).solve(float(k[i]), fams, region.fixed(c),
                                                  follow=True)
            else:
                res, c, tb = climb(params, region, float(k[i]), fams, rungs, start, tail)
                start = c
                if tail is not None:
                    extra = {"tail_bound": tb}
            if track and i + 1 < len(k):
                continue_rows(rungs(c, float(k[i + 1])), res, float(k[i + 1]))
            save(i, res.as_dict() | {"c_max": c} | extra)
            if progress is not None:
                progress()
        sizes = {c: n for c, (_, n) in rungs.largest.items()}
        cells2 = max((cs.cells2 for cs in rungs.solvers.values()), default=0)
    finally:
        rungs.destroy()
    return ShareRun(time.perf_counter() - t0, done, max(sizes.values(), default=0), cells2,
                    sizes, {c: m for c, (m, _) in rungs.largest.items()})


def rung_table(rungs: RungSolvers, used: Sequence[float], per_rank: list[dict]) -> dict:
    """``summary.json`` discretisation keys of the rungs used: cells and unknowns per bound.

    Each rung's mesh is planned per ``k`` (:class:`RungSolvers`); the table gives its largest,
    over every rank.

    Args:
        rungs: The solvers per bound (only their rule is read).
        used: The bound each ``k`` used (``c_max`` of its saved result).
        per_rank: Each rank's ``{"unknowns": {c: n}, "cells": {c: m}}`` (:attr:`ShareRun.rungs`,
            :attr:`ShareRun.rung_cells`).
    """
    sizes: dict[float, int] = {}
    cells: dict[float, int] = {}
    for d in per_rank:
        for c, n in d["unknowns"].items():
            sizes[c] = max(n, sizes.get(c, 0))
        for c, m in d.get("cells", {}).items():
            cells[c] = max(m, cells.get(c, 0))
    table = [{"c_max": c, "degree": d[0], "cells": cells.get(c, d[1]), "unknowns": sizes.get(c),
              "k_values": sum(1 for u in used if u == c)}
             for c in sorted(set(used)) for d in [rungs.discretisation(c)]]
    return {"unknowns": max((r["unknowns"] or 0 for r in table), default=0), "per_rung": table,
            "mesh_per_k": (f"each rung's mesh planned at k rounded up to k_max * "
                           f"{MESH_K_RATIO}^-j; the table gives the largest")}


def region_referee(k: np.ndarray, used: Sequence[float], exact: Sequence[float], by: str
                   ) -> dict:
    """``summary.json`` region keys: who chose the bound at each ``k``, and the exact referee.

    Args:
        k: The requested wavenumbers.
        used: The bound each ``k`` used.
        exact: The exact roots' bound at each ``k`` when they refereed the FE's (else empty).
        by: ``"fe"`` (the FE climbed, :func:`climb`) or ``"exact"`` (:func:`region_at_k`).
    """
    out: dict = {"by": by}
    if exact:
        out["exact_disagrees_at_k"] = [float(kk) for kk, a, b in zip(k, used, exact, strict=True)
                                       if a != b]
    return out


def continue_rows(cs: CertifiedSolver, res: KResult, k_next: float) -> None:
    """Each row's FE eigenpair continued to ``k_next``: keys ``re_next``, ``im_next`` (NaN: lost).

    :func:`forms.solvers.certified.continue_fe` on the degree-``p`` model over
    :data:`TRACK_SUBSTEPS` equal steps; its factorisations are added to ``res``.
    """
    ks = np.linspace(res.k, k_next, TRACK_SUBSTEPS + 1)
    for row in res.rows:
        vals, n = continue_fe(cs.banded[0], ks, complex(row["re_lambda"], row["im_lambda"]))
        z = vals[-1] if not np.isnan(vals[0]) else complex(math.nan, math.nan)
        row["re_next"], row["im_next"] = float(z.real), float(z.imag)
        res.factorizations += n


def label_by_continuation(results: list[KResult]) -> int:
    """Label the rows ``c0, c1, ...`` by the links of :func:`continue_rows` (in place).

    A row at ``k_(i+1)`` inherits the label of the row at ``k_i`` whose continued value is
    nearest to it, when each is the other's nearest and they agree to :data:`TRACK_LINK_RTOL`;
    every other row gets a new label (numbered in ``k``, then by ``|Im Lambda|``).

    Returns:
        The number of labels.
    """
    count = 0
    prev: list[dict] = []
    for res in results:
        rows = sorted(res.rows, key=lambda r: (abs(r["im_lambda"]), r["im_lambda"]))
        here = np.array([complex(r["re_lambda"], r["im_lambda"]) for r in rows])
        nxt = np.array([complex(r.get("re_next", math.nan), r.get("im_next", math.nan))
                        for r in prev])
        linked: dict[int, str] = {}
        for a, z in enumerate(nxt):
            if np.isnan(z) or not len(here):
                continue
            b = int(np.argmin(np.abs(here - z)))
            near = np.abs(nxt - here[b])
            if (int(np.nanargmin(near)) == a
                    and abs(here[b] - z) <= TRACK_LINK_RTOL * abs(here[b])):
                linked[b] = prev[a]["label"]
        for b, row in enumerate(rows):
            if b in linked:
                row["label"] = linked[b]
            else:
                row["label"], count = f"c{count}", count + 1
        prev = rows
    return count


def describe_discretisation(params: Params, discretisation: tuple[int, int, float],
                            share: ShareRun, rtol: float, solver: str = "newton",
                            check_exact: bool = True) -> dict:
    """``summary.json`` keys ``discretisation`` and ``method``: the model, mesh and estimate."""
    degree, cells, ratio = discretisation
    model = "cross-section (1D in y), polynomial form"
    if params.two_body:
        model += ", layered (two bodies)"
    return {"discretisation": {"model": model, "degree": degree, "cells": cells,
                               "grading_ratio": ratio, "substrate_cells": share.substrate_cells,
                               "unknowns": share.unknowns, "rtol": rtol,
                               "error_estimate": f"P{degree + 1} on the same mesh, one Newton "
                               f"solve from the P{degree} value"},
            "method": METHODS[solver], "solver": solver, "check_exact": check_exact}


def tail_at_k(params: Params, region: Region, res: KResult, c_max: float,
              derived: bool = True, layers: list[ExactLayer] | None = None) -> dict:
    """``per_k`` keys of the region proof at one ``k``.

    The bound used, the tail bound at its ``W`` (:func:`analytic.physics.tail.tail_bound`, or
    with ``layers`` :func:`analytic.physics.tail_layers.layered_bound`; ``None`` when not
    ``derived``) and whether it is below the fastest row.
    """
    w = region.fixed(c_max).im_max(params, res.k)
    tb = ((layered_bound(params, layers, res.k, w) if layers is not None
           else tail_bound(params, res.k, w)) if derived else None)
    return tail_entry(region, res, c_max, tb)


def tail_entry(region: Region, res: KResult, c_max: float, tb: float | None) -> dict:
    """``per_k`` keys of the region proof at one ``k`` from its bound ``c_max`` and tail bound."""
    fastest = max((r["re_lambda"] for r in res.rows), default=None)
    target = fastest if fastest is not None else region.re_min
    return {"c_max": c_max, "tail_bound": tb,
            "fastest_proven": bool(tb is not None and tb < target)}


def most_unstable(rows: list[dict], results: list[KResult], k: np.ndarray,
                  open_k: list[dict], tails: list[dict] | None = None,
                  why_not: str = "", check_exact: bool = True) -> dict | None:
    """The row with the largest ``Re Lambda`` and its certificate (``None``: no rows).

    Args:
        rows: Every row of the sweep.
        results: The per-``k`` results the rows come from.
        k: The requested wavenumbers, sorted.
        open_k: The ``k`` whose count did not close (see :func:`summarise`).
        tails: :func:`tail_at_k` of every ``k``: the most unstable value is the fastest mode of
            the swept ``k`` when every tail bound is below it.
        why_not: Why no tail bound exists for these parameters ("" if it does).
        check_exact: The exact roots were consulted (the certificate's statement).
    """
    if not rows:
        return None
    best = max(rows, key=lambda r: r["re_lambda"])
    tb = [t["tail_bound"] for t in tails or []]
    beyond = None if (not tb or any(v is None for v in tb)) else max(tb)
    res_best = next((res for res in results if res.k == best["k"]), None)
    return {"k": best["k"], "re_lambda": best["re_lambda"], "im_lambda": best["im_lambda"],
            "branch": best["label"], "status": best["status"],
            "rel_error": best["rel_error"], "error_estimate": best["error_estimate"],
            "at_edge_of_k_range": best["k"] in (float(k[0]), float(k[-1])),
            "certificate": {
                "statement": CERTIFICATE_STATEMENTS[check_exact],
                "carries": best.get("certificate", ""),
                "all_k_closed": not open_k,
                "region_at_k": list(res_best.box) if res_best else None,
                "count_at_k": (res_best.n_exact if check_exact else res_best.n_fe)
                if res_best else None,
                "certified": bool(best["status"] == "ok" and not open_k),
                "largest_tail_bound": beyond,
                "fastest_mode": bool(beyond is not None and beyond < best["re_lambda"]),
                "fastest_mode_statement": why_not or FASTEST_STATEMENT}}


def summarise(params: Params, region: Region, k: np.ndarray, results: list[KResult],
              fams: list[BranchResult], c_max_at_k: Sequence[float] | None = None,
              check_exact: bool = True, layered: dict | None = None,
              tail_bounds: Sequence[float | None] | None = None) -> dict:
    """The sweep's summary: region, certificate, accuracy, families, most unstable, per ``k``.

    Pure data (no files). The keys, in order: ``region``, ``certificate`` (``k`` values closed
    or not, rows ok or flagged), ``accuracy`` (largest error against the exact roots and
    largest error estimate), ``families`` (count, notes), ``most_unstable``
    (:func:`most_unstable`), ``per_k`` (counts, box, seconds, factorisations, and the
    certificate each row carries: ``fe`` and/or ``exact``). ``layered``
    (:func:`layered_summary`): a layered/graded slider, its keys join ``region``; its tail
    bound is :func:`analytic.physics.tail_layers.layered_bound` where one is derived:
    ``tail_bounds``, the bound each ``k`` saved when it climbed (:func:`solve_k_values`; its
    ``c_max`` then in units of the stack's ``c_d``), else computed here (seconds a ``k``).
    """
    rows = [r for res in results for r in res.rows]
    flagged = [r for r in rows if r["status"] != "ok"]
    open_k = [{"k": res.k, "n_fe": res.n_fe, "n_exact": res.n_exact, "note": res.note}
              for res in results if not res.closed]
    errs = [r["rel_error"] for r in rows if math.isfinite(r["rel_error"])]
    ests = [r["error_estimate"] for r in rows if math.isfinite(r["error_estimate"])]
    cs = list(c_max_at_k) if c_max_at_k is not None else [region.c_max] * len(results)
    why_not = layered["why_not"] if layered is not None else why_no_tail_bound(params)
    layers = (_exact_layers(layered["tail_layers"]) if layered is not None and not why_not
              else None)
    pairs = list(zip(results, cs, strict=True))
    if layers is not None and tail_bounds is not None:  # saved by the climb
        scale = layered["velocity_scale"] / velocity_scale(params)
        tails = [tail_entry(region, res, c / scale, tb)
                 for (res, c), tb in zip(pairs, tail_bounds, strict=True)]
    else:
        tails = [tail_at_k(params, region, res, c, not why_not, layers)
                 | ({"c_max": layered["c_max"]} if layered is not None else {})
                 for res, c in pairs]
    most = most_unstable(rows, results, k, open_k, tails, why_not, check_exact)
    if layered is not None:
        layered = layered | {"proven_to_hold_fastest_mode": bool(
            most is not None and most["certificate"]["fastest_mode"])}
    return {
        "region": region.as_dict(params) | (layered or {}),
        "certificate": {"k_values": len(results), "k_closed": len(results) - len(open_k),
                        "found_by": {w: sum(res.found_by == w for res in results)
                                     for w in sorted({res.found_by for res in results})},
                        "k_not_closed": open_k, "rows": len(rows),
                        "rows_ok": len(rows) - len(flagged),
                        "rows_flagged": flagged[:MAX_FLAGGED_LISTED]},
        "accuracy": {"max_rel_error_vs_exact": max(errs) if errs else None,
                     "max_error_estimate": max(ests) if ests else None},
        "families": {"count": len(fams), "notes": {f.label: f.note for f in fams if f.note}},
        "most_unstable": most,
        **({"labels": TRACK_STATEMENT} if any("re_next" in r for r in rows) else {}),
        "per_k": [{"k": res.k, "n_fe": res.n_fe, "n_exact": res.n_exact, "closed": res.closed,
                   "box": list(res.box), **tail, "seconds": res.seconds,
                   "factorizations": res.factorizations, "found_by": res.found_by,
                   "certificate": [r.get("certificate", "") for r in res.rows]}
                  for res, tail in zip(results, tails, strict=True)],
    }


def envelope(rows: Sequence[dict]) -> list[dict]:
    """The fastest and the second fastest row at every ``k`` of a sweep's rows (CSV or dicts).

    Returns:
        One dict per ``k`` (increasing): ``k``, ``label``, ``re_lambda``, ``im_lambda`` of the
        fastest row, ``second_label`` and ``second_re_lambda`` (``""`` and NaN if alone).
    """
    by_k: dict[float, list[tuple[float, float, str]]] = {}
    for r in rows:
        by_k.setdefault(float(r["k"]), []).append(
            (float(r["re_lambda"]), float(r["im_lambda"]), str(r["label"])))
    out = []
    for k in sorted(by_k):
        ranked = sorted(by_k[k], key=lambda t: -t[0])
        second = ranked[1] if len(ranked) > 1 else (math.nan, math.nan, "")
        out.append({"k": k, "label": ranked[0][2], "re_lambda": ranked[0][0],
                    "im_lambda": ranked[0][1], "second_label": second[2],
                    "second_re_lambda": second[0]})
    return out


def envelope_changes(env: Sequence[dict]) -> dict:
    """The peak of :func:`envelope` and where another label takes the lead.

    Returns:
        ``peak`` (the envelope's row of largest ``Re Lambda``), ``leaders`` (each run of equal
        labels along ``k``: ``label``, ``k_from``, ``k_to``) and ``peak_label_leads_everywhere``
        (no other label is fastest at any swept ``k``).
    """
    leaders: list[dict] = []
    for e in env:
        if leaders and leaders[-1]["label"] == e["label"]:
            leaders[-1]["k_to"] = e["k"]
        else:
            leaders.append({"label": e["label"], "k_from": e["k"], "k_to": e["k"]})
    peak = max(env, key=lambda e: e["re_lambda"])
    return {"peak": dict(peak), "leaders": leaders,
            "peak_label_leads_everywhere": all(e["label"] == peak["label"] for e in env)}
