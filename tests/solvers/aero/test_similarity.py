"""The compressible laminar similarity solution (solvers/aero/similarity.py) against closed
forms (Blasius, Crocco-Busemann) and its own integral conservation laws."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypate.solvers.aero.analytic import eckert_heat_flux
from hypate.solvers.aero.similarity import edge_state, laminar_similarity, similarity_heat_flux
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition
from scipy.integrate import trapezoid


def _linear_viscosity(T):
    """mu proportional to T: the Chapman-Rubesin parameter C = 1 everywhere."""
    return 1e-7 * np.asarray(T, float)


def test_incompressible_limit_is_blasius():
    """M -> 0, adiabatic: f''(0) = 0.46960 in the sqrt(2 xi) scaling (0.33206 / sqrt(1/2):
    c_f = 0.664 / sqrt(Re_x)), to 1e-5."""
    s = laminar_similarity(1e-3, 300.0, 300.0, 1.4, 0.72)
    assert s.shear == pytest.approx(0.469600, abs=1e-5)
    assert abs(s.heat) < 1e-6


@pytest.mark.parametrize("g_w", [0.5, 2.0, 6.0])
def test_unit_prandtl_and_chapman_rubesin_give_crocco_busemann(g_w):
    """Pr = 1, C = 1: the temperature is the Crocco-Busemann quadratic in the velocity, g =
    g_w + (g_aw - g_w) f' - (gamma - 1)/2 M^2 f'^2 with g_aw = 1 + (gamma - 1)/2 M^2 (recovery
    factor 1), and the Reynolds analogy g'(0) = (g_aw - g_w) f''(0) holds; at M 6, to 1e-5."""
    M, gam = 6.0, 1.4
    s = laminar_similarity(M, 220.0, g_w * 220.0, gam, 1.0, viscosity=_linear_viscosity)
    e = 0.5 * (gam - 1.0) * M**2
    g_cb = g_w + (1.0 + e - g_w) * s.velocity - e * s.velocity**2
    assert s.shear == pytest.approx(0.469600, abs=1e-5)  # C = 1: Blasius again
    assert np.max(np.abs(s.temperature - g_cb)) < 1e-5 * (1.0 + e)
    assert s.heat == pytest.approx((1.0 + e - g_w) * s.shear, rel=1e-5)


@pytest.mark.parametrize("T_w", [300.0, 900.0])
def test_momentum_and_energy_integrals_hold(T_w):
    """Sutherland gas, Pr 0.690, M 6 at 25 km: the momentum integral C_w f''(0) = int f'(1 -
    f') d eta and the energy integral C_w g'(0) / Pr = int f' (H_e - H) d eta (H = g + (gamma
    - 1)/2 M^2 f'^2, the total enthalpy over c_p T_e) -- the flat plate's conservation laws --
    to 1e-4 (trapezoid rule on the solver's mesh)."""
    flow = FlowCondition.from_altitude(6.0, 25000.0)
    pr, gam, M = 0.690, flow.gamma, flow.mach
    s = laminar_similarity(M, flow.temperature, T_w, gam, pr)
    fp, e = s.velocity, 0.5 * (gam - 1.0) * M**2
    momentum = trapezoid(fp * (1.0 - fp), s.eta)
    assert s.wall_chapman_rubesin * s.shear == pytest.approx(momentum, rel=1e-4)
    H = s.temperature + e * fp**2
    energy = trapezoid(fp * (1.0 + e - H), s.eta)
    assert s.wall_chapman_rubesin * s.heat / pr == pytest.approx(energy, rel=1e-4)


def test_outer_boundary_is_far_enough():
    """Doubling the truncated eta range changes the wall gradients by < 1e-6."""
    a = laminar_similarity(6.0, 221.6, 600.0, 1.4, 0.690)
    b = laminar_similarity(6.0, 221.6, 600.0, 1.4, 0.690, eta_max=24.0)
    assert a.heat == pytest.approx(b.heat, rel=1e-6)
    assert a.shear == pytest.approx(b.shear, rel=1e-6)


@pytest.mark.parametrize("T_w", [300.0, 600.0, 900.0])
def test_eckert_estimate_is_within_two_percent_of_the_exact_solution(T_w):
    """The laminar Eckert reference-temperature flux (Eqs. 2.39-2.43) on the CFD flat plate
    (M 6, 25 km, Pr 0.690, x 1-2 m): measured -0.5 / +0.15 / +1.2 % of the similarity
    solution at 300 / 600 / 900 K; within 2 %. The flux scales as x^-1/2."""
    flow = replace(FlowCondition.from_altitude(6.0, 25000.0), prandtl=0.690)
    x = np.linspace(1.0125, 1.9875, 40)
    q = similarity_heat_flux(flow, flow.pressure, T_w, x)
    np.testing.assert_allclose(q * np.sqrt(x), q[0] * np.sqrt(x[0]), rtol=1e-12)
    q_e = eckert_heat_flux(flow, flow.pressure, T_w, x, "laminar")
    assert np.mean(q_e) == pytest.approx(np.mean(q), rel=0.02)


def test_edge_state_is_the_free_stream_at_its_pressure():
    flow = FlowCondition.from_altitude(6.0, 25000.0)
    T_e, u_e, M_e = edge_state(flow, flow.pressure)
    assert T_e == pytest.approx(flow.temperature, rel=1e-12)
    assert M_e == pytest.approx(6.0, rel=1e-12)


def test_bad_inputs_are_refused_by_name():
    with pytest.raises(InputError, match="T_w"):
        laminar_similarity(6.0, 221.6, -1.0, 1.4, 0.690)
    with pytest.raises(InputError, match="gamma"):
        laminar_similarity(6.0, 221.6, 300.0, 1.0, 0.690)
    flow = FlowCondition.from_altitude(6.0, 25000.0)
    with pytest.raises(InputError, match="x_le"):
        similarity_heat_flux(flow, flow.pressure, 300.0, [0.0, 1.0])
