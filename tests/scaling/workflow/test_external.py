"""A scaling study on the user's own simulator (scaling.workflow.vocabulary.external, issue 42)."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import REPO, tiny_study_text
from hypate.scaling.workflow.vocabulary.external import SimulatedHistories, external_response
from hypate.scaling.workflow.vocabulary.objectives import ModelFailure
from hypate.scaling.workflow.vocabulary.problem import ScalingProblem
from hypate.scaling.workflow.vocabulary.study import load_study, parse_study
from hypate.solvers.errors import InputError

EXAMPLE = REPO / "studies" / "examples" / "own_simulator.toml"

#: A simulator file of the tests: hypate's own solver behind the protocol, refusing the
#: thinnest models (a region "your code" cannot simulate), and two broken ones.
SIMULATORS = '''
import numpy as np
from hypate import ModelFailure, SimulatedHistories
from hypate.scaling.workflow.vocabulary.configuration import simulate_configuration

def thick_only(configuration):
    if configuration.panel.thickness < 0.003:
        raise ModelFailure("thinner than 3 mm: outside my code's validity")
    r = simulate_configuration(configuration)
    ext = r.extremes()
    return SimulatedHistories(
        deflection=np.asarray(r.center_deflection) / configuration.panel.thickness,
        temperature=np.asarray(r.mean_temperature) / configuration.flow.stagnation_temperature,
        layer_temperature=ext["layer_temperature"], max_stress_ratio=ext["max_stress_ratio"],
        stress_at_ratio=ext["stress_at_ratio"])

def histories_only(configuration):
    r = simulate_configuration(configuration)
    return SimulatedHistories(
        deflection=np.asarray(r.center_deflection) / configuration.panel.thickness,
        temperature=np.asarray(r.mean_temperature) / configuration.flow.stagnation_temperature)

def a_dict(configuration):
    return {"deflection": [0.0], "temperature": [1.0]}
'''


def _study(tmp_path: Path, function: str, sections: str = "", **kw):
    (tmp_path / "sims.py").write_text(SIMULATORS)
    text = tiny_study_text(sections=sections, **kw).replace(
        'aero = "pt-bl"', f'aero = "pt-bl"\nsimulator = "sims.py:{function}"')
    path = tmp_path / "study.toml"
    path.write_text(text)
    return load_study(path)


def test_the_example_simulator_gives_hypates_objectives_exactly():
    # the README's example wraps hypate's own solver: through the protocol (histories over
    # h and T0, back to SI) J, the admissibility columns and the histories the engine's
    # surrogate models agree with the built-in path to rounding (1e-12)
    study = load_study(EXAMPLE)
    assert study.spec.simulator == f"{EXAMPLE.parent / 'own_simulator.py'}:simulate"
    own = ScalingProblem(study.spec)
    builtin = ScalingProblem(dataclasses.replace(study.spec, simulator=None))
    designs = [[5.8, 6.0e7, 1440.0, 1.0, 0.0037], [6.5, 2.0e7, 900.0, 0.3, 0.008]]
    for x in designs:
        J1, G1, aux1 = own.outputs(own.model_configuration(np.array(x)))
        J2, G2, aux2 = builtin.outputs(builtin.model_configuration(np.array(x)))
        for name in ("J_u", "J_T"):
            assert J1[name] == pytest.approx(J2[name], rel=1e-12)
        np.testing.assert_allclose(G1, G2, rtol=1e-12, atol=0.0)
        np.testing.assert_allclose(aux1["histories"], aux2["histories"], rtol=1e-12)
    assert own.prototype_response.scheme == "external"


def test_a_run_on_an_own_simulator_learns_its_failures(tmp_path: Path):
    # a run end to end (evaluations.csv, design point): every design below 3 mm is a failed
    # evaluation with the simulator's own message; the design point is a thicker one
    import hypate

    study = _study(tmp_path, "thick_only", initial=6, iterations=1)
    outcome = hypate.run_study(study, tmp_path / "run")
    ev = pd.read_csv(tmp_path / "run" / "evaluations.csv")
    thin = ev["h"] < 0.003
    assert thin.any() and (~thin).any()
    assert (ev.loc[thin, "status"] != "ok").all()
    assert ev.loc[thin, "message"].str.contains("outside my code's validity").all()
    # the thicker ones run (hypate's solver may still find them unstable: its own message)
    assert (ev.loc[~thin, "status"] == "ok").any()
    assert not ev.loc[~thin, "message"].fillna("").str.contains("my code").any()
    assert outcome.design_point["design"]["h"] >= 0.003


def test_the_protocol_refuses_what_it_cannot_use(tmp_path: Path):
    with pytest.raises(InputError) as err:  # no such module
        parse_study(_toml(tmp_path, "no_such_module_xyz:f"), tmp_path / "s.toml")
    assert err.value.field == "simulation.simulator"
    with pytest.raises(InputError, match="no function 'missing'"):
        _study(tmp_path, "missing")
    with pytest.raises(InputError, match="projection"):  # J of the centre deflection only
        _modal(tmp_path)
    # a dict is not the protocol's histories: refused at the prototype, naming the key
    with pytest.raises(InputError, match="SimulatedHistories") as err:
        ScalingProblem(_study(tmp_path, "a_dict").spec).prototype_response  # noqa: B018
    assert err.value.field == "simulation.simulator"
    # the temperature check needs the layers' temperatures: on without them, refused
    with pytest.raises(InputError) as err:
        ScalingProblem(_study(tmp_path, "histories_only").spec).prototype_response  # noqa: B018
    assert err.value.field == "admissibility.temperature"
    off = '[admissibility]\ntemperature = "off"\ndata = "off"\nstress = "off"\n'
    problem = ScalingProblem(_study(tmp_path, "histories_only", sections=off).spec)
    assert problem.prototype_response.status == "completed"


def _toml(tmp_path: Path, name: str) -> dict:
    import tomllib

    text = tiny_study_text().replace('aero = "pt-bl"', f'aero = "pt-bl"\nsimulator = "{name}"')
    return tomllib.loads(text)


def _modal(tmp_path: Path):
    (tmp_path / "sims.py").write_text(SIMULATORS)
    text = tiny_study_text().replace(
        'aero = "pt-bl"', 'aero = "pt-bl"\nsimulator = "sims.py:thick_only"').replace(
        'xi = 4.0', 'xi = 4.0\nprojection = "modal"')
    path = tmp_path / "modal.toml"
    path.write_text(text)
    return load_study(path)


def test_short_or_diverged_histories_are_failed_evaluations(tmp_path: Path):
    study = _study(tmp_path, "thick_only")
    problem = ScalingProblem(study.spec)
    config = problem.model_configuration(np.array([6.0, 3.0e7, 1200.0, 0.005]))
    n = config.simulation.n_steps + 1
    short = external_response(SimulatedHistories(np.zeros(n - 2), np.ones(n - 2)), config)
    assert short.status == "unstable" and len(short.times) == n - 2
    assert short.times[1] == pytest.approx(config.simulation.time_step)
    with pytest.raises(ModelFailure, match="non-finite"):
        external_response(SimulatedHistories([0.0, np.nan], [1.0, 1.0]), config)
    with pytest.raises(InputError, match="equal length"):
        external_response(SimulatedHistories([0.0, 1.0], [1.0]), config)


def test_the_readme_shows_the_example_as_it_is():
    # README "Your own simulator" prints the example's function: the two cannot drift
    readme = (REPO / "README.md").read_text().split("## Your own simulator", 1)[1]
    shown = readme.split("```python\n", 1)[1].split("```", 1)[0]
    source = (EXAMPLE.parent / "own_simulator.py").read_text()
    assert shown.strip() == source[source.index("def simulate"):].strip()


def test_an_edited_simulator_file_is_another_campaign(tmp_path: Path):
    # the simulator's code decides the results: a resume after editing it is refused,
    # naming the file's hash, like an edited case file or ROM archive
    from hypate.scaling.workflow.campaigns.campaign import campaign_identity, changed_keys

    study = _study(tmp_path, "thick_only")
    before = campaign_identity(study, 0)
    (tmp_path / "sims.py").write_text(SIMULATORS + "\n# edited\n")
    changes = changed_keys(before, campaign_identity(study, 0))
    assert [c.split()[0] for c in changes] == ["files.simulator_sha256"]


def test_an_edited_simulator_module_is_another_campaign(tmp_path: Path,
                                                        monkeypatch: pytest.MonkeyPatch):
    # a "package.module:function" simulator: its module's source file is hashed the same way
    from hypate.scaling.workflow.campaigns.campaign import campaign_identity, changed_keys
    from hypate.scaling.workflow.vocabulary.external import simulator_source

    package = tmp_path / "lib" / "hypate_test_simpkg"
    package.mkdir(parents=True)
    (package / "__init__.py").write_text("")
    (package / "sims.py").write_text(SIMULATORS)
    monkeypatch.syspath_prepend(str(tmp_path / "lib"))
    text = tiny_study_text().replace(
        'aero = "pt-bl"', 'aero = "pt-bl"\nsimulator = "hypate_test_simpkg.sims:thick_only"')
    (tmp_path / "study.toml").write_text(text)
    study = load_study(tmp_path / "study.toml")
    assert simulator_source(study.spec.simulator) == package / "sims.py"
    before = campaign_identity(study, 0)
    assert before["files"]["simulator_sha256"] is not None
    (package / "sims.py").write_text(SIMULATORS + "\n# edited\n")
    changes = changed_keys(before, campaign_identity(study, 0))
    assert [c.split()[0] for c in changes] == ["files.simulator_sha256"]
    assert simulator_source("math:sqrt") is None  # a compiled module: nothing to hash


def test_the_stress_check_reads_the_simulators_stress(tmp_path: Path):
    # a stress check in "constraint" mode: the column is the relative violation of
    # yield / safety factor at the simulator's point of the largest ratio, ratio x SF - 1
    # (von Mises 300 MPa at 1.5 x yield), not a silent 0
    from hypate.scaling.workflow.vocabulary.admissibility import simulated_columns

    study = _study(tmp_path, "thick_only", sections='[admissibility]\nstress = "constraint"\n')
    problem = ScalingProblem(study.spec)
    config = problem.model_configuration(np.array([6.0, 3.0e7, 1200.0, 0.005]))
    n = config.simulation.n_steps + 1
    hist = SimulatedHistories(np.zeros(n), np.ones(n), layer_temperature=[[300.0, 400.0]],
                              max_stress_ratio=1.5, stress_at_ratio=3.0e8)
    G = simulated_columns(problem.admissibility, config.panel,
                          external_response(hist, config).extremes())
    assert problem.admissibility.simulated_constraints[-1] == "stress"
    sf = problem.admissibility.rule("stress").safety_factor
    assert G[-1] == pytest.approx(1.5 * sf - 1.0, rel=1e-12) and G[-1] > 0.0


def test_a_sweep_point_finds_a_relative_simulator_from_anywhere(tmp_path: Path,
                                                               monkeypatch: pytest.MonkeyPatch):
    # the sweep's stored study (study_data) keeps the simulator file absolute, so a
    # sub-study is rebuilt from any working directory (hypate laws, sweeps)
    from hypate.scaling.workflow.vocabulary.derived import study_at, study_data

    study = load_study(EXAMPLE)
    monkeypatch.chdir(tmp_path)
    again = study_at(study_data(study), xi=2.0)
    assert again.spec.simulator == study.spec.simulator
