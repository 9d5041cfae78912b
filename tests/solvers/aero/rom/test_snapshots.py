"""ROM snapshots (solvers/aero/rom/snapshots.py): external NPZ/CSV files, the built-in
source in parallel."""
from __future__ import annotations

import csv
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest
from conftest import SMALL_ROM
from hypate.solvers.aero.rom.build import (
    build_rom_from_config,
    check_rom,
    geometry_from_config,
)
from hypate.solvers.aero.rom.config import parse_rom_config
from hypate.solvers.aero.rom.plan import olh_plan
from hypate.solvers.aero.rom.snapshots import generate_samples, read_snapshots
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition


def test_external_snapshots_npz_and_csv(tmp_path: Path) -> None:
    cfg = parse_rom_config(SMALL_ROM)
    geom = geometry_from_config(cfg)
    D = olh_plan(np.array([[-6, 6], [-2, 2], [-2, 2], [200, 900]], float), 20, 5)
    P, Q = generate_samples(geom, D[:, :3], D[:, 3], cfg.reference.flow())
    pts = geom.points()
    np.savez(tmp_path / "snap.npz", inputs=D, pressure=P, heat_flux=Q, x=pts.x, y=pts.y)
    with open(tmp_path / "snap.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["sample", "a1", "a2", "a3", "T_w", "x", "y", "pressure", "heat_flux"])
        for i in range(D.shape[0]):
            for k in reversed(range(pts.n)):  # any row order
                w.writerow([i, *D[i], pts.x[k], pts.y[k], P[i, k], Q[i, k]])
    for name in ("snap.npz", "snap.csv"):
        d2, p2, q2 = read_snapshots(tmp_path / name, geom)
        np.testing.assert_allclose(d2, D, rtol=1e-12)
        np.testing.assert_allclose(p2, P, rtol=1e-12)
        np.testing.assert_allclose(q2, Q, rtol=1e-12)
    data = dict(SMALL_ROM, source={"kind": "snapshots", "path": "snap.csv"})
    rom = build_rom_from_config(parse_rom_config(data), base_dir=tmp_path)
    assert rom.source["kind"] == "snapshots"
    with pytest.raises(InputError, match="external snapshots"):
        check_rom(rom, 3)
    np.savez(tmp_path / "bad.npz", inputs=D[:, :2], pressure=P, heat_flux=Q)
    with pytest.raises(InputError, match="inputs must have shape"):
        read_snapshots(tmp_path / "bad.npz", geom)
    np.savez(tmp_path / "badx.npz", inputs=D, pressure=P, heat_flux=Q, x=pts.x * 1.1)
    with pytest.raises(InputError, match="grid"):
        read_snapshots(tmp_path / "badx.npz", geom)


def test_parallel_generation_equals_serial() -> None:
    geom = geometry_from_config(parse_rom_config(SMALL_ROM))
    A = np.random.default_rng(0).uniform(-1, 1, (23, 3))
    T = np.linspace(300, 800, 23)
    flow = FlowCondition.from_altitude(6.0, 25000.0)
    serial = generate_samples(geom, A, T, flow)
    with ThreadPoolExecutor(2) as pool:
        par = generate_samples(geom, A, T, flow, executor=pool, chunk_size=5)
    # equal up to the batch-dependent stopping of the Prandtl-Meyer Newton iteration
    np.testing.assert_allclose(par[0], serial[0], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(par[1], serial[1], rtol=1e-9)
