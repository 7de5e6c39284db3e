"""The finite elements' own maxima over ``k``: a sampled maximum refined along its FE mode.

A scene that samples the FE's fastest eigenvalue over ``k`` (``envelope.py --fe-check all``:
:func:`forms.studies.sweep.fe_fastest` at every sample) has the local maxima of those samples
refined by the finite elements alone: the FE mode at the sample is continued in ``k`` by
Newton on the discrete problem (:meth:`forms.solvers.banded.BandedOperator.newton`, the
eigenvector carried along) and its growth rate maximised over the neighbouring interval by
Brent's bounded search (:func:`fe_mode_peak`: the exact roots' search,
:func:`analytic.numerics.spectrum.peak_along`, with the FE in place of ``det_M``); then
:func:`fe_fastest` certifies the result at the ``k`` found (its count, its climbed region), so
that the scene can say whether the refined mode is the FE's fastest there (:func:`fe_peak`).
No exact root is consulted: the exact refined maxima are the scene's referee.
"""

from __future__ import annotations

from typing import Any

from analytic.numerics.spectrum import Region, peak_along
from analytic.params import Params
from forms.studies.sweep import RungSolvers, fe_fastest

#: Largest step in ``k`` of the continuation between two evaluations (the exact search's
#: ``family_peak`` default); the growth rate of one mode is smooth, the envelope is not.
PEAK_DK = 0.05


def fe_mode_peak(banded: Any, k0: float, z0: complex, lo: float, hi: float,
                 dk: float = PEAK_DK) -> dict:
    """Largest ``Re Lambda`` of the FE mode through ``(k0, z0)`` for ``k`` in ``[lo, hi]``.

    :func:`analytic.numerics.spectrum.peak_along` (Brent's bounded search, the exact roots'
    :func:`analytic.numerics.spectrum.family_peak`) with Newton on the discrete problem as its
    step, the eigenvector carried from the point each step starts from. A step whose Newton
    does not converge ends that evaluation (counted in ``lost``; the search is told the value
    is ``-inf`` there). The sample itself counts as an evaluation.

    Args:
        banded: The degree-``p`` banded model (:class:`forms.solvers.banded.BandedModel`).
        k0: The sample's ``k``.
        z0: The FE eigenvalue there (on any mesh: the first Newton step moves it to this one's).
        lo: Left end of the interval searched.
        hi: Right end.
        dk: Largest continuation step.

    Returns:
        ``k``, ``value`` (the largest ``Re`` reached, with its ``Lambda``; ``None``: Newton
        failed at the sample), ``evaluations``, ``lost`` (evaluations whose continuation
        failed), ``factorizations``.
    """
    count = {"lost": 0, "factorizations": 0}

    def newton(k: float, guess: complex, x: Any) -> tuple[complex, Any] | None:
        op = banded.operator(k)
        e = op.newton(guess, x)
        count["factorizations"] += op.factorizations
        if not e.converged:
            count["lost"] += 1
            return None
        return complex(e.value), e.vector

    start = newton(float(k0), complex(z0), None)
    if start is None:
        return {"k": float(k0), "value": None, "evaluations": 0, **count}
    evaluated = {float(k0): start[0]}
    if hi > lo:
        evaluated |= peak_along(newton, k0, start, lo, hi, dk)
    k = max(evaluated, key=lambda q: evaluated[q].real)
    return {"k": k, "value": evaluated[k], "evaluations": len(evaluated), **count}


def fe_peak(params: Params, region: Region, k0: float, z0: complex, c0: float, lo: float,
            hi: float, rtol: float = 1e-8) -> dict:
    """A sampled FE maximum refined along its mode (:func:`fe_mode_peak`), certified at its ``k``.

    The continuation runs on the mesh of the rung ``c0`` the FE accepted at the sample (planned
    for ``hi``: it holds the mode over the interval); the ``k`` it finds is then handed to
    :func:`forms.studies.sweep.fe_fastest` (a mesh of its own, its count, its climbed region).
    Not collective (``COMM_SELF`` solvers).

    Returns:
        ``k``; ``continued_re``, ``continued_im`` (the mode's value there on the continuation's
        mesh; ``None``: Newton failed at the sample); the keys of :func:`fe_fastest` at ``k``;
        ``evaluations``, ``lost``, ``factorizations`` of the search; ``sample_k``.
    """
    rungs = RungSolvers(params, region, float(hi), rtol, (0, 0, 1.0), check_exact=False)
    try:
        got = fe_mode_peak(rungs(float(c0), float(hi)).banded[0], k0, z0, lo, hi)
    finally:
        rungs.destroy()
    z = got.pop("value")
    out = {"k": got.pop("k"), "continued_re": None if z is None else z.real,
           "continued_im": None if z is None else z.imag, "sample_k": float(k0), **got}
    return out | fe_fastest(params, region, out["k"], rtol)
