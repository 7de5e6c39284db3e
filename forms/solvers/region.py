"""Every eigenvalue of ``T(Lambda) = sum_j Lambda^j A_j`` in a box, with a count of its own.

Generic: PETSc matrices in (distributed, any model: 2D Bloch cell, finite block, layers), the
friction law's ``(Lambda + 1)`` denominator already cleared (as for
:class:`forms.solvers.slepc.PolynomialSolver`), eigenpairs out. No exact root is an input.

- :class:`LogDet`: ``log det T_h(Lambda)`` from MUMPS's determinant (``ICNTL(33) = 1``:
  ``det = (RINFOG(12) + i RINFOG(13)) 2^INFOG(34)``), one parallel LU per point, vectorised
  over points.
- :func:`winding`: the winding number from ``log F`` samples, adaptive, each interval verified
  once by bisection (the rules of :func:`analytic.numerics.roots.winding_number`, tuned for a
  determinant whose every sample is a factorisation: see :data:`MAX_DLOG`).
- :func:`count_in_box`: the argument principle on ``log det T_h`` along the box's contour: the
  number of discrete eigenvalues in the box, independent of the eigen-solver.
- :class:`RegionSolver`: SLEPc PEP (TOAR, shift-and-invert, MUMPS LU) over a tiling of the box.
  A tile is *covered* when the solve at its centre returned ``nev`` converged pairs and the
  farthest lies outside the tile's circumscribed disc (then every eigenvalue of the tile is among
  them: shift-and-invert returns the eigenvalues nearest the shift); a tile not covered is split
  in four. The result carries ``found`` and ``counted``: ``found == counted`` is the certificate,
  verified by a second count with the found values divided out where the first count and the
  tiles disagree or two found values share a sample interval next to the contour
  (:func:`unresolved`).

The cleared denominator adds the spurious roots ``spurious`` (``Lambda = -1``, ...): the box must
not contain them (:class:`RegionSolver` and :func:`count_in_box` refuse it), the solver drops
them. Dirichlet rows (:func:`forms.friction.apply_dirichlet`: 1 on the diagonal of ``A_0``, 0 in
the others) have their eigenvalues at infinity, far from every tile's target, and multiply
``det T_h`` by a constant: they change neither the pairs nor the count.

Options: the PEP has prefix ``<prefix>`` (``-region_pep_type``, ``-region_st_*`` ...), the
determinant's LU ``<prefix>det_`` (``-region_det_pc_factor_mat_solver_type``,
``-region_det_mat_mumps_icntl_14`` ...); setters first, ``setFromOptions`` last.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from mpi4py import MPI
from petsc4py import PETSc

from analytic.numerics.roots import ContourError
from forms.solvers.slepc import shift_off, sinvert_pep

Box = tuple[float, float, float, float]

#: Largest change of ``log|det T_h|`` between neighbouring contour samples (:func:`winding`):
#: a zero at distance ``delta`` from the contour makes ``log|det|`` dip by about
#: ``log(h / delta)`` over a spacing ``h``, so samples are refined there. Not the relative rule of
#: :func:`analytic.numerics.roots.winding_number` (``max_rel = 0.8``, a factor 1.8): ``det T_h`` is
#: a polynomial of degree ~ (number of unknowns), its modulus changes by many decades along the
#: contour, and that rule took 10284 LU factorisations for the block L = 4 (2210 unknowns, box
#: (0.05, 0.6, -16, 16)); its verification pass, repeated after every refinement, took 2992 for a
#: box with no zero in it (0.1, 0.6, -4, 4). A cluster of zeros next to the edge can be counted
#: short with it (:func:`unresolved`): :meth:`RegionSolver.solve` then verifies the count.
MAX_DLOG = 2.0
#: An interval between a falling and a rising one of ``log|det|`` is bisected when the steeper
#: neighbour's slope times its length exceeds this (:func:`winding`): a local minimum of
#: ``|det|`` between two samples marks zeros nearer the contour than the samples, and a *pair*
#: of them turns the phase by ``2 pi`` there, which neither the phase rule nor :data:`MAX_DLOG`
#: sees (session 22: 168 of 200 synthetic pairs next to an edge counted short without it, none
#: with it; the L = 32 block's cluster of 9 next to an edge (tests/test_region_solver.py)
#: counted 7-8 without it at 16-64 initial samples a side, 9 with 1.5 and below, 8 at 3 of 7
#: samplings with 2.0). Its cost: the block L = 4's box (0.2, 0.655) x (-0.023, 125.67), no
#: eigenvalue inside, 1 227 -> 2 135 samples (1.74x; 1 232 with 2.0).
MAX_DIP = 1.5
#: An interval is bisected when a neighbour's rate of turn times its length exceeds this
#: (:func:`winding`): a phase turning fast and evenly (a row of eigenvalues just outside the
#: edge) is read modulo ``2 pi`` in an interval that turns by nearly ``2 pi``, the same at
#: every level (session 22: the L = 32 block's left edge near ``Im = 81.45``, two intervals
#: 8x longer than their neighbours, each turning -5.7 rad, read +0.86 and +0.60). Session 23,
#: 60 random rows of 20-200 zeros outside an edge per seed (tests/test_region_solver.py):
#: 30-40 of 60 wrong or unresolved without it (218 of 360), none with ``pi / 2`` (2 of 360
#: with ``pi``), with fewer samples (8 900 per count against 14 600: the levels agree sooner);
#: the 600-zero test's counts 0.2 % more samples, the block L = 4's box above 1.1 % (2 135 ->
#: 2 158).
MAX_GRADE = math.pi / 2

#: Most verification counts of one :meth:`RegionSolver.solve` (each followed by more tiles
#: while it finds eigenvalues not yet found).
MAX_RECOUNTS = 3


def _wrap(x: np.ndarray) -> np.ndarray:
    return np.angle(np.exp(1j * x))


def _initial_tiles(box: Box, stop_at: int | None, nev: int) -> tuple[int, int]:
    """``(n_re, n_im)``: about ``nev/2`` eigenvalues per tile, no tile over 3x taller than wide.

    A tall tile's circumscribed disc reaches far outside the box (the block's stable modes).
    """
    a, b, c, d = box
    n_tiles = max(1, math.ceil(2 * (stop_at or 1) / nev))
    aspect = (d - c) / (b - a)
    n_re = max(1, round(math.sqrt(n_tiles / aspect)))
    return n_re, max(math.ceil(n_tiles / n_re), math.ceil(aspect * n_re / 3.0))


def _tile_list(box: Box, n_re: int, n_im: int) -> list[Box]:
    """The ``n_re x n_im`` tiles of ``box``, the one nearest the real axis last.

    :meth:`RegionSolver.solve` pops from the end: the order only changes how soon found ==
    counted stops the tiling (the block's fastest modes are slow waves; in a tall box above a
    growth floor the first tiles then hold them).
    """
    a, b, c, d = box
    todo = [(a + (b - a) * i / n_re, a + (b - a) * (i + 1) / n_re,
             c + (d - c) * j / n_im, c + (d - c) * (j + 1) / n_im)
            for i in range(n_re) for j in range(n_im)]
    return sorted(todo, key=lambda t: -abs(t[2] + t[3]))


def _keep_new(pairs: list, kept: list, box: Box, scale: float,
              spurious: Sequence[complex]) -> None:
    """Append the pairs inside ``box``, new and not spurious, to ``kept``; destroy the rest."""
    a, b, c, d = box
    for lam, v in pairs:
        inside = a <= lam.real <= b and c <= lam.imag <= d
        new = all(abs(lam - w) > 1e-8 * max(abs(lam), scale) for w, _ in kept)
        spur = any(abs(lam - s) <= 1e-6 * max(1.0, abs(s)) for s in spurious)
        if inside and new and not spur:
            kept.append((lam, v))
        else:
            v.destroy()


def _local_stage(logf, point, increments, perimeter: float, t: np.ndarray,  # noqa: ANN001
                 f: np.ndarray, max_dphase: float, max_dlog: float, levels: int,
                 max_points: int) -> tuple[int, int, np.ndarray]:
    """Stage 2 of :func:`winding` from the samples ``(t, f)``: ``(total, samples added, t)``.

    Every interval starts verified once (the samples are a uniform doubling).
    """
    ok = np.ones(t.size, dtype=int)
    added = 0
    while True:
        tn = np.append(t[1:], perimeter)
        fn = np.append(f[1:], f[:1])
        dph, bad = increments(t, f)
        todo = bad | (ok < levels)
        if not todo.any():
            return int(round(float(dph.sum()) / (2.0 * math.pi))), added, t
        if np.any((tn - t)[todo] < 1e-12 * perimeter) or t.size + todo.sum() > max_points:
            z = point(t[todo][:1])[0]
            raise ContourError(f"phase of det T_h not resolved near z = {z:.6g}: move the edge")
        tm = 0.5 * (t + tn)[todo]
        fm = np.asarray(logf(point(tm)), dtype=complex)
        added += tm.size
        d1, d2 = fm - f[todo], fn[todo] - fm
        p1, p2 = _wrap(d1.imag), _wrap(d2.imag)
        good = ((np.abs(p1) <= max_dphase) & (np.abs(p2) <= max_dphase)
                & (np.abs(d1.real) <= max_dlog) & (np.abs(d2.real) <= max_dlog)
                & (np.abs(p1 + p2 - dph[todo]) < 1e-6))
        lv = np.where(good, ok[todo] + 1, 0)
        ok[todo] = lv
        t = np.concatenate([t, tm])
        f = np.concatenate([f, fm])
        ok = np.concatenate([ok, lv])
        order = np.argsort(t)
        t, f, ok = t[order], f[order], ok[order]


def _contour(box: Box) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Corners (counter-clockwise from ``(re_min, im_min)``, closed), side lengths, arc length."""
    a, b, c, d = box
    corners = np.array([a + 1j * c, b + 1j * c, b + 1j * d, a + 1j * d, a + 1j * c])
    lengths = np.abs(np.diff(corners))
    return corners, lengths, np.concatenate([[0.0], np.cumsum(lengths)])


def _dips(h: np.ndarray, dl: np.ndarray, max_dip: float) -> np.ndarray:
    """Intervals at a steep local minimum of ``log|F|`` (:data:`MAX_DIP`).

    ``h[i]``, ``dl[i]``: the length of interval ``i`` (``t_i .. t_(i+1)``, cyclic) and the change
    of ``log|F|`` over it. Flagged: ``log|F|`` falls over interval ``i - 1`` and rises over
    ``i + 1``, and the steeper of the two slopes times interval ``i``'s length exceeds
    ``max_dip``.
    """
    slope = dl / h
    left, right = np.roll(slope, 1), np.roll(slope, -1)
    return (left < 0) & (right > 0) & (h * np.maximum(-left, right) > max_dip)


def _graded(h: np.ndarray, dph: np.ndarray, max_grade: float) -> np.ndarray:
    """Intervals longer than a fast-turning neighbour allows (:data:`MAX_GRADE`).

    ``h[i]``, ``dph[i]``: the length of interval ``i`` (cyclic) and the wrapped phase increment
    over it. Flagged: a neighbour's rate of turn ``|dph| / h`` times interval ``i``'s length
    exceeds ``max_grade``.
    """
    rate = np.abs(dph) / h
    return h * np.maximum(np.roll(rate, 1), np.roll(rate, -1)) > max_grade


def _dips_and_grading(t: np.ndarray, perimeter: float, dl: np.ndarray, dph: np.ndarray,
                      max_dip: float, max_grade: float) -> np.ndarray:
    """The intervals :func:`_dips` or :func:`_graded` flags (a rule is off at ``inf``).

    The intervals' lengths are computed once for both rules.
    """
    h = np.append(t[1:], t[0] + perimeter) - t
    out = np.zeros(t.size, dtype=bool)
    if math.isfinite(max_dip):
        out |= _dips(h, dl, max_dip)
    if math.isfinite(max_grade):
        out |= _graded(h, dph, max_grade)
    return out


def arc_position(box: Box, z: complex) -> tuple[float, float]:
    """Where ``z`` projects onto the contour: ``(t, distance)``.

    ``t`` is the arc length (:func:`winding`'s parameter) of the contour point nearest ``z``.
    """
    corners, lengths, cum = _contour(box)
    best = (math.inf, 0.0)
    for side in range(4):
        p, q = corners[side], corners[side + 1]
        s = min(max(((z - p) * np.conj(q - p)).real / lengths[side] ** 2, 0.0), 1.0)
        dist = abs(z - (p + s * (q - p)))
        if dist < best[0]:
            best = (dist, float(cum[side] + s * lengths[side]))
    return best[1], best[0]


def winding(logf, box: Box, *, n_initial: int = 64,  # noqa: ANN001
            max_dphase: float = math.pi / 3, max_dlog: float = MAX_DLOG,
            levels: int = 1, max_points: int = 40000,
            samples: bool = False, max_dip: float | None = None,
            max_grade: float | None = None) -> int | tuple[int, np.ndarray]:
    """Winding number of ``F`` on the counter-clockwise edge of ``box`` from ``log F`` samples.

    ``logf(z)`` is vectorised and returns ``log|F| + i arg F`` (any branch). Uniform (in arc
    length) samples, doubled; at each level where the wrapped phase increments of at least
    90 % of the intervals are below ``max_dphase``, the level is refined locally (stage 2) and
    its total taken; the answer is the total of two consecutive levels that agree.

    - Uniform doubling: ``det T_h`` turns fast *and evenly* along an edge that runs past many
      eigenvalues (153 turns along one side in the synthetic test of the tests); local
      bisection alone cannot see that: an interval that turns by ``2^m * 2 pi`` has halves,
      quarters ... that look resolved (measured: 126 instead of 138 with 16 samples per side
      and two levels of verification).
    - Local (stage 2): an interval is bisected while its increment exceeds ``max_dphase`` or
      ``log|F|`` changes by more than ``max_dlog`` (a zero near the edge), and until it was
      verified by bisection ``levels`` times in a row (halves within both rules, their phase
      increments adding up to the parent's). Each level is refined locally before the totals
      are compared, so a zero a distance ``delta`` from the edge costs a few bisections near it,
      not a uniform spacing ``~ delta`` over the whole contour (before: the uniform levels
      alone had to agree; the block L = 4 at the table's mesh, box ``(0.2, 0.655) x (-0.023,
      125.67)``, took 8206 samples).
    - Dips and grading (``max_dip``, ``max_grade``; ``None``: :data:`MAX_DIP`,
      :data:`MAX_GRADE`; ``inf``: off): an interval at a steep local minimum of ``log|F|``
      (:func:`_dips`: a pair of zeros nearer the edge than the samples turns the phase by
      ``2 pi`` unseen) or longer than a fast-turning neighbour allows (:func:`_graded`: a
      fast even turn read modulo ``2 pi``) is bisected too.

    With ``samples``: ``(total, t)``, ``t`` the sorted arc-length parameters of the samples of
    the level returned (:func:`arc_position` places a point on the same scale).

    Raises:
        ContourError: ``log F`` not finite, or the phase not resolved (a zero on the contour).
    """
    corners, lengths, cum = _contour(box)
    perimeter = float(cum[-1])
    dip = MAX_DIP if max_dip is None else max_dip
    grade = MAX_GRADE if max_grade is None else max_grade

    def point(t: np.ndarray) -> np.ndarray:
        side = np.clip(np.searchsorted(cum, t, side="right") - 1, 0, 3)
        s = (t - cum[side]) / lengths[side]
        return corners[side] + s * (corners[side + 1] - corners[side])

    def increments(t: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if not np.all(np.isfinite(f)):
            raise ContourError("log det not finite on the contour: an eigenvalue on the edge")
        dlt = np.append(f[1:], f[:1]) - f
        dph = _wrap(dlt.imag)
        bad = (np.abs(dph) > max_dphase) | (np.abs(dlt.real) > max_dlog)
        return dph, bad | _dips_and_grading(t, perimeter, dlt.real, dph, dip, grade)

    t = np.linspace(0.0, perimeter, 4 * n_initial, endpoint=False)
    f = np.asarray(logf(point(t)), dtype=complex)
    previous, used = None, t.size
    while True:
        _, bad = increments(t, f)
        total = None
        if bad.mean() <= 0.1:
            total, added, tl = _local_stage(logf, point, increments, perimeter, t, f,
                                            max_dphase, max_dlog, levels,
                                            max_points - used + t.size)
            used += added
            if total == previous:
                return (total, tl) if samples else total
        previous = total
        if used + t.size > max_points:
            raise ContourError("phase of det T_h not resolved by uniform sampling")
        tm = t + 0.5 * perimeter / t.size
        fm = np.asarray(logf(point(tm)), dtype=complex)
        used += tm.size
        t = np.stack([t, tm], axis=1).ravel()
        f = np.stack([f, fm], axis=1).ravel()


def unresolved(box: Box, t: np.ndarray, values: Sequence[complex]) -> list[complex]:
    """The ``values`` whose phase steps the count's samples may have missed.

    ``t``: the count's sample parameters (:func:`winding` with ``samples``). A zero at distance
    ``delta`` turns the phase by about ``pi`` within ``~delta`` of its nearest contour point.
    One such step in an interval longer than ``delta`` is seen (an increment near ``pi``); two
    in one interval (``2 pi``) look like none: a cluster of zeros next to an edge is undercounted
    (measured: the 9 zeros of the block ``L = 32`` at ``Re`` 0.1266-0.1412 next to the edge
    ``Re = 0.125``, ``Im`` 6.35-6.92, counted as 7 with 16 initial samples a side, as 9, 8, 7
    with 17, 24, 32; tests/test_region_solver.py). Returned: the values closer to the contour
    than the length of their sample interval, where an interval holds two or more of them.
    """
    if len(values) == 0:
        return []
    perimeter = float(_contour(box)[2][-1])
    ts = np.sort(np.asarray(t, dtype=float))
    near: dict[int, list[complex]] = {}
    for z in values:
        tz, dist = arc_position(box, complex(z))
        i = int(np.searchsorted(ts, tz))
        lo = ts[i - 1] if i > 0 else ts[-1] - perimeter
        hi = ts[i] if i < ts.size else ts[0] + perimeter
        if dist < hi - lo:
            near.setdefault(i % ts.size, []).append(complex(z))
    return [z for group in near.values() if len(group) >= 2 for z in group]


def _distance(box: Box, z: complex) -> float:
    """Distance from ``z`` to the box."""
    a, b, c, d = box
    return math.hypot(max(a - z.real, 0.0, z.real - b), max(c - z.imag, 0.0, z.imag - d))


def _check_box(box: Sequence[float], spurious: Sequence[complex]) -> Box:
    a, b, c, d = (float(v) for v in box)
    if not (b > a and d > c) or not all(math.isfinite(v) for v in (a, b, c, d)):
        raise ValueError(f"box = {tuple(box)} must be finite with re_max > re_min, "
                         "im_max > im_min")
    for s in spurious:
        if a <= s.real <= b and c <= s.imag <= d:
            raise ValueError(f"box = {tuple(box)} contains the spurious root {s} of the cleared "
                             "denominator: take re_min above it")
    return a, b, c, d


class _Combination:
    """``T(z) = sum_j z^j A_j`` in one matrix whose pattern is the union of the ``A_j``."""

    def __init__(self, matrices: Sequence[PETSc.Mat]) -> None:
        self.matrices = list(matrices)
        t = self.matrices[0].copy()
        for a in self.matrices[1:]:
            t.axpy(1.0, a, PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)
        self.mat = t

    def set(self, z: complex) -> PETSc.Mat:
        t = self.mat
        t.zeroEntries()
        for j, a in enumerate(self.matrices):
            t.axpy(z**j, a, PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
        return t

    def destroy(self) -> None:
        self.mat.destroy()


def serial_copies(matrices: Sequence[PETSc.Mat]) -> list[PETSc.Mat]:
    """A whole sequential copy of each (distributed) matrix on every rank (owned by the caller).

    ``MatCreateSubMatrices`` with every row and column: the same global numbering, so the same
    determinant.
    """
    n = matrices[0].getSize()[0]
    every = PETSc.IS().createStride(n, 0, 1, comm=PETSc.COMM_SELF)
    try:
        return [m.createSubMatrices(every, every)[0] for m in matrices]
    finally:
        every.destroy()


class LogDet:
    """``log det T_h(z)`` at points ``z`` by MUMPS (collective; same value on every rank).

    One LU per point (the symbolic analysis is done once). ``det = (RINFOG(12) + i RINFOG(13))
    * 2^INFOG(34)``, so ``log det = log(RINFOG(12) + i RINFOG(13)) + INFOG(34) log 2`` never
    over- or underflows. The argument is a branch of ``arg det`` (the winding count only uses
    wrapped increments between neighbouring samples).

    With ``split`` on several ranks, every rank holds a sequential copy of the matrices
    (:func:`serial_copies`) and factorises its own share of the points (every ``size``-th one)
    with a serial LU; the values are then gathered, so every rank has all of them, in the order
    of ``z`` (the same samples and the same rule as without ``split``).

    Args:
        matrices: ``A_0, ..., A_d`` (PETSc, any communicator).
        prefix: Options prefix of the LU (``KSP`` ``preonly`` + ``PC`` ``lu`` + MUMPS).
        split: Share the points among the ranks (serial LUs) instead of one parallel LU each.
    """

    def __init__(self, matrices: Sequence[PETSc.Mat], prefix: str = "region_det_",
                 split: bool = False) -> None:
        self.world = matrices[0].getComm().tompi4py()
        self.copies: list[PETSc.Mat] = []
        if split and self.world.size > 1:
            self.copies = serial_copies(matrices)
            matrices = self.copies
        self.comm = matrices[0].getComm().tompi4py()
        self.combo = _Combination(matrices)
        ksp = PETSc.KSP().create(self.comm)
        ksp.setOptionsPrefix(prefix)
        ksp.setType(PETSc.KSP.Type.PREONLY)
        pc = ksp.getPC()
        pc.setType(PETSc.PC.Type.LU)
        pc.setFactorSolverType("mumps")
        ksp.setOperators(self.combo.mat)
        ksp.setFromOptions()
        pc.setFactorSetUpSolverType()
        pc.getFactorMatrix().setMumpsIcntl(33, 1)  # compute the determinant
        self.ksp = ksp
        self.evaluations = 0
        self.seconds = 0.0

    def __call__(self, z: np.ndarray) -> np.ndarray:
        """Vectorised ``log det T_h`` (complex logarithm) at the points ``z``."""
        z = np.atleast_1d(np.asarray(z, dtype=complex))
        t0 = time.perf_counter()
        if self.comm.size == self.world.size:
            out = self._at(z)
        else:  # split: every rank its share, then all of them everywhere
            rank, size = self.world.rank, self.world.size
            shares = self.world.allgather(self._at(z.ravel()[rank::size]))
            out = np.empty(z.size, dtype=complex)
            for r, share in enumerate(shares):
                out[r::size] = share
            out = out.reshape(z.shape)
        self.evaluations += z.size
        self.seconds += time.perf_counter() - t0
        return out

    def _at(self, z: np.ndarray) -> np.ndarray:
        out = np.empty(z.shape, dtype=complex)
        pc = self.ksp.getPC()
        for i, zi in enumerate(z.flat):
            self.combo.set(complex(zi))
            self.ksp.setOperators(self.combo.mat)
            pc.setUp()
            f = pc.getFactorMatrix()
            mant = complex(f.getMumpsRinfog(12), f.getMumpsRinfog(13))
            expo = f.getMumpsInfog(34)
            mant, expo = self.comm.bcast((mant, expo), root=0)
            out.flat[i] = (np.log(mant) if mant != 0 else -np.inf) + expo * math.log(2.0)
        return out

    def destroy(self) -> None:
        """Destroy the LU, the combined matrix and the sequential copies."""
        self.ksp.destroy()
        self.combo.destroy()
        for m in self.copies:
            m.destroy()
        self.copies = []


class SampleJournal:
    """The count's samples of ``log det`` on disk as they are computed: a stopped count resumes.

    A count of a long block takes hours (36 085 samples in 65 min on 2 ranks: the velocity top's
    ``L = 64`` to ``|Im| = 125.67``); a run stopped in it lost them all. The journal is a CSV
    file, ``re,im,logdet_re,logdet_im`` per sample (Python's shortest round-trip float repr: the
    values read back are the values computed, bit for bit), after a header line naming the
    problem (:meth:`open`). Every value computed is appended and flushed before the count goes
    on; a count run again with the journal takes its samples from it and computes only the
    others, so it takes the same steps and gives the same count. Collective: rank 0 reads and
    writes the file, every rank holds the same samples.
    """

    HEADER = "re,im,logdet_re,logdet_im"
    #: Samples computed between two writes: a uniform level of a tall box's count holds
    #: thousands (an hour of LUs on the ``L = 64`` block), so the batch is cut.
    CHUNK = 64

    def __init__(self, comm: MPI.Comm, path: str, problem: str) -> None:
        """Open (or start) the journal at ``path`` for ``problem`` (a line naming it).

        Raises:
            RuntimeError: The file names another problem (on every rank).
        """
        self.comm, self.path, self.problem = comm, path, problem
        got, error = None, ""
        if comm.rank == 0:
            try:
                got = self._read()
            except (OSError, ValueError) as err:
                error = f"count journal {path}: {err}"
        got, error = comm.bcast((got, error), root=0)
        if error:
            raise RuntimeError(error)
        self.values: dict[complex, complex] = got
        self.reused = 0

    def _read(self) -> dict[complex, complex]:
        if not os.path.exists(self.path):
            os.makedirs(os.path.dirname(self.path) or ".", exist_ok=True)
            with open(self.path, "w") as f:
                f.write(f"# {self.problem}\n{self.HEADER}\n")
            return {}
        out: dict[complex, complex] = {}
        with open(self.path) as f:
            lines = f.read().split("\n")
        if lines[:2] != [f"# {self.problem}", self.HEADER]:
            raise ValueError(f"it belongs to another problem ({lines[0]!r}, this one: "
                             f"'# {self.problem}'): remove it or use another --out")
        for line in lines[2:]:
            parts = line.split(",")
            if len(parts) != 4:  # the last line of a stopped write, or the final newline
                continue
            a, b, c, d = (float(v) for v in parts)
            out[complex(a, b)] = complex(c, d)
        return out

    def __call__(self, z: np.ndarray, compute: Callable[[np.ndarray], np.ndarray],
                 written: Callable[[], object] | None = None) -> np.ndarray:
        """``compute(z)`` with the samples already journalled taken from the journal.

        ``written`` is called after each chunk is written (progress within a long batch).
        """
        z = np.atleast_1d(np.asarray(z, dtype=complex))
        flat = z.ravel()
        have = [self.values.get(complex(w)) for w in flat]
        missing = np.array([v is None for v in have], dtype=bool)
        out = np.array([0j if v is None else v for v in have], dtype=complex)
        self.reused += int((~missing).sum())
        todo = np.flatnonzero(missing)
        for lo in range(0, todo.size, self.CHUNK):  # written as it goes, a chunk at a time
            idx = todo[lo:lo + self.CHUNK]
            new = np.asarray(compute(flat[idx]), dtype=complex).ravel()
            out[idx] = new
            self._append(flat[idx], new)
            if written is not None:
                written()
        return out.reshape(z.shape)

    def _append(self, z: np.ndarray, new: np.ndarray) -> None:
        """Keep and write (rank 0, flushed to disk) the values ``new`` at the points ``z``."""
        self.values.update(zip(map(complex, z), map(complex, new), strict=True))
        error = ""
        if self.comm.rank == 0:
            try:
                with open(self.path, "a") as f:
                    f.write("".join(f"{w.real!r},{w.imag!r},{v.real!r},{v.imag!r}\n"
                                    for w, v in zip(map(complex, z), map(complex, new),
                                                    strict=True)))
                    f.flush()
                    os.fsync(f.fileno())
            except OSError as err:  # e.g. a full disk: every rank stops, not rank 0 alone
                error = f"count journal {self.path}: {err.strerror or err}"
        error = self.comm.bcast(error, root=0)
        if error:
            raise OSError(error)


def _wind_nudged(logf: Callable[[np.ndarray], np.ndarray], bx: Box,
                 spurious: Sequence[complex], n_initial: int, nudge: float,
                 tries: int) -> tuple[int, np.ndarray, Box]:
    """The winding number on ``bx``'s edge, the box nudged outwards if a root is on it.

    On a :class:`ContourError` the box is enlarged by ``nudge`` of its size on every side and
    wound again (up to ``tries`` times).

    Returns:
        ``(count, samples, box_used)``.
    """
    for attempt in range(tries):
        try:
            n, t = winding(logf, bx, n_initial=n_initial, samples=True)
            return n, t, bx
        except ContourError:
            if attempt == tries - 1:
                raise
            a, b, c, d = bx
            da, dc = nudge * (b - a), nudge * (d - c)
            bx = _check_box((a - da, b + da, c - dc, d + dc), spurious)
    raise ValueError("tries must be at least 1")


def count_in_box(matrices: Sequence[PETSc.Mat], box: Sequence[float],
                 spurious: Sequence[complex] = (-1.0 + 0j,), *, cleared_rows: int = 0,
                 prefix: str = "region_det_", n_initial: int = 16, nudge: float = 1e-3,
                 tries: int = 3, split: bool = False,
                 reference: Sequence[PETSc.Mat] | None = None,
                 deflate: Sequence[complex] = (),
                 progress: Callable[[str], object] | None = None,
                 journal: SampleJournal | None = None) -> tuple[int, Box, dict]:
    """Discrete eigenvalues of ``T_h`` in ``box``: the winding number of ``det T_h`` on its edge.

    ``det T_h`` is a polynomial in ``Lambda`` (no poles), so the winding number is the number of
    zeros inside, with multiplicity. The samples are those of
    ``F = det T_h / prod_s (Lambda - s)^cleared_rows`` (``s`` in ``spurious``, all outside the
    box: the divisor winds 0 times, the count is the same for any ``cleared_rows``). With
    ``cleared_rows`` = the rows multiplied by the cleared denominator
    (:attr:`forms.friction.FrictionOperator.cleared_rows`), ``F`` is the determinant of the
    rational operator, in which the cluster of ``cleared_rows`` discrete eigenvalues next to
    each ``s`` (one per interface node: -1.0002 .. -1.07 on the block L = 2, P2) is cancelled by
    as many poles; undivided, that cluster makes the phase turn about half a time per interface
    node along the far edge (measured, edge ``Re = 0.6``: 20.0, 24.6, 28.7 turns with 17, 25, 33
    nodes; 12.4, 13.4, 13.8 divided) and the sampling grow with the mesh. If an
    eigenvalue lies on (or extremely near) the contour
    (:class:`~analytic.numerics.roots.ContourError`), the box is enlarged by ``nudge`` times its
    size on every side and counted again (up to ``tries`` times); the box actually used is
    returned. ``split``: the samples shared among the ranks (:class:`LogDet`).

    ``reference``: matrices ``R_0, ..., R_e`` of an operator with **no eigenvalue in the box**
    (the caller's guarantee, e.g. an undamped elastic ``K + Lambda^2 M``: real symmetric,
    ``M`` positive definite, eigenvalues on the imaginary axis, none in a box with ``re_min >
    0``); the samples are then those of ``F / det R(Lambda)`` (a second LU per sample, prefix
    ``prefix + "ref_"``), whose winding number is the same count. Its use: where ``T`` is
    ``R`` plus a low-rank part (the friction rows), the phase of ``det R`` carries the whole
    dense spectrum's turning along the box's long edges and the quotient's phase turns slowly
    (measured, block L = 16, P2, 8 x 8 per unit, edge ``Re = 0.2``, ``Im`` 60 to 61: 149 rad per
    unit of arc for ``F``, 0.24 for the quotient).

    ``deflate``: known eigenvalues in the box, divided out: the count of the others
    (:meth:`RegionSolver._verify`). ``progress``: called with ``"count: N samples, T s"``.
    ``journal``: the samples of ``log det T_h - log det R_h`` kept on disk as computed and
    taken from it where already there (:class:`SampleJournal`: a stopped count resumes).

    Returns:
        ``(count, box_used, info)`` with ``info`` = evaluations (LU factorisations), seconds
        and ``samples`` (the arc-length parameters of the samples counted: :func:`unresolved`).
    """
    bx = _check_box(box, spurious)
    logdet = LogDet(matrices, prefix, split)
    logref = None if reference is None else LogDet(reference, prefix + "ref_", split)

    def raw(z: np.ndarray) -> np.ndarray:
        out = logdet(z)
        return out - logref(z) if logref is not None else out

    def report() -> None:
        if progress is not None:
            spent = logdet.seconds + (logref.seconds if logref else 0.0)
            kept = f" (and {journal.reused} from the journal)" if journal and journal.reused \
                else ""
            progress(f"count: {logdet.evaluations} samples{kept}, {spent:.0f} s")

    def logf(z: np.ndarray) -> np.ndarray:
        z = np.atleast_1d(np.asarray(z, dtype=complex))
        out = raw(z) if journal is None else journal(z, raw, report)
        for s in spurious if cleared_rows else ():
            # an integer multiple of 2 pi i across the branch cut: the wrapped increments of
            # :func:`winding` do not see it
            out = out - cleared_rows * np.log(z - s)
        for s in deflate:  # the same: a multiple of 2 pi i, unseen
            out = out - np.log(z - s)
        report()
        return out

    try:
        n, t, bx = _wind_nudged(logf, bx, spurious, n_initial, nudge, tries)
        spent = logdet.seconds + (logref.seconds if logref else 0.0)
        return n, bx, {"evaluations": logdet.evaluations, "seconds": spent, "samples": t}
    finally:
        logdet.destroy()
        if logref is not None:
            logref.destroy()


@dataclass
class RegionResult:
    """Eigenpairs of ``T`` in a box.

    Attributes:
        box: ``(re_min, re_max, im_min, im_max)`` actually used (the count may nudge it).
        values: Eigenvalues in the box (sorted by decreasing real part).
        residuals: Relative residuals ``||T u|| / (sum_j |L|^j ||A_j||_F ||u||)``.
        vectors: PETSc eigenvectors (owned by the caller: :meth:`destroy`).
        counted: Argument-principle count (``None`` if not counted).
        tiles: Tiles solved (including those split).
        seconds: ``{"solve": ..., "count": ...}``.
        count_evaluations: LU factorisations of the count.
        restarts: Most SLEPc restarts (``PEP.getIterationNumber``) of one tile solve.
        counts: The first count and each verification's total (``found`` then ``+`` its count;
            :meth:`RegionSolver._verify`): ``counted`` is the last; empty without a count.
    """

    box: Box
    values: np.ndarray
    residuals: np.ndarray
    vectors: list[PETSc.Vec]
    counted: int | None
    tiles: int = 0
    seconds: dict = field(default_factory=dict)
    count_evaluations: int = 0
    restarts: int = 0
    counts: list[int] = field(default_factory=list)

    @property
    def recounts(self) -> int:
        """Verification counts made (the count with the values found divided out)."""
        return max(len(self.counts) - 1, 0)

    @property
    def found(self) -> int:
        """Number of eigenvalues found in the box."""
        return int(len(self.values))

    @property
    def closed(self) -> bool:
        """The certificate: every counted eigenvalue found, none more."""
        return self.counted is not None and self.found == self.counted

    def conjugate_gap(self) -> float:
        """Largest ``|conj(z) - nearest w| / max(|z|, 1)`` over the set (0 for a symmetric one)."""
        z = self.values
        if z.size == 0:
            return 0.0
        d = np.abs(np.conj(z)[:, None] - z[None, :]).min(axis=1)
        return float(np.max(d / np.maximum(np.abs(z), 1.0)))

    def record(self) -> dict:
        """JSON-ready summary (no vectors)."""
        return {"box": list(self.box), "found": self.found, "counted": self.counted,
                "closed": self.closed, "tiles": self.tiles, "seconds": self.seconds,
                "count_evaluations": self.count_evaluations, "restarts": self.restarts,
                "recounts": self.recounts, "counts": list(self.counts),
                "values": [[z.real, z.imag] for z in self.values],
                "residuals": [float(r) for r in self.residuals]}

    def destroy(self) -> None:
        """Destroy the eigenvectors."""
        for v in self.vectors:
            v.destroy()
        self.vectors = []


def _residual(matrices: Sequence[PETSc.Mat], norms: np.ndarray, lam: complex,
              v: PETSc.Vec) -> float:
    r, tmp = v.duplicate(), v.duplicate()
    r.set(0.0)
    for j, a in enumerate(matrices):
        a.mult(v, tmp)
        r.axpy(lam**j, tmp)
    num = r.norm()
    den = float(np.sum(np.abs(lam) ** np.arange(len(matrices)) * norms)) * v.norm()
    r.destroy()
    tmp.destroy()
    return float(num / den) if den > 0 else float("inf")


def inverted(matrices: Sequence[PETSc.Mat], pole: complex) -> list[PETSc.Mat]:
    """``B_0, ..., B_d`` with ``mu^d T(pole + 1/mu) = sum_k mu^k B_k`` (``T = sum_j L^j A_j``).

    ``B_k = sum_j binom(j, i) pole^i A_j`` with ``i = k - d + j`` (``0 <= i <= j``): ``B_0 =
    A_d``, ``B_d = T(pole)``. The eigenvalues are ``mu = 1/(Lambda - pole)`` with the same
    vectors; ``Lambda = infinity`` (the Dirichlet rows) goes to ``mu = 0``, the eigenvalues next
    to ``pole`` far away. Every ``B_k`` has the union pattern of the ``A_j`` (owned by the
    caller).
    """
    d = len(matrices) - 1
    union = _Combination(matrices)
    out = []
    for k in range(d + 1):
        b = union.mat.duplicate(copy=False)
        for j, a in enumerate(matrices):
            i = k - d + j
            if 0 <= i <= j:
                b.axpy(math.comb(j, i) * complex(pole) ** i, a,
                       PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
        out.append(b)
    union.destroy()
    return out


def inverted_disc(centre: complex, radius: float, pole: complex) -> tuple[complex, float] | None:
    """Image ``(centre, radius)`` of the disc ``|Lambda - centre| <= radius`` in ``mu``.

    ``mu = 1/(Lambda - pole)``; ``None`` if the disc holds ``pole`` (its image is no disc).
    """
    a = complex(centre) - pole
    den = abs(a) ** 2 - radius**2
    if den <= 1e-12 * abs(a) ** 2:
        return None
    return a.conjugate() / den, radius / den


class RegionSolver:
    """Every eigenpair of ``sum_j Lambda^j A_j`` in a box: PEP shift-and-invert over tiles.

    With ``invert`` (default), each tile is solved in ``mu = 1/(Lambda - s)`` (:func:`inverted`;
    ``s`` the spurious root nearest the box), with its disc mapped by :func:`inverted_disc`
    (discs go to discs: "the nearest ``nev`` in ``mu``" is again "every eigenvalue of the
    tile's disc" when the farthest lies outside the mapped disc). Reason: each interface node
    adds a discrete eigenvalue next to ``s`` (the state variable's relaxation; -1.0002 ..
    -1.07 on the block L = 2, P2), a near-degenerate cluster that grows with the mesh; in
    ``Lambda`` it is the nearest set of every tile near the real axis whose own eigenvalues are
    fewer than ``nev`` (measured, target 0.31, block L = 2: 8 cluster members in 89 restarts at
    350 unknowns, none converged in 300 restarts at 1274, 19 s; the 12 tiles of the box
    ``(0.02, 0.6, -10, 10)`` at 350 unknowns: at most 299 restarts in ``Lambda``, 13 in ``mu``);
    in ``mu`` it lies beyond ``1/0.07``. A tile disc holding ``s`` is not mapped (``Lambda`` is
    used for it).

    Args:
        comm: Communicator of the matrices.
        nev: Eigenpairs per tile solve.
        tol: SLEPc tolerance.
        max_it: SLEPc maximum restarts.
        prefix: Options prefix of the PEP (the count's LU: ``prefix + "det_"``).
        max_tiles: Largest number of tile solves before giving up (the result is then open).
        invert: Solve the tiles in ``mu`` (above); ``False``: in ``Lambda``.
    """

    def __init__(self, comm: MPI.Comm, nev: int = 12, tol: float = 1e-12, max_it: int = 300,
                 prefix: str = "region_", max_tiles: int = 400, invert: bool = True) -> None:
        self.comm = comm
        self.prefix = prefix
        self.max_tiles = max_tiles
        self.invert = invert
        self.pep = sinvert_pep(comm, nev, tol, max_it, prefix)

    def settings(self) -> dict[str, object]:
        """Solver settings in use (for summaries)."""
        pep = self.pep
        st = pep.getST()
        tol, max_it = pep.getTolerances()
        return {"eigensolver": "SLEPc PEP over a tiling of the box", "type": pep.getType(),
                "st": st.getType(), "factor_solver": st.getKSP().getPC().getFactorSolverType(),
                "nev_per_tile": pep.getDimensions()[0], "tol": tol, "max_it": max_it,
                "options_prefix": pep.getOptionsPrefix() or "",
                "count": "argument principle on log det T_h (MUMPS ICNTL(33))",
                "tiles_in": ("mu = 1/(Lambda - s), s the spurious root nearest the box"
                             if self.invert else "Lambda")}

    def _solve_at(self, mats: Sequence[PETSc.Mat], target: complex
                  ) -> list[tuple[complex, PETSc.Vec]]:
        pep = self.pep
        # setOperators resets the solver's state: without it, a new target alone is not taken
        # by the second solve (SLEPc 3.18 returned the previous tile's eigenvalues)
        pep.setOperators(list(mats))
        pep.setTarget(target)
        pep.solve()
        self._restarts = max(self._restarts, pep.getIterationNumber())
        out = []
        for i in range(pep.getConverged()):
            v = mats[0].createVecRight()
            lam = complex(pep.getEigenpair(i, v))
            out.append((lam, v))
        return out

    def _tile(self, centre: complex, radius: float, nev: int
              ) -> tuple[list[tuple[complex, PETSc.Vec]], bool]:
        """Pairs ``(Lambda, v)`` of one tile solve and whether they cover the tile's disc."""
        disc = None if self._pole is None else inverted_disc(centre, radius, self._pole)
        mats, (c, r) = (self._mats, (centre, radius)) if disc is None else (self._inv, disc)
        # off the centre by 1e-3 of the disc: a shift on an eigenvalue is singular
        pairs = self._solve_at(mats, shift_off(c, 1e-3 * r / max(abs(c), 1.0)))
        pairs.sort(key=lambda p: abs(p[0] - c))
        # covered: the farthest converged pair lies outside the disc (SLEPc converges the
        # pairs nearest the shift first; it may return fewer than nev)
        covered = bool(pairs) and abs(pairs[min(nev, len(pairs)) - 1][0] - c) > r
        if disc is not None:
            keep = [(self._pole + 1.0 / mu, v) for mu, v in pairs if mu != 0]
            for mu, v in pairs:
                if mu == 0:
                    v.destroy()
            pairs = keep
        return pairs, covered

    def solve(self, matrices: Sequence[PETSc.Mat], box: Sequence[float],
              spurious: Sequence[complex] = (-1.0 + 0j,), *, count: bool = True,
              expected: int | None = None, tiles: tuple[int, int] | None = None,
              cleared_rows: int = 0, split_count: bool = False,
              reference: Sequence[PETSc.Mat] | None = None,
              progress: Callable[[str], object] | None = None,
              journal: SampleJournal | None = None) -> RegionResult:
        """Every eigenpair in ``box``; with ``count``, the argument-principle count too.

        Args:
            matrices: ``A_0, ..., A_d`` (the cleared polynomial form).
            box: ``(re_min, re_max, im_min, im_max)``.
            spurious: Roots of the cleared denominator (outside the box; dropped).
            cleared_rows: Rows multiplied by the cleared denominator, divided out of the
                count's samples (:func:`count_in_box`; the count does not change).
            count: Count the eigenvalues in the box (:func:`count_in_box`) first; the tiling
                starts with about ``counted / (nev / 2)`` tiles and stops as soon as the
                count is found (the count, not the cover, is the certificate).
            expected: Without ``count``: stop once this many are found (e.g. the count of a
                coarser mesh, for an estimate); else every tile is solved until covered.
            tiles: Initial tiling ``(n_re, n_im)``; default about ``counted / (nev / 2)``
                tiles, none more than three times taller than wide.
            split_count: The count's samples shared among the ranks, each with a serial LU
                of a whole copy of the matrices (:class:`LogDet`); the tiles stay parallel.
            reference: An operator without eigenvalues in the box whose determinant divides
                the count's samples (:func:`count_in_box`).
            progress: Called with a short line after every batch of the count's samples and
                every tile (``"tiles: 3 solved, 5 of 12 found"``); the verification's count
                lines start with ``"verify "``.
            journal: The count's samples on disk (:class:`SampleJournal`; the verification's
                too): a stopped count resumes from it.

        Returns:
            :class:`RegionResult` (``closed`` is the certificate; with ``count``, verified by
            :meth:`_verify`).
        """
        bx = _check_box(box, spurious)
        counted, info = None, {"evaluations": 0, "seconds": 0.0}
        if count:
            counted, bx, info = count_in_box(matrices, bx, spurious, cleared_rows=cleared_rows,
                                             prefix=self.prefix + "det_", split=split_count,
                                             reference=reference, progress=progress,
                                             journal=journal)
        a, b, c, d = bx
        nev = self.pep.getDimensions()[0]
        stop_at = counted if count else expected
        if counted == 0:
            return RegionResult(bx, np.zeros(0, complex), np.zeros(0), [], 0, 0,
                                {"solve": 0.0, "count": info["seconds"]}, info["evaluations"],
                                counts=[0])
        n_re, n_im = tiles if tiles is not None else _initial_tiles(bx, stop_at, nev)
        shape = (len(matrices), matrices[0].getSize())
        if getattr(self, "_shape", shape) != shape:
            self.pep.reset()  # SLEPc 3.18 keeps work arrays of the previous size
        self._shape = shape
        self._prepare(matrices, bx, spurious)
        norms = np.array([m.norm(PETSc.NormType.FROBENIUS) for m in matrices])
        scale = max(b - a, d - c)
        t0 = time.perf_counter()
        todo = _tile_list(bx, n_re, n_im)
        kept: list[tuple[complex, PETSc.Vec]] = []
        solved = self._cover(todo, kept, bx, spurious, nev, stop_at, progress)
        t_solve = time.perf_counter() - t0
        counts = [counted] if count else []
        if count:
            solved, t_more = self._verify(matrices, bx, spurious, todo, kept, counts, info,
                                          dict(cleared_rows=cleared_rows, split=split_count,
                                               reference=reference, journal=journal),
                                          progress, solved)
            t_solve += t_more
        counted = counts[-1] if counts else None
        self._release()
        # by decreasing real part; a conjugate pair (real parts equal to rounding) in a fixed
        # order, Im <= 0 first, so that "the fastest" is the same value in every run
        kept.sort(key=lambda p: (-round(p[0].real / scale, 9), p[0].imag))
        values = np.array([p[0] for p in kept], dtype=complex)
        residuals = np.array([_residual(matrices, norms, lam, v) for lam, v in kept])
        return RegionResult(bx, values, residuals, [v for _, v in kept], counted, solved,
                            {"solve": t_solve, "count": info["seconds"]},
                            info["evaluations"], self._restarts, counts)

    def _prepare(self, matrices: Sequence[PETSc.Mat], bx: Box,
                 spurious: Sequence[complex]) -> None:
        """The solve's state: its matrices and, with ``invert``, the inverted operator.

        The operator is inverted about the spurious root nearest the box (:func:`inverted`).
        """
        self._mats = list(matrices)
        self._pole, self._restarts, self._inv = None, 0, []
        if self.invert and spurious:
            self._pole = complex(min(spurious, key=lambda z: _distance(bx, z)))
            self._inv = inverted(matrices, self._pole)

    def _verify(self, matrices: Sequence[PETSc.Mat], bx: Box, spurious: Sequence[complex],
                todo: list[Box], kept: list, counts: list[int], info: dict, options: dict,
                progress: Callable[[str], object] | None, solved: int) -> tuple[int, float]:
        """The verification of :meth:`solve`: ``counts`` and ``info`` updated in place.

        If the tiles found a number other than the count, or two found values lie in one
        interval of the count's samples, both closer to the contour than it is long
        (:func:`unresolved`: the count may have missed them), the box is counted again with the
        found values divided out (``deflate`` of :func:`count_in_box`): ``found + that count``
        replaces the count; while it exceeds ``found``, the tiles left by the first pass are
        solved on (at most :data:`MAX_RECOUNTS` times). Returns the tiles solved in all and
        the seconds of the tiles added here.
        """
        nev, t_solve = self.pep.getDimensions()[0], 0.0
        samples = info.get("samples", ())
        while len(counts) <= MAX_RECOUNTS and (
                len(kept) != counts[-1] or (len(counts) == 1 and unresolved(
                    bx, samples, [p[0] for p in kept]))):
            try:
                extra, _, more = count_in_box(
                    matrices, bx, spurious, tries=1, prefix=self.prefix + "det_",
                    deflate=[p[0] for p in kept], **options,
                    progress=None if progress is None else (lambda x: progress("verify " + x)))
            except ContourError:
                break  # counted stays the first count's: not closed if it differs
            info["evaluations"] += more["evaluations"]
            info["seconds"] += more["seconds"]
            counts.append(len(kept) + extra)
            if extra <= 0 or not todo:
                break
            t0 = time.perf_counter()
            solved += self._cover(todo, kept, bx, spurious, nev, counts[-1], progress)
            t_solve += time.perf_counter() - t0
        return solved, t_solve

    def _cover(self, todo: list[Box], kept: list[tuple[complex, PETSc.Vec]], bx: Box,
               spurious: Sequence[complex], nev: int, stop_at: int | None,
               progress: Callable[[str], object] | None) -> int:
        """The tiles ``todo`` solved (last first, popped), the uncovered ones split (pushed).

        New distinct eigenpairs in ``bx`` are appended to ``kept``, until ``stop_at`` are kept
        or every tile is covered; ``todo`` keeps the tiles not solved. Returns the tiles solved.
        """
        scale = max(bx[1] - bx[0], bx[3] - bx[2])
        solved = 0
        while todo and solved < self.max_tiles and (stop_at is None
                                                     or len(kept) < stop_at):
            ta, tb, tc, td = todo.pop()
            centre = complex(0.5 * (ta + tb), 0.5 * (tc + td))
            radius = 0.5 * math.hypot(tb - ta, td - tc)
            pairs, covered = self._tile(centre, radius, nev)
            solved += 1
            _keep_new(pairs, kept, bx, scale, spurious)
            if progress is not None:
                progress(f"tiles: {solved} solved, {len(kept)}"
                         + (f" of {stop_at}" if stop_at is not None else "") + " found")
            # SLEPc may converge fewer than nev pairs: a tile that small is not split further
            # (without this, measured: endless splits towards a box corner, 7 of 8 converged)
            if not covered and radius > 1e-3 * scale:
                xm, ym = 0.5 * (ta + tb), 0.5 * (tc + td)
                todo += [(ta, xm, tc, ym), (xm, tb, tc, ym), (ta, xm, ym, td), (xm, tb, ym, td)]
        return solved

    def _release(self) -> None:
        for b in getattr(self, "_inv", []):
            b.destroy()
        self._inv = []

    def destroy(self) -> None:
        """Destroy the SLEPc object (and the inverted matrices of an interrupted solve)."""
        self._release()
        self.pep.destroy()
