"""hypate.scaling.report.rundata: a run directory read back, finished or interrupted."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import forget_study_file
from hypate.scaling.report.rundata import RunData, load_run
from hypate.solvers.errors import InputError

VARIABLES = ["M", "p0", "T0", "h"]  # the tiny study's design variables
OBJECTIVES = ["J_u", "J_T"]
N_EVALUATIONS = 7  # 1 classical seed + 4 initial samples + 2 iterations


def _copy_without(out: Path, tmp_path: Path, *names: str) -> Path:
    """A copy of the run directory ``out`` without the files ``names``."""
    run = tmp_path / "copy"
    shutil.copytree(out, run)
    for name in names:
        (run / name).unlink(missing_ok=True)
    return run


def test_finished_run(tiny_run: tuple[Path, Path]) -> None:
    out, study = tiny_run
    run = load_run(out)  # the study file is recorded in the run directory
    assert run.study is not None and Path(run.study_path) == study
    assert run.variables == VARIABLES and run.objectives == OBJECTIVES
    assert list(run.evaluations.columns[2:8]) == VARIABLES + OBJECTIVES
    assert len(run.evaluations) == N_EVALUATIONS
    assert not run.interrupted and not run.point_rebuilt and run.notes == []
    assert run.point == json.loads((out / "design_point.json").read_text())
    assert run.prototype is not None and run.model is not None
    assert run.model_time_step == pytest.approx(run.point["model_time_step"])
    ok = run.ok
    assert (ok["status"] == "ok").all() and np.isfinite(ok[OBJECTIVES].to_numpy()).all()


def test_interrupted_run_rebuilds_the_design_point(tiny_run: tuple[Path, Path],
                                                    tmp_path: Path) -> None:
    out, study = tiny_run
    run_dir = _copy_without(out, tmp_path, "design_point.json", "design_point.npz",
                            "evaluations.csv", "pareto.csv")
    # the store names the study file: found again
    assert load_run(run_dir).study is not None
    # without the study (moved since): the store's numbered columns, no similarity
    forget_study_file(run_dir)
    bare = load_run(run_dir)
    assert bare.interrupted and bare.point_rebuilt and bare.study is None
    assert bare.variables == ["x0", "x1", "x2", "x3"] and bare.objectives == ["f0", "f1"]
    assert any("study file unknown" in n for n in bare.notes)
    assert bare.point["similarity"] == [] and bare.model_time_step is None
    # with it: names, similarity table and model time step; the runner's criterion
    # (smallest max(J), Sec. 9.2.3) gives the finished run's design point
    data = load_run(run_dir, study_path=study)
    assert data.point_rebuilt and data.variables == VARIABLES
    assert data.point["similarity"] and data.model is None and data.model_time_step > 0
    full = json.loads((out / "design_point.json").read_text())
    assert data.point["objectives"] == pytest.approx(full["objectives"])
    assert data.point["design"] == pytest.approx(full["design"])


def test_names_from_the_csv_header(tiny_run: tuple[Path, Path], tmp_path: Path) -> None:
    """No study found: the variable names come from evaluations.csv next to the store."""
    out, _ = tiny_run
    run_dir = _copy_without(out, tmp_path, "design_point.json")
    forget_study_file(run_dir)
    run = load_run(run_dir)
    assert run.study is None
    assert run.variables == VARIABLES and run.objectives == OBJECTIVES


def test_csv_alone(tiny_run: tuple[Path, Path], tmp_path: Path) -> None:
    """No store: the evaluations come from evaluations.csv, with a note."""
    out, _ = tiny_run
    run_dir = _copy_without(out, tmp_path, "evaluations.sqlite", "design_point.json")
    run = load_run(run_dir)
    assert any("no evaluations.sqlite" in n for n in run.notes)
    assert run.variables == VARIABLES and run.objectives == OBJECTIVES
    csv = pd.read_csv(out / "evaluations.csv")
    np.testing.assert_array_equal(run.evaluations[OBJECTIVES].to_numpy(),
                                  csv[OBJECTIVES].to_numpy())
    # the id column is the row number: it becomes the index, not a column
    assert "id" not in run.evaluations.columns
    np.testing.assert_array_equal(run.evaluations.index.to_numpy(), csv["id"].to_numpy())


def test_rule_recorded_then_study_then_default(tiny_run: tuple[Path, Path]) -> None:
    out, _ = tiny_run
    run = load_run(out)
    assert run.point["rule"] == "minmax" and run.rule == "minmax"
    assert run.point_id == run.point["evaluation"]
    run.point = {"rule": "knee"}
    assert run.rule == "knee" and run.point_id is None
    run.point, run.study = {}, None
    assert run.rule == "minmax" and run.weights is None  # runs older than the key


def test_not_a_run_directory(tmp_path: Path, tiny_run: tuple[Path, Path]) -> None:
    with pytest.raises(InputError, match="not a run directory"):
        load_run(tmp_path)
    with pytest.raises(InputError, match="not a directory"):
        load_run(tmp_path / "missing")
    out, _ = tiny_run
    with pytest.raises(InputError) as info:
        load_run(out, study_path=tmp_path / "nope.toml")
    assert info.value.field == "--study"


def test_figure_path_creates_the_folder(tmp_path: Path) -> None:
    path = RunData(directory=tmp_path).figure_path("x")
    assert path == tmp_path / "figures" / "x.png" and path.parent.is_dir()
