"""Time-scheduled radiant heating (solvers/thermal/schedule.py) in the thermal march of the
coupled model (PanelModel.thermal_step, the call the TC scheme makes each step).

Oracles: the exact time mean of a piecewise-linear T^4 (Gauss-Legendre, exact for the
quartic on each segment); the energy balance of a slab with only radiation exchange
(stored heat = absorbed heater heat - emitted heat over the test); a lumped-capacitance
reference (a thin, highly conducting slab against the ODE rho c h dT/dt = eps sigma
(T_rad(t)^4 - T^4) solved to 1e-10); and a flat schedule equal, bit for bit, to the
constant heater.
"""
from __future__ import annotations

import numpy as np
import pytest
from hypate.solvers.aero.factory import make_fluid_model
from hypate.solvers.coupling.model import PanelModel
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition
from hypate.solvers.materials import STEFAN_BOLTZMANN, isotropic
from hypate.solvers.panel import Layer, PanelSpec
from hypate.solvers.settings import SimulationSettings
from hypate.solvers.thermal.schedule import HeaterSchedule
from scipy.integrate import solve_ivp

#: Heater control temperatures (K) at t / t_end = 0, 1/3, 2/3, 1: up, down, up again.
SCHEDULE = (300.0, 1500.0, 900.0, 1800.0)
EPS = 0.8
FLOW = FlowCondition.from_static(5.0, 100.0, 220.0)


def schedule_integral_T4(values, duration: float) -> float:
    """int_0^duration T_rad(t)^4 dt of the piecewise-linear schedule, by 3-point
    Gauss-Legendre on each segment (exact for a quartic): independent of the solver's
    interpolation."""
    x, w = np.polynomial.legendre.leggauss(3)
    seg = duration / (len(values) - 1)
    total = 0.0
    for a, b in zip(values[:-1], values[1:]):
        T = a + (b - a) * 0.5 * (x + 1.0)
        total += 0.5 * seg * float(w @ T**4)
    return total


def radiating_slab(thickness: float, conductivity: float, duration: float, steps: int,
                   **settings) -> PanelModel:
    """A single-layer slab, insulated below, exchanging heat with the surroundings only by
    radiation on top (no aerodynamic heating: the fluid model's heating is off)."""
    mat = isotropic("slab", 4500.0, 1.1e11, 0.3, 9e-6, conductivity, 550.0)
    panel = PanelSpec(layers=(Layer(mat, thickness, 0.0, 2),), mesh=(2, 2), length=0.2,
                      width=0.2, emissivity=EPS, initial_temperature=300.0)
    sim = SimulationSettings(time_step=duration / steps, duration=duration, **settings)
    return PanelModel(panel, FLOW, make_fluid_model("pt", "none"), sim)


def march(m: PanelModel, steps: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(times, nodal T per step, upper-surface mean T per step) of ``steps`` thermal steps."""
    dt = m.settings.time_step
    u = np.zeros(m.structure.n_dof)
    T = m.thermal.initial_state()
    Ts, top = [T], [m.thermal.surface_mean(T, "top")]
    for n in range(steps):
        T = m.thermal_step(T, u, dt, t=n * dt)
        Ts.append(T)
        top.append(m.thermal.surface_mean(T, "top"))
    return dt * np.arange(steps + 1), np.array(Ts), np.array(top)


def test_schedule_interpolates_and_its_mean_fourth_power_is_exact() -> None:
    h = HeaterSchedule(SCHEDULE, 90.0)
    np.testing.assert_allclose(h([0.0, 30.0, 45.0, 60.0, 90.0, 200.0]),
                               [300.0, 1500.0, 1200.0, 900.0, 1800.0, 1800.0], rtol=0, atol=0)
    assert isinstance(h(10.0), float)
    # Gauss-Legendre is exact for the quartic on each segment: equal to round-off
    assert h.mean_fourth_power() == pytest.approx(schedule_integral_T4(SCHEDULE, 90.0) / 90.0,
                                                  rel=1e-13)
    with pytest.raises(InputError, match="at least 2"):
        HeaterSchedule((900.0,), 90.0)
    with pytest.raises(InputError, match="> 0"):
        HeaterSchedule((900.0, -1.0), 90.0)
    with pytest.raises(InputError, match="both"):
        SimulationSettings(radiation_temperature=900.0, radiation_schedule=SCHEDULE)


def test_radiating_slab_stores_the_absorbed_minus_the_emitted_heat() -> None:
    # Energy balance over the test: rho c_p V dT = A eps sigma (T_rad(t)^4 - T_w(t)^4) dt.
    # Constant properties, so the stored heat 1^T C (T - T0) is exact; the top surface stays
    # uniform (uniform conditions), so the emitted heat is A eps sigma int T_w^4 dt with the
    # upper-surface mean T_w. Both sides' quadratures are second order in dt (Crank-Nicolson
    # collocates the loads at t_n + dt/2; the emitted integral below is the trapezoid rule):
    # measured relative differences 2.1e-5 at 120 steps and 5.3e-6 at 240 (ratio 4.0, second
    # order), so the tolerance 1e-4 at 120 steps. A heater held at T_rad(0) would store
    # nothing (-100 %) and loads collocated at t_n instead of t_n + dt/2 miss by 2.5e-2.
    duration, steps = 120.0, 120
    m = radiating_slab(0.003, 20.0, duration, steps, radiation_schedule=SCHEDULE)
    t, T, top = march(m, steps)
    area = m.panel.length * m.panel.width
    stored = m.thermal.stored_energy(T[-1])
    absorbed = area * EPS * STEFAN_BOLTZMANN * schedule_integral_T4(SCHEDULE, duration)
    emitted = area * EPS * STEFAN_BOLTZMANN * np.trapezoid(top**4, t)
    assert stored > 0.3 * absorbed  # the heater really heated the slab
    assert stored == pytest.approx(absorbed - emitted, rel=1e-4)


def test_thin_slab_follows_the_lumped_capacitance_ode() -> None:
    # A thin slab of an (artificially) very good conductor, k = 5e4 W/(m K): Biot number
    # h_rad h / k < 1e-4 with h_rad = 4 eps sigma T^3 <= 1.1e3 W/(m^2 K), so it is lumped,
    # rho c_p h dT/dt = eps sigma (T_rad(t)^4 - T^4). Reference: that ODE by Radau to 1e-10.
    # Measured max |T_mean - T_ref| 0.050 K at dt = 0.5 s, 0.0126 K at 0.25 s (ratio 4.0:
    # Crank-Nicolson's O(dt^2)) and 0.0037 K at 0.125 s (the through-thickness floor,
    # 0.004 K top to bottom): tolerance 0.1 K at 0.5 s. A heater held at T_rad(0) = 300 K
    # would leave the slab at 300 K, 1264 K below the reference.
    duration, steps = 90.0, 180
    thickness = 0.002
    m = radiating_slab(thickness, 5e4, duration, steps, radiation_schedule=SCHEDULE)
    t, T, _ = march(m, steps)
    mean = np.array([m.thermal.mean_temperature(Tn) for Tn in T])
    heater = HeaterSchedule(SCHEDULE, duration)
    rc = 4500.0 * 550.0 * thickness

    def rhs(tt: float, y: np.ndarray) -> np.ndarray:
        return EPS * STEFAN_BOLTZMANN * (heater(tt) ** 4 - y**4) / rc

    ref = solve_ivp(rhs, (0.0, duration), [300.0], method="Radau", rtol=1e-10, atol=1e-8,
                    t_eval=t, max_step=duration / 300.0, first_step=1e-3).y[0]
    assert np.max(np.abs(mean - ref)) < 0.1
    assert mean[-1] > 1000.0  # heated far above the start: the check has teeth


def test_flat_schedule_is_the_constant_heater_bit_for_bit() -> None:
    steps = 20
    flat = radiating_slab(0.003, 20.0, 60.0, steps, radiation_schedule=(1400.0,) * 4)
    const = radiating_slab(0.003, 20.0, 60.0, steps, radiation_temperature=1400.0)
    _, T_flat, _ = march(flat, steps)
    _, T_const, _ = march(const, steps)
    assert np.array_equal(T_flat, T_const)
    # and the schedule does change the answer when it is not flat
    ramp = radiating_slab(0.003, 20.0, 60.0, steps, radiation_schedule=(300.0, 2500.0))
    _, T_ramp, _ = march(ramp, steps)
    assert not np.allclose(T_ramp[-1], T_const[-1], rtol=1e-3)
