"""The installed ``hypate`` console script: help, condition, error handling."""
from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys

import pytest
from hypate.scaling.cli.main import COMMAND_MODULES, main


def _hypate(*args: str) -> subprocess.CompletedProcess:
    exe = shutil.which("hypate")
    cmd = [exe, *args] if exe else [sys.executable, "-m", "hypate.scaling.cli.main", *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=120)


def test_console_script_help_and_condition_json() -> None:
    out = _hypate("--help")
    assert out.returncode == 0 and "condition" in out.stdout and "validate" in out.stdout
    res = _hypate("condition", "--mach", "6", "--altitude", "25000", "--json")
    assert res.returncode == 0, res.stderr
    data = json.loads(res.stdout)
    assert set(data) == {"mach", "pressure", "temperature", "density", "velocity",
                         "speed_of_sound", "dynamic_pressure", "viscosity",
                         "reynolds_per_meter", "stagnation_pressure", "stagnation_temperature"}
    assert data["pressure"] == pytest.approx(2549.2, rel=1e-3)


def test_every_subcommand_has_help(capsys: pytest.CaptureFixture) -> None:
    # the subcommands as build_parser registers them: every module of the registry
    sub = argparse.ArgumentParser().add_subparsers(dest="command")
    for module in COMMAND_MODULES:
        module.register(sub)
    for name in sub.choices:
        with pytest.raises(SystemExit) as exc:
            main([name, "--help"])
        assert exc.value.code == 0, name
    assert len(sub.choices) >= 3


@pytest.mark.parametrize("args, field", [
    (["condition", "--mach", "0.5", "--altitude", "1000"], "mach"),
    (["condition", "--mach", "6", "--p0", "-1", "--T0", "1000"], "p0"),
    (["condition", "--mach", "6", "--p0", "1e6"], "--p0/--T0"),
    (["condition", "--mach", "6", "--altitude", "1", "--pressure", "1", "--temperature", "1"],
     "--altitude"),
])
def test_condition_errors(capsys: pytest.CaptureFixture, args: list[str], field: str) -> None:
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.startswith("hypate: error: ") and field in err and len(err.strip().splitlines()) == 1


def test_stagnation_condition_round_trip(capsys: pytest.CaptureFixture) -> None:
    assert main(["condition", "--mach", "7", "--p0", "2.96475e6", "--T0", "2127.778", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["stagnation_pressure"] == pytest.approx(2.96475e6, rel=1e-12)
    assert data["stagnation_temperature"] == pytest.approx(2127.778, rel=1e-12)


def test_usage_error_exit_code(capsys: pytest.CaptureFixture) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["condition"])
    assert exc.value.code == 2
