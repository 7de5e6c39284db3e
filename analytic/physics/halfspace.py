"""Half-space (``kH -> infinity``) spectrum ``s(z, q) = 0`` and its roots (paper section 5, App. C).

Variables (docs/design.md section 2: in code units ``k`` is the paper's ``q`` and ``Lambda`` its
``lambda``): ``z = -Lambda / (i q)``, i.e. ``Lambda = -i q z``; ``Re Lambda = q Im z``, so a root
with ``Im z > 0`` is unstable.

Sheets. ``s`` contains ``A = sqrt(1 - z^2)`` (``k_s = q A``) and ``B = sqrt(1 - beta^2 z^2)``
(``k_d = q B``). The *physical sheet* takes both principal roots (``Re A, Re B >= 0``: both
partial waves decay into the solid); its cuts are the real intervals ``|z| > 1`` and
``|z| > 1/beta``. :func:`s_tilde` is the paper's Appendix C companion: ``A -> -A`` (a shear
wave that grows away from the interface), ``B`` principal. Everything is evaluated by one
function, :func:`spectrum`, which takes ``A`` and ``B`` explicitly.

Branch points as variables. The dilatational family sits next to the branch point
``z = 1/beta``, which also lies on the cut of ``A``. There we use ``kappa_d = B`` as the unknown
(Eq. kappa_d: ``z = sqrt(1 - kappa_d^2)/beta``) and two functions analytic in the disc
``|kappa_d| < sqrt(1 - beta^2)``:

- ``branch="unstable"``: ``A = -i w``, ``w = sqrt(1 - beta^2 - kappa_d^2)/beta``. This is the
  physical sheet for ``Re kappa_d > 0, Im kappa_d < 0`` (``Im z > 0``) and ``s~`` for
  ``Re kappa_d > 0, Im kappa_d > 0`` (``Im z < 0``).
- ``branch="stable"``: ``A = +i w``. Physical for ``Im kappa_d > 0`` (``Im z < 0``), ``s~`` for
  ``Im kappa_d < 0``.

``Re kappa_d < 0`` is the sheet with a growing dilatational wave (neither ``s`` nor ``s~``).
A root of one of these functions is continuous in ``q``; it is a root of ``s`` or of ``s~``
according to where it is, which is how the gaps of the paper's Fig. comparison / Fig. gaps
close into continuous curves. The shear family, next to ``z = -1``, uses
``kappa_s = A`` (``z = -sqrt(1 - kappa_s^2)``; ``B`` is analytic there): physical for
``Re kappa_s > 0``. The quasi-static family (``|z| << 1``, ``q >> 1``, Rice et al. 2001) is
solved in ``z`` itself, where ``s`` is analytic.

Every root carries its sheet (``"physical"``, ``"s_tilde"`` or ``"unphysical"``), the
residual of the function it solves and of ``s``/``s~`` at the same ``z``.
"""

from __future__ import annotations

import cmath
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from analytic.law import FrictionLaw
from analytic.numerics.continuation import Path, Trial, march
from analytic.numerics.maximise import maximise
from analytic.numerics.roots import Root, count_zeros, polish
from analytic.params import ParameterError, Params, require_rigid

FAMILIES = ("dilatational", "shear", "quasistatic")
DILATATIONAL_BRANCHES = ("unstable", "stable")
Number = complex | np.ndarray


def _sqrt(x: Number) -> Number:
    """Principal square root; ``cmath`` for scalars (fast in Newton loops), numpy for arrays."""
    if isinstance(x, np.ndarray):
        return np.sqrt(x.astype(complex))
    return cmath.sqrt(x)


def _elementwise(fun: Callable[[complex], complex]) -> Callable[[np.ndarray], np.ndarray]:
    """Vectorise a scalar function for :mod:`analytic.numerics.roots`.

    :mod:`analytic.numerics.roots` calls with 1- or 4-point arrays, where a Python loop over
    ``cmath``
    scalars is several times faster than numpy.
    """
    def vec(x: np.ndarray) -> np.ndarray:
        return np.array([fun(complex(v)) for v in np.ravel(x)], dtype=complex).reshape(
            np.shape(x))
    return vec


def _c(x: complex | float | np.ndarray) -> Number:
    """Complex scalar or complex array (no 0-d arrays)."""
    if isinstance(x, np.ndarray) and x.ndim > 0:
        return x.astype(complex)
    return complex(x)


# --------------------------------------------------------------------------------------------
# The spectrum on any sheet
# --------------------------------------------------------------------------------------------
def kappa_s(z: complex | np.ndarray) -> complex | np.ndarray:
    """Principal ``sqrt(1 - z^2)`` (``k_s / q``; cut on real ``|z| > 1``)."""
    z = _c(z)
    return _sqrt(1.0 - z * z)


def kappa_d(z: complex | np.ndarray, beta: float) -> complex | np.ndarray:
    """Principal ``sqrt(1 - beta^2 z^2)`` (``k_d / q``; cut on real ``|z| > 1/beta``)."""
    z = _c(z)
    return _sqrt(1.0 - beta * beta * z * z)


def g1(z: complex | np.ndarray, beta: float, A: complex | np.ndarray,  # noqa: N803
       B: complex | np.ndarray) -> complex | np.ndarray:  # noqa: N803
    """Eq. (g12_dimless) ``g1 = z^2 / (1 - A B)`` for given square-root values ``A, B``.

    Written without cancellation as ``(1 + A B) / (1 + beta^2 - beta^2 z^2)`` (multiply by
    ``1 + A B`` and use ``A^2 = 1 - z^2``, ``B^2 = 1 - beta^2 z^2``), finite at ``z = 0``.
    With ``A -> -A`` this is ``-g~1`` of Eq. (g12_dimless_gap).
    """
    return (1.0 + A * B) / (1.0 + beta * beta * (1.0 - z * z))


def spectrum(z: complex | np.ndarray, q: float, p: Params, A: complex | np.ndarray,  # noqa: N803
             B: complex | np.ndarray) -> complex | np.ndarray:  # noqa: N803
    """Eq. (spectrum_dimless_generalized) with the square roots ``A, B`` given explicitly.

    ``gamma (1 - i q z) [B g1 (1 - i alpha_pc q z) - i f g2] + gamma q alpha_ld g2 z
    - i z (Delta - i q z)``, ``g2 = 2 - g1``. Reduces to Eq. (spectrum_dimless) for
    ``alpha_pc = alpha_ld = 0``. ``A = kappa_s(z), B = kappa_d(z)`` gives :func:`s`,
    ``A = -kappa_s(z)`` gives :func:`s_tilde`.
    """
    require_rigid(p, "analytic.physics.halfspace")
    z = _c(z)
    gg1 = g1(z, p.beta, A, B)
    gg2 = 2.0 - gg1
    # the friction law cleared of L + 1 at L = -i q z: gamma (a B g1 - i b g2) - gamma c / q,
    # with -gamma c / q = L (L + Delta) / q = -i z (L + Delta) (finite at q = 0)
    law = FrictionLaw.from_params(p)
    L = -1j * q * z  # noqa: N806
    a, b, _ = law.cleared(L)
    return p.gamma * (a * B * gg1 - 1j * b * gg2) - 1j * z * (L + law.Delta)


def s(z: complex | np.ndarray, q: float, p: Params) -> complex | np.ndarray:
    """The half-space spectrum on the physical sheet (Eqs. spectrum_dimless(_generalized))."""
    return spectrum(z, q, p, kappa_s(z), kappa_d(z, p.beta))


def s_tilde(z: complex | np.ndarray, q: float, p: Params) -> complex | np.ndarray:
    """Appendix C companion ``s~`` (Eq. spectrum_dimless_gap): growing shear wave, ``A -> -A``.

    For ``alpha_pc, alpha_ld > 0`` the same substitution is applied to the generalized
    spectrum (the paper writes ``s~`` only for the standard model).
    """
    return spectrum(z, q, p, -kappa_s(z), kappa_d(z, p.beta))


# --------------------------------------------------------------------------------------------
# Branch-point variables
# --------------------------------------------------------------------------------------------
def z_from_kappa_d(kap: complex | np.ndarray, beta: float) -> complex | np.ndarray:
    """Eq. (kappa_d): ``z = sqrt(1 - kappa_d^2) / beta`` (``Re z > 0`` branch)."""
    kap = _c(kap)
    return _sqrt(1.0 - kap * kap) / beta


def z_from_kappa_s(kap: complex | np.ndarray) -> complex | np.ndarray:
    """``z = -sqrt(1 - kappa_s^2)`` (the shear family, near ``z = -1``)."""
    kap = _c(kap)
    return -_sqrt(1.0 - kap * kap)


def _branch_sign(branch: str) -> float:
    if branch not in DILATATIONAL_BRANCHES:
        raise ParameterError(
            f"branch = {branch!r} is not one of {', '.join(DILATATIONAL_BRANCHES)}")
    return 1.0 if branch == "unstable" else -1.0


def s_dilatational(kap: complex | np.ndarray, q: float, p: Params,
                   branch: str = "unstable") -> complex | np.ndarray:
    """The spectrum as an analytic function of ``kappa_d`` near ``z = 1/beta``.

    ``B = kappa_d``, ``z = sqrt(1 - kappa_d^2)/beta`` and ``A = -/+ i sqrt(1 - beta^2 -
    kappa_d^2)/beta`` for ``branch = "unstable"/"stable"`` (the paper's ``g^_{1+}``/``g^_{1-}``
    of Eq. g12_dimless1, kept exact). Analytic for ``|kappa_d| < sqrt(1 - beta^2)``.
    """
    sign = _branch_sign(branch)
    kap = _c(kap)
    z = z_from_kappa_d(kap, p.beta)
    w = _sqrt(1.0 - p.beta**2 - kap * kap) / p.beta
    return spectrum(z, q, p, -1j * sign * w, kap)


def s_shear(kap: complex | np.ndarray, q: float, p: Params) -> complex | np.ndarray:
    """The spectrum as an analytic function of ``kappa_s`` near ``z = -1``.

    ``A = kappa_s``, ``z = -sqrt(1 - kappa_s^2)``, ``B = sqrt(1 - beta^2 + beta^2 kappa_s^2)``
    (principal, analytic for ``|kappa_s| < sqrt(1 - beta^2)/beta``).
    """
    kap = _c(kap)
    z = z_from_kappa_s(kap)
    B = _sqrt(1.0 - p.beta**2 + p.beta**2 * kap * kap)  # noqa: N806
    return spectrum(z, q, p, kap, B)


# --------------------------------------------------------------------------------------------
# Roots
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class HalfSpaceRoot:
    """One root of the half-space spectrum at wavenumber ``q``.

    Attributes:
        q: Wavenumber (code ``k``).
        z: ``-Lambda/(i q)``.
        Lambda: Growth rate ``-i q z`` (``Re > 0``: unstable).
        family: ``"dilatational"``, ``"shear"`` or ``"quasistatic"``.
        branch: For the dilatational family the ``kappa_d`` function used (``"unstable"`` /
            ``"stable"``), else ``""``.
        kappa: The unknown actually solved for (``kappa_d``, ``kappa_s`` or ``z``).
        sheet: ``"physical"`` (a root of ``s``), ``"s_tilde"`` (a root of ``s~``) or
            ``"unphysical"`` (growing dilatational wave).
        residual: ``|F(kappa)|`` of the function solved, relative to the size of its terms.
        residual_s: ``|s(z)|`` (physical sheet) or ``|s~(z)|`` (``s_tilde`` sheet) at ``z``,
            NaN on the unphysical sheet.
        cond: Condition estimate of the root (from :func:`analytic.numerics.roots.polish`).
        converged: Newton converged.
        reason: Why it stopped.
        ks: ``k_s / q`` used at the root (``A``; principal on the physical sheet).
        kd: ``k_d / q`` used at the root (``B``).
    """

    q: float
    z: complex
    Lambda: complex
    family: str
    branch: str
    kappa: complex
    sheet: str
    residual: float
    residual_s: float
    cond: float
    converged: bool
    reason: str
    ks: complex = complex("nan")
    kd: complex = complex("nan")

    @property
    def decay_length_s(self) -> float:
        """``1 / Re k_s``: e-folding depth of the shear partial wave into the solid.

        ``inf`` if it does not decay; negative if it grows (the ``s~`` sheet).
        """
        re = self.q * self.ks.real
        return math.inf if re == 0 else 1.0 / re

    @property
    def decay_length_d(self) -> float:
        """``1 / Re k_d``: e-folding depth of the dilatational partial wave into the solid.

        Diverges at the dilatational threshold, where ``kappa_d -> 0``.
        """
        re = self.q * self.kd.real
        return math.inf if re == 0 else 1.0 / re

    @property
    def growth(self) -> float:
        """``Re Lambda = q Im z``."""
        return float(self.Lambda.real)

    @property
    def physical(self) -> bool:
        """True for a root of ``s`` on the physical sheet."""
        return self.sheet == "physical"


def _scale(q: float, p: Params, z: complex) -> float:
    """Size of the terms of ``s`` at ``z`` (for relative residuals)."""
    az = abs(z)
    return (p.gamma * (1 + q * az) * (1 + p.f + p.alpha_pc * q * az)
            + p.gamma * q * p.alpha_ld * az + az * (abs(p.Delta) + q * az) + 1.0)


def _make_root(q: float, p: Params, family: str, branch: str, r: Root, A: complex,  # noqa: N803
               B: complex, z: complex) -> HalfSpaceRoot:  # noqa: N803
    a0 = complex(kappa_s(z))
    sheet = ("physical" if abs(A - a0) <= abs(A + a0) else "s_tilde") if B.real >= 0 else \
        "unphysical"
    if sheet == "physical":
        res_s = abs(complex(s(z, q, p)))
    elif sheet == "s_tilde":
        res_s = abs(complex(s_tilde(z, q, p)))
    else:
        res_s = math.nan
    scale = _scale(q, p, z)
    return HalfSpaceRoot(q=float(q), z=complex(z), Lambda=complex(-1j * q * z), family=family,
                         branch=branch, kappa=complex(r.value), sheet=sheet,
                         residual=float(r.residual) / scale, residual_s=res_s / scale,
                         cond=float(r.cond), converged=bool(r.converged), reason=str(r.reason),
                         ks=complex(A), kd=complex(B))


def dilatational_root(q: float, p: Params, *, branch: str = "unstable",
                      guess: complex | None = None, tol: float = 1e-14) -> HalfSpaceRoot:
    """Root of :func:`s_dilatational` (unknown ``kappa_d``) at ``q``.

    Args:
        q: Wavenumber ``> 0``.
        p: Parameters (``H`` is ignored).
        branch: ``"unstable"`` or ``"stable"`` function of ``kappa_d`` (module docstring).
        guess: Starting ``kappa_d``; default ``0`` (the branch point itself: the first Newton
            step is then the paper's linearisation, Eq. kappa_d1/kappa_d2).
        tol: Newton tolerance.
    """
    sign = _branch_sign(branch)
    r = polish(_elementwise(lambda x: s_dilatational(x, q, p, branch)),
               0j if guess is None else guess, tol=tol)
    kap = complex(r.value)
    z = complex(z_from_kappa_d(kap, p.beta))
    w = cmath.sqrt(1.0 - p.beta**2 - kap * kap) / p.beta
    return _make_root(q, p, "dilatational", branch, r, -1j * sign * w, kap, z)


def shear_root(q: float, p: Params, *, guess: complex | None = None,
               tol: float = 1e-14) -> HalfSpaceRoot:
    """Root of :func:`s_shear` (unknown ``kappa_s``) at ``q``; default guess ``0`` (``z = -1``)."""
    r = polish(_elementwise(lambda x: s_shear(x, q, p)), 0j if guess is None else guess,
               tol=tol)
    kap = complex(r.value)
    z = complex(z_from_kappa_s(kap))
    B = cmath.sqrt(1.0 - p.beta**2 + p.beta**2 * kap * kap)  # noqa: N806
    return _make_root(q, p, "shear", "", r, kap, B, z)


def quasistatic_lambda(q: float, p: Params) -> np.ndarray:
    """Both roots ``lambda`` of the quasi-static limit (``c_s, c_d -> infinity``, section 5.3).

    With ``g1 -> 2/(1+beta^2)``, ``g2 -> 2 beta^2/(1+beta^2)`` (the paper's
    ``4(1-nu)/(3-4nu)``, ``2(1-2nu)/(3-4nu)``) and ``z = i lambda / q -> 0``, ``s = 0`` becomes
    ``lambda^2 + (Delta + a) lambda + a = 0`` with ``a = q gamma (g1 - i f g2)``
    (standard model).
    """
    b2 = p.beta**2
    a = q * p.gamma * (2.0 / (1 + b2) - 1j * p.f * 2 * b2 / (1 + b2))
    return np.roots([1.0, p.Delta + a, a])


def quasistatic_root(q: float, p: Params, *, guess: complex | None = None,
                     tol: float = 1e-14) -> HalfSpaceRoot:
    """Root of :func:`s` in ``z`` near ``z = 0`` (quasi-static family).

    Default guess: the quasi-static root with the larger ``Re lambda``
    (:func:`quasistatic_lambda`), ``z = i lambda / q``.
    """
    if guess is None:
        lam = quasistatic_lambda(q, p)
        lam0 = lam[np.argmax(lam.real)]
        guess = 1j * lam0 / q
    r = polish(_elementwise(lambda x: s(x, q, p)), complex(guess), tol=tol)
    z = complex(r.value)
    return _make_root(q, p, "quasistatic", "", r, complex(kappa_s(z)),
                      complex(kappa_d(z, p.beta)), z)


def find_root(family: str, q: float, p: Params, *, branch: str = "unstable",
              guess: complex | None = None) -> HalfSpaceRoot:
    """Dispatch to :func:`dilatational_root`, :func:`shear_root` or :func:`quasistatic_root`."""
    if family == "dilatational":
        return dilatational_root(q, p, branch=branch, guess=guess)
    if family == "shear":
        return shear_root(q, p, guess=guess)
    if family == "quasistatic":
        return quasistatic_root(q, p, guess=guess)
    raise ParameterError(f"family = {family!r} is not one of {', '.join(FAMILIES)}")


def follow(family: str, qs: Sequence[float] | np.ndarray, p: Params, *,
           branch: str = "unstable", guess: complex | None = None, max_halvings: int = 12,
           max_jump: float = 0.2) -> list[HalfSpaceRoot]:
    """Continue one root in ``q`` (natural continuation with step halving).

    The first ``q`` starts from ``guess`` (default: the family's default guess). Each next
    ``q`` starts from the previous root; if Newton fails or the unknown jumps by more than
    ``max_jump`` (relative to ``1 + |unknown|``), the step is halved (at most ``max_halvings``
    times); a root that still fails is returned with ``converged = False`` and its reason.

    Args:
        family: ``"dilatational"``, ``"shear"`` or ``"quasistatic"``.
        qs: Increasing or decreasing wavenumbers ``> 0``.
        p: Parameters.
        branch: Dilatational ``kappa_d`` function.
        guess: Starting unknown at ``qs[0]``.
        max_halvings: Step-halving depth.
        max_jump: Largest accepted change of the unknown per (sub)step.

    Returns:
        One :class:`HalfSpaceRoot` per ``q``.
    """
    qs = np.asarray(qs, dtype=float)
    first = find_root(family, float(qs[0]), p, branch=branch, guess=guess)
    stepper = _HalfSpaceStepper(family, p, branch, max_jump)
    run = march(stepper, Path([first.q], [first.kappa]), qs[1:], max_halvings=max_halvings)
    return [first] + [t.result for t in run.trials if t is not None]


@dataclass
class _HalfSpaceStepper:
    """:func:`follow` on the continuation engine: natural continuation, bounded jumps.

    Each step starts Newton from the previous unknown (order-0 predictor) and is accepted when
    it converged and moved by at most ``max_jump (1 + |unknown|)``; the engine halves a
    refused step, and a root still refused after the last halving is kept as it is.
    """

    family: str
    p: Params
    branch: str
    max_jump: float

    def attempt(self, path: Path, k_new: float) -> Trial[HalfSpaceRoot]:
        """Newton from the previous unknown, jump bounded."""
        x_cur = path.predict(k_new, order=0)
        r = find_root(self.family, k_new, self.p, branch=self.branch, guess=x_cur)
        ok = r.converged and abs(r.kappa - x_cur) <= self.max_jump * (1 + abs(x_cur))
        return Trial(k_new, r.kappa, ok, r)

    def rescue(self, path: Path, trial: Trial[HalfSpaceRoot], k_target: float
               ) -> Trial[HalfSpaceRoot]:
        """No further halving: the refused root stands for the target (``converged`` says)."""
        trial.closes_target = True
        return trial

    def next_step(self, path: Path, h: float, trial: Trial[HalfSpaceRoot], clamped: bool,
                  dk: float) -> float:
        """After any accepted step, straight on to the target."""
        return math.inf


def dilatational_tracks(qs: np.ndarray, p: Params) -> dict[str, list[HalfSpaceRoot]]:
    """Both ``kappa_d`` roots continued over ``qs`` (:func:`follow`, dilatational family).

    Args:
        qs: Wavenumbers (monotone).
        p: Parameters.

    Returns:
        ``{"unstable": roots, "stable": roots}``, one root per ``q`` for each function.
    """
    return {b: follow("dilatational", qs, p, branch=b) for b in ("unstable", "stable")}


def physical_curve(roots: list[HalfSpaceRoot], attr: Callable[[HalfSpaceRoot], float],
                   sheet: str = "physical") -> np.ndarray:
    """``attr(root)`` where the root is converged and on ``sheet``, NaN elsewhere (gaps show).

    Args:
        roots: A track (e.g. of :func:`dilatational_tracks`).
        attr: Quantity of a root, e.g. ``lambda r: r.growth``.
        sheet: ``"physical"`` (``s``) or ``"s_tilde"``.

    Returns:
        One value per root.
    """
    return np.array([attr(r) if (r.converged and r.sheet == sheet) else np.nan for r in roots])


def count_roots(q: float, p: Params, box: tuple[float, float, float, float], *,
                sheet: str = "physical") -> int:
    """Argument-principle count of the roots of ``s`` (or ``s~``) inside a box of the ``z``-plane.

    The box must avoid the cuts (the real axis outside ``(-1, 1)``), e.g. a box in the upper
    half-plane ``im_min > 0``: the count is then a checked statement ("all unstable roots with
    ``Im z >= im_min`` in this box"), not a hope.

    Args:
        q: Wavenumber.
        p: Parameters.
        box: ``(re_min, re_max, im_min, im_max)`` in ``z``.
        sheet: ``"physical"`` (``s``) or ``"s_tilde"``.

    Raises:
        ParameterError: If the box crosses a cut.
    """
    re0, re1, im0, im1 = box
    if not (re0 < re1 and im0 < im1):
        raise ParameterError(f"box = {box!r} must have re_min < re_max and im_min < im_max")
    if im0 <= 0.0 <= im1 and (re0 < -1.0 or re1 > 1.0):
        raise ParameterError(f"box = {box!r} crosses a branch cut (real axis outside (-1, 1))")
    fun = s if sheet == "physical" else s_tilde
    return count_zeros(lambda z: fun(z, q, p), box)


# --------------------------------------------------------------------------------------------
# Largest growth rate over q, and thresholds located numerically
# --------------------------------------------------------------------------------------------
QS_MAX_ABS_Z = 0.5  # a "quasi-static" root has |z| = |Lambda| / (c_s q) well below 1
SHEAR_MAX_DIST = 0.25  # a "shear" root has |z + 1| below this (else it is no longer shear-like)


def default_qgrid(family: str, p: Params) -> np.ndarray:
    """Log-spaced ``q`` grid for :func:`max_growth`, scaled with ``gamma`` where it matters.

    - dilatational: ``1e-6 min(1, gamma) .. 1e3`` (10/decade): the unstable interval
      ``(0, q_c)`` shrinks to zero at threshold, and ``Re kappa_d ~ q / gamma``;
    - shear: ``1e-3 min(1, gamma) .. 1e3`` (20/decade): ``q_c^(s) = gamma sqrt(1-beta^2) /
      (1 - Gamma)`` is small for small ``gamma``;
    - quasi-static: ``1e-3 .. 1e5`` (10/decade): ``q_c^(qs) ~ f^2 beta^4 / gamma``.
    """
    g = min(1.0, p.gamma)
    if family == "dilatational":
        lo, hi, per = math.log10(1e-6 * g), 3.0, 10
    elif family == "shear":
        lo, hi, per = math.log10(1e-3 * g), 3.0, 20
    else:
        lo, hi, per = -3.0, 5.0, 10
    return np.logspace(lo, hi, int(round((hi - lo) * per)) + 1)


def unstable_margin(r: HalfSpaceRoot) -> float:
    """Signed margin, positive iff ``r`` is a physical *and* unstable root.

    Continuous along a continued root (unlike the growth rate masked by the sheet), so its
    maximum over ``q`` can be bracketed and refined even when the unstable ``q`` interval is
    tiny (near a threshold):

    - dilatational (``"unstable"`` function): ``min(Re kappa_d, -Im kappa_d)`` (physical needs
      ``Re kappa_d > 0``, unstable ``Im kappa_d < 0``);
    - shear: ``min(Re kappa_s, Im kappa_s)``, ``-inf`` if ``|z + 1| > SHEAR_MAX_DIST`` (at
      large ``q`` the continued shear root turns into the quasi-static one near ``z = 0``);
    - quasi-static: ``Im z`` (the root near ``z = 0`` is on the physical sheet); ``-inf`` if
      Newton left the neighbourhood ``|z| <= QS_MAX_ABS_Z``.

    A root that did not converge gets ``-inf``.
    """
    if not r.converged or not math.isfinite(abs(r.kappa)):
        return -math.inf
    if r.family == "dilatational":
        if not in_family(r):
            return -math.inf
        return min(r.kappa.real, -r.kappa.imag)
    if r.family == "shear":
        if abs(r.z + 1.0) > SHEAR_MAX_DIST:
            return -math.inf  # continued away from z = -1 (e.g. into the quasi-static root)
        return min(r.kappa.real, r.kappa.imag)
    if r.sheet != "physical" or abs(r.z) > QS_MAX_ABS_Z:
        return -math.inf  # not (or no longer) the slow quasi-static root
    return r.z.imag


def in_family(r: HalfSpaceRoot) -> bool:
    """Whether a converged root still belongs to its family (by location in the z-plane).

    dilatational: a root of the ``"unstable"`` ``kappa_d`` function inside its disc of
    analyticity ``|kappa_d| < sqrt(1 - beta^2)`` (Newton from far away can land on a root of
    the continued function elsewhere, e.g. near the imaginary ``z`` axis); shear:
    ``|z + 1| <= SHEAR_MAX_DIST``; quasi-static: ``|z| <= QS_MAX_ABS_Z``.
    """
    if not r.converged:
        return False
    if r.family == "shear":
        return abs(r.z + 1.0) <= SHEAR_MAX_DIST
    if r.family == "quasistatic":
        return abs(r.z) <= QS_MAX_ABS_Z
    beta = abs(cmath.sqrt(1.0 - r.kappa * r.kappa) / r.z)  # z = sqrt(1 - kappa^2) / beta
    return r.branch == "unstable" and abs(r.kappa) < math.sqrt(1.0 - beta * beta)


def family_room(r: HalfSpaceRoot) -> float:
    """Relative distance of a root from the edge of its family's region (1: centre, 0: edge)."""
    if r.family == "shear":
        return 1.0 - abs(r.z + 1.0) / SHEAR_MAX_DIST
    if r.family == "quasistatic":
        return 1.0 - abs(r.z) / QS_MAX_ABS_Z
    beta = abs(cmath.sqrt(1.0 - r.kappa * r.kappa) / r.z)
    return 1.0 - abs(r.kappa) / math.sqrt(1.0 - beta * beta)


def _family_growth(r: HalfSpaceRoot) -> float:
    return r.growth if (in_family(r) and r.physical) else -math.inf


@dataclass(frozen=True)
class MaxGrowth:
    """Largest growth of one family over ``q`` (from :func:`max_growth`).

    Attributes:
        family: Root family.
        unstable: A physical unstable root exists for some ``q`` (``margin > 0``).
        margin: Maximum over ``q`` of :func:`unstable_margin`.
        q_margin: Where it is attained.
        growth: Largest ``Re Lambda`` over the physical roots of the family (NaN if the family
            has no physical root on the grid).
        q_growth: Where it is attained.
        n_failed: Grid points where the root did not converge.
    """

    family: str
    unstable: bool
    margin: float
    q_margin: float
    growth: float
    q_growth: float
    n_failed: int
    root_margin: HalfSpaceRoot | None = None

    @property
    def interior(self) -> bool:
        """The maximising root is well inside its family's region (:func:`family_room` > 10 %).

        False means the margin is limited by the region's edge (``|z| = QS_MAX_ABS_Z`` or
        ``|z + 1| = SHEAR_MAX_DIST``), not by a change of stability: a threshold located there
        is an artefact of the family rule.
        """
        return self.root_margin is not None and family_room(self.root_margin) > 0.1


def _refine_max(fun: Callable[[float], float], qs: np.ndarray, i: int) -> tuple[float, float]:
    """Maximise ``fun`` in ``log q`` between the grid neighbours of index ``i`` (bounded Brent)."""
    lo = math.log(qs[max(i - 1, 0)])
    hi = math.log(qs[min(i + 1, len(qs) - 1)])
    if hi <= lo:
        return float(qs[i]), fun(float(qs[i]))
    t_best, v_best = maximise(lambda t: fun(math.exp(t)), lo, hi, xatol=1e-10 * (1.0 + abs(lo)))
    q_best = math.exp(t_best)
    v_i = fun(float(qs[i]))
    return (q_best, v_best) if v_best >= v_i else (float(qs[i]), v_i)


def max_growth(family: str, p: Params, qs: Sequence[float] | np.ndarray | None = None,
               *, refine: bool = True) -> MaxGrowth:
    """Largest growth rate of one family over ``q`` (physical roots only).

    The roots of the family are computed on a log-spaced ``q`` grid (:func:`default_qgrid`),
    by continuation and (shear, quasi-static) from the family's own starting point at each
    ``q``; then the maxima of :func:`unstable_margin` and of the growth rate (roots in the
    family, :func:`in_family`, on the physical sheet) are refined between grid neighbours
    with a bounded Brent search.

    Args:
        family: ``"dilatational"``, ``"shear"`` or ``"quasistatic"``.
        p: Parameters.
        qs: Increasing wavenumbers (default: :func:`default_qgrid`).
        refine: Refine the maxima (otherwise grid values).
    """
    if family not in FAMILIES:
        raise ParameterError(f"family = {family!r} is not one of {', '.join(FAMILIES)}")
    qs = default_qgrid(family, p) if qs is None else np.asarray(qs, dtype=float)
    # Tracks: the root continued in q and, for the shear and quasi-static families, the root
    # Newton finds at each q from the family's own starting point (branch point z = -1, resp.
    # the quasi-static root): continuation from small q need not follow the root that crosses
    # the branch point at q_c (seen for gamma << 1).
    tracks: list[tuple[list[HalfSpaceRoot], Callable[[float, int], HalfSpaceRoot]]] = []
    if family != "quasistatic":
        cont = follow(family, qs, p, branch="unstable")
        guesses = [r.kappa for r in cont]
        tracks.append((cont, lambda q, i: find_root(family, q, p, branch="unstable",
                                                     guess=guesses[i])))
    if family != "dilatational":
        fresh = [find_root(family, float(q), p) for q in qs]
        tracks.append((fresh, lambda q, i: find_root(family, q, p)))
    n_failed = min(sum(not r.converged for r in roots) for roots, _ in tracks)
    q_m, m, q_g, g = math.nan, -math.inf, math.nan, -math.inf
    r_m = None
    for roots, solve in tracks:
        q_t, m_t, q_gt, g_t, i_t = _track_maxima(roots, solve, qs, refine)
        if m_t > m:
            q_m, m = q_t, m_t
            r_m = solve(q_t, i_t) if math.isfinite(q_t) else None
        if g_t > g:
            q_g, g = q_gt, g_t
    if not math.isfinite(g):
        q_g, g = math.nan, math.nan
    return MaxGrowth(family=family, unstable=m > 0, margin=m, q_margin=q_m, growth=g,
                     q_growth=q_g, n_failed=n_failed, root_margin=r_m)


def _track_maxima(roots: list[HalfSpaceRoot], solve: Callable[[float, int], HalfSpaceRoot],
                  qs: np.ndarray, refine: bool) -> tuple[float, float, float, float, int]:
    """Maxima over ``q`` of the margin and of the physical growth along one track of roots."""
    margins = np.array([unstable_margin(r) for r in roots])
    growths = np.array([_family_growth(r) for r in roots])
    # Refine around every local maximum of the grid margin (the unstable interval near a
    # threshold is a narrow peak that need not be the largest grid value), keep the best.
    q_m, m, i_m = math.nan, -math.inf, 0
    last = len(qs) - 1
    peaks = [i for i in range(len(qs)) if np.isfinite(margins[i])
             and margins[i] >= margins[max(i - 1, 0)] and margins[i] >= margins[min(i + 1, last)]]
    peaks = sorted(peaks, key=lambda i: -margins[i])[:6]
    for i in peaks:
        if refine:
            q_i, m_i = _refine_max(lambda q, i=i: unstable_margin(solve(q, i)), qs, i)
        else:
            q_i, m_i = float(qs[i]), float(margins[i])
        if m_i > m:
            q_m, m, i_m = q_i, m_i, i
    q_g, g = math.nan, -math.inf
    if np.isfinite(growths).any():
        i_g = int(np.argmax(growths))
        q_g, g = float(qs[i_g]), float(growths[i_g])
        if refine:
            q_g, g = _refine_max(lambda q: _family_growth(solve(q, i_g)), qs, i_g)
    if m > 0 and g <= 0:  # the margin found an interval the growth grid missed
        q_g, g = q_m, solve(q_m, i_m).growth
    return q_m, m, q_g, g, i_m


def threshold_delta(family: str, gamma_f: float, f: float, beta: float,
                    bracket: tuple[float, float], *, xtol: float = 1e-10,
                    qs: Sequence[float] | np.ndarray | None = None,
                    alpha_pc: float = 0.0, alpha_ld: float = 0.0) -> float:
    """Stability boundary ``Delta(Gamma)`` of one family, located from the spectrum.

    Root of ``Delta -> max_q margin`` (:func:`max_growth`; its sign is the sign of the
    largest growth rate of the family) by Brent's method on ``bracket``; ``gamma = Gamma/f``.

    Returns:
        The threshold, or NaN unless the family is unstable at ``bracket[0]`` and stable at
        ``bracket[1]``. (Where the stable side has no root of the family at all, the margin
        is ``-inf``: plain bisection on the sign first, then Brent.)
    """
    from scipy.optimize import brentq

    gamma = gamma_f / f

    def margin(delta: float) -> float:
        p = Params(f=f, gamma=gamma, beta=beta, Delta=delta, H=math.inf, alpha_pc=alpha_pc,
                   alpha_ld=alpha_ld)
        return max_growth(family, p, qs).margin

    lo, hi = bracket
    m_lo, m_hi = margin(lo), margin(hi)
    if not m_lo > 0 or m_hi > 0 or math.isnan(m_hi):
        return math.nan
    for _ in range(60):  # bisect on the sign until the stable end has a finite margin
        if math.isfinite(m_hi):
            break
        mid = 0.5 * (lo + hi)
        m_mid = margin(mid)
        if m_mid > 0:
            lo, m_lo = mid, m_mid
        else:
            hi, m_hi = mid, m_mid
    if not math.isfinite(m_hi):
        return math.nan
    return float(brentq(margin, lo, hi, xtol=xtol, rtol=4 * np.finfo(float).eps))
