"""The ``[variables]`` table (scaling/workflow/vocabulary/design_space.py): a time-scheduled radiant
heater ``T_rad = { schedule = n, range = [lo, hi], shape = ... }`` -- key validation, the
control-point variables, the constant heater reproduced by a flat schedule, the
increasing shape's cheap constraints, what-ifs, seeds, laws and the similarity table."""
from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import tiny_study_text
from hypate.scaling.cli.main import main
from hypate.scaling.workflow.vocabulary.configuration import apply_design
from hypate.scaling.workflow.campaigns.laws import DesignPoint, fit_laws
from hypate.scaling.workflow.vocabulary.problem import ScalingProblem
from hypate.scaling.workflow.campaigns.run import run_study, seeds_from_runs
from hypate.scaling.workflow.vocabulary.similarity import (
    reference_quantities,
    similarity_parameters,
)
from hypate.scaling.workflow.vocabulary.study import load_study, parse_study
from hypate.scaling.workflow.vocabulary.uncertainty import scattered_configuration
from hypate.scaling.workflow.analyses.whatif import evaluate_whatif
from hypate.solvers.errors import InputError
from hypate.solvers.materials import STEFAN_BOLTZMANN

RANGE = "range = [300.0, 2500.0]"


def _study(entry: str, **kw):
    return parse_study(tomllib.loads(tiny_study_text(sections=f"T_rad = {entry}\n", **kw)))


def _write(tmp_path: Path, entry: str, name: str = "tiny.toml", **kw) -> Path:
    path = tmp_path / name
    path.write_text(tiny_study_text(sections=f"T_rad = {entry}\n", **kw))
    return path


# -- the key -----------------------------------------------------------------------------
def test_schedule_expands_into_named_control_points() -> None:
    study = _study(f'{{ schedule = 4, {RANGE} }}')
    assert study.spec.names[-4:] == ["T_rad[0]", "T_rad[1]", "T_rad[2]", "T_rad[3]"]
    assert all((v.lower, v.upper) == (300.0, 2500.0) for v in study.spec.variables[-4:])
    assert study.spec.increasing == ()  # shape "free" by default
    inc = _study(f'{{ schedule = 3, {RANGE}, shape = "increasing" }}')
    assert inc.spec.increasing == ("T_rad",) and len(inc.spec.names) == 4 + 3


BAD_KEYS = [
    ("too few points", f"{{ schedule = 1, {RANGE} }}", "variables.T_rad.schedule", "[2, 12]"),
    ("too many points", f"{{ schedule = 13, {RANGE} }}", "variables.T_rad.schedule", "[2, 12]"),
    ("not an integer", f"{{ schedule = 4.0, {RANGE} }}", "variables.T_rad.schedule", "integer"),
    ("a string", f'{{ schedule = "4", {RANGE} }}', "variables.T_rad.schedule", "integer"),
    ("missing schedule", f"{{ {RANGE} }}", "variables.T_rad.schedule", "missing"),
    ("missing range", "{ schedule = 4 }", "variables.T_rad.range", "missing"),
    ("zero lower", "{ schedule = 4, range = [0.0, 2500.0] }", "variables.T_rad.range", "0 <"),
    ("reversed", "{ schedule = 4, range = [2500.0, 300.0] }", "variables.T_rad.range",
     "lower < upper"),
    ("not finite", "{ schedule = 4, range = [300.0, inf] }", "variables.T_rad.range[1]",
     "finite"),
    ("beyond the hard limits", "{ schedule = 4, range = [300.0, 6000.0] }",
     "variables.T_rad.range", "allowed range"),
    ("one number", "{ schedule = 4, range = [300.0] }", "variables.T_rad.range", "2 items"),
    ("unknown shape", f'{{ schedule = 4, {RANGE}, shape = "falling" }}',
     "variables.T_rad.shape", "'free', 'increasing' or 'decreasing'"),
    ("misspelt key", f'{{ schedule = 4, {RANGE}, shap = "free" }}', "variables.T_rad.shap",
     "did you mean 'shape'"),
]


@pytest.mark.parametrize("label, entry, key, words", BAD_KEYS, ids=[b[0] for b in BAD_KEYS])
def test_bad_schedule_keys_are_refused_naming_the_key(label, entry, key, words) -> None:
    with pytest.raises(InputError) as err:
        _study(entry)
    assert err.value.field == key, label
    assert words in err.value.message, (label, err.value.message)


def test_only_t_rad_can_be_scheduled_and_not_twice() -> None:
    text = tiny_study_text().replace("h = [0.001, 0.01]", f"h = {{ schedule = 3, {RANGE} }}")
    with pytest.raises(InputError) as err:
        parse_study(tomllib.loads(text))
    assert err.value.field == "variables.h" and "only T_rad" in err.value.message
    with pytest.raises(InputError) as err:
        _study(f"{{ schedule = 3, {RANGE} }}", tail="[fixed]\nT_rad = 900.0\n")
    assert err.value.field == "fixed.T_rad"


def test_unknown_shape_exits_2_naming_the_key_and_writes_nothing(tmp_path: Path, capsys) -> None:
    path = _write(tmp_path, f'{{ schedule = 4, {RANGE}, shape = "wavy" }}')
    out = tmp_path / "run"
    assert main(["run", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err.startswith("hypate: error: variables.T_rad") and "shape" in err
    assert not out.exists()


def test_apply_design_needs_every_control_point_and_no_constant_heater() -> None:
    template = _study(f"{{ schedule = 3, {RANGE} }}").spec.model
    cfg = apply_design(template, {"T_rad[0]": 400.0, "T_rad[1]": 900.0, "T_rad[2]": 800.0})
    assert cfg.simulation.radiation_schedule == (400.0, 900.0, 800.0)
    assert cfg.radiation_temperature is None
    for design, key in [({"T_rad[0]": 400.0, "T_rad[2]": 800.0}, "design.T_rad[1]"),
                        ({"T_rad[0]": 400.0}, "design.T_rad[0]"),
                        ({f"T_rad[{k}]": 500.0 for k in range(13)}, "design.T_rad[12]"),
                        ({"T_rad[0]": 400.0, "T_rad[1]": -5.0}, "design.T_rad[1]"),
                        ({"T_rad": 900.0, "T_rad[0]": 400.0, "T_rad[1]": 500.0}, "design.T_rad")]:
        with pytest.raises(InputError) as err:
            apply_design(template, design)
        assert err.value.field == key, design


# -- the constant heater, bit for bit ------------------------------------------------------
def test_flat_schedule_gives_the_constant_heaters_objectives() -> None:
    # the same design with T_rad = 1500 K constant and as a flat 4-point schedule: the
    # heater temperature is 1500 K at every step either way, so J agrees to round-off
    # (measured: bit for bit)
    const = ScalingProblem(_study("[300.0, 2500.0]").spec)
    sched = ScalingProblem(_study(f"{{ schedule = 4, {RANGE} }}").spec)
    x = 0.5 * (const.xl + const.xu)
    x[-1] = 1500.0
    J_const = const.errors(x)
    J_sched = sched.errors(np.r_[x[:-1], [1500.0] * 4])
    for key in ("J_u", "J_T"):
        assert abs(J_sched[key] - J_const[key]) <= 1e-12, key
    # a schedule that is not flat gives another model (the variables reach the simulator)
    J_ramp = sched.errors(np.r_[x[:-1], [300.0, 1000.0, 1800.0, 2500.0]])
    assert abs(J_ramp["J_T"] - J_const["J_T"]) > 1e-3


def test_bi_ext_of_a_schedule_is_its_time_mean_absorbed_flux() -> None:
    const = ScalingProblem(_study("[300.0, 2500.0]").spec)
    sched = ScalingProblem(_study(f"{{ schedule = 3, {RANGE} }}").spec)
    x = 0.5 * (const.xl + const.xu)
    x[-1] = 1500.0
    bi = {r["name"]: r["model"] for r in const.similarity(x)}["Bi_ext"]
    flat = {r["name"]: r["model"] for r in sched.similarity(np.r_[x[:-1], [1500.0] * 3])}
    assert flat["Bi_ext"] == pytest.approx(bi, rel=1e-12)
    ramp = np.r_[x[:-1], [300.0, 900.0, 2100.0]]
    cfg = sched.model_configuration(ramp)
    ref = reference_quantities(cfg)
    # mean of T^4 over two equal linear segments, in closed form
    mean_T4 = np.mean([(b**5 - a**5) / (5 * (b - a)) for a, b in ((300.0, 900.0),
                                                                    (900.0, 2100.0))])
    q = cfg.panel.emissivity * STEFAN_BOLTZMANN * mean_T4
    expect = q * ref.thickness / (ref.conductivity * ref.temperatures.thermal)
    assert similarity_parameters(cfg)["Bi_ext"] == pytest.approx(expect, rel=1e-12)


# -- the increasing shape -----------------------------------------------------------------
def test_increasing_shape_is_a_cheap_linear_inequality(tmp_path: Path) -> None:
    study = load_study(_write(tmp_path, f'{{ schedule = 3, {RANGE}, shape = "increasing" }}',
                              initial=4, iterations=2))
    problem = ScalingProblem(study.spec)
    con = problem.cheap_constraints()[0]  # then the tunnel's size and duration checks
    assert con.kind == "ineq"
    x = 0.5 * (problem.xl + problem.xu)
    x[-3:] = [500.0, 1600.0, 1200.0]  # the last step decreases by 400 K
    np.testing.assert_allclose(con.fun(x), [-1100.0 / 2200.0, 400.0 / 2200.0], rtol=1e-14)
    assert con.violation(x) == pytest.approx(400.0 / 2200.0)
    # every design the run evaluates (classical seed, initial sample, proposals) increases
    run_study(study, tmp_path / "run")
    ev = pd.read_csv(tmp_path / "run" / "evaluations.csv")
    T = ev[["T_rad[0]", "T_rad[1]", "T_rad[2]"]].to_numpy(float)
    assert len(T) == 1 + 4 + 2
    assert np.all(np.diff(T, axis=1) >= -1e-8 * 2200.0)


def test_decreasing_shape_is_the_mirrored_inequality(tmp_path: Path) -> None:
    study = load_study(_write(tmp_path, f'{{ schedule = 3, {RANGE}, shape = "decreasing" }}'))
    assert study.spec.decreasing == ("T_rad",) and study.spec.increasing == ()
    problem = ScalingProblem(study.spec)
    con = problem.cheap_constraints()[0]  # then the tunnel's size and duration checks
    x = 0.5 * (problem.xl + problem.xu)
    x[-3:] = [1600.0, 500.0, 1200.0]  # the last step increases by 700 K
    np.testing.assert_allclose(con.fun(x), [-1100.0 / 2200.0, 700.0 / 2200.0], rtol=1e-14)
    np.testing.assert_array_equal(con.jac(x)[:, -3:], np.array([[-1, 1, 0], [0, -1, 1]])
                                  / 2200.0)
    res = evaluate_whatif(study, {"T_rad[2]": 1700.0})  # 1400 -> 1700 K against the shape
    (ineq,) = res["constraints"]["inequalities"]
    assert ineq["name"] == "T_rad decreasing" and not ineq["satisfied"]
    assert ineq["increase"] == pytest.approx(300.0)
    assert any("increases by 300 K" in f for f in res["constraints"]["outside"])


# -- what-ifs, seeds, laws -----------------------------------------------------------------
def test_whatif_sets_one_control_point(tmp_path: Path, capsys) -> None:
    path = _write(tmp_path, f'{{ schedule = 4, {RANGE}, shape = "increasing" }}')
    res = evaluate_whatif(load_study(path), {"T_rad[1]": 900.0})
    assert res["design"]["T_rad[1]"] == 900.0 and res["sources"]["T_rad[1]"] == "set"
    assert [res["design"][f"T_rad[{k}]"] for k in (0, 2, 3)] == [1400.0] * 3  # midpoints
    assert res["status"] == "ok"
    # 1400 -> 900 K breaks the increasing shape: evaluated anyway, and flagged
    (ineq,) = res["constraints"]["inequalities"]
    assert not ineq["satisfied"] and ineq["decrease"] == pytest.approx(500.0)
    assert any("decreases by 500 K" in f for f in res["constraints"]["outside"])
    assert main(["whatif", str(path), "--set", "T_rad[1]=900", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["design"]["T_rad[1]"] == 900.0
    assert main(["whatif", str(path), "--set", "T_rad[7]=900"]) == 2
    assert "--set" in capsys.readouterr().err


def test_a_constant_heater_run_seeds_a_flat_schedule(tmp_path: Path) -> None:
    first = tmp_path / "const"
    first.mkdir()
    pd.DataFrame({"M": [6.0, 6.5], "p0": [3e6, 4e6], "T0": [1500.0, 1600.0],
                  "h": [0.004, 0.005], "T_rad": [1234.0, 800.0], "J_u": [0.1, 0.3],
                  "J_T": [0.1, 0.2], "status": ["ok", "ok"]}).to_csv(first / "evaluations.csv")
    study = load_study(_write(tmp_path, f"{{ schedule = 3, {RANGE} }}"))
    problem = ScalingProblem(study.spec)
    (x, why), _ = seeds_from_runs(study, problem, [first])
    assert "const evaluation 0" in why
    np.testing.assert_array_equal(x[-3:], [1234.0] * 3)


def test_laws_fit_control_points_with_the_heaters_analytical_exponent() -> None:
    points = [DesignPoint(xi=xi, design={"h": 0.01 / xi, "T_rad[0]": 900.0 * xi**0.1,
                                         "T_rad[1]": 1500.0})
              for xi in (2.0, 3.0, 4.0)]
    laws = {law.variable: law for law in fit_laws(points)}
    assert laws["T_rad[0]"].analytical_exponent == 0.0 == laws["T_rad[1]"].analytical_exponent
    assert laws["T_rad[0]"].fit.exponent == pytest.approx(0.1, rel=1e-9)
    assert laws["h"].analytical_exponent == -1.0
    assert math.isfinite(laws["T_rad[1]"].fit.exponent)


def test_heater_scatter_is_one_factor_on_every_control_point() -> None:
    """``[uncertainty] T_rad`` of a scheduled heater scales the whole programme: at factor
    f each control point is f times the nominal one, on the nominal design's clock."""
    study = _study(f"{{ schedule = 3, {RANGE} }}",
                   tail="[uncertainty]\nT_rad = { normal = 0.05 }\n")
    assert list(study.uncertainty.names) == ["T_rad"]
    problem = ScalingProblem(study.spec)
    x = np.array([6.0, 2.0e7, 1200.0, 0.004, 500.0, 1500.0, 900.0])
    nominal = problem.model_configuration(x)
    cfg = scattered_configuration(problem, x, ["T_rad"], [1.1])
    assert cfg.simulation.radiation_schedule == pytest.approx((550.0, 1650.0, 990.0), rel=1e-14)
    assert cfg.simulation.time_step == nominal.simulation.time_step
    with pytest.raises(InputError) as err:
        _study(f"{{ schedule = 3, {RANGE} }}", tail="[uncertainty]\nT_sky = { normal = 0.05 }\n")
    assert err.value.field == "uncertainty.T_sky"
