"""Multi-fidelity Bayesian optimization (scaling.engine.fidelity) on the two-fidelity
Forrester function (Forrester, Sobester & Keane 2007)."""
from __future__ import annotations

import dataclasses
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest
from hypate.scaling.engine.fidelity import MultiFidelityOptimizer
from hypate.scaling.engine.functional import FunctionProblem
from hypate.scaling.engine.multifidelity import MultiFidelityKriging, MultiFidelityModel
from hypate.scaling.engine.settings import OptimizerSettings, RunContext, SettingError
from hypate.scaling.engine.store import EvaluationStore

F_MIN, X_MIN = -6.020740055766075, 0.7572487694238677  # the high-fidelity minimum
COSTS = (0.1, 1.0)


def high(x: float) -> float:
    return (6 * x - 2) ** 2 * np.sin(12 * x - 4)


def low(x: float) -> float:
    return 0.5 * high(x) + 10 * (x - 0.5) - 5


def two_level(z: np.ndarray) -> float:
    return high(z[0]) if round(z[1]) == 1 else low(z[0])


def _optimizer(seed: int, n_iter: int = 10, store=None, batch: int = 1
               ) -> MultiFidelityOptimizer:
    settings = OptimizerSettings(acquisition="lcb", n_init=3, n_iter=n_iter, seed=seed,
                                 batch_size=batch)
    return MultiFidelityOptimizer(FunctionProblem(two_level, [(0.0, 1.0), (0.0, 1.0)]),
                                  settings, RunContext(store=store), costs=COSTS,
                                  low_samples=[6])


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


@pytest.mark.parametrize("batch", [1, 2])
def test_resumed_run_replays_the_stored_levels(tmp_path, batch):
    full = _optimizer(1, n_iter=5, store=str(tmp_path / "a.sqlite"), batch=batch).run()
    with EvaluationStore(tmp_path / "b.sqlite") as store:
        _optimizer(1, n_iter=2, store=store, batch=batch).run()
    again = _optimizer(1, n_iter=5, store=str(tmp_path / "b.sqlite"), batch=batch).run()
    assert np.array_equal(full.X, again.X) and np.array_equal(full.F, again.F)
    assert len(full.X) == 3 * 2 + 6 + 5 * batch


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


def _forrester_model(X_low: np.ndarray, X_top: np.ndarray) -> MultiFidelityModel:
    mf = MultiFidelityKriging(np.array([[0.0, 1.0]])).fit(
        [X_low[:, None], X_top[:, None]], [low(X_low), high(X_top)])
    return MultiFidelityModel([mf])


def _promotion(opt: MultiFidelityOptimizer, X_low: np.ndarray, X_top: np.ndarray):
    X = np.r_[X_low, X_top][:, None]
    level = np.r_[np.zeros(len(X_low), int), np.ones(len(X_top), int)]
    F_top = high(X_top)[:, None]
    return opt.promotion(_forrester_model(X_low, X_top), X, np.ones(len(X), bool), level,
                         F_top)


def test_promotion_sends_the_best_predicted_cheap_design_to_the_top():
    opt = _optimizer(0)
    X_low, X_top = np.linspace(0.0, 1.0, 11), np.array([0.0, 0.4, 0.6, 1.0])
    x = _promotion(opt, X_low, X_top)
    # the co-kriging's best cheap design not yet simulated at the top ...
    fresh = X_low[np.abs(X_low[:, None] - X_top[None]).min(axis=1) > 1e-5]
    mu = _forrester_model(X_low, X_top).predict_moments(fresh[:, None])[0][:, 0]
    assert x is not None and x[0] == pytest.approx(fresh[np.argmin(mu)], abs=1e-12)
    # ... is truly better than every top-level observation (x = 0.7 or 0.8, f < -4.6)
    assert high(x[0]) < high(X_top).min()
    # a design already simulated at the top (within min_distance) is not promoted again
    again = _promotion(opt, X_low, np.r_[X_top, x[0] + 1e-7])
    assert again is None or abs(again[0] - x[0]) > 1e-5


def test_no_promotion_when_the_top_level_is_already_best_or_everything_ran_there():
    opt = _optimizer(0)
    X_low = np.linspace(0.0, 1.0, 11)
    # the top level holds the true minimum: no cheap design is predicted below it
    assert _promotion(opt, X_low, np.array([0.0, 0.4, X_MIN, 1.0])) is None
    # every cheap design has run at the top: nothing left to promote
    assert _promotion(opt, X_low, X_low.copy()) is None


def _two_objectives(z: np.ndarray) -> list[float]:
    return [two_level(z), (z[0] - 0.3) ** 2 + 0.1 * z[1]]


def test_workers_store_the_serial_campaign():
    """With a process pool (the nested initial design evaluated two at a time, the start
    design built beside it) the campaign is the in-process one, bit for bit."""
    problem = FunctionProblem(_two_objectives, [(0.0, 1.0), (0.0, 1.0)], n_obj=2)
    settings = OptimizerSettings(acquisition="hvlcb", n_init=3, n_iter=6, seed=2,
                                 ref_point=[20.0, 2.0])
    serial = MultiFidelityOptimizer(problem, settings, costs=COSTS, low_samples=[5]).run()
    with ProcessPoolExecutor(2) as pool:
        shared = MultiFidelityOptimizer(problem, settings, RunContext(executor=pool),
                                        costs=COSTS, low_samples=[5]).run()
    assert np.array_equal(serial.X, shared.X) and np.array_equal(serial.F, shared.F)
    assert len(np.unique(serial.X[:, 1])) == 2  # both levels were used


def test_a_batch_believes_its_members(tmp_path):
    """batch_size 2: each iteration stores two designs at least min_distance apart; the
    first is the serial proposal's from the same records (the same model and random
    numbers; a promotion or the acquisition's design); a process pool stores the same
    campaign; the top-level minimum is still found."""
    problem = FunctionProblem(two_level, [(0.0, 1.0), (0.0, 1.0)])
    settings = OptimizerSettings(acquisition="lcb", n_init=3, n_iter=6, seed=0, batch_size=2)
    stored = RunContext(store=str(tmp_path / "b.sqlite"))
    result = MultiFidelityOptimizer(problem, settings, stored, costs=COSTS,
                                    low_samples=[6]).run()
    it = result.data["iteration"].to_numpy()
    assert len(it) == 3 * 2 + 6 + 6 * 2
    with EvaluationStore(tmp_path / "b.sqlite") as store:
        records = store.load()
    serial = MultiFidelityOptimizer(problem, dataclasses.replace(settings, batch_size=1),
                                    costs=COSTS, low_samples=[6])
    for t in range(1, 7):
        rows = result.X[it == t]
        assert len(rows) == 2 and abs(rows[0, 0] - rows[1, 0]) >= settings.min_distance
        first = serial.propose([r for r in records if r.iteration < t], t)
        assert np.array_equal(first[0], rows[0])
    with ProcessPoolExecutor(2) as pool:
        shared = MultiFidelityOptimizer(problem, settings, RunContext(executor=pool),
                                        costs=COSTS, low_samples=[6]).run()
    assert np.array_equal(result.X, shared.X) and np.array_equal(result.F, shared.F)
    top = np.rint(result.X[:, 1]) == 1
    k = int(np.argmin(np.where(top, result.F[:, 0], np.inf)))
    assert result.F[k, 0] == pytest.approx(F_MIN, abs=0.02)


def test_a_batch_needs_the_believer():
    settings = OptimizerSettings(n_init=3, n_iter=1, batch_size=2, batch_strategy="liar")
    with pytest.raises(SettingError, match="believer"):
        MultiFidelityOptimizer(FunctionProblem(two_level, [(0.0, 1.0), (0.0, 1.0)]), settings,
                               costs=COSTS, low_samples=[1])
