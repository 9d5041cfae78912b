"""The ROM fluid model (solvers/aero/rom/model.py): accuracy, corrections, Jacobians
(Eqs. 2.74-2.76) against finite differences, other grids, geometric similarity, the
conventional ROM."""
from __future__ import annotations

import numpy as np
import pytest
from conftest import SMALL_ROM, assert_matches_richardson, richardson_jacobian, rom_state
from hypate.solvers.aero.base import SurfacePoints, SurfaceState, dense
from hypate.solvers.aero.rom.build import build_rom_from_config, check_rom, nrmse
from hypate.solvers.aero.rom.config import parse_rom_config
from hypate.solvers.aero.rom.model import RomFluid
from hypate.solvers.aero.rom.snapshots import generate_samples
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
    wide = SurfacePoints.grid(1.0, 1.0, 1.0, 33, 4)
    with pytest.raises(InputError, match="2D panel"):
        small_rom.evaluate(wide, SurfaceState.flat(wide.n, 500.0), flow)


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
