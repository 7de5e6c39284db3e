"""Exact two-body spectrum: a slider on a deformable substrate (finite contrast).

Geometry and units: body 1 (the slider) ``0 < y < H`` with ``mu = rho = c_s = 1`` and ``beta``;
body 2 (the substrate) ``-H2 < y < 0`` with ``mu2, rho2`` relative to body 1,
``c_s2 = sqrt(mu2/rho2)``, ``c_d2 = c_s2/beta2`` (:attr:`analytic.params.Params.substrate`).
Perturbations go as ``exp(Lambda t - i k x)``.

**Fields in one layer** (material ``mu, rho, beta``; ``c_s^2 = mu/rho``). With
``psi'' = k_s^2 psi``, ``phi'' = k_d^2 phi``, ``k_s^2 = Lambda^2/c_s^2 + k^2``,
``k_d^2 = beta^2 Lambda^2/c_s^2 + k^2`` and ``P = Lambda^2/c_s^2 + 2 k^2``::

    u_x = psi' - i k phi            u_y = i k psi + phi'
    s_xy = mu (P psi - 2 i k phi')  s_yy = mu (P phi + 2 i k psi')

(body 1: exactly :mod:`analytic.physics.finite_h`). Columns of body 2 are divided by ``mu2`` (a
positive constant: zeros and phase unchanged), so its stresses are O(1) however stiff it is.

**Matrix** (8x8 for finite ``H`` and ``H2``; a half-space drops its two outer columns and its
two outer rows). Columns: body 1 then body 2, each ``psi, phi`` partial waves. Rows:

- the top condition at ``y = H`` (``bc``: ``u_x = s_yy = 0`` or ``s_xy = s_yy = 0``),
- the bottom condition at ``y = -H2`` (``bc2``: ``u_x = s_yy = 0`` or ``s_xy = s_yy = 0``),
- at ``y = 0``: ``u_y``, ``s_xy``, ``s_yy`` continuous, and the friction law on the slip
  ``(Lambda+1)(1 + alpha_pc Lambda) s_xy + (f (Lambda+1) - alpha_ld Lambda) s_yy
  - (1/gamma) Lambda (Lambda + Delta) (u_x^(1) - u_x^(2)) = 0`` (the coefficients of
  :meth:`analytic.law.FrictionLaw.row`, the same polynomial form as the rigid
  case).

**Single-valued spectrum function** (finite ``H`` and ``H2``). Exactly as
:func:`analytic.physics.finite_h.det_M`, per layer: the even basis (``cosh(k (y - y_outer))``,
``sinh(k (y - y_outer))/k``) makes every entry even in ``k_s, k_d`` of both layers, so
``det(M_even)`` is entire in ``Lambda``; it vanishes like ``Lambda^8`` at ``Lambda = 0``
(both layers' potential representations degenerate, ``Lambda^4`` each; measured, see tests).
:func:`det_twobody` evaluates instead a well-conditioned *regular* partial-wave determinant:
partial waves decaying from the interface and from the outer boundary, each ``(psi, phi)`` pair
replaced by ``psi`` and the divided difference ``(phi + sigma psi) / (k_d - k_s)``, written
without cancellation (:func:`_regular_pair`). That pair stays independent at ``Lambda = 0``, so
nothing vanishes there and nothing is lost when ``|Lambda| / c_s << k`` (a stiff substrate is
quasi-static: ``mu2 = 1e10`` still works). Per finite layer
``det(M_even)/Lambda^4 = const * det(M_regular) exp(H (k_s + k_d)) / (k_s k_d (k_s + k_d)^2)``;
:func:`det_twobody` multiplies the Hadamard-normalised ``det(M_regular)`` by the phase of that
factor and divides it by the positive weight ``h/(1+h)`` per wavenumber (``finite_h``'s).
Result: single-valued, continuous phase, no poles, zero exactly at the spectrum, modulus a
relative residual (~1e-16 at a computed root). The argument principle
(:mod:`analytic.numerics.roots`)
therefore counts eigenvalues in any box, ``Lambda = 0`` included. One difference from
:func:`analytic.physics.finite_h.det_M`: across the imaginary axis beyond the branch points (where
the
principal ``k_s, k_d`` flip sign) the Hadamard row norms of the regular basis are not
invariant, so the *modulus* jumps by up to 14 % there (measured over several stacks); the phase
is continuous (to 1e-6 rad), and :func:`analytic.numerics.roots.winding_number` allows relative
jumps
up to 0.8 between samples (a larger one would raise ``ContourError``, never miscount).

**Half-spaces** (``H = inf`` and/or ``H2 = inf``): only the decaying partial waves, with
principal square roots (the physical sheet). The function is analytic off the cuts
``Lambda in i R``, ``|Im Lambda| > c_s k`` (resp. ``c_s2 k``, ``c_d k``...) on the imaginary
axis (the regular basis has no spurious zero at ``Lambda = 0``). Boxes for
:func:`analytic.numerics.roots.zeros_in_box` must not cross the imaginary axis beyond the smallest
branch point ``min(c_s1, c_s2) k`` (e.g. ``Re Lambda > 0`` boxes: every unstable root).

Independent check: :func:`det_twobody_propagator` (first-order ODE system for
``(u_x, u_y, s_xy, s_yy)`` in each layer, matrix exponentials; entire in ``Lambda``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from analytic.law import FrictionLaw
from analytic.params import Material, ParameterError, Params
from analytic.physics.finite_h import _even_pair, row_normalised_det

SPURIOUS_ORDER_FINITE_LAYER = 4
SPURIOUS_ORDER_HALF_SPACE = 2


def _require_two_body(p: Params) -> None:
    if not p.two_body:
        raise ParameterError("mu2 = inf (rigid substrate): use analytic.physics.finite_h / "
                             "analytic.physics.halfspace, or give a finite mu2 > 0")


SHEETS = ("physical", "outgoing")


def layer_wavenumbers(Lambda: np.ndarray, k: np.ndarray, m: Material, sheet: str = "physical"
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``k_s, k_d`` and ``P = Lambda^2/c_s^2 + 2 k^2`` of one layer.

    ``sheet = "physical"``: principal roots (``Re >= 0``, cuts on the imaginary axis beyond
    ``+-i c k``). ``sheet = "outgoing"``: ``k_s = sqrt(a + i k) sqrt(a - i k)``,
    ``a = Lambda / c_s`` (principal factors), equal to the principal root for
    ``Re Lambda > 0`` and continued analytically across the imaginary axis, where it gives the
    waves that carry energy *away* from the interface (radiation); its cuts run from
    ``+-i c k`` to the left, parallel to the real axis. Its roots in ``Re Lambda < 0`` are the
    leaky (radiating) modes that a PML or a long time signal sees.
    """
    a = Lambda * math.sqrt(m.rho / m.mu)
    L2 = a * a
    k2 = k * k
    if sheet == "physical":
        return np.sqrt(L2 + k2), np.sqrt(m.beta**2 * L2 + k2), L2 + 2.0 * k2
    if sheet != "outgoing":
        raise ParameterError(f"sheet = {sheet!r} is not one of {', '.join(SHEETS)}")
    b = m.beta * a
    return (np.sqrt(a + 1j * k) * np.sqrt(a - 1j * k), np.sqrt(b + 1j * k) * np.sqrt(b - 1j * k),
            L2 + 2.0 * k2)


def _fields(P: np.ndarray, k: np.ndarray, mu: float, v: np.ndarray, d: np.ndarray,
            kind: str) -> np.ndarray:
    """(u_x, u_y, s_xy, s_yy) / mu of one potential with value ``v`` and derivative ``d``."""
    if kind == "psi":
        f = [d, 1j * k * v, P * v, 2j * k * d]
    else:
        f = [-1j * k * v, d, -2j * k * d, P * v]
    f[0] = f[0] / mu
    f[1] = f[1] / mu
    return np.stack(f, axis=-1)


def _phi1(x: np.ndarray) -> np.ndarray:
    """``expm1(x) / x`` (1 at 0), for complex ``x``."""
    small = np.abs(x) < 1e-5
    xs = np.where(small, 1.0, x)
    return np.where(small, 1.0 + 0.5 * x + x * x / 6.0, np.expm1(xs) / xs)


def _regular_pair(ks: np.ndarray, kd: np.ndarray, k: np.ndarray, P: np.ndarray, eps: np.ndarray,
                  beta: float, sigma: np.ndarray | float, t: np.ndarray | float) -> np.ndarray:
    """Fields of the partial waves ``psi = exp(-sigma k_s t)`` and ``N = (phi + sigma psi)/D``.

    ``phi = i exp(-sigma k_d t)``, ``D = k_d - k_s = (beta^2 - 1) eps / (k_d + k_s)``,
    ``eps = Lambda^2 / c_s^2``. At ``Lambda = 0`` the two partial waves coincide
    (``phi = -sigma psi``); ``N`` is their divided difference, written without cancellation
    (every difference of square roots as ``eps`` over a sum), so the pair stays independent and
    well conditioned down to ``Lambda = 0`` (the quasi-static limit of a stiff substrate).
    ``sigma``, ``t`` may be arrays broadcast against the others (several pairs in one call).
    Returns the fields of shape ``broadcast + (2, 4)``: ``psi`` then ``N``, each ``(u_x, u_y,
    s_xy, s_yy)`` for ``mu = 1``.
    """
    Es = np.exp(-sigma * ks * t)
    D = (beta * beta - 1.0) * eps / (kd + ks)
    x = -sigma * D * t
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        big = np.abs(x) > 0.5
        Dsafe = np.where(big, D, 1.0)
        Q = np.where(big, (np.exp(-sigma * kd * t) - Es) / Dsafe, -sigma * t * Es * _phi1(x))
    omb = 1.0 - beta * beta
    k_ks = -eps / (k + ks)  # k - k_s
    r_ks = (kd + ks) / (omb * (k + ks))  # (k - k_s) / D
    r_kd = -beta * beta * (kd + ks) / (omb * (kd + k))  # (k_d - k) / D
    r_pd = -(kd + ks) * (kd + k * (1.0 - 2.0 * beta * beta)) / (omb * (kd + k))  # (P-2k k_d)/D
    r_ps = (kd + ks) * k_ks / (omb * (k + ks))  # (P - 2 k k_s) / D
    d = -sigma * ks * Es
    out = np.empty(Es.shape + (2, 4), dtype=complex)  # filled in place: np.stack of small
    out[..., 0, 0], out[..., 0, 1] = d, 1j * k * Es  # arrays dominated the cost
    out[..., 0, 2], out[..., 0, 3] = P * Es, 2j * k * d
    out[..., 1, 0] = k * Q + r_ks * Es
    out[..., 1, 1] = -1j * sigma * (kd * Q + r_kd * Es)
    out[..., 1, 2] = sigma * (r_pd * Es - 2.0 * k * kd * Q)
    out[..., 1, 3] = 1j * (P * Q + r_ps * Es)
    return out


def _layer(Lambda: np.ndarray, k: np.ndarray, m: Material, H: float, side: int, basis: str,
           sheet: str = "physical") -> tuple[np.ndarray, np.ndarray | None]:
    """Fields of one layer's basis columns at the interface and at its outer boundary.

    ``side = +1``: body 1, ``0 < y < H``; ``side = -1``: body 2, ``-H < y < 0``. Columns are
    scaled by ``1/mu`` (displacements ``/ mu``, stresses as they are). Returns
    ``(at_interface, at_outer)`` of shape ``(..., 4 fields, n_columns)``; ``at_outer`` is None
    for a half-space (two decaying columns only).

    Bases: ``"regular"`` (default: partial waves decaying from the interface and from the
    outer boundary, each ``psi, phi`` pair replaced by ``psi`` and the divided difference of
    :func:`_regular_pair`), ``"waves"`` (the plain partial waves, degenerate at
    ``Lambda = 0``), ``"even"`` (``cosh``, ``sinh/k`` about the outer boundary). ``sheet``
    (:func:`layer_wavenumbers`) applies to a half-space only; finite layers are single-valued.
    """
    ks, kd, P = layer_wavenumbers(Lambda, k, m, sheet if not math.isfinite(H) else "physical")
    s = float(side)
    if basis == "regular":
        eps = Lambda * Lambda * (m.rho / m.mu)
        # (sigma, t) of each pair, all in one call: the wave decaying from the interface at
        # the interface (s, 0); for a finite layer also the one from the outer boundary
        # exp(s k (y - s H)) at the interface (-s, -s H), then both at the outer boundary
        # (s, s H) and (-s, 0)
        sig, at = ([s], [0.0]) if not math.isfinite(H) else \
            ([s, -s, s, -s], [0.0, -s * H, s * H, 0.0])
        ex = (Ellipsis, None)
        pairs = _regular_pair(ks[ex], kd[ex], k[ex], P[ex], eps[ex], m.beta, np.array(sig),
                              np.array(at))  # (..., pair, psi/N, field)
        c = np.swapaxes(pairs.reshape(pairs.shape[:-3] + (2 * len(sig), 4)), -1, -2)
        c[..., 0:2, :] /= m.mu  # (..., field, column): columns psi, N of each pair
        return (c, None) if not math.isfinite(H) else (c[..., 0:4], c[..., 4:8])
    one = np.ones_like(ks)
    zero = np.zeros_like(ks)
    if not math.isfinite(H):
        # decaying away from the interface: exp(-side k y)
        inner = [(one, -s * ks, "psi"), (1j * one, -1j * s * kd, "phi")]
        outer = None
    elif basis == "waves":
        es, ed = np.exp(-H * ks), np.exp(-H * kd)
        # exp(-side k y) from the interface, exp(side k (y - side H)) from the outer boundary
        inner = [(one, -s * ks, "psi"), (1j * one, -1j * s * kd, "phi"),
                 (es, s * ks * es, "psi"), (1j * ed, 1j * s * kd * ed, "phi")]
        outer = [(es, -s * ks * es, "psi"), (1j * ed, -1j * s * kd * ed, "phi"),
                 (one, s * ks, "psi"), (1j * one, 1j * s * kd, "phi")]
    elif basis == "even":
        # cosh(k (y - side H)) and sinh(k (y - side H))/k, times exp(-H Re k)
        cs, ss = _even_pair(ks, H)
        cd, sd = _even_pair(kd, H)
        rs, rd = np.exp(-H * ks.real), np.exp(-H * kd.real)
        inner = [(cs, -s * ks * ks * ss, "psi"), (-s * ss, cs, "psi"),
                 (cd, -s * kd * kd * sd, "phi"), (-s * sd, cd, "phi")]
        outer = [(rs * one, zero, "psi"), (zero, rs * one, "psi"),
                 (rd * one, zero, "phi"), (zero, rd * one, "phi")]
    else:
        raise ValueError(f"basis = {basis!r} is not 'regular', 'waves' or 'even'")

    def stack(cols: list[tuple[np.ndarray, np.ndarray, str]]) -> np.ndarray:
        return np.stack([_fields(P, k, m.mu, v, d, kind) for v, d, kind in cols], axis=-1)

    return stack(inner), (None if outer is None else stack(outer))


_BC_ROWS = {"velocity": (0, 3), "stress": (2, 3)}


def matrix_twobody(Lambda: np.ndarray | complex, k: np.ndarray | float, p: Params,
                   basis: str = "regular", sheet: str = "physical") -> np.ndarray:
    """The two-body matrix (8x8 for finite ``H, H2``; 6x6 or 4x4 with half-spaces).

    Rows: top condition (2, finite ``H``), bottom condition (2, finite ``H2``), ``[u_y]``,
    ``[s_xy]``, ``[s_yy]``, friction. Columns: body 1, then body 2 (``/ mu2``).

    Args:
        Lambda: Complex growth rate(s); broadcast against ``k``.
        k: Wavenumber(s) ``> 0``.
        p: Parameters with finite ``mu2``.
        basis: ``"regular"`` (default), ``"waves"`` or ``"even"`` (see :func:`_layer`).
        sheet: ``"physical"`` or ``"outgoing"`` for a half-space (:func:`layer_wavenumbers`).

    Returns:
        Array of shape ``broadcast(Lambda, k).shape + (n, n)``.
    """
    _require_two_body(p)
    L, kk = np.broadcast_arrays(np.asarray(Lambda, dtype=complex), np.asarray(k, dtype=float))
    in1, out1 = _layer(L, kk, p.slider, p.H, +1, basis, sheet)
    in2, out2 = _layer(L, kk, p.substrate, p.H2, -1, basis, sheet)
    n1, n2 = in1.shape[-1], in2.shape[-1]
    n_rows = 4 + (out1 is not None) * 2 + (out2 is not None) * 2
    M = np.zeros(L.shape + (n_rows, n1 + n2), dtype=complex)  # filled row by row in place
    i = 0
    if out1 is not None:
        for r in _BC_ROWS[p.bc]:
            M[..., i, :n1] = out1[..., r, :]
            i += 1
    if out2 is not None:
        for r in _BC_ROWS[p.bc2]:
            M[..., i, n1:] = out2[..., r, :]
            i += 1
    for r in (1, 2, 3):  # u_y, s_xy, s_yy continuous
        M[..., i, :n1], M[..., i, n1:] = in1[..., r, :], -in2[..., r, :]
        i += 1
    a, b, c = FrictionLaw.from_params(p).row(L)
    a, b, c = a[..., None], b[..., None], c[..., None]
    M[..., i, :n1] = a * in1[..., 2, :] + b * in1[..., 3, :] + c * in1[..., 0, :]
    M[..., i, n1:] = -c * in2[..., 0, :]
    return M


def spurious_order(p: Params) -> int:
    """Order of the spurious zero at ``Lambda = 0`` of the ``"even"``/``"waves"`` determinants."""
    return sum(SPURIOUS_ORDER_FINITE_LAYER if math.isfinite(h) else SPURIOUS_ORDER_HALF_SPACE
               for h in (p.H, p.H2))


def det_twobody(Lambda: np.ndarray | complex, k: np.ndarray | float, p: Params,
                sheet: str = "physical") -> np.ndarray:
    """The two-body spectrum function: zero exactly at the eigenvalues, no poles.

    Single-valued in ``Lambda`` for finite ``H`` and ``H2`` (module docstring); with a
    half-space, the physical-sheet function (principal square roots). Modulus: the
    Hadamard-normalised determinant in the regular partial-wave basis (a relative residual,
    ~1e-16 at a computed root) divided by the positive weight ``h/(1+h)`` per ``k_s``, ``k_d``
    of a finite layer (``h = H |k|``), which removes the spurious zeros where two partial waves
    of a finite layer coincide (``k_s = 0`` or ``k_d = 0``).

    Args:
        Lambda: Complex growth rate(s), any shape; broadcast against ``k``.
        k: Wavenumber(s) ``> 0``.
        p: Parameters with finite ``mu2``.
        sheet: For a half-space (``H`` or ``H2`` infinite): ``"physical"`` (principal roots,
            decaying waves) or ``"outgoing"`` (radiating continuation across the imaginary
            axis, :func:`layer_wavenumbers`); the same for ``Re Lambda > 0``.

    Returns:
        Complex array of the broadcast shape.
    """
    _require_two_body(p)
    L, kk = np.broadcast_arrays(np.asarray(Lambda, dtype=complex), np.asarray(k, dtype=float))
    layers = [(p.slider, p.H), (p.substrate, p.H2)]
    scale = np.abs(L) + kk
    degenerate = np.zeros(L.shape, dtype=bool)
    for m, h in layers:
        if math.isfinite(h):
            ks, kd, _ = layer_wavenumbers(L, kk, m)
            degenerate = degenerate | (np.abs(ks) < 1e-12 * scale) | (np.abs(kd) < 1e-12 * scale)
    if degenerate.any():  # removable 0/0 points of a continuous function: step off them
        L = np.where(degenerate, L + 1e-12 * scale * (1 + 1j), L)
    M = matrix_twobody(L, kk, p, "regular", sheet)
    with np.errstate(invalid="ignore", divide="ignore"):
        phase = np.ones(L.shape, dtype=complex)
        weight = np.ones(L.shape)
        for m, h in layers:
            if not math.isfinite(h):
                continue
            # det(M_even) / Lambda^4 of this layer ~ det(M_regular) exp(h (k_s + k_d))
            #   / (k_s k_d (k_s + k_d)^2)  (positive constants dropped)
            ks, kd, _ = layer_wavenumbers(L, kk, m)
            hs, hd = h * np.abs(ks), h * np.abs(kd)
            phase = phase * np.exp(1j * h * (ks.imag + kd.imag))
            phase = phase * np.where(hs > 0, np.abs(ks) / ks, 1.0)
            phase = phase * np.where(hd > 0, np.abs(kd) / kd, 1.0)
            phase = phase * (np.abs(ks + kd) / (ks + kd)) ** 2
            weight = weight * (hs / (1.0 + hs)) * (hd / (1.0 + hd))
        return row_normalised_det(M) * phase / weight


def det_twobody_even(Lambda: np.ndarray | complex, k: np.ndarray | float, p: Params
                     ) -> np.ndarray:
    """``det(M_even) / Lambda^8`` up to a positive factor, from the even basis (a cross-check).

    Finite ``H`` and ``H2`` only; accurate for moderate ``H Re k`` (ill-conditioned for large).
    """
    _finite_layers(p)
    return row_normalised_det(matrix_twobody(Lambda, k, p, "even"), Lambda, spurious_order(p))


def _finite_layers(p: Params) -> None:
    _require_two_body(p)
    if not (math.isfinite(p.H) and math.isfinite(p.H2)):
        raise ParameterError("H = inf or H2 = inf: this function needs finite H and H2")


def _state_matrix(Lambda: complex, k: float, m: Material) -> np.ndarray:
    """``w' = A w`` for ``w = (u_x, u_y, s_xy, s_yy)`` in a layer of material ``m``."""
    mu, lam = m.mu, m.lame_lambda
    ik = 1j * k
    return np.array([
        [0, ik, 1 / mu, 0],
        [ik * lam / (lam + 2 * mu), 0, 0, 1 / (lam + 2 * mu)],
        [m.rho * Lambda**2 + k * k * (lam + 2 * mu) - k * k * lam * lam / (lam + 2 * mu), 0, 0,
         ik * lam / (lam + 2 * mu)],
        [0, m.rho * Lambda**2, ik, 0],
    ], dtype=complex)


_FREE = {"velocity": [1, 2], "stress": [0, 1]}  # unknown components on a boundary


def det_twobody_propagator(Lambda: complex, k: float, p: Params) -> complex:
    """Independent formulation: 4x4 determinant from the layers' propagators (scalar ``Lambda``).

    ``w(0^+) = expm(-A_1 H) w(H)``, ``w(0^-) = expm(A_2 H2) w(-H2)`` with the two free
    components of ``w`` at each outer boundary as unknowns; rows ``[u_y], [s_xy], [s_yy]``,
    friction. Entire in ``Lambda`` (no spurious zeros), but its zeros only; moderate ``k H``.
    """
    _finite_layers(p)
    L = complex(Lambda)
    T1 = scipy.linalg.expm(-_state_matrix(L, k, p.slider) * p.H)[:, _FREE[p.bc]]
    T2 = scipy.linalg.expm(_state_matrix(L, k, p.substrate) * p.H2)[:, _FREE[p.bc2]]
    a, b, c = (complex(v) for v in FrictionLaw.from_params(p).row(np.array(L)))
    rows = np.array([
        np.concatenate([T1[1], -T2[1]]),
        np.concatenate([T1[2], -T2[2]]),
        np.concatenate([T1[3], -T2[3]]),
        np.concatenate([a * T1[2] + b * T1[3] + c * T1[0], -c * T2[0]]),
    ])
    return complex(np.linalg.det(rows))


# --------------------------------------------------------------------------------------------
# k = 0 cut-offs
# --------------------------------------------------------------------------------------------
def cutoff_twobody(n: int, sign: int, p: Params) -> complex:
    """Cut-off ``Lambda_0`` of branch ``(n, sign)`` at ``k -> 0`` for two bodies (finite ``H``).

    At ``k = 0`` the dilatational fields decouple (``s_yy = 0`` on both outer boundaries for
    every ``bc``/``bc2``; ``u_y``, ``s_yy`` continuous at ``y = 0``): a free-free composite rod
    with impedances ``Z1 = 1/beta``, ``Z2 = rho2 c_d2``.

    Finite ``H2``: the ``n``-th root (``n = 0, 1, ...``, by increasing ``|Im|``, ``sign Im > 0``)
    of ``Z1 sin(beta H w) cos(H2 w / c_d2) + Z2 cos(beta H w) sin(H2 w / c_d2) = 0``,
    ``Lambda_0 = i w``, excluding ``w = 0`` (the rigid translation of the stack in ``y``, which
    becomes the flexural branch for ``k > 0``). A stiff thin substrate acts as a free rigid mass
    ``rho2 H2``: ``beta H w_n in ((2n+1) pi/2, (n+1) pi)``. So ``mu2 -> inf`` at fixed ``k > 0``
    gives the rigid roots, but the cut-offs stay those of the mass-loaded rod: the rigid limit is
    not uniform in ``k``.

    ``H2 = inf``: the rod radiates into the substrate, ``tanh(beta Lambda_0 H) = -Z2/Z1``: leaky
    cut-offs with ``Re Lambda_0 < 0``, roots of :func:`det_twobody` with ``sheet="outgoing"``.
    ``Z2 > Z1``: ``beta H Lambda_0 = -atanh(Z1/Z2) + i (n + 1/2) pi``; ``Z2 < Z1``:
    ``-atanh(Z2/Z1) + i (n + 1) pi`` (the real root, ``n = -1``, excluded).

    Raises:
        ParameterError: On ``n < 0``, ``sign`` not +-1, a rigid substrate, ``H = inf`` or an
            impedance-matched half-space substrate (``Z2 = Z1``: no cut-off).
    """
    from scipy.optimize import brentq

    _require_two_body(p)
    if int(n) != n or n < 0:
        raise ParameterError(f"n = {n!r} is outside its allowed range n >= 0 (integer)")
    if sign not in (1, -1):
        raise ParameterError(f"sign = {sign!r} must be +1 or -1")
    if not math.isfinite(p.H):
        raise ParameterError("H = inf: branches start at the cut-offs of a finite slider; "
                             "use a finite H")
    m2 = p.substrate
    z1, z2 = 1.0 / p.beta, m2.rho * m2.c_d
    if not math.isfinite(p.H2):
        r = z2 / z1
        if abs(r - 1.0) < 1e-12:
            raise ParameterError("impedance-matched half-space substrate (rho2 c_d2 = rho1 "
                                 "c_d1): no cut-offs, everything radiates at k = 0")
        if r > 1.0:
            t = complex(-math.atanh(1.0 / r), (n + 0.5) * math.pi)
        else:
            t = complex(-math.atanh(r), (n + 1) * math.pi)
        return complex(t.real, sign * t.imag) / (p.beta * p.H)
    a, b = p.beta * p.H, p.H2 / m2.c_d

    def g(w: np.ndarray | float) -> np.ndarray:
        return z1 * np.sin(a * w) * np.cos(b * w) + z2 * np.cos(a * w) * np.sin(b * w)

    # g is a sum of two sinusoids of frequencies a +- b: neighbouring roots are at least
    # ~pi/(a+b)/2 apart; sample 20 points per pi/(a+b), skip the root at w = 0
    step = 0.05 * math.pi / (a + b)
    w_lo, found = 0.5 * step, 0
    while True:
        w = w_lo + step * np.arange(4097)
        gw = g(w)
        for i in np.nonzero(np.sign(gw[:-1]) * np.sign(gw[1:]) <= 0)[0]:
            if found == n:
                root = brentq(g, w[i], w[i + 1], xtol=1e-15, rtol=1e-15)
                return complex(0.0, sign * root)
            found += 1
        w_lo = float(w[-1])


def branch_sheet(p: Params) -> str:
    """The sheet on which branches of ``p`` are followed: ``"outgoing"`` with a half-space."""
    return "outgoing" if (p.two_body and not math.isfinite(p.H2)) else "physical"


def root_sheet(Lambda: complex, k: float, p: Params) -> str:
    """Which sheet a root of the outgoing continuation is on.

    ``"physical"`` if every half-space partial wave decays away from the interface at
    ``Lambda`` (``Re k_s, Re k_d >= 0``), else ``"leaky"`` (radiating, growing with depth: a
    resonance, not an eigenvalue); ``"physical"`` without half-spaces.
    """
    L, kk = np.asarray(complex(Lambda)), np.asarray(float(k))
    for m, h in ((p.slider, p.H), (p.substrate, p.H2)):
        if not math.isfinite(h):
            ks, kd, _ = layer_wavenumbers(L, kk, m, "outgoing")
            if ks.real < 0 or kd.real < 0:
                return "leaky"
    return "physical"


def composite_rod_roots(p: Params, n_max: int) -> list[complex]:
    """The cut-offs ``cutoff_twobody(n, +1)`` for ``n < n_max`` (for tests and plots)."""
    return [cutoff_twobody(n, 1, p) for n in range(n_max)]


# --------------------------------------------------------------------------------------------
# Generalized Rayleigh wave (two half-spaces, frictionless contact without opening)
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class GeneralizedRayleigh:
    """Result of :func:`generalized_rayleigh`.

    Attributes:
        exists: True if a generalized Rayleigh wave exists.
        speed: Its speed over ``c_s1`` (None if it does not exist).
        c_max: ``min(c_s1, c_s2)``, the upper end of the admissible speeds.
    """

    exists: bool
    speed: float | None
    c_max: float

    def as_dict(self) -> dict[str, bool | float | None]:
        """``{"exists": ..., "speed": ...}`` (the CLI's JSON)."""
        return {"exists": self.exists, "speed": self.speed}


def _gr_function(c: np.ndarray, m1: Material, m2: Material) -> np.ndarray:
    """Secular function of the generalized Rayleigh wave at real speeds ``0 < c < c_max``.

    Each half-space under a normal traction only (``s_xy = 0``) has the normal compliance
    ``u_y / s_yy = -+ s^2 B / (mu k R)`` with ``s = c/c_s``, ``A = sqrt(1 - s^2)``,
    ``B = sqrt(1 - beta^2 s^2)``, Rayleigh function ``R = (2 - s^2)^2 - 4 A B``. Continuity
    of ``u_y`` and ``s_yy`` across the interface: ``s1^2 B1 R2 / mu1 + s2^2 B2 R1 / mu2 = 0``.
    Divided by ``c^4`` (``R ~ 2 (1 - beta^2) s^2`` at small ``c``) to have a finite limit.
    """
    out = np.zeros_like(c)
    terms = []
    for m in (m1, m2):
        s2 = (c / m.c_s) ** 2
        A = np.sqrt(1.0 - s2)
        B = np.sqrt(1.0 - m.beta**2 * s2)
        R = (2.0 - s2) ** 2 - 4.0 * A * B
        terms.append((s2 * B / m.mu, R))
    out = terms[0][0] * terms[1][1] + terms[1][0] * terms[0][1]
    return out / c**4


def generalized_rayleigh(mu2: float, rho2: float, beta: float, beta2: float | None = None
                         ) -> GeneralizedRayleigh:
    """The generalized Rayleigh wave of two half-spaces in frictionless contact (Weertman 1963).

    Body 1: ``mu = rho = 1``, ``beta``; body 2: ``mu2``, ``rho2``, ``beta2`` (None: ``beta``).
    The wave exists iff the secular function (:func:`_gr_function`) has a root in
    ``0 < c < c_max = min(c_s1, c_s2)``; its speed is then between the smaller Rayleigh speed
    and ``c_max`` (identical materials: the Rayleigh speed). Sign changes are bracketed on a
    fine grid (4000 points, clustered towards ``c_max``) and refined by Brent's method.

    Returns:
        A :class:`GeneralizedRayleigh`.

    Raises:
        ParameterError: On invalid material parameters (same ranges as :class:`Params`).
    """
    from scipy.optimize import brentq

    p = Params(beta=beta, mu2=mu2, rho2=rho2, beta2=beta2)
    if not p.two_body:
        raise ParameterError("mu2 = inf: the generalized Rayleigh wave needs a finite mu2")
    m1, m2 = p.slider, p.substrate
    c_max = min(m1.c_s, m2.c_s)
    t = np.linspace(0.0, 1.0, 4001)[1:-1]
    c = c_max * (1.0 - (1.0 - t) ** 2)  # clustered near c_max, where the root goes at the edge
    g = _gr_function(c, m1, m2)
    idx = np.nonzero(np.sign(g[:-1]) * np.sign(g[1:]) < 0)[0]
    if idx.size == 0:
        return GeneralizedRayleigh(False, None, c_max)
    i = int(idx[-1])
    speed = brentq(lambda x: float(_gr_function(np.array([x]), m1, m2)[0]), c[i], c[i + 1],
                   xtol=1e-15, rtol=1e-15)
    return GeneralizedRayleigh(True, float(speed), c_max)


def rayleigh_speed(beta: float) -> float:
    """Rayleigh speed over ``c_s`` of a half-space with ``beta = c_s/c_d``."""
    from scipy.optimize import brentq

    def R(s: float) -> float:
        s2 = s * s
        return (2.0 - s2) ** 2 - 4.0 * math.sqrt(1.0 - s2) * math.sqrt(1.0 - beta**2 * s2)

    return float(brentq(R, 0.5, 1.0 - 1e-15, xtol=1e-15, rtol=1e-15))


def gr_existence_map(mu2s: np.ndarray, rho2s: np.ndarray, beta: float,
                     beta2: float | None = None) -> np.ndarray:
    """Generalized Rayleigh speed over the contrast plane (over ``c_s1``, NaN: no wave).

    ``speed[i, j]`` is at ``(rho2s[i], mu2s[j])``.
    """
    out = np.full((len(rho2s), len(mu2s)), np.nan)
    for i, r in enumerate(rho2s):
        for j, m in enumerate(mu2s):
            g = generalized_rayleigh(float(m), float(r), beta, beta2)
            if g.exists:
                out[i, j] = g.speed
    return out
