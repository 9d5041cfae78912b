"""``hypate heat`` (scaling/commands/thermal.py): public JSON and input errors."""
from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from hypate.scaling.cli.main import main
from hypate.solvers.materials import STEFAN_BOLTZMANN

RHO, CP, K, H = 8000.0, 500.0, 20.0, 0.004

PANEL = """
[panel]
kind = "3d"
length = 0.2
width = 0.2
mesh = [2, 2]
initial_temperature = 300.0
emissivity = {eps}

[[panel.layers]]
material = "slab"
thickness = {h}
sublayers = 16

[materials.slab]
density = {rho}
youngs_modulus = 2.0e11
poisson_ratio = 0.3
thermal_expansion = 1.0e-5
conductivity = {k}
specific_heat = {cp}
"""


def _panel(tmp_path: Path, eps: float) -> str:
    path = tmp_path / f"slab_{eps}.toml"
    path.write_text(PANEL.format(eps=eps, h=H, rho=RHO, k=K, cp=CP))
    return str(path)


def _heat(capsys: pytest.CaptureFixture, *args: str) -> tuple[int, str, str]:
    code = main(["heat", *args])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_heat_json_insulated_slab(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    q, dt, duration = 1e5, 0.5, 12.25
    code, out, err = _heat(capsys, _panel(tmp_path, 0.0), "--flux", str(q), "--duration",
                           str(duration), "--time-step", str(dt), "--json")
    assert code == 0, err
    data = json.loads(out)
    assert set(data) == {"times", "top_temperature", "bottom_temperature",
                         "mean_temperature"}
    n = len(data["times"])
    assert all(len(v) == n for v in data.values())
    assert data["times"][0] == 0.0 and data["times"][-1] == duration  # short last step
    assert n == 26
    # emissivity 0: no radiation, insulated elsewhere -> the mean temperature rises exactly
    # by q t / (rho c_p h) (energy conservation; round-off tolerance)
    for t, Tm in zip(data["times"], data["mean_temperature"]):
        assert Tm == pytest.approx(300.0 + q * t / (RHO * CP * H), rel=1e-10, abs=1e-9)
    # top/bottom against the Carslaw & Jaeger series (materials.md) at the end, Fo ~ 0.38;
    # 0.5 % of the temperature rise (coarse dt = 0.5 s, 16 sub-layers)
    Fo = K * duration / (RHO * CP * H**2)
    n_ = range(1, 200)
    top = q * H / K * (Fo + 1 / 3 - 2 / math.pi**2 * sum(
        math.exp(-(m**2) * math.pi**2 * Fo) / m**2 for m in n_))
    bot = q * H / K * (Fo - 1 / 6 - 2 / math.pi**2 * sum(
        (-1) ** m * math.exp(-(m**2) * math.pi**2 * Fo) / m**2 for m in n_))
    assert data["top_temperature"][-1] - 300.0 == pytest.approx(top, rel=5e-3)
    assert data["bottom_temperature"][-1] - 300.0 == pytest.approx(bot, rel=5e-3)


def test_heat_radiative_equilibrium(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    q, eps, T_rad = 2e4, 0.8, 250.0
    code, out, err = _heat(capsys, _panel(tmp_path, eps), "--flux", str(q), "--duration",
                           "6000", "--time-step", "20", "--T-rad", str(T_rad), "--json")
    assert code == 0, err
    data = json.loads(out)
    T_eq = (q / (eps * STEFAN_BOLTZMANN) + T_rad**4) ** 0.25
    # long run to steady state: radiation balances the flux (ringing of CN decays slowly
    # at this dt; 1e-4 relative)
    assert data["top_temperature"][-1] == pytest.approx(T_eq, rel=1e-4)
    assert data["mean_temperature"][-1] == pytest.approx(T_eq, rel=1e-4)


def test_heat_text_output(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    code, out, err = _heat(capsys, _panel(tmp_path, 0.85), "--flux", "5e4", "--duration",
                           "2", "--time-step", "1")
    assert code == 0, err
    assert "top (K)" in out and len(out.splitlines()) == 5


@pytest.mark.parametrize("args, option", [
    (["--flux", "1e4", "--duration", "-1", "--time-step", "0.1"], "--duration"),
    (["--flux", "1e4", "--duration", "1", "--time-step", "0"], "--time-step"),
    (["--flux", "1e4", "--duration", "1", "--time-step", "nan"], "--time-step"),
    (["--flux", "inf", "--duration", "1", "--time-step", "0.1"], "--flux"),
    (["--flux", "1e4", "--duration", "1", "--time-step", "0.1", "--T-rad", "-5"], "--T-rad"),
    (["--flux", "1e4", "--duration", "1e9", "--time-step", "1e-3"], "--time-step"),
])
def test_heat_bad_inputs_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture, args,
                                option) -> None:
    code, out, err = _heat(capsys, _panel(tmp_path, 0.5), *args, "--json")
    assert code == 2
    assert option in err and "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_heat_missing_file_and_missing_option(tmp_path: Path,
                                              capsys: pytest.CaptureFixture) -> None:
    code, _, err = _heat(capsys, str(tmp_path / "nope.toml"), "--flux", "1", "--duration",
                         "1", "--time-step", "1")
    assert code == 2 and "nope.toml" in err
    with pytest.raises(SystemExit) as exc:
        main(["heat", _panel(tmp_path, 0.5), "--duration", "1", "--time-step", "1"])
    assert exc.value.code == 2
