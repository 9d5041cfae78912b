"""Continuation of a TC step off the quasi-steady path (``[simulation] continuation_steps``).

Two designs of the quick-start's model (evaluations of the optimizer before the setting
existed): at one, next to the best design, the model "diverged" at its first steps -- one
Newton from the flat t = 0 state across the first temperature step converged to the
unstable equilibrium between the buckled branches; at the other, the same Newton landed on
the *stable* branch the panel does not buckle onto (J_u 223 % where its neighbours have
25 %). Checked against the definition of the path: the continued state is an equilibrium
whose LSA is stable, the same state (to the Newton tolerance) as the continuation with
eight times as many increments, and another state than the one Newton's.
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
#: A design where one Newton buckles the panel the other way (LSA stable).
OTHER_BRANCH = np.array([5.100549522367342, 25945186.968063906, 1587.8111529524172,
                         1.8006397228144184, 0.003068046945404865])
#: A design of the same run as DIVERGED whose steps never leave the path.
STABLE = np.array([5.967065, 7.734541e7, 1523.306509, 1.191799, 0.003762])


@pytest.fixture(scope="module")
def problem() -> ScalingProblem:
    return ScalingProblem(load_study(REPO / "scaling" / "data" / "quickstart.toml").spec)


def _config(problem: ScalingProblem, x: np.ndarray, steps: int):
    config = problem.model_configuration(x)
    return dataclasses.replace(config, simulation=dataclasses.replace(
        config.simulation, continuation_steps=steps))


def _first_step(problem: ScalingProblem, x: np.ndarray, steps: int):
    """One Newton's and the continuation's equilibria of the first step, and the model."""
    config = _config(problem, x, steps)
    settings = config.run_settings(keep_fields=False)
    model = PanelModel(config.panel, config.flow, make_fluid_model(
        settings.aero, settings.heating, settings.boundary_layer), settings)
    u0, T0 = model.initial_state()
    u0, _ = model.equilibrium(u0, T0)
    T1 = model.thermal_step(T0, u0, settings.time_step, T_guess=T0, t=0.0)
    one_newton, _ = model.equilibrium(u0, T1)
    return model, one_newton, model.continued_equilibrium(u0, T0, T1, steps), \
        model.continued_equilibrium(u0, T0, T1, 8 * steps), T1


@pytest.mark.parametrize("x, one_newton_status", [(DIVERGED, "divergence"),
                                                  (OTHER_BRANCH, "neutral")])
def test_first_step_follows_the_path(problem: ScalingProblem, x: np.ndarray,
                                     one_newton_status: str) -> None:
    plain = simulate_configuration(_config(problem, x, 0))
    resp = simulate_configuration(_config(problem, x, 4))
    assert resp.status == "completed"
    assert resp.continued == [pytest.approx(resp.times[1])]
    assert resp.lsa_status[1] in ("stable", "neutral")
    model, one_newton, u4, u32, T1 = _first_step(problem, x, 4)
    assert model.stability(one_newton, T1).status == one_newton_status
    assert not model.stability(u4, T1).unstable
    scale = float(np.linalg.norm(u4))
    assert np.linalg.norm(u4 - u32) <= 1e-6 * scale  # the path, not the increments' choice
    assert np.linalg.norm(u4 - one_newton) >= 0.5 * scale  # another equilibrium altogether
    # the recorded first step is the continued state
    w = model.structure.deflection(u4)[model.structure.mesh.center]
    assert resp.center_deflection[1] == pytest.approx(w, rel=1e-9)
    if plain.status == "completed":  # the other branch: the model buckles the other way
        assert np.sign(plain.center_deflection[-1]) == -np.sign(resp.center_deflection[-1])
    else:
        assert plain.lsa_status[1] == "divergence"


def test_runs_without_divergence_are_unchanged(problem: ScalingProblem) -> None:
    a = simulate_configuration(_config(problem, STABLE, 0))
    b = simulate_configuration(_config(problem, STABLE, 4))
    assert a.status == b.status == "completed" and b.continued == []
    assert a.center_deflection == b.center_deflection
    assert a.mean_temperature == b.mean_temperature
    assert np.array_equal(np.asarray(a.lsa), np.asarray(b.lsa))


def test_continued_steps_survive_a_save(tmp_path: Path, problem: ScalingProblem) -> None:
    resp = simulate_configuration(_config(problem, DIVERGED, 4))
    back = Response.load(resp.save(tmp_path / "r.npz"))
    assert back.continued == resp.continued and back.continued


@pytest.mark.parametrize("steps", [-1, 101])
def test_continuation_steps_out_of_range(steps: int) -> None:
    with pytest.raises(InputError, match=r"simulation\.continuation_steps.*\[0, 100\]"):
        SimulationSettings(continuation_steps=steps)
