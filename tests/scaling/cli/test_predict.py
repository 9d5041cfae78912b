"""``hypate predict``: outputs, JSON, and every bad measured file ending in exit code 2 with
one line naming the column, nothing written."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypate.scaling.cli.main import main
from hypate.solvers.coupling.response import Response


def _model_csv(run_dir: Path, path: Path, noise: float = 0.0) -> Path:
    model = Response.load(run_dir / "design_point.npz")
    rng = np.random.default_rng(0)
    w = np.asarray(model.center_deflection)
    T = np.asarray(model.mean_temperature)
    pd.DataFrame({"time [ms]": 1e3 * np.asarray(model.times),
                  "center_deflection [mm]": 1e3 * (w + noise * np.std(w)
                                                   * rng.standard_normal(w.size)),
                  "mean_temperature [degC]": T - 273.15}).to_csv(path, index=False)
    return path


def test_json_summary_and_outputs(prediction_run, tmp_path, capsys):
    csv = _model_csv(prediction_run, tmp_path / "test.csv", noise=0.02)
    out = tmp_path / "out"
    assert main(["predict", str(prediction_run), "--measured", str(csv), "--out", str(out),
                 "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["source"] == "design point" and summary["points"] == 21
    assert summary["prototype_time_step"] == 8.0
    for name, unit in (("center_deflection", "m"), ("mean_temperature", "K")):
        h = summary["histories"][name]
        assert h["unit"] == unit and h["half_width"] > 0 and h["in_band"] >= 0.95
        # the parts add up as stated: H = B + sqrt(scatter^2 + measurement^2)
        assert h["half_width"] == pytest.approx(h["residual"] + h["measurement"], rel=1e-12)
    assert summary["scatter_source"].startswith("none")
    files = {Path(p).name for p in summary["files"].values()}
    assert files == {"prediction.csv", "prediction.json", "prediction.png", "prediction.html"}
    assert sorted(p.name for p in out.iterdir()) == sorted(files)  # no temporary left
    table = pd.read_csv(out / "prediction.csv")
    assert list(table.columns) == [
        "time [s]", "model_time [s]", "center_deflection [m]", "center_deflection_lower [m]",
        "center_deflection_upper [m]", "simulated_center_deflection [m]",
        "mean_temperature [K]", "mean_temperature_lower [K]", "mean_temperature_upper [K]",
        "simulated_mean_temperature [K]"]
    np.testing.assert_allclose(table["time [s]"] / 8.0, np.arange(21), atol=1e-9)
    half = table["mean_temperature_upper [K]"] - table["mean_temperature [K]"]
    np.testing.assert_allclose(half, summary["histories"]["mean_temperature"]["half_width"])
    assert json.loads((out / "prediction.json").read_text()) == summary
    page = (out / "prediction.html").read_text()
    assert "data:image/png;base64," in page and "http" not in page.replace(
        "http-equiv", "")
    assert (out / "prediction.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_text_output_and_default_directory(prediction_run, tmp_path, capsys):
    run_dir = tmp_path / "run"
    shutil.copytree(prediction_run, run_dir, ignore=shutil.ignore_patterns("run.lock"))
    csv = _model_csv(run_dir, tmp_path / "test.csv")
    assert main(["predict", str(run_dir), "--measured", str(csv)]) == 0
    text = capsys.readouterr().out
    assert "center_deflection: +-" in text and "in band at 100 %" in text
    assert (run_dir / "prediction" / "prediction.csv").is_file()
    # the run's report gains a Prediction section from prediction/prediction.json
    assert "<h2>Prediction</h2>" not in (run_dir / "report.html").read_text()
    assert main(["report", str(run_dir)]) == 0
    page = (run_dir / "report.html").read_text()
    summary = json.loads((run_dir / "prediction" / "prediction.json").read_text())
    section = page[page.index("<h2>Prediction</h2>"):]
    assert "<a href='prediction/prediction.html'>" in section
    for name in ("center_deflection", "mean_temperature"):
        assert f"<td>{name} [{summary['histories'][name]['unit']}]</td>" in section
    assert section.count("<td>100 %</td>") == 2  # the model's own response: all in band


GOOD_HEADER = "time [s],center_deflection [m],mean_temperature [K]\n"


@pytest.mark.parametrize("text, column, what", [
    ("center_deflection [m]\n0.001\n", "time [s|ms]", "missing"),
    ("time [s]\n0\n1\n", "center_deflection [m|mm] or mean_temperature [K|degC]", "missing"),
    ("time [s],centre_deflection [m]\n0,0\n", "centre_deflection [m]", "unknown column"),
    ("time [min],center_deflection [m]\n0,0\n", "time [min]", "unit 'min'"),
    ("time [s],center_deflection [in]\n0,0\n", "center_deflection [in]", "unit 'in'"),
    ("time [s],mean_temperature [F]\n0,300\n", "mean_temperature [F]", "unit 'F'"),
    ("time,center_deflection [m]\n0,0\n", "time", "NAME [UNIT]"),
    ("time [s],time [ms],center_deflection [m]\n0,0,0\n", "time [ms]", "twice"),
    (GOOD_HEADER + "0,0,300\n2,0,300\n1,0,300\n", "time [s]", "increase strictly"),
    (GOOD_HEADER + "0,0,300\n0,0,300\n", "time [s]", "increase strictly"),
    (GOOD_HEADER + "0,0,300\n1,nan,300\n", "center_deflection [m]", "NaN"),
    (GOOD_HEADER + "0,0,300\n1,,300\n", "center_deflection [m]", "empty"),
    (GOOD_HEADER + "0,0,300\n1,0.01,hot\n", "mean_temperature [K]", "not a number"),
    (GOOD_HEADER + "0,0,300\n1,inf,300\n", "center_deflection [m]", "not finite"),
    ("time [s],mean_temperature [degC]\n0,20\n1,-300\n", "mean_temperature [degC]",
     "absolute zero"),
    (GOOD_HEADER + "0,0,300\n1e6,0,300\n", "time [s]", "outside the model's test span"),
    (GOOD_HEADER + "-1,0,300\n1,0,300\n", "time [s]", "outside the model's test span"),
])
def test_bad_measured_files_exit_2_naming_the_column(prediction_run, tmp_path, capsys,
                                                     text, column, what):
    csv = tmp_path / "bad.csv"
    csv.write_text(text)
    out = tmp_path / "out"
    assert main(["predict", str(prediction_run), "--measured", str(csv), "--out",
                 str(out)]) == 2
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert err.count("\n") == 0 and err.startswith("hypate: error: --measured: ")
    assert f"column '{column}'" in err and what in err
    assert captured.out == "" and not out.exists()


@pytest.mark.parametrize("text, what", [("", "empty file"), ("\n\n", "empty file"),
                                        (GOOD_HEADER, "no data rows"),
                                        ("# only a comment\n", "empty file")])
def test_empty_measured_files_exit_2(prediction_run, tmp_path, capsys, text, what):
    csv = tmp_path / "empty.csv"
    csv.write_text(text)
    out = tmp_path / "out"
    assert main(["predict", str(prediction_run), "--measured", str(csv), "--out",
                 str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("hypate: error: --measured: ") and what in err
    assert not out.exists()


def test_bad_run_directories_and_options_exit_2(prediction_run, tmp_path, capsys):
    csv = _model_csv(prediction_run, tmp_path / "test.csv")
    assert main(["predict", str(tmp_path), "--measured", str(csv)]) == 2
    assert "RUN_DIR" in capsys.readouterr().err
    # another size needs a sweep run
    assert main(["predict", str(prediction_run), "--measured", str(csv), "--xi", "3",
                 "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("hypate: error: --xi: ") and "not a sweep run" in err
    assert main(["predict", str(prediction_run), "--measured", str(tmp_path / "nope.csv"),
                 "--out", str(tmp_path / "o")]) == 2
    assert "--measured" in capsys.readouterr().err
    (tmp_path / "file").write_text("")
    assert main(["predict", str(prediction_run), "--measured", str(csv), "--out",
                 str(tmp_path / "file")]) == 2
    assert "--out" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_help_states_the_header_contract(capsys):
    with pytest.raises(SystemExit):
        main(["predict", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "time [s|ms], center_deflection [m|mm], mean_temperature [K|degC]" in text
