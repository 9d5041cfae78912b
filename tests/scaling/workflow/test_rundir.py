"""The run-directory contract: default run directories of `hypate run` (a repeated run never
refuses to start) and the design-point rules."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import tiny_study_text
from hypate.scaling.cli.main import main
from hypate.scaling.engine.design_point import (
    DESIGN_POINT_RULES,
    describe_rule,
    design_point_index,
    knee_distances,
    rank_designs,
)
from hypate.scaling.workflow.campaigns.execute import default_run_dir
from hypate.scaling.workflow.vocabulary.study import load_study
from hypate.solvers.errors import InputError


def test_default_run_dir_numbers_new_runs_and_resumes_the_latest(tmp_path: Path) -> None:
    root = tmp_path / "runs"
    assert default_run_dir("q", False, root) == root / "q"
    (root / "q").mkdir(parents=True)
    assert default_run_dir("q", False, root) == root / "q-2"
    (root / "q-2").mkdir()
    assert default_run_dir("q", False, root) == root / "q-3"
    assert default_run_dir("q", True, root) == root / "q-2"
    assert default_run_dir("other", True, root) == root / "other"


# -- the design-point rules (engine.design_point.design_point_index) --------------------------------------
#: A convex two-objective front (rows 0-4) plus two dominated designs (5, 6).
FRONT = np.array([[0.0, 1.0], [0.1, 0.5], [0.3, 0.32], [0.6, 0.12], [1.0, 0.0],
                  [0.7, 0.7], [0.4, 0.9]])


def test_minmax_rule_is_the_smallest_largest_objective() -> None:
    assert design_point_index(FRONT, "minmax") == 2  # max(0.3, 0.32) is the smallest
    assert design_point_index(FRONT) == int(rank_designs(FRONT)[0])  # the default


def test_weighted_rule_normalizes_by_the_pareto_range() -> None:
    # the Pareto range is [0, 1] on both objectives: sums 1.0, 0.6, 0.62, 0.72, 1.0
    assert design_point_index(FRONT, "weighted") == 1
    assert design_point_index(FRONT, "weighted", [1.0, 0.0]) == 0  # J_u only
    assert design_point_index(FRONT, "weighted", [0.0, 1.0]) == 4  # J_T only
    # a zero weight never picks a dominated design that ties on the weighted objective
    tie = np.array([[0.2, 0.9], [0.2, 0.5], [0.6, 0.1]])
    assert design_point_index(tie, "weighted", [1.0, 0.0]) == 1
    # scaling one objective does not move the choice (normalized by the Pareto range)
    scaled = FRONT * np.array([100.0, 1.0])
    assert design_point_index(scaled, "weighted", [0.3, 0.7]) == \
        design_point_index(FRONT, "weighted", [0.3, 0.7])


def test_knee_rule_is_the_farthest_point_from_the_extremes_line() -> None:
    d = knee_distances(FRONT)
    # distance to the line J_u + J_T = 1 through (0, 1) and (1, 0), closed form
    np.testing.assert_allclose(d[:5], (1.0 - FRONT[:5].sum(axis=1)) / np.sqrt(2.0),
                               rtol=0, atol=1e-12)
    assert np.isnan(d[5:]).all()  # dominated designs are no knee
    assert design_point_index(FRONT, "knee") == 1  # 0.4/sqrt(2), the largest


def test_every_rule_is_the_minimum_for_one_objective() -> None:
    F = np.array([[0.4], [0.1], [0.3]])
    for rule in DESIGN_POINT_RULES:
        assert design_point_index(F, rule) == 1
        assert "smallest objective" in describe_rule(rule, 1)


def test_unknown_rule_raises() -> None:
    with pytest.raises(ValueError, match="minmax, weighted, knee"):
        design_point_index(FRONT, "best")


def test_design_point_key_is_validated(tmp_path: Path) -> None:
    path = tmp_path / "s.toml"
    path.write_text(tiny_study_text(tail='design_point = "knee"\n'))
    assert load_study(path).optimizer.design_point == "knee"
    path.write_text(tiny_study_text())
    assert load_study(path).optimizer.design_point == "minmax"  # today's rule by default
    path.write_text(tiny_study_text(tail='design_point = "kne"\n'))
    with pytest.raises(InputError) as info:
        load_study(path)
    assert info.value.field == "optimizer.design_point"
    for allowed in DESIGN_POINT_RULES:
        assert allowed in info.value.message


def test_a_run_records_and_applies_its_rule(tmp_path: Path) -> None:
    """design_point.json names the rule, and its evaluation is that rule's choice among the
    successful, admissible rows of evaluations.csv (ids = row numbers)."""
    study = tmp_path / "knee.toml"
    study.write_text(tiny_study_text(tail='design_point = "knee"\n'))
    out = tmp_path / "run"
    assert main(["run", str(study), "--out", str(out), "-q"]) == 0
    point = json.loads((out / "design_point.json").read_text())
    assert point["rule"] == "knee"
    csv = pd.read_csv(out / "evaluations.csv")
    ok = csv[(csv["status"] == "ok") & csv[["J_u", "J_T"]].notna().all(axis=1)
             & (csv["admissible"].astype(str) == "True")]
    assert len(ok) >= 3 and point["admissible"] is True
    chosen = ok["id"].to_numpy()[design_point_index(ok[["J_u", "J_T"]].to_numpy(), "knee")]
    assert point["evaluation"] == chosen
