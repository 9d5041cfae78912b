"""`hypate whatif`: one design without optimization, sweeps, and input errors."""
from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest
from conftest import tiny_study_text
from hypate.scaling.cli.main import main
from hypate.scaling.workflow.analyses.whatif import evaluate_whatif
from hypate.scaling.workflow.vocabulary.study import load_study

TINY = tiny_study_text(sections='\n[constraints]\nequality = ["T_inf"]\n')


@pytest.fixture()
def study(tmp_path: Path) -> Path:
    path = tmp_path / "tiny.toml"
    path.write_text(TINY)
    return path


def _json(capsys) -> dict:
    return json.loads(capsys.readouterr().out)


def test_whatif_json_fields(study: Path, capsys) -> None:
    assert main(["whatif", str(study), "--set", "p0=6e6", "--set", "h=0.01", "--json"]) == 0
    res = _json(capsys)
    assert res["design"]["p0"] == 6e6 and res["design"]["h"] == 0.01
    assert res["sources"] == {"M": "midpoint", "p0": "set", "T0": "midpoint", "h": "set"}
    assert res["design"]["M"] == pytest.approx(6.0)  # midpoint of the ideal tunnel's [5, 7]
    assert res["status"] in ("ok", "failed")
    assert set(res["objectives"]) == {"J_u", "J_T", "J_s"}
    if res["status"] == "ok":
        assert all(v >= 0 for v in res["objectives"].values())
    rows = res["similarity"]
    assert rows and set(rows[0]) == {"name", "prototype", "model", "relative_difference"}
    con = res["constraints"]
    assert "h=upper" in con["active"] and con["outside"] == []
    assert [e["name"] for e in con["equalities"]] == ["T_inf"]
    assert con["equalities"][0]["residual"] >= 0.0
    assert res["model_time_step"] > 0


def test_whatif_outside_bounds_is_evaluated_and_flagged(study: Path, capsys) -> None:
    assert main(["whatif", str(study), "--set", "h=0.02"]) == 0
    text = capsys.readouterr().out
    assert "OUTSIDE: h above upper" in text and "J_u" in text
    assert "similarity parameters" in text


def test_whatif_sweep_writes_png_and_csv(study: Path, tmp_path: Path, capsys) -> None:
    out = tmp_path / "sweep"
    assert main(["whatif", str(study), "--set", "p0=6e6", "--sweep", "h=0.002:0.012:3",
                 "--out", str(out), "--json"]) == 0
    res = _json(capsys)["sweep"]
    png, csv = out / "whatif_h.png", out / "whatif_h.csv"
    assert Path(res["png"]) == png and Path(res["csv"]) == csv
    assert png.read_bytes().startswith(b"\x89PNG\r\n\x1a\n")
    df = pd.read_csv(csv)
    assert len(df) == 3 and {"M", "p0", "T0", "h", "J_u", "J_T", "status"} <= set(df.columns)
    assert df["h"].tolist() == pytest.approx([0.002, 0.007, 0.012])
    assert (df["p0"] == 6e6).all()
    assert [r["value"] for r in res["rows"]] == pytest.approx([0.002, 0.007, 0.012])
    assert res["rows"][-1]["outside"]  # 0.012 > upper bound 0.01: flagged


def test_a_sweep_without_out_writes_under_runs(study: Path, tmp_path: Path,
                                               monkeypatch: pytest.MonkeyPatch, capsys) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["whatif", str(study), "--sweep", "h=0.002:0.004:2", "--json"]) == 0
    res = _json(capsys)["sweep"]
    name = load_study(study).name
    assert Path(res["csv"]) == Path("runs") / f"whatif-{name}" / "whatif_h.csv"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["runs", "tiny.toml"]


@pytest.mark.parametrize("argv, option", [
    (["--set", "wingspan=3"], "--set"),
    (["--set", "h"], "--set"),
    (["--set", "h=abc"], "--set"),
    (["--set", "h=-0.001"], "--set"),
    (["--sweep", "h=0.001:0.01"], "--sweep"),
    (["--sweep", "colour=1:2:3"], "--sweep"),
    (["--sweep", "h=0.001:0.01:1"], "--sweep"),
    (["--set", "h=0.002", "--sweep", "h=0.001:0.01:3"], "--sweep"),
    (["--out", "x"], "--out"),
    (["--base", "/nonexistent/run"], "--base"),
], ids=["unknown", "no value", "not a number", "negative", "sweep syntax", "sweep unknown",
        "sweep n", "set and sweep", "out without sweep", "base missing"])
def test_whatif_errors_exit_2_naming_the_option(study: Path, capsys, argv, option) -> None:
    assert main(["whatif", str(study), *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("hypate: error: ") and option in err[-1], err


def test_whatif_base_from_run(study: Path, tmp_path: Path, capsys) -> None:
    run = tmp_path / "run"
    run.mkdir()
    design = {"M": 5.5, "p0": 2e7, "T0": 1500.0, "h": 0.004}
    (run / "design_point.json").write_text(json.dumps({"design": design}))
    assert main(["whatif", str(study), "--base", str(run), "--set", "p0=6e6", "--json"]) == 0
    res = _json(capsys)
    assert res["design"] == {**design, "p0": 6e6}
    assert res["sources"]["M"] == "design point" and res["sources"]["p0"] == "set"


def test_whatif_of_a_sweep_evaluates_at_the_point_the_base_run_directory_names(
        tmp_path: Path, capsys, monkeypatch) -> None:
    """A [sweep] study's what-if at a point (``--point``, or the point whose run directory
    ``--base`` is: recorded in its design_point.json, even when copied elsewhere) equals the
    same design in a single study written for that flight condition ([prototype]
    mach/altitude), bit for bit; at another point it differs and says so."""
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(tiny_study_text(name="s", tail="\n[sweep]\n"
                                     "conditions = [[6.0, 25000.0], [5.5, 22000.0]]\n"))
    design = evaluate_whatif(load_study(sweep), {})["design"]  # the midpoints: it runs
    point = tmp_path / "copied"  # a point directory under another name
    point.mkdir()
    (point / "design_point.json").write_text(json.dumps({"study": "s [M5.5_H22km]",
                                                         "design": design}))
    assert main(["whatif", str(sweep), "--base", str(point), "--json"]) == 0
    at_base = _json(capsys)
    assert at_base["study"] == "s [M5.5_H22km]" and at_base["status"] == "ok"
    assert at_base["point"] == "M5.5_H22km"
    single = tmp_path / "single.toml"
    single.write_text(tiny_study_text(name="s").replace(
        "[prototype]\n", "[prototype]\nmach = 5.5\naltitude = 22000.0\n"))
    assert main(["whatif", str(single), "--base", str(point), "--json"]) == 0
    assert _json(capsys)["objectives"] == at_base["objectives"]
    monkeypatch.chdir(point)  # --base . and the design_point.json file name the point too
    for base in (".", "design_point.json"):
        assert main(["whatif", str(sweep), "--base", base, "--json"]) == 0
        assert _json(capsys)["objectives"] == at_base["objectives"]
    assert main(["whatif", str(sweep), "--point", "M6_H25km", "--base", str(point),
                 "--json"]) == 0
    captured = capsys.readouterr()
    other = json.loads(captured.out)
    assert other["study"] == "s [M6_H25km]" and other["status"] == "ok"
    assert other["objectives"]["J_s"] != at_base["objectives"]["J_s"]
    assert "the design of point M5.5_H22km (--base) evaluated at point M6_H25km" in \
        captured.err


def test_whatif_of_a_sweep_without_a_point_says_so(tmp_path: Path, capsys) -> None:
    """A base directory that merely has a label's name (not inside a sweep run, nothing
    recorded) picks no point: the study's own condition, with a note."""
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(tiny_study_text(name="s", tail="\n[sweep]\n"
                                     "conditions = [[5.5, 22000.0]]\n"))
    lookalike = tmp_path / "M5.5_H22km"
    lookalike.mkdir()
    (lookalike / "design_point.json").write_text(json.dumps(
        {"study": "other", "design": {"h": 0.004}}))
    assert main(["whatif", str(sweep), "--base", str(lookalike), "--json"]) == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out)["point"] is None
    assert json.loads(captured.out)["study"] == "s"
    assert "has a [sweep]; evaluated at its own scale and flight condition" in captured.err
    (tmp_path / "sweep.json").write_text("{}")  # inside a sweep run: the directory's name
    assert main(["whatif", str(sweep), "--base", str(lookalike), "--json"]) == 0
    assert _json(capsys)["point"] == "M5.5_H22km"


@pytest.mark.parametrize("argv, message", [
    (["--point", "M9_H1km"], "not a point of the sweep; one of M6_H25km"),
    (["--point", "xi_2", "--no-sweep"], "has no [sweep]"),
])
def test_whatif_point_errors_name_the_option(tmp_path: Path, capsys, argv, message) -> None:
    path = tmp_path / "s.toml"
    tail = "" if "--no-sweep" in argv else "\n[sweep]\nconditions = [[6.0, 25000.0]]\n"
    path.write_text(tiny_study_text(name="s", tail=tail))
    assert main(["whatif", str(path), *[a for a in argv if a != "--no-sweep"]]) == 2
    err = capsys.readouterr().err
    assert "--point" in err and message in err, err


def test_whatif_external_heat_flux_reaches_the_simulation(study: Path) -> None:
    # q_ext (Eq. 6.1d) was only in the similarity table (Bi_ext), the simulated J_u and
    # J_T bit-identical; now it heats the model's upper surface. q_ext = 0 is the default
    # exactly.
    s = load_study(study)
    base = evaluate_whatif(s, {})
    zero = evaluate_whatif(s, {"q_ext": 0.0})
    heated = evaluate_whatif(s, {"q_ext": 2e5})
    assert base["status"] == zero["status"] == heated["status"] == "ok"
    assert zero["objectives"] == base["objectives"]
    bi_ext = {r["name"]: r["model"] for r in heated["similarity"]}["Bi_ext"]
    assert bi_ext > 0.1
    J0, J1 = base["objectives"]["J_T"], heated["objectives"]["J_T"]
    assert abs(J1 - J0) > 1e-2 * J0, (J0, J1)
