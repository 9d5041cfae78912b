"""The one runner (issue 42): ``hypate run`` and ``hypate.run_study`` take the same path from
a study file to its results -- the same files, byte for byte."""
from __future__ import annotations

import json
from pathlib import Path

import hypate
import pytest
from conftest import tiny_study_text
from hypate.scaling.cli.main import main
from hypate.scaling.workflow.campaigns.execute import RUN_KINDS, SeedsOutcome, check_request, run_kind
from hypate.scaling.workflow.campaigns.rundir import EVALUATIONS_CSV, SWEEP_JSON
from hypate.scaling.workflow.campaigns.seeds import SEEDS_JSON
from hypate.scaling.workflow.vocabulary.study import load_study
from hypate.scaling.workflow.campaigns.sweep import SweepOutcome
from hypate.solvers.errors import InputError

SWEEP = tiny_study_text(name="tiny_sweep", xi=2.0, tail="""
[sweep]
xi = [2, 3]
recycle = 1
initial_samples = 2
iterations = 1
""")


def _study(tmp_path: Path, text: str, name: str) -> Path:
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return path


def test_run_study_on_a_sweep_writes_the_sweep_json_of_hypate_run(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = _study(tmp_path, SWEEP, "tiny_sweep")
    assert main(["run", str(path), "--out", str(tmp_path / "cli"), "-q"]) == 0
    monkeypatch.chdir(tmp_path)  # the API's default directory: runs/<study name>
    outcome = hypate.run_study(hypate.load_study(path), on_written=None)
    assert isinstance(outcome, SweepOutcome)
    api = tmp_path / "runs" / "tiny_sweep"
    assert (api / SWEEP_JSON).read_bytes() == (tmp_path / "cli" / SWEEP_JSON).read_bytes()
    for point in ("xi_2", "xi_3"):
        a = (api / point / EVALUATIONS_CSV).read_text().splitlines()
        b = (tmp_path / "cli" / point / EVALUATIONS_CSV).read_text().splitlines()
        assert len(a) == len(b) > 1
        # every column but the wall time of each evaluation
        strip = [line.split(",") for line in (a[0], b[0])]
        col = strip[0].index("seconds")
        assert [r.split(",")[:col] for r in a] == [r.split(",")[:col] for r in b]


def test_run_study_with_seeds_writes_the_seeds_json_of_hypate_run(tmp_path: Path) -> None:
    path = _study(tmp_path, tiny_study_text(name="tiny_seeds", initial=3, iterations=1),
                  "tiny_seeds")
    assert main(["run", str(path), "--seeds", "2", "--out", str(tmp_path / "cli"), "-q"]) == 0
    outcome = hypate.run_study(load_study(path), tmp_path / "api", seeds=2, on_written=None)
    assert isinstance(outcome, SeedsOutcome)
    assert outcome.seeds == [3, 4] and outcome.summary["finished"] == 2
    api, cli = (json.loads((tmp_path / d / SEEDS_JSON).read_text()) for d in ("api", "cli"))
    for data in (api, cli):  # each seed's wall time is the machine's, not the run's
        for rec in data["seeds"]:
            assert rec.pop("wall_seconds") > 0
    assert api == cli


def test_the_runner_picks_one_way_per_study_and_refuses_what_does_not_fit(
        tmp_path: Path) -> None:
    single = load_study(_study(tmp_path, tiny_study_text(), "tiny"))
    sweep = load_study(_study(tmp_path, SWEEP, "tiny_sweep"))
    assert run_kind(single) == "single" and run_kind(single, seeds=3) == "seeds"
    assert run_kind(sweep) == "sweep" and run_kind(sweep, seeds=3) == "sweep"
    assert set(RUN_KINDS) == {"sweep", "seeds", "robust", "single"}
    with pytest.raises(InputError, match="--seeds"):
        check_request(sweep, 2, ())
    with pytest.raises(InputError, match="--seed-from"):
        check_request(sweep, None, [tmp_path])
