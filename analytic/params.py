"""Dimensionless parameters of the problem and their validation (docs/design.md section 2).

Units: ``c_s = mu = rho = 1`` of body 1 (the slider); time unit ``t0 = D / (|g'(1)| v0)``;
length unit ``c_s t0``. Every part of the project (analytic roots, finite elements, workflows)
takes a :class:`Params`.

Two bodies: the substrate ``-H2 < y < 0`` has shear modulus ``mu2`` and density
``rho2`` relative to body 1 (so ``c_s2 = sqrt(mu2/rho2)``), its own ``beta2 = c_s2/c_d2``
(``None``: equal to ``beta``), height ``H2`` (``inf``: half-space) and bottom condition ``bc2``
(``"velocity"``: ``u_x = 0, s_yy = 0``; ``"stress"``: ``s_xy = s_yy = 0``). The default
``mu2 = inf`` is the rigid substrate of the paper; then ``rho2, beta2, H2, bc2`` are ignored.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

import numpy as np

BETA_MAX = 1.0 / math.sqrt(2.0)
BOUNDARY_CONDITIONS = ("velocity", "stress")


class ParameterError(ValueError):
    """A user-supplied parameter is outside its allowed range (one line, names the parameter)."""


def _finite(name: str, value: float) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} = {value!r} is not a number") from None
    if not math.isfinite(v):
        raise ParameterError(f"{name} = {value!r} must be a finite number")
    return v


def _beta(name: str, value: float, meaning: str) -> float:
    """A wave-speed ratio ``c_s/c_d`` of one body: finite, ``0 < value < 1/sqrt(2)``."""
    v = _finite(name, value)
    if not 0.0 < v < BETA_MAX:
        raise ParameterError(
            f"{name} = {value!r} is outside its allowed range 0 < {name} < 1/sqrt(2)"
            f" = {BETA_MAX:.6f} ({name} = {meaning})"
        )
    return v


def _boundary_condition(name: str, value: str) -> None:
    """An outer boundary condition: one of :data:`BOUNDARY_CONDITIONS`."""
    if value not in BOUNDARY_CONDITIONS:
        raise ParameterError(f"{name} = {value!r} is not one of {', '.join(BOUNDARY_CONDITIONS)}")


def _positive_or_inf(name: str, value: float) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} = {value!r} is not a number") from None
    if math.isnan(v) or v <= 0:
        raise ParameterError(f"{name} = {value!r} is outside its allowed range {name} > 0"
                             " (inf allowed)")
    return v


@dataclass(frozen=True)
class Material:
    """An isotropic elastic material in body-1 units (``mu = rho = c_s = 1`` for body 1).

    Attributes:
        mu: Shear modulus.
        rho: Density.
        beta: ``c_s / c_d``.
    """

    mu: float
    rho: float
    beta: float

    @property
    def c_s(self) -> float:
        """Shear wave speed ``sqrt(mu / rho)``."""
        return math.sqrt(self.mu / self.rho)

    @property
    def c_d(self) -> float:
        """Dilatational wave speed ``c_s / beta``."""
        return self.c_s / self.beta

    @property
    def lame_lambda(self) -> float:
        """First Lame parameter ``mu (1/beta^2 - 2)``."""
        return self.mu * (1.0 / self.beta**2 - 2.0)


@dataclass(frozen=True)
class Params:
    """Dimensionless parameters; defaults are the paper's (f=0.3, gamma=3, beta=0.5, Delta=0.7).

    Attributes:
        f: Steady-state friction coefficient, ``f >= 0``.
        gamma: ``mu / (c_s sigma0 d_v f)`` (radiation damping over direct effect), ``> 0``.
        beta: ``c_s / c_d``, ``0 < beta < 1/sqrt(2)`` (Poisson ratio ``0 <= nu < 1/2``).
        Delta: Steady-state over direct velocity dependence of friction (any finite real;
            ``Delta < 0`` is steady-state velocity weakening).
        H: Strip height in units of ``c_s t0``, ``> 0``; ``math.inf`` means a half-space.
        bc: Top condition, ``"velocity"`` (``du_x = 0``) or ``"stress"`` (``dsigma_xy = 0``);
            ``dsigma_yy = 0`` in both cases.
        alpha_pc: Prakash-Clifton regularisation, ``>= 0`` (0: standard model).
        alpha_ld: Linker-Dieterich coefficient, ``>= 0`` (0: standard model).
        mu2: Substrate shear modulus over body 1's, ``> 0``; ``math.inf`` (default): rigid.
        rho2: Substrate density over body 1's, ``> 0`` (finite).
        beta2: Substrate ``c_s2/c_d2`` in ``(0, 1/sqrt(2))``; ``None`` (default): equal to
            ``beta`` (see :attr:`substrate_beta`).
        H2: Substrate height, ``> 0``; ``math.inf`` (default): half-space.
        bc2: Bottom condition at ``y = -H2``: ``"velocity"`` (``u_x = 0``) or ``"stress"``
            (``s_xy = 0``); ``s_yy = 0`` in both cases.
    """

    f: float = 0.3
    gamma: float = 3.0
    beta: float = 0.5
    Delta: float = 0.7
    H: float = 0.5
    bc: str = "velocity"
    alpha_pc: float = 0.0
    alpha_ld: float = 0.0
    mu2: float = math.inf
    rho2: float = 1.0
    beta2: float | None = None
    H2: float = math.inf
    bc2: str = "velocity"

    def __post_init__(self) -> None:
        f = _finite("f", self.f)
        if f < 0:
            raise ParameterError(f"f = {self.f!r} is outside its allowed range f >= 0")
        gamma = _finite("gamma", self.gamma)
        if gamma <= 0:
            raise ParameterError(f"gamma = {self.gamma!r} is outside its allowed range gamma > 0")
        beta = _beta("beta", self.beta, "c_s/c_d")
        delta = _finite("Delta", self.Delta)
        try:
            h = float(self.H)
        except (TypeError, ValueError):
            raise ParameterError(f"H = {self.H!r} is not a number") from None
        if math.isnan(h) or h <= 0:
            raise ParameterError(f"H = {self.H!r} is outside its allowed range H > 0")
        _boundary_condition("bc", self.bc)
        apc = _finite("alpha_pc", self.alpha_pc)
        ald = _finite("alpha_ld", self.alpha_ld)
        if apc < 0:
            raise ParameterError(f"alpha_pc = {self.alpha_pc!r} is outside its allowed range >= 0")
        if ald < 0:
            raise ParameterError(f"alpha_ld = {self.alpha_ld!r} is outside its allowed range >= 0")
        mu2 = _positive_or_inf("mu2", self.mu2)
        rho2 = _finite("rho2", self.rho2)
        if rho2 <= 0:
            raise ParameterError(f"rho2 = {self.rho2!r} is outside its allowed range rho2 > 0")
        beta2 = None if self.beta2 is None else _beta("beta2", self.beta2, "c_s2/c_d2")
        h2 = _positive_or_inf("H2", self.H2)
        _boundary_condition("bc2", self.bc2)
        for name, value in (("f", f), ("gamma", gamma), ("beta", beta), ("Delta", delta),
                            ("H", h), ("alpha_pc", apc), ("alpha_ld", ald), ("mu2", mu2),
                            ("rho2", rho2), ("beta2", beta2), ("H2", h2)):
            object.__setattr__(self, name, value)

    @property
    def lame_lambda(self) -> float:
        """First Lame parameter in units of mu: ``1/beta**2 - 2``."""
        return 1.0 / self.beta**2 - 2.0

    @property
    def Gamma(self) -> float:  # noqa: N802 - the paper's name
        """``Gamma = gamma * f``, the abscissa of the paper's phase diagram."""
        return self.gamma * self.f

    @property
    def generalized(self) -> bool:
        """True when a generalized friction model (``alpha_pc`` or ``alpha_ld`` > 0) is used."""
        return self.alpha_pc > 0 or self.alpha_ld > 0

    @property
    def two_body(self) -> bool:
        """True for a deformable substrate (finite ``mu2``); False: the rigid substrate."""
        return math.isfinite(self.mu2)

    @property
    def substrate_beta(self) -> float:
        """The substrate's ``beta2``, with ``None`` resolved to ``beta``."""
        return self.beta if self.beta2 is None else self.beta2

    @property
    def substrate(self) -> Material:
        """The substrate's material in body-1 units (meaningful when :attr:`two_body`)."""
        return Material(mu=self.mu2, rho=self.rho2, beta=self.substrate_beta)

    @property
    def slider(self) -> Material:
        """Body 1's material: ``mu = rho = 1``, ``beta``."""
        return Material(mu=1.0, rho=1.0, beta=self.beta)

    def replace(self, **changes: float | str) -> Params:
        """Return a copy with some fields changed (validated again)."""
        return replace(self, **changes)

    def as_dict(self) -> dict[str, float | str]:
        """Plain dict, for JSON output."""
        return asdict(self)


def require_rigid(p: Params, what: str) -> None:
    """Raise :class:`ParameterError` if ``p`` has a deformable substrate (finite ``mu2``).

    For the parts of the project that model the rigid substrate only (``what`` names them).
    """
    if p.two_body:
        raise ParameterError(f"mu2 = {p.mu2!r}: {what} is for the rigid substrate (mu2 = inf) "
                             "only; two bodies: analytic.physics.twobody / "
                             "analytic.numerics.branches")


def check_k(k: float | np.ndarray, name: str = "k") -> np.ndarray:
    """Validate wavenumbers: finite and ``> 0``.

    Args:
        k: A wavenumber or an array of them.
        name: Name used in the error message.

    Returns:
        ``k`` as a 1D float array.

    Raises:
        ParameterError: If any value is NaN, infinite or ``<= 0``.
    """
    arr = np.atleast_1d(np.asarray(k, dtype=float))
    if arr.size == 0:
        raise ParameterError(f"{name}: no wavenumbers given")
    bad = ~np.isfinite(arr) | (arr <= 0)
    if bad.any():
        raise ParameterError(
            f"{name} = {arr[bad][0]!r} is outside its allowed range {name} > 0 (finite)"
        )
    return arr
