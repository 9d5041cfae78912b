"""Every value validated where it is read (issue 43, items 6 and 7): a study seed beyond
the store's 64-bit integer, a time step whose steps overflow, nesting no parser should
recurse through, a run name that leaves ``runs/``; each is one line naming the key, exit
code 2, nothing written.
"""
from __future__ import annotations

import os
from pathlib import Path

import pytest
from conftest import PROTOTYPE_CASE, tiny_study_text
from hypate.scaling.cli.main import main


def _error_line(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("hypate: error: "), err
    return lines[0]


@pytest.mark.parametrize("seed", [2**63, 2**64], ids=["2^63", "2^64"])
def test_a_study_seed_beyond_the_store_is_refused_by_validate_and_run(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], seed: int) -> None:
    study = tmp_path / "seed.toml"
    study.write_text(tiny_study_text(seed=seed))
    assert main(["validate", str(study)]) == 2
    assert _error_line(capsys).startswith("hypate: error: optimizer.seed: must be an integer "
                                          "in [0, 9223372036854775807]")
    os.chdir(tmp_path)
    assert main(["run", str(study), "-q"]) == 2
    assert "optimizer.seed" in _error_line(capsys)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["seed.toml"]  # nothing written


def test_a_time_step_whose_steps_overflow_is_refused(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    study = tmp_path / "dt.toml"
    study.write_text(tiny_study_text(time_step=1e308))
    assert main(["validate", str(study)]) == 2
    assert _error_line(capsys).startswith("hypate: error: simulation.time_step: ")


def test_a_case_file_with_too_many_steps_is_refused(tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    text = PROTOTYPE_CASE.read_text().replace("duration = 160.0", "duration = 1e300")
    assert "duration = 1e300" in text
    case = tmp_path / "case.toml"
    case.write_text(text.replace("time_step = 1.0", "time_step = 1e-300"))
    assert main(["validate", str(case)]) == 2
    line = _error_line(capsys)
    assert "simulation.duration" in line and "at most 100000" in line


def test_deeply_nested_toml_is_one_line(tmp_path: Path,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    deep = tmp_path / "deep.toml"
    deep.write_text("a = " + "[" * 5000 + "]" * 5000 + "\n")
    assert main(["validate", str(deep)]) == 2
    assert "nested more than 32 levels deep" in _error_line(capsys)
    nested = tmp_path / "nested.toml"  # parses, but deeper than any hypate file needs
    nested.write_text("a = " + "[" * 40 + "]" * 40 + "\n")
    assert main(["validate", str(nested)]) == 2
    assert "nested more than 32 levels deep" in _error_line(capsys)


@pytest.mark.parametrize("name", ["../../escaped", "..", "a/b", ".hidden", ""])
def test_a_study_name_must_be_a_plain_file_name(tmp_path: Path, name: str,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    study = tmp_path / "named.toml"
    study.write_text(tiny_study_text(name=name))
    os.chdir(tmp_path)
    assert main(["run", str(study), "-q"]) == 2
    assert _error_line(capsys).startswith("hypate: error: study.name: ")
    assert sorted(p.name for p in tmp_path.parent.iterdir() if p.name == "escaped") == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["named.toml"]
