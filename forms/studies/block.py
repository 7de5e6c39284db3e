"""Finite block of length ``L`` on the substrate against the infinite strip: the computation.

Used by ``workflows/finite_block.py``:

- :func:`infinite_strip_reference`: per branch the infinite strip's most unstable ``k`` and
  ``Lambda`` (cross-section model, continuation in ``k``), the reference (most unstable branch)
  and the shift targets for the block solves;
- :func:`most_unstable_block_mode`: the block of one length solved near every target, the
  distinct eigenvalues kept, the most unstable one returned (:class:`BlockMode`, with the CSV
  row of :data:`ROW_COLUMNS`);
- :func:`auto_box`: the complete search's default box (growth floor and ceiling from the
  strip's reference growth, frequency of the provable region at the mesh's resolvable ``k``);
- :func:`block_spectrum`: the complete search: every eigenvalue of the block in a box
  (:class:`forms.solvers.region.RegionSolver`) with its certificate (found == counted by the
  argument principle, conjugate symmetry, the estimate against degree + 1), rows of
  :data:`SPECTRUM_COLUMNS`;
- :func:`converged_rows`: lengths and eigenvalues of the rows that converged;
- :func:`extrapolate`: the limit ``L -> infinity`` (Richardson, observed order), along
  :func:`same_mode_tail`;
- :func:`long_block_limit`: the cross-section model's long-block limit at the largest ``L``
  (:func:`forms.solvers.spatial_stability.kulikovskii_limit`; rigid substrate only);
- :func:`estimate_seconds`: the up-front estimate of a scan (``finite_block.py`` prints it).

Two bodies (``params.two_body``, finite ``H2``): the block is the slider on a substrate block of
the same length (:func:`forms.models.strip.strip_mesh_for`), and the infinite strip's reference
comes from the exact two-body roots (:func:`analytic.numerics.branches.follow_branch`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np

import dolfinx.fem
from mpi4py import MPI
from petsc4py import PETSc

from analytic.numerics import branches as exact_branches
from analytic.numerics.spectrum import Region
from analytic.numerics.tracking import Branch, waveguide_lambda
from analytic.params import Params
from forms.friction import DIRICHLET_DIAGONAL, apply_dirichlet
from forms.mode_postprocessing import normalise
from forms.models.strip import (
    FrictionProfile,
    build_strip_problem,
    friction_operator_for,
    solve_modes,
    strip_mesh_for,
)
from forms.solvers.continuation import follow_fe_branch, most_unstable_k
from forms.solvers.region import RegionSolver, SampleJournal
from forms.solvers.spatial_stability import kulikovskii_limit

#: Columns of :meth:`BlockMode.row` (the CSV of ``finite_block.py``).
ROW_COLUMNS = ("L", "re_lambda", "im_lambda", "residual", "candidates", "re_lambda_inf",
               "im_lambda_inf", "k_inf")


#: Nodes per wavelength below which the block's mesh is taken not to resolve a wavenumber
#: (:func:`resolvable_k`): 8 nodes, i.e. 4 cells of degree 2.
NODES_PER_WAVELENGTH = 8
#: Growth floor and ceiling of :func:`auto_box`, in units of the strip's reference growth.
AUTO_GROWTH = (0.5, 2.0)


#: Seconds of one block length with ``--search targets``: per length, per shift target, per
#: unknown and target. Measured on this 2-core machine (2026-11-25, load 12, one rank, P2,
#: 4 cells per unit, ny = 3, 3 targets): 238, 462, 910 unknowns 1.6, 2.1, 3.7 s (model 1.7,
#: 1.8, 1.9 s); workflows/results/finite_block (2 ranks, P2, 8 x 8 per unit, 3 targets):
#: 69 666 unknowns 24.5 s velocity top, 41.6 s stress top (model 26.7 s).
TARGET_SECONDS = (1.0, 0.2, 1.2e-4)
#: Seconds of one length of the complete search (:func:`block_spectrum`, the default
#: :func:`auto_box`): per length, per unknown. Measured as above: 238, 462 unknowns 146, 187 s.
COMPLETE_SECONDS = (100.0, 0.18)
#: Seconds of the infinite strip's reference (exact continuation): fixed, and per ``k`` of the
#: scan and branch. The run above, 80 ``k`` and 2 branches, spent about 25 s before its first
#: length (model 22.8 s); test_faults.SCENES's, 3 ``k`` and 2 branches, about 3 s with the
#: pictures (model 2.8 s).
REFERENCE_SECONDS = (2.0, 0.13)


def estimate_seconds(unknowns: Sequence[int], targets: int, search: str, k_scan: int,
                     branches: int) -> float:
    """Estimated seconds of a scan: the reference, then one length per entry of ``unknowns``.

    ``search`` is ``targets`` (:data:`TARGET_SECONDS`) or ``complete``
    (:data:`COMPLETE_SECONDS`); the ranks share each solve (no speed-up assumed).
    """
    if search == "complete":
        each = [COMPLETE_SECONDS[0] + COMPLETE_SECONDS[1] * n for n in unknowns]
    else:
        a, b, c = TARGET_SECONDS
        each = [a + targets * (b + c * n) for n in unknowns]
    return REFERENCE_SECONDS[0] + REFERENCE_SECONDS[1] * k_scan * branches + float(sum(each))


#: Columns of :meth:`BlockSpectrum.rows` (``finite_block_spectrum.csv``: every eigenvalue in the
#: box, per length).
SPECTRUM_COLUMNS = ("L", "re_lambda", "im_lambda", "residual", "estimate", "found", "counted",
                    "closed")


@dataclass
class StripReference:
    """The infinite strip's most unstable growth per branch, and the block's shift targets.

    Attributes:
        per_branch: ``(label, k, Lambda)`` of each branch at its most unstable ``k``.
        label: Label of the most unstable branch (the reference).
        k_inf: Its most unstable ``k``.
        lam_inf: Its ``Lambda`` there.
        targets: Distinct shift targets (``Im <= 0``) for the block solves.
    """

    per_branch: list[tuple[str, float, complex]]
    label: str
    k_inf: float
    lam_inf: complex
    targets: list[complex]

    def record(self) -> dict:
        """JSON-ready entries: branches, reference branch, per-branch maxima, targets."""
        return {"branches": [t[0] for t in self.per_branch], "reference_branch": self.label,
                "per_branch": [[t[0], t[1], t[2].real, t[2].imag] for t in self.per_branch],
                "k_inf": self.k_inf, "lambda_inf": [self.lam_inf.real, self.lam_inf.imag],
                "targets": [[t.real, t.imag] for t in self.targets]}


@dataclass
class BlockMode:
    """The most unstable mode found for one block length.

    Attributes:
        length: ``L``.
        eigenvalue: ``Lambda`` (``None`` if no target gave a converged mode).
        residual: Its relative residual (``nan`` if none).
        candidates: Number of distinct converged eigenvalues.
        u: The normalised mode (if asked for), else ``None``.
    """

    length: float
    eigenvalue: complex | None
    residual: float
    candidates: int
    u: dolfinx.fem.Function | None = None

    def row(self, ref: StripReference) -> list[float | int]:
        """The values of :data:`ROW_COLUMNS` (``nan`` for a length without a mode)."""
        nan = float("nan")
        lam = (nan, nan) if self.eigenvalue is None else (self.eigenvalue.real,
                                                           self.eigenvalue.imag)
        residual = nan if self.eigenvalue is None else self.residual
        return [self.length, *lam, residual, self.candidates, ref.lam_inf.real,
                ref.lam_inf.imag, ref.k_inf]


def _distinct(values: Sequence[complex], rel: float) -> list[complex]:
    """``values`` without near repeats (``|z - w| <= rel |z|``), first occurrences kept."""
    out: list[complex] = []
    for z in values:
        if all(abs(z - w) > rel * abs(z) for w in out):
            out.append(z)
    return out


def infinite_strip_reference(comm: MPI.Comm, params: Params, branches: Sequence[tuple[int, int]],
                             k_scan: np.ndarray, n_targets: int) -> StripReference:
    """The infinite strip per branch, and shift targets on both sides of the most unstable k.

    Per branch: the most unstable ``k`` on ``k_scan`` (:func:`most_unstable_k`, from the
    waveguide estimate), refined on 11 points over one grid step on each side. Targets: the
    branch followed from there to ``1.5 k`` and to ``0.5 k`` (``n_targets`` points each), mapped
    to ``Im Lambda <= 0`` (the block's operators are real, its spectrum symmetric under
    conjugation); a stable branch seeds no targets when there are several. Every rank computes
    (``MPI.COMM_SELF`` solves); the reference and targets are rank 0's.

    Args:
        comm: Communicator of the ranks that need the result.
        params: Parameters.
        branches: ``(n, sign)`` of the waveguide branches.
        k_scan: Grid of ``k`` (increasing).
        n_targets: Points of each half of the target path.
    """
    if params.two_body:
        return _exact_reference(comm, params, branches, k_scan, n_targets)
    dk = (k_scan[-1] - k_scan[0]) / max(len(k_scan) - 1, 1)
    per_branch = []
    targets = []
    for nb in branches:
        b = Branch(*nb)

        def wg(k: float, b: Branch = b) -> complex:
            return waveguide_lambda(params, b, k)

        k0, lam0 = most_unstable_k(params, wg, k_scan)
        kb, lb = most_unstable_k(params, lambda k, z=lam0: z, np.linspace(k0, k0 + dk, 11))
        kb2, lb2 = most_unstable_k(params, lambda k, z=lam0: z,
                                   np.linspace(k0, max(k0 - dk, 1e-3), 11))
        if lb2.real > lb.real:
            kb, lb = kb2, lb2
        per_branch.append((b.label, kb, lb))
        if lb.real <= 0 and len(branches) > 1:
            continue  # a stable branch seeds no targets
        for ks in (np.linspace(kb, 1.5 * kb, n_targets), np.linspace(kb, 0.5 * kb, n_targets)):
            for z in follow_fe_branch(params, lambda k, z=lb: z, ks):
                if np.isfinite(z):
                    targets.append(z if z.imag <= 0 else z.conjugate())
    label, k_inf, lam_inf = max(per_branch, key=lambda t: t[2].real)
    label, k_inf, lam_inf, targets = comm.bcast(
        (label, k_inf, lam_inf, _distinct(targets, 1e-6)), root=0)
    return StripReference(per_branch, label, k_inf, lam_inf, targets)


def _exact_max(params: Params, nb: tuple[int, int], ks: np.ndarray) -> tuple[float, complex]:
    """Largest ``Re Lambda`` of the exact branch ``nb`` on ``ks`` (``nan`` if it was lost)."""
    res = exact_branches.follow_branch(params, nb[0], nb[1], ks)
    lam = np.where(res.ok, res.Lambda, complex("nan"))
    if not np.isfinite(lam).any():
        return float(ks[0]), complex("nan")
    i = int(np.nanargmax(np.where(np.isfinite(lam), lam.real, np.nan)))
    return float(res.k[i]), complex(lam[i])


def _exact_reference(comm: MPI.Comm, params: Params, branches: Sequence[tuple[int, int]],
                     k_scan: np.ndarray, n_targets: int) -> StripReference:
    """:func:`infinite_strip_reference` from the exact roots (two bodies), rank 0's values.

    The same steps: the most unstable ``k`` of each branch on ``k_scan``, refined on 21 points
    over one grid step on each side; targets on ``[0.5 k, 1.5 k]``, mapped to ``Im <= 0``.
    """
    out = None
    if comm.rank == 0:
        dk = (k_scan[-1] - k_scan[0]) / max(len(k_scan) - 1, 1)
        per_branch, targets = [], []
        for nb in branches:
            k0, _ = _exact_max(params, nb, np.asarray(k_scan, dtype=float))
            kb, lb = _exact_max(params, nb, np.linspace(max(k0 - dk, 1e-3), k0 + dk, 21))
            per_branch.append((Branch(*nb).label, kb, lb))
            if not np.isfinite(lb) or (lb.real <= 0 and len(branches) > 1):
                continue  # a stable (or lost) branch seeds no targets
            path = exact_branches.follow_branch(params, nb[0], nb[1],
                                                np.linspace(0.5 * kb, 1.5 * kb, 2 * n_targets))
            targets += [z if z.imag <= 0 else z.conjugate()
                        for z, ok in zip(path.Lambda, path.ok, strict=True) if ok]
        label, k_inf, lam_inf = max(per_branch, key=lambda t: np.nan_to_num(t[2].real, nan=-1e300))
        out = StripReference(per_branch, label, k_inf, lam_inf, _distinct(targets, 1e-6))
    return comm.bcast(out, root=0)


def resolvable_k(cells_per_unit: int, degree: int) -> float:
    """Largest wavenumber along ``x`` the block's mesh resolves (a stated rule, not a bound).

    :data:`NODES_PER_WAVELENGTH` nodes per wavelength, the nodes of degree ``degree`` spaced
    ``1 / (cells_per_unit degree)``: ``k = 2 pi cells_per_unit degree / NODES_PER_WAVELENGTH``.
    """
    return 2.0 * np.pi * cells_per_unit * degree / NODES_PER_WAVELENGTH


def auto_box(params: Params, lam_ref: complex, cells_per_unit: int, degree: int
             ) -> tuple[float, float, float, float]:
    """The complete search's default box ``(re_min, re_max, -W, W)``.

    ``Re Lambda`` from :data:`AUTO_GROWTH` ``[0]`` to ``[1]`` times the reference growth
    ``Re lam_ref`` (the strip's fastest ``0-``/``0+`` mode): the floor only leaves out modes
    slower than half of it, which cannot be the block's fastest once the box holds one mode;
    the ceiling is checked against the infinite strip's fastest growth over all modes and all
    ``k`` by a test (committed envelopes). ``|Im Lambda| <= W``, the frequency of the
    sweep's default region (:class:`analytic.numerics.spectrum.Region`, phase velocities up to
    ``4 c_d``) at :func:`resolvable_k`: the frequencies of every mode of the infinite strip the
    mesh resolves, at the phase velocities the region holds. Neither bound is a proof about the
    block; a wider box at one length is the check (README).
    """
    g = abs(lam_ref.real)
    w = Region().im_max(params, resolvable_k(cells_per_unit, degree))
    return AUTO_GROWTH[0] * g, AUTO_GROWTH[1] * g, -w, w


def most_unstable_block_mode(comm: MPI.Comm, params: Params, length: float, *,
                             cells_per_unit: int, ny: int, degree: int, lateral: str,
                             targets: Sequence[complex], nev: int, keep_mode: bool = False
                             ) -> BlockMode:
    """The block ``0 < x < length`` solved near every target; its most unstable mode.

    Eigenvalues within ``1e-8`` relative of one found before are dropped. Collective (mesh on
    ``comm``); SLEPc options prefix ``block_``; every PETSc object destroyed before returning.

    Args:
        comm: Mesh communicator.
        params: Parameters.
        length: ``L``.
        cells_per_unit: Cells per unit length in ``x`` (at least 2 cells).
        ny: Cells along ``y``.
        degree: Lagrange degree.
        lateral: Lateral ends, ``free``, ``roller`` or ``clamped``.
        targets: Shift targets (:attr:`StripReference.targets`).
        nev: Eigenpairs per target.
        keep_mode: Also return the normalised mode as a function.
    """
    nx = max(2, int(round(cells_per_unit * length)))
    strip = strip_mesh_for(comm, params, float(length), nx, ny)
    problem = build_strip_problem(strip, params, k=None, degree=degree, lateral=lateral)
    found = []
    try:
        for tgt in targets:
            for m in solve_modes(problem, tgt, nev=nev, prefix="block_"):
                if all(abs(m.eigenvalue - f.eigenvalue) > 1e-8 * abs(m.eigenvalue)
                       for f in found):
                    found.append(m)
                else:
                    m.vector.destroy()
        if not found:
            return BlockMode(float(length), None, float("nan"), 0)
        best = max(found, key=lambda m: m.eigenvalue.real)
        u = None
        if keep_mode:
            u = problem.to_function(best.vector)
            normalise(u)
        return BlockMode(float(length), best.eigenvalue, best.residual, len(found), u)
    finally:
        for m in found:
            m.vector.destroy()
        problem.destroy()


@dataclass
class BlockSpectrum:
    """Every eigenvalue of a block in a box, with its certificate.

    Attributes:
        length: ``L``.
        box: ``(re_min, re_max, im_min, im_max)`` used (the count may widen it by 1e-3).
        values: Eigenvalues in the box, by decreasing real part.
        residuals: Their relative residuals.
        found: ``len(values)``.
        counted: Argument-principle count of ``det T_h`` in the box.
        conjugate_gap: Largest relative distance of a conjugate to the set (0: symmetric).
        estimates: ``|Lambda_p - Lambda_{p+1}| / |Lambda_{p+1}|`` per eigenvalue (nearest
            eigenvalue of the degree ``p + 1`` mesh; ``nan`` if not estimated).
        seconds: Solve and count times.
        tiles: Tile solves.
        u: The fastest mode, normalised (if asked for).
        mirrored: Values that are conjugates of values found (the half box of
            :func:`block_spectrum`; 0 for a full box); ``found`` and ``counted`` include them.
        count_evaluations: LU factorisations of the count (its contour's samples), the
            verification counts' included.
        counts: The first count and each verification's total (full box;
            :meth:`forms.solvers.region.RegionSolver._verify`: the count with the values found
            divided out, made when the first count and the tiles disagree or two found values
            share a sample interval next to the contour).
    """

    length: float
    box: tuple[float, float, float, float]
    values: np.ndarray
    residuals: np.ndarray
    found: int
    counted: int | None
    conjugate_gap: float
    estimates: np.ndarray
    seconds: dict
    tiles: int
    u: dolfinx.fem.Function | None = None
    mirrored: int = 0
    count_evaluations: int = 0
    counts: list = field(default_factory=list)

    @property
    def recounts(self) -> int:
        """Verification counts made."""
        return max(len(self.counts) - 1, 0)

    @property
    def closed(self) -> bool:
        """The count closes: every counted eigenvalue found, none more."""
        return self.counted is not None and self.found == self.counted

    def mode(self) -> BlockMode:
        """The fastest eigenvalue as a :class:`BlockMode` (the row of :data:`ROW_COLUMNS`)."""
        if self.found == 0:
            return BlockMode(self.length, None, float("nan"), 0, self.u)
        return BlockMode(self.length, complex(self.values[0]), float(self.residuals[0]),
                         self.found, self.u)

    def rows(self) -> list[list[float | int | str]]:
        """The values of :data:`SPECTRUM_COLUMNS`, one row per eigenvalue."""
        return [[self.length, z.real, z.imag, float(r), float(e), self.found, self.counted,
                 "yes" if self.closed else "no"]
                for z, r, e in zip(self.values, self.residuals, self.estimates, strict=True)]

    def record(self) -> dict:
        """JSON-ready certificate of this length."""
        best = self.mode().eigenvalue
        return {"L": self.length, "box": list(self.box), "found": self.found,
                "counted": self.counted, "closed": self.closed,
                "conjugate_gap": self.conjugate_gap,
                "fastest": None if best is None else [best.real, best.imag],
                "fastest_estimate": float(self.estimates[0]) if self.found else None,
                "max_estimate": float(np.nanmax(self.estimates)) if self.found and
                np.isfinite(self.estimates).any() else None,
                "tiles": self.tiles, "seconds": self.seconds, "mirrored": self.mirrored,
                "count_evaluations": self.count_evaluations, "recounts": self.recounts,
                "counts": list(self.counts)}


@contextmanager
def region_session(comm: MPI.Comm, problem: object, nev: int, prefix: str
                   ) -> Iterator[tuple[object, RegionSolver]]:
    """The friction operator of a strip ``problem`` and a :class:`RegionSolver` on ``comm``.

    On exit the solver, the operator and the problem are destroyed (in that order; a result
    of the solver is the caller's to destroy first).
    """
    op = friction_operator_for(problem)
    solver = RegionSolver(comm, nev=nev, prefix=prefix)
    try:
        yield op, solver
    finally:
        solver.destroy()
        op.destroy()
        problem.destroy()


#: Half box of :func:`block_spectrum` (``half``): its lower edge at ``Im = -HALF_OFFSET (re_max -
#: re_min)``, off the real axis, where a real operator's real eigenvalues lie.
HALF_OFFSET = 0.05


def half_box(box: Sequence[float]) -> tuple[float, float, float, float]:
    """The part ``Im >= -HALF_OFFSET (re_max - re_min)`` of a box symmetric about the real axis.

    Raises:
        ValueError: ``box`` not symmetric (``im_min != -im_max``) or too flat for the offset.
    """
    a, b, c, d = (float(v) for v in box)
    eps = HALF_OFFSET * (b - a)
    if c != -d or d <= eps:
        raise ValueError(f"box = {tuple(box)}: a half box needs im_min = -im_max and im_max >"
                         f" {eps:g}")
    return a, b, -eps, d


def mirror(values: np.ndarray, box: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
    """The set of a real operator in the full box from its half box ``box`` (:func:`half_box`).

    Every value above the half box's mirrored lower edge, ``Im > -im_min``, has its conjugate
    (below the half box) added; those within ``|Im| <= -im_min`` have theirs in the half box
    already. Returns ``(values, source)``, sorted as :meth:`RegionSolver.solve` sorts
    (decreasing real part, a conjugate pair ``Im <= 0`` first): ``source[i]`` is the index in
    ``values`` that value ``i`` is, or is the conjugate of.
    """
    a, b, c, d = box
    idx = list(range(len(values))) + [i for i, z in enumerate(values) if z.imag > -c]
    out = np.array([values[i] if n < len(values) else np.conj(values[i])
                    for n, i in enumerate(idx)], dtype=complex)
    scale = max(b - a, d - c)
    order = sorted(range(len(out)), key=lambda n: (-round(out[n].real / scale, 9), out[n].imag))
    return out[order], np.array(idx, dtype=int)[order]


def _region_solve(comm: MPI.Comm, params: Params, length: float, cells_per_unit: int, ny: int,
                  degree: int, lateral: str, box: Sequence[float], nev: int, count: bool,
                  keep_mode: bool, friction: FrictionProfile | None, prefix: str,
                  expected: int | None = None, split: bool = False,
                  divide: bool = False, progress: Callable[[str], object] | None = None,
                  journal: str | None = None):
    """One region solve of the block; ``keep_mode``: the fastest found, as a function.

    The mode is that of the value of ``Im <= 0`` (a conjugated vector if only ``Im > 0`` was
    found, as in a half box), the one the sorted full set lists first. ``divide``: the count's
    samples divided by the elastic determinant (:func:`elastic_reference`). ``journal``: a
    path for the count's samples (:class:`forms.solvers.region.SampleJournal`).
    """
    nx = max(2, int(round(cells_per_unit * length)))
    strip = strip_mesh_for(comm, params, float(length), nx, ny)
    problem = build_strip_problem(strip, params, k=None, degree=degree, lateral=lateral,
                                  friction=friction)
    with region_session(comm, problem, nev, prefix) as (op, solver):
        res, ref = None, elastic_reference(problem) if divide and count else None
        book = None
        if journal is not None and count:  # the problem the samples belong to, in one line
            book = SampleJournal(comm, journal, (
                f"log det of the block L = {float(length)!r}, {nx} x {ny} cells, P{degree}, "
                f"{op.matrices[0].getSize()[0]} unknowns, {lateral} ends, reference "
                f"{'elastic' if ref else 'none'}, box {tuple(float(v) for v in box)}"))
        try:
            res = solver.solve(op.matrices, box, op.law.spurious, count=count,
                               cleared_rows=op.cleared_rows, expected=expected,
                               split_count=split, reference=ref, progress=progress,
                               journal=book)
            u = None
            if keep_mode and res.found:
                if res.values[0].imag > 0:
                    res.vectors[0].conjugate()
                u = problem.to_function(res.vectors[0])
                normalise(u)
            return res, u
        finally:
            for m in ref or ():
                m.destroy()
            if res is not None:
                res.destroy()  # the vectors; values and counts stay


def elastic_reference(problem: object) -> list[PETSc.Mat]:
    """``K, 0, M`` of the block without friction, Dirichlet rows as in ``T`` (owned by caller).

    ``K + Lambda^2 M`` (the interface's ``x``-rows those of a frictionless interface): real
    symmetric with ``M`` positive definite on the free rows, so its eigenvalues satisfy
    ``Lambda^2 = -u^H K u / u^H M u <= 0``: all on the imaginary axis, none in a box with
    ``re_min > 0``. ``T`` is this operator plus the friction rows (a low-rank change), so
    ``det T / det`` of it turns slowly along the box's edges
    (:func:`forms.solvers.region.count_in_box`, ``reference``).
    """
    k = problem.stiffness.copy()
    m = problem.mass.copy()
    zero = problem.stiffness.duplicate(copy=False)
    apply_dirichlet([k, zero, m], problem.dirichlet, 0, DIRICHLET_DIAGONAL)
    return [k, zero, m]


def block_spectrum(comm: MPI.Comm, params: Params, length: float, *, cells_per_unit: int,
                   ny: int, degree: int, lateral: str, box: Sequence[float], nev: int,
                   estimate: bool = True, keep_mode: bool = False,
                   friction: FrictionProfile | None = None,
                   prefix: str = "block_region_", half: bool = False,
                   split_count: bool = False, divide: bool = False,
                   progress: Callable[[str], object] | None = None,
                   journal: str | None = None) -> BlockSpectrum:
    """Every eigenvalue of the block ``0 < x < length`` in ``box``, with its certificate.

    The region solve (:class:`forms.solvers.region.RegionSolver`, options prefix
    ``block_region_``, the count's LU ``block_region_det_``) counts the eigenvalues in the box by
    the argument principle on ``log det T_h`` and finds them by shift-and-invert over tiles; no
    infinite-strip target is used. With ``half``, only the half box (:func:`half_box`) is
    counted and solved and the rest is its conjugate (:func:`mirror`: the block's operators are
    real); ``found`` and ``counted`` are then the full box's, ``counted`` = the half box's count
    plus the conjugates added. With ``estimate``, the same box is solved (tiles only, until as
    many as found) on the mesh of degree ``degree + 1`` and each eigenvalue gets the relative
    distance to the nearest one there. Collective; every PETSc object destroyed before
    returning.

    Args:
        comm: Mesh communicator.
        params: Parameters.
        length: ``L``.
        cells_per_unit: Cells per unit length in ``x``.
        ny: Cells along ``y``.
        degree: Lagrange degree.
        lateral: Lateral ends.
        box: ``(re_min, re_max, im_min, im_max)`` (``re_min > -1``: the cleared denominator's
            root ``-1`` must stay outside; ``im_min = -im_max`` with ``half``).
        nev: Eigenpairs per tile solve.
        estimate: Also solve at degree ``degree + 1``.
        keep_mode: Also return the fastest mode as a normalised function.
        friction: Friction parameters along the interface (default: uniform, ``params``').
        prefix: Options prefix of the region solve (its count's LU: ``prefix + "det_"``).
        half: Count and solve ``Im >= -HALF_OFFSET (re_max - re_min)`` only, mirror the rest.
        split_count: The count's samples shared among the ranks (serial LUs,
            :class:`forms.solvers.region.LogDet`).
        divide: The count's samples divided by the frictionless block's determinant
            (:func:`elastic_reference`; only for ``re_min > 0``, where it has no eigenvalue):
            the same count, far fewer samples.
        progress: Called with a short line as the count and the tiles advance (the
            estimate's lines prefixed ``P(p+1) estimate``); the caller throttles and prints.
        journal: A path where the count keeps its samples as it computes them
            (:class:`forms.solvers.region.SampleJournal`): a count stopped and run again with
            the same path computes only the samples it had not.
    """
    tail = (friction, prefix)
    fine_progress = None if progress is None else (
        lambda line: progress(f"P{degree + 1} estimate, {line}"))
    res, u = _region_solve(comm, params, length, cells_per_unit, ny, degree, lateral,
                           half_box(box) if half else box, nev, True, keep_mode, *tail,
                           split=split_count, divide=divide and float(box[0]) > 0,
                           progress=progress, journal=journal)
    values, source = res.values, np.arange(res.found)
    full = res.box
    if half:
        values, source = mirror(res.values, res.box)
        a, b, _, d = res.box
        full = (a, b, -d, d)
    est = np.full(res.found, np.nan)
    seconds = dict(res.seconds)
    if estimate and res.found:
        t0 = time.perf_counter()
        fine, _ = _region_solve(comm, params, length, cells_per_unit, ny, degree + 1, lateral,
                                res.box, nev, False, False, *tail, expected=res.found,
                                progress=fine_progress)
        if fine.found:
            est = np.array([np.min(np.abs(fine.values - z)) / abs(z) for z in res.values])
        seconds["estimate"] = time.perf_counter() - t0
    extra = len(values) - res.found
    counted = None if res.counted is None else res.counted + extra
    gap = float(np.max(np.abs(np.conj(values)[:, None] - values[None, :]).min(axis=1)
                       / np.maximum(np.abs(values), 1.0))) if len(values) else 0.0
    return BlockSpectrum(float(length), full, values, res.residuals[source], len(values),
                         counted, gap, est[source], seconds, res.tiles, u, extra,
                         res.count_evaluations, [c + extra for c in res.counts])


def converged_rows(rows: Sequence[dict[str, str]]) -> tuple[np.ndarray, np.ndarray]:
    """Lengths and eigenvalues of the CSV rows (:data:`ROW_COLUMNS`) that have a mode.

    Returns:
        ``(L, Lambda)`` sorted by ``L`` (rows whose ``re_lambda`` is ``nan`` or empty left out).
    """
    ok = [r for r in rows if r["re_lambda"] not in ("nan", "")]
    L = np.array([float(r["L"]) for r in ok])
    lam = np.array([complex(float(r["re_lambda"]), float(r["im_lambda"])) for r in ok])
    order = np.argsort(L)
    return L[order], lam[order]


#: Relative distance in ``|Im Lambda|`` within which the fastest modes of consecutive lengths
#: are taken as the same global mode (:func:`same_mode_tail`). The same mode moves by 1.5 %
#: from ``L = 8`` to 64 (stress top, ``alpha_pc = 0.1``: ``|Im|`` 5.609 to 5.561); the fastest
#: there changed thickness mode at ``L = 64``, to ``|Im| = 19.27``.
SAME_MODE_IM = 0.1


def same_mode_tail(L: np.ndarray, lam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The largest lengths whose fastest mode is the largest length's.

    Each length's ``|Im|`` within :data:`SAME_MODE_IM` (relative) of its next-longer
    neighbour's. An extrapolation ``L -> infinity`` is meaningful only along one global mode:
    where a higher thickness mode takes over as the fastest, the lengths before it are left
    out.

    Returns:
        ``(L, lam)`` of that tail, sorted by ``L``.
    """
    order = np.argsort(L)
    L, lam = np.asarray(L)[order], np.asarray(lam)[order]
    j = len(L) - 1
    while j > 0 and (abs(abs(lam[j - 1].imag) - abs(lam[j].imag))
                     <= SAME_MODE_IM * max(abs(lam[j].imag), 1.0)):
        j -= 1
    return L[j:], lam[j:]


def extrapolate(L: np.ndarray, values: np.ndarray) -> tuple[float, float]:
    """Limit ``L -> infinity`` from the three largest lengths (Richardson, observed order).

    With ``L`` in a geometric ratio ``r`` and monotone differences, the order ``p`` comes from
    ``(v2 - v1)/(v3 - v2) = r^p`` and the limit is ``v3 + (v3 - v2)/(r^p - 1)``; otherwise a
    least-squares ``a + b/L``. Returns ``(limit, p)`` (``nan`` from fewer than three lengths).
    """
    order = np.argsort(L)
    L, v = np.asarray(L)[order], np.asarray(values)[order]
    if len(L) < 3:
        return float("nan"), float("nan")
    (l1, l2, l3), (v1, v2, v3) = L[-3:], v[-3:]
    r = l2 / l1
    d1, d2 = v2 - v1, v3 - v2
    if abs(l3 / l2 - r) < 1e-9 * r and d1 * d2 > 0 and abs(d1) > abs(d2):
        p = float(np.log(d1 / d2) / np.log(r))
        return float(v3 + d2 / (r**p - 1.0)), p
    b, a = np.polyfit(1.0 / L[-3:], v[-3:], 1)
    return float(a), 1.0


def long_block_limit(params: Params, L: np.ndarray, lam: np.ndarray) -> dict | None:
    """:func:`forms.solvers.spatial_stability.kulikovskii_limit` at the block of the largest ``L``.

    Runs on the calling rank alone. Raises ``RuntimeError`` as that function does.

    Returns:
        Its dict plus ``from_block_length``, or ``None`` if it found fewer than two roots or
        the substrate is deformable (the cross-section model behind it is the rigid one's).
    """
    if params.two_body:
        return None
    i = int(np.argmax(L))
    kul = kulikovskii_limit(params, complex(lam[i]))
    if kul is not None:
        kul["from_block_length"] = float(L[i])
    return kul
