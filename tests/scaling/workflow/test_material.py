"""The model material as a categorical design variable (``[variables] material = [...]``):
key validation, level -> material in the model (objectives identical to a fixed-material
study's), the run's outputs (evaluations.csv, design_point.json, classical.json, report),
what-ifs and the laws."""
from __future__ import annotations

import json
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import tiny_study_text
from hypate.scaling.cli.main import main
from hypate.scaling.engine.mixed import MixedCoordinates
from hypate.scaling.workflow.analyses.whatif import evaluate_whatif
from hypate.scaling.workflow.campaigns.laws import (
    DesignPoint,
    fit_laws,
    materials_by_scale,
    predicted_design,
)
from hypate.scaling.workflow.campaigns.run import surrogate_coordinates
from hypate.scaling.workflow.vocabulary.problem import ScalingProblem
from hypate.scaling.workflow.vocabulary.study import parse_study
from hypate.solvers.errors import InputError

MATERIALS = '["ti6242", "inconel718", "al7075"]'


def _text(entry: str = MATERIALS, model: str = "sublayers = 1", objectives: str = "",
          **kw) -> str:
    """The tiny study with ``material = entry`` among its variables and ``model`` as the
    body of its [model] table (no fixed material); ``objectives`` replaces its list."""
    text = tiny_study_text(sections=f"material = {entry}\n", **kw).replace(
        'material = "ti6242"\n', model + "\n", 1)
    return text.replace('["J_u", "J_T"]', objectives, 1) if objectives else text


def _study(entry: str = MATERIALS, **kw):
    return parse_study(tomllib.loads(_text(entry, **kw)))


def _fixed(material: str):
    """The tiny study with a fixed [model] material (the same continuous variables)."""
    return parse_study(tomllib.loads(tiny_study_text().replace(
        'material = "ti6242"', f'material = "{material}"', 1)))


# -- the key -----------------------------------------------------------------------------
def test_material_list_is_one_variable_with_a_level_per_name() -> None:
    study = _study()
    var = study.spec.variables[-1]
    assert (var.name, var.lower, var.upper) == ("material", 0.0, 2.0)
    assert study.spec.material_names == ("ti6242", "inconel718", "al7075")
    assert ScalingProblem(study.spec).categorical.count == 3
    assert "variable material in {ti6242, inconel718, al7075}" in study.summary()


BAD = [
    ("unknown name", '["ti6242", "unobtainium"]', {}, "variables.material", "unknown material"),
    ("one name", '["ti6242"]', {}, "variables.material", "2 to 8"),
    ("repeated", '["ti6242", "ti6242"]', {}, "variables.material", "twice"),
    ("numbers", "[0.0, 2.0]", {}, "variables.material", "list of names"),
    ("with a fixed material", MATERIALS, {"model": 'material = "ti6242"'}, "model.material",
     "one or the other"),
    ("with a polish", MATERIALS, {"tail": "polish = 3", "objectives": '["J_s"]'},
     "optimizer.polish", "set it to 0"),
]


@pytest.mark.parametrize("label, entry, kw, key, words", BAD, ids=[b[0] for b in BAD])
def test_bad_material_keys_are_refused_naming_the_key(label, entry, kw, key, words) -> None:
    with pytest.raises(InputError) as err:
        _study(entry, **kw)
    assert err.value.field.startswith(key) and words in err.value.message


def test_names_for_a_continuous_variable_and_a_fixed_material_number_are_refused() -> None:
    text = tiny_study_text().replace("h = [0.001, 0.01]", 'h = ["a", "b"]')
    with pytest.raises(InputError, match="numbers") as err:
        parse_study(tomllib.loads(text))
    assert err.value.field == "variables.h"
    with pytest.raises(InputError, match="categorical") as err:
        parse_study(tomllib.loads(tiny_study_text(sections="[fixed]\nmaterial = 1.0\n")))
    assert err.value.field == "fixed.material"


def test_a_robust_search_over_a_categorical_material_is_refused() -> None:
    tail = ('[uncertainty]\n"model.youngs_modulus" = { normal = 0.03 }\n'
            '[robust]\nstatistic = "mean"\n')
    with pytest.raises(InputError, match="robust") as err:
        _study(tail=tail)
    assert err.value.field == "robust"


def test_a_categorical_material_has_no_scatter_its_properties_do() -> None:
    with pytest.raises(InputError, match="categorical") as err:
        _study(tail="[uncertainty]\nmaterial = { normal = 0.1 }\n")
    assert err.value.field == "uncertainty.material"
    study = _study(tail='[uncertainty]\n"model.conductivity" = { normal = 0.05 }\n')
    assert list(study.uncertainty.names) == ["model.conductivity"]


def test_a_study_material_table_is_a_level() -> None:
    tail = ('[materials.my_alloy]\nkind = "isotropic"\ndensity = 4000.0\n'
            'youngs_modulus = 1.0e11\npoisson_ratio = 0.3\nthermal_expansion = 1.0e-5\n'
            'conductivity = 10.0\nspecific_heat = 600.0\n')
    study = _study('["ti6242", "my_alloy"]', tail=tail)
    cfg = ScalingProblem(study.spec).model_configuration([6.0, 1e7, 1000.0, 0.004, 1.0])
    mat = cfg.panel.layers[0].material
    assert float(mat.density(500.0)) == 4000.0 and float(mat.specific_heat(500.0)) == 600.0


# -- level -> model ------------------------------------------------------------------------
@pytest.mark.parametrize("level, name", [(0, "ti6242"), (1, "inconel718"), (2, "al7075")])
def test_each_level_is_the_fixed_material_studys_model(level: int, name: str) -> None:
    """Same continuous design: the model, its matched time step (Eq. 9.6 with the
    material's Fourier reference) and J_u, J_T equal the fixed-material study's exactly."""
    mixed = ScalingProblem(_study().spec)
    fixed_study = _fixed(name)
    fixed = ScalingProblem(fixed_study.spec, prototype_response=mixed.prototype_response)
    xc = np.array([6.0, 2.0e7, 1200.0, 0.004])
    x = np.append(xc, level + 0.3)  # snapped to the nearest level
    assert mixed.material_name(x) == name and mixed.design(x)["material"] == level
    cm, cf = mixed.model_configuration(x), fixed.model_configuration(xc)
    assert cm.panel.layers[0].material.name == cf.panel.layers[0].material.name
    assert cm.simulation.time_step == pytest.approx(cf.simulation.time_step, rel=1e-14)
    em, ef = mixed.errors(x), fixed.errors(xc)
    assert em["J_u"] == pytest.approx(ef["J_u"], rel=1e-12)
    assert em["J_T"] == pytest.approx(ef["J_T"], rel=1e-12)
    assert mixed.active_bounds(x) == fixed.active_bounds(xc)  # a level is no bound


def test_materials_change_the_matched_time_step() -> None:
    """Fourier time scaling: dt_m / dt_p = (L_m / L_p)^2 (alpha_p / alpha_m), Eq. (9.6), so
    the ratio of two materials' time steps at one design is their diffusivity ratio."""
    p = ScalingProblem(_study().spec)
    xc = [6.0, 2.0e7, 1200.0, 0.004]
    dt = [p.model_configuration(xc + [k]).simulation.time_step for k in (0, 2)]
    ref = [p.model_configuration(xc + [k]) for k in (0, 2)]
    from_props = []
    for cfg in ref:
        m, T = cfg.panel.layers[0].material, cfg.panel.initial_temperature
        rho_c = float(m.density(T)) * float(m.specific_heat(T))
        from_props.append(rho_c / float(m.k1(T)))
    assert dt[1] / dt[0] == pytest.approx(from_props[1] / from_props[0], rel=1e-9)


@pytest.mark.parametrize("kind", ["log", "similarity"])
def test_surrogate_coordinates_span_the_continuous_variables_only(kind: str) -> None:
    """The material's level has lower bound 0 (no log) and no similarity exponent: the
    log / similarity axes are built over the 4 continuous variables, and the engine's
    one-hot coordinates take them as they are."""
    study = _study(tail=f'coordinates = "{kind}"')
    problem = ScalingProblem(study.spec)
    coords = surrogate_coordinates(study, problem)
    assert coords.matrix.shape == (4, 4)
    mixed = MixedCoordinates(problem.categorical, problem.n_var, coords)
    z = mixed(np.array([[6.0, 2.0e7, 1200.0, 0.004, 2.0]]))
    assert z.shape == (1, 4 + 3) and list(z[0, 4:]) == [0.0, 0.0, 1.0]
    assert z[0, :4] == pytest.approx(coords(np.array([[6.0, 2.0e7, 1200.0, 0.004]]))[0])


# -- a run ---------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def material_run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("material") / "run"
    path = out.parent / "tiny_material.toml"
    path.write_text(_text(initial=6, iterations=3))
    assert main(["run", str(path), "--out", str(out)]) == 0
    return out


def test_run_outputs_name_the_material(material_run: Path) -> None:
    df = pd.read_csv(material_run / "evaluations.csv")
    cols = list(df.columns)
    assert cols[cols.index("material") + 1] == "material_name"
    names = ["ti6242", "inconel718", "al7075"]
    assert all(names[int(k)] == n for k, n in zip(df["material"], df["material_name"]))
    assert set(df["material"]) <= {0.0, 1.0, 2.0}  # levels only, never in between
    point = json.loads((material_run / "design_point.json").read_text())
    block = point["material"]
    assert block["levels"] == names and block["name"] == names[block["level"]]
    assert point["design"]["material"] == block["level"]
    assert df.loc[point["evaluation"], "material_name"] == block["name"]
    assert not any(a.startswith("material=") for a in point["active_constraints"])


def test_classical_baseline_per_material_and_the_best_heads_it(material_run: Path) -> None:
    df = pd.read_csv(material_run / "evaluations.csv")
    seeds = df[df["iteration"] == -1]
    assert list(seeds["material_name"]) == ["ti6242", "inconel718", "al7075"]
    classical = json.loads((material_run / "classical.json").read_text())
    by = classical["by_material"]
    assert list(by) == ["ti6242", "inconel718", "al7075"]
    worst = {name: max(rec["objectives"].values()) for name, rec in by.items()}
    assert classical["material"] == min(worst, key=worst.get)
    for (_, row), (name, rec) in zip(seeds.iterrows(), by.items()):
        assert rec["objectives"]["J_u"] == pytest.approx(row["J_u"], rel=1e-12)
        assert rec["design"]["material"] == ["ti6242", "inconel718", "al7075"].index(name)


def test_report_shows_the_material_by_name(material_run: Path) -> None:
    page = (material_run / "report.html").read_text()
    point = json.loads((material_run / "design_point.json").read_text())
    assert (f"<td>material</td><td>-</td><td>{point['material']['name']}</td>"
            "<td>one of: ti6242, inconel718, al7075</td>") in page


# -- what-if and laws ----------------------------------------------------------------------
def test_whatif_sets_the_material_by_name() -> None:
    study = _study()
    res = evaluate_whatif(study, {"material": "al7075", "h": 0.004})
    assert res["material"] == "al7075" and res["design"]["material"] == 2.0
    x = np.array([res["design"][n] for n in study.spec.names])
    assert res["objectives"]["J_T"] == pytest.approx(
        ScalingProblem(study.spec).errors(x)["J_T"], rel=1e-12)
    unset = evaluate_whatif(study, {"h": 0.004})
    assert unset["material"] == "ti6242" and unset["sources"]["material"] == "first listed"


def test_whatif_material_on_a_fixed_material_study_swaps_the_template() -> None:
    res = evaluate_whatif(_fixed("ti6242"), {"material": "inconel718"})
    ref = evaluate_whatif(_fixed("inconel718"), {})
    assert res["material"] == "inconel718" and res["sources"]["material"].startswith("extra")
    assert res["objectives"]["J_u"] == pytest.approx(ref["objectives"]["J_u"], rel=1e-12)


def test_whatif_unknown_material_exits_2_naming_set(tmp_path: Path, capsys) -> None:
    path = tmp_path / "s.toml"
    path.write_text(_text())
    assert main(["whatif", str(path), "--set", "material=steel"]) == 2
    err = capsys.readouterr().err
    assert "--set" in err and "'steel'" in err and "ti6242, inconel718, al7075" in err


def test_laws_report_the_material_per_scale_and_do_not_fit_it() -> None:
    bounds = {"h": (1e-4, 5e-2), "material": (0.0, 2.0)}
    points = [DesignPoint(xi=xi, design={"h": 0.02 / xi, "material": level}, bounds=bounds,
                          material=name)
              for xi, level, name in ((2.0, 1.0, "inconel718"), (4.0, 0.0, "ti6242"))]
    laws = fit_laws(points)
    assert [law.variable for law in laws] == ["h"]
    assert laws[0].fit.exponent == pytest.approx(-1.0, abs=1e-12)
    assert materials_by_scale(points) == [{"xi": 2.0, "material": "inconel718"},
                                          {"xi": 4.0, "material": "ti6242"}]
    design = predicted_design(laws, points, 5.0, ["h", "material"])
    assert design["material"] == 0.0 and design["h"] == pytest.approx(0.004, rel=1e-9)


def test_a_sweep_reports_each_scales_material_in_hypate_laws(tmp_path: Path, capsys) -> None:
    path = tmp_path / "sweep.toml"
    path.write_text(_text(initial=4, iterations=1,
                          tail="[sweep]\nxi = [2.0, 4.0]\ninitial_samples = 3\niterations = 1\n"))
    out = tmp_path / "run"
    assert main(["run", str(path), "--out", str(out)]) == 0
    chosen = {}
    for label in ("xi_2", "xi_4"):
        point = json.loads((out / label / "design_point.json").read_text())
        chosen[point["xi"]] = point["material"]["name"]
    capsys.readouterr()
    assert main(["laws", str(out), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["materials"] == [{"xi": xi, "material": name} for xi, name in chosen.items()]
    assert "material" not in [law["variable"] for law in doc["laws"]]
    assert main(["laws", str(out)]) == 0
    text = capsys.readouterr().out
    assert all(f"material at xi = {xi:g}: {name}" in text for xi, name in chosen.items())
    sweep_csv = pd.read_csv(out / "sweep.csv")
    assert list(sweep_csv["material_name"]) == list(chosen.values())
