"""One simulation-settings type with one set of defaults (solvers/settings.py).

The defect this guards against: the ``[simulation]`` defaults disagreed across four
representations (``rho_bar`` 1.0 in case files, 0.5 in study files and in the scaling
problem, 0.95 in the generalized-alpha parameters), and the external heat flux of a
configuration never reached the simulator. Now every representation is built from
:class:`SimulationSettings`, and a configuration carries the settings it runs.
"""
from __future__ import annotations

import dataclasses
import inspect

import numpy as np
import pytest
from hypate.scaling.workflow.vocabulary.problem import ScalingProblem
from hypate.scaling.workflow.vocabulary.study import SimulationSection, load_study
from hypate.solvers.config import SimulationConfig, parse_case, settings_from_config
from hypate.solvers.coupling.lc import run_lc
from hypate.solvers.errors import InputError
from hypate.solvers.settings import DEFAULTS, SimulationSettings
from hypate.solvers.structure.dynamics import AlphaStepper, GeneralizedAlpha, transient

SETTINGS_FIELDS = {f.name for f in dataclasses.fields(SimulationSettings)}


@pytest.mark.parametrize("schema", [SimulationConfig, SimulationSection])
def test_file_schemas_take_the_one_set_of_defaults(schema) -> None:
    shared = SETTINGS_FIELDS & set(schema.model_fields)
    assert len(shared) >= 8
    for name in shared:
        assert schema.model_fields[name].default == getattr(DEFAULTS, name), name
    if "steps" in schema.model_fields:  # a study counts steps of the prototype time step
        assert schema.model_fields["steps"].default * DEFAULTS.time_step == DEFAULTS.duration


def test_the_integrators_default_to_the_settings_spectral_radius() -> None:
    assert dataclasses.fields(GeneralizedAlpha)[0].default is dataclasses.MISSING
    for fn in (AlphaStepper.__init__, transient):
        assert inspect.signature(fn).parameters["rho_bar"].default == DEFAULTS.rho_bar
    assert inspect.signature(run_lc).parameters["rho_bar"].default is None  # model.settings'


def test_an_empty_case_simulation_table_is_the_defaults() -> None:
    data = {"panel": {"layers": [{"material": "ti6242", "thickness": 0.002}]},
            "flow": {"mach": 6.0, "altitude": 25000.0}, "simulation": {}}
    assert settings_from_config(parse_case(data).simulation) == DEFAULTS


def test_settings_validate_and_name_the_key() -> None:
    with pytest.raises(InputError, match="simulation.rho_bar"):
        SimulationSettings(rho_bar=1.5)
    with pytest.raises(InputError, match="simulation.scheme"):
        SimulationSettings(scheme="s3")
    with pytest.raises(InputError, match="simulation.aero"):
        SimulationSettings(aero="newtonian")


def test_what_the_table_sees_is_what_the_simulator_runs(tiny_study) -> None:
    study = load_study(tiny_study(sections='q_ext = [1.0, 2e5]\n'))
    problem = ScalingProblem(study.spec)
    x = 0.5 * (problem.xl + problem.xu)
    config = problem.model_configuration(x)
    run = config.run_settings()
    # one object: the reference time of the time parameters is the simulated time step,
    # and the table's q_ext is the simulated external heat flux
    assert config.time == run.time_step == problem.model_time_step(config)
    assert config.external_heat_flux == run.external_heat_flux == pytest.approx(x[-1])
    assert run.n_steps == study.spec.simulation.n_steps  # same steps, matched duration
    assert study.spec.simulation.rho_bar == DEFAULTS.rho_bar
    bi_ext = {r["name"]: r for r in problem.similarity(x)}["Bi_ext"]["model"]
    assert bi_ext > 0.0 and np.isfinite(bi_ext)
