"""Flow conditions: standard atmosphere, isentropic relations, Sutherland viscosity."""
from __future__ import annotations

import math

import pytest
from conftest import assert_matches_richardson, richardson_derivative
from hypate.solvers.errors import InputError
from hypate.solvers.flow import (
    FlowCondition,
    sutherland_viscosity,
    sutherland_viscosity_derivative,
)


# Acceptance values of issue 2 (1976 standard atmosphere, geometric altitude), tolerance 0.1 %.
@pytest.mark.parametrize("altitude, p, T", [(20000.0, 5529.3, 216.65),
                                            (25000.0, 2549.2, 221.55),
                                            (30000.0, 1197.0, 226.51)])
def test_standard_atmosphere(altitude: float, p: float, T: float) -> None:
    f = FlowCondition.from_altitude(6.0, altitude)
    assert f.pressure == pytest.approx(p, rel=1e-3)
    assert f.temperature == pytest.approx(T, rel=1e-3)
    assert f.density == pytest.approx(p / (287.05 * T), rel=2e-3)


@pytest.mark.parametrize("mach, p0, T0", [(5.0, 2.0e6, 1300.0), (6.0, 8.27e6, 1800.0),
                                          (7.0, 2.96e6, 2500.0), (1.5, 2.0e5, 300.0)])
def test_isentropic_round_trip(mach: float, p0: float, T0: float) -> None:
    f = FlowCondition.from_stagnation(mach, p0, T0)
    g = FlowCondition.from_static(mach, f.pressure, f.temperature)
    # round trip (M, p0, T0) -> (p, T) -> (p0, T0): only rounding error, 1e-10 relative
    assert g.stagnation_pressure == pytest.approx(p0, rel=1e-10)
    assert g.stagnation_temperature == pytest.approx(T0, rel=1e-10)


def test_derived_quantities_closed_forms() -> None:
    f = FlowCondition.from_static(6.0, 2549.22, 221.552)
    assert f.cp == pytest.approx(1.4 * 287.05 / 0.4, rel=1e-14)
    assert f.speed_of_sound == pytest.approx(math.sqrt(1.4 * 287.05 * 221.552), rel=1e-14)
    # q = gamma p M^2 / 2 for a perfect gas
    assert f.dynamic_pressure == pytest.approx(0.5 * 1.4 * 2549.22 * 36.0, rel=1e-12)
    assert f.stagnation_temperature == pytest.approx(221.552 * 8.2, rel=1e-14)
    assert f.reynolds(2.0) == pytest.approx(2.0 * f.reynolds_per_meter, rel=1e-14)


def test_sutherland_matches_ambiance_and_derivative() -> None:
    from ambiance import Atmosphere

    atm = Atmosphere(25000.0)
    # ambiance uses the same Sutherland constants (ICAO): agreement to rounding
    assert float(sutherland_viscosity(atm.temperature[0])) == pytest.approx(
        float(atm.dynamic_viscosity[0]), rel=1e-6)
    fd, bound = richardson_derivative(lambda t: sutherland_viscosity(600.0 + t), 2e-3)
    # tolerance: the extrapolated difference's own measured error (~1e-12 relative here)
    assert_matches_richardson(sutherland_viscosity_derivative(600.0), fd, bound, "dmu/dT")


@pytest.mark.parametrize("kwargs, field", [
    (dict(mach=0.5, altitude=1000.0), "mach"),
    (dict(mach=1.0, altitude=1000.0), "mach"),
    (dict(mach=6.0, altitude=-6000.0), "altitude"),
    (dict(mach=6.0, altitude=90000.0), "altitude"),
])
def test_altitude_errors(kwargs: dict, field: str) -> None:
    with pytest.raises(InputError) as exc:
        FlowCondition.from_altitude(**kwargs)
    assert exc.value.field == field


@pytest.mark.parametrize("p0, T0, field", [(0.0, 1000.0, "p0"), (-1.0, 1000.0, "p0"),
                                           (1e6, 0.0, "T0"), (1e6, float("nan"), "T0")])
def test_stagnation_errors(p0: float, T0: float, field: str) -> None:
    with pytest.raises(InputError) as exc:
        FlowCondition.from_stagnation(6.0, p0, T0)
    assert exc.value.field == field
