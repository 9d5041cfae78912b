"""Fixtures of the report tests: a finished tiny run (shared) and runs built in memory."""
from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import tiny_study_text
from hypate.scaling.cli.main import main
from hypate.scaling.report.rundata import RunData


@pytest.fixture(scope="session")
def tiny_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A finished tiny run (2x2 mesh, 4 steps, 1 + 4 + 2 evaluations; ~2 s) and its study
    file. Tests that change the directory work on a copy."""
    tmp = tmp_path_factory.mktemp("report")
    study = tmp / "tiny.toml"
    study.write_text(tiny_study_text())
    out = tmp / "run"
    assert main(["run", str(study), "--out", str(out)]) == 0
    return out, study


@pytest.fixture
def fabricated_run(tmp_path: Path) -> Callable[..., RunData]:
    """``make(objectives=("J_u", "J_T"))``: a :class:`RunData` built in memory (no study,
    no responses): six evaluations, the last one failed, and a design point with one
    similarity parameter above the 10 % threshold and one below."""

    def make(objectives: Sequence[str] = ("J_u", "J_T")) -> RunData:
        objectives = list(objectives)
        J = np.array([[0.5, 0.4], [0.3, 0.6], [0.2, 0.2], [0.1, 0.5], [0.6, 0.05],
                      [np.nan, np.nan]])[:, : len(objectives)]
        frame = pd.DataFrame({"iteration": [0, 0, 0, 1, 2, 3], "batch_index": 0,
                              "M": [5.0, 5.5, 6.0, 6.5, 7.0, 7.5],
                              "h": [1e-3, 2e-3, 3e-3, 4e-3, 5e-3, 6e-3]})
        for k, name in enumerate(objectives):
            frame[name] = J[:, k]
        frame["status"] = ["ok"] * 5 + ["failed"]
        frame["message"] = [""] * 5 + ["LSA diverged at step 3"]
        frame["seconds"] = 1.0
        frame["seed"] = 0
        point = {"study": "fabricated", "design": {"M": 6.0, "h": 3e-3},
                 "objectives": {o: 0.2 for o in objectives}, "active_constraints": [],
                 "similarity": [{"name": "lambda_F", "prototype": 1.0, "model": 1.05,
                                 "relative_difference": 0.05},
                                {"name": "Bi", "prototype": 2.0, "model": 3.0,
                                 "relative_difference": 0.5}]}
        return RunData(directory=tmp_path, evaluations=frame, variables=["M", "h"],
                       objectives=objectives, point=point)

    return make
