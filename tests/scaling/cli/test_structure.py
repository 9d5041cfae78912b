"""``hypate modes|buckling|static`` and ``hypate bench structure`` (public JSON of issue 4)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypate.scaling.cli.main import main

PANEL = """
[panel]
kind = "3d"
length = 1.0
width = 1.0
boundary = "simply_supported"
mesh = [4, 4]
initial_temperature = 300.0

[[panel.layers]]
material = "plate"
thickness = 0.002

[materials.plate]
kind = "isotropic"
density = 8220.0
youngs_modulus = 204.0e9
poisson_ratio = 0.29
thermal_expansion = 1.237e-5
conductivity = 11.71
specific_heat = 418.4
"""


@pytest.fixture()
def panel_file(tmp_path: Path) -> str:
    path = tmp_path / "panel.toml"
    path.write_text(PANEL)
    return str(path)


def _json(capsys: pytest.CaptureFixture[str], *argv: str) -> dict:
    assert main(list(argv)) == 0
    return json.loads(capsys.readouterr().out)


def test_modes_json(panel_file: str, capsys: pytest.CaptureFixture[str]) -> None:
    # Sec. 9.1 prototype plate (Table 9.1 properties) on a 4 x 4 mesh: f11 of the Navier
    # solution pi/2 * 2/a^2 sqrt(D/(rho h)) = 9.44 Hz within 0.5 %.
    out = _json(capsys, "modes", panel_file, "--count", "4", "--json")
    assert set(out) == {"frequencies_hz"}
    f = np.array(out["frequencies_hz"])
    assert f.shape == (4,) and np.all(np.diff(f) >= 0)
    D = 204e9 * 0.002**3 / (12 * (1 - 0.29**2))
    assert f[0] == pytest.approx(np.pi * np.sqrt(D / (8220 * 0.002)), rel=5e-3)
    hot = _json(capsys, "modes", panel_file, "--count", "2", "--delta-T", "0.2", "--json")
    assert hot["frequencies_hz"][0] < f[0]          # heating softens the panel


def test_buckling_json(panel_file: str, capsys: pytest.CaptureFixture[str]) -> None:
    # 0.4123 K (Sec. 9.1), 2 % (issue 4)
    out = _json(capsys, "buckling", panel_file, "--json")
    assert set(out) == {"critical_delta_T"}
    assert out["critical_delta_T"] == pytest.approx(0.4123, rel=0.02)


def test_static_json(panel_file: str, capsys: pytest.CaptureFixture[str]) -> None:
    out = _json(capsys, "static", panel_file, "--pressure", "100", "--json")
    assert set(out) == {"center_deflection", "max_deflection"}
    assert out["center_deflection"] > 0.0            # positive pressure pushes towards +z
    assert out["max_deflection"] == pytest.approx(out["center_deflection"], rel=1e-9)
    hot = _json(capsys, "static", panel_file, "--pressure", "0", "--delta-T", "1.0", "--json")
    assert abs(hot["center_deflection"]) > 1e-4      # buckled at 2.4 T_cr


def test_human_output_and_errors(panel_file: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["buckling", panel_file]) == 0
    assert "critical uniform temperature rise" in capsys.readouterr().out
    assert main(["modes", panel_file, "--count", "0"]) == 2
    assert "--count" in capsys.readouterr().err
    assert main(["static", panel_file, "--pressure", "nan"]) == 2
    assert main(["modes", str(Path(panel_file).with_name("missing.toml"))]) == 2


def test_bench_structure_json(capsys: pytest.CaptureFixture[str]) -> None:
    out = _json(capsys, "bench", "structure", "--mesh", "3", "--repeat", "1", "--json")
    assert out["n_dof"] == 5 * 7 * 7
    assert out["assembly_s"] > 0 and out["ratio_assembly_to_factorization"] > 0
    assert out["fastest_factorization"] in out["factorization_s"]
