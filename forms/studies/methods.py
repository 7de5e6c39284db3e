"""Where methods fail: each way of finding the eigenvalues of the 1D model in ``R`` vs the count.

The computation behind ``workflows/methods_chart.py``. At one ``k`` and one region size
``c_max`` the 1D section model (:class:`forms.models.section.SectionModel`, the sweep's default
discretisation for that region) is solved by:

- ``tiling``: shift-and-invert Krylov-Schur PEP over a tiling of the box
  (:class:`forms.solvers.region.RegionSolver`, told the banded count so it stops once found);
- ``dense``: the companion linearisation (:func:`forms.solvers.slepc.
  dense_companion_eigenvalues`), skipped (``failed``) above :data:`DENSE_MAX` pencil rows;
- ``moments``: the sweep's default FE-first path (:meth:`forms.solvers.banded.BandedOperator.
  moment_eigs` inside :class:`forms.solvers.certified.CertifiedSolver`, no exact root used).

Truth: the union of all methods' values inside the box, each polished by banded Newton,
deduplicated; its size is compared with the banded argument-principle count
(:meth:`forms.solvers.banded.BandedOperator.count`) and the row says whether they agree.
Per method: ``found`` (truth values within ``rtol`` of one of its values), ``missed``
(``count - found``), ``spurious`` (its values in the box not within ``rtol`` of a truth value),
wall seconds. A method that raises is a row with ``failed`` set, never a crash.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from mpi4py import MPI

from analytic.numerics.roots import Box
from analytic.numerics.spectrum import Region
from analytic.params import Params
from forms.solvers.banded import BandedOperator
from forms.solvers.certified import CertifiedSolver, default_discretisation
from forms.solvers.region import RegionSolver
from forms.solvers.slepc import dense_companion_eigenvalues

#: Methods in the order of the chart.
METHODS = ("tiling", "dense", "moments")
#: Options prefix of the tiling's PEP (its determinant LU: ``methods_tiling_det_``).
PREFIXES = ("methods_tiling_",)
#: Largest companion pencil (degree x unknowns) for scipy eig (measured: 2x250 rows took 19 s).
DENSE_MAX = 400
#: CSV columns of a row.
COLUMNS = ("k", "c_max", "method", "unknowns", "count", "truth", "found", "missed",
           "spurious", "seconds", "failed")


def _in_box(z: complex, box: Box) -> bool:
    return box[0] <= z.real <= box[1] and box[2] <= z.imag <= box[3]


def _near(z: complex, values: list[complex], rtol: float) -> bool:
    return any(abs(z - v) <= rtol * max(1.0, abs(v)) for v in values)


def _truth(fe: BandedOperator, candidates: list[complex], box: Box, rtol: float) -> list[complex]:
    """Candidates polished by banded Newton, kept inside ``box``, deduplicated."""
    out: list[complex] = []
    for z in candidates:
        try:
            e = fe.newton(z)
        except Exception:  # noqa: BLE001 - a candidate Newton cannot polish is not truth
            continue
        v = complex(e.value)
        if np.isfinite(v) and _in_box(v, box) and abs(v - z) <= 1e-3 * max(1.0, abs(z)) \
                and not _near(v, out, rtol):
            out.append(v)
    return out


def _run(fn: Callable[[], list[complex]]) -> tuple[list[complex], float, str]:
    t0 = time.perf_counter()
    try:
        vals = fn()
        return vals, time.perf_counter() - t0, ""
    except Exception as err:  # noqa: BLE001 - a failing method is a result, not a crash
        return [], time.perf_counter() - t0, f"{type(err).__name__}: {err}"[:120]


def methods_point(params: Params, k: float, c_max: float, rtol: float = 1e-6,
                  methods: tuple[str, ...] = METHODS) -> list[dict]:
    """One row per method at ``(k, c_max)`` (module docstring); runs on ``MPI.COMM_SELF``.

    Args:
        params: Parameters (finite ``H``).
        k: Wavenumber.
        c_max: Region size (largest phase velocity, :class:`Region`).
        rtol: Relative distance under which two eigenvalues are the same.
        methods: Subset of :data:`METHODS`.
    """
    region = Region(c_max=c_max)
    degree, cells, ratio = default_discretisation(params, region, k)
    cs = CertifiedSolver(params, region, degree, cells, ratio, k, 1e-8, check_exact=False)
    box = region.box(params, k)
    try:
        fe = cs.banded[0].operator(k)
        op = cs.models[0].operator(k)
        n, deg = cs.unknowns, len(op.matrices) - 1
        count = fe.count(box)

        def tiling() -> list[complex]:
            rs = RegionSolver(MPI.COMM_SELF, prefix=PREFIXES[0], max_tiles=60)
            rs.pep.setFromOptions()
            try:
                res = rs.solve(op.matrices, box, count=False, expected=count)
                vals = [complex(v) for v in res.values]
                res.destroy()
            finally:
                rs.destroy()
            return vals

        def dense() -> list[complex]:
            if deg * n > DENSE_MAX:
                raise RuntimeError(f"pencil {deg * n} > DENSE_MAX = {DENSE_MAX}")
            return [complex(v) for v in dense_companion_eigenvalues(op)]

        def moments() -> list[complex]:
            res = cs.solve(k, box=box)
            return [complex(r["re_lambda"], r["im_lambda"]) for r in res.rows]

        fns = {"tiling": tiling, "dense": dense, "moments": moments}
        runs = {m: _run(fns[m]) for m in methods}
        cands = [v for vals, _, _ in runs.values() for v in vals if _in_box(v, box)]
        truth = _truth(fe, cands, box, rtol)
        rows = []
        for m, (vals, sec, why) in runs.items():
            inside = [v for v in vals if _in_box(v, box)]
            found = sum(_near(t, inside, rtol) for t in truth)
            rows.append({"k": float(k), "c_max": float(c_max), "method": m, "unknowns": n,
                         "count": count, "truth": len(truth), "found": found,
                         "missed": count - found,
                         "spurious": sum(not _near(v, truth, rtol) for v in inside),
                         "seconds": sec, "failed": why})
        return rows
    finally:
        cs.destroy()


def methods_grid(params: Params, ks: list[float], c_maxes: list[float], rtol: float = 1e-6,
                 methods: tuple[str, ...] = METHODS, comm: MPI.Comm = MPI.COMM_WORLD
                 ) -> list[dict]:
    """Rows of every ``(k, c_max)``, points shared round-robin over the ranks (all get all)."""
    points = [(k, c) for k in ks for c in c_maxes]
    mine = [row for i, (k, c) in enumerate(points) if i % comm.size == comm.rank
            for row in methods_point(params, k, c, rtol, methods)]
    rows = [r for part in comm.allgather(mine) for r in part]
    return sorted(rows, key=lambda r: (r["k"], r["c_max"], METHODS.index(r["method"])))
