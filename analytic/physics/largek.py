"""The paper's large-``kH`` closed forms (sections 5 and 6), one function each.

Notation: ``Gamma = gamma f``; ``b_d = beta (1/beta^2 - 2)`` (slope of the dilatational
boundary); ``w0 = sqrt(1/beta^2 - 1)``. Code units: ``q`` is the code's ``k``.

Which are exact (tested to round-off against :mod:`analytic.physics.halfspace`) and which are
approximations (tested with the measured error stated in the tests and the README):

- exact: :func:`threshold_gamma` / :func:`delta_d` (Eq. threshold; the ``q -> 0`` root sits at
  ``kappa_d = 0``), :func:`all_modes_gamma` (Eq. all_modes; ``q -> infinity``),
  :func:`qc_shear` / :func:`delta_s` (Eqs. full_shear_inst, full_shear_inst1/2; a root at
  ``z = -1``), :func:`delta_m` (Eq. Delta_m, the maximum of :func:`delta_s`),
  :func:`delta_qs_limit` (the quasi-static limit's own threshold, derived here);
- linearisations in ``kappa_d``: :func:`kappa_d_linear` (Eqs. kappa_d1, kappa_d2),
  :func:`z_linear`, :func:`growth_linear`, :func:`growth_rate_dilatational`
  (Eq. analytic_spectrum), :func:`qc_dilatational` (Eq. qc);
- leading order in ``f^2``/``Gamma``: :func:`delta_qs` (Eq. riceQS),
  :func:`delta_m_leading`.
"""

from __future__ import annotations

import math

import numpy as np

from analytic.params import Params

ArrayLike = float | np.ndarray


def slope_d(beta: float) -> float:
    """``b_d = beta (1/beta^2 - 2)``: ``Delta_d = b_d Gamma``."""
    return beta * (1.0 / beta**2 - 2.0)


def _sign(branch: str) -> float:
    if branch not in ("unstable", "stable"):
        raise ValueError(f"branch = {branch!r} is not 'unstable' or 'stable'")
    return 1.0 if branch == "unstable" else -1.0


# ------------------------------------------------------------------ dilatational (section 5.1)
def kappa_d_linear(q: ArrayLike, p: Params, branch: str = "unstable") -> ArrayLike:
    """Eq. (kappa_d2) (reduces to Eq. kappa_d1 for ``alpha_pc = alpha_ld = 0``).

    ``branch="unstable"`` takes the paper's lower signs (``1 + f w0``), ``"stable"`` the upper.
    """
    sg = _sign(branch)
    b, f, g = p.beta, p.f, p.gamma
    w0 = math.sqrt(1.0 / b**2 - 1.0)
    q = np.asarray(q, dtype=float)
    a = 1.0 - 1j * q / b
    num = (1j * f * g * a * (2.0 - 1.0 / b**2) + 1j * (p.Delta - 1j * q / b) / b
           - g * q * p.alpha_ld * (2.0 - 1.0 / b**2) / b)
    den = (g * a * (1.0 + sg * f * w0 - 1j * p.alpha_pc * q / b) / b**2
           + sg * 1j * g * q * p.alpha_ld * w0 / b**3)
    return num / den


def z_linear(q: ArrayLike, p: Params, branch: str = "unstable") -> ArrayLike:
    """``z = sqrt(1 - kappa_d^2)/beta`` (Eq. kappa_d) with ``kappa_d`` of Eq. (kappa_d2)."""
    kap = kappa_d_linear(q, p, branch)
    return np.sqrt(1.0 - kap * kap) / p.beta


def growth_linear(q: ArrayLike, p: Params, branch: str = "unstable") -> ArrayLike:
    """``Re lambda = q Im z`` with :func:`z_linear` (the paper's generalized-model curves)."""
    return np.asarray(q, dtype=float) * np.imag(z_linear(q, p, branch))


def growth_rate_dilatational(q: ArrayLike, p: Params, branch: str = "unstable") -> ArrayLike:
    """Eq. (analytic_spectrum): ``Re lambda(q)`` of the dilatational family (standard model).

    ``branch="unstable"`` is the paper's plus sign (``(1 + f w0)^2`` in the denominator).
    """
    sg = _sign(branch)
    b, f, g, d = p.beta, p.f, p.gamma, p.Delta
    gb = p.Gamma * slope_d(b)
    w0 = math.sqrt(1.0 / b**2 - 1.0)
    q = np.asarray(q, dtype=float)
    q2 = q * q / b**2
    return q * q * (1.0 - d) * ((gb - 1.0) * q2 + gb - d) / (
        g**2 * (q2 + 1.0) ** 2 * (1.0 + sg * f * w0) ** 2)


def growth_rate_dilatational_physical(q: ArrayLike, p: Params) -> ArrayLike:
    """The paper's dotted curve: the unstable sign where it is ``> 0``, else the stable sign."""
    gu = growth_rate_dilatational(q, p, "unstable")
    gs = growth_rate_dilatational(q, p, "stable")
    return np.where(gu > 0, gu, gs)


def qc_dilatational(p: Params) -> float:
    """Eq. (qc): ``q_c^(d) = beta sqrt((Gamma b_d - Delta)/(1 - Gamma b_d))``.

    Returns NaN below threshold and ``inf`` when all modes are unstable.
    """
    gb = p.Gamma * slope_d(p.beta)
    if gb <= p.Delta:
        return math.nan
    if gb >= 1.0:
        return math.inf
    return p.beta * math.sqrt((gb - p.Delta) / (1.0 - gb))


def threshold_gamma(delta: ArrayLike, beta: float) -> ArrayLike:
    """Eq. (threshold): ``Gamma = Delta / (beta (1/beta^2 - 2))`` (exact)."""
    return np.asarray(delta, dtype=float) / slope_d(beta)


def delta_d(gamma_f: ArrayLike, beta: float) -> ArrayLike:
    """Eq. (stability_boundaries) ``Delta_d(Gamma) = Gamma beta (1/beta^2 - 2)`` (exact)."""
    return np.asarray(gamma_f, dtype=float) * slope_d(beta)


def all_modes_gamma(beta: float) -> float:
    """Eq. (all_modes): all ``q`` of the dilatational family are unstable above this ``Gamma``."""
    return 1.0 / slope_d(beta)


# ------------------------------------------------------------------------- shear (section 5.2)
def qc_shear(gamma: float, f: float, beta: float, alpha_pc: float = 0.0,
             alpha_ld: float = 0.0) -> float:
    """Critical wavenumber of the shear family at its threshold (Eqs. full_shear_inst(1,2)).

    Exact: ``s(z = -1, q) = 0`` splits into a real equation for ``q`` and an imaginary one for
    ``Delta``. Returns NaN where the ``alpha_pc = 0`` limit does not exist
    (``1 - gamma (f - alpha_ld) <= 0``).
    """
    b = math.sqrt(1.0 - beta**2)
    c = 1.0 - gamma * (f - alpha_ld)
    if alpha_pc == 0.0:
        return gamma * b / c if c > 0 else math.nan
    x = c / (2.0 * alpha_pc * gamma * b)
    return math.sqrt(1.0 / alpha_pc + x * x) - x


def delta_s_gamma(gamma: float, f: float, beta: float, alpha_pc: float = 0.0,
                  alpha_ld: float = 0.0) -> float:
    """Shear threshold ``Delta = gamma f - gamma sqrt(1-beta^2) (1 + alpha_pc) q_c^(s)``.

    Eq. (full_shear_inst1); Eq. (full_shear_inst2) for ``alpha_pc = 0``; Eq. (full_shear_inst)
    for ``alpha_ld = 0`` too. Unstable for ``Delta`` below it.
    """
    qc = qc_shear(gamma, f, beta, alpha_pc, alpha_ld)
    return gamma * f - gamma * math.sqrt(1.0 - beta**2) * (1.0 + alpha_pc) * qc


def delta_s(gamma_f: ArrayLike, f: float, beta: float) -> ArrayLike:
    """Eq. (stability_boundaries): ``Delta_s = Gamma - Gamma^2 (1-beta^2) / ((1-Gamma) f^2)``."""
    g = np.asarray(gamma_f, dtype=float)
    return g - g * g * (1.0 - beta**2) / ((1.0 - g) * f * f)


def delta_s_zero_gamma(f: float, beta: float) -> float:
    """``Gamma = f^2 / (1 - beta^2 + f^2)`` where :func:`delta_s` returns to zero."""
    return f * f / (1.0 - beta**2 + f * f)


def delta_m(f: float, beta: float) -> float:
    """Eq. (Delta_m): maximum over ``Gamma`` of :func:`delta_s`."""
    c = 1.0 - beta**2
    return (2.0 * c + f * f - 2.0 * math.sqrt(c * (c + f * f))) / (f * f)


def delta_m_gamma(f: float, beta: float) -> float:
    """``Gamma`` maximising :func:`delta_s`: ``1 - sqrt(c/(1+c))``, ``c = (1-beta^2)/f^2``."""
    c = (1.0 - beta**2) / f**2
    return 1.0 - math.sqrt(c / (1.0 + c))


def delta_m_leading(f: float, beta: float) -> float:
    """Parabolic approximation of Eq. (Delta_m): ``f^2 / (4 (1 - beta^2))``."""
    return f * f / (4.0 * (1.0 - beta**2))


# ------------------------------------------------------------------- quasi-static (section 5.3)
def delta_qs(f: float, beta: float) -> float:
    """Eq. (riceQS), leading order: ``Delta_qs = f^2 beta^4 / 4`` (independent of ``Gamma``)."""
    return 0.25 * f * f * beta**4


def delta_qs_limit(f: float, beta: float) -> float:
    """Exact threshold of the quasi-static limit spectrum (derived here, not in the paper).

    The quasi-static spectrum (:func:`analytic.physics.halfspace.quasistatic_lambda`) is
    ``lambda^2 + (Delta + a) lambda + a = 0``, ``a = q gamma g1 (1 - i f beta^2)`` (since
    ``g2/g1 = beta^2``). Putting ``lambda = i omega`` and asking for a double root in
    ``u = Delta + q gamma g1`` gives ``eps (1+Delta)^2 = 4 (1+eps) Delta``, ``eps = f^2 beta^4``,
    whose small root is ``Delta = (sqrt(1+eps) - 1)^2 / eps = eps/4 - eps^2/8 + ...``: Eq.
    (riceQS) is its first term.
    """
    eps = f * f * beta**4
    return (math.sqrt(1.0 + eps) - 1.0) ** 2 / eps


def qc_quasistatic(gamma: float, f: float, beta: float) -> float:
    """Critical ``q`` of the quasi-static limit at its threshold :func:`delta_qs_limit`.

    ``q gamma g1 = u - Delta`` with the double root ``u = eps (1 + Delta) / (2 (1 + eps))``,
    ``g1 = 2/(1 + beta^2)``.
    """
    eps = f * f * beta**4
    d = delta_qs_limit(f, beta)
    u = eps * (1.0 + d) / (2.0 * (1.0 + eps))
    return (u - d) * (1.0 + beta**2) / (2.0 * gamma)


# ------------------------------------------------------------------------- the phase diagram
def stability_boundaries(gamma_f: ArrayLike, f: float, beta: float) -> dict[str, np.ndarray]:
    """Eq. (stability_boundaries): ``Delta_d, Delta_s, Delta_qs`` on a ``Gamma`` array.

    ``Delta_s`` is NaN for ``Gamma >= 1`` (it diverges to ``-inf`` at ``Gamma = 1``).
    """
    g = np.atleast_1d(np.asarray(gamma_f, dtype=float))
    ds = np.full_like(g, np.nan)
    ok = g < 1.0
    ds[ok] = delta_s(g[ok], f, beta)
    return {"dilatational": delta_d(g, beta), "shear": ds,
            "quasistatic": np.full_like(g, delta_qs(f, beta))}


def qs_truncation_gamma(f: float, beta: float) -> float:
    """``Gamma`` where the (leading-order) quasi-static line meets the upper boundary.

    The paper truncates ``Delta_qs`` there: at ``f^2 beta^3 / (4 (1/beta^2 - 2))`` on
    ``Delta_d`` when ``b_d >= 1``, else where it meets ``Delta_s`` (approximately
    ``f^2 beta^4 / 4``; solved exactly here).
    """
    dq = delta_qs(f, beta)
    g_d = dq / slope_d(beta)
    # smallest root of Delta_s(G) = dq: (1-G)(G - dq) f^2 = G^2 (1 - beta^2)
    c = 1.0 - beta**2
    a2, a1, a0 = -(f * f) - c, f * f * (1.0 + dq), -(f * f) * dq
    roots = np.roots([a2, a1, a0])
    roots = np.sort(roots[np.isreal(roots)].real)
    g_s = float(roots[0]) if roots.size else math.inf
    return min(g_d, g_s)


def upper_boundary(gamma_f: ArrayLike, f: float, beta: float) -> np.ndarray:
    """The paper's dashed line: upper envelope of the three (truncated) boundaries."""
    g = np.atleast_1d(np.asarray(gamma_f, dtype=float))
    b = stability_boundaries(g, f, beta)
    qs = np.where(g <= qs_truncation_gamma(f, beta), b["quasistatic"], -np.inf)
    return np.fmax(np.fmax(b["dilatational"], np.nan_to_num(b["shear"], nan=-np.inf)), qs)
