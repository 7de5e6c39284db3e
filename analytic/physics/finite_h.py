"""Exact finite-H spectrum ``det M(Lambda, k, H) = 0`` (docs/design.md section 4).

Units ``c_s = mu = rho = 1``, ``c_d = 1/beta``. Perturbations go as ``exp(Lambda t - i k x)``.

**Fields.** With the shear potential ``psi(y)`` and the dilatational potential ``phi(y)``
(``psi'' = k_s^2 psi``, ``phi'' = k_d^2 phi``, ``k_s = sqrt(Lambda^2 + k^2)``,
``k_d = sqrt(beta^2 Lambda^2 + k^2)``) the displacement and the tractions on ``y = const`` are::

    u_x = psi' - i k phi            u_y = i k psi + phi'
    s_xy = P psi - 2 i k phi'       s_yy = P phi + 2 i k psi'        P = Lambda^2 + 2 k^2

``psi = exp(-+ k_s y)`` and ``phi = i exp(-+ k_d y)`` are the four partial waves of the paper's
Eq. (elastic fields) (columns ``A_1..A_4``).

**Matrix.** Four columns (basis solutions), four rows: the two top conditions at ``y = H``
(``bc = "velocity"``: ``u_x = 0, s_yy = 0``; ``bc = "stress"``: ``s_xy = 0, s_yy = 0``), then
``u_y = 0`` and the friction law at ``y = 0`` (docs/design.md section 3), the latter multiplied by
``Lambda + 1`` so that it is polynomial in ``Lambda`` (:meth:`analytic.law.FrictionLaw.row`; not
multiplied when ``alpha_ld = 0`` and ``Delta = 1``, where the factor cancels, so no spurious root
at ``Lambda = -1`` appears). Nothing here has a pole: ``Lambda = -1`` and
``Lambda = -1/alpha_pc`` are ordinary points.

Two bases are implemented (``basis=``):

- ``"waves"``: the paper's partial waves, the growing ones scaled as ``exp(k (y - H))``
  (docs/design.md section 4);
  principal square roots, so this determinant is *not* single-valued in ``Lambda``: flipping the
  sign of ``k_s`` swaps and rescales two columns. Its zeros are the spectrum, but the argument
  principle fails on contours that cross the cuts (``Lambda`` on the imaginary axis with
  ``|Im Lambda| > k`` or ``> k/beta``, exactly where the waveguide branches start).
- ``"even"`` (default, used for all root finding): ``psi in {cosh(k_s (y-H)),
  sinh(k_s (y-H))/k_s}`` and the same for ``phi``; every entry is an even function of ``k_s`` and
  ``k_d``, hence entire and single-valued in ``Lambda``. Each column is multiplied by
  ``exp(-H Re k_{s,d})`` (a positive number: no overflow at large ``kH``, phase unchanged).

**The spectrum function.** The entire, single-valued function whose zeros are the spectrum is
``R(Lambda) = det(M_even) / Lambda^4``: the potential representation degenerates at ``Lambda = 0``
(``k_s = k_d``), where ``det(M_even)`` vanishes like ``Lambda^4`` for both top conditions
(measured; ``Lambda = 0`` is not an eigenvalue). Evaluating ``det(M_even)`` directly is
ill-conditioned at large ``H Re k`` (its top rows mix ``exp(-H Re k_s)`` and ``exp(-H Re k_d)``),
while the partial-wave matrix is well conditioned there. Changing basis column pair by column pair
gives ``det(M_even) = const * det(M_waves) exp(H (k_s + k_d)) / (k_s k_d)``, so :func:`det_M`
returns::

    det_M = det(M_waves) / prod_i ||row_i||  *  exp(i H Im(k_s + k_d)) (|k_s|/k_s) (|k_d|/k_d)
            * (|Lambda|/Lambda)^4  /  w(Lambda)

with the positive weight ``w = (h_s/(1+h_s)) (h_d/(1+h_d)) (|Lambda|/(|Lambda| + k + 1/H))^4``,
``h_{s,d} = H |k_{s,d}|``, which removes the spurious vanishing of the modulus at ``k_s = 0``,
``k_d = 0`` (two partial waves coincide) and ``Lambda = 0``. Its phase is the phase of ``R``, its
modulus is the Hadamard-normalised determinant (about ``1e-16`` at a computed root: a relative
residual) away from those points. So ``det_M`` is single-valued and continuous, has no poles,
its zeros are exactly the spectrum, and its winding number on a contour counts the eigenvalues
inside. It is not analytic (positive, smooth scale factors), which Newton's method and the
argument principle do not need (see :mod:`analytic.numerics.roots`). Rounding: the value loses
accuracy
like ``1e-16 / |Lambda|^4`` near the origin and ``1e-16 / (H |k_{s,d}|)`` near
``Lambda = +-i k, +-i k/beta``: keep contours off those points (``|Lambda| >~ 1e-3``).
"""

from __future__ import annotations

import cmath
import math

import numpy as np

from analytic.law import FrictionLaw
from analytic.params import ParameterError, Params, require_rigid

SPURIOUS_ORDER_AT_ZERO = 4


def _finite_h(p: Params) -> float:
    if not math.isfinite(p.H):
        raise ParameterError("H = inf: the finite-H functions need a finite H > 0 (half-space: "
                             "analytic.physics.halfspace)")
    return p.H


def wavenumbers(Lambda: np.ndarray | complex, k: np.ndarray | float, beta: float
                ) -> tuple[np.ndarray, np.ndarray]:
    """``k_s = sqrt(Lambda^2 + k^2)``, ``k_d = sqrt(beta^2 Lambda^2 + k^2)`` (principal roots)."""
    L = np.asarray(Lambda, dtype=complex)
    k = np.asarray(k, dtype=float)
    return np.sqrt(L * L + k * k), np.sqrt(beta * beta * L * L + k * k)


def _even_pair(kappa: np.ndarray, H: float) -> tuple[np.ndarray, np.ndarray]:
    """``cosh(H kappa)`` and ``sinh(H kappa)/kappa``, both times ``exp(-H Re kappa)``.

    Even in ``kappa``; ``Re kappa >= 0`` for principal roots, so nothing overflows.
    """
    x = H * kappa
    phase = np.exp(1j * x.imag)
    e2 = np.exp(-2.0 * x)
    c = 0.5 * phase * (1.0 + e2)
    small = np.abs(x) < 1e-6
    xs = np.where(small, 1.0, x)
    ratio = np.where(small, 1.0 - x + (2.0 / 3.0) * x * x, -np.expm1(-2.0 * xs) / (2.0 * xs))
    s = H * phase * ratio  # sinh(x)/kappa * exp(-Re x) = H * exp(i Im x) * (1 - e^{-2x})/(2x)
    return c, s


def _columns_fields(P: np.ndarray, k: np.ndarray, vals: list[tuple[np.ndarray, np.ndarray]],
                    kinds: tuple[str, ...]) -> np.ndarray:
    """Fields (u_x, u_y, s_xy, s_yy) of each column from (value, derivative) of its potential."""
    shape = np.broadcast(P, k).shape  # every column's fields broadcast to it on assignment
    out = np.empty(shape + (4, 4), dtype=complex)  # (..., 4 fields, 4 columns)
    for j, ((v, d), kind) in enumerate(zip(vals, kinds, strict=True)):
        # filled in place (np.stack of small arrays dominated the cost of det_M)
        if kind == "psi":
            out[..., 0, j], out[..., 1, j] = d, 1j * k * v
            out[..., 2, j], out[..., 3, j] = P * v, 2j * k * d
        else:
            out[..., 0, j], out[..., 1, j] = -1j * k * v, d
            out[..., 2, j], out[..., 3, j] = -2j * k * d, P * v
    return out


def _boundary_fields(Lambda: np.ndarray, k: np.ndarray, p: Params, basis: str
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Fields of the four basis columns at the bottom (y = 0) and the top (y = H)."""
    H = _finite_h(p)
    ks, kd = wavenumbers(Lambda, k, p.beta)
    P = Lambda * Lambda + 2.0 * k * k
    one = np.ones_like(ks)
    zero = np.zeros_like(ks)
    kinds = ("psi", "psi", "phi", "phi")
    if basis == "even":
        cs, ss = _even_pair(ks, H)
        cd, sd = _even_pair(kd, H)
        rs, rd = np.exp(-H * ks.real), np.exp(-H * kd.real)
        bottom = [(cs, -ks * ks * ss), (-ss, cs), (cd, -kd * kd * sd), (-sd, cd)]
        top = [(rs * one, zero), (zero, rs * one), (rd * one, zero), (zero, rd * one)]
    elif basis == "waves":
        es, ed = np.exp(-H * ks), np.exp(-H * kd)
        bottom = [(one, -ks), (1j * one, -1j * kd), (es, ks * es), (1j * ed, 1j * kd * ed)]
        top = [(es, -ks * es), (1j * ed, -1j * kd * ed), (one, ks), (1j * one, 1j * kd)]
        kinds = ("psi", "phi", "psi", "phi")
    else:
        raise ValueError(f"basis = {basis!r} is not 'even' or 'waves'")
    return _columns_fields(P, k, bottom, kinds), _columns_fields(P, k, top, kinds)


def matrix_M(Lambda: np.ndarray | complex, k: np.ndarray | float, p: Params,
             basis: str = "even") -> np.ndarray:
    """The 4x4 matrix (rows: two top conditions, ``u_y(0) = 0``, friction law at y = 0).

    Args:
        Lambda: Complex growth rate(s); broadcast against ``k``.
        k: Wavenumber(s) ``> 0`` (not checked here: see :func:`analytic.params.check_k`).
        p: Parameters (``p.bc`` selects the top condition).
        basis: ``"even"`` (single-valued, default) or ``"waves"`` (the paper's partial waves).

    Returns:
        Array of shape ``broadcast(Lambda, k).shape + (4, 4)``.
    """
    require_rigid(p, "analytic.physics.finite_h")
    L, kk = np.broadcast_arrays(np.asarray(Lambda, dtype=complex), np.asarray(k, dtype=float))
    bottom, top = _boundary_fields(L, kk, p, basis)
    a, b, c = FrictionLaw.from_params(p).row(L)
    friction = a[..., None] * bottom[..., 2, :] + b[..., None] * bottom[..., 3, :] \
        + c[..., None] * bottom[..., 0, :]
    rows = (0, 3) if p.bc == "velocity" else (2, 3)
    return np.stack([top[..., rows[0], :], top[..., rows[1], :], bottom[..., 1, :], friction],
                    axis=-2)


def _waves_matrix(L: np.ndarray, kk: np.ndarray | float, ks: np.ndarray, kd: np.ndarray,  # noqa: N803
                  p: Params) -> np.ndarray:
    """:func:`matrix_M` in the ``"waves"`` basis, only the entries its four rows use.

    Same floating-point operations, entry by entry, as ``matrix_M(L, kk, p, "waves")`` (``L``,
    ``kk`` broadcast against each other, ``ks``, ``kd`` their :func:`wavenumbers`), so the same
    values (up to the sign of a zero), at a fraction of the per-call cost (``det_M`` is called
    on small arrays thousands of times): each field is computed for the two ``psi`` columns
    (0, 2) and the two ``phi`` columns (1, 3) at once.
    """
    H = p.H
    es, ed = np.exp(-H * ks), np.exp(-H * kd)
    ex = (Ellipsis, None)
    P = (L * L + 2.0 * kk * kk)[ex]
    kx = np.asarray(kk)[ex]
    ik, mik, i2k, mi2k = 1j * kx, -1j * kx, 2j * kx, -2j * kx
    # potentials (value v, y-derivative d) of the columns psi, phi, psi, phi at the top (y = H)
    # and the bottom (y = 0): exp(-k y) from the bottom, exp(k (y - H)) from the top
    vt = np.empty(es.shape + (4,), dtype=complex)
    dt = np.empty(es.shape + (4,), dtype=complex)
    vt[..., 0], vt[..., 1], vt[..., 2], vt[..., 3] = es, 1j * ed, 1.0, 1j
    dt[..., 0], dt[..., 1], dt[..., 2], dt[..., 3] = -ks * es, -1j * kd * ed, ks, 1j * kd
    swap = [2, 3, 0, 1]  # the bottom's columns are the top's, the two waves exchanged
    vb, db = vt[..., swap], -dt[..., swap]
    psi, phi = slice(0, 4, 2), slice(1, 4, 2)
    a, b, c = (np.asarray(x)[ex] for x in FrictionLaw.from_params(p).row(L))
    M = np.empty(es.shape + (4, 4), dtype=complex)
    if p.bc == "velocity":  # u_x at the top: psi d, phi -i k v
        M[..., 0, psi], M[..., 0, phi] = dt[..., psi], mik * vt[..., phi]
    else:  # s_xy at the top: psi P v, phi -2 i k d
        M[..., 0, psi], M[..., 0, phi] = P * vt[..., psi], mi2k * dt[..., phi]
    M[..., 1, psi], M[..., 1, phi] = i2k * dt[..., psi], P * vt[..., phi]  # s_yy at the top
    M[..., 2, psi], M[..., 2, phi] = ik * vb[..., psi], db[..., phi]  # u_y at the bottom
    # friction at the bottom: a s_xy + b s_yy + c u_x
    M[..., 3, psi] = a * (P * vb[..., psi]) + b * (i2k * db[..., psi]) + c * db[..., psi]
    M[..., 3, phi] = a * (mi2k * db[..., phi]) + b * (P * vb[..., phi]) + c * (mik * vb[..., phi])
    return M


def det_M(Lambda: np.ndarray | complex, k: np.ndarray | float, p: Params) -> np.ndarray:
    """The spectrum function: zero exactly at the eigenvalues, single-valued, no poles.

    See the module docstring: the modulus is the Hadamard-normalised partial-wave determinant
    (a relative residual, ``<= 1`` up to the weight near the origin), the phase is that of the
    entire function ``det(M_even) / Lambda^4``.

    Args:
        Lambda: Complex growth rate(s), any shape; broadcast against ``k``.
        k: Wavenumber(s) ``> 0``.
        p: Parameters (finite ``H``).

    Returns:
        Complex array of the broadcast shape (a 0-d array for scalar input).
    """
    H = _finite_h(p)
    require_rigid(p, "analytic.physics.finite_h")
    if np.ndim(k) == 0 and np.size(Lambda) <= SMALL_CALL:
        # a Newton step's five points: the same formula point by point in Python's complex
        # arithmetic, without numpy's per-operation overhead (None: a point it leaves to the
        # arrays below)
        out = _det_M_points(np.asarray(Lambda, dtype=complex), float(k), p)
        if out is not None:
            return out
    if np.ndim(k) == 0:  # one k (the usual call): no broadcast copies
        L, kk = np.array(Lambda, dtype=complex), float(k)
    else:
        L, kk = np.broadcast_arrays(np.asarray(Lambda, dtype=complex),
                                    np.asarray(k, dtype=float))
    # Exactly at k_s = 0, k_d = 0 or Lambda = 0 the formula is 0/0 (a removable point of a
    # continuous function): evaluate a relative 1e-12 away instead.
    ks, kd = wavenumbers(L, kk, p.beta)
    aL = np.abs(L)
    tiny = 1e-12 * (aL + kk)
    degenerate = (np.abs(ks) < tiny) | (np.abs(kd) < tiny) | (L == 0)
    if degenerate.any():
        L = np.where(degenerate, L + tiny * (1 + 1j), L)
        ks, kd = wavenumbers(L, kk, p.beta)
        aL = np.abs(L)
    M = _waves_matrix(L, kk, ks, kd, p)
    # after the step off the degenerate points k_s, k_d and Lambda are nonzero
    aks, akd = np.abs(ks), np.abs(kd)
    hs, hd = H * aks, H * akd
    phase = np.exp(1j * H * (ks.imag + kd.imag)) * (aks / ks) * (akd / kd) \
        * (aL / L) ** SPURIOUS_ORDER_AT_ZERO
    weight = (hs / (1.0 + hs)) * (hd / (1.0 + hd)) \
        * (aL / (aL + kk + 1.0 / H)) ** SPURIOUS_ORDER_AT_ZERO
    rnd = row_normalised_det(M)
    near = aL < NEAR_ORIGIN * kk
    if np.any(near):
        shape = np.shape(rnd)
        idx = np.flatnonzero(np.broadcast_to(near, shape))
        flat = np.array(rnd, dtype=complex).reshape(-1)

        def pick(x: np.ndarray | float) -> np.ndarray:
            return np.broadcast_to(x, shape).reshape(-1)[idx]

        flat[idx] = _det_near_origin(pick(L), pick(kk), pick(ks), pick(kd),
                                     np.broadcast_to(M, shape + (4, 4)).reshape(-1, 4, 4)[idx], p)
        rnd = flat.reshape(shape)
    return rnd * phase / weight


#: :func:`det_M` on at most this many points (one ``k``) takes :func:`_det_M_points`: a polish's
#: Newton step evaluates five (value and difference stencil), and with arrays that small
#: numpy's per-operation overhead was most of its cost (session 21: 5 points 300 us with the
#: arrays, 80-95 us point by point; 5-point calls were a third of a stability map's time).
SMALL_CALL = 8


def _det4(m: list[list[complex]]) -> complex:
    """Determinant of a 4 x 4 matrix (four rows of four) by LU with partial pivoting.

    The pivot is the entry of largest ``|Re| + |Im|`` (LAPACK's ``izamax``, which
    ``numpy.linalg.det`` uses; the first such row on a tie). Written out column by column: the
    operations, their order and the row swaps of the loop over columns it replaced (kept as
    the reference in tests/test_det_m_fast.py, equal bit for bit), without its loops and
    indexing, which were most of its cost (session 25: 10.4 -> 4.4 us a call; one call per
    point of every Newton step of ``analytic``).
    """
    r0, r1, r2, r3 = m
    d: complex = 1.0
    # column 0: pivot, then the 3 x 3 Schur complement x1, x2, x3
    z = r0[0]
    best, piv = abs(z.real) + abs(z.imag), 0
    z = r1[0]
    if (v := abs(z.real) + abs(z.imag)) > best:
        best, piv = v, 1
    z = r2[0]
    if (v := abs(z.real) + abs(z.imag)) > best:
        best, piv = v, 2
    z = r3[0]
    if abs(z.real) + abs(z.imag) > best:
        piv = 3
    if piv == 1:
        r0, r1, d = r1, r0, -d
    elif piv == 2:
        r0, r2, d = r2, r0, -d
    elif piv == 3:
        r0, r3, d = r3, r0, -d
    a = r0[0]
    if a == 0:
        return 0j
    d *= a
    a1, a2, a3 = r0[1], r0[2], r0[3]
    f = r1[0] / a
    x1 = (r1[1] - f * a1, r1[2] - f * a2, r1[3] - f * a3)
    f = r2[0] / a
    x2 = (r2[1] - f * a1, r2[2] - f * a2, r2[3] - f * a3)
    f = r3[0] / a
    x3 = (r3[1] - f * a1, r3[2] - f * a2, r3[3] - f * a3)
    # column 1: pivot among x1, x2, x3, then the 2 x 2 complement y2, y3
    z = x1[0]
    best, piv = abs(z.real) + abs(z.imag), 1
    z = x2[0]
    if (v := abs(z.real) + abs(z.imag)) > best:
        best, piv = v, 2
    z = x3[0]
    if abs(z.real) + abs(z.imag) > best:
        piv = 3
    if piv == 2:
        x1, x2, d = x2, x1, -d
    elif piv == 3:
        x1, x3, d = x3, x1, -d
    a = x1[0]
    if a == 0:
        return 0j
    d *= a
    a2, a3 = x1[1], x1[2]
    f = x2[0] / a
    y2 = (x2[1] - f * a2, x2[2] - f * a3)
    f = x3[0] / a
    y3 = (x3[1] - f * a2, x3[2] - f * a3)
    # column 2
    z, w = y2[0], y3[0]
    if abs(w.real) + abs(w.imag) > abs(z.real) + abs(z.imag):
        y2, y3, d = y3, y2, -d
    a = y2[0]
    if a == 0:
        return 0j
    d *= a
    return d * (y3[1] - y3[0] / a * y2[1])


def _det_M_points(L: np.ndarray, k: float, p: Params) -> np.ndarray | None:  # noqa: N803
    """:func:`det_M` at a few points of one ``k``, point by point (the same formula).

    The entries are those of :func:`_waves_matrix`, the determinant :func:`_det4`; they differ
    from the array path by rounding only (relative ``~ 1e-16`` times the matrix's condition
    number: tests/test_det_m_fast.py). ``None`` if a point needs the array path's special
    cases (a removable point, ``|Lambda| < NEAR_ORIGIN k``, a value not finite).
    """
    H, b2 = p.H, p.beta * p.beta
    law = FrictionLaw.from_params(p)
    out: list[complex] = []
    ik, mik, i2k, mi2k = 1j * k, -1j * k, 2j * k, -2j * k
    kk, kk2, near, inv_h = k * k, 2.0 * k * k, NEAR_ORIGIN * k, 1.0 / H
    # the law's parameters and the top's row, once per call (not per point)
    cancels, velocity = law.cancels, p.bc == "velocity"
    apc, fr, gam, dlt, ald = law.alpha_pc, law.f, law.gamma, law.Delta, law.alpha_ld
    try:
        for z in L.ravel().tolist():
            aL = abs(z)
            if not aL >= near or not math.isfinite(aL):
                return None
            L2 = z * z  # noqa: N806
            ks, kd = cmath.sqrt(L2 + kk), cmath.sqrt(b2 * L2 + kk)
            aks, akd = abs(ks), abs(kd)
            tiny = 1e-12 * (aL + k)
            if aks < tiny or akd < tiny:
                return None
            es, ed = cmath.exp(-H * ks), cmath.exp(-H * kd)
            P = L2 + kk2  # noqa: N806
            # the columns psi, phi, psi, phi: potentials at the top (v, d) and the bottom
            vt1, vt3 = 1j * ed, 1j
            dt0, dt1, dt2, dt3 = -ks * es, -1j * kd * ed, ks, 1j * kd
            vb0, vb1, vb2, vb3 = 1.0, 1j, es, 1j * ed
            db0, db1, db2, db3 = -dt2, -dt3, -dt0, -dt1
            if cancels:
                a, bf, c = 1.0 + apc * z, fr, -z / gam
            else:
                a = (1.0 + apc * z) * (z + 1.0)
                bf = fr * (z + 1.0) - ald * z
                c = -z * (z + dlt) / gam
            if velocity:  # u_x at the top
                r0 = (dt0, mik * vt1, dt2, mik * vt3)
            else:  # s_xy at the top
                r0 = (P * es, mi2k * dt1, P, mi2k * dt3)
            rows = (r0,
                    (i2k * dt0, P * vt1, i2k * dt2, P * vt3),  # s_yy at the top
                    (ik * vb0, db1, ik * vb2, db3),  # u_y at the bottom
                    (a * (P * vb0) + bf * (i2k * db0) + c * db0,  # friction at the bottom
                     a * (mi2k * db1) + bf * (P * vb1) + c * (mik * vb1),
                     a * (P * vb2) + bf * (i2k * db2) + c * db2,
                     a * (mi2k * db3) + bf * (P * vb3) + c * (mik * vb3)))
            # the row norms as the array path computes them: sqrt of the sum of Re^2 + Im^2
            norm = 1.0
            for r0_, r1_, r2_, r3_ in rows:
                norm *= math.sqrt(r0_.real * r0_.real + r0_.imag * r0_.imag
                                  + r1_.real * r1_.real + r1_.imag * r1_.imag
                                  + r2_.real * r2_.real + r2_.imag * r2_.imag
                                  + r3_.real * r3_.real + r3_.imag * r3_.imag)
            u = aL / z
            phase = cmath.exp(1j * H * (ks.imag + kd.imag)) * (aks / ks) * (akd / kd) \
                * (u * u) * (u * u)
            hs, hd = H * aks, H * akd
            w = aL / (aL + k + inv_h)
            weight = (hs / (1.0 + hs)) * (hd / (1.0 + hd)) * (w * w) * (w * w)
            out.append(_det4(rows) / norm * phase / weight)
    except (OverflowError, ZeroDivisionError, ValueError):
        return None
    return np.array(out, dtype=complex).reshape(L.shape)


#: ``|Lambda| < NEAR_ORIGIN k``: :func:`det_M` takes the determinant with the partial-wave pairs
#: replaced by their divided differences (:func:`_det_near_origin`). There the columns of each
#: pair cancel (``det`` vanishes like ``Lambda^4``, removed by the normalisation) and ``k_s``,
#: ``k_d`` round towards ``k``: the plain double-precision value at ``Lambda = 1e-6`` stood out
#: from its neighbours by a factor of 2 to 9 at ``k = 100`` (``H = 0.1``), and the stability
#: map's counts failed there (session 12).
NEAR_ORIGIN = 1e-2


def _det_near_origin(L: np.ndarray, k: np.ndarray, ks: np.ndarray, kd: np.ndarray,  # noqa: N803
                     M: np.ndarray, p: Params) -> np.ndarray:
    """``row_normalised_det(M)`` next to the origin, without the cancellation (1-d arrays).

    At ``Lambda = 0`` the shear and dilatational waves of one end give the same displacement
    field (``curl(psi z) = i grad(phi)`` for equal potentials), so column 0 + column 1 (the
    waves from the bottom) and column 2 - column 3 (from the top) are ``O(Lambda^2)``.
    ``det M = Lambda^4 det M~`` with those two columns replaced by their sums divided by
    ``Lambda^2``, written out field by field (``u_x, u_y, s_xy, s_yy``) as ``(p - q) X(a) +
    q (X(a) - X(b))`` with ``p - q``, ``k_s - k = Lambda^2/(k_s + k)``, ``k_d - k = beta^2
    Lambda^2/(k_d + k)``, ``k_s - k_d = (1 - beta^2) Lambda^2/(k_s + k_d)`` in closed form and
    ``exp(-H a) - exp(-H b) = exp(-H b) expm1(-H (a - b))``: no difference of nearly equal
    numbers is left, and ``M~`` is well conditioned (its two new columns tend to the static
    solutions ``y exp(-+k y)``). Checked against the determinant in mpmath at 30-60 digits
    (tests/test_analytic_finite_h.py). Before session 13 this was that mpmath determinant,
    4.5 ms a point, a third of a 3 x 3 stability map's time on a 2-core AMD EPYC.
    """
    b2, H = p.beta**2, p.H  # noqa: N806
    L2 = L * L  # noqa: N806
    P = L2 + 2.0 * k * k  # noqa: N806
    es, ed = np.exp(-H * ks), np.exp(-H * kd)
    s_k, d_k = 1.0 / (ks + k), b2 / (kd + k)  # (k_s - k), (k_d - k) over Lambda^2
    dsd = (1.0 - b2) * L2 / (ks + kd)  # k_s - k_d
    m_p, m_m = np.expm1(H * dsd) / L2, np.expm1(-H * dsd) / L2
    sxy0 = 1.0 - 2.0 * k * d_k  # (P - 2 k k_d) / Lambda^2
    syy0 = L2 * s_k * s_k  # (P - 2 k k_s) / Lambda^2
    # column 0 + column 1 over Lambda^2 (waves from the bottom): X = exp(-H kappa) at the
    # top, 1 at the bottom
    bottom = {"ux": (-s_k * ed + ks * es * m_p, -s_k + 0j),
              "uy": (1j * (-d_k * es + kd * ed * m_m), -1j * d_k),
              "sxy": (sxy0 * es + 2.0 * k * kd * ed * m_m, sxy0 + 0j),
              "syy": (1j * (syy0 * ed + 2.0 * k * ks * es * m_p), 1j * syy0)}
    # column 2 - column 3 over Lambda^2 (waves from the top): 1 at the top, exp(-H kappa) at
    # the bottom
    top = {"ux": (s_k + 0j, s_k * es + k * ed * m_m),
           "uy": (-1j * d_k, 1j * (-d_k * es + kd * ed * m_m)),
           "sxy": (sxy0 + 0j, sxy0 * es + 2.0 * k * kd * ed * m_m),
           "syy": (-1j * syy0, 1j * (-syy0 * es + P * ed * m_m))}
    a, b, c = (np.broadcast_to(x, L.shape) for x in FrictionLaw.from_params(p).row(L))
    Mt = np.array(M, dtype=complex)  # noqa: N806
    for col, f in ((0, bottom), (2, top)):
        Mt[:, 0, col] = f["ux" if p.bc == "velocity" else "sxy"][0]  # u_x or s_xy at the top
        Mt[:, 1, col] = f["syy"][0]  # s_yy at the top
        Mt[:, 2, col] = f["uy"][1]  # u_y at the bottom
        Mt[:, 3, col] = a * f["sxy"][1] + b * f["syy"][1] + c * f["ux"][1]  # friction
    norms = np.sqrt(np.add.reduce((M.conj() * M).real, axis=-1))
    return L2 * L2 * np.linalg.det(Mt) / np.multiply.reduce(norms, axis=-1)


def row_normalised_det(M: np.ndarray, Lambda: np.ndarray | complex | None = None,  # noqa: N803
                       order: int = 0) -> np.ndarray:
    """``det(M)`` over the product of its row norms (a relative residual, ``<= 1``).

    With ``Lambda``: times ``(|Lambda|/Lambda)^order``, the phase of ``det(M) / Lambda^order``
    (the even bases vanish like ``Lambda^order`` at 0; 1 there).
    """
    # the row norms as np.linalg.norm(M, axis=-1) computes them, without its per-call overhead
    norms = np.sqrt(np.add.reduce((M.conj() * M).real, axis=-1))
    out = np.linalg.det(M) / np.multiply.reduce(norms, axis=-1)
    if Lambda is None:
        return out
    L = np.broadcast_to(np.asarray(Lambda, dtype=complex), out.shape)  # noqa: N806
    with np.errstate(invalid="ignore", divide="ignore"):
        unit = np.where(L == 0, 1.0, np.abs(L) / np.where(L == 0, 1.0, L))
    return out * unit**order


def det_M_even(Lambda: np.ndarray | complex, k: np.ndarray | float, p: Params) -> np.ndarray:
    """``det(M_even) / Lambda^4`` up to a positive factor, from the even basis directly.

    Same zeros and phase (up to a constant) as :func:`det_M`; accurate for moderate ``H Re k``
    only (ill-conditioned when ``H |Re k_s - Re k_d|`` is large). A cross-check.
    """
    return row_normalised_det(matrix_M(Lambda, k, p, "even"), Lambda, SPURIOUS_ORDER_AT_ZERO)


def det_M_waves(Lambda: np.ndarray | complex, k: np.ndarray | float, p: Params) -> np.ndarray:
    """Row-normalised determinant in the paper's partial-wave basis (docs/design.md section 4).

    Same zeros as :func:`det_M`, but multi-valued across the cuts of ``k_s``, ``k_d`` (the
    imaginary axis beyond ``+-i k``): do not use it for argument-principle counts.
    """
    return row_normalised_det(matrix_M(Lambda, k, p, "waves"))


def _tanh(x: np.ndarray) -> np.ndarray:
    """Tanh for Re x >= 0 without overflow."""
    e2 = np.exp(-2.0 * x)
    return (1.0 - e2) / (1.0 + e2)


def G12(Lambda: np.ndarray | complex, k: np.ndarray | float, p: Params
        ) -> tuple[np.ndarray, np.ndarray]:
    """The paper's ``G_1``, ``G_2`` (Eq. pert_elastodynamics_auxiliary), velocity top.

    ``s_xy = -k_d G_1 u_x`` and ``s_yy = i k G_2 u_x`` at ``y = 0`` (Eq. pert_elastodynamics).
    """
    H = _finite_h(p)
    L = np.asarray(Lambda, dtype=complex)
    k = np.asarray(k, dtype=float)
    ks, kd = wavenumbers(L, k, p.beta)
    coth_d = 1.0 / _tanh(H * kd)
    tanh_s = _tanh(H * ks)
    G1 = coth_d * L * L / (kd * ks * coth_d * tanh_s - k * k)
    G2 = 2.0 - G1 / coth_d
    return G1, G2


def spectrum_S(Lambda: np.ndarray | complex, k: np.ndarray | float, p: Params) -> np.ndarray:
    """The paper's closed form ``S(Lambda, k, H)`` (Eq. Hspectrum_dimensionless), ``mu = 1``.

    ``S = k_d G_1 - i k f G_2 + Lambda (Lambda + Delta) / (gamma (Lambda + 1))`` for the
    velocity top. The generalized friction law (docs/design.md section 3) is included:
    ``(1 + alpha_pc Lambda) k_d G_1 - i k (f - alpha_ld Lambda/(Lambda+1)) G_2 + ...``.
    Meromorphic: poles at ``Lambda = -1`` and where the denominator of ``G_1`` vanishes.

    Raises:
        ParameterError: If ``p.bc`` is not ``"velocity"`` (no closed form is given for
            ``"stress"``; use :func:`det_M`).
    """
    if p.bc != "velocity":
        raise ParameterError(f"bc = {p.bc!r}: the closed form S is for bc = 'velocity' only")
    L = np.asarray(Lambda, dtype=complex)
    k = np.asarray(k, dtype=float)
    _, kd = wavenumbers(L, k, p.beta)
    G1, G2 = G12(L, k, p)
    law = FrictionLaw.from_params(p)
    return law.shear(L) * kd * G1 - 1j * k * law.normal(L) * G2 + law.slip(L)


def cutoff(n: int, sign: int, p: Params) -> complex:
    """Waveguide cut-off ``Lambda_0 = sign * i (2n+1) pi / (2 beta H)`` (Eq. waveguide_cutoff).

    The limit ``k -> 0`` of the branch ``n`` (``sign = +1`` or ``-1``). It is the same for both
    top conditions: at ``k = 0`` the dilatational part decouples (``u_y(0) = 0``,
    ``s_yy(H) = 0``: a quarter-wave resonance, ``cosh(beta Lambda H) = 0``) whether ``u_x`` or
    ``s_xy`` is imposed on top; ``det M(k=0)`` factorises as ``cosh(beta Lambda H)`` times a
    shear/friction factor (see tests).

    Raises:
        ParameterError: On ``n < 0`` or ``sign`` not +-1.
    """
    if int(n) != n or n < 0:
        raise ParameterError(f"n = {n!r} is outside its allowed range n >= 0 (integer)")
    if sign not in (1, -1):
        raise ParameterError(f"sign = {sign!r} must be +1 or -1")
    H = _finite_h(p)
    require_rigid(p, "analytic.physics.finite_h.cutoff")
    return complex(0.0, sign * (2 * n + 1) * math.pi / (2.0 * p.beta * H))
