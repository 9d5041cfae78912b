"""``hypate reproduce`` (issue 21): flags, bad input, strict ``--json``, progress on stderr.

The full ``--quick`` run takes minutes (README); here the command runs on the two cheapest
reproductions (the runner's plan narrowed), which exercises the same code path."""
from __future__ import annotations

import json
from pathlib import Path

import pytest
from hypate.scaling.cli.main import build_parser, main
from hypate.studies.scripts import reproduce


@pytest.fixture
def cheap_plan(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    keys = ["ch7_table7_3_modes", "ch9_table9_3"]
    items = [i for i in reproduce.plan() if i.key in keys]
    monkeypatch.setattr(reproduce, "plan", lambda: items)
    return keys


def test_the_four_public_flags_parse() -> None:
    args = build_parser().parse_args(["reproduce", "--quick", "--seeds", "3", "--out", "d",
                                      "--json"])
    assert (args.quick, args.seeds, args.out, args.json) == (True, 3, "d", True)
    defaults = build_parser().parse_args(["reproduce"])
    assert (defaults.quick, defaults.seeds, defaults.out) == (False, 1, "reproduction")
    assert defaults.jobs == "auto" and build_parser().parse_args(
        ["reproduce", "--jobs", "2"]).jobs == "2"


@pytest.mark.parametrize("jobs", ["0", "65", "two"])
def test_bad_jobs_end_in_one_line_naming_the_flag(jobs: str, tmp_path: Path,
                                                  capsys: pytest.CaptureFixture) -> None:
    out = tmp_path / "out"
    assert main(["reproduce", "--quick", "--jobs", jobs, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"hypate: error: --jobs: must be an integer in [1, 64] or auto; got {jobs!r}"]
    assert not out.exists()  # nothing written


@pytest.mark.parametrize("seeds", ["0", "21", "-1"])
def test_bad_seeds_end_in_one_line_naming_the_flag(seeds: str, tmp_path: Path,
                                                   capsys: pytest.CaptureFixture) -> None:
    out = tmp_path / "out"
    assert main(["reproduce", "--quick", "--seeds", seeds, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"hypate: error: --seeds: must be an integer in [1, 20]; got {seeds}"]
    assert not out.exists()  # nothing written


def test_out_that_is_a_file_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    f = tmp_path / "file"
    f.write_text("x")
    assert main(["reproduce", "--quick", "--out", str(f)]) == 2
    assert "--out" in capsys.readouterr().err and f.read_text() == "x"


def test_json_is_strict_and_names_the_page(cheap_plan: list[str], tmp_path: Path,
                                           capsys: pytest.CaptureFixture) -> None:
    out = tmp_path / "out"
    assert main(["reproduce", "--quick", "--out", str(out), "--json"]) == 0
    captured = capsys.readouterr()
    record = json.loads(captured.out, parse_constant=lambda c: pytest.fail(c))
    assert record["page"] == str(out / "reproduction.html") and Path(record["page"]).exists()
    assert [r["key"] for r in record["reproductions"]] == cheap_plan
    assert record["quick"] is True and record["seeds"] == 1 and record["finished"] is True
    # Table 7.3: 10 rows, all within their tolerances; Table 9.3: 12 of 12 compared
    assert (record["compared"], record["match"]) == (22, 22)
    assert "reproduce: " in captured.err  # progress goes to stderr, never stdout


def test_quiet_prints_only_the_result(cheap_plan: list[str], tmp_path: Path,
                                      capsys: pytest.CaptureFixture) -> None:
    assert main(["reproduce", "--quick", "--out", str(tmp_path / "o"), "-q"]) == 0
    captured = capsys.readouterr()
    assert captured.err == ""
    assert captured.out.strip().splitlines()[-1] == str(tmp_path / "o" / "reproduction.html")
