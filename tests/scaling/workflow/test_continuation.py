"""Continuation of a TC step the LSA finds divergent (``[simulation] continuation_steps``).

The quick-start's model at a design next to its best (seed 8's evaluation 50 of the
shipped optimizer, before the setting existed) "diverged" at its first steps: one Newton from
the flat t = 0 state across the first temperature step converged to the unstable
equilibrium between the buckled branches, while the quasi-steady path continued in the
temperature stays on a stable branch. Checked against the definition of the path: the
continued state is an equilibrium whose LSA is stable, and the same state (to the Newton
tolerance) as the continuation with four times as many increments.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from hypate.scaling.workflow.vocabulary.configuration import simulate_configuration
from hypate.scaling.workflow.vocabulary.problem import ScalingProblem
from hypate.scaling.workflow.vocabulary.study import load_study
from hypate.solvers.aero.factory import make_fluid_model
from hypate.solvers.coupling.model import PanelModel
from hypate.solvers.coupling.response import Response
from hypate.solvers.errors import InputError
from hypate.solvers.settings import SimulationSettings

REPO = Path(__file__).resolve().parents[3]
#: (M, p0, T0, L_le, h) of the design (quick-start variables, SI).
DIVERGED = np.array([5.962351, 7.683479e7, 1514.699923, 1.176139, 0.003734])
#: A design of the same run whose steps never diverge.
STABLE = np.array([5.967065, 7.734541e7, 1523.306509, 1.191799, 0.003762])


@pytest.fixture(scope="module")
def problem() -> ScalingProblem:
    return ScalingProblem(load_study(REPO / "scaling" / "data" / "quickstart.toml").spec)


def _config(problem: ScalingProblem, x: np.ndarray, steps: int):
    config = problem.model_configuration(x)
    return dataclasses.replace(config, simulation=dataclasses.replace(
        config.simulation, continuation_steps=steps))


def test_divergent_step_is_continued_onto_the_stable_branch(problem: ScalingProblem) -> None:
    plain = simulate_configuration(_config(problem, DIVERGED, 0))
    assert plain.status == "unstable" and plain.lsa_status[1] == "divergence"
    config = _config(problem, DIVERGED, 8)
    resp = simulate_configuration(config)
    assert resp.status == "completed"
    assert resp.continued == [pytest.approx(resp.times[1])]
    assert resp.lsa_status[1] in ("stable", "neutral")
    # the continued state: a stable equilibrium on the path, the same with 32 increments
    settings = config.run_settings(keep_fields=False)
    model = PanelModel(config.panel, config.flow, make_fluid_model(
        settings.aero, settings.heating, settings.boundary_layer), settings)
    u0, T0 = model.initial_state()
    u0, _ = model.equilibrium(u0, T0)
    T1 = model.thermal_step(T0, u0, settings.time_step, T_guess=T0, t=0.0)
    one_newton, _ = model.equilibrium(u0, T1)
    assert model.stability(one_newton, T1).status == "divergence"
    u8 = model.continued_equilibrium(u0, T0, T1, 8)
    u32 = model.continued_equilibrium(u0, T0, T1, 32)
    assert not model.stability(u8, T1).unstable
    scale = float(np.max(np.abs(u8)))
    assert np.max(np.abs(u8 - u32)) <= 1e-6 * scale
    assert np.max(np.abs(u8 - one_newton)) >= 0.1 * scale  # another equilibrium altogether
    w = resp.center_deflection[1]
    assert abs(w - plain.center_deflection[1]) >= 0.1 * abs(w)


def test_runs_without_divergence_are_unchanged(problem: ScalingProblem) -> None:
    a = simulate_configuration(_config(problem, STABLE, 0))
    b = simulate_configuration(_config(problem, STABLE, 8))
    assert a.status == b.status == "completed" and b.continued == []
    assert a.center_deflection == b.center_deflection
    assert a.mean_temperature == b.mean_temperature
    assert np.array_equal(np.asarray(a.lsa), np.asarray(b.lsa))


def test_continued_steps_survive_a_save(tmp_path: Path, problem: ScalingProblem) -> None:
    resp = simulate_configuration(_config(problem, DIVERGED, 8))
    back = Response.load(resp.save(tmp_path / "r.npz"))
    assert back.continued == resp.continued and back.continued


@pytest.mark.parametrize("steps", [-1, 101])
def test_continuation_steps_out_of_range(steps: int) -> None:
    with pytest.raises(InputError, match=r"simulation\.continuation_steps.*\[0, 100\]"):
        SimulationSettings(continuation_steps=steps)
