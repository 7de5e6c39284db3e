"""The certified complete spectrum at one ``k``: FE eigenvalues, their count, exact roots.

docs/design.md section 8. For every requested ``k`` and a rectangle ``R`` (by default the
:class:`analytic.numerics.spectrum.Region` at ``k``), with the default ``solver="linear"``:

1. FE count: the argument principle on ``log det T_h`` along the boundary of ``R``
   (:meth:`forms.solvers.condensed.CondensedOperator.count_and_samples`: adaptive contour points,
   ``det T_h = det M_II prod_j (z^2 + w_j) det S(z)`` by the Schur-complement identity on the
   quadratic interior block, the same determinant as one banded LU per point,
   ``count="banded"``) gives ``N_FE``;
2. FE eigenvalues, with no exact root as input: the eigenvalues of one dense linear
   eigenproblem of the condensed form
   (:meth:`forms.solvers.condensed.CondensedOperator.linear_eigs`), each polished by Newton on
   the discrete nonlinear eigenproblem; where they are fewer than ``N_FE`` (or with
   ``solver="moments"``), contour-integral moments of ``T_h(z)^{-1} V`` on the same contour
   points (Beyn's method, :meth:`forms.solvers.banded.BandedOperator.moment_eigs`), each
   predictor polished the same way; the count closes when the distinct values found inside
   ``R`` are ``N_FE`` (the count comes from neither, so a missed eigenvalue shows). In a sweep
   (``follow=True``) the FE's own eigenpairs of the previous ``k``, extrapolated in ``k``
   (:meth:`CertifiedSolver.predictors`), are tried first, and the linearisation runs only
   where they do not give ``N_FE`` values (an eigenvalue entering ``R``, a Newton failure);
3. error estimate: one Newton solve on the degree ``p + 1`` discretisation started from the
   FE value gives ``|Lambda_p - Lambda_{p+1}| / |Lambda_{p+1}|``;
4. with ``check_exact`` (default) the exact side is consulted afterwards: the argument-principle
   count ``N_exact`` of ``det_M`` in ``R`` and every exact root with the label of its family
   (:func:`analytic.numerics.spectrum.certified_roots`); each FE value is matched to a distinct
   exact root (nearest both ways), which gives its label and its error; the count closes only if
   also ``N_exact == N_FE``. Without ``check_exact`` nothing of ``analytic``'s roots or families
   is used and the labels are ``fe0, fe1, ...`` in the order of ``|Im Lambda|``.

``solver="newton"`` is the former path: every exact root is the predictor of a Newton
iteration, then the FE count (kept for comparison, ``--solver newton``).

A row's ``status`` is ``ok`` only if the count closes, the estimate is within ``rtol`` and,
when checked, its label is certified and its error against the exact root is within ``rtol``;
otherwise the status says which check failed. Its ``certificate`` says what it carries: ``fe``
(count closed, estimate within ``rtol``) and/or ``exact`` (matched to a distinct exact root of
a closed exact count, error within ``rtol``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from mpi4py import MPI

from analytic.numerics.branches import BranchResult
from analytic.numerics.continuation import Path
from analytic.numerics.roots import Box, ContourError
from analytic.numerics.spectrum import Region, certified_roots, on_usable_box
from analytic.params import Params
from forms.models.profiles import SliderMaterial
from forms.models.section import SectionModel, contour_samples, section_stack
from forms.solvers.banded import BandedModel, BandedOperator, Eigen, is_new, predicted_near
from forms.solvers.condensed import CondensedModel, CondensedOperator
from forms.solvers.partial import NearModel

#: Columns of one spectrum row, in CSV order.
ROW_FIELDS = ("k", "label", "re_lambda", "im_lambda", "re_lambda_exact", "im_lambda_exact",
              "rel_error", "error_estimate", "residual", "status", "certificate")
#: Ways of finding the FE eigenvalues (``--solver``): linearised predictors (moments where they
#: fall short), contour moments only, or exact-seeded.
SOLVERS = ("linear", "moments", "newton")
#: Ways of evaluating ``det T_h`` on the contour: condensed (default) or one banded LU a point.
COUNTS = ("condensed", "banded")
#: Unknowns from which the interior modes are found banded and lazily
#: (:class:`forms.solvers.partial.NearModel`) instead of by one dense ``eigh`` per ``k``
#: (:class:`forms.solvers.condensed.CondensedModel`): per ``k`` (modes, count and linearised
#: predictors, one rank, 2026-11-28) the two cost 0.062 s against 0.056 s at 384 interior rows,
#: 0.23 against 0.25 s at 728, 0.40 against 0.44 s at 1 007 and 1.23 against 2.22 s at 1 760.
NEAR_MIN = 900
#: Solves of a sweep (:meth:`CertifiedSolver.predictors`) through which each eigenvalue is
#: extrapolated in ``k`` (3: quadratic).
FOLLOW_POINTS = 3
#: Continuation only to a ``k`` at most this many times the last two solves' spacing away
#: (``--k 50,51``: one solve before, the step 2 % of ``k``; continued from it, the run took
#: 1.1x the CPU of none, session 17).
FOLLOW_REACH = 2.0
#: Newton steps a continued predictor may take (two or three where it is good: the default
#: sweeps, session 17).
FOLLOW_MAXIT = 5
#: Solves without continuation after one whose predictors went astray (as many inside the box
#: as counted, or more, but fewer distinct eigenvalues in it). A grid too coarse for the
#: predictors (``--bc stress --k 0.5:30:60 --c-max 4``: 49 of 60 ``k`` fell back, most with
#: one or two of 6-39 predictors lost) cost 1.17x the CPU of no continuation before this rule;
#: on the default stress sweep one attempt of 123 went astray (session 17).
FOLLOW_PAUSE = 4
#: Most eigenvalues :meth:`CertifiedSolver._continuation` finds beyond its predictors, from the
#: count's power sums (:func:`missing_roots`): ``u``'s first three sums carried 1.5e-6
#: (:meth:`forms.solvers.condensed.CondensedOperator.power_sums`), well within Newton's reach.
FILL_MAX = 3
#: Largest count of one box of contour moments (:func:`split_box`): the moments' cost per contour
#: point grows with the block width (about ``3/4`` of the count), the count's does not.
MAX_PER_BOX = 16


def split_box(counter: Callable[[Box], tuple[int, np.ndarray]], box: Box, count: int,
              t: np.ndarray, most: int) -> list[tuple[Box, int, np.ndarray]]:
    """Boxes tiling ``box``, each with at most ``most`` eigenvalues by its own count.

    ``box`` (counted ``count``, contour parameters ``t``) is cut across its longer side, in
    units of ``Im`` for the tall boxes of the sweep, into ``ceil(2 count / most)`` equal parts;
    each part is counted by the argument principle (``counter``), a part over ``most`` is split
    again. A cut through (or too near) an eigenvalue makes its part's count fail
    (:class:`~analytic.numerics.roots.ContourError`): the cut is moved by ``1e-4``, ``-1e-4``,
    ``3e-4`` ... of the part's size. The parts' counts are returned as counted: the caller
    checks that they add up to ``count`` (the contour integrals along the cuts cancel).

    Returns:
        ``[(part, count, t), ...]``, from the bottom (or left) up.

    Raises:
        ContourError: No usable cut.
    """
    if count <= most:
        return [(box, count, t)]
    a, b, c, d = box
    pieces = max(2, math.ceil(2 * count / most))
    tall = (d - c) >= (b - a)
    lo, hi = (c, d) if tall else (a, b)
    step = (hi - lo) / pieces
    out: list[tuple[Box, int, np.ndarray]] = []
    start = lo
    for i in range(1, pieces + 1):
        for shift in (0.0, 1e-4, -1e-4, 3e-4, -3e-4, 1e-3, -1e-3):
            cut = hi if i == pieces else lo + i * step + shift * step
            part = (a, b, start, cut) if tall else (start, cut, c, d)
            try:
                n, tp = counter(part)
                break
            except ContourError:
                if i == pieces:
                    raise
        else:
            raise ContourError(f"no usable cut near {lo + i * step:.6g} in {box}")
        out += split_box(counter, part, n, tp, most) if n > most else [(part, n, tp)]
        start = cut
    return out


def _find(fe: BandedOperator, counter: Callable, box: Box, count: int, t: np.ndarray,
          most: int, sums: Callable | None, lin: Callable | None,
          cont: Callable[[Box, int], list[Eigen]] | None, polish: Callable[..., list[Eigen]]
          ) -> tuple[list[Eigen], bool, str, str]:
    """The eigenpairs in ``box``: continued or linearised predictors, else moments per part.

    ``cont(box, count)`` (the FE's own eigenpairs of the previous ``k``, continued and
    Newton-polished: :meth:`CertifiedSolver.predictors`) is tried first; then ``lin(box)``
    (:meth:`forms.solvers.condensed.CondensedOperator.linear_eigs`) gives predictors with
    vectors for the whole box. A set is kept when as many distinct values as
    ``count`` lie inside (the count comes from neither: a missed eigenvalue sends the search
    on). Otherwise (too large a pencil, or a value missing) the moments run per part of
    :func:`split_box` and the note says why. ``polish`` polishes the linearised predictors
    (``fe.polish`` or :func:`_polisher`'s).

    Returns:
        ``(found, the parts' counts add up to count, note, found_by)``: ``found_by`` is
        ``continuation``, ``linearised`` or ``moments``.
    """
    note = ""
    bx = tuple(float(v) for v in box)
    if cont is not None and count > 0:
        found = cont(bx, count)
        if len(found) == count:
            return found, True, "", "continuation"
    if lin is not None and count > 0:
        try:
            found = polish(*lin(box), bx, exact_start=True)
            if len(found) == count:
                return found, True, "", "linearised"
            note = f"linearised predictors gave {len(found)} of {count}: moments"
        except NotImplementedError as err:
            note = f"moments: {err}"
    try:
        parts = split_box(counter, box, count, t, most)
    except ContourError as err:  # no usable cut: the whole box in one block
        parts = [(box, count, t)]
        note = "; ".join(x for x in (note, f"box not split: {err}") if x)
    ok = sum(n for _, n, _ in parts) == count
    if not ok:
        note = "; ".join(x for x in (note, f"counts of the sub-boxes {[n for _, n, _ in parts]}"
                                     f" do not add up to {count}") if x)
    found: list[Eigen] = []
    for part in parts:
        found += _moments_in(fe, *part, sums)
    return found, ok, note, "moments"


def _moments_in(fe: BandedOperator, box: Box, count: int, t: np.ndarray,
                sums: Callable | None) -> list[Eigen]:
    """:meth:`BandedOperator.moment_eigs` in one box, one retry if it finds too few."""
    found = fe.moment_eigs(box, count, t, sums=sums)
    if len(found) != count:
        # one retry with a larger subspace and another random block; merged, distinct
        for e in fe.moment_eigs(box, count, t, moments=4, extra=count + 8, seed=7, sums=sums):
            if is_new(e.value, found):
                found.append(e)
    return found


def _label_by_frequency(rows: list[dict]) -> bool:
    """Labels ``fe0, fe1, ...`` in the order of ``|Im Lambda|`` (no exact check); ``True``."""
    for j, row in enumerate(sorted(rows, key=lambda r: (abs(r["im_lambda"]), r["im_lambda"]))):
        row["label"] = f"fe{j}"
    return True


def _distinct(values: list[complex]) -> bool:
    """No two of ``values`` within ``1e-9`` relative (the count's distinct eigenvalues)."""
    return all(abs(values[a] - values[b]) > 1e-9 * max(1.0, abs(values[a]))
               for a in range(len(values)) for b in range(a))


def _polisher(fe: BandedOperator, cond: CondensedOperator | None
              ) -> Callable[..., list[Eigen]]:
    """``fe.polish`` with every predictor first polished by Newton on the condensed form.

    All predictors near the box at once (:meth:`forms.solvers.condensed.CondensedOperator.
    newton_many`, one vectorised step for all), each with its null vector
    (:meth:`~forms.solvers.condensed.CondensedOperator.null_vector_pairs`); a pair is kept by
    the banded Newton's own test (converged and residual on ``T`` below ``1e-10``), the others
    go to ``fe.polish``. Each kept value has had one two-sided Rayleigh step on ``T_h``
    (:meth:`forms.solvers.banded.BandedOperator.rayleigh_step`). The count that closes the
    solve is unchanged; a value lost here (two
    predictors on one eigenvalue) leaves it open, as a failed banded Newton does.
    """
    if cond is None or not cond.has_left:
        return fe.polish

    def polish(lam: np.ndarray, vecs: np.ndarray, bx: Box, *, exact_start: bool = False,
               maxit: int = 12) -> list[Eigen]:
        a0, b0, c0, d0 = bx
        near = np.flatnonzero(predicted_near(lam, bx))
        near = near[np.argsort(lam[near].real, kind="stable")]
        z, conv, its, steps = cond.newton_many(lam[near], maxit=maxit)
        x, y = cond.null_vector_pairs(z[conv])
        # one two-sided Rayleigh step on T_h itself: the value of T_h to rounding (the condensed
        # values alone differed by up to 1.6e-12 between a sparse and a dense list of k)
        zr, res = fe.rayleigh_step(z[conv], x, y)
        kept, rest = [], []
        for j, col in zip(np.flatnonzero(conv), range(x.shape[1]), strict=True):
            if res[col] < 1e-10:
                out = np.empty(fe.n, dtype=complex)
                out[fe.perm] = x[:, col]
                kept.append(Eigen(complex(zr[col]), out / out[np.argmax(np.abs(out))],
                                  float(res[col]), int(its[j]), True, abs(zr[col] - z[j])))
            else:
                rest.append(near[j])
        rest = np.array(sorted([*rest, *near[~conv]]), dtype=int)
        if rest.size:
            kept += fe.polish(lam[rest], vecs[:, rest], bx, exact_start=exact_start,
                              maxit=maxit)
        found: list[Eigen] = []
        for e in kept:
            if a0 < e.value.real < b0 and c0 < e.value.imag < d0 and is_new(e.value, found):
                found.append(e)
        return found

    return polish


def missing_roots(cond: CondensedOperator, box: Box, count: int, known: np.ndarray,
                  missing: int) -> np.ndarray | None:
    """Predictors of the ``missing`` eigenvalues in ``box`` that ``known`` lacks.

    The count's power sums of all ``count`` eigenvalues (:meth:`forms.solvers.condensed.
    CondensedOperator.power_sums`) less those of ``known`` are the power sums of the missing
    ones; Newton's identities give their elementary symmetric functions, the roots of that
    polynomial the predictors. ``None``: the box's samples are not held.
    """
    got = cond.power_sums(box, count, missing)
    if got is None:
        return None
    sums, c, r = got
    u = (np.asarray(known, dtype=complex) - c) / r
    q = sums - np.array([np.sum(u ** p) for p in range(1, missing + 1)])
    e = [1.0 + 0j]
    for j in range(1, missing + 1):  # j e_j = sum_i (-1)^(i-1) e_(j-i) q_i
        e.append(sum((-1) ** (i - 1) * e[j - i] * q[i - 1] for i in range(1, j + 1)) / j)
    return c + r * np.roots([(-1) ** j * e[j] for j in range(missing + 1)])


def _fill(cond: CondensedOperator, polish: Callable[..., list[Eigen]], bx: Box, count: int,
          found: list[Eigen]) -> list[Eigen]:
    """``found`` and what Newton finds from :func:`missing_roots` (distinct, inside)."""
    guess = missing_roots(cond, bx, count, np.array([e.value for e in found]),
                          count - len(found))
    if guess is None:
        return found
    out = list(found)
    for e in polish(guess, np.full((cond.bop.n, guess.size), np.nan, dtype=complex), bx):
        if is_new(e.value, out):
            out.append(e)
    return out


def _condensed(fe: BandedOperator, model: CondensedModel | None = None, k: float = 0.0
               ) -> CondensedOperator | None:
    """The condensed form of ``fe`` (``model``'s at ``k`` if given), or ``None``.

    ``None``: ``fe`` has none (the banded fallback).
    """
    try:
        return model.operator(fe, k) if model is not None else CondensedOperator(fe)
    except NotImplementedError:
        return None


def default_discretisation(p: Params, region: Region, k_max: float, rtol: float = 1e-8,
                           degree: int = 0) -> tuple[int, int, float]:
    """``(degree, cells, grading ratio)`` meeting ``rtol`` on every root of the region.

    The fastest-oscillating mode of the region has a transverse wavenumber of at most
    ``W = |Im Lambda|_max`` (shear part, ``c_s = 1``). P4 with 7 cells per wavelength
    ``2 pi / W`` gave a relative error of ``2e-10`` on the top root of the region (paper
    defaults, ``H = 0.5``, ``k = 6``: 41 cells, error estimate 2.1e-10, error 2.1e-10) and the
    errors go as ``h^8``; graded meshes (large ``k H``) lose a factor of about 3 (stress top,
    ``k = 13``: 3.6e-8 with 7 per wavelength) and few cells lose some more (stress top,
    ``k = 1``: 13 cells, 4.9 per wavelength, gave 2.4e-8 where 1e-8 was aimed at), so
    ``11 (2e-10 / rtol)^(1/8)`` cells per wavelength (``alpha_pc = 2``, ``k = 4``: 10 gave
    1.006e-8 on a shear-family root); at least 6 cells. With ``alpha_pc > 0`` 12.5 instead of
    11: its shear-family roots are nearly undamped at high frequency, and 11 left two of them,
    at the top of the 16 ``c_d`` rung (``alpha_pc = 0.05``, ``k = 6``, ``|Im| = 217``), at an
    estimate of 1.04e-8.

    The mesh is uniform: the region holds modes that oscillate through the whole strip (up to
    ``W``) as well as modes that decay over ``1/k >= 1/W`` above the interface, and both need
    the same cell size (a graded mesh, ``k H = 25``, ratio 6.4, left the top roots at 2e-6).

    Other degrees ``p`` (``degree``; 0: :data:`DEFAULT_DEGREE`): the P4 rule times
    :data:`DEGREE_RATIO` ``[p]``, with the exponent ``1/(2p)`` (errors as ``h^(2p)``).
    """
    d = degree or DEFAULT_DEGREE
    return d, _cells(region.im_max(p, k_max), p.H, 1.0, rtol, _per_wave(p), d), 1.0


#: Lagrange degree of the sweep's cross-section model (session 16: P4 before). At ``rtol =
#: 1e-8`` P6 needs 0.56x P4's unknowns (the interior's eigh 0.3x: 2.47 -> 0.75 s in a profile
#: of ``--bc stress --k 4:6:21``); side by side on one rank (tests/timing/sweep_speed.py) the
#: default stress sweep cost 1.54x less CPU, the velocity sweep 1.24x less, the same counts and
#: statuses, values within 2.3e-9.
DEFAULT_DEGREE = 6
#: Cells per wavelength of degree ``p`` over P4's at the error ``2e-10``, measured on the
#: hardest root of the default stress sweep (``k = 6``, the 16 ``c_d`` rung, ``|Im| = 217``,
#: 17.3 shear wavelengths in ``H``): P4 needs 8.5 cells per wavelength (96 cells: 6.2e-9),
#: P2 175 (400 cells: 6.5e-7, ``h^4``), P3 24.4 (400: 2.7e-10), P5 4.4 (70: 4.2e-10, 80:
#: 1.1e-10), P6 2.7 (40: 1.2e-9, 50: 8.9e-11, slope ``h^11.7``), P1 about 51 000 (2 000
#: cells: 3.9e-5, extrapolated as ``h^2``: P1 cannot reach such errors). The P4 rule's margins
#: (graded meshes, few cells, ``alpha_pc``) are kept as factors.
DEGREE_RATIO = {1: 6000.0, 2: 20.4, 3: 2.85, 4: 1.0, 5: 0.515, 6: 0.315}


def _per_wave(p: Params) -> float:
    """P4 cells per shear wavelength at ``rtol = 2e-10`` (:func:`default_discretisation`)."""
    return 12.5 if p.alpha_pc > 0 else 11.0


def _cells(w: float, height: float, c_s: float, rtol: float, per_wave: float, degree: int
           ) -> int:
    """Cells of a layer of height ``height`` for the shear wavelength ``2 pi c_s / w``.

    ``per_wave DEGREE_RATIO[degree] (2e-10/rtol)^(1/(2 degree))`` per wavelength (``per_wave``
    that of P4), at least 6.
    """
    waves = w * height / (2.0 * math.pi * c_s)
    per = per_wave * DEGREE_RATIO[degree] * (2e-10 / rtol) ** (1.0 / (2 * degree))
    return int(max(6, math.ceil(per * waves)))


def substrate_cells(p: Params, region: Region, k_max: float, rtol: float = 1e-8,
                    degree: int = 0) -> int:
    """Cells of a deformable substrate (finite ``H2``).

    The rule of :func:`default_discretisation` with the substrate's shear-wave speed ``c_s2``.
    """
    return _cells(region.im_max(p, k_max), p.H2, math.sqrt(p.mu2 / p.rho2), rtol, _per_wave(p),
                  degree or DEFAULT_DEGREE)


@dataclass
class KResult:
    """Everything computed at one ``k`` (JSON-able through :meth:`as_dict`).

    Attributes:
        k: Wavenumber.
        rows: One dict per eigenvalue (keys :data:`ROW_FIELDS`).
        n_exact: Argument-principle count of exact roots in the region (``None``: failed).
        n_fe: Argument-principle count of FE eigenvalues in the region (``None``: failed).
        box: The rectangle actually used.
        closed: The count closes (see module docstring).
        note: Why not, or other remarks.
        seconds: Wall time of this ``k``.
        factorizations: Banded LU factorisations spent (Newton + counts).
        found_by: How the FE eigenvalues were found (:func:`_find`): ``continuation`` (the
            FE's own eigenpairs of the previous ``k`` as predictors), ``linearised``,
            ``moments``; ``""``: no count, or ``solver="newton"``.
    """

    k: float
    rows: list[dict] = field(default_factory=list)
    n_exact: int | None = None
    n_fe: int | None = None
    box: tuple = ()
    closed: bool = False
    note: str = ""
    seconds: float = 0.0
    factorizations: int = 0
    found_by: str = ""

    def as_dict(self) -> dict:
        """Plain-JSON form."""
        return {"k": self.k, "rows": self.rows, "n_exact": self.n_exact, "n_fe": self.n_fe,
                "box": list(self.box), "closed": self.closed, "note": self.note,
                "seconds": self.seconds, "factorizations": self.factorizations,
                "found_by": self.found_by}

    @classmethod
    def from_dict(cls, d: dict) -> KResult:
        """Inverse of :meth:`as_dict`."""
        return cls(d["k"], d["rows"], d["n_exact"], d["n_fe"], tuple(d["box"]), d["closed"],
                   d["note"], d["seconds"], d.get("factorizations", 0), d.get("found_by", ""))


class CertifiedSolver:
    """FE models of degree ``p`` and ``p + 1`` on one mesh, on one process.

    Args:
        params: Parameters (finite ``H``).
        region: The region ``R``.
        degree: Lagrange degree ``p`` of the reported values.
        cells: Cells of the interval mesh.
        ratio: Grading ratio of the mesh.
        k_max: Largest ``k`` of the sweep.
        rtol: Relative accuracy a row must reach to be ``ok``.
        material: Layers/profiles of the slider (:func:`forms.models.profiles.slider_material`;
            ``None``: homogeneous).
        check_exact: Match the FE eigenvalues to the exact roots afterwards (labels, errors);
            ``False``: ``analytic``'s roots and families are never consulted.
        solver: ``"linear"`` (FE first, :meth:`forms.solvers.condensed.CondensedOperator.
            linear_eigs`, the moments where they fall short), ``"moments"`` (FE first,
            :meth:`forms.solvers.banded.BandedOperator.moment_eigs`) or ``"newton"`` (FE
            Newton from every exact root; needs ``check_exact``).
        count: ``"condensed"`` (``log det T_h`` and the moments' solves in the condensed form
            of :class:`forms.solvers.condensed.CondensedOperator`, the same determinant) or
            ``"banded"`` (one banded LU per contour point, kept for comparison).
        max_per_box: Largest count of one block of moments: a box counting more is split
            (:func:`split_box`).
    """

    def __init__(self, params: Params, region: Region, degree: int, cells: int, ratio: float,
                 k_max: float, rtol: float, material: SliderMaterial | None = None, *,
                 check_exact: bool = True, solver: str = "linear",
                 count: str = "condensed", max_per_box: int = MAX_PER_BOX) -> None:
        if count not in COUNTS:
            raise ValueError(f"count = {count!r} is outside its allowed values {COUNTS}")
        self.count, self.max_per_box = count, max_per_box
        if solver not in SOLVERS:
            raise ValueError(f"solver = {solver!r} is outside its allowed values {SOLVERS}")
        if solver == "newton" and not check_exact:
            raise ValueError("solver = 'newton' starts from the exact roots: needs check_exact")
        self.params, self.region, self.rtol = params, region, rtol
        self.check_exact, self.solver = check_exact, solver
        # the one 1D model; rigid and homogeneous it is the CrossSectionModel of these cells
        self.cells2 = substrate_cells(params, region, k_max, rtol, degree) if params.two_body else 0
        stack = section_stack(params, material, degree=degree, cells=cells, k_max=k_max,
                              ratio=ratio, cells2=self.cells2 or None, ratio2=1.0)
        self.models = [SectionModel(MPI.COMM_SELF, stack, params, degree=d)
                       for d in (degree, degree + 1)]
        self.banded = [BandedModel(m) for m in self.models]
        self._cmodel: NearModel | CondensedModel | bool | None = None
        #: ``(k, values, vectors)`` of the last FOLLOW_POINTS closed solves with ``follow``.
        self._history: list[tuple[float, np.ndarray, np.ndarray]] = []
        self._pause = 0  #: solves left without continuation (:meth:`_continuation`)
        self.degree, self.cells, self.ratio = degree, cells, ratio

    def _condensed_model(self) -> NearModel | CondensedModel | None:
        """The ``k``-independent condensed form of the degree-``p`` model (built once).

        From :data:`NEAR_MIN` unknowns the banded :class:`NearModel`, else (or where it has
        none) the dense :class:`CondensedModel`. ``None``: neither; each ``k`` is condensed
        alone.
        """
        if self._cmodel is None:
            self._cmodel = False
            big = self.banded[0].n >= NEAR_MIN
            for kind in (NearModel, CondensedModel) if big else (CondensedModel,):
                try:
                    self._cmodel = kind(self.banded[0])
                    break
                except NotImplementedError:
                    continue
        return self._cmodel or None

    @property
    def unknowns(self) -> int:
        """Unknowns of the degree-``p`` model."""
        return self.models[0].size

    def predictors(self, k: float) -> tuple[np.ndarray, np.ndarray] | None:
        """Predictors at ``k`` from this solver's last closed solves (``follow=True``).

        ``(values, vectors)`` (vectors in banded order): each eigenvalue of the last ``k``
        extrapolated in ``k`` by the polynomial through it and its chain of mutual nearest
        values at the solves before (up to :data:`FOLLOW_POINTS` points; a value without a
        partner is taken as it is), with its vector. ``None``: fewer than two closed solves,
        or ``k`` farther from the last than :data:`FOLLOW_REACH` times their spacing.
        """
        ks = [h[0] for h in self._history]
        if len(ks) < 2 or abs(k - ks[-1]) > FOLLOW_REACH * abs(ks[-1] - ks[-2]):
            return None
        chains = [np.arange(self._history[-1][1].size)]  # indices into each earlier solve
        for (_, za, _), (_, zb, _) in zip(self._history[-2::-1], self._history[:0:-1],
                                             strict=True):
            if not (za.size and zb.size):
                break
            dist = np.abs(zb[:, None] - za[None, :])
            near, back = np.argmin(dist, axis=1), np.argmin(dist, axis=0)
            prev = chains[-1]
            chains.append(np.where(back[near[prev]] == prev, near[prev], -1))
        z_last = self._history[-1][1]
        pred = z_last.copy()
        for i in range(z_last.size):
            pts = [(ks[-1 - j], self._history[-1 - j][1][c[i]]) for j, c in enumerate(chains)]
            pts = pts[:next((j for j, c in enumerate(chains) if c[i] < 0), len(pts))]
            pred[i] = sum(z * math.prod((k - kb) / (ka - kb) for kb, _ in pts if kb != ka)
                          for ka, z in pts)
        return pred, self._history[-1][2]

    def _continuation(self, k: float, polish: Callable[..., list[Eigen]],
                      cond: CondensedOperator | None
                      ) -> Callable[[Box, int], list[Eigen]] | None:
        """``(box, count) -> eigenpairs`` from :meth:`predictors` at ``k``, or ``None``.

        ``None``: no predictors, or paused. Each predictor near the box (those polish starts
        from, :func:`forms.solvers.banded.predicted_near`) gets :data:`FOLLOW_MAXIT` Newton
        steps by ``polish`` (the operator's, or :func:`_polisher`'s). With the condensed form
        ``cond``, up to :data:`FILL_MAX` eigenvalues they do not reach (entered the box since
        the last ``k``) are found from the count's power sums (:func:`missing_roots`); more
        than that many predictors short of ``count``, none is polished (the linearisation
        runs). When enough predictors do not give ``count`` distinct eigenvalues in the box,
        the next :data:`FOLLOW_PAUSE` solves try none.
        """
        if self._pause > 0:
            self._pause -= 1
            return None
        pred = self.predictors(k)
        if pred is None or not pred[0].size:
            return None

        fill = FILL_MAX if cond is not None else 0

        def attempt(bx: Box, count: int) -> list[Eigen]:
            short = count - int(np.sum(predicted_near(pred[0], bx)))
            if short > fill:
                return []
            found = polish(pred[0], pred[1], bx, maxit=FOLLOW_MAXIT)
            if 0 < count - len(found) <= fill:
                found = _fill(cond, polish, bx, count, found)
            if len(found) < count and short <= 0:  # enough predictors, not the count
                self._pause = FOLLOW_PAUSE
            return found

        return attempt

    def _remember(self, k: float, found: list[Eigen], perm: np.ndarray) -> None:
        """Keep the eigenpairs of a closed solve at ``k`` for :meth:`predictors`.

        The last :data:`FOLLOW_POINTS` distinct ``k`` (a second solve at the same ``k``, e.g.
        another rung sharing this mesh, replaces the first).
        """
        keep = [h for h in self._history if h[0] != float(k)][-(FOLLOW_POINTS - 1):]
        self._history = [*keep, (
            float(k), np.array([e.value for e in found], dtype=complex),
            np.stack([e.vector[perm] for e in found], axis=1) if found
            else np.zeros((perm.size, 0), dtype=complex))]

    def solve(self, k: float, fams: list[BranchResult] | None = None,
              region: Region | None = None, box: Box | None = None, *,
              follow: bool = False) -> KResult:
        """The certified spectrum at ``k`` (see the module docstring).

        Args:
            k: Wavenumber.
            fams: The followed exact families (only with ``check_exact``).
            region: The region at this ``k`` (default: the solver's own); a per-``k``
                region: see :func:`forms.studies.sweep.region_at_k`.
            box: The rectangle (default: the region's at ``k``; with ``check_exact`` the
                rectangle of the exact count, which may be a nudged copy).
            follow: A sweep in ``k``: this solver's eigenpairs of its last closed solves
                are the first predictors (:meth:`predictors`; ``solver="linear"`` only), and
                this solve's are kept for the next.
        """
        region = region if region is not None else self.region
        if self.solver == "newton":
            return self._solve_seeded(k, fams or [], region)
        t0 = time.perf_counter()
        p, rtol = self.params, self.rtol
        out = KResult(float(k))
        labelled: list = []
        exact_box = None
        if self.check_exact:
            try:
                labelled, exact_box, out.n_exact = certified_roots(p, k, region, fams or [])
            except ContourError as err:
                out.note = f"exact count failed: {err}"
        fe, fine = (b.operator(k) for b in self.banded)
        cond = _condensed(fe, self._condensed_model(), k) if self.count == "condensed" else None
        count_in = cond.count_and_samples if cond is not None else fe.count_and_samples
        stack = self.models[0].stack

        def counter(bx: Box) -> tuple[int, np.ndarray]:
            return count_in(bx, contour_samples(stack, bx))

        sums = cond.moment_sums if cond is not None else None
        want = box if box is not None else (exact_box or region.box(p, k))
        try:
            (n_fe, t), used = on_usable_box(want, k, counter)
            out.n_fe = n_fe
        except ContourError as err:
            out.note = "; ".join(x for x in (out.note, f"FE count failed: {err}") if x)
            used, t = want, None
        out.box = tuple(float(v) for v in used)
        found, parts_ok = [], True
        if t is not None:
            lin = cond.linear_eigs if cond is not None and self.solver == "linear" else None
            polish = _polisher(fe, cond)
            cont = self._continuation(k, polish, cond) if follow and lin else None
            found, parts_ok, why, out.found_by = _find(
                fe, counter, used, out.n_fe, t, self.max_per_box, sums, lin, cont, polish)
            out.note = "; ".join(x for x in (out.note, why) if x)
        rows = [self._row(k, e, fine) for e in found]
        matched = (self._match_exact(rows, labelled, exact_box, used) if self.check_exact
                   else _label_by_frequency(rows))
        distinct = _distinct([e.value for e in found])
        fe_closed = out.n_fe is not None and out.n_fe == len(found) and distinct and parts_ok
        out.closed = fe_closed and matched
        if follow and fe_closed:
            self._remember(k, found, fe.perm)
        for row in rows:
            row["certificate"] = "+".join(
                name for name, ok in (("fe", fe_closed and row["error_estimate"] <= rtol),
                                      ("exact", self.check_exact and out.closed
                                       and row["rel_error"] <= rtol)) if ok)
        if not out.closed:
            why = f"count not closed: FE {out.n_fe}, found {len(found)}"
            if self.check_exact:
                why += f", exact {out.n_exact} ({len(labelled)} roots)"
            if not distinct:
                why += ", two FE values coincide"
            out.note = "; ".join(x for x in (out.note, why) if x)
            for row in rows:
                row["status"] = ("" if row["status"] == "ok" else row["status"] + "; ") + why
        out.rows = sorted(rows, key=lambda r: (-r["re_lambda"], r["im_lambda"]))
        out.factorizations = fe.factorizations + fine.factorizations
        out.seconds = time.perf_counter() - t0
        return out

    def _row(self, k: float, e: Eigen, fine: BandedOperator) -> dict:
        """One row of an FE eigenpair: the P(p+1) estimate; no exact root yet."""
        est = math.nan
        g = fine.newton(e.value, maxit=6)
        if g.converged:
            est = abs(e.value - g.value) / abs(g.value)
        problems = [] if est <= self.rtol else [f"estimate {est:.1e} > rtol"]
        return {"k": float(k), "label": "", "re_lambda": float(e.value.real),
                "im_lambda": float(e.value.imag), "re_lambda_exact": math.nan,
                "im_lambda_exact": math.nan, "rel_error": math.nan,
                "error_estimate": float(est), "residual": float(e.residual),
                "status": "; ".join(problems) or "ok"}

    def _match_exact(self, rows: list[dict], labelled: list, exact_box: Box | None,
                     used: Box) -> bool:
        """Match every FE row to a distinct exact root (nearest both ways); label and errors.

        Returns:
            Whether the matching is a bijection on the same rectangle.
        """
        exact = np.array([r.value for r in labelled], dtype=complex)
        fe = np.array([complex(r["re_lambda"], r["im_lambda"]) for r in rows], dtype=complex)
        ok = exact_box is not None and tuple(exact_box) == tuple(used) and len(exact) == len(fe)
        for i, row in enumerate(rows):
            problems = [] if row["status"] == "ok" else [row["status"]]
            if not len(exact):
                row["status"] = "; ".join(problems + ["no exact root to match"])
                ok = False
                continue
            j = int(np.argmin(np.abs(exact - fe[i])))
            mutual = int(np.argmin(np.abs(fe - exact[j]))) == i
            r = labelled[j]
            rel = abs(fe[i] - r.value) / max(abs(r.value), 1e-300)
            row.update(label=r.label, re_lambda_exact=float(r.value.real),
                       im_lambda_exact=float(r.value.imag), rel_error=float(rel))
            if not r.certified:
                problems.append(f"label not certified ({r.note})")
            if not mutual:
                problems.append("FE value nearer another exact root")
                ok = False
            if not rel <= self.rtol:
                problems.append(f"error {rel:.1e} > rtol")
            row["status"] = "; ".join(problems) or "ok"
        return ok

    def _solve_seeded(self, k: float, fams: list[BranchResult], region: Region) -> KResult:
        """``--solver newton``: FE Newton from every exact root, then the FE count."""
        t0 = time.perf_counter()
        p, rtol = self.params, self.rtol
        out = KResult(float(k))
        try:
            labelled, box, n_exact = certified_roots(p, k, region or self.region, fams)
        except ContourError as err:
            out.note = f"exact count failed: {err}"
            out.seconds = time.perf_counter() - t0
            return out
        out.box, out.n_exact = tuple(float(v) for v in box), n_exact
        fe, fine = (b.operator(k) for b in self.banded)
        exact = np.array([r.value for r in labelled], dtype=complex)
        values = []
        for j, r in enumerate(labelled):
            e = fe.newton(r.value)
            est = math.nan
            if e.converged:
                g = fine.newton(e.value, maxit=6)
                if g.converged:
                    est = abs(e.value - g.value) / abs(g.value)
            rel = abs(e.value - r.value) / max(abs(r.value), 1e-300)
            near = int(np.argmin(np.abs(exact - e.value))) if len(exact) else -1
            problems = []
            if not r.certified:
                problems.append(f"label not certified ({r.note})")
            if not e.converged:
                problems.append(f"Newton did not converge (residual {e.residual:.1e})")
            elif near != j:
                problems.append("FE value nearer another exact root")
            if not rel <= rtol:
                problems.append(f"error {rel:.1e} > rtol")
            if not est <= rtol:
                problems.append(f"estimate {est:.1e} > rtol")
            values.append(e.value)
            out.rows.append({
                "k": float(k), "label": r.label,
                "re_lambda": float(e.value.real), "im_lambda": float(e.value.imag),
                "re_lambda_exact": float(r.value.real), "im_lambda_exact": float(r.value.imag),
                "rel_error": float(rel), "error_estimate": float(est),
                "residual": float(e.residual), "status": "; ".join(problems) or "ok",
            })
        try:
            out.n_fe = fe.count(box, contour_samples(self.models[0].stack, box))
        except ContourError as err:
            out.note = f"FE count failed: {err}"
        vals = np.array(values, dtype=complex)
        distinct = all(abs(vals[a] - vals[b]) > 1e-9 * max(1.0, abs(vals[a]))
                       for a in range(len(vals)) for b in range(a))
        out.closed = (out.n_fe is not None and out.n_fe == n_exact == len(labelled)
                      and distinct)
        if not out.closed:
            why = (f"count not closed: FE {out.n_fe}, exact {n_exact}, reported {len(labelled)}"
                   + ("" if distinct else ", two FE values coincide"))
            out.note = "; ".join(x for x in (out.note, why) if x)
            for row in out.rows:
                row["status"] = ("" if row["status"] == "ok" else row["status"] + "; ") + why
        for row in out.rows:
            row["certificate"] = "fe+exact" if out.closed and row["status"] == "ok" else ""
        out.factorizations = fe.factorizations + fine.factorizations
        out.seconds = time.perf_counter() - t0
        return out

    def destroy(self) -> None:
        """Destroy the PETSc objects of both models."""
        for m in self.models:
            m.destroy()


def continue_fe(banded: BandedModel, ks: np.ndarray, z0: complex) -> tuple[np.ndarray, int]:
    """FE continuation of one eigenpair over the sorted ``ks`` (Newton on the discrete NEP).

    The previous eigenvector and the linear predictor of the one continuation engine
    (:meth:`analytic.numerics.continuation.Path.predict`, order 1) start a Newton iteration
    (:meth:`forms.solvers.banded.BandedOperator.newton`) at every ``k``: a few banded
    factorisations per point, no eigensolver. No root count: this is the fast inner loop, the
    certificate comes from :class:`CertifiedSolver`.

    Returns:
        ``(eigenvalues, factorisations)``; NaN where Newton did not converge.
    """
    out = np.full(len(ks), complex(np.nan, np.nan))
    path = Path([], [])
    x = None
    total = 0
    for i, k in enumerate(ks):
        guess = path.predict(float(k), order=1) if path.k else z0
        op = banded.operator(float(k))
        e = op.newton(guess, x)
        total += op.factorizations
        if not e.converged:
            continue
        out[i], x = e.value, e.vector
        path.append(float(k), e.value)
    return out, total
