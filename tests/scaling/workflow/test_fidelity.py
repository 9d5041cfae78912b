"""[[fidelity]] levels of a study (issue 19): parsing, refusals, the level's simulation, and a
multi-fidelity run whose design point and front are top-level evaluations."""
from __future__ import annotations

import json
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import tiny_study_text
from hypate.scaling.cli.main import main
from hypate.scaling.report.rundata import load_run
from hypate.scaling.workflow.vocabulary.fidelity import level_data
from hypate.scaling.workflow.vocabulary.study import parse_study
from hypate.solvers.errors import InputError

LEVELS = """
[[fidelity]]
name = "coarse"
mesh = [1, 1]
time_step_factor = 2.0
initial_samples = 4

[[fidelity]]
name = "full"
"""


def _data(levels: str = LEVELS, **kw) -> dict:
    return tomllib.loads(tiny_study_text(tail=levels, **kw))


def test_a_lower_level_is_the_study_at_its_mesh_and_time_step() -> None:
    study = parse_study(_data())
    assert study.level_names == ["coarse", "full"]
    (name, low, _), top = study.lower_levels[0], study.spec
    assert name == "coarse" and low.model.panel.mesh == (1, 1)
    assert low.prototype.panel.mesh == (1, 1)  # the level's own prototype
    assert low.simulation.time_step == pytest.approx(2.0 * top.simulation.time_step, rel=1e-15)
    assert low.simulation.duration == pytest.approx(top.simulation.duration, rel=1e-15)
    assert low.names == top.names
    # budget: 4 top designs at both levels + 4 coarse ones + the iterations
    assert study.budget == 4 + 4 + 4 + study.optimizer.iterations


def test_level_data_scales_the_time_step_and_the_steps() -> None:
    data = _data()
    low = level_data(data, parse_study(data).raw.fidelity[0])
    assert "fidelity" not in low
    assert low["simulation"]["time_step"] == 2.0 * data["simulation"]["time_step"]
    assert low["simulation"]["steps"] * 2 == data["simulation"]["steps"]
    assert low["simulation"]["mesh"] == [1, 1]


@pytest.mark.parametrize("levels, key", [
    ('[[fidelity]]\nname = "full"\n', "fidelity"),                         # one level
    ('[[fidelity]]\nname = "a"\nmesh = [1, 1]\n[[fidelity]]\nname = "a"\n', "fidelity"),
    ('[[fidelity]]\nname = "a"\n[[fidelity]]\nname = "full"\n', "fidelity[0]"),  # no cheaper
    ('[[fidelity]]\nname = "a"\ntime_step_factor = 3.0\n[[fidelity]]\nname = "full"\n',
     "fidelity[0].time_step_factor"),                                     # 4 steps / 3
    ('[[fidelity]]\nname = "a"\nmesh = [1, 1]\n[[fidelity]]\nname = "full"\nmesh = [2, 2]\n',
     "fidelity[1]"),                                                      # top overridden
])
def test_bad_levels_are_refused_naming_the_key(levels: str, key: str) -> None:
    with pytest.raises(InputError) as err:
        parse_study(_data(levels))
    assert key in str(err.value)


def test_levels_take_a_batch() -> None:
    data = _data()
    data["optimizer"]["batch_size"] = 2
    study = parse_study(data)
    assert study.budget == 4 + 4 + 4 + 2 * study.optimizer.iterations


@pytest.fixture(scope="module")
def mf_run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("fidelity") / "run"
    path = out.parent / "tiny_mf.toml"
    path.write_text(tiny_study_text(name="tiny_mf", initial=3, iterations=3, tail=LEVELS))
    assert main(["run", str(path), "--out", str(out), "-q"]) == 0
    return out


def test_the_design_point_and_front_are_top_level(mf_run: Path) -> None:
    df = pd.read_csv(mf_run / "evaluations.csv")
    cols = list(df.columns)
    assert cols[cols.index("fidelity") + 1] == "fidelity_name"
    assert set(df["fidelity_name"]) <= {"coarse", "full"}
    assert (df["fidelity"] == 0).sum() >= 3 + 4  # the nested and the coarse initial designs
    point = json.loads((mf_run / "design_point.json").read_text())
    row = df.iloc[point["evaluation"]]
    assert row["fidelity_name"] == "full"
    top = df[(df["fidelity"] == 1) & (df["status"] == "ok")]
    # chosen among the admissible top-level evaluations (the coarse level has no flag)
    assert set(df.loc[df["fidelity"] == 0, "admissible"].dropna()) == set()
    admissible = top[top["admissible"].astype(str) == "True"]
    assert len(admissible) and point["admissible"] is True
    worst = np.maximum(admissible["J_u"], admissible["J_T"])
    assert max(point["objectives"].values()) == pytest.approx(worst.min(), rel=1e-12)
    assert set(pd.read_csv(mf_run / "pareto.csv")["fidelity_name"]) == {"full"}
    by = point["fidelity"]["by_level"]
    assert by["coarse"]["evaluations"] + by["full"]["evaluations"] == len(df)
    assert "fidelity" not in point["design"]


def test_the_report_shows_the_top_level_and_the_rest_apart(mf_run: Path) -> None:
    run = load_run(mf_run)
    df = pd.read_csv(mf_run / "evaluations.csv")
    assert list(run.evaluations.index) == list(df.index[df["fidelity"] == 1])
    assert len(run.lower_fidelity) == int((df["fidelity"] == 0).sum())
    assert "fidelity" not in run.variables
    assert main(["report", str(mf_run)]) == 0
    assert "lower-fidelity evaluations (coarse)" in (mf_run / "report.html").read_text()
