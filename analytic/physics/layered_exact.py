"""Exact spectrum of a layered or graded slider on a rigid substrate (propagator matrices).

The reference of the 1D model's layers and profiles (:mod:`forms.models.section`), derived
independently of it: the plane-strain equations of motion for ``u_hat(y) exp(Lambda t - i k x)``
written as a first-order system for the state ``v = (u_x, u_y, sigma_xy, sigma_yy)``::

    u_x'      = sigma_xy / mu + i k u_y
    u_y'      = (sigma_yy + i k lambda u_x) / (lambda + 2 mu)
    sigma_xy' = (rho Lambda^2 + k^2 (lambda + 2 mu - lambda^2/(lambda + 2 mu))) u_x
                + i k lambda/(lambda + 2 mu) sigma_yy
    sigma_yy' = rho Lambda^2 u_y + i k sigma_xy

(``lambda = mu (1/beta^2 - 2)``; the last two lines are ``rho Lambda^2 u = div sigma`` with
``d/dx = -i k``). ``v`` is continuous across layer interfaces (welded layers), so
``v(H) = P v(0)`` with ``P`` the product of the layers' ``expm(A h)`` (exact for constant layers)
or, for a profile, the solution of the matrix system ``P' = A(y) P`` (``solve_ivp``, DOP853).

The eigenvalues are the roots of ``det N(Lambda)``, the 4x4 matrix of the conditions on
``v(0)``: ``u_y(0) = 0`` (rigid substrate), the friction row
:meth:`analytic.law.FrictionLaw.row` (docs/design.md section 3, cleared of
``Lambda + 1``: a spurious root at ``Lambda = -1`` may appear) and two rows of ``P`` for the top
condition (``"velocity"``: ``u_x = sigma_yy = 0``; ``"stress"``: ``sigma_xy = sigma_yy = 0``).
Units: those of :class:`analytic.params.Params` (the friction parameters refer to ``mu = 1``).
Use moderate ``k H`` (a few tens): the propagator grows like ``exp(k H)``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.integrate
import scipy.linalg
import scipy.optimize

from analytic.law import FrictionLaw
from analytic.numerics.roots import Root, polish
from analytic.params import Params

#: A material coefficient of ``y``: a constant or a vectorised function.
Coefficient = float | Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class ExactLayer:
    """A layer ``bottom < y < top`` of the slider; each material a number or a function of y."""

    bottom: float
    top: float
    mu: Coefficient = 1.0
    rho: Coefficient = 1.0
    beta: Coefficient = 0.5

    def values(self, y: float) -> tuple[float, float, float]:
        """``(mu, rho, beta)`` at ``y``."""
        return tuple(float(c(np.asarray(y))) if callable(c) else float(c)  # type: ignore[return-value]
                     for c in (self.mu, self.rho, self.beta))

    @property
    def constant(self) -> bool:
        """No material varies with ``y``."""
        return not any(callable(c) for c in (self.mu, self.rho, self.beta))


def system_matrix(lam: complex, k: float, mu: float, rho: float, beta: float) -> np.ndarray:
    """``A`` of ``v' = A v`` (module docstring) for one material."""
    lm = mu * (1.0 / beta**2 - 2.0)
    m = lm + 2.0 * mu
    ik = 1j * k
    return np.array([
        [0.0, ik, 1.0 / mu, 0.0],
        [ik * lm / m, 0.0, 0.0, 1.0 / m],
        [rho * lam**2 + k**2 * (m - lm**2 / m), 0.0, 0.0, ik * lm / m],
        [0.0, rho * lam**2, ik, 0.0],
    ], dtype=complex)


def propagator(lam: complex, k: float, layers: Sequence[ExactLayer], rtol: float = 1e-13
               ) -> np.ndarray:
    """``P`` with ``v(top) = P v(0)`` through ``layers`` (bottom-up, contiguous from 0)."""
    out = np.eye(4, dtype=complex)
    for lay in layers:
        h = lay.top - lay.bottom
        if lay.constant:
            step = scipy.linalg.expm(system_matrix(lam, k, *lay.values(lay.bottom)) * h)
        else:
            def rhs(y: float, p: np.ndarray, lay: ExactLayer = lay) -> np.ndarray:
                a = system_matrix(lam, k, *lay.values(y))
                return (a @ p.reshape(4, 4)).ravel()
            sol = scipy.integrate.solve_ivp(rhs, (lay.bottom, lay.top),
                                            np.eye(4, dtype=complex).ravel(), method="DOP853",
                                            rtol=rtol, atol=rtol * 1e-3)
            step = sol.y[:, -1].reshape(4, 4)
        out = step @ out
    return out


def boundary_matrix(lam: complex, k: float, p: Params, layers: Sequence[ExactLayer]
                    ) -> np.ndarray:
    """``N(Lambda)``: rows ``u_y(0) = 0``, friction at ``y = 0``, two top conditions."""
    a, b, c = (complex(v) for v in FrictionLaw.from_params(p).row(np.asarray(lam)))
    prop = propagator(lam, k, layers)
    rows = (0, 3) if p.bc == "velocity" else (2, 3)
    return np.array([[0.0, 1.0, 0.0, 0.0], [c, 0.0, a, b], prop[rows[0]], prop[rows[1]]],
                    dtype=complex)


def det_layered(lam: complex, k: float, p: Params, layers: Sequence[ExactLayer]) -> complex:
    """``det N(Lambda)``, the rows normalised to unit length (zero exactly at the roots)."""
    n = boundary_matrix(lam, k, p, layers)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return complex(np.linalg.det(n))


def layered_root(z0: complex, k: float, p: Params, layers: Sequence[ExactLayer],
                 tol: float = 1e-13) -> Root:
    """The root of :func:`det_layered` Newton reaches from ``z0`` (e.g. an FE eigenvalue)."""
    fun = np.vectorize(lambda z: det_layered(complex(z), k, p, layers), otypes=[complex])
    return polish(fun, complex(z0), tol=tol)


def follow_layered(z0: complex, k0: float, ks: Sequence[float], p: Params,
                   layers: Sequence[ExactLayer]) -> np.ndarray:
    """The root through ``(k0, z0)`` at each of ``ks`` (Newton from the neighbour nearer ``k0``).

    Raises:
        RuntimeError: Newton fails at some ``k`` (refine ``ks``).
    """
    ks = np.asarray(ks, dtype=float)
    out = np.empty(len(ks), dtype=complex)
    for side in (ks >= k0, ks < k0):
        idx = np.flatnonzero(side)
        idx = idx[np.argsort(np.abs(ks[idx] - k0))]
        z = complex(z0)
        for i in idx:
            root = layered_root(z, float(ks[i]), p, layers)
            if not root.converged:
                raise RuntimeError(f"layered root lost at k = {ks[i]}: {root.reason}")
            z = out[i] = root.value
    return out


def branch_peak(z0: complex, k0: float, ks: Sequence[float], p: Params,
                layers: Sequence[ExactLayer]) -> tuple[float, complex]:
    """``(k, Lambda)`` of the largest ``Re Lambda`` along the root through ``(k0, z0)``.

    The root is followed over the grid ``ks`` (:func:`follow_layered`); the best grid point is
    refined between its neighbours (bounded Brent, ``xatol = 1e-9``).
    """
    ks = np.sort(np.asarray(ks, dtype=float))
    zs = follow_layered(z0, k0, ks, p, layers)
    i = int(np.argmax(zs.real))
    lo, hi = ks[max(i - 1, 0)], ks[min(i + 1, len(ks) - 1)]
    res = scipy.optimize.minimize_scalar(
        lambda k: -layered_root(zs[i], float(k), p, layers).value.real, bounds=(lo, hi),
        method="bounded", options={"xatol": 1e-9})
    k = float(res.x)
    return k, layered_root(zs[i], k, p, layers).value
