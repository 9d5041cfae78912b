"""The OpenFOAM snapshot source: tiny real builds (Euler, coarse mesh), resume without
re-running finished snapshots, provenance and held-out check in the ROM file."""
from __future__ import annotations

import copy
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from importlib import resources

import numpy as np
import pytest
from hypate.solvers.aero.rom import openfoam as source
from hypate.solvers.aero.rom.build import (
    build_rom_from_config,
    check_holdout,
    geometry_from_config,
    nrmse,
)
from hypate.solvers.aero.rom.config import parse_rom_config
from hypate.solvers.aero.rom.io import load_rom, save_rom
from hypate.solvers.aero.rom.openfoam import resample, snapshot_spec
from hypate.solvers.aero.rom.openfoam_case import Resolution
from hypate.solvers.aero.rom.openfoam_run import CaseResult, find_openfoam
from hypate.solvers.aero.shock_expansion import ShockExpansionFluid
from hypate.solvers.errors import InputError

needs_openfoam = pytest.mark.skipif(
    shutil.which("rhoCentralFoam") is None, reason="OpenFOAM is not installed (apt-get "
    "install openfoam; .ci/run installs it as root)")

#: A two-mode 2-D panel on a coarse CFD mesh (about a second a snapshot).
TINY = {
    "panel": {"kind": "2d", "length": 1.0, "leading_edge_length": 1.0, "thickness": 0.0025},
    "grid": {"n_x": 17},
    "reference": {"mach": 6.0, "altitude": 25000.0},
    "modes": [{"m": 1, "range": [-4.0, 4.0]}, {"m": 2, "range": [-2.0, 2.0]}],
    "wall_temperature": {"range": [300.0, 900.0]},
    "source": {"kind": "openfoam", "model": "euler", "holdout": 2, "timeout": 120.0,
               "resolution": {"cells_panel": 16, "cells_plate": 4, "cells_normal": 16,
                              "wall_cell": 0.01, "height": 0.4, "max_iterations": 6000,
                              "sample_every": 25, "window": 8, "tolerance": 1e-3}},
    "training": {"samples": 6, "seed": 0, "restarts": 0, "optimized_modes": 1},
}


def test_resample_is_linear_inside_and_beyond_the_faces():
    x = np.array([0.5, 1.5, 2.5])
    v = 2.0 * x + 1.0
    assert np.allclose(resample(x, v, np.array([0.0, 1.0, 3.0])), [1.0, 3.0, 7.0])


def test_snapshot_wall_follows_the_modes():
    cfg = parse_rom_config(copy.deepcopy(TINY))
    settings = source.OpenFoamSettings("euler", Resolution(cells_panel=16))
    spec = snapshot_spec(geometry_from_config(cfg), np.array([2.0, -1.0]), 500.0,
                         cfg.reference.flow(), settings)
    x = spec.panel[:, 0] - 1.0
    w = 0.0025 * (2.0 * np.sin(np.pi * x) - np.sin(2.0 * np.pi * x))
    assert np.allclose(spec.panel[:, 1], w, atol=1e-15)
    assert spec.panel[0, 1] == 0.0 and spec.panel[-1, 1] == 0.0


def test_openfoam_source_needs_a_2d_panel():
    data = copy.deepcopy(TINY)
    data["panel"]["kind"] = "3d"
    data["grid"]["n_y"] = 3
    with pytest.raises(InputError, match="2d snapshots"):
        parse_rom_config(data)


def test_unknown_model_is_refused_naming_the_key():
    data = copy.deepcopy(TINY)
    data["source"]["model"] = "rans"
    with pytest.raises(InputError) as err:
        parse_rom_config(data)
    assert "source.model" in err.value.field


def test_a_diverged_snapshot_is_run_again_at_half_the_courant_number(tmp_path, monkeypatch):
    """The retry policy of run_snapshot, on a stand-in solver (no OpenFOAM needed): diverged
    starts are run again at Co / 2, Co / 4; any other failure is final."""
    cfg = parse_rom_config(copy.deepcopy(TINY))
    g = geometry_from_config(cfg)
    flow = cfg.reference.flow()
    settings = source.OpenFoamSettings("euler", Resolution(courant=0.2), timeout=60.0)
    x = 1.0 + np.linspace(0.0, 1.0, 17)[:-1] + 1.0 / 32.0  # face centres of 16 cells
    seen = []

    def solver(folder, openfoam, resolution, viscous, timeout=None, converge_below=0.1):
        seen.append(resolution.courant)
        if resolution.courant > converge_below:  # the impulsive start blows up
            return CaseResult(False, "rhoCentralFoam failed: floating point exception (the "
                              "solution diverged)", cpu_seconds=1.0, diverged=True)
        return CaseResult(True, x=x, y=0 * x, pressure=np.full(16, flow.pressure),
                          temperature=np.full(16, flow.temperature), heat_flux=0 * x,
                          iterations=500, cpu_seconds=2.0)

    monkeypatch.setattr(source, "run_case", solver)
    record = source.run_snapshot(g, np.array([2.0, 0.0, 500.0]), flow, settings, None,
                                 tmp_path)
    assert seen == [0.2, 0.1] and record.converged and record.courant == 0.1
    assert record.seconds == 3.0 and np.allclose(record.pressure, 0.0)
    seen.clear()  # never converging: rejected after 1 + DIVERGED_RETRIES attempts
    monkeypatch.setattr(source, "run_case", lambda *a, **k: solver(*a, **k, converge_below=0))
    record = source.run_snapshot(g, np.array([2.0, 0.0, 500.0]), flow, settings, None,
                                 tmp_path)
    assert seen == [0.2, 0.1, 0.05] and not record.converged
    assert "diverged" in record.reason and record.courant == 0.05
    seen.clear()  # a failure that is not a divergence is final
    monkeypatch.setattr(source, "run_case", lambda *a, **k: seen.append(1) or CaseResult(
        False, "not converged after 100 iterations"))
    record = source.run_snapshot(g, np.array([2.0, 0.0, 500.0]), flow, settings, None,
                                 tmp_path)
    assert seen == [1] and record.reason == "not converged after 100 iterations"


@needs_openfoam
def test_tiny_cfd_rom_resumes_without_rerunning(tmp_path, monkeypatch):
    cfg = parse_rom_config(copy.deepcopy(TINY))
    store = tmp_path / "store"
    runs = []
    real = source.run_case
    monkeypatch.setattr(source, "run_case", lambda *a, **k: runs.append(1) or real(*a, **k))
    rom = build_rom_from_config(cfg, store=store)
    assert len(runs) == 8  # 6 training + 2 held out
    prov = rom.provenance
    assert prov["openfoam_version"] == find_openfoam().version and prov["model"] == "euler"
    assert prov["snapshots"] == 6 and prov["holdout"] == 2 and prov["rejected"] == 0
    # the held-out CFD snapshots against the shock-expansion march (no boundary layer) on
    # the same deformed panel: within 15 % of each snapshot's range in the NRMSE of
    # Eq. (7.7) on this 16-cell panel (measured 9 and 11 %: the corners at the supports are
    # smeared over a cell, 1/16 of the panel; a wrong sign or mode would give ~100 %)
    g = geometry_from_config(cfg)
    X, P = rom.holdout[0], rom.holdout[1]
    _, ws = g.deformation(X[:, :-1])
    se, _ = ShockExpansionFluid(boundary_layer=False, heating="none").evaluate_batch(
        g.points(), ws, 0.0, np.repeat(X[:, -1:], g.n_x, axis=1), cfg.reference.flow())
    assert np.all(nrmse(se, P, g.points().weights) < 0.15)
    # a killed build: drop two finished snapshots, resume: only those two run again
    files = sorted(store.glob("*.npz"))
    for f in files[:2]:
        f.unlink()
    with pytest.raises(InputError, match="--resume"):
        build_rom_from_config(cfg, store=store)
    runs.clear()
    again = build_rom_from_config(cfg, store=store, resume=True)
    assert len(runs) == 2
    assert np.array_equal(again.holdout[1], rom.holdout[1])
    # the provenance and the held-out set survive the file
    save_rom(again, tmp_path / "rom.npz")
    loaded = load_rom(tmp_path / "rom.npz")
    assert loaded.provenance == again.provenance
    check = check_holdout(loaded)
    assert check["samples"] == 2
    assert 0.0 <= check["pressure"]["nrmse_median"] <= check["pressure"]["nrmse_max"]


@needs_openfoam
def test_unconverged_snapshots_are_left_out_with_their_reason(tmp_path):
    data = copy.deepcopy(TINY)
    data["source"]["resolution"]["max_iterations"] = 100  # stopped long before convergence
    with pytest.raises(InputError, match="not converged after 100 iterations"):
        build_rom_from_config(parse_rom_config(data), store=tmp_path / "s")


def _toml(data: dict, prefix: str = "") -> str:
    """A small TOML writer for the nested build-file dict of this module."""
    lines, tables = [], []
    for key, value in data.items():
        if isinstance(value, dict):
            tables.append((f"{prefix}{key}", value))
        elif isinstance(value, list) and value and isinstance(value[0], dict):
            for item in value:
                lines.append(f"[[{prefix}{key}]]")
                lines += [f"{k} = {json.dumps(v)}" for k, v in item.items()]
        else:
            lines.insert(0, f"{key} = {json.dumps(value)}")
    out = "\n".join(lines) + "\n"
    for name, table in tables:
        out += f"[{name}]\n" + _toml(table, f"{name}.")
    return out


@needs_openfoam
def test_killed_cli_build_resumes_without_rerunning(tmp_path):
    """hypate rom build killed (SIGKILL) after some snapshots: --resume runs only the rest."""
    config = tmp_path / "tiny.toml"
    config.write_text(_toml(copy.deepcopy(TINY)), encoding="utf-8")
    out = tmp_path / "rom.npz"
    store = tmp_path / "rom.snapshots"
    cmd = [sys.executable, "-m", "hypate.scaling.cli.main", "rom", "build", str(config),
           "--out", str(out), "-q"]
    proc = subprocess.Popen(cmd)
    deadline = time.monotonic() + 120.0
    while len(list(store.glob("*.npz"))) < 3 and time.monotonic() < deadline:
        time.sleep(0.05)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    finished = {f.name: f.stat().st_mtime_ns for f in store.glob("*.npz")}
    assert 3 <= len(finished) < 8 and not out.exists()
    refused = subprocess.run(cmd, capture_output=True, text=True)
    assert refused.returncode == 2 and "--resume" in refused.stderr
    subprocess.run(cmd + ["--resume"], check=True)
    assert out.is_file() and len(list(store.glob("*.npz"))) == 8
    # the finished snapshots were reused as they were, not computed again
    assert all((store / name).stat().st_mtime_ns == t for name, t in finished.items())


def test_shipped_cfd_rom_holds_its_provenance_and_held_out_errors():
    """studies/rom/rom_2d_panel_cfd.npz: OpenFOAM provenance and held-out NRMSE (Eq. 7.7)
    below 5 % of each snapshot's range for p and q (the issue's acceptance)."""
    rom = load_rom(resources.files("hypate.studies").joinpath("rom", "rom_2d_panel_cfd.npz"))
    prov = rom.provenance
    assert prov["solver"].startswith("OpenFOAM") and prov["model"] == "euler"
    assert prov["snapshots"] >= 100 and prov["holdout"] >= 20
    assert rom.edge_temperature_model is not None  # q: Eckert on the kriged p and T_e
    check = check_holdout(rom)
    assert check["pressure"]["nrmse_max"] < 0.05
    assert check["heat_flux"]["nrmse_max"] < 0.05
