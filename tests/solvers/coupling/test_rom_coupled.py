"""Issue 7: a coupled TC run with the ROM reproduces the run with the built-in source."""
from __future__ import annotations

import tomllib
import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import REPO
from hypate.solvers.aero.rom.build import build_rom_from_config
from hypate.solvers.aero.rom.config import load_rom_config
from hypate.solvers.aero.rom.io import save_rom
from hypate.solvers.config import parse_case
from hypate.solvers.coupling.run import simulate

CASE = """
[panel]
kind = "2d"
length = 1.0
boundary = "simply_supported"
leading_edge_length = 1.0
mesh = [16]
emissivity = 0.85
[[panel.layers]]
material = "al7075"
thickness = 0.0025
sublayers = 2
[flow]
mach = 6.0
altitude = 25000.0
[simulation]
scheme = "tc"
aero = "{aero}"
heating = "eckert"
time_step = 0.1
duration = 6.0
"""


@pytest.mark.slow
def test_tc_run_with_rom_matches_built_in_source(tmp_path: Path) -> None:
    # the Sec. 7.1 2D panel (a = 1 m, h = 2.5 mm, L_le = 1 m) in its ROM's reference flow
    rom = tmp_path / "rom.npz"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cfg, base = load_rom_config(REPO / "studies" / "rom" / "rom_2d_panel.toml")
        save_rom(build_rom_from_config(cfg, base), rom)
        runs = {}
        for name, aero in (("source", "se"), ("rom", f"rom:{rom.as_posix()}")):
            case = parse_case(tomllib.loads(CASE.format(aero=aero)))
            runs[name] = simulate(case.panel, case.flow, case.simulation, keep_fields=False)
    a, b = runs["source"], runs["rom"]
    assert a.status == b.status
    n = min(len(a.times), len(b.times))
    wa, wb = np.asarray(a.center_deflection[1:n]), np.asarray(b.center_deflection[1:n])
    # acceptance (issue 7): centre deflection within 5 % (measured 2.1 %)
    assert np.max(np.abs(wa - wb)) <= 0.05 * np.max(np.abs(wa))
