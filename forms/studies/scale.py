"""The 2D region solve at scale: one finite block, measured, and a cost model fitted to it.

Used by ``workflows/scale_benchmark.py``:

- :func:`cells_for_unknowns`: the mesh ``(nx, ny)`` of a block (square cells) whose Lagrange
  space has about a given number of unknowns;
- :func:`measure_region_solve`: one region solve of the block (:mod:`forms.solvers.region`: the
  argument-principle count on MUMPS's ``log det T_h``, then shift-and-invert Krylov-Schur over
  tiles), each part in its own PETSc log stage, with its wall time, its LU factorisations'
  time (PETSc events ``MatLUFactorSym``, ``MatLUFactorNum``, ``MatSolve``), the peak resident
  memory per rank and MUMPS's own memory report; a row of :data:`COLUMNS`;
- :func:`fit_cost_model`: per number of ranks, the seconds per LU of the count and per tile
  solve as power laws ``a N^b`` in the unknowns ``N``, with their largest relative error.
"""

from __future__ import annotations

import math
import resource
from collections.abc import Sequence

import numpy as np

from mpi4py import MPI
from petsc4py import PETSc

from analytic.params import Params
from forms.models.strip import build_strip_problem, strip_mesh_for
from forms.solvers.region import count_in_box
from forms.studies.block import region_session

#: Columns of a measured row (``scale_np<ranks>.csv``). Times in seconds (slowest rank), memory
#: in MiB: ``rss_max`` the largest peak resident set over the ranks (``ru_maxrss``: the process's
#: peak so far, so rows must go by increasing size), ``mumps_mem_max`` MUMPS's ``INFOG(21)``
#: (memory effectively used by the factorisation on the most loaded rank) of the tile solver.
COLUMNS = ("ranks", "unknowns", "nx", "ny", "box_re_min", "box_re_max", "box_im_max", "found",
           "counted", "closed", "wall", "setup", "count", "count_evaluations", "count_lu",
           "tiles_time", "tiles", "tiles_lu", "tiles_solve", "lu_share", "rss_max",
           "mumps_mem_max", "fastest_re", "fastest_im")

#: PETSc log events whose times are summed as "the factorisation" (symbolic + numeric LU).
LU_EVENTS = ("MatLUFactorSym", "MatLUFactorNum")


def unknowns_of(nx: int, ny: int, degree: int = 2) -> int:
    """Unknowns of the vector Lagrange space of degree ``degree`` on the ``nx x ny`` block."""
    return 2 * (degree * nx + 1) * (degree * ny + 1)


def cells_for_unknowns(target: int, length: float, height: float,
                       degree: int = 2) -> tuple[int, int]:
    """``(nx, ny)``: square cells (``nx / ny = length / height``), about ``target`` unknowns."""
    ratio = length / height
    ny = max(1, round(math.sqrt(target / (2.0 * ratio)) / degree))
    best = min((max(1, ny + d) for d in (-1, 0, 1)),
               key=lambda m: abs(unknowns_of(max(1, round(ratio * m)), m, degree) - target))
    return max(1, round(ratio * best)), best


def _event_seconds(comm: MPI.Comm, stage: PETSc.Log.Stage, names: Sequence[str]) -> float:
    """Sum of the events' times in ``stage`` on the slowest rank (PETSc logs per rank)."""
    local = sum(PETSc.Log.Event(n).getPerfInfo(stage.id)["time"] for n in names)
    return comm.allreduce(local, op=MPI.MAX)


def _stage(name: str) -> PETSc.Log.Stage:
    return PETSc.Log.Stage(name)


def measure_region_solve(comm: MPI.Comm, params: Params, length: float, nx: int, ny: int, *,
                         box: Sequence[float], degree: int = 2, nev: int = 8, count: bool = True,
                         divide: bool = True, prefix: str = "scale_region_") -> dict:
    """One region solve of the free block ``0 < x < length`` in ``box``, measured.

    The count (:func:`forms.solvers.region.count_in_box`, LU prefix ``prefix + "det_"``; only
    with ``count``; with ``divide`` the cleared denominator's ``(Lambda + 1)^m`` divided out of
    its samples, ``m`` = ``FrictionOperator.cleared_rows``) and the tile solves
    (:class:`forms.solvers.region.RegionSolver`, prefix ``prefix``, without a count: tiles
    split until the box is covered) run in the PETSc log stages ``scale_count`` and
    ``scale_tiles``; event times are differences taken around this call, so several calls in
    one process are independent. Collective; every PETSc object destroyed.

    Returns:
        The row of :data:`COLUMNS` (a dict).
    """
    PETSc.Log.begin()  # idempotent: logging on, so that the events have times
    st_count, st_tiles = _stage("scale_count"), _stage("scale_tiles")
    before = {(s.id, n): _event_seconds(comm, s, (n,)) for s in (st_count, st_tiles)
              for n in (*LU_EVENTS, "MatSolve")}
    comm.barrier()
    t0 = MPI.Wtime()
    strip = strip_mesh_for(comm, params, float(length), nx, ny)
    problem = build_strip_problem(strip, params, k=None, degree=degree, lateral="free")
    with region_session(comm, problem, nev, prefix) as (op, solver):
        res = None
        try:
            t_setup = comm.allreduce(MPI.Wtime() - t0, op=MPI.MAX)
            counted, bx, info = None, tuple(box), {"evaluations": 0, "seconds": 0.0}
            if count:
                st_count.push()
                counted, bx, info = count_in_box(op.matrices, box, op.law.spurious,
                                                 cleared_rows=op.cleared_rows if divide else 0,
                                                 prefix=prefix + "det_")
                st_count.pop()
            t_count = comm.allreduce(info["seconds"], op=MPI.MAX)
            st_tiles.push()
            res = solver.solve(op.matrices, bx, op.law.spurious, count=False)
            st_tiles.pop()
            factor = solver.pep.getST().getKSP().getPC().getFactorMatrix()
            mumps_mem = comm.allreduce(factor.getMumpsInfog(21), op=MPI.MAX)
            unknowns = op.matrices[0].getSize()[0]
            fastest = complex(res.values[0]) if res.found else complex("nan")
            found, tiles, t_tiles = res.found, res.tiles, comm.allreduce(res.seconds["solve"],
                                                                         op=MPI.MAX)
        finally:
            if res is not None:
                res.destroy()
    comm.barrier()
    wall = MPI.Wtime() - t0

    def spent(stage: PETSc.Log.Stage, names: Sequence[str]) -> float:
        return sum(_event_seconds(comm, stage, (n,)) - before[(stage.id, n)] for n in names)

    count_lu, tiles_lu = spent(st_count, LU_EVENTS), spent(st_tiles, LU_EVENTS)
    rss = comm.allreduce(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, op=MPI.MAX)
    return {"ranks": comm.size, "unknowns": unknowns, "nx": nx, "ny": ny,
            "box_re_min": bx[0], "box_re_max": bx[1], "box_im_max": bx[3], "found": found,
            "counted": "" if counted is None else counted,
            "closed": "" if counted is None else found == counted, "wall": wall, "setup": t_setup,
            "count": t_count, "count_evaluations": info["evaluations"], "count_lu": count_lu,
            "tiles_time": t_tiles, "tiles": tiles, "tiles_lu": tiles_lu,
            "tiles_solve": spent(st_tiles, ("MatSolve",)),
            "lu_share": (count_lu + tiles_lu) / wall, "rss_max": rss / 1024.0,
            "mumps_mem_max": float(mumps_mem), "fastest_re": fastest.real,
            "fastest_im": fastest.imag}


def _power_fit(n: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """``(a, b)`` of ``y = a n^b`` by least squares on the logarithms (one point: ``b = 1``)."""
    if len(set(n.tolist())) < 2:
        return float(np.mean(y / n)), 1.0
    b, log_a = np.polyfit(np.log(n), np.log(y), 1)
    return float(math.exp(log_a)), float(b)


def fit_cost_model(rows: Sequence[dict]) -> dict[int, dict[str, float]]:
    """Per number of ranks: the count's and the tiles' time per operation, power laws in ``N``.

    ``count = a_count N^b_count E`` (``E`` = ``count_evaluations``, one LU factorisation each;
    rows with a count only) and ``tiles_time = a_tile N^b_tile T`` (``T`` = ``tiles``, one
    factorisation plus the Krylov-Schur iterations each), least squares on the logarithms over
    the unknowns ``N``. ``count_error`` and ``tile_error``: the largest ``|model / measured - 1|``
    over the rows fitted (``nan`` without rows).

    Args:
        rows: Rows of :data:`COLUMNS` (values may be strings, as read from the CSV).
    """
    out: dict[int, dict[str, float]] = {}
    for ranks in sorted({int(r["ranks"]) for r in rows}):
        sel = [r for r in rows if int(r["ranks"]) == ranks]
        entry: dict[str, float] = {"points": len(sel)}
        for key, ops, secs in (("count", "count_evaluations", "count"),
                               ("tile", "tiles", "tiles_time")):
            use = [r for r in sel if float(r[ops]) > 0]
            if not use:
                entry.update({f"a_{key}": math.nan, f"b_{key}": math.nan,
                              f"{key}_error": math.nan})
                continue
            n = np.array([float(r["unknowns"]) for r in use])
            m = np.array([float(r[ops]) for r in use])
            t = np.array([float(r[secs]) for r in use])
            a, b = _power_fit(n, t / m)
            entry.update({f"a_{key}": a, f"b_{key}": b,
                          f"{key}_error": float(np.max(np.abs(a * n**b * m / t - 1.0)))})
        out[ranks] = entry
    return out


#: The plan line's model (one rank), power laws through two measured points each
#: (2026-11-25): a tile solve 27 ms at 170 unknowns (load 1) and 97 s at 201 294 (np1, load
#: 3-14); a count evaluation 1.0 ms at 170 (load 1) and 0.41 s at 49 454 (count50k_np1,
#: load 3); 12 tiles and 1024 count evaluations (the default box).
PLAN_MODEL = {"a_tile": 7.1e-5, "b_tile": 1.157, "a_count": 4.3e-6, "b_count": 1.06}
PLAN_TILES, PLAN_EVALUATIONS = 12, 1024


def estimate_seconds(sizes: Sequence[int], count_up_to: int) -> float:
    """Up-front estimate of a scale run (one rank, seconds).

    :func:`predict` of :data:`PLAN_MODEL` per size, the count only for the sizes up to
    ``count_up_to``.
    """
    return float(sum(predict(PLAN_MODEL, n, PLAN_EVALUATIONS if n <= count_up_to else 0,
                             PLAN_TILES) for n in sizes))


def predict(model: dict[str, float], unknowns: float, evaluations: float, tiles: float) -> float:
    """Seconds of count + tiles by a model of :func:`fit_cost_model`."""
    return (model["a_count"] * unknowns ** model["b_count"] * evaluations
            + model["a_tile"] * unknowns ** model["b_tile"] * tiles)



def _fmt(v: float, digits: int = 3) -> str:
    return "-" if not math.isfinite(v) else f"{v:.{digits}g}"


def _load(row: dict) -> str:
    """Load average before-after a row (one value in rows written with a single ``load``)."""
    if "load_start" in row:
        return f"{float(row['load_start']):.0f}-{float(row['load_end']):.0f}"
    return f"{float(row['load']):.0f}"


def markdown_table(rows: Sequence[dict]) -> str:
    """The README's table of the measured rows and the fitted model (recomputed by the tests).

    Args:
        rows: Rows of :data:`COLUMNS` (values may be strings, as read from the CSV), any ranks.
    """
    head = ("| ranks | unknowns | wall s | count s (E) | tiles s (T) | LU share | peak RSS"
            " MiB/rank | found / counted | load |\n|---|---|---|---|---|---|---|---|---|")
    lines = [head]
    for r in sorted(rows, key=lambda r: (int(r["ranks"]), int(r["unknowns"]))):
        counted = r["counted"] if str(r["counted"]) != "" else "not counted"
        lines.append(f"| {int(r['ranks'])} | {int(r['unknowns'])} | {_fmt(float(r['wall']))} | "
                     f"{_fmt(float(r['count']))} ({int(r['count_evaluations'])}) | "
                     f"{_fmt(float(r['tiles_time']))} ({int(r['tiles'])}) | "
                     f"{float(r['lu_share']):.2f} | {float(r['rss_max']):.0f} | "
                     f"{int(r['found'])} / {counted} | {_load(r)} |")
    lines.append("")
    for ranks, m in fit_cost_model(rows).items():
        lines.append(f"- {ranks} rank(s), {m['points']} sizes: per count LU "
                     f"{_fmt(m['a_count'])} N^{_fmt(m['b_count'])} s (largest error "
                     f"{_fmt(100 * m['count_error'], 2)} %), per tile solve "
                     f"{_fmt(m['a_tile'])} N^{_fmt(m['b_tile'])} s (largest error "
                     f"{_fmt(100 * m['tile_error'], 2)} %)")
    return "\n".join(lines) + "\n"
