"""Multi-fidelity Bayesian optimization (scaling.engine.fidelity) on the two-fidelity
Forrester function (Forrester, Sobester & Keane 2007)."""
from __future__ import annotations

import numpy as np
import pytest
from hypate.scaling.engine.fidelity import MultiFidelityOptimizer
from hypate.scaling.engine.functional import FunctionProblem
from hypate.scaling.engine.optimizer import BayesianOptimizer
from hypate.scaling.engine.settings import OptimizerSettings, SettingError
from hypate.scaling.engine.store import EvaluationStore

F_MIN, X_MIN = -6.020740055766075, 0.7572487694238677  # the high-fidelity minimum
COSTS = (0.1, 1.0)


def high(x: float) -> float:
    return (6 * x - 2) ** 2 * np.sin(12 * x - 4)


def low(x: float) -> float:
    return 0.5 * high(x) + 10 * (x - 0.5) - 5


def two_level(z: np.ndarray) -> float:
    return high(z[0]) if round(z[1]) == 1 else low(z[0])


def _optimizer(seed: int, n_iter: int = 10, store=None) -> MultiFidelityOptimizer:
    settings = OptimizerSettings(acquisition="lcb", n_init=3, n_iter=n_iter, seed=seed,
                                 store=store)
    return MultiFidelityOptimizer(FunctionProblem(two_level, [(0.0, 1.0), (0.0, 1.0)]),
                                  settings, costs=COSTS, low_samples=[6])


def _cost(X: np.ndarray) -> float:
    return float(sum(COSTS[int(round(level))] for level in X[:, 1]))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_finds_the_high_fidelity_minimum_and_uses_the_cheap_level(seed):
    result = _optimizer(seed).run()
    top = np.rint(result.X[:, 1]) == 1
    assert np.rint(result.X[:, 1]).min() == 0 and top.sum() >= 3
    k = int(np.argmin(np.where(top, result.F[:, 0], np.inf)))
    assert result.F[k, 0] == pytest.approx(F_MIN, abs=0.02)
    assert result.X[k, 0] == pytest.approx(X_MIN, abs=0.01)


def test_nested_initial_design_and_level_bookkeeping():
    opt = _optimizer(0)
    Z = opt.initial_design()
    low_rows, top_rows = Z[Z[:, 1] == 0], Z[Z[:, 1] == 1]
    assert len(top_rows) == 3 and len(low_rows) == 3 + 6
    # every top design is also simulated at the cheap level (nested designs)
    assert all(np.any(np.all(np.isclose(low_rows[:, :1], t[:1]), axis=1)) for t in top_rows)


def test_resumed_run_replays_the_stored_levels(tmp_path):
    full = _optimizer(1, n_iter=5, store=str(tmp_path / "a.sqlite")).run()
    with EvaluationStore(tmp_path / "b.sqlite") as store:
        _optimizer(1, n_iter=2, store=store).run()
    again = _optimizer(1, n_iter=5, store=str(tmp_path / "b.sqlite")).run()
    assert np.array_equal(full.X, again.X) and np.array_equal(full.F, again.F)


def test_settings_are_checked():
    problem = FunctionProblem(two_level, [(0.0, 1.0), (0.0, 1.0)])
    base = OptimizerSettings(n_init=3, n_iter=1)
    with pytest.raises(SettingError, match="costs"):
        MultiFidelityOptimizer(problem, base, costs=[1.0], low_samples=[])
    with pytest.raises(SettingError, match="low_samples"):
        MultiFidelityOptimizer(problem, base, costs=COSTS, low_samples=[1, 2])
    with pytest.raises(SettingError, match="level"):
        MultiFidelityOptimizer(FunctionProblem(two_level, [(0.0, 1.0), (0.0, 2.0)]), base,
                               costs=COSTS, low_samples=[1])
