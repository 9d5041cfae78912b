"""The CLI for scripts: --version, studies, init, validate (every schema), --json, "did you
mean", progress lines without a terminal, honest run summaries."""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
from importlib.metadata import version
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from conftest import tiny_study_text
from hypate.scaling.cli.commands import quick_answer, top_level_parser
from hypate.scaling.cli.main import build_parser, main
from hypate.scaling.cli.progress import Progress
from hypate.scaling.workflow.vocabulary.study import load_study


def _json(capsys: pytest.CaptureFixture) -> object:
    return json.loads(capsys.readouterr().out)


def test_version(capsys: pytest.CaptureFixture) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0 and capsys.readouterr().out.strip() == f"hypate {version('hypate')}"


def test_version_and_help_are_answered_without_loading_a_command(
        capsys: pytest.CaptureFixture) -> None:
    """The console script answers --version and --help from the light registry
    (scaling/cli/commands.py), in a fresh interpreter without numpy; its listing is the
    full parser's, command for command and help for help."""
    code = ("import sys; from hypate.scaling.cli.commands import quick_answer; "
            "c = quick_answer(sys.argv[1:]); assert 'numpy' not in sys.modules; sys.exit(c)")
    for flag in ("--version", "--help"):
        done = subprocess.run([sys.executable, "-c", code, flag], capture_output=True,
                              text=True, timeout=120)
        assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[0] == "usage: hypate [-h] [--version] COMMAND ..."
    assert quick_answer(["run", "--help"]) is None  # a command's help loads the command
    full = next(a for a in build_parser()._actions
                if isinstance(a, argparse._SubParsersAction))
    light = next(a for a in top_level_parser()._actions
                 if isinstance(a, argparse._SubParsersAction))
    assert [(a.dest, a.help) for a in full._choices_actions] == \
        [(a.dest, a.help) for a in light._choices_actions]


def test_a_mistyped_command_gets_a_suggestion(capsys: pytest.CaptureFixture) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["rnu"])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and "did you mean 'run'?" in err and err.count("\n") == 1


def test_every_option_default_is_in_help(capsys: pytest.CaptureFixture) -> None:
    for cmd in (["flutter"], ["bench", "bo"], ["rom", "plan"]):
        with pytest.raises(SystemExit):
            main([*cmd, "--help"])
        text = " ".join(capsys.readouterr().out.split())
        assert "default" in text, cmd


def test_studies_lists_every_shipped_study(capsys: pytest.CaptureFixture) -> None:
    assert main(["studies", "--json"]) == 0
    rows = {r["name"]: r for r in _json(capsys)}
    assert {"quickstart", "sec9_2_2_xi4", "sec9_1_xi2_equal_nu"} <= set(rows)
    assert rows["quickstart"]["evaluations"] == 68 and rows["quickstart"]["duration"]
    # the stored count is the budget + the classical baseline evaluated first
    assert rows["quickstart"]["classical_baseline"] is True
    assert rows["sec9_2_4_envelope"]["sweep_points"] == 25  # Table 9.11's 25 conditions


@pytest.mark.parametrize("source", ["quickstart", "sec9_1_xi2", "sec9_2_3_case2_wt5"])
def test_init_writes_a_study_that_validates_anywhere(source: str, tmp_path: Path,
                                                    capsys: pytest.CaptureFixture) -> None:
    path = tmp_path / "mine.toml"
    assert main(["init", str(path), "--from", source]) == 0
    assert path.read_text().startswith("# Study file written by `hypate init")
    assert load_study(path).name == "mine"  # named after its file: runs/mine, not runs/<source>
    capsys.readouterr()
    assert main(["validate", str(path), "--json"]) == 0
    doc = _json(capsys)
    assert doc["valid"] and doc["schema"] == "study"
    assert main(["init", str(path)]) == 2  # never overwrites
    assert "exists" in capsys.readouterr().err


def test_init_suggests_a_shipped_name(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    assert main(["init", str(tmp_path / "x.toml"), "--from", "quikstart"]) == 2
    assert "--from: no shipped study 'quikstart'; did you mean 'quickstart'?" in \
        capsys.readouterr().err
    assert not (tmp_path / "x.toml").exists()


@pytest.mark.parametrize("name, schema", [("quickstart", "study"), ("sec9_2_prototype", "case"),
                                          ("studies/rom/rom_2d_panel.toml", "rom")])
def test_validate_applies_and_names_the_schema(name: str, schema: str, repo_root: Path,
                                               capsys: pytest.CaptureFixture,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(repo_root)
    assert main(["validate", name]) == 0
    assert f"valid ({schema} file)" in capsys.readouterr().out


def test_validate_json_of_a_bad_study_names_the_key_and_suggests(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(tiny_study_text().replace("initial_samples", "inital_samples"))
    assert main(["validate", str(path), "--json"]) == 2
    doc = _json(capsys)
    assert doc["valid"] is False and doc["field"] == "optimizer.inital_samples"
    assert "did you mean 'initial_samples'?" in doc["message"]


def test_run_json_and_resume_summaries(tiny_study, tmp_path: Path,
                                       capsys: pytest.CaptureFixture) -> None:
    study = tiny_study()
    out = tmp_path / "run"
    assert main(["run", str(study), "--out", str(out), "--json", "-q"]) == 0
    cap = capsys.readouterr()
    doc = json.loads(cap.out)
    assert cap.err == ""  # -q: nothing on stderr
    assert doc["evaluations"] == doc["new_evaluations"] == 7  # 4 + 2 + the classical seed
    assert doc["report"] == str(out / "report.html") and Path(doc["report"]).is_file()
    assert set(doc["design_point"]) == {"design", "objectives", "active_constraints",
                                        "admissible", "binding", "prototype_admissibility"}
    table = pd.read_csv(out / "evaluations.csv")  # failed: the evaluations not "ok"
    assert doc["failed"] == int((table.status != "ok").sum())
    assert main(["run", str(study), "--out", str(out), "--resume", "-q"]) == 0
    assert "already complete (7 evaluations)" in capsys.readouterr().out


def test_progress_without_a_terminal_prints_lines(capsys: pytest.CaptureFixture,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    clock = iter([0.0, 0.0, 1.0, 12.0, 13.0])  # start, then one reading per call
    monkeypatch.setattr("hypate.scaling.cli.progress.time.monotonic", lambda: next(clock))
    bar = Progress(tty=False)
    for done in (1, 2, 3, 4):
        bar(done, 4, None)
    bar.close()
    lines = capsys.readouterr().err.strip().splitlines()
    # one line once 10 s have passed (t = 12 s: 2 evaluations since the first in 12 s,
    # 6 s each, one left) and one at the end; none in between
    assert lines == ["evaluations 3/4, 12 s, ETA 6 s", "evaluations 4/4, 13 s"]


def test_a_resumed_progress_counts_the_stored_best_and_times_only_this_session(
        capsys: pytest.CaptureFixture, monkeypatch: pytest.MonkeyPatch) -> None:
    clock = iter([0.0, 0.0, 12.0])  # start, then one reading per call
    monkeypatch.setattr("hypate.scaling.cli.progress.time.monotonic", lambda: next(clock))
    # 10 of 12 stored, the best of them max(J) 0.2; this session's first is worse
    bar = Progress(tty=False, history=[np.array([0.2, 0.1]), np.array([0.5, 0.4])])
    bar(11, 12, SimpleNamespace(status="ok", F=[0.3, 0.3], warnings=()))
    bar(12, 12, SimpleNamespace(status="ok", F=[0.6, 0.6], warnings=()))
    bar.close()
    line = capsys.readouterr().err.strip().splitlines()[-1]
    assert line.startswith("evaluations 12/12, best 0.2, HV ") and line.endswith(", 12 s")


def test_solver_warnings_are_collected_and_summarized_once(capsys: pytest.CaptureFixture) -> None:
    import warnings

    from hypate.scaling.cli.run import collected_warnings, warning_summary

    with collected_warnings(verbose=False) as caught:
        for _ in range(3):
            warnings.warn("ti6242.conductivity: clamped", RuntimeWarning, stacklevel=1)
        warnings.warn("other", UserWarning, stacklevel=1)
    assert capsys.readouterr().err == ""  # nothing reached the terminal
    assert warning_summary(caught) == [
        "4 solver warnings of 2 kinds during the run (-v shows each as it is recorded; "
        "evaluation ids as in evaluations.csv):",
        "  RuntimeWarning: ti6242.conductivity: clamped: run (3 times)",
        "  UserWarning: other: run (1 time)"]
    with pytest.warns(RuntimeWarning), collected_warnings(verbose=True) as shown:
        warnings.warn("shown", RuntimeWarning, stacklevel=1)
    assert shown == [] and warning_summary(shown) == []


def test_workers_beyond_the_cores_are_capped_with_one_line(capsys: pytest.CaptureFixture,
                                                           monkeypatch: pytest.MonkeyPatch
                                                           ) -> None:
    from hypate.scaling.cli import run as run_cli
    from hypate.scaling.workflow.vocabulary.shipped import default_study
    from hypate.scaling.workflow.vocabulary.study import load_study

    study = load_study(default_study())
    monkeypatch.setattr(run_cli, "usable_cores", lambda: 2)
    assert run_cli.resolve_workers("99", study) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["--workers 99: this machine gives the run 2 cores; using 2 workers"]
    assert run_cli.resolve_workers("2", study) == 2 and not capsys.readouterr().err
