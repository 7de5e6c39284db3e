"""Where methods fail: each way of finding the eigenvalues of the 1D model in ``R`` vs the count.

The computation behind ``workflows/methods_chart.py``. At one ``k`` and one region size
``c_max`` the 1D section model (:class:`forms.models.section.SectionModel`, the sweep's default
discretisation for that region) is solved by:

- ``tiling``: shift-and-invert Krylov-Schur PEP over a tiling of the box
  (:class:`forms.solvers.region.RegionSolver`, told the banded count so it stops once found);
- ``dense``: the companion linearisation (:func:`forms.solvers.slepc.
  dense_companion_eigenvalues`), skipped (``failed``) above :data:`DENSE_MAX` pencil rows;
- ``linear``: the sweep's default FE-first path (``CertifiedSolver(solver="linear")``): the
  eigenvalues of the linearised condensed form
  (:meth:`forms.solvers.condensed.CondensedOperator.linear_eigs`) Newton-polished, the moments
  where they fall short of the count; its time includes its count and the ``p + 1``
  estimates;
- ``moments``: the FE-first path with contour moments only (:meth:`forms.solvers.banded.
  BandedOperator.moment_eigs` inside ``CertifiedSolver(solver="moments")``, no exact root
  used; the sweep's ``--solver moments``, its default before 2026-11-28);
- ``ciss``: SLEPc PEP CISS (contour integral, Sakurai-Sugiura) on the polynomial form, the
  region an RG ellipse through the corners of the box (SLEPc 3.18's PEP CISS rejects an RG
  interval, PETSc error 56), :data:`CISS_POINTS` quadrature points;
- ``nleigs``: SLEPc NEP NLEIGS on the split form (``1/(Lambda + 1)`` a rational FN, problem
  type ``RATIONAL``), the region an RG interval equal to the box, target its centre, told the
  count as ``nev`` (like the tiling), ``ncv`` by :func:`nleigs_ncv`;
- ``newton``: the exact-seeded path (``CertifiedSolver(solver="newton")``, the sweep's
  ``--solver newton``): the exact roots in the box (no followed families, so the search in the
  box is part of its time), each the start of a banded Newton iteration.

Truth: the union of all methods' values inside the box, each polished by banded Newton,
deduplicated; its size is compared with the banded argument-principle count
(:meth:`forms.solvers.banded.BandedOperator.count`) and the row says whether they agree.
Per method: ``found`` (truth values within ``rtol`` of one of its values), ``missed``
(``count - found``), ``spurious`` (its values in the box not within ``rtol`` of a truth value),
wall seconds. A method that raises, or reports no convergence (a SLEPc converged reason that
is not ``CONVERGED_*``, an exact-seeded Newton that did not converge), is a row with ``failed``
set to the reason, never a crash; the converged values a non-converged SLEPc run did return
still count as found (each met SLEPc's tolerance).
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from mpi4py import MPI
from petsc4py import PETSc
from slepc4py import SLEPc

from analytic.numerics.roots import Box
from analytic.numerics.spectrum import Region
from analytic.params import Params
from forms.friction import FrictionOperator
from forms.models.section import SectionModel, contour_samples
from forms.solvers.banded import BandedOperator
from forms.solvers.certified import CertifiedSolver, default_discretisation
from forms.solvers.region import RegionSolver
from forms.solvers.slepc import collect_pairs, dense_companion_eigenvalues, rational_fn

#: Methods in the order of the chart.
METHODS = ("tiling", "dense", "linear", "moments", "ciss", "nleigs", "newton")
#: Options prefixes: the tiling's PEP (its determinant LU: ``methods_tiling_det_``), the CISS
#: PEP, the NLEIGS NEP.
PREFIXES = ("methods_tiling_", "methods_ciss_", "methods_nleigs_")
#: CISS quadrature points on the ellipse (SLEPc's default 32 missed 1 of 3 at k = 2, c_max = 2,
#: measured 2026-11-24; 128 found all 3).
CISS_POINTS = 128
#: CISS moment size: SLEPc's default 8, set because ``setCISSSizes`` otherwise takes
#: ``CISS_POINTS / 4`` (with 32 moments: 0 of 3 found and 4 spurious, same point and day).
CISS_MOMENTS = 8
#: Largest height / width of one CISS ellipse's box (:func:`ciss_pieces`). One ellipse over the
#: whole box (height / width 216 at k = 12, c_max = 8) found 0 of 23 (test_methods_chart.py);
#: with 256 or 512 points 8 and 0 (tried once, 2026-11-24).
CISS_ASPECT = 8.0
#: (The ellipses scaled by 1.25 about their centres, to keep the corners off the contour, found
#: fewer at k = 12, c_max = 8: 15 of 23 against 20, 2026-11-24; not used.)
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


def nleigs_ncv(nev: int) -> int:
    """NLEIGS subspace size for ``nev`` wanted pairs.

    SLEPc's default missed 1 of 3 at k = 2, c_max = 2 (``ncv = 60`` found all; 2026-11-24).
    """
    return max(4 * nev, 40)


def _slepc_reason(reason: str) -> str:
    return "" if reason.startswith("CONVERGED") else f"SLEPc {reason}"


def ciss_pieces(box: Box) -> list[Box]:
    """The box cut along ``Im`` into pieces no taller than :data:`CISS_ASPECT` widths."""
    width, height = box[1] - box[0], box[3] - box[2]
    m = max(1, int(np.ceil(height / (CISS_ASPECT * width))))
    cuts = np.linspace(box[2], box[3], m + 1)
    return [(box[0], box[1], float(cuts[i]), float(cuts[i + 1])) for i in range(m)]


def _ciss_pep(op: FrictionOperator, piece: Box, prefix: str) -> SLEPc.PEP:
    """A PEP CISS on the ellipse through the corners of ``piece`` (setters, options last)."""
    cx, cy = 0.5 * (piece[0] + piece[1]), 0.5 * (piece[2] + piece[3])
    a, b = 0.5 * (piece[1] - piece[0]), 0.5 * (piece[3] - piece[2])
    pep = SLEPc.PEP().create(MPI.COMM_SELF)
    pep.setOperators(op.matrices)
    pep.setType(SLEPc.PEP.Type.CISS)
    pep.setProblemType(SLEPc.PEP.ProblemType.GENERAL)
    pep.setTolerances(tol=1e-10)
    pep.setCISSSizes(ip=CISS_POINTS, ms=CISS_MOMENTS)
    rg = pep.getRG()
    rg.setType(SLEPc.RG.Type.ELLIPSE)
    rg.setEllipseParameters(complex(cx, cy), np.sqrt(2.0) * a, b / a)
    pep.setOptionsPrefix(prefix)
    pep.setFromOptions()
    return pep


def ciss_values(op: FrictionOperator, box: Box, prefix: str) -> tuple[list[complex], str]:
    """PEP CISS on each piece of :func:`ciss_pieces`.

    A new PEP for each piece: SLEPc 3.18 keeps the first contour when only the RG changes.

    Returns:
        The values inside their own piece, and the SLEPc reasons that were not convergence.
    """
    vals: list[complex] = []
    reasons: set[str] = set()
    for piece in ciss_pieces(box):
        pep = _ciss_pep(op, piece, prefix)
        try:
            pep.solve()
            res = collect_pairs(pep, SLEPc.PEP.ConvergedReason, op, 0.0)
        finally:
            pep.destroy()
        vals += [p.value for p in res.pairs if _in_box(p.value, piece)
                 and not _near(p.value, vals, 1e-9)]
        res.destroy()
        reasons.add(_slepc_reason(res.reason))
    return vals, ", ".join(sorted(r for r in reasons if r))


def nleigs_values(model: SectionModel, k: float, box: Box, nev: int, prefix: str
                  ) -> tuple[list[complex], str]:
    """NEP NLEIGS (split form) in the RG interval ``box``, ``nev`` pairs nearest its centre."""
    op = model.operator(k)
    centre = complex(0.5 * (box[0] + box[1]), 0.5 * (box[2] + box[3]))
    nep = SLEPc.NEP().create(MPI.COMM_SELF)
    fns = [rational_fn(MPI.COMM_SELF, f) for f in op.functions]
    try:
        nep.setSplitOperator(op.matrices, fns, PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
        nep.setType(SLEPc.NEP.Type.NLEIGS)
        nep.setProblemType(SLEPc.NEP.ProblemType.RATIONAL)
        nep.setTarget(centre)
        nep.setWhichEigenpairs(SLEPc.NEP.Which.TARGET_MAGNITUDE)
        nep.setDimensions(nev=max(nev, 1), ncv=nleigs_ncv(nev))
        nep.setTolerances(tol=1e-10, maxit=100)
        rg = nep.getRG()
        rg.setType(SLEPc.RG.Type.INTERVAL)
        rg.setIntervalEndpoints(*box)
        for ksp in nep.getNLEIGSKSPs():
            ksp.setType(PETSc.KSP.Type.PREONLY)
            ksp.getPC().setType(PETSc.PC.Type.LU)
            ksp.getPC().setFactorSolverType("mumps")
        nep.setOptionsPrefix(prefix)
        nep.setFromOptions()
        nep.solve()
        res = collect_pairs(nep, SLEPc.NEP.ConvergedReason, op, centre)
        vals = [p.value for p in res.pairs]
        res.destroy()
        return vals, _slepc_reason(res.reason)
    finally:
        nep.destroy()
        for f in fns:
            f.destroy()


def _run(fn: Callable[[], tuple[list[complex], str]]) -> tuple[list[complex], float, str]:
    t0 = time.perf_counter()
    try:
        vals, why = fn()
        return vals, time.perf_counter() - t0, why
    except Exception as err:  # noqa: BLE001 - a failing method is a result, not a crash
        return [], time.perf_counter() - t0, f"raised {type(err).__name__}: {err}"[:120]


def _seeded(cs: CertifiedSolver, k: float, region: Region, box: Box
            ) -> tuple[list[complex], str]:
    """Exact-seeded Newton (``--solver newton``): its values and what did not converge."""
    res = cs.solve(k, [], region)
    bad = sum("Newton did not converge" in r["status"] for r in res.rows)
    why = f"Newton did not converge from {bad} exact root(s)" if bad else ""
    if res.note and not why:
        why = res.note if "failed" in res.note else ""
    return [complex(r["re_lambda"], r["im_lambda"]) for r in res.rows], why


def _methods(params: Params, cs: CertifiedSolver, k: float, region: Region, count: int,
             solvers: dict) -> dict[str, Callable[[], tuple[list[complex], str]]]:
    """The methods as functions of nothing (their models built beforehand)."""
    box = region.box(params, k)
    op = cs.models[0].operator(k)
    n, deg = cs.unknowns, len(op.matrices) - 1

    def tiling() -> tuple[list[complex], str]:
        rs = RegionSolver(MPI.COMM_SELF, prefix=PREFIXES[0], max_tiles=60)
        rs.pep.setFromOptions()
        try:
            res = rs.solve(op.matrices, box, count=False, expected=count)
            vals = [complex(v) for v in res.values]
            res.destroy()
        finally:
            rs.destroy()
        return vals, ""

    def dense() -> tuple[list[complex], str]:
        if deg * n > DENSE_MAX:
            raise RuntimeError(f"pencil {deg * n} > DENSE_MAX = {DENSE_MAX}")
        return [complex(v) for v in dense_companion_eigenvalues(op)], ""

    def certified(solver: CertifiedSolver) -> tuple[list[complex], str]:
        res = solver.solve(k, box=box)
        return [complex(r["re_lambda"], r["im_lambda"]) for r in res.rows], ""

    return {"tiling": tiling, "dense": dense, "moments": lambda: certified(cs),
            "linear": lambda: certified(solvers["linear"]),
            "ciss": lambda: ciss_values(op, box, PREFIXES[1]),
            "nleigs": lambda: nleigs_values(solvers["split"], k, box, count, PREFIXES[2]),
            "newton": lambda: _seeded(solvers["newton"], k, region, box)}


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
    cs = CertifiedSolver(params, region, degree, cells, ratio, k, 1e-8, check_exact=False,
                         solver="moments")
    box = region.box(params, k)
    solvers: dict = {}  # models of the other methods, built outside their timing
    try:
        if "linear" in methods:
            solvers["linear"] = CertifiedSolver(params, region, degree, cells, ratio, k, 1e-8,
                                                check_exact=False)
        if "nleigs" in methods:
            solvers["split"] = SectionModel(MPI.COMM_SELF, cs.models[0].stack, params,
                                            degree=degree, form="split")
        if "newton" in methods:
            solvers["newton"] = CertifiedSolver(params, region, degree, cells, ratio, k, 1e-8,
                                                solver="newton")
        fe = cs.banded[0].operator(k)
        count = fe.count(box, contour_samples(cs.models[0].stack, box))
        fns = _methods(params, cs, k, region, count, solvers)
        runs = {m: _run(fns[m]) for m in methods}
        cands = [v for vals, _, _ in runs.values() for v in vals if _in_box(v, box)]
        truth = _truth(fe, cands, box, rtol)
        rows = []
        for m, (vals, sec, why) in runs.items():
            inside = [v for v in vals if _in_box(v, box)]
            found = sum(_near(t, inside, rtol) for t in truth)
            rows.append({"k": float(k), "c_max": float(c_max), "method": m,
                         "unknowns": cs.unknowns, "count": count, "truth": len(truth),
                         "found": found, "missed": count - found,
                         "spurious": sum(not _near(v, truth, rtol) for v in inside),
                         "seconds": sec, "failed": why})
        return rows
    finally:
        for s in solvers.values():
            s.destroy()
        cs.destroy()


#: Seconds of one ``(k, c_max)`` point (every method) per ``(W H)^2``, ``W`` the region's
#: height. Measured on this 2-core machine (2026-11-25, load 8, one rank): the default
#: points (``k = 0.5, 2, 6`` x ``c_max = 2, 4``, ``W H`` = 13.6-36.6) 1.8, 1.9, 1.1, 2.0, 5.7,
#: 12.1 s (model 1.7, 1.9, 2.5, 3.8, 5.4, 12.1 s).
SECONDS_PER_WH2 = 9e-3


def estimate_seconds(params: Params, ks: list[float], c_maxes: list[float], ranks: int) -> float:
    """Estimated seconds of :func:`methods_grid` (points round-robin over ``ranks``)."""
    costs = [SECONDS_PER_WH2 * (Region(c_max=c).im_max(params, k) * params.H) ** 2
             for k in ks for c in c_maxes]
    return max(sum(costs[r::ranks]) for r in range(max(1, ranks)))


def methods_grid(params: Params, ks: list[float], c_maxes: list[float], rtol: float = 1e-6,
                 methods: tuple[str, ...] = METHODS, comm: MPI.Comm = MPI.COMM_WORLD
                 ) -> list[dict]:
    """Rows of every ``(k, c_max)``, points shared round-robin over the ranks (all get all)."""
    points = [(k, c) for k in ks for c in c_maxes]
    mine = [row for i, (k, c) in enumerate(points) if i % comm.size == comm.rank
            for row in methods_point(params, k, c, rtol, methods)]
    rows = [r for part in comm.allgather(mine) for r in part]
    return sorted(rows, key=lambda r: (r["k"], r["c_max"], METHODS.index(r["method"])))
