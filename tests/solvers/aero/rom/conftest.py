"""Fixtures of the ROM tests: the small 2-D ROM (built once per module) and its file, and
a small ROM with an edge-temperature field."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import SMALL_ROM
from hypate.solvers.aero.rom.build import build_rom, build_rom_from_config, geometry_from_config
from hypate.solvers.aero.rom.config import parse_rom_config
from hypate.solvers.aero.rom.io import save_rom
from hypate.solvers.aero.rom.model import RomFluid
from hypate.solvers.aero.rom.plan import olh_plan
from hypate.solvers.aero.rom.snapshots import generate_samples
from hypate.solvers.aero.shock_expansion import eckert_heat_flux_edge


@pytest.fixture(scope="module")
def small_rom() -> RomFluid:
    return build_rom_from_config(parse_rom_config(SMALL_ROM))


@pytest.fixture(scope="module")
def small_rom_file(small_rom: RomFluid, tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("rom") / "small.npz"
    save_rom(small_rom, path)
    return path


#: The sample source of :func:`edge_rom`: an inviscid OpenFOAM-Euler ROM's description.
EULER_SOURCE = {"kind": "openfoam", "model": "euler", "boundary_layer": False,
                "regime": "turbulent"}


@pytest.fixture(scope="module")
def edge_rom() -> RomFluid:
    """A small ROM with an edge-temperature field laid out as the OpenFOAM source's Euler
    snapshots, without OpenFOAM: the pressure of the shock-expansion march without boundary
    layer, an edge temperature (isentropic from that pressure, times a deformation-dependent
    factor so that it is no function of p alone) and Eckert's flux on both as the heat flux."""
    cfg = parse_rom_config(dict(SMALL_ROM, source={"kind": "shock-expansion",
                                                   "boundary_layer": False}))
    g = geometry_from_config(cfg)
    ref = cfg.reference.flow()
    bounds = np.vstack([[m.range for m in cfg.modes], [cfg.wall_temperature.range]])
    D = olh_plan(bounds, 50, 3)
    P, _ = generate_samples(g, D[:, :-1], D[:, -1], ref,
                            source={"kind": "shock-expansion", "boundary_layer": False})
    x = g.points(1.0).x
    iso = ((ref.pressure + P) / ref.pressure) ** ((ref.gamma - 1.0) / ref.gamma)
    T_e = ref.temperature * iso * (1.0 + 0.02 * D[:, :1] * np.sin(np.pi * x))
    Q = eckert_heat_flux_edge(ref, ref.pressure + P, T_e, D[:, -1:], g.points(1.0).x_le)
    rom = build_rom(g, ref, D, P, Q, bounds=bounds, n_restarts=0, optimized_modes=2,
                    source=EULER_SOURCE, rng=3, edge_temperature=T_e)
    rom.provenance = {"model": "euler"}  # as a CFD build records it (and a file keeps it)
    return rom
