"""The ROM fluid model (solvers/aero/rom/model.py): accuracy, corrections, Jacobians
(Eqs. 2.74-2.76) against finite differences, other grids, geometric similarity, the
conventional ROM."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from conftest import SMALL_ROM, assert_matches_richardson, richardson_jacobian, rom_state
from hypate.solvers.aero.analytic import eckert_heat_flux
from hypate.solvers.aero.base import SurfacePoints, SurfaceState, dense
from hypate.solvers.aero.rom.build import build_rom_from_config, check_rom, nrmse
from hypate.solvers.aero.rom.config import parse_rom_config
from hypate.solvers.aero.rom.model import RomFluid
from hypate.solvers.aero.rom.snapshots import generate_samples
from hypate.solvers.aero.shock_expansion import ShockExpansionFluid, eckert_heat_flux_edge
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition


def test_small_rom_accuracy_at_reference(small_rom: RomFluid) -> None:
    res = check_rom(small_rom, 30, rng=11)
    # 50 samples, 4 inputs: well converged already (the 200-sample acceptance is slow-marked)
    assert res["pressure_nrmse"] < 0.01 and res["heat_flux_nrmse"] < 0.02, res


def test_corrections_are_identity_at_reference(small_rom: RomFluid) -> None:
    g = small_rom.geometry
    pts, st = rom_state(g, 1.0, [2.0, -1.0, 0.5], nonuniform=False)
    d = small_rom.inputs(pts, st, small_rom.reference)
    p_pk = small_rom.pressure_model.predict(d[None])[0]
    q_pk = small_rom.heat_model.predict(d[None])[0]
    for corr in ("bl", "pt"):
        loads = small_rom.with_options(correction=corr).evaluate(pts, st, small_rom.reference)
        np.testing.assert_allclose(loads.pressure, p_pk, rtol=1e-10, atol=1e-9)
        np.testing.assert_allclose(loads.heat_flux, q_pk, rtol=1e-10, atol=1e-9)


@pytest.mark.parametrize("correction, edge, scale, mach, altitude", [
    ("bl", "rom", 2.0, 7.0, 30000.0), ("pt", "rom", 1.0, 5.0, 20000.0),
    ("bl", "pt", 4.0, 6.0, 25000.0)])
def test_rom_jacobians_match_central_differences(small_rom: RomFluid, correction: str,
                                                 edge: str, scale: float, mach: float,
                                                 altitude: float) -> None:
    fluid = small_rom.with_options(correction=correction, edge_pressure=edge)
    flow = FlowCondition.from_altitude(mach, altitude)
    pts, st = rom_state(small_rom.geometry, scale, [3.0, -1.0, 0.5], velocity=0.3)
    J = fluid.evaluate(pts, st, flow, jacobians=True).jacobians
    fields = {"w": "displacement", "ws": "slope", "wdot": "velocity", "Tw": "wall_temperature"}
    # steps where the extrapolated difference's truncation and rounding (the GP's noise
    # over h) balance: its measured bound stays ~1e-7 of the largest slope
    steps = {"w": 4e-4 / scale, "ws": 2e-5, "wdot": 2e-3, "Tw": 2.0}
    for key, name in fields.items():
        for part in ("pressure", "heat_flux"):
            def f(v, name=name, part=part):
                kw = {k: getattr(st, k) for k in fields.values()}
                kw[name] = v
                return getattr(fluid.evaluate(pts, SurfaceState(**kw), flow), part)

            fd, bound = richardson_jacobian(f, getattr(st, name), steps[key])
            an = dense(J[("dp_d" if part == "pressure" else "dq_d") + key])
            if not np.any(fd):
                assert not np.any(an), key
                continue
            # tolerance: the difference's own measured error (conftest.richardson_derivative)
            assert_matches_richardson(an, fd, bound, (key, part))


def test_rom_on_another_grid_and_projection(small_rom: RomFluid) -> None:
    pts = SurfacePoints.grid(0.5, 0.5, 0.5, 21, 1)  # xi = 2, coarser grid: interpolated
    xr = pts.x * 2.0
    w = (0.0025 / 2.0) * (2.0 * np.sin(np.pi * xr) - 1.0 * np.sin(2 * np.pi * xr))
    st = SurfaceState(w, pts.streamwise_derivative @ w, 0 * w, np.full(pts.n, 500.0))
    d = small_rom.inputs(pts, st, small_rom.reference)
    # the projection recovers the modal amplitudes of the reference-size deformation
    np.testing.assert_allclose(d, [2.0, -1.0, 0.0, 500.0], atol=1e-10)
    loads = small_rom.evaluate(pts, st, FlowCondition.from_altitude(6.0, 25000.0))
    assert loads.pressure.shape == (21,) and np.all(np.isfinite(loads.heat_flux))


def test_mismatched_panel_is_refused(small_rom: RomFluid) -> None:
    flow = small_rom.reference
    bad = SurfacePoints.grid(1.0, 1.0, 0.5, 33, 1)  # a/L_le = 2 instead of 1
    with pytest.raises(InputError, match="panel mismatch"):
        small_rom.evaluate(bad, SurfaceState.flat(bad.n, 500.0), flow)
    # a 2-D ROM runs strip-wise along the flow only
    skew = SurfacePoints.grid(1.0, 1.0, 1.0, 33, 4, flow_angle=np.radians(10.0))
    with pytest.raises(InputError, match="strip-wise along the flow"):
        small_rom.evaluate(skew, SurfaceState.flat(skew.n, 500.0), flow)


@pytest.fixture(scope="module")
def inviscid_rom() -> RomFluid:
    """The small ROM from the shock-expansion source without its boundary layer."""
    cfg = dict(SMALL_ROM, source={"kind": "shock-expansion", "boundary_layer": False})
    return build_rom_from_config(parse_rom_config(cfg))


def _strip_state(pts: SurfacePoints, scale: float, amplitudes: list[float]) -> SurfaceState:
    """A 3-D wall state: the ROM's modes along x times sin(pi y / b), a wall temperature
    varying in x and y, a small normal velocity."""
    n_x, n_y = pts.shape
    a, b = pts.x.max(), pts.y.max()
    xr = pts.x / a
    w = 0.0025 / scale * sum(c * np.sin((k + 1) * np.pi * xr) for k, c in enumerate(amplitudes))
    w = w * np.sin(np.pi * pts.y / b)
    T = 450.0 + 200.0 * xr + 100.0 * pts.y / b + 40.0 * np.sin(2 * np.pi * xr)
    return SurfaceState(w, pts.streamwise_derivative @ w, 0.2 * np.sin(np.pi * xr), T)


@pytest.mark.parametrize("inviscid", [False, True])
def test_2d_rom_applied_strip_wise_is_the_2d_rom_of_each_strip(
        small_rom: RomFluid, inviscid_rom: RomFluid, inviscid: bool) -> None:
    rom = inviscid_rom if inviscid else small_rom
    flow = FlowCondition.from_altitude(5.5, 22000.0)
    pts = SurfacePoints.grid(0.5, 0.5, 0.5, 21, 5)  # xi = 2; the inviscid one any L_le
    st = _strip_state(pts, 2.0, [2.0, -1.0, 0.5])
    loads = rom.evaluate(pts, st, flow)
    n_x, n_y = pts.shape
    assert rom.inputs(pts, st, flow).shape == (n_y, rom.n_inputs)
    line = SurfacePoints.grid(0.5, 0.5, 0.5, n_x, 1)
    for j in range(n_y):
        k = slice(j * n_x, (j + 1) * n_x)
        one = rom.evaluate(line, SurfaceState(st.displacement[k], st.slope[k], st.velocity[k],
                                              st.wall_temperature[k]), flow)
        # the same arithmetic strip by strip, the kriging batched over the strips: equal
        # to round-off (measured up to 2e-11 of the field's largest value)
        for part in ("pressure", "heat_flux"):
            a, b = getattr(loads, part)[k], getattr(one, part)
            scale = np.abs(getattr(loads, part)).max()
            np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-9 * scale)


@pytest.mark.parametrize("inviscid", [False, True])
def test_strip_wise_jacobians_match_central_differences(
        small_rom: RomFluid, inviscid_rom: RomFluid, inviscid: bool) -> None:
    rom = inviscid_rom if inviscid else small_rom
    flow = FlowCondition.from_altitude(6.5, 27000.0)
    # xi = 4; the inviscid ROM at L_le = 0.6 m, four times its a / L_le; 9 points resolve
    # the three modes
    pts = SurfacePoints.grid(0.25, 0.3, 0.6 if inviscid else 0.25, 9, 3)
    st = _strip_state(pts, 4.0, [3.0, -1.0, 0.5])
    J = rom.evaluate(pts, st, flow, jacobians=True).jacobians
    fields = {"w": "displacement", "ws": "slope", "wdot": "velocity", "Tw": "wall_temperature"}
    steps = {"w": 1e-4, "ws": 2e-5, "wdot": 2e-3, "Tw": 2.0}  # as the 2-D test above
    n = pts.n
    for key, name in fields.items():
        def f(v, name=name):
            kw = {k: getattr(st, k) for k in fields.values()}
            kw[name] = v
            loads = rom.evaluate(pts, SurfaceState(**kw), flow)
            return np.r_[loads.pressure, loads.heat_flux]

        fd, bound = richardson_jacobian(f, getattr(st, name), steps[key])
        for part, rows in (("dp_d", slice(0, n)), ("dq_d", slice(n, 2 * n))):
            an = dense(J[part + key])
            if not np.any(fd[rows]):
                assert not np.any(an), key
                continue
            assert_matches_richardson(an, fd[rows], bound[rows], (key, part))
    # block-diagonal over the three strips
    assert sp.issparse(J["dp_dw"]) and J["dp_dw"].nnz <= 3 * 9 * 9


def test_inviscid_rom_serves_any_leading_edge_distance(inviscid_rom: RomFluid) -> None:
    """An inviscid ROM's pressure does not depend on L_le; its heat flux is Eckert's at the
    actual distance from the leading edge (Eqs. 2.39-2.43, 2.65)."""
    rom = inviscid_rom
    flow = FlowCondition.from_altitude(5.4, 23000.0)
    amps = [2.5, -0.8, 0.4]
    xr = np.linspace(0.0, 1.0, 41)
    w = 0.0025 / 4.0 * sum(c * np.sin((k + 1) * np.pi * xr) for k, c in enumerate(amps))
    out = {}
    for L_le in (0.1, 0.35, 2.0):  # a = 0.25 m: a / L_le from 2.5 to 0.125
        pts = SurfacePoints.grid(0.25, 0.25, L_le, 41, 1)
        st = SurfaceState(w, pts.streamwise_derivative @ w, 0.0 * w, np.full(41, 700.0))
        out[L_le] = (pts, rom.evaluate(pts, st, flow))
    p0 = out[0.35][1].pressure
    for L_le, (pts, loads) in out.items():
        np.testing.assert_array_equal(loads.pressure, p0)
        # the heat flux scales as Eckert's flux at the same edge state (closed form: the
        # same pressure and wall temperature, only x_le differs)
        ratio = (eckert_heat_flux(flow, flow.pressure + p0, 700.0, pts.x_le)
                 / eckert_heat_flux(flow, flow.pressure + p0, 700.0, out[0.35][0].x_le))
        np.testing.assert_allclose(loads.heat_flux / out[0.35][1].heat_flux, ratio,
                                   rtol=1e-12)
    # against the source itself at the actual L_le: the shock-expansion march without a
    # boundary layer on the 0.25 m panel 0.1 m behind the leading edge
    pts, loads = out[0.1]
    st = SurfaceState(w, pts.streamwise_derivative @ w, 0.0 * w, np.full(41, 700.0))
    src = ShockExpansionFluid(boundary_layer=False).evaluate(pts, st, flow)
    # 50 samples over 4 inputs: the ROM's own error against its source is ~0.5 % of the
    # range at the reference (test_small_rom_accuracy_at_reference); the correction to
    # M 5.4 / 23 km adds the piston-theory rescaling of the shock-expansion pressure
    assert nrmse(src.pressure[None], loads.pressure[None], pts.weights)[0] < 0.03
    assert nrmse(src.heat_flux[None], loads.heat_flux[None], pts.weights)[0] < 0.03


def test_viscous_rom_still_needs_its_a_over_l_le(inviscid_rom: RomFluid,
                                                   small_rom: RomFluid) -> None:
    assert not small_rom.inviscid and inviscid_rom.inviscid
    pts = SurfacePoints.grid(0.25, 0.25, 0.6, 21, 1)
    st = SurfaceState.flat(pts.n, 500.0)
    with pytest.raises(InputError, match="boundary layer in its snapshots"):
        small_rom.evaluate(pts, st, small_rom.reference)
    assert np.all(np.isfinite(inviscid_rom.evaluate(pts, st, small_rom.reference).pressure))


def test_conventional_rom_builds_and_predicts() -> None:
    cfg = dict(SMALL_ROM, training=dict(SMALL_ROM["training"], samples=40),
               conventional={"mach": [5.0, 7.0], "altitude": [20000.0, 30000.0]})
    rom = build_rom_from_config(parse_rom_config(cfg))
    assert rom.kind == "conventional" and rom.n_inputs == 7
    pts, st = rom_state(rom.geometry, 1.0, [1.0, 0.5, 0.0], nonuniform=False)
    flow = FlowCondition.from_altitude(6.5, 22000.0)
    loads = rom.evaluate(pts, st, flow, jacobians=True)
    p_src, _ = generate_samples(rom.geometry, [[1.0, 0.5, 0.0]], [550.0], flow)
    # 40 samples over 7 inputs: a coarse comparison model, within 5 % of the range
    assert nrmse(p_src, loads.pressure[None], pts.weights)[0] < 0.05
    with pytest.raises(InputError, match="no geometric scaling"):
        rom.evaluate(*rom_state(rom.geometry, 2.0, [1.0, 0.0, 0.0]), flow)


def test_edge_rom_heat_flux_is_eckert_on_the_kriged_fields(edge_rom: RomFluid) -> None:
    """An Euler ROM's reference heat flux is Eckert's flux (Eqs. 2.39-2.43) on the kriged
    pressure and edge temperature at the wall temperature, not the kriged heat flux; at
    the reference the corrections are the identity (Eqs. 2.65, 2.72)."""
    rom = edge_rom
    g, ref = rom.geometry, rom.reference
    pts, st = rom_state(g, 1.0, [2.0, -1.0, 0.5], nonuniform=False)
    d = rom.inputs(pts, st, ref)
    p_pk = rom.pressure_model.predict(d[None])[0]
    T_e = rom.edge_temperature_model.predict(d[None])[0]
    law = eckert_heat_flux_edge(ref, ref.pressure + p_pk, T_e, st.wall_temperature, pts.x_le)
    loads = rom.evaluate(pts, st, ref)
    # the same arithmetic in another order (batched kriging with gradients): round-off
    np.testing.assert_allclose(loads.heat_flux, law, rtol=1e-10, atol=1e-9)
    np.testing.assert_allclose(rom.reference_loads(d)[1][0], law, rtol=1e-12)
    # and the law, not the kriged heat flux: they differ by the kriging errors (the two
    # fields fitted on 50 samples: about 1e-3 of the range here; equal would mean the
    # edge-temperature field is ignored)
    kriged = rom.heat_model.predict(d[None])[0]
    assert np.max(np.abs(kriged - law)) > 1e-6 * np.ptp(law)
    # the pressure path does not know the edge-temperature field: bit for bit the same
    plain = RomFluid(g, ref, rom.pressure_model, rom.heat_model, source=rom.source)
    other = plain.evaluate(pts, st, ref, jacobians=True)
    both = rom.evaluate(pts, st, ref, jacobians=True)
    np.testing.assert_array_equal(other.pressure, both.pressure)
    for key in ("dp_dw", "dp_dws", "dp_dwdot", "dp_dTw"):
        np.testing.assert_array_equal(dense(other.jacobians[key]), dense(both.jacobians[key]))
    # without the field the ROM returns its kriged heat flux, as before
    np.testing.assert_allclose(other.heat_flux, kriged, rtol=1e-10, atol=1e-9)


def test_a_rom_without_edge_field_evaluates_the_kriged_heat_flux_unchanged(
        small_rom: RomFluid) -> None:
    """The heat-flux path of a ROM without the field is the kriged flux through the same
    operations as before the field existed: the reference-grid prediction interpolated,
    bit for bit equal to the POD-kriging prediction with gradients on the identity grid."""
    assert small_rom.edge_temperature_model is None
    pts, st = rom_state(small_rom.geometry, 1.0, [1.5, 0.5, -0.3], nonuniform=False)
    d = small_rom.inputs(pts, st, small_rom.reference)
    coef, _ = small_rom.heat_model.predict_coefficients(d[None], gradient=True)
    q = small_rom.heat_model.pod_.reconstruct(coef)[0]
    loads = small_rom.with_options(correction="pt").evaluate(pts, st, small_rom.reference)
    # the Eq. (2.65) ratio at the reference is num / den of the same Eckert flux: one to
    # round-off (the mean wall temperature is a weighted sum)
    np.testing.assert_allclose(loads.heat_flux, q, rtol=1e-13, atol=0.0)
    np.testing.assert_array_equal(small_rom.reference_loads(d)[1][0],
                                  small_rom.heat_model.predict(d[None])[0])


@pytest.mark.parametrize("scale, mach, altitude, n_y", [
    (2.0, 7.0, 30000.0, 1), (1.0, 5.5, 22000.0, 1), (4.0, 6.5, 27000.0, 3)])
def test_edge_rom_jacobians_match_central_differences(edge_rom: RomFluid, scale: float,
                                                      mach: float, altitude: float,
                                                      n_y: int) -> None:
    """dq/d(w, w_s, w_dot, T_w) through the chain rule of the Eckert flux on the kriged p
    and T_e (complex-step partials) against extrapolated central differences, on a 2-D
    panel and strip-wise on a 3-D one at another flow and L_le (inviscid: any a / L_le)."""
    flow = FlowCondition.from_altitude(mach, altitude)
    a = 1.0 / scale
    pts = SurfacePoints.grid(a, a, 0.6 * a, 17 if n_y > 1 else 33, n_y)
    st = _strip_state(pts, scale, [3.0, -1.0, 0.5])
    J = edge_rom.evaluate(pts, st, flow, jacobians=True).jacobians
    fields = {"w": "displacement", "ws": "slope", "wdot": "velocity", "Tw": "wall_temperature"}
    steps = {"w": 4e-4 / scale, "ws": 2e-5, "wdot": 2e-3, "Tw": 2.0}  # as the tests above
    for key, name in fields.items():
        def f(v, name=name):
            kw = {k: getattr(st, k) for k in fields.values()}
            kw[name] = v
            return edge_rom.evaluate(pts, SurfaceState(**kw), flow).heat_flux

        fd, bound = richardson_jacobian(f, getattr(st, name), steps[key])
        an = dense(J["dq_d" + key])
        if not np.any(fd):
            assert not np.any(an), key
            continue
        assert_matches_richardson(an, fd, bound, key)


def test_edge_temperature_field_needs_a_scaled_rom(edge_rom: RomFluid) -> None:
    with pytest.raises(InputError, match="edge-temperature") as err:
        RomFluid(edge_rom.geometry, edge_rom.reference, edge_rom.pressure_model,
                 edge_rom.heat_model, kind="conventional",
                 edge_temperature_model=edge_rom.edge_temperature_model)
    assert err.value.field == "rom.edge_temperature"
