"""ROM persistence (solvers/aero/rom/io.py): round trip, the fluid-model factory, refused
files."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import rom_state
from hypate.solvers.aero.factory import make_fluid_model
from hypate.solvers.aero.rom.io import FORMAT_VERSION, load_rom
from hypate.solvers.aero.rom.model import RomFluid
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition


def test_save_load_roundtrip_and_fluid_model_factory(small_rom: RomFluid,
                                                     small_rom_file: Path) -> None:
    loaded = make_fluid_model(f"rom:{small_rom_file}")
    assert isinstance(loaded, RomFluid)
    with np.load(small_rom_file, allow_pickle=False) as npz:  # no object arrays anywhere
        assert int(npz["format_version"]) == FORMAT_VERSION
        assert npz["input_bounds"].shape == (4, 2)
    pts, st = rom_state(small_rom.geometry, 2.0, [1.0, 0.3, -0.2])
    flow = FlowCondition.from_altitude(7.0, 30000.0)
    a = small_rom.evaluate(pts, st, flow)
    b = loaded.evaluate(pts, st, flow)
    np.testing.assert_allclose(b.pressure, a.pressure, rtol=1e-9)
    np.testing.assert_allclose(b.heat_flux, a.heat_flux, rtol=1e-9)


def test_corrupted_or_foreign_files_are_refused(small_rom_file: Path, tmp_path: Path) -> None:
    raw = small_rom_file.read_bytes()
    trunc = tmp_path / "trunc.npz"
    trunc.write_bytes(raw[: len(raw) // 2])
    flipped = tmp_path / "flip.npz"
    flipped.write_bytes(raw[:200] + bytes([raw[200] ^ 0xFF]) + raw[201:])
    text = tmp_path / "text.npz"
    text.write_text("not a rom")
    with np.load(small_rom_file, allow_pickle=False) as npz:
        data = {k: npz[k] for k in npz.files}
    tampered = tmp_path / "tampered.npz"
    np.savez(tampered, **dict(data, pressure_mean=data["pressure_mean"] * 1.01))
    version = tmp_path / "version.npz"
    np.savez(version, **dict(data, format_version=np.array(99)))
    missing = tmp_path / "missing.npz"
    np.savez(missing, **{k: v for k, v in data.items() if k != "heat_flux_modes"})
    for path in (trunc, flipped, text, tampered, version, missing, tmp_path / "none.npz"):
        with pytest.raises(InputError):
            load_rom(path)
