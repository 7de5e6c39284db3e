"""Physical units in and out (docs/design.md section 2).

Standard rate-and-state friction with the aging law::

    f(v, phi) = f* + a ln(v / v*) + b ln(v* phi / D),      d phi/dt = 1 - v phi / D

so ``g(x) = 1 - x``, ``|g'(1)| = 1``, the steady state is ``phi0 = D / v0`` and, at ``v0``:

- direct effect ``d_v f = a / v0``;
- steady-state slope ``d_v f_ss = (a - b) / v0``;
- ``Delta = d_v f_ss / d_v f = (a - b) / a`` (velocity strengthening: ``b < a``, ``Delta > 0``);
- ``gamma = mu / (c_s sigma0 d_v f) = mu v0 / (c_s sigma0 a)``;
- ``beta = c_s / c_d = sqrt((1 - 2 nu) / (2 (1 - nu)))`` (plane strain, Eq. beta);
- ``f`` is the steady-state friction coefficient at ``v0`` (``tau0 = f sigma0``).

Units of the dimensionless problem: time ``t0 = D / v0`` [s], length ``l0 = c_s t0`` [m],
``c_s = sqrt(mu / rho)``. Back: growth rate ``Re Lambda / t0`` [1/s], angular frequency
``Im Lambda / t0`` [rad/s], wavelength ``2 pi l0 / k`` [m], phase velocity ``c_s Im Lambda / k``
[m/s] (positive: the pattern ``exp(Lambda t - i k x)`` moves towards ``+x``, the sliding
direction), height ``H = H_m / l0``.

Two bodies: a :class:`Substrate` (shear modulus, Poisson ratio, density, height [m],
bottom condition) gives ``mu2 = mu_sub / mu``, ``rho2 = rho_sub / rho``,
``beta2 = beta(nu_sub)``, ``H2 = H_sub / l0``; the units stay those of body 1 (the slider).
Worked examples (literature values, rounded; marked as such below): :data:`PMMA_ON_STEEL`,
:data:`PMMA_ON_POLYCARBONATE`, :data:`HOMALITE_ON_POLYCARBONATE`.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from analytic.params import ParameterError, Params


def _positive(name: str, value: float, unit: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} = {value!r} is not a number") from None
    if not (math.isfinite(v) and v > 0):
        raise ParameterError(f"{name} = {value!r} is outside its allowed range {name} > 0 [{unit}]")
    return v


@dataclass(frozen=True)
class Physical:
    """Physical data of the sliding body and the interface (SI units), validated.

    Attributes:
        mu: Shear modulus [Pa], ``> 0``.
        nu: Poisson ratio, ``0 < nu < 1/2`` (so that ``0 < beta < 1/sqrt 2``).
        rho: Mass density [kg/m^3], ``> 0``.
        sigma0: Applied compressive normal stress [Pa], ``> 0``.
        v0: Steady sliding velocity [m/s], ``> 0``.
        D: Memory length of the state variable [m], ``> 0``.
        f: Steady-state friction coefficient at ``v0``, ``>= 0``.
        a: Direct effect ``d f / d ln v``, ``> 0``.
        b: State effect ``d f / d ln phi`` (any finite value; usually ``> 0``).
        H: Height of the sliding body [m], ``> 0`` (``math.inf``: half-space).
    """

    mu: float
    nu: float
    rho: float
    sigma0: float
    v0: float
    D: float
    f: float
    a: float
    b: float
    H: float = math.inf

    def __post_init__(self) -> None:
        for name, unit in (("mu", "Pa"), ("rho", "kg/m^3"), ("sigma0", "Pa"), ("v0", "m/s"),
                           ("D", "m"), ("a", "-")):
            object.__setattr__(self, name, _positive(name, getattr(self, name), unit))
        try:
            nu = float(self.nu)
        except (TypeError, ValueError):
            raise ParameterError(f"nu = {self.nu!r} is not a number") from None
        if not (math.isfinite(nu) and 0.0 < nu < 0.5):
            raise ParameterError(f"nu = {self.nu!r} is outside its allowed range 0 < nu < 1/2")
        object.__setattr__(self, "nu", nu)
        for name in ("f", "b"):
            try:
                v = float(getattr(self, name))
            except (TypeError, ValueError):
                raise ParameterError(f"{name} = {getattr(self, name)!r} is not a number") from None
            if not math.isfinite(v):
                raise ParameterError(f"{name} = {v!r} must be a finite number")
            object.__setattr__(self, name, v)
        if self.f < 0:
            raise ParameterError(f"f = {self.f!r} is outside its allowed range f >= 0")
        h = float(self.H)
        if math.isnan(h) or h <= 0:
            raise ParameterError(f"H = {self.H!r} is outside its allowed range H > 0 [m]")
        object.__setattr__(self, "H", h)

    def as_dict(self) -> dict[str, float]:
        """Plain dict, for JSON output."""
        return asdict(self)


@dataclass(frozen=True)
class Substrate:
    """Physical data of the substrate (body 2, below the interface), validated.

    Attributes:
        mu: Shear modulus [Pa], ``> 0``.
        nu: Poisson ratio, ``0 < nu < 1/2``.
        rho: Mass density [kg/m^3], ``> 0``.
        H: Height [m], ``> 0`` (``math.inf``: half-space).
        bc: Bottom condition, ``"velocity"`` or ``"stress"``.
    """

    mu: float
    nu: float
    rho: float
    H: float = math.inf
    bc: str = "velocity"

    def __post_init__(self) -> None:
        object.__setattr__(self, "mu", _positive("substrate mu", self.mu, "Pa"))
        object.__setattr__(self, "rho", _positive("substrate rho", self.rho, "kg/m^3"))
        try:
            nu = float(self.nu)
        except (TypeError, ValueError):
            raise ParameterError(f"substrate nu = {self.nu!r} is not a number") from None
        if not (math.isfinite(nu) and 0.0 < nu < 0.5):
            raise ParameterError(f"substrate nu = {self.nu!r} is outside its allowed range "
                                 "0 < nu < 1/2")
        object.__setattr__(self, "nu", nu)
        h = float(self.H)
        if math.isnan(h) or h <= 0:
            raise ParameterError(f"substrate H = {self.H!r} is outside its allowed range "
                                 "H > 0 [m]")
        object.__setattr__(self, "H", h)

    @property
    def c_s(self) -> float:
        """Shear wave speed [m/s]."""
        return math.sqrt(self.mu / self.rho)

    def as_dict(self) -> dict[str, float | str]:
        """Plain dict, for JSON output."""
        return asdict(self)


def beta_from_nu(nu: float) -> float:
    """Plane-strain ``beta = c_s/c_d = sqrt((1 - 2 nu) / (2 (1 - nu)))`` (Eq. beta)."""
    return math.sqrt((1.0 - 2.0 * nu) / (2.0 * (1.0 - nu)))


def nu_from_beta(beta: float) -> float:
    """Inverse of :func:`beta_from_nu`: ``nu = (1 - 2 beta^2) / (2 (1 - beta^2))``."""
    return (1.0 - 2.0 * beta**2) / (2.0 * (1.0 - beta**2))


@dataclass(frozen=True)
class Conversion:
    """Dimensionless parameters of a physical case, with its units and the way back.

    Attributes:
        params: The dimensionless :class:`~analytic.params.Params`.
        t0: Time unit ``D / v0`` [s].
        length: Length unit ``c_s t0`` [m].
        c_s: Shear wave speed [m/s].
        c_d: Dilatational wave speed [m/s].
    """

    params: Params
    t0: float
    length: float
    c_s: float
    c_d: float

    def growth_rate(self, Lambda: complex | np.ndarray) -> np.ndarray:
        """``Re Lambda / t0`` [1/s]."""
        return np.real(Lambda) / self.t0

    def angular_frequency(self, Lambda: complex | np.ndarray) -> np.ndarray:
        """``Im Lambda / t0`` [rad/s]."""
        return np.imag(Lambda) / self.t0

    def wavelength(self, k: float | np.ndarray) -> np.ndarray:
        """``2 pi length / k`` [m]."""
        return 2.0 * math.pi * self.length / np.asarray(k, dtype=float)

    def k_from_wavelength(self, wavelength_m: float | np.ndarray) -> np.ndarray:
        """Dimensionless ``k`` of a wavelength in metres."""
        return 2.0 * math.pi * self.length / np.asarray(wavelength_m, dtype=float)

    def phase_velocity(self, Lambda: complex | np.ndarray, k: float | np.ndarray) -> np.ndarray:
        """``c_s Im Lambda / k`` [m/s] (positive: towards the sliding direction ``+x``)."""
        return self.c_s * np.imag(Lambda) / np.asarray(k, dtype=float)

    def height(self, H: float) -> float:
        """Dimensionless height back to metres."""
        return H * self.length


def to_dimensionless(phys: Physical, *, bc: str = "velocity",
                     substrate: Substrate | None = None) -> Conversion:
    """Convert physical data to ``(f, beta, gamma, Delta, H)`` and the units ``t0``, ``c_s t0``.

    Args:
        phys: Validated physical data.
        bc: Top condition of the resulting :class:`~analytic.params.Params`.
        substrate: The deformable substrate (None: rigid, ``mu2 = inf``); gives ``mu2, rho2,
            beta2, H2, bc2`` relative to body 1.

    Returns:
        A :class:`Conversion`.

    Raises:
        ParameterError: If the result is outside the dimensionless ranges.
    """
    c_s = math.sqrt(phys.mu / phys.rho)
    beta = beta_from_nu(phys.nu)
    t0 = phys.D / phys.v0
    length = c_s * t0
    gamma = phys.mu * phys.v0 / (c_s * phys.sigma0 * phys.a)
    Delta = (phys.a - phys.b) / phys.a
    H = phys.H / length if math.isfinite(phys.H) else math.inf
    params = Params(f=phys.f, gamma=gamma, beta=beta, Delta=Delta, H=H, bc=bc)
    if substrate is not None:
        params = params.replace(
            mu2=substrate.mu / phys.mu, rho2=substrate.rho / phys.rho,
            beta2=beta_from_nu(substrate.nu),
            H2=substrate.H / length if math.isfinite(substrate.H) else math.inf,
            bc2=substrate.bc)
    return Conversion(params=params, t0=t0, length=length, c_s=c_s, c_d=c_s / beta)


def to_physical(params: Params, *, mu: float, rho: float, sigma0: float, v0: float,
                D: float) -> Physical:
    """The way back: physical data reproducing ``params`` for given ``mu, rho, sigma0, v0, D``.

    ``nu`` from ``beta``, ``a = mu v0 / (c_s sigma0 gamma)``, ``b = a (1 - Delta)``,
    ``H = params.H c_s D / v0``.
    """
    c_s = math.sqrt(_positive("mu", mu, "Pa") / _positive("rho", rho, "kg/m^3"))
    a = mu * v0 / (c_s * _positive("sigma0", sigma0, "Pa") * params.gamma)
    length = c_s * _positive("D", D, "m") / _positive("v0", v0, "m/s")
    return Physical(mu=mu, nu=nu_from_beta(params.beta), rho=rho, sigma0=sigma0, v0=v0, D=D,
                    f=params.f, a=a, b=a * (1.0 - params.Delta), H=params.H * length)


PMMA_ON_STEEL = Physical(
    mu=1170.0 * 1345.0**2,  # rho c_s^2 ~ 2.1 GPa (PMMA, c_s = 1345 m/s)
    nu=0.33,
    rho=1170.0,
    sigma0=1.0e6,  # assumed: 1 MPa nominal pressure
    v0=1.0e-3,  # assumed: 1 mm/s
    D=0.5e-6,  # order of magnitude for PMMA multicontact interfaces
    f=0.5,
    a=0.010,
    b=0.007,  # assumed: velocity strengthening at v0 (Delta = 0.3)
    H=0.05,  # a 5 cm tall block
)
"""Worked example of the README (PMMA block on a much stiffer steel/glass substrate).

Sources and assumptions are listed in the README (section "physical units")."""


# Literature values (rounded, for worked examples; check the sources before quantitative use):
# PMMA c_s = 1345 m/s, rho = 1170 kg/m^3, nu = 0.33 (as above); polycarbonate and Homalite-100
# as used in the bimaterial laboratory-earthquake experiments of Xia, Rosakis, Kanamori & Rice
# (Science 2005): polycarbonate c_s ~ 960 m/s, rho ~ 1200 kg/m^3, nu ~ 0.38; Homalite-100
# c_s ~ 1255 m/s, rho ~ 1230 kg/m^3, nu ~ 0.35; steel mu ~ 80 GPa, rho ~ 7850 kg/m^3, nu ~ 0.29
# (handbook values). Interface data (sigma0, v0, D, f, a, b) as in PMMA_ON_STEEL (assumed).
POLYCARBONATE = Substrate(mu=1200.0 * 960.0**2, nu=0.38, rho=1200.0, H=0.05)
"""Polycarbonate substrate, 5 cm thick (literature values, rounded; see above)."""

STEEL = Substrate(mu=80.0e9, nu=0.29, rho=7850.0, H=0.05)
"""Steel substrate, 5 cm thick (handbook values, rounded)."""

HOMALITE_100 = Physical(
    mu=1230.0 * 1255.0**2, nu=0.35, rho=1230.0, sigma0=PMMA_ON_STEEL.sigma0, v0=PMMA_ON_STEEL.v0,
    D=PMMA_ON_STEEL.D, f=PMMA_ON_STEEL.f, a=PMMA_ON_STEEL.a, b=PMMA_ON_STEEL.b,
    H=PMMA_ON_STEEL.H)
"""A Homalite-100 slider with the interface data of :data:`PMMA_ON_STEEL` (assumed)."""

PMMA_ON_POLYCARBONATE = (PMMA_ON_STEEL, POLYCARBONATE)
"""(slider, substrate): PMMA on polycarbonate (``mu2 ~ 0.52``, the substrate is slower)."""

HOMALITE_ON_POLYCARBONATE = (HOMALITE_100, POLYCARBONATE)
"""(slider, substrate): Homalite-100 on polycarbonate (``c_s2/c_s1 ~ 0.76``)."""

PMMA_ON_STEEL_DEFORMABLE = (PMMA_ON_STEEL, STEEL)
"""(slider, substrate): PMMA on a deformable steel substrate (``mu2 ~ 38``: near rigid)."""
