"""ROM persistence (solvers/aero/rom/io.py): round trip, the fluid-model factory, refused
files."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import rom_state
from hypate.solvers.aero.base import dense
from hypate.solvers.aero.factory import make_fluid_model
from hypate.solvers.aero.rom import io as rom_io
from hypate.solvers.aero.rom.io import (
    EDGE_TEMPERATURE_FORMAT_VERSION,
    FORMAT_VERSION,
    load_rom,
    save_rom,
)
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


def test_edge_temperature_field_round_trip(edge_rom: RomFluid, tmp_path: Path) -> None:
    path = tmp_path / "edge.npz"
    save_rom(edge_rom, path)
    with np.load(path, allow_pickle=False) as npz:
        assert int(npz["format_version"]) == EDGE_TEMPERATURE_FORMAT_VERSION
        assert npz["edge_temperature_modes"].shape[0] == 33
    loaded = load_rom(path)
    assert loaded.edge_temperature_model is not None and loaded.inviscid
    pts, st = rom_state(edge_rom.geometry, 2.0, [1.0, 0.3, -0.2])
    flow = FlowCondition.from_altitude(7.0, 30000.0)
    a = edge_rom.evaluate(pts, st, flow, jacobians=True)
    b = loaded.evaluate(pts, st, flow, jacobians=True)
    # loading refits the Cholesky factors with the stored hyperparameters: round-off
    np.testing.assert_allclose(b.pressure, a.pressure, rtol=1e-9)
    np.testing.assert_allclose(b.heat_flux, a.heat_flux, rtol=1e-9)
    np.testing.assert_allclose(dense(b.jacobians["dq_dTw"]), dense(a.jacobians["dq_dTw"]),
                               rtol=1e-7, atol=1e-9 * np.abs(dense(a.jacobians["dq_dTw"])).max())


def test_a_rom_without_edge_field_keeps_the_first_layout(small_rom_file: Path) -> None:
    with np.load(small_rom_file, allow_pickle=False) as npz:
        assert int(npz["format_version"]) == FORMAT_VERSION == 1
        assert not any(k.startswith("edge_temperature") for k in npz.files)
    assert load_rom(small_rom_file).edge_temperature_model is None


def test_bad_or_missing_edge_members_are_refused_naming_them(
        edge_rom: RomFluid, tmp_path: Path,
        monkeypatch: pytest.MonkeyPatch) -> None:
    model = edge_rom.edge_temperature_model
    full = model.state
    # a member left out (the digest over what is written is valid)
    monkeypatch.setattr(model, "state", lambda prefix: {
        k: v for k, v in full(prefix).items() if k != f"{prefix}_theta"})
    save_rom(edge_rom, tmp_path / "missing.npz")
    with pytest.raises(InputError, match="edge_temperature_theta"):
        load_rom(tmp_path / "missing.npz")
    # a member of the wrong shape
    monkeypatch.setattr(model, "state", lambda prefix: dict(
        full(prefix), **{f"{prefix}_mean": full(prefix)[f"{prefix}_mean"][:-1]}))
    save_rom(edge_rom, tmp_path / "shape.npz")
    with pytest.raises(InputError, match="edge_temperature_mean"):
        load_rom(tmp_path / "shape.npz")
    # the layout's version and its members disagree
    monkeypatch.setattr(model, "state", full)
    monkeypatch.setattr(rom_io, "EDGE_TEMPERATURE_FORMAT_VERSION", FORMAT_VERSION)
    save_rom(edge_rom, tmp_path / "version.npz")
    monkeypatch.undo()
    with pytest.raises(InputError, match="format version 1 cannot hold the edge_temperature"):
        load_rom(tmp_path / "version.npz")
