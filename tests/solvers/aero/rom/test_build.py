"""Building and checking ROMs (solvers/aero/rom/build.py): progress reporting, and the
Sec. 7.1 acceptance sizes (``slow``)."""
from __future__ import annotations

import numpy as np
import pytest
from conftest import ROM_STUDY, SMALL_ROM
from hypate.solvers.aero.rom.build import BUILD_STEPS, build_rom_from_config, check_rom
from hypate.solvers.aero.rom.config import load_rom_config, parse_rom_config
from hypate.solvers.aero.rom.model import RomFluid
from hypate.solvers.flow import FlowCondition


@pytest.fixture(scope="module")
def study_rom() -> RomFluid:
    cfg, base = load_rom_config(ROM_STUDY)
    assert cfg.training.samples <= 200
    return build_rom_from_config(cfg, base)


def test_build_reports_every_step_in_order_and_the_same_rom() -> None:
    calls: list[tuple[str, int, int]] = []
    cfg = parse_rom_config(SMALL_ROM)
    rom = build_rom_from_config(cfg, progress=lambda *c: calls.append(c))
    assert [s for s in dict.fromkeys(c[0] for c in calls)] == list(BUILD_STEPS)
    for step in BUILD_STEPS:
        done = [c[1] for c in calls if c[0] == step]
        totals = {c[2] for c in calls if c[0] == step}
        assert len(totals) == 1 and done == sorted(done) and done[-1] == totals.pop(), step
    # 50 samples in one chunk of 50; each POD-kriging counts one by one: the POD, a fit per
    # optimized coefficient (at least one), the multi-output model
    assert [c for c in calls if c[0] == "snapshots"] == [("snapshots", 50, 50)]
    for step in BUILD_STEPS[1:]:
        done = [c[1] for c in calls if c[0] == step]
        assert done == list(range(1, len(done) + 1)) and len(done) >= 3, step
    # reporting does not change the build
    quiet = build_rom_from_config(cfg)
    np.testing.assert_array_equal(rom.pressure_model.gp_.theta_, quiet.pressure_model.gp_.theta_)


@pytest.mark.slow
def test_sec71_rom_converges_with_200_samples(study_rom: RomFluid) -> None:
    res = check_rom(study_rom, 100, rng=2024)
    # acceptance (Sec. 7.1, Fig. 7.3): < 1 % pressure, < 2 % heat flux on 100 held-out
    # samples; measured 0.16 % and 0.23 %
    assert res["pressure_nrmse"] < 0.01 and res["heat_flux_nrmse"] < 0.02, res


@pytest.mark.slow
def test_correction_and_scaling_fig76_analogue(study_rom: RomFluid) -> None:
    results = {}
    for mach in (5.0, 6.0, 7.0):
        for alt in (20000.0, 25000.0, 30000.0):
            flow = FlowCondition.from_altitude(mach, alt)
            for xi in (1.0, 2.0, 4.0):
                for corr in ("bl", "pt"):
                    results[mach, alt, xi, corr] = check_rom(
                        study_rom.with_options(correction=corr), 30, flow, xi, "eq76", rng=1)
    bl = np.array([[r["pressure_nrmse"], r["heat_flux_nrmse"]]
                   for k, r in results.items() if k[3] == "bl"])
    pt = np.array([[r["pressure_nrmse"], r["heat_flux_nrmse"]]
                   for k, r in results.items() if k[3] == "pt"])
    # acceptance: corrected ROM (default BL) < 10 % in pressure and heat flux everywhere;
    # BL beats PT for pressure on average (measured mean 0.35 % vs 8.3 %)
    assert bl.max() < 0.10, bl.max(axis=0)
    assert bl[:, 0].mean() < pt[:, 0].mean()


@pytest.mark.slow
def test_nonuniform_wall_temperature_eq76(study_rom: RomFluid) -> None:
    res = check_rom(study_rom, 100, temperature="eq76", rng=5)
    # acceptance: heat-flux NRMSE < 10 % with the Eq. (7.6) non-uniform wall temperature
    assert res["heat_flux_nrmse"] < 0.10 and res["pressure_nrmse"] < 0.10, res
