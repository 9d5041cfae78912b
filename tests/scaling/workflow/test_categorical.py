"""A categorical design variable is a general kind: the model's edge support
(``[variables] boundary = ["simply_supported", "clamped"]``), one row of the variable
table, is chosen by a study exactly as the material is -- level -> model, the outputs
naming it, the what-if -- and a study may choose both at once (the engine enumerates their
combinations)."""
from __future__ import annotations

import json
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import tiny_study_text
from hypate.scaling.cli.main import main
from hypate.scaling.workflow.analyses.whatif import evaluate_whatif
from hypate.scaling.workflow.vocabulary.problem import ScalingProblem
from hypate.scaling.workflow.vocabulary.study import parse_study
from hypate.scaling.workflow.vocabulary.variables import CATEGORICAL, DESIGN_VARIABLES
from hypate.solvers.errors import InputError

EDGES = '["simply_supported", "clamped"]'
MATERIALS = '["ti6242", "inconel718", "al7075"]'


def _text(boundary: str = EDGES, material: str | None = None, **kw) -> str:
    """The tiny study choosing its edge support (and, with ``material``, its material)."""
    sections = f"boundary = {boundary}\n" + (f"material = {material}\n" if material else "")
    text = tiny_study_text(sections=sections, **kw)
    return text.replace('material = "ti6242"\n', "sublayers = 1\n", 1) if material else text


def _study(boundary: str = EDGES, material: str | None = None, **kw):
    return parse_study(tomllib.loads(_text(boundary, material, **kw)))


def _fixed(boundary: str):
    """The tiny study with the edge support fixed in its [model] table."""
    return parse_study(tomllib.loads(tiny_study_text().replace(
        'material = "ti6242"', f'material = "ti6242"\nboundary = "{boundary}"', 1)))


def test_the_edge_support_is_one_row_of_the_table() -> None:
    row = DESIGN_VARIABLES["boundary"]
    assert row.kind == "categorical" and row.target == ("panel", "boundary")
    assert CATEGORICAL == ("material", "boundary")
    study = _study()
    var = study.spec.variables[-1]
    assert (var.name, var.lower, var.upper) == ("boundary", 0.0, 1.0)
    assert "variable boundary in {simply_supported, clamped}" in study.summary()


@pytest.mark.parametrize("entry, words", [('["simply_supported", "welded"]', "'welded' is not"),
                                          ('["clamped"]', "2 to 8"),
                                          ("[0.0, 1.0]", "list of names")])
def test_a_value_the_row_does_not_allow_is_refused_naming_the_key(entry, words) -> None:
    with pytest.raises(InputError) as err:
        _study(entry)
    assert err.value.field == "variables.boundary" and words in err.value.message


@pytest.mark.parametrize("level, name", [(0, "simply_supported"), (1, "clamped")])
def test_each_level_is_the_fixed_support_studys_model(level: int, name: str) -> None:
    """Same continuous design: the model's edges and J_u, J_T equal those of the study
    that fixes the support in its [model] table."""
    mixed = ScalingProblem(_study().spec)
    fixed = ScalingProblem(_fixed(name).spec, prototype_response=mixed.prototype_response)
    xc = np.array([6.0, 2.0e7, 1200.0, 0.004])
    x = np.append(xc, level - 0.2)  # snapped to the nearest level
    assert mixed.choice_names(x) == {"boundary": name} and mixed.design(x)["boundary"] == level
    assert mixed.model_configuration(x).panel.boundary == name
    em, ef = mixed.errors(x), fixed.errors(xc)
    assert em["J_u"] == pytest.approx(ef["J_u"], rel=1e-12)
    assert em["J_T"] == pytest.approx(ef["J_T"], rel=1e-12)


def test_clamping_stiffens_the_model() -> None:
    """The two levels are different models: clamped edges raise the plate's bending
    stiffness, so the centre deflection history differs (a level that changed nothing
    would pass the equality test above vacuously)."""
    p = ScalingProblem(_study().spec)
    xc = [6.0, 2.0e7, 1200.0, 0.004]
    w = [np.abs(p.simulate_model(xc + [k])[1].center_deflection).max() for k in (0, 1)]
    assert w[1] < w[0]


def test_material_and_support_together_are_two_categorical_entries() -> None:
    study = _study(material=MATERIALS)
    problem = ScalingProblem(study.spec)
    cat = problem.categorical
    assert study.spec.categorical_names == ["boundary", "material"]
    assert cat.indices == (4, 5) and cat.sizes == (2, 3) and cat.count == 6
    x = [6.0, 2.0e7, 1200.0, 0.004, 1.0, 2.0]
    cfg = problem.model_configuration(x)
    assert cfg.panel.boundary == "clamped" and cfg.panel.layers[0].material.name == "al7075"
    assert problem.choice_names(x) == {"boundary": "clamped", "material": "al7075"}


def test_whatif_sets_the_support_by_name_on_a_study_that_fixes_it() -> None:
    res = evaluate_whatif(_fixed("simply_supported"), {"boundary": "clamped"})
    ref = evaluate_whatif(_fixed("clamped"), {})
    assert res["boundary"] == "clamped" and res["sources"]["boundary"].startswith("extra")
    assert res["objectives"]["J_u"] == pytest.approx(ref["objectives"]["J_u"], rel=1e-12)
    with pytest.raises(InputError, match="simply_supported, clamped"):
        evaluate_whatif(_fixed("clamped"), {"boundary": "pinned"})


@pytest.fixture(scope="module")
def two_choice_run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("categorical") / "run"
    path = out.parent / "tiny_two_choices.toml"
    path.write_text(_text(material='["ti6242", "inconel718"]', initial=6, iterations=2))
    assert main(["run", str(path), "--out", str(out), "-q"]) == 0
    return out


def test_a_run_choosing_both_names_each_value(two_choice_run: Path) -> None:
    df = pd.read_csv(two_choice_run / "evaluations.csv")
    edges, materials = ["simply_supported", "clamped"], ["ti6242", "inconel718"]
    for col, names in (("boundary", edges), ("material", materials)):
        cols = list(df.columns)
        assert cols[cols.index(col) + 1] == f"{col}_name"
        assert set(df[col]) <= set(map(float, range(len(names))))  # levels only
        assert all(names[int(k)] == n for k, n in zip(df[col], df[f"{col}_name"]))
    # one classical seed per combination of the values, each combination once
    seeds = df[df["iteration"] == -1]
    assert sorted(zip(seeds["boundary_name"], seeds["material_name"])) == sorted(
        (b, m) for b in edges for m in materials)
    point = json.loads((two_choice_run / "design_point.json").read_text())
    for col in ("boundary", "material"):
        block = point[col]
        assert block["name"] == df.loc[point["evaluation"], f"{col}_name"]
        assert set(block["best"]) == set(edges if col == "boundary" else materials)
    page = (two_choice_run / "report.html").read_text()
    assert (f"<td>boundary</td><td>-</td><td>{point['boundary']['name']}</td>"
            "<td>one of: simply_supported, clamped</td>") in page
