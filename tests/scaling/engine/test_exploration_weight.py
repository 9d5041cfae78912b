"""The exploration weight's schedule (``OptimizerSettings.v_final``,
``BayesianOptimizer.exploration_weight``, scaling/engine/optimizer.py): closed-form values
and the weight each iteration's acquisition is built with."""
from __future__ import annotations

import pytest
from hypate.scaling.engine.acquisition import HypervolumeLCB
from hypate.scaling.engine.benchmarks import Branin, BraninCurrin
from hypate.scaling.engine.optimizer import BayesianOptimizer
from hypate.scaling.engine.settings import OptimizerSettings, SettingError

#: HVLCB's own weights: first and last iteration under ``v_final = "auto"``.
V0, V1 = HypervolumeLCB.default_v, HypervolumeLCB.default_v_final


def test_exploration_weight_falls_linearly_to_v_final():
    # HVLCB's defaults: v = 1.5 at iteration 1 falls to default_v_final = 0.5 at n_iter,
    # halfway in between; the polish iteration n_iter + 1 keeps v_final
    opt = BayesianOptimizer(BraninCurrin(), n_iter=11)
    assert opt.settings.v_final == "auto"
    assert [opt.exploration_weight(t) for t in (1, 6, 11, 12)] == pytest.approx(
        [V0, (V0 + V1) / 2, V1, V1], rel=1e-15)
    # v_final None: v as set throughout (None: the acquisition's own default)
    assert BayesianOptimizer(BraninCurrin(), n_iter=11, v_final=None).exploration_weight(6) \
        is None
    two = BayesianOptimizer(BraninCurrin(), n_iter=5, v=2.0, v_final=0.0)
    assert two.exploration_weight(3) == pytest.approx(1.0, rel=1e-15)
    # EI has no default schedule, PoI no weight at all: "auto" keeps v
    assert BayesianOptimizer(Branin(), acquisition="ei").exploration_weight(3) is None
    assert BayesianOptimizer(Branin(), acquisition="poi", v_final=0.1).exploration_weight(3) \
        is None
    with pytest.raises(SettingError, match="'auto'"):
        OptimizerSettings(v_final="late")


def test_each_iteration_builds_its_acquisition_with_the_scheduled_weight():
    seen: list[float] = []

    def factory(model, context):
        seen.append(context.v)
        return HypervolumeLCB.from_context(model, context)

    BayesianOptimizer(BraninCurrin(), acquisition=factory, n_init=5, n_iter=3, v=1.5,
                      v_final=0.5, ref_point=[18.0, 6.0], seed=0).run()
    assert seen == pytest.approx([1.5, 1.0, 0.5], rel=1e-15)
