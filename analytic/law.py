"""The linearised friction law, written once (docs/design.md section 3).

In code units, with ``sxy``, ``syy`` the traction perturbations at ``y = 0`` and ``ux`` the
slip (slip velocity ``Lambda ux``), the law of the generalized model reads::

    (1 + alpha_pc L) sxy + (f - alpha_ld L/(L + 1)) syy - (1/gamma) L (L + Delta)/(L + 1) ux = 0

:class:`FrictionLaw` holds its parameters and gives it in the forms the code needs:

- the rational multipliers :meth:`~FrictionLaw.shear`, :meth:`~FrictionLaw.normal`,
  :meth:`~FrictionLaw.slip` (the closed forms ``S``, the small-``k`` expansion);
- the same multiplied by ``L + 1``: the polynomials :attr:`~FrictionLaw.rx`,
  :attr:`~FrictionLaw.ry`, :attr:`~FrictionLaw.ux` over :attr:`~FrictionLaw.den` (the
  finite-element row operation, ``forms.friction``), evaluated by :meth:`~FrictionLaw.row`
  (the exact determinant's friction row, which keeps the rational form's cancellation when
  ``alpha_ld = 0`` and ``Delta = 1``);
- the roots that clearing the denominator may add, :attr:`~FrictionLaw.spurious`.

:class:`ScalarFunction` is a scalar function ``num(L)/den(L)`` of an operator
``T(L) = sum_i phi_i(L) A_i`` (the powers ``L^j`` of a polynomial form, the ``1/(L + 1)`` of
a split form).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np

from analytic.params import Params

#: Ascending coefficients ``(c0, c1, ...)`` of ``c0 + c1 L + ...``.
Poly = tuple[float, ...]

_pv = np.polynomial.polynomial


def polymul(a: Poly, b: Poly) -> Poly:
    """Product of two polynomials with ascending coefficients."""
    return tuple(float(c) for c in _pv.polymul(a, b))


def shift(a: Poly, power: int) -> Poly:
    """``L**power * a(L)`` (ascending coefficients)."""
    return (0.0,) * power + tuple(a)


def degree(c: Poly) -> int:
    """Degree of a polynomial (index of its last nonzero coefficient; 0 for zero)."""
    nz = [i for i, v in enumerate(c) if v != 0.0]
    return nz[-1] if nz else 0


@dataclass(frozen=True)
class ScalarFunction:
    """``phi(L) = num(L)/den(L)``, ascending coefficients; ``den = (1.0,)`` for a polynomial.

    Attributes:
        num: Numerator coefficients.
        den: Denominator coefficients.
    """

    num: Poly
    den: Poly = (1.0,)

    @classmethod
    def power(cls, j: int) -> ScalarFunction:
        """``L**j``."""
        return cls(num=(0.0,) * j + (1.0,))

    @property
    def power_index(self) -> int | None:
        """``j`` when the function is ``L**j``, else None."""
        if self.den != (1.0,) or self.num[-1] != 1.0 or any(self.num[:-1]):
            return None
        return len(self.num) - 1

    def value_and_derivative(self, z: complex) -> tuple[complex, complex]:
        """``phi(z)`` and ``phi'(z)``."""
        j = self.power_index
        if j is not None:
            return z**j, (j * z ** (j - 1) if j > 0 else 0.0)
        num = np.asarray(self.num, dtype=complex)
        den = np.asarray(self.den, dtype=complex)
        n, d = _pv.polyval(z, num), _pv.polyval(z, den)
        dn, dd = _pv.polyval(z, _pv.polyder(num)), _pv.polyval(z, _pv.polyder(den))
        return n / d, (dn * d - n * dd) / (d * d)

    def __call__(self, z: complex) -> complex:
        """``phi(z)``."""
        j = self.power_index
        if j is not None:
            return complex(z) ** j
        return complex(_pv.polyval(z, self.num) / _pv.polyval(z, self.den))


@dataclass(frozen=True)
class FrictionLaw:
    """The linearised rate-and-state law of docs/design.md section 3 (code units).

    Attributes:
        f: Steady friction coefficient.
        gamma: Stiffness ratio ``gamma``.
        Delta: ``Delta = 1 - b/a`` (velocity dependence of steady friction).
        alpha_pc: Prakash-Clifton relaxation (0: none).
        alpha_ld: Linker-Dieterich normal-stress dependence of the state (0: none).
    """

    f: float
    gamma: float
    Delta: float
    alpha_pc: float = 0.0
    alpha_ld: float = 0.0
    den: Poly = field(default=(1.0, 1.0), init=False)

    @classmethod
    def from_params(cls, p: Params) -> FrictionLaw:
        """The law for parameters ``p`` (standard or generalized).

        Cached per value (the law is immutable): the scalar root finders build it at every
        evaluation, where a frozen dataclass's construction cost 30 % of a half-space
        ``spectrum`` call.
        """
        if cls is not FrictionLaw:
            return cls(f=p.f, gamma=p.gamma, Delta=p.Delta, alpha_pc=p.alpha_pc,
                       alpha_ld=p.alpha_ld)
        return _law_of(p.f, p.gamma, p.Delta, p.alpha_pc, p.alpha_ld)

    # ---- rational form ------------------------------------------------------------------
    def shear(self, L: np.ndarray | complex) -> np.ndarray | complex:  # noqa: N803
        """Multiplier of ``sxy``: ``1 + alpha_pc L``."""
        return 1.0 + self.alpha_pc * L

    def normal(self, L: np.ndarray | complex) -> np.ndarray | complex:  # noqa: N803
        """Multiplier of ``syy``: ``f - alpha_ld L/(L + 1)``."""
        return self.f - self.alpha_ld * L / (L + 1.0)

    def slip(self, L: np.ndarray | complex) -> np.ndarray | complex:  # noqa: N803
        """``sigma0 df / ux = L (L + Delta) / (gamma (L + 1))`` (enters the law with ``-``)."""
        return L * (L + self.Delta) / (self.gamma * (L + 1.0))

    # ---- polynomial form (multiplied by L + 1) ------------------------------------------
    @property
    def rx(self) -> Poly:
        """``(1 + alpha_pc L)(L + 1)``, the numerator of ``sxy``'s multiplier."""
        return polymul((1.0, self.alpha_pc), (1.0, 1.0))

    @property
    def ry(self) -> Poly:
        """``f (L + 1) - alpha_ld L``, the numerator of ``syy``'s multiplier."""
        return (self.f, self.f - self.alpha_ld)

    @property
    def ux(self) -> Poly:
        """``L (L + Delta)/gamma``, the numerator of the slip term (with sign ``-``)."""
        return (0.0, self.Delta / self.gamma, 1.0 / self.gamma)

    @property
    def spurious(self) -> tuple[complex, ...]:
        """Roots that clearing ``L + 1`` may add: ``-1`` and, if ``alpha_pc > 0``, ``-1/alpha_pc``.

        ``-1/alpha_pc`` is the Prakash-Clifton relaxation, whose denominator the form above
        has already cleared into ``1 + alpha_pc L``.
        """
        if self.alpha_pc > 0:
            return (-1.0 + 0j, -1.0 / self.alpha_pc + 0j)
        return (-1.0 + 0j,)

    @property
    def cancels(self) -> bool:
        """True when ``L + 1`` cancels from the rational form (``alpha_ld = 0``, ``Delta = 1``)."""
        return self.alpha_ld == 0 and self.Delta == 1.0

    def cleared(self, L: np.ndarray | complex) -> tuple:  # noqa: N803
        """``(a, b, c)`` of ``a sxy + b syy + c ux = 0``: the law multiplied by ``L + 1``.

        ``a = (1 + alpha_pc L)(L + 1)``, ``b = f (L + 1) - alpha_ld L``,
        ``c = -L (L + Delta)/gamma``: the values of :attr:`rx`, :attr:`ry`, ``-``:attr:`ux`.
        """
        return (self.shear(L) * (L + 1.0), self.f * (L + 1.0) - self.alpha_ld * L,
                -L * (L + self.Delta) / self.gamma)

    def row(self, L: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # noqa: N803
        """:meth:`cleared` on an array, except when ``L + 1`` cancels (:attr:`cancels`).

        Then the law is not multiplied by it (so no root at ``L = -1`` appears):
        ``(1 + alpha_pc L, f, -L/gamma)``.
        """
        L = np.asarray(L, dtype=complex)  # noqa: N806
        if self.cancels:
            return self.shear(L) * np.ones_like(L), self.f * np.ones_like(L), -L / self.gamma
        return self.cleared(L)

    def is_spurious(self, lam: complex, rtol: float = 1e-6) -> bool:
        """True if ``lam`` is within ``rtol * max(1, |s|)`` of a spurious root ``s``."""
        return any(abs(lam - s) <= rtol * max(1.0, abs(s)) for s in self.spurious)

    # ---- the interface row of a discrete model (forms.friction) --------------------------
    def x_row_numerators(self) -> dict[str, Poly]:
        """Numerator (in ``L``) multiplying each source row in a discrete model's interface row.

        The row reads ``(rx R_x + ry R_y + ux (B u)_x) / den = 0`` with the reactions
        ``R = K u + L^2 M u`` (``R_x = -sxy``, ``R_y = -syy``; docs/design.md section 5.3). Keys:
        ``"Kx"``, ``"Mx"`` (rows of ``K``, ``M`` at ``u_x``), ``"Ky"``, ``"My"`` (rows at
        ``u_y``), ``"Bx"`` (interface mass row at ``u_x``); ``M`` carries the ``L^2`` shift.
        """
        return {
            "Kx": self.rx,
            "Mx": shift(self.rx, 2),
            "Ky": self.ry,
            "My": shift(self.ry, 2),
            "Bx": self.ux,
        }

    @property
    def degree(self) -> int:
        """Degree in ``L`` of the discrete polynomial form (3, or 4 with ``alpha_pc > 0``)."""
        return max(2, max(degree(c) for c in self.x_row_numerators().values()))

    def polynomial_coefficients(self) -> dict[str, list[float]]:
        """Interface row: coefficient of each source in ``A_j`` (``j = 0..degree``)."""
        n = self.degree + 1
        return {key: _padded(c, n) for key, c in self.x_row_numerators().items()}

    def split_coefficients(self) -> tuple[dict[str, list[float]], dict[str, float]]:
        """Interface row in partial fractions: ``num/den = q(L) + r/den``.

        Returns:
            ``(poly, rational)``: ``poly[key][j]`` multiplies ``L^j`` (``j = 0..degree-1``),
            ``rational[key]`` multiplies ``1/den(L)``.
        """
        n = self.degree  # quotient degree <= degree - 1
        poly: dict[str, list[float]] = {}
        rational: dict[str, float] = {}
        for key, num in self.x_row_numerators().items():
            q, r = _pv.polydiv(np.asarray(num, float), np.asarray(self.den))
            poly[key] = _padded(tuple(q), n)
            rational[key] = float(r[0]) if len(r) else 0.0
        return poly, rational

    def multipliers(self, lam: complex) -> dict[str, complex]:
        """Rational values ``num(L)/den(L)`` per source row (checks against the traction law)."""
        d = _pv.polyval(lam, self.den)
        return {key: _pv.polyval(lam, num) / d for key, num in self.x_row_numerators().items()}


def _padded(c: Poly, n: int) -> list[float]:
    out = [0.0] * n
    for i, v in enumerate(c):
        if v != 0.0:
            if i >= n:
                raise ValueError("polynomial longer than the requested length")
            out[i] = float(v)
    return out


@functools.lru_cache(maxsize=256)
def _law_of(f: float, gamma: float, Delta: float, alpha_pc: float,  # noqa: N803
            alpha_ld: float) -> FrictionLaw:
    """The law of these values, built once (:meth:`FrictionLaw.from_params`)."""
    return FrictionLaw(f=f, gamma=gamma, Delta=Delta, alpha_pc=alpha_pc, alpha_ld=alpha_ld)
