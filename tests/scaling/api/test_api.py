"""`import hypate`: the documented Python API (scaling/api/__init__.py)."""
from __future__ import annotations

import doctest

import hypate
import hypate._api as hypate_api  # where the lazy top-level package's names live
import numpy as np
import pandas as pd
import pytest
from hypate.scaling.engine.benchmarks import BraninCurrin

BRANIN_MIN = 0.397887  # global minimum of the Branin function (three minimizers)


def branin(x: np.ndarray) -> float:
    b, c = 5.1 / (4 * np.pi**2), 5 / np.pi
    return float((x[1] - b * x[0]**2 + c * x[0] - 6)**2
                 + 10 * (1 - 1 / (8 * np.pi)) * np.cos(x[0]) + 10)


def test_the_documented_names_are_there() -> None:
    for name in ("load_study", "run_study", "Study", "BayesianOptimizer", "minimize"):
        assert name in hypate.__all__ and hasattr(hypate, name)


@pytest.mark.parametrize("seed", range(5))
def test_minimize_finds_the_branin_minimum_for_every_seed(seed: int) -> None:
    res = hypate.minimize(branin, bounds=[(-5, 10), (0, 15)], n_evaluations=40, seed=seed)
    assert res.success and res.nfev == 40
    assert abs(res.fun - BRANIN_MIN) < 1e-3           # the acceptance tolerance
    assert branin(res.x) == pytest.approx(res.fun, rel=1e-12)
    ev = res.evaluations
    assert isinstance(ev, pd.DataFrame) and len(ev) == 40
    assert ev["f0"].min() == pytest.approx(res.fun, rel=1e-12)


def test_minimize_is_reproducible_for_a_seed() -> None:
    a = hypate.minimize(branin, bounds=[(-5, 10), (0, 15)], n_evaluations=20, seed=3)
    b = hypate.minimize(branin, bounds=[(-5, 10), (0, 15)], n_evaluations=20, seed=3)
    np.testing.assert_array_equal(a.evaluations[["x0", "x1", "f0"]].to_numpy(),
                                  b.evaluations[["x0", "x1", "f0"]].to_numpy())


def test_minimize_takes_several_objectives_and_pymoo_problems() -> None:
    def two(x: np.ndarray) -> list[float]:
        return [x[0]**2 + x[1]**2, (x[0] - 1)**2 + x[1]**2]

    res = hypate.minimize(two, bounds=[(-2, 2), (-2, 2)], n_evaluations=20, seed=1)
    # the Pareto set of these two paraboloids is the segment 0 <= x0 <= 1, x1 = 0
    assert res.pareto_fun.shape[1] == 2 and len(res.pareto_fun) >= 3
    assert np.all(np.diff(res.pareto_fun[:, 0]) >= 0)  # sorted by the first objective
    assert res.fun.shape == (2,) and max(res.fun) <= min(max(f) for f in res.pareto_fun) + 1e-12
    res = hypate.minimize(BraninCurrin(), n_evaluations=16, seed=0)
    assert res.nfev == 16 and res.pareto_fun.shape[1] == 2


def test_minimize_refuses_bad_input() -> None:
    with pytest.raises(ValueError, match="bounds"):
        hypate.minimize(branin, n_evaluations=20)
    with pytest.raises(ValueError, match="lower < upper"):
        hypate.minimize(branin, bounds=[(1, 0), (0, 15)], n_evaluations=20)
    with pytest.raises(ValueError, match="n_evaluations"):
        hypate.minimize(branin, bounds=[(-5, 10), (0, 15)], n_evaluations=3)
    # a function that breaks its contract fails its evaluations (recorded, not a crash)
    res = hypate.minimize(lambda x: [1.0, 2.0], bounds=[(0, 1)], n_obj=1, n_evaluations=8)
    assert not res.success and res.x is None
    assert res.evaluations["message"].str.contains("number").all()


def test_the_docstring_examples_run() -> None:
    failures, tried = doctest.testmod(hypate_api, verbose=False)
    assert tried >= 3 and failures == 0
