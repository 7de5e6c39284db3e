"""Grids of the scenes' options (``--k``, ``--mu2-grid``, ...): :func:`parse_grid`."""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from analytic.cli import parse_k
from analytic.params import ParameterError

__all__ = ["SWEEP_DELTA_MAX", "SWEEP_WH_MAX", "SWEEP_W_MAX", "check_sweep_limits", "parse_grid",
           "check_branch_kh", "check_roots_region", "progress_mapper"]


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


#: Limits of the certified sweep (sweep_k.py) on its region R (height ``W = Region.im_max`` at
#: the largest k, first rung of an adaptive region), measured on this project's 2-core machine.
#: The region holds about ``1.3 W H`` roots and the 1D mesh grows with ``W H``
#: (forms.solvers.certified.default_discretisation). Session 12 (FE first, --check-exact no,
#: one rank, the machine loaded with two other jobs): stress top k = 60 (W H = 253, climbs to
#: 12 c_d, 165 roots) 157 s, 2.8 GB; k = 100 (W H = 412, 12 c_d, 272 roots, 10 418 unknowns)
#: 297 s of CPU (673 s wall), 7.0 GB; both equal to an exact count up to 32 c_d. The limit
#: admits k = 100 at the defaults (the envelope's range). Before session 12 the limits were
#: W H <= 250 and W <= 500 (k = 60 at the defaults was refused).
SWEEP_WH_MAX = 420.0
#: The height alone: thin strips hold few roots in a tall region. Session 12, k = 1, exact
#: check on: H = 0.01 (W = 1265), 0.001 (12 574), 1e-4 and 1e-6 (W = 3.1e6) certified in
#: 2-11 s, both roots matched to the exact ones; H = 1e-8 (W = 3.1e8) found no FE eigenvalue
#: where the exact count has 2 (the count "not closed", exit 1). (Before: W = 1257 left the
#: count open, W = 12 574 found no contour: det_M's zero test against its largest sample,
#: analytic.numerics.roots._increments.)
SWEEP_W_MAX = 4e6
#: |Delta| at k = 1: Delta = -10 took 13 s, -1000 took 45 s with 4 of 13 roots flagged, -1e6
#: more than 150 s without a line (issue 18): the friction law's rate term stiffens the roots.
SWEEP_DELTA_MAX = 1000.0


#: Unknowns of a finite block (P``p`` on ``L cells_per_unit x ny`` cells, two components, both
#: bodies): the README's finite-block table ran its largest block, ``L = 128`` at 8 cells per
#: unit and 8 in ``y``, P2 (69 666 unknowns); larger blocks were never run on this machine, and
#: ``finite_block.py --lengths 1e6`` asked for 10^9 before this limit.
BLOCK_UNKNOWNS_MAX = 100_000


def require_finite_heights(params: Any, what: str, substrate: bool = False) -> None:
    """One line (exit 2) unless ``H`` is finite (and, with ``substrate``, ``H2`` of two bodies).

    Args:
        params: The parameters.
        what: Why a finite height is needed here (e.g. "a finite strip"), named in the line.
        substrate: Also refuse ``H2 = inf`` when the substrate is deformable (both bodies
            meshed).
    """
    if not math.isfinite(params.H):
        raise ParameterError(f"H = inf is outside its allowed range here ({what})")
    if substrate and params.two_body and not math.isfinite(params.H2):
        raise ParameterError(f"H2 = inf is outside its allowed range here ({what}: both "
                             "bodies are meshed)")


def block_unknowns(length: float, cells_per_unit: int, ny: int, degree: int,
                   two_body: bool = False) -> int:
    """Unknowns of a finite block's mesh (``ceil(L cells_per_unit) x ny`` cells, P``degree``)."""
    nx = math.ceil(length * cells_per_unit)
    return 2 * (degree * nx + 1) * (degree * ny + 1) * (2 if two_body else 1)


def check_block_size(length: float, cells_per_unit: int, ny: int, degree: int,
                     two_body: bool = False, name: str = "--lengths") -> None:
    """Refuse a finite block larger than :data:`BLOCK_UNKNOWNS_MAX` unknowns, in one line."""
    nx = math.ceil(length * cells_per_unit)
    n = block_unknowns(length, cells_per_unit, ny, degree, two_body)
    if n > BLOCK_UNKNOWNS_MAX:
        raise ParameterError(
            f"{name} = {length:g}: the block would have about {n:.3g} unknowns (P{degree}, "
            f"{nx} x {ny} cells), above {BLOCK_UNKNOWNS_MAX}, the largest size run here (the "
            "README's table: L = 128, 69 666 unknowns); use a shorter block or fewer cells")


def check_section_options(args: Any) -> None:
    """``sweep_k.py``'s options of the 1D section model, shared by every ``--model``.

    ``--degree`` (0: from the rule) up to 6, ``--cells`` (0: from the rule) up to 100000,
    ``--rtol`` in ``[1e-13, 1e-2]``, ``--omega0 >= 0``.

    Raises:
        ParameterError: One line naming the option and its allowed range.
    """
    from analytic.cli import positive_int

    positive_int("--degree", args.degree, 0, 6)
    positive_int("--cells", args.cells, 0, 100000)
    if not (math.isfinite(args.rtol) and 1e-13 <= args.rtol <= 1e-2):
        raise ParameterError(f"--rtol = {args.rtol} is outside its allowed range "
                             "1e-13 <= rtol <= 1e-2")
    if not (math.isfinite(args.omega0) and args.omega0 >= 0):
        raise ParameterError(f"--omega0 = {args.omega0} is outside its allowed range >= 0")


#: Unknowns of the 1D section model the sweep's first rung may plan at its largest ``k`` (the
#: cells rule of ``--degree`` at ``--rtol``,
#: :func:`forms.solvers.certified.default_discretisation`).
#: The largest measured (``k = 100``, 12 ``c_d``, P4): 10 418 unknowns, 56.6 s for one ``k``
#: (README). The default P6 plans at most about 2 000 within :data:`SWEEP_WH_MAX`; P2 up to
#: 22 500, P1 over a million (P1 cannot reach ``rtol = 1e-8`` in bounded time).
SECTION_UNKNOWNS_MAX = 50000


def check_sweep_limits(params: Any, k: np.ndarray, region: Any, degree: int = 0, cells: int = 0,
                       rtol: float = 1e-8) -> None:
    """Refuse a sweep the certified solver cannot finish in bounded time; say when it is long.

    Args:
        params: The run's :class:`analytic.params.Params`.
        k: The wavenumbers.
        region: The :class:`analytic.numerics.spectrum.Region`.
        degree: ``--degree`` (0: the default).
        cells: ``--cells`` (0: the rule's; a fixed count is not checked).
        rtol: ``--rtol``.

    Raises:
        ParameterError: One line naming the limit (:data:`SWEEP_WH_MAX`, :data:`SWEEP_W_MAX`,
            :data:`SECTION_UNKNOWNS_MAX`) and why.
    """
    if abs(params.Delta) > SWEEP_DELTA_MAX:
        raise ParameterError(f"Delta = {params.Delta:g} is outside [-{SWEEP_DELTA_MAX:g}, "
                             f"{SWEEP_DELTA_MAX:g}], the range in which the certified sweep "
                             "closes its root counts in bounded time")
    kmax = float(np.max(k))
    if region.c_max is None:  # adaptive: the first rung is what every k value needs at least
        from analytic.numerics.spectrum import C_LADDER

        region = region.fixed(C_LADDER[0])
    w = region.im_max(params, kmax)
    if w > SWEEP_W_MAX:
        raise ParameterError(
            f"the region's height |Im Lambda| <= {w:.4g} at k = {kmax:g} (c_max k/beta + "
            f"omega0, omega0 = 2 pi/(beta H)) is above {SWEEP_W_MAX:g}, the tallest region "
            "whose roots the contour integrals resolve; use a larger H, a smaller --c-max or "
            "k, or give --omega0")
    wh = w * params.H
    if wh > SWEEP_WH_MAX:
        raise ParameterError(
            f"the region would hold about {1.3 * wh:.0f} roots at k = {kmax:g} (k*H = "
            f"{kmax * params.H:g}), above {1.3 * SWEEP_WH_MAX:.0f}, the most the certified "
            "sweep follows in a few minutes per k value; use a smaller k or H, or a smaller "
            "--c-max")
    if not cells and math.isfinite(params.H):
        from forms.solvers.certified import default_discretisation

        d, n_cells, _ = default_discretisation(params, region, kmax, rtol, degree)
        if 2 * d * n_cells > SECTION_UNKNOWNS_MAX:
            raise ParameterError(
                f"--degree = {d} with --rtol = {rtol:g} needs about {2 * d * n_cells} unknowns at "
                f"k = {kmax:g} (the cells rule of each degree), above {SECTION_UNKNOWNS_MAX}, the "
                "most the sweep solves in bounded time; use a higher --degree (default 6) or a "
                "larger --rtol")


#: The exact roots' region (envelope.py, contrast.py: argument principle on det_M at every k),
#: its height ``W = Region.im_max`` at the largest k and the first rung of an adaptive region,
#: measured serially on this project's loaded 2-core machine at the defaults (H = beta = 0.5,
#: c_max = 4): W = 105 took 1.4 s per k value, 425 took 18 s, 825 (k = 100, envelope's largest
#: default k) 47 s, 1625 (k = 200) 226 s; the time grows as about W^2.3, so ``--k 1e7``
#: (W = 8e7) would run for years without a line.
ROOTS_W_MAX = 1700.0


def check_roots_region(params: Any, kmax: float, region: Any, what: str = "k") -> None:
    """Refuse a region of exact roots taller than :data:`ROOTS_W_MAX` at ``kmax``.

    Raises:
        ParameterError: One line naming the height, the limit and why.
    """
    if region.c_max is None:  # adaptive: the first rung is what every k value needs at least
        from analytic.numerics.spectrum import C_LADDER

        region = region.fixed(C_LADDER[0])
    w = region.im_max(params, kmax)
    if not w <= ROOTS_W_MAX:
        raise ParameterError(
            f"the region's height |Im Lambda| <= {w:.4g} at k = {kmax:g} (c_max k times the "
            f"largest c_d, plus omega0) is above {ROOTS_W_MAX:g}, beyond which the exact root "
            f"count takes more than about 4 minutes per k value; use a smaller {what}")


def check_branch_kh(params: Any, k: float, name: str = "--k") -> None:
    """Refuse ``k*H`` above ``analytic.cli.BRANCH_KH_MAX`` for a branch followed from small k.

    mode_shape.py follows its branch from small k to ``k`` in steps that scale with ``k*H``, as
    ``python -m analytic branch`` does (whose measured limit this is). Measured with
    mode_shape.py on the loaded 2-core machine: ``--k 100`` (k*H = 50, the limit) 74 s,
    ``--k 1e7`` more than 200 s without a line before this check.

    Raises:
        ParameterError: One line naming ``name``, the limit and why.
    """
    from analytic.cli import BRANCH_KH_MAX

    kh = float(k) * params.H
    if not kh <= BRANCH_KH_MAX:
        raise ParameterError(f"{name} = {k:g}: k*H = {kh:g} is above {BRANCH_KH_MAX:g}, the "
                             "largest for which the branch is followed from small k in bounded "
                             f"time (steps scale with k*H); use k <= {BRANCH_KH_MAX / params.H:g}"
                             " or a smaller H")


def region_from_args(c_max: str, re_min: float, re_max: float = 2.0,
                     omega0: float | None = None) -> Any:
    """The region of ``--c-max``, ``--re-min``, ``--re-max``, ``--omega0``.

    ``--c-max`` is a number > 0, or ``auto``: grown per ``k`` until it provably holds the
    fastest mode.

    Raises:
        ParameterError: One line naming the option and its allowed range.
    """
    from analytic.numerics.spectrum import Region

    try:
        c = None if str(c_max) == "auto" else float(c_max)
    except ValueError:
        raise ParameterError(f"--c-max = {c_max!r} is outside its allowed range: a number > 0 "
                             "or auto") from None
    try:
        return Region(re_min, re_max, c, omega0)
    except ParameterError as err:
        raise ParameterError("--" + str(err).replace("_", "-", 1)) from None


def proof_clause(proven: int, with_root: int) -> str:
    """What a printed maximum over ``R`` means: proven the fastest mode, or the largest in R only.

    Args:
        proven: ``k`` samples at which the tail bound proves that no root outside ``R`` grows
            faster than the fastest inside (:func:`analytic.numerics.spectrum.fastest_mode`).
        with_root: ``k`` samples with a root in ``R`` (the proof needs one).
    """
    if with_root and proven >= with_root:
        return f"R proven to hold the fastest mode at all {with_root} k with a root"
    return (f"in R only, R proven to hold the fastest mode at {proven} of {with_root} k with a "
            "root: see summary.json")


def progress_mapper(comm: Any, desc: str, quiet: bool = False, unit: str = " k values"
                    ) -> Callable[[Sequence[float], Callable[[int], Any]], dict[int, Any]]:
    """A ``mapper(costs, fn)`` (:func:`_sharing.map_shared` on ``comm``) with rank 0's bar.

    For a scene's stage that would otherwise be silent (the sweep's region bound at every k:
    about 0.4 s per k serially, so minutes for thousands of k values): a progress bar of rank
    0's share from its first item, on stderr, unless ``quiet``; ``unit`` counts the items.
    """
    from _sharing import map_shared, my_share
    from tqdm import tqdm

    def mapper(costs: Sequence[float], fn: Callable[[int], Any]) -> dict[int, Any]:
        mine = my_share(comm, costs)
        bar = None if quiet or comm.rank != 0 or not len(mine) else tqdm(
            total=len(mine), desc=f"{desc} (rank 0 of {comm.size})", unit=unit,
            file=sys.stderr)

        def step(i: int) -> Any:
            value = fn(i)
            if bar is not None:
                bar.update()
            return value

        try:
            return map_shared(comm, costs, step)
        finally:
            if bar is not None:
                bar.close()

    return mapper
