"""Analytical aerothermodynamics (Sec. 2.3) against closed forms and independent values."""
from __future__ import annotations

import numpy as np
import pytest
from conftest import assert_matches_richardson, richardson_jacobian
from hypate.solvers.aero.analytic import (
    AnalyticFluid,
    BoundaryLayerShape,
    adiabatic_wall_temperature,
    eckert_heat_flux,
    piston_pressure,
)
from hypate.solvers.aero.base import (
    JACOBIAN_KEYS,
    BlockJacobians,
    FluidJacobians,
    FluidLoads,
    SurfacePoints,
    SurfaceState,
    dense,
)
from hypate.solvers.aero.factory import make_fluid_model
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition

M6_25KM = FlowCondition.from_static(6.0, 2549.22, 221.552)  # materials.md check state


# Independent check values (materials.md), gamma = 1.4, V = v_n / a_inf = M_n.
@pytest.mark.parametrize("mn, exact, third", [(0.05, 1.0721354, 1.0721350),
                                              (0.10, 1.1486857, 1.1486800),
                                              (0.20, 1.3159318, 1.3158400),
                                              (-0.10, 0.8681255, 0.8681200)])
def test_piston_theory_check_values(mn: float, exact: float, third: float) -> None:
    p, _ = piston_pressure(mn, 1.0, 1.4, "pt")
    p3, _ = piston_pressure(mn, 1.0, 1.4, "pt3")
    assert 1.0 + p == pytest.approx(exact, abs=5e-8)  # values quoted to 7 decimals
    assert 1.0 + p3 == pytest.approx(third, abs=5e-8)


def test_full_minus_third_order_is_fourth_order() -> None:
    # PT - PT3 = O(M_n^4): halving M_n divides the difference by ~16.
    mn = np.array([0.08, 0.04, 0.02, 0.01])
    diff = piston_pressure(mn, 1.0, 1.4, "pt")[0] - piston_pressure(mn, 1.0, 1.4, "pt3")[0]
    rates = np.log2(diff[:-1] / diff[1:])
    assert np.all(np.abs(rates - 4.0) < 0.1)  # leading term M_n^4, next term shifts ~1 %/halving


def test_first_order_pt_and_ls_agree_at_high_mach() -> None:
    flow = FlowCondition.from_static(20.0, 1000.0, 220.0)
    pts = SurfacePoints.grid(1.0, 1.0, 1.0, 11, 1)
    rng = np.random.default_rng(1)
    state = SurfaceState(np.zeros(pts.n), rng.normal(0, 1e-3, pts.n),
                         rng.normal(0, 0.1, pts.n), np.full(pts.n, 300.0))
    p1 = AnalyticFluid("pt1", heating="none").evaluate(pts, state, flow).pressure
    pls = AnalyticFluid("ls", heating="none").evaluate(pts, state, flow).pressure
    # LS differs from PT1 by factors M/sqrt(M^2-1) and (M^2-2)/(M^2-1): 0.1 % and 0.25 % at M 20
    assert np.max(np.abs(pls - p1)) <= 0.01 * np.max(np.abs(p1))


def _state(pts: SurfacePoints, rng: np.random.Generator) -> SurfaceState:
    w = 0.002 * np.sin(np.pi * pts.x) * (1 + 0.3 * np.cos(np.pi * pts.y)) + rng.normal(0, 1e-4, pts.n)
    return SurfaceState(w, pts.streamwise_derivative @ w, rng.normal(0, 0.5, pts.n),
                        500.0 + 300.0 * pts.x + 50.0 * pts.y + rng.normal(0, 5.0, pts.n))


@pytest.mark.parametrize("aero", ["pt", "pt1", "pt3", "ls", "pt-bl"])
@pytest.mark.parametrize("angle", [0.0, 0.4])
def test_jacobians_match_central_differences(aero: str, angle: float) -> None:
    pts = SurfacePoints.grid(1.0, 0.6, 0.8, 7, 4, flow_angle=angle)
    model = make_fluid_model(aero, "eckert", "turbulent")
    state = _state(pts, np.random.default_rng(3))
    S = pts.streamwise_derivative
    loads = model.evaluate(pts, state, M6_25KM, jacobians=True)
    J = {k: dense(v) for k, v in loads.jacobians.items()}

    def run(w, wdot, Tw):
        st = SurfaceState(w, S @ w, wdot, Tw)
        out = model.evaluate(pts, st, M6_25KM)
        return np.concatenate([out.pressure, out.heat_flux])

    n = pts.n
    checks = [
        ("w", state.displacement, 1e-7, lambda w: run(w, state.velocity, state.wall_temperature),
         np.vstack([J["dp_dw"] + J["dp_dws"] @ S.toarray(), J["dq_dw"] + J["dq_dws"] @ S.toarray()])),
        ("wdot", state.velocity, 1e-4, lambda v: run(state.displacement, v, state.wall_temperature),
         np.vstack([J["dp_dwdot"], J["dq_dwdot"]])),
        ("Tw", state.wall_temperature, 1e-3, lambda T: run(state.displacement, state.velocity, T),
         np.vstack([J["dp_dTw"], J["dq_dTw"]])),
    ]
    for name, x, h, fun, analytic in checks:
        numeric, bound = richardson_jacobian(fun, x, 2 * h)
        # tolerance: the extrapolated difference's own measured error (truncation and
        # rounding, conftest.richardson_derivative), entry by entry
        for rows, label in ((slice(0, n), "p"), (slice(n, 2 * n), "q")):
            assert_matches_richardson(analytic[rows], numeric[rows], bound[rows],
                                      f"d{label}/d{name} ({aero})")


def test_effective_shape_thickens_downstream_and_raises_pressure() -> None:
    bl = BoundaryLayerShape(M6_25KM)
    x = np.array([1.0, 1.5, 2.0])
    d = bl.thickness(x, np.full(3, 300.0))
    assert np.all(np.diff(d) > 0)
    # delta ~ x^(6/7) at fixed wall temperature (Eq. 2.35 with m = 1/7)
    assert d[2] / d[0] == pytest.approx(2.0 ** (6.0 / 7.0), rel=1e-12)
    pts = SurfacePoints.grid(1.0, 1.0, 1.0, 9, 1)
    flat = SurfaceState.flat(pts.n, 300.0)
    p_bl = AnalyticFluid("pt", effective_shape=True).evaluate(pts, flat, M6_25KM).pressure
    p = AnalyticFluid("pt").evaluate(pts, flat, M6_25KM).pressure
    assert np.all(p == 0.0) and np.all(p_bl > 0.0)  # growing layer = compression slope


def test_effective_shape_is_a_slope_offset_that_ignores_the_deflection() -> None:
    # the premise of the Ch. 8 finding on Table 8.2's RANS column: pt-bl is piston theory at
    # the wall slope plus the Cox-Crabtree slope d(delta)/ds(x, T_w), which the deflection
    # does not change -- so the boundary layer adds no out-of-phase pressure (Sec. 8.1)
    pts = SurfacePoints.grid(1.0, 1.0, 1.0, 9, 1)
    rng = np.random.default_rng(5)
    T_w = 400.0 + 500.0 * pts.x
    d_s = BoundaryLayerShape(M6_25KM).slope(pts.x_le, T_w, pts.streamwise_derivative @ T_w)[0]
    bl, pt = AnalyticFluid("pt", effective_shape=True), AnalyticFluid("pt")
    for amplitude in (0.0, 0.003, 0.01):
        w = amplitude * np.sin(np.pi * pts.x) + rng.normal(0.0, 1e-4, pts.n)
        slope, v = pts.streamwise_derivative @ w, rng.normal(0.0, 0.5, pts.n)
        p_bl = bl.evaluate(pts, SurfaceState(w, slope, v, T_w), M6_25KM).pressure
        p_at_offset = pt.evaluate(pts, SurfaceState(w, slope + d_s, v, T_w), M6_25KM).pressure
        np.testing.assert_allclose(p_bl, p_at_offset, rtol=1e-13, atol=0.0)


# -- Eckert --------------------------------------------------------------------------------
def test_eckert_independent_check_values() -> None:
    # materials.md: M 6, 25 km, x = 1 m, T_w = 300 K. The dissertation's enthalpy form reduces
    # to these temperature formulas for a calorically perfect gas; values quoted to ~5 digits.
    # rel 5e-5: the fluxes are quoted to 5 significant digits.
    f = M6_25KM
    assert float(adiabatic_wall_temperature(f, f.pressure, "turbulent")) == pytest.approx(1651.28, abs=0.01)
    assert float(adiabatic_wall_temperature(f, f.pressure, "laminar")) == pytest.approx(1575.10, abs=0.01)
    assert float(eckert_heat_flux(f, f.pressure, 300.0, 1.0, "turbulent")) == pytest.approx(85244.0, rel=5e-5)
    assert float(eckert_heat_flux(f, f.pressure, 300.0, 1.0, "laminar")) == pytest.approx(15152.0, rel=5e-5)


@pytest.mark.parametrize("regime", ["turbulent", "laminar"])
def test_eckert_zero_at_adiabatic_wall_and_monotone(regime: str) -> None:
    f = M6_25KM
    pe = f.pressure * 1.3
    taw = float(adiabatic_wall_temperature(f, pe, regime))
    assert abs(float(eckert_heat_flux(f, pe, taw, 1.0, regime))) < 1e-9
    Tw = np.linspace(250.0, taw - 1.0, 200)
    q = eckert_heat_flux(f, pe, Tw, 1.0, regime)
    assert np.all(q > 0) and np.all(np.diff(q) < 0)


def test_turbulent_exceeds_laminar() -> None:
    f = M6_25KM
    Tw = np.linspace(300.0, 1400.0, 12)
    assert np.all(eckert_heat_flux(f, f.pressure, Tw, 1.0, "turbulent")
                  > eckert_heat_flux(f, f.pressure, Tw, 1.0, "laminar"))


def test_heat_flux_scales_with_distance_as_cf_laws() -> None:
    f, x = M6_25KM, np.array([0.5, 1.0, 2.0])
    q_lam = eckert_heat_flux(f, f.pressure, 400.0, x, "laminar")
    # laminar c_f ~ Re_x^-1/2 and Re_x ~ x: q(2x)/q(x) = 2^-1/2 exactly
    assert q_lam[2] / q_lam[1] == pytest.approx(2 ** -0.5, rel=1e-12)
    q_turb = eckert_heat_flux(f, f.pressure, 400.0, x, "turbulent")
    # turbulent c_f ~ (log10 Re*)^-2.584 with Re* proportional to x
    T_r = 0.28 * f.temperature + 0.5 * 400.0 + 0.22 * float(adiabatic_wall_temperature(f, f.pressure))
    from hypate.solvers.flow import sutherland_viscosity
    re1 = f.pressure / (f.gas_constant * T_r) * f.velocity * 1.0 / float(sutherland_viscosity(T_r))
    expected = (np.log10(2 * re1) / np.log10(re1)) ** -2.584
    assert q_turb[2] / q_turb[1] == pytest.approx(expected, rel=1e-12)


def test_model_name_errors() -> None:
    with pytest.raises(InputError, match="simulation.aero"):
        make_fluid_model("newtonian")
    with pytest.raises(InputError, match="simulation.heating"):
        AnalyticFluid("pt", heating="fay-riddell")


@pytest.mark.parametrize("aero", ["pt", "ls", "pt-bl"])
def test_pointwise_coefficients_are_the_jacobian_blocks(aero: str) -> None:
    # the coefficient forms the coupling reads equal the blocks the FD test checks
    pts = SurfacePoints.grid(1.0, 0.6, 0.8, 7, 4, flow_angle=0.4)
    loads = make_fluid_model(aero).evaluate(pts, _state(pts, np.random.default_rng(4)),
                                            M6_25KM, jacobians=True)
    J = loads.jacobians
    assert isinstance(J, FluidJacobians)
    s, v = J.pressure_coefficients()
    assert not np.any(dense(J["dp_dw"]))
    np.testing.assert_array_equal(dense(J["dp_dws"]), np.diag(s))
    np.testing.assert_array_equal(dense(J["dp_dwdot"]), np.diag(v))
    a, b = J.tw_coefficients()
    form = np.diag(a) + (0.0 if b is None else np.diag(b) @ dense(pts.streamwise_derivative))
    assert (b is None) == (aero != "pt-bl")
    # the block is summed in another order: round-off (1e-12 of the largest entry)
    ref = dense(J["dq_dTw"])
    np.testing.assert_allclose(form, ref, rtol=0.0, atol=1e-12 * np.max(np.abs(ref)))


def test_block_jacobians_have_no_pointwise_form() -> None:
    # a fidelity that returns its blocks as a plain mapping (the ROM) is held as
    # BlockJacobians: the same blocks, and "not pointwise" through the interface
    blocks = {k: np.eye(3) for k in JACOBIAN_KEYS}
    loads = FluidLoads(np.zeros(3), np.zeros(3))
    assert isinstance(loads.jacobians, BlockJacobians) and len(loads.jacobians) == 0
    loads.jacobians = blocks
    assert isinstance(loads.jacobians, BlockJacobians)
    assert set(loads.jacobians) == set(JACOBIAN_KEYS)
    assert loads.jacobians["dq_dTw"] is blocks["dq_dTw"]
    assert loads.jacobians.pressure_coefficients() is None
    assert loads.jacobians.tw_coefficients() is None
