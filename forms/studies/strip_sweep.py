"""Every eigenvalue of the 2D Bloch strip cell in a box, each with its dominant harmonic.

The cell of :mod:`forms.studies.strip_mode` (``wavelengths`` wavelengths ``2 pi / k`` long,
built by :func:`forms.studies.strip_mode.bloch_strip`) is solved by the region solver
(:class:`forms.solvers.region.RegionSolver`, options prefix ``strip_region_``, the count's LU
``strip_region_det_``) with no exact root as input: the argument-principle count on
``log det T_h`` (MUMPS) and shift-and-invert over tiles. A cell of ``w`` wavelengths also holds
the modes of wavenumbers ``k (1 + m / w)``; each eigenvalue carries the dominant one
(:attr:`forms.models.strip.StripMode.harmonic` ``m``) as ``harmonic = 1 + m / w``
(wavenumber ``harmonic * k``): harmonic 1 is the cross-section set at ``k``, the others the
cross-section set at ``harmonic * k``. Collective on the mesh communicator.

Convergence estimate (the cross-section sweep's rule, :mod:`forms.solvers.certified` step 3):
each eigenvalue ``z`` of the degree-``p`` cell is followed to the degree ``p + 1`` cell on the
same mesh (:func:`refine_values`: one shift-and-invert PEP solve at ``z``, options prefix
``strip_estimate_``; the nearest converged eigenvalue ``w``) and ``|z - w| / |w|`` is its
``error_estimate``; ``w`` must be mutual (no other ``z`` nearer it). A row carries the
certificate ``fe`` when the count closed, its estimate is within ``rtol`` and its partner is
mutual (:func:`strip_rows`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from mpi4py import MPI

from analytic.numerics.roots import ContourError
from analytic.numerics.spectrum import Region
from analytic.params import Params
from analytic.physics.tail import velocity_scale
from forms.mode_postprocessing import harmonic_content
from forms.models.strip import build_strip_problem, friction_operator_for
from forms.solvers.certified import CertifiedSolver, default_discretisation
from forms.solvers.slepc import shift_off, sinvert_pep
from forms.studies.block import NODES_PER_WAVELENGTH, region_session
from forms.studies.strip_mode import bloch_strip
from forms.studies.sweep import RungSolvers, climb

PREFIX = "strip_region_"
"""Options prefix of the strip's region solve (the count's LU: ``strip_region_det_``)."""
ESTIMATE_PREFIX = "strip_estimate_"
"""Options prefix of the ``p + 1`` solves of the convergence estimate (:func:`refine_values`)."""
PREFIXES = (PREFIX, PREFIX + "det_", ESTIMATE_PREFIX)
"""Every options prefix of the strip's SLEPc/PETSc objects."""
EXTRA_FIELDS = ("harmonic", "rel_distance_1d")
"""The strip's columns after the cross-section sweep's (``harmonic``: wavenumber / ``k``)."""


@dataclass
class StripSpectrum:
    """Eigenvalues of the Bloch cell at ``k`` in a box.

    Attributes:
        k: Wavenumber.
        box: The box used.
        values: Eigenvalues (decreasing real part).
        residuals: Relative residuals.
        harmonics: Wavenumber of each mode in units of ``k`` (1: the mode ``exp(-i k x)``).
        counted: Argument-principle count.
        closed: ``found == counted``.
        unknowns: Size of ``T_h``.
        seconds: Timings (``solve``, ``count``, ``harmonics``, ``estimate``).
        fine: The degree ``p + 1`` partner of each value (:func:`refine_values`; NaN: none
            converged); ``None``: no estimate made.
        fine_unknowns: Size of the degree ``p + 1`` ``T_h`` (0: no estimate).
        next_values: Each value continued to the sweep's next ``k``
            (:func:`continue_values`); ``None``: not continued (the last ``k``).
    """

    k: float
    box: tuple
    values: np.ndarray
    residuals: np.ndarray
    harmonics: np.ndarray
    counted: int | None
    closed: bool
    unknowns: int
    seconds: dict = field(default_factory=dict)
    fine: np.ndarray | None = None
    fine_unknowns: int = 0
    next_values: np.ndarray | None = None

    def rows(self) -> list[dict]:
        """One dict per eigenvalue (``k``, ``re``, ``im``, ``harmonic``, ``residual``)."""
        return [{"k": self.k, "re": z.real, "im": z.imag, "harmonic": float(h),
                 "residual": float(r)}
                for z, h, r in zip(self.values, self.harmonics, self.residuals, strict=True)]


def strip_spectrum(comm: MPI.Comm, params: Params, k: float, box: Sequence[float], *,
                   wavelengths: int = 1, cells_per_wavelength: int = 12, ny: int = 6,
                   degree: int = 2, nev: int = 12, estimate: bool = True) -> StripSpectrum:
    """Every eigenvalue of the Bloch cell at ``k`` in ``box`` with its harmonic (collective).

    Args:
        comm: Mesh communicator (the whole communicator: MUMPS factorises in parallel).
        params: Parameters (``H`` finite).
        k: Wavenumber (> 0).
        box: ``(re_min, re_max, im_min, im_max)`` (``re_min > -1``).
        wavelengths: Cell length in wavelengths ``2 pi / k``.
        cells_per_wavelength: Cells along ``x`` per wavelength.
        ny: Cells along ``y``.
        degree: Lagrange degree.
        nev: Eigenpairs per shift-and-invert tile.
        estimate: Also follow each eigenvalue to degree ``degree + 1`` on the same mesh
            (:func:`refine_values`), for the convergence estimate.

    Returns:
        :class:`StripSpectrum`; every PETSc object destroyed.
    """
    strip = bloch_strip(comm, params, k, wavelengths, cells_per_wavelength, ny)
    problem = build_strip_problem(strip, params, k=k, degree=degree)
    with region_session(comm, problem, nev, PREFIX) as (op, solver):
        res = None
        try:
            res = solver.solve(op.matrices, box, op.law.spurious, count=True,
                               cleared_rows=op.cleared_rows)
            t0 = MPI.Wtime()
            harmonics = []
            for v in res.vectors:
                content = harmonic_content(problem, problem.to_function(v))
                m = max(content, key=content.get)
                harmonics.append(1.0 + m / wavelengths)
            t_h = MPI.Wtime() - t0
            out = StripSpectrum(float(k), tuple(res.box), res.values.copy(), res.residuals.copy(),
                                np.array(harmonics, dtype=float), res.counted, res.closed,
                                int(op.matrices[0].getSize()[0]),
                                {**res.seconds, "harmonics": t_h})
        finally:
            if res is not None:
                res.destroy()
    if estimate:
        t0 = MPI.Wtime()
        out.fine, out.fine_unknowns = refine_values(strip, params, k, degree + 1, out.values)
        out.seconds["estimate"] = MPI.Wtime() - t0
    return out


def refine_values(strip: object, params: Params, k: float, degree: int,
                  values: np.ndarray, nev: int = 2) -> tuple[np.ndarray, int]:
    """The eigenvalue of the degree-``degree`` cell on ``strip`` nearest each of ``values``.

    One shift-and-invert PEP solve (TOAR, MUMPS LU, options prefix :data:`ESTIMATE_PREFIX`)
    per value, the shift moved off it by ``1e-6`` (:func:`forms.solvers.slepc.shift_off`):
    one factorisation per eigenvalue, no count (measured at ``k = 4``, P2 -> P3, 12 x 6 cells:
    0.065 s an eigenvalue against 13 s for the P2 region solve with its count). Collective;
    the same values on every rank.

    Returns:
        ``(partners, unknowns)``: NaN where no pair converged; the size of the finer ``T_h``.
    """
    out = np.full(len(values), complex(np.nan, np.nan))
    if not len(values):
        return out, 0
    problem = build_strip_problem(strip, params, k=k, degree=degree)
    op = friction_operator_for(problem)
    pep = sinvert_pep(strip.comm, nev, 1e-12, 300, ESTIMATE_PREFIX)
    try:
        mats = op.matrices
        for j, z in enumerate(values):
            pep.setOperators(mats)  # resets the state: the new target is taken
            pep.setTarget(shift_off(complex(z), 1e-6))
            pep.solve()
            got = [complex(pep.getEigenpair(i)) for i in range(pep.getConverged())]
            if got:
                out[j] = min(got, key=lambda w, z=z: abs(w - z))
        return out, int(mats[0].getSize()[0])
    finally:
        pep.destroy()
        op.destroy()
        problem.destroy()


def continue_values(comm: MPI.Comm, params: Params, ks: Sequence[float], values: np.ndarray,
                    *, cells_per_wavelength: int = 12, ny: int = 6, degree: int = 2,
                    nev: int = 2) -> tuple[np.ndarray, int]:
    """Each of ``values`` (eigenvalues of the cell at ``ks[0]``) followed to ``ks[-1]``.

    At every further ``k`` of ``ks`` the cell of one wavelength (the mesh rule of
    :func:`strip_spectrum`: at the last ``k`` it is the sweep's own cell) is built and each
    value's predictor (secant through its last two points, or its last point) starts one
    shift-and-invert PEP solve (options prefix :data:`ESTIMATE_PREFIX`); the nearest converged
    eigenvalue is kept. No count: these are the links of the labels
    (:func:`forms.studies.sweep.label_by_continuation`), not a certificate. Collective.

    Returns:
        ``(values at ks[-1], factorisations)``; NaN where no pair converged.
    """
    path = [np.asarray(values, dtype=complex)]
    factorisations = 0
    for k in ks[1:]:
        strip = bloch_strip(comm, params, float(k), 1, cells_per_wavelength, ny)
        problem = build_strip_problem(strip, params, k=float(k), degree=degree)
        op = friction_operator_for(problem)
        pep = sinvert_pep(comm, nev, 1e-12, 300, ESTIMATE_PREFIX)
        try:
            now = np.full(len(values), complex(np.nan, np.nan))
            guess = 2.0 * path[-1] - path[-2] if len(path) > 1 else path[-1]
            for j, z in enumerate(guess):
                if np.isnan(z):
                    continue
                pep.setOperators(op.matrices)
                pep.setTarget(shift_off(complex(z), 1e-6))
                pep.solve()
                factorisations += 1
                got = [complex(pep.getEigenpair(i)) for i in range(pep.getConverged())]
                if got:
                    now[j] = min(got, key=lambda w, z=z: abs(w - z))
            path.append(now)
        finally:
            pep.destroy()
            op.destroy()
            problem.destroy()
    return path[-1], factorisations


def estimates(values: np.ndarray, fine: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """``|z - w| / |w|`` of each value ``z`` and its ``p + 1`` partner ``w``, and mutuality.

    Returns:
        ``(estimate, mutual)``: NaN (and not mutual) without a partner; ``mutual[j]``: no other
        value is nearer the partner of value ``j`` than value ``j`` itself.
    """
    n = len(values)
    if fine is None:
        return np.full(n, np.nan), np.zeros(n, dtype=bool)
    fine = np.asarray(fine, dtype=complex)
    est = np.abs(values - fine) / np.abs(fine)
    mutual = np.array([bool(np.isfinite(fine[j]))
                       and int(np.argmin(np.abs(values - fine[j]))) == j for j in range(n)])
    return est, mutual


def c_max_holding(params: Params, k: float, z: complex, omega0: float = 0.0) -> float:
    """The smallest ``c_max`` of :func:`strip_box` whose box at ``k`` holds ``Im z``."""
    return max(0.0, abs(z.imag) - omega0) / (float(k) * velocity_scale(params))


def strip_box(params: Params, k: float, re_min: float, re_max: float, c_max: float,
              omega0: float = 0.0) -> tuple[float, float, float, float]:
    """The strip's box at ``k``: ``re_min <= Re <= re_max``, ``|Im| <= c_max k c_d + omega0``.

    The cross-section sweep's region (:class:`analytic.numerics.spectrum.Region`) with a fixed
    phase-velocity bound ``c_max`` (units of :func:`analytic.physics.tail.velocity_scale`) and
    the allowance ``omega0`` (here 0 by default: no cut-off allowance).
    """
    w = c_max * float(k) * velocity_scale(params) + omega0
    return (float(re_min), float(re_max), -w, w)


def section_sets(params: Params, k: float, harmonics: Sequence[float], box: Sequence[float],
                 rtol: float = 1e-8, degree: int = 0, cells: int = 0) -> dict[float, SectionSet]:
    """The cross-section model's eigenvalues at ``h k`` for every harmonic ``h`` (one process).

    Each set is the complete FE spectrum (:class:`forms.solvers.certified.CertifiedSolver`,
    ``check_exact=False``: no exact root) in ``box`` widened by :func:`_padded` (so that a strip
    eigenvalue near the edge finds its partner just outside). At a negative wavenumber the set
    is the conjugate of the one at ``|h| k`` (the unreduced operators are real); ``h = 0`` is
    ``k = 0``.

    Args:
        params: Parameters.
        k: The strip's wavenumber.
        harmonics: Harmonics whose sets are wanted.
        box: The strip's box.
        rtol: Accuracy that sets the 1D discretisation (:func:`default_discretisation`).
        degree: 1D Lagrange degree (0: from ``rtol``).
        cells: 1D cells (0: from ``rtol``).
    """
    wide = _padded(box)
    hs = sorted({float(h) for h in harmonics})
    q_max = max([abs(h) * k for h in hs] + [k])
    w = max(abs(wide[2]), abs(wide[3]))
    region = Region(re_min=wide[0], re_max=wide[1], c_max=1e-6, omega0=w)
    d, c, ratio = default_discretisation(params, region, q_max, rtol)
    solver = CertifiedSolver(params, region, degree or d, cells or c, ratio, q_max, rtol,
                             check_exact=False)
    out = {}
    for h in hs:
        flip = h < 0
        sub = (wide[0], wide[1], -wide[3], -wide[2]) if flip else tuple(wide)
        res = solver.solve(abs(h) * k, box=sub)
        vals = np.array([complex(r["re_lambda"], r["im_lambda"]) for r in res.rows])
        vals = vals.conj() if flip else vals
        in_box = [z for z in vals if inside(z, box)]
        out[h] = SectionSet(h, abs(h) * k * (-1.0 if flip else 1.0), vals, len(in_box),
                            bool(res.closed))
    return out


def resolved_harmonics(cells_per_wavelength: int, degree: int) -> int:
    """Largest harmonic ``h`` the cell resolves along ``x`` (a stated rule, not a bound).

    The finite block's rule (:func:`forms.studies.block.resolvable_k`): at least
    :data:`forms.studies.block.NODES_PER_WAVELENGTH` nodes per wavelength ``2 pi / (h k)``,
    the cell having ``cells_per_wavelength degree`` nodes per ``2 pi / k``; at least 1.
    """
    return max(1, cells_per_wavelength * degree // NODES_PER_WAVELENGTH)


def fastest_by_harmonic(params: Params, k: float, n: int, rtol: float = 1e-8, degree: int = 0,
                        cells: int = 0) -> list[dict]:
    """The fastest mode of each harmonic ``h = 1 .. n`` of the cell, proven by the 1D model.

    The cell's modes of harmonic ``h`` are the cross-section model's at the wavenumber ``h k``
    (those of ``-h`` their conjugates: the same growth rates), so the fastest mode of the cell
    over the harmonics it resolves is the fastest of these. Each is the cross-section FE's own
    provable region at ``h k`` (:func:`forms.studies.sweep.climb`: no exact root; the region
    grows until the tail bound beyond it is below the fastest eigenvalue inside), the sweep's
    default region and discretisation for ``rtol`` (``degree``, ``cells``: 0 from the rule).
    One process.

    Returns:
        Per harmonic: ``harmonic``, ``wavenumber``, ``re_lambda``, ``im_lambda`` (the fastest
        eigenvalue at ``h k``; NaN: none in the region), ``c_max`` (the bound that
        proves, units of :func:`analytic.physics.tail.velocity_scale`), ``tail_bound``
        (``None``: none derived) and ``proven`` (the count closed and the tail bound is below
        the fastest value; not where no contour of the climb could be used, ``note`` why).
    """
    region = Region(c_max=None)
    rungs = RungSolvers(params, region, n * float(k), rtol, (degree, cells, 0.0),
                        check_exact=False)
    out = []
    try:
        for h in range(1, n + 1):
            try:
                res, c, tb = climb(params, region, h * float(k), [], rungs)
            except ContourError as err:  # no usable contour at the top rung: not proven
                out.append({"harmonic": h, "wavenumber": h * float(k), "re_lambda": math.nan,
                            "im_lambda": math.nan, "c_max": None, "tail_bound": None,
                            "proven": False, "note": str(err)})
                continue
            best = max(res.rows, key=lambda r: (r["re_lambda"], -r["im_lambda"]), default=None)
            z = (complex(math.nan, math.nan) if best is None
                 else complex(best["re_lambda"], best["im_lambda"]))
            target = region.re_min if best is None else z.real
            out.append({"harmonic": h, "wavenumber": h * float(k), "re_lambda": z.real,
                        "im_lambda": z.imag, "c_max": c, "tail_bound": tb,
                        "proven": bool(res.closed and tb is not None and tb < target)})
    finally:
        rungs.destroy()
    return out


def fastest_of(harmonics: Sequence[dict]) -> dict | None:
    """The fastest of :func:`fastest_by_harmonic`'s entries with a value (``None``: none)."""
    return max((f for f in harmonics if math.isfinite(f["re_lambda"])),
               key=lambda f: f["re_lambda"], default=None)


@dataclass
class SectionSet:
    """The cross-section model's eigenvalues at the wavenumber of one harmonic.

    Attributes:
        harmonic: The harmonic ``h`` (wavenumber ``h k``).
        wavenumber: ``h k``.
        values: Every eigenvalue in the widened box.
        in_box: How many of them lie in the strip's box.
        closed: The 1D count closed.
    """

    harmonic: float
    wavenumber: float
    values: np.ndarray
    in_box: int
    closed: bool


def _padded(box: Sequence[float]) -> tuple[float, float, float, float]:
    """``box`` widened by 5 % of its height (imaginary) and 0.05 (real, staying above -1)."""
    re_pad = min(0.05, (box[0] + 1.0) / 2.0)
    im_pad = 0.05 * (box[3] - box[2])
    return (box[0] - re_pad, box[1] + 0.05, box[2] - im_pad, box[3] + im_pad)


def inside(z: complex, box: Sequence[float]) -> bool:
    """``z`` strictly inside ``box`` ``(re_min, re_max, im_min, im_max)``."""
    return box[0] < z.real < box[1] and box[2] < z.imag < box[3]


def compare_with_section(spectrum: StripSpectrum, sets: dict[float, SectionSet]
                         ) -> tuple[np.ndarray, dict]:
    """Distance of each strip eigenvalue to the 1D set of its harmonic, and per-harmonic counts.

    Returns:
        ``(distances, per_harmonic)``: ``min |z - w| / |z|`` over the 1D set ``w`` of the
        eigenvalue's harmonic (``inf`` if that set is empty), and, per harmonic (key ``str(h)``),
        ``strip`` (eigenvalues of the strip), ``section`` (1D eigenvalues in the box),
        ``section_closed`` and ``max_rel_distance``.
    """
    dist = np.full(len(spectrum.values), np.inf)
    for j, (z, h) in enumerate(zip(spectrum.values, spectrum.harmonics, strict=True)):
        w = sets[float(h)].values if float(h) in sets else np.array([])
        if len(w):
            dist[j] = float(np.min(np.abs(w - z)) / abs(z))
    per = {}
    for h, s in sorted(sets.items()):
        mine = dist[spectrum.harmonics == h]
        per[f"{h:g}"] = {"wavenumber": s.wavenumber, "strip": int(len(mine)),
                         "section": s.in_box, "section_closed": s.closed,
                         "max_rel_distance": float(mine.max()) if len(mine) else None}
    return dist, per


def strip_rows(spectrum: StripSpectrum, distances: np.ndarray, rtol: float) -> list[dict]:
    """The sweep's rows (:data:`forms.solvers.certified.ROW_FIELDS` + :data:`EXTRA_FIELDS`).

    No exact root: those columns are empty. ``error_estimate`` is :func:`estimates`'s. ``status``
    is ``ok`` when the count closed, the estimate is within ``rtol`` and the ``p + 1`` partner
    is mutual; otherwise it names what failed. ``certificate`` is ``fe`` for an ``ok`` row
    (the cross-section sweep's meaning: count closed, estimate within ``rtol``), else empty.
    Rows and labels ``h<harmonic>_<j>`` by harmonic, then ``|Im Lambda|`` to 9 digits (a
    conjugate pair ties to rounding), then ``Im Lambda`` (over
    ``k``: :func:`forms.studies.sweep.label_by_continuation` of the keys ``re_next``,
    ``im_next`` that the rows carry when ``spectrum.next_values`` is set).
    """
    est, mutual = estimates(spectrum.values, spectrum.fine)
    rows = []
    order = sorted(range(len(spectrum.values)),
                   key=lambda j: (spectrum.harmonics[j], round(abs(spectrum.values[j].imag), 9),
                                  spectrum.values[j].imag))
    seen: dict[float, int] = {}
    for j in order:
        z, h = spectrum.values[j], float(spectrum.harmonics[j])
        n = seen[h] = seen.get(h, -1) + 1
        problems = [] if spectrum.closed else [f"count not closed: counted {spectrum.counted},"
                                               f" found {len(spectrum.values)}"]
        if not est[j] <= rtol:
            problems.append("no p+1 estimate" if np.isnan(est[j])
                            else f"estimate {est[j]:.1e} > rtol")
        elif not mutual[j]:
            problems.append("p+1 partner nearer another value")
        rows.append({"k": spectrum.k, "label": f"h{h:g}_{n}", "re_lambda": float(z.real),
                     "im_lambda": float(z.imag), "re_lambda_exact": math.nan,
                     "im_lambda_exact": math.nan, "rel_error": math.nan,
                     "error_estimate": float(est[j]), "residual": float(spectrum.residuals[j]),
                     "status": "; ".join(problems) or "ok",
                     "certificate": "" if problems else "fe", "harmonic": h,
                     "rel_distance_1d": float(distances[j])})
        if spectrum.next_values is not None:  # the links of sweep.label_by_continuation
            w = complex(spectrum.next_values[j])
            rows[-1] |= {"re_next": w.real, "im_next": w.imag}
    return rows


def canonical_labels(rows: list[dict]) -> None:
    """Renumber the labels ``c0, c1, ...`` of linked rows by first ``k``, then ``|Im Lambda|``.

    :func:`forms.studies.sweep.label_by_continuation` numbers new labels in the order of
    ``|Im Lambda|``, where the two rows of a conjugate pair (harmonics ``h`` and ``-h``) tie to
    rounding, which differs between runs under MPI (measured: ``c2`` and ``c3`` swapped between
    two ``mpirun -n 2`` runs). Here ``|Im|`` is rounded to 9 digits and ``Im <= 0`` comes first;
    which rows share a label is unchanged. In place.
    """
    first: dict[str, tuple] = {}
    for r in rows:
        key = (r["k"], round(abs(r["im_lambda"]), 9), r["im_lambda"])
        first[r["label"]] = min(first.get(r["label"], key), key)
    new = {lab: f"c{n}" for n, lab in enumerate(sorted(first, key=first.__getitem__))}
    for r in rows:
        r["label"] = new[r["label"]]


def spectrum_cost(comm: MPI.Comm, params: Params, k: float, box: Sequence[float], *,
                  cells_per_wavelength: int = 12, ny: int = 6, degree: int = 2,
                  rtol: float = 1e-8) -> dict:
    """Cost per eigenvalue of the strip's complete spectrum at ``k`` against the 1D model's.

    Side by side in one call: the strip in ``box`` (:func:`strip_spectrum`, wall time from
    the mesh to the harmonics, slowest rank), then on rank 0 the cross-section model's
    certified FE spectrum (:class:`forms.solvers.certified.CertifiedSolver`, no exact root,
    P4 for ``rtol``) at ``k`` in the same box and in the cross-section sweep's default region
    at ``k`` (:class:`analytic.numerics.spectrum.Region` with ``c_max = 4``), each timed from
    the model's construction. Collective.

    Returns:
        ``{"strip": ..., "section_same_box": ..., "section_region": ...}`` (the 1D entries on
        rank 0 only), each with ``unknowns``, ``eigenvalues``, ``closed``, ``seconds``,
        ``seconds_per_eigenvalue``, the strip's also its phases (``count``, ``solve``,
        ``harmonics``).
    """
    comm.Barrier()
    t0 = MPI.Wtime()
    s = strip_spectrum(comm, params, k, box, cells_per_wavelength=cells_per_wavelength, ny=ny,
                       degree=degree)
    wall = comm.allreduce(MPI.Wtime() - t0, op=MPI.MAX)
    out = {"strip": _cost(s.unknowns, len(s.values), s.closed, wall)
           | {"box": list(s.box), "phases": dict(s.seconds), "ranks": comm.size,
              "mesh": {"cells_per_wavelength": cells_per_wavelength, "ny": ny,
                       "degree": degree}}}
    if comm.rank == 0:
        full = Region()
        for name, region, bx in (
                ("section_same_box", Region(re_min=box[0], re_max=box[1], c_max=1e-6,
                                            omega0=max(abs(box[2]), abs(box[3]))), box),
                ("section_region", full, full.box(params, k))):
            t0 = time.perf_counter()
            d, c, ratio = default_discretisation(params, region, k, rtol)
            solver = CertifiedSolver(params, region, d, c, ratio, k, rtol, check_exact=False)
            res = solver.solve(k, box=tuple(bx))
            out[name] = _cost(solver.unknowns, len(res.rows), bool(res.closed),
                              time.perf_counter() - t0) | {"box": list(res.box),
                                                           "degree": d, "cells": c}
    return out


def _cost(unknowns: int, n: int, closed: bool, seconds: float) -> dict:
    return {"unknowns": int(unknowns), "eigenvalues": int(n), "closed": closed,
            "seconds": seconds, "seconds_per_eigenvalue": seconds / n if n else None}
