"""Spatial stability of the cross-section model: roots ``k(Lambda)`` and the long-block limit.

At a fixed complex growth rate ``Lambda`` the cross-section operator
``T(Lambda; k) = T0(Lambda) + k T1(Lambda) + k^2 T2(Lambda)`` is quadratic in ``k``
(:meth:`forms.models.cross_section.CrossSectionModel.k_blocks`), so the spatial roots ``k(Lambda)``
(the
waves a finite block is built from) are the eigenvalues of a quadratic PEP in ``k``
(:func:`spatial_roots`). From them, without any 2D solve:

- :func:`kulikovskii_growth`: a point of Kulikovskii's curve ``Im k1 = Im k2`` (where the
  global modes of a long block accumulate as its length grows);
- :func:`saddle_point`: the pinch point where two spatial roots coincide (absolute instability);
- :func:`kulikovskii_limit`: the long-block limit of a block eigenvalue (one or the other).

Used by ``workflows/finite_block.py``; beyond the paper.
"""

from __future__ import annotations

import numpy as np

from mpi4py import MPI
from petsc4py import PETSc

from analytic.params import Params
from forms.models.cross_section import CrossSectionModel
from forms.solvers.slepc import PolynomialSolver


def spatial_roots(model: CrossSectionModel, lam: complex, target: complex, nev: int = 1
                  ) -> list[complex]:
    """Wavenumbers ``k`` (complex) with ``T(lam; k) u = 0``: a quadratic eigenproblem in ``k``.

    The cross-section operator is ``T(L; k) = T0(L) + k T1(L) + k^2 T2(L)`` with each ``Tj`` a
    polynomial in ``L`` (:meth:`forms.models.cross_section.CrossSectionModel.k_blocks`);
    at fixed ``lam`` this is a SLEPc PEP in ``k``, solved by shift-and-invert near ``target``.

    Args:
        model: A polynomial-form ``CrossSectionModel``.
        lam: Growth rate ``Lambda``.
        target: Shift for ``k``.
        nev: Number of roots wanted.

    Returns:
        The converged roots sorted by distance to ``target``.
    """
    same = PETSc.Mat.Structure.SAME_NONZERO_PATTERN
    coeffs = []
    for part in model.k_blocks():  # T0, T1, T2: one FrictionOperator per power of k
        A = part.matrices[0].duplicate(copy=True)
        for i in range(1, len(part.matrices)):
            A.axpy(lam**i, part.matrices[i], structure=same)
        coeffs.append(A)
    # The same SLEPc set-up as every Lambda solve (TOAR, shift-and-invert, MUMPS), in k; the
    # spurious-root filter of PolynomialSolver.solve is about Lambda, so the PEP is used directly.
    solver = PolynomialSolver(model.comm, nev=nev, tol=1e-12, prefix="kroots_")
    try:
        pep = solver.pep
        pep.setOperators(coeffs)
        pep.setTarget(target)
        pep.solve()
        roots = [complex(pep.getEigenpair(i)) for i in range(pep.getConverged())]
    finally:
        solver.destroy()
        for A in coeffs:
            A.destroy()
    return sorted(roots, key=lambda z: abs(z - target))


def kulikovskii_growth(model: CrossSectionModel, omega: float, sigma0: float, k1: complex,
                       k2: complex, tol: float = 1e-10, max_it: int = 30
                       ) -> tuple[complex, complex, complex]:
    """Growth rate ``sigma`` at frequency ``omega`` where ``Im k1(Lambda) = Im k2(Lambda)``.

    Kulikovskii's condition: in a long finite domain, global modes built from two spatial
    waves ``k1, k2`` (reflected into each other at the ends) accumulate, as ``L -> infinity``,
    on the curve where both waves have the same spatial growth ``Im k``. Secant iteration on
    ``sigma`` with ``Lambda = sigma + i omega``; ``k1``, ``k2`` are followed by
    shift-and-invert from the previous values.

    Returns:
        ``(Lambda, k1, k2)`` at convergence.

    Raises:
        RuntimeError: If the iteration does not converge or a root is lost.
    """
    def gap(sigma: float) -> tuple[float, complex, complex]:
        lam = complex(sigma, omega)
        r1 = spatial_roots(model, lam, k1)
        r2 = spatial_roots(model, lam, k2)
        if not r1 or not r2:
            raise RuntimeError(f"spatial root lost at Lambda = {lam}")
        return r1[0].imag - r2[0].imag, r1[0], r2[0]

    s0, s1 = sigma0, sigma0 + 1e-3
    g0, k1, k2 = gap(s0)
    for _ in range(max_it):
        g1, k1, k2 = gap(s1)
        if abs(g1) < tol or g1 == g0:
            return complex(s1, omega), k1, k2
        s0, s1, g0 = s1, s1 - g1 * (s1 - s0) / (g1 - g0), g1
    raise RuntimeError("Kulikovskii iteration did not converge")


def saddle_point(model: CrossSectionModel, lam0: complex, k1: complex, k2: complex,
                 tol: float = 1e-10, max_it: int = 40) -> tuple[complex, complex]:
    """Pinch point: ``Lambda`` where two spatial roots ``k1(Lambda), k2(Lambda)`` coincide.

    Near a double root ``k1 - k2 ~ sqrt(Lambda - Lambda_s)``, so ``G = (k1 - k2)^2`` is
    analytic and simple there; secant iteration on ``G`` in the complex plane. The two roots are
    those nearest their previous midpoint.

    Returns:
        ``(Lambda_s, k_s)``.

    Raises:
        RuntimeError: If the iteration does not converge.
    """
    def G(lam: complex, mid: complex) -> tuple[complex, complex]:
        r = spatial_roots(model, lam, mid, nev=2)
        if len(r) < 2:
            raise RuntimeError(f"spatial roots lost at Lambda = {lam}")
        return (r[0] - r[1]) ** 2, 0.5 * (r[0] + r[1])

    mid = 0.5 * (k1 + k2)
    z0, z1 = lam0, lam0 + 1e-3 * (1 + 1j)
    g0, mid = G(z0, mid)
    for _ in range(max_it):
        g1, mid = G(z1, mid)
        if g1 == g0:
            break
        z0, z1, g0 = z1, z1 - g1 * (z1 - z0) / (g1 - g0), g1
        if abs(z1 - z0) < tol * max(abs(z1), 1.0):
            _, mid = G(z1, mid)
            return complex(z1), complex(mid)
    raise RuntimeError("saddle-point iteration did not converge")


def curve_peak(om: np.ndarray, sig: np.ndarray) -> tuple[float, float]:
    """Largest ``sig`` on a sampled curve ``sig(om)``: a parabola through the best three samples.

    The parabola's vertex is used only where it lies between the outer two of them (a concave
    fit); otherwise the best sample is: a vertex outside them (a nearly flat or convex fit) is
    not a peak of the sampled curve.

    Returns:
        ``(sig_max, om_max)``.
    """
    order = np.argsort(om)
    om, sig = np.asarray(om, float)[order], np.asarray(sig, float)[order]
    j = int(np.argmax(sig))
    best = (float(sig[j]), float(om[j]))
    if j == 0 or j == len(sig) - 1:
        return best
    a2, a1, a0 = np.polyfit(om[j - 1:j + 2], sig[j - 1:j + 2], 2)
    if not a2 < 0:
        return best
    vertex = -a1 / (2 * a2)
    if not om[j - 1] <= vertex <= om[j + 1]:
        return best
    return float(np.polyval([a2, a1, a0], vertex)), float(vertex)


def _follow_curve(model: CrossSectionModel, lam_block: complex, k1: complex, k2: complex,
                  oms: np.ndarray) -> list[tuple[complex, complex, complex]]:
    """Samples ``(Lambda, k1, k2)`` of the curve ``Im k1 = Im k2`` at the frequencies ``oms``.

    Followed from the sample nearest the block's frequency outwards, each from its neighbour.
    A direction ends where the two tracked roots merge (``k1 = k2`` satisfies ``Im k1 = Im k2``
    trivially) or a root jumps by more than the pair's separation (another root taken): stress
    top, ``alpha_pc = 0.1``, ``L = 8``, both roots ran to ``-2.81 - 2.54i`` two samples from the
    centre, that sample had ``Re Lambda = 4.17`` and the reported limit was 4.32, against the
    strip's 0.196.

    Returns:
        The valid samples, ordered by frequency.
    """
    centre = int(np.argmin(np.abs(oms - lam_block.imag)))
    curve = {}
    for direction in (range(centre, len(oms)), range(centre - 1, -1, -1)):
        sigma, a, b = lam_block.real, k1, k2
        for i in direction:
            try:
                lam, a2, b2 = kulikovskii_growth(model, float(oms[i]), sigma, a, b)
            except RuntimeError:
                break
            if (abs(a2 - b2) < 1e-6 * max(abs(a2), 1.0)
                    or max(abs(a2 - a), abs(b2 - b)) > abs(a - b)):
                break
            curve[i] = (lam, a2, b2)
            sigma, a, b = lam.real, a2, b2
    return [curve[i] for i in sorted(curve)]


def kulikovskii_limit(params: Params, lam_block: complex, span: float = 0.15, points: int = 7,
                      pinch: float = 0.5) -> dict | None:
    """Long-block limit from the cross-section model alone.

    At the block eigenvalue of the largest ``L``, the two spatial roots ``k1, k2`` with the
    closest ``Im k`` are the wave pair the block's global mode is made of. If they nearly
    coincide (``|k1 - k2| < pinch``) they pinch: the limit is the saddle point
    ``dLambda/dk = 0`` (absolute instability), :func:`saddle_point`. Otherwise (Kulikovskii's
    condition) the curve ``Im k1 = Im k2`` is followed over ``omega`` in
    ``Im(lam_block) +- span`` and its largest growth rate found by a parabola through the best
    three points; if that curve rises to an end where its two waves are within ``pinch``, it
    runs into their pinch and the limit is the saddle point there (stress top, ``alpha_pc =
    0.1``, the ``0+`` mode at ``L = 8``: the curve rises to 0.1438 where ``|k1 - k2| = 0.13``,
    the saddle is at 0.1441, as from ``L = 16``, whose waves already pinch). Runs on one rank.

    Returns:
        ``{"type": "kulikovskii" | "saddle", "lambda": [re, im], "k1_at_block", "k2_at_block",
        ...}``, or ``None`` if fewer than two roots were found. The Kulikovskii curve keeps
        only the samples :func:`_follow_curve` could follow.

    Raises:
        RuntimeError: The saddle point not converged, or no sample of the curve followed.
    """
    model = CrossSectionModel(MPI.COMM_SELF, params, degree=3, k_max=8.0)
    try:
        roots = [r for r in spatial_roots(model, lam_block, 0.0, nev=16) if abs(r) < 10]
        if len(roots) < 2:
            return None
        k1, k2 = min(((a, b) for i, a in enumerate(roots) for b in roots[i + 1:]),
                     key=lambda ab: abs(ab[0].imag - ab[1].imag))
        info = {"k1_at_block": [k1.real, k1.imag], "k2_at_block": [k2.real, k2.imag]}
        pinched = (lam_block, k1, k2) if abs(k1 - k2) < pinch else None
        if pinched is None:
            curve = _follow_curve(model, lam_block, k1, k2, np.linspace(
                lam_block.imag - span, lam_block.imag + span, points))
            if not curve:
                raise RuntimeError("Kulikovskii curve not followed from Lambda ="
                                   f" {lam_block:.6g}: the two spatial waves merged or were"
                                   " lost at once")
            info["curve"] = [[c[0].real, c[0].imag, c[1].real, c[1].imag, c[2].real, c[2].imag]
                             for c in curve]
            end = max((curve[0], curve[-1]), key=lambda c: c[0].real)
            if end[0].real >= max(c[0].real for c in curve) and abs(end[1] - end[2]) < pinch:
                pinched = end  # the curve rises into the pinch of its two waves
        if pinched is not None:  # the limit is the saddle point
            lam_s, k_s = saddle_point(model, *pinched)
            return {"type": "saddle", "lambda": [lam_s.real, lam_s.imag],
                    "k_saddle": [k_s.real, k_s.imag], **info}
    finally:
        model.destroy()
    sig_max, om_max = curve_peak(np.array([c[0].imag for c in curve]),
                                 np.array([c[0].real for c in curve]))
    return {"type": "kulikovskii", "lambda": [sig_max, om_max], **info}
