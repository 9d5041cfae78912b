"""Free-stream flow conditions: flight (1976 standard atmosphere) or wind tunnel.

A :class:`FlowCondition` is built from (Mach, geometric altitude) through the 1976 U.S.
standard atmosphere (``ambiance``; identical to ICAO 1993 below 32 km), from tunnel
stagnation conditions (Mach, p0, T0) through the isentropic perfect-gas relations, or
from static (Mach, p, T). Calorically perfect air: gamma = 1.4, R = 287.05 J/(kg K),
Sutherland viscosity (mu_ref 1.458e-6 kg/(m s K^0.5), S = 110.4 K), Pr = 0.72.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from ambiance import Atmosphere
from hypate.solvers.errors import InputError
from numpy.typing import ArrayLike, NDArray

GAMMA = 1.4
GAS_CONSTANT = 287.05
PRANDTL = 0.72
SUTHERLAND_BETA = 1.458e-6
SUTHERLAND_S = 110.4
#: Geometric altitudes covered by the standard-atmosphere table (m).
ALTITUDE_RANGE = (-5000.0, 80000.0)


def sutherland_viscosity(T: ArrayLike) -> NDArray[np.float64]:
    """Dynamic viscosity of air (Pa s), Sutherland's law (complex input allowed for
    complex-step derivatives)."""
    T = np.asarray(T)
    T = T if np.iscomplexobj(T) else T.astype(float)
    return SUTHERLAND_BETA * T**1.5 / (T + SUTHERLAND_S)


def sutherland_viscosity_derivative(T: ArrayLike) -> NDArray[np.float64]:
    """d(mu)/dT of :func:`sutherland_viscosity`."""
    T = np.asarray(T, dtype=float)
    return sutherland_viscosity(T) * (1.5 / T - 1.0 / (T + SUTHERLAND_S))


def _stagnation_ratio(mach: float, gamma: float) -> float:
    """T0/T = 1 + (gamma - 1)/2 M^2 (isentropic)."""
    return 1.0 + 0.5 * (gamma - 1.0) * mach * mach


def _check_mach(mach: float) -> float:
    mach = float(mach)
    if not (math.isfinite(mach) and mach > 1.0):
        raise InputError("mach", f"must be > 1 (supersonic/hypersonic flow); got {mach:g}")
    return mach


def _check_positive(name: str, value: float, unit: str) -> float:
    value = float(value)
    if not (math.isfinite(value) and value > 0.0):
        raise InputError(name, f"must be a positive number ({unit}); got {value:g}")
    return value


@dataclass(frozen=True)
class FlowCondition:
    """Free-stream state of a calorically perfect gas (SI units).

    Build with :meth:`from_altitude`, :meth:`from_stagnation` or :meth:`from_static`.
    """

    mach: float
    pressure: float
    temperature: float
    gamma: float = GAMMA
    gas_constant: float = GAS_CONSTANT
    prandtl: float = PRANDTL
    altitude: float | None = None

    # -- constructors -----------------------------------------------------------------
    @classmethod
    def from_static(cls, mach: float, pressure: float, temperature: float) -> FlowCondition:
        """From free-stream Mach number, static pressure (Pa) and temperature (K)."""
        return cls(mach=_check_mach(mach),
                   pressure=_check_positive("pressure", pressure, "Pa"),
                   temperature=_check_positive("temperature", temperature, "K"))

    @classmethod
    def from_altitude(cls, mach: float, altitude: float) -> FlowCondition:
        """Flight at geometric altitude (m), 1976 standard atmosphere."""

        mach = _check_mach(mach)
        altitude = float(altitude)
        lo, hi = ALTITUDE_RANGE
        if not (math.isfinite(altitude) and lo <= altitude <= hi):
            raise InputError("altitude", f"must be within the standard-atmosphere table "
                             f"[{lo:g}, {hi:g}] m (geometric); got {altitude:g}")
        atm = Atmosphere(altitude)
        return cls(mach=mach, pressure=float(atm.pressure[0]),
                   temperature=float(atm.temperature[0]), altitude=altitude)

    @classmethod
    def from_stagnation(cls, mach: float, p0: float, T0: float) -> FlowCondition:
        """Tunnel: Mach number and reservoir (stagnation) pressure p0 (Pa), temperature T0 (K),
        through the isentropic perfect-gas relations."""
        mach = _check_mach(mach)
        p0 = _check_positive("p0", p0, "Pa")
        T0 = _check_positive("T0", T0, "K")
        ratio = _stagnation_ratio(mach, GAMMA)
        T = T0 / ratio
        p = p0 * ratio ** (-GAMMA / (GAMMA - 1.0))
        return cls(mach=mach, pressure=p, temperature=T)

    # -- derived quantities ------------------------------------------------------------
    @property
    def cp(self) -> float:
        """Specific heat at constant pressure, J/(kg K)."""
        return self.gamma * self.gas_constant / (self.gamma - 1.0)

    @property
    def density(self) -> float:
        return self.pressure / (self.gas_constant * self.temperature)

    @property
    def speed_of_sound(self) -> float:
        return math.sqrt(self.gamma * self.gas_constant * self.temperature)

    @property
    def velocity(self) -> float:
        return self.mach * self.speed_of_sound

    @property
    def dynamic_pressure(self) -> float:
        """q = rho V^2 / 2 = gamma p M^2 / 2, Pa."""
        return 0.5 * self.density * self.velocity**2

    @property
    def viscosity(self) -> float:
        return float(sutherland_viscosity(self.temperature))

    @property
    def reynolds_per_meter(self) -> float:
        return self.density * self.velocity / self.viscosity

    @property
    def stagnation_temperature(self) -> float:
        return self.temperature * _stagnation_ratio(self.mach, self.gamma)

    @property
    def stagnation_pressure(self) -> float:
        ratio = _stagnation_ratio(self.mach, self.gamma)
        return self.pressure * ratio ** (self.gamma / (self.gamma - 1.0))

    def reynolds(self, length: float) -> float:
        """Reynolds number based on ``length`` (m)."""
        return self.reynolds_per_meter * length

    def to_dict(self) -> dict[str, float]:
        """The public JSON fields of ``hypate condition --json``."""
        return {name: float(getattr(self, name)) for name in PUBLIC_FIELDS}

    def as_record(self) -> dict[str, float | None]:
        """All stored fields (for saving a condition)."""
        return asdict(self)


#: JSON fields of ``hypate condition --json`` (public contract).
PUBLIC_FIELDS = ("mach", "pressure", "temperature", "density", "velocity", "speed_of_sound",
                 "dynamic_pressure", "viscosity", "reynolds_per_meter", "stagnation_pressure",
                 "stagnation_temperature")
