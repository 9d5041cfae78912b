"""Fixtures of the ROM tests: the small 2-D ROM (built once per module) and its file."""
from __future__ import annotations

from pathlib import Path

import pytest
from conftest import SMALL_ROM
from hypate.solvers.aero.rom.build import build_rom_from_config
from hypate.solvers.aero.rom.config import parse_rom_config
from hypate.solvers.aero.rom.io import save_rom
from hypate.solvers.aero.rom.model import RomFluid


@pytest.fixture(scope="module")
def small_rom() -> RomFluid:
    return build_rom_from_config(parse_rom_config(SMALL_ROM))


@pytest.fixture(scope="module")
def small_rom_file(small_rom: RomFluid, tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("rom") / "small.npz"
    save_rom(small_rom, path)
    return path
