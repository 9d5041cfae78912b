"""Shock-expansion source (solvers/aero/shock_expansion.py): closed forms and limits."""
from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import assert_matches_richardson, richardson_jacobian
from hypate.solvers.aero.analytic import (
    eckert_heat_flux,
    linearized_supersonic_pressure,
    piston_pressure,
)
from hypate.solvers.aero.base import SurfacePoints, SurfaceState, dense
from hypate.solvers.aero.shock_expansion import (
    ShockExpansionFluid,
    eckert_edge_with_derivatives,
    eckert_heat_flux_edge,
    expansion,
    inverse_prandtl_meyer,
    max_deflection,
    oblique_shock,
    oblique_shock_angle,
    prandtl_meyer,
)
from hypate.solvers.flow import FlowCondition
from scipy.optimize import brentq

G = 1.4


def _theta(M: float, beta: float) -> float:
    """theta-beta-M relation (Anderson, Modern Compressible Flow, Eq. 4.17)."""
    return math.atan(2.0 / math.tan(beta) * (M**2 * math.sin(beta) ** 2 - 1.0)
                     / (M**2 * (G + math.cos(2.0 * beta)) + 2.0))


@pytest.mark.parametrize("M, theta_deg", [(6.0, 5.0), (6.0, 20.0), (2.0, 10.0), (10.0, 1.0)])
def test_oblique_shock_matches_independent_theta_beta_m_solution(M: float, theta_deg: float
                                                                  ) -> None:
    th = math.radians(theta_deg)
    mu = math.asin(1.0 / M)
    beta_star = float(np.arcsin(np.sqrt(((G + 1) * M**2 - 4 + np.sqrt((G + 1) * ((G + 1) * M**4
                      + 8 * (G - 1) * M**2 + 16))) / (4 * G * M**2))))
    beta_ref = brentq(lambda b: _theta(M, b) - th, mu + 1e-12, beta_star)  # weak branch
    assert float(oblique_shock_angle(M, th)) == pytest.approx(beta_ref, abs=1e-10)
    M2, p_ratio, T_ratio = oblique_shock(M, th)
    Mn1 = M * math.sin(beta_ref)
    # normal-shock relations (Anderson Eqs. 3.57, 3.51, 3.53) on the normal component
    assert float(p_ratio) == pytest.approx(1 + 2 * G / (G + 1) * (Mn1**2 - 1), rel=1e-10)
    rho = (G + 1) * Mn1**2 / ((G - 1) * Mn1**2 + 2)
    assert float(T_ratio) == pytest.approx((1 + 2 * G / (G + 1) * (Mn1**2 - 1)) / rho, rel=1e-10)
    Mn2 = math.sqrt((1 + 0.5 * (G - 1) * Mn1**2) / (G * Mn1**2 - 0.5 * (G - 1)))
    assert float(M2) == pytest.approx(Mn2 / math.sin(beta_ref - th), rel=1e-10)


def test_wedge_m6_5deg_table_values() -> None:
    # M = 6, theta = 5 deg: beta = 13.16 deg, p2/p1 = 2.010 (theta-beta-M chart / NACA 1135
    # relations; 3 significant digits)
    assert math.degrees(float(oblique_shock_angle(6.0, math.radians(5.0)))) == pytest.approx(
        13.16, abs=0.01)
    assert float(oblique_shock(6.0, math.radians(5.0))[1]) == pytest.approx(2.010, abs=1e-3)
    # maximum deflection at M = 6: 42.4 deg (NACA 1135 chart, gamma = 1.4)
    assert math.degrees(float(max_deflection(6.0))) == pytest.approx(42.44, abs=0.02)


def test_prandtl_meyer_closed_form_and_inverse() -> None:
    # nu(2) = 26.38 deg (isentropic tables, gamma = 1.4); nu(inf) = 130.45 deg
    assert math.degrees(float(prandtl_meyer(2.0))) == pytest.approx(26.3798, abs=1e-4)
    assert math.degrees(float(prandtl_meyer(1e8))) == pytest.approx(130.4541, abs=1e-3)
    M = np.array([1.2, 2.0, 6.0, 12.0])
    assert inverse_prandtl_meyer(prandtl_meyer(M), M * 0.9 + 0.2) == pytest.approx(M, rel=1e-12)
    # expansion from M = 2 by 10 deg: nu = 36.38 deg -> M = 2.385 (tables), isentropic p ratio
    M2, p_ratio, _ = expansion(2.0, math.radians(10.0))
    assert float(M2) == pytest.approx(2.385, abs=2e-3)
    assert float(p_ratio) == pytest.approx(((1 + 0.2 * 4) / (1 + 0.2 * float(M2) ** 2)) ** 3.5,
                                           rel=1e-12)


def _surface(flow_angle: float = 0.0) -> SurfacePoints:
    return SurfacePoints.grid(1.0, 1.0, 1.0, 41, 1, flow_angle)


def test_panel_wedge_and_expansion_corner_without_boundary_layer() -> None:
    flow = FlowCondition.from_altitude(6.0, 25000.0)
    pts = _surface()
    src = ShockExpansionFluid(boundary_layer=False)
    th = math.radians(5.0)
    for sign in (1.0, -1.0):
        slope = np.full(pts.n, sign * math.tan(th))
        loads = src.evaluate(pts, SurfaceState(slope * pts.x, slope, 0 * slope,
                                               np.full(pts.n, 500.0)), flow)
        if sign > 0:  # compression corner at the panel's leading edge: one oblique shock
            expected = float(oblique_shock(6.0, th)[1])
        else:  # expansion corner: Prandtl-Meyer
            expected = float(expansion(6.0, th)[1])
        np.testing.assert_allclose(loads.pressure / flow.pressure + 1.0, expected, rtol=1e-10)


def test_small_slopes_approach_linear_theory_and_piston_theory() -> None:
    flow = FlowCondition.from_altitude(6.0, 25000.0)
    pts = _surface()
    src = ShockExpansionFluid(boundary_layer=False)
    eps = 1e-5
    slope = eps * np.cos(np.pi * pts.x)
    loads = src.evaluate(pts, SurfaceState(0 * slope, slope, 0 * slope, np.full(pts.n, 500.0)),
                         flow)
    p_ls, _, _ = linearized_supersonic_pressure(flow, slope, 0 * slope)
    p_pt, _ = piston_pressure(flow.mach * slope, flow.pressure, flow.gamma, "pt")
    scale = np.abs(p_ls).max()
    # exact small-slope limit is linear supersonic theory: error O(M theta) relative
    assert np.abs(loads.pressure - p_ls).max() / scale < 1e-3
    # piston theory differs by M / sqrt(M^2 - 1) - 1 = 1.4 % at M = 6 (Eq. 2.38)
    assert np.abs(loads.pressure - p_pt).max() / scale < 0.02


def test_flat_plate_boundary_layer_pressure_and_eckert_heat_flux() -> None:
    flow = FlowCondition.from_altitude(6.0, 25000.0)
    pts = _surface()
    T = np.full(pts.n, 500.0)
    loads = ShockExpansionFluid().evaluate(pts, SurfaceState.flat(pts.n, 500.0), flow)
    # the displacement thickness grows like x^(6/7): a favourable-gradient induced pressure,
    # positive and decreasing along the panel
    assert np.all(loads.pressure > 0.0)
    assert np.all(np.diff(loads.pressure) < 0.0)
    # without the boundary layer the edge is the free stream: Eckert of analytic.py exactly
    q0 = ShockExpansionFluid(boundary_layer=False).evaluate(
        pts, SurfaceState.flat(pts.n, 500.0), flow).heat_flux
    np.testing.assert_allclose(q0, eckert_heat_flux(flow, flow.pressure, T, pts.x_le),
                               rtol=1e-12)
    np.testing.assert_allclose(
        eckert_heat_flux_edge(flow, flow.pressure, flow.temperature, T, pts.x_le), q0, rtol=1e-12)


def test_source_jacobians_match_finite_differences() -> None:
    flow = FlowCondition.from_altitude(6.0, 25000.0)
    pts = SurfacePoints.grid(1.0, 1.0, 1.0, 17, 2)
    x = pts.x
    w = 0.01 * np.sin(np.pi * x) + 0.003 * np.sin(2 * np.pi * x)
    st = SurfaceState(w, pts.streamwise_derivative @ w, 0.2 * np.sin(np.pi * x),
                      500.0 + 200.0 * x)
    src = ShockExpansionFluid(fd_step=1e-6)
    J = src.evaluate(pts, st, flow, jacobians=True).jacobians

    def f(**kw: np.ndarray) -> np.ndarray:
        s = dict(slope=st.slope, velocity=st.velocity, wall_temperature=st.wall_temperature)
        s.update(kw)
        loads = src.evaluate(pts, SurfaceState(w, **s), flow)
        return np.r_[loads.pressure, loads.heat_flux]

    # The source's Jacobian is itself a central difference, at step fd_step (slope) and
    # fd_step T_w (wall temperature). The extrapolated difference at twice those steps
    # contains that very difference D(h/2); its measured bound (three times D(h/2)'s
    # truncation plus the rounding, conftest.richardson_derivative) covers the errors of
    # both, so the tolerance is the formulas' own error.
    for key, name, h in (("ws", "slope", 2e-6), ("Tw", "wall_temperature", 2e-6 * st.wall_temperature)):
        fd, bound = richardson_jacobian(lambda v, name=name: f(**{name: v}), getattr(st, name), h)
        an = np.vstack([dense(J["dp_d" + key]), dense(J["dq_d" + key])])
        assert_matches_richardson(an, fd, bound, key)
    np.testing.assert_allclose(dense(J["dp_dwdot"]), dense(J["dp_dws"]) / flow.velocity)


def test_eckert_edge_partials_match_central_differences() -> None:
    """dq/dp_e, dq/dT_e, dq/dT_w of Eckert's flux on a given edge state (Eqs. 2.39-2.43;
    complex step) against extrapolated central differences, pointwise; the flux is the
    real law's to the last bit."""
    flow = FlowCondition.from_altitude(6.0, 25000.0)
    rng = np.random.default_rng(5)
    n = 12
    p_e = flow.pressure * rng.uniform(0.5, 3.0, n)
    T_e = flow.temperature * rng.uniform(0.9, 1.4, n)
    T_w = rng.uniform(250.0, 1400.0, n)
    x_le = rng.uniform(0.2, 2.0, n)
    for regime in ("turbulent", "laminar"):
        q, *partials = eckert_edge_with_derivatives(flow, p_e, T_e, T_w, x_le, regime)
        np.testing.assert_array_equal(q, eckert_heat_flux_edge(flow, p_e, T_e, T_w, x_le,
                                                               regime))
        args = [p_e, T_e, T_w]
        for k, (h, partial) in enumerate(zip((1e-3 * flow.pressure, 0.05, 0.5), partials)):
            def f(v, k=k, args=args, regime=regime):
                a = list(args)
                a[k] = v
                return eckert_heat_flux_edge(flow, *a, x_le, regime)

            fd, bound = richardson_jacobian(f, args[k], h)
            assert_matches_richardson(np.diag(partial), fd, bound, (regime, k))
