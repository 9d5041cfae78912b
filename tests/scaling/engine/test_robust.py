"""Robust Bayesian optimization over (design, uncertain inputs) (scaling.engine.robust)."""
from __future__ import annotations

import numpy as np
import pytest
from hypate.scaling.engine.functional import FunctionProblem
from hypate.scaling.engine.optimizer import BayesianOptimizer
from hypate.scaling.engine.propagation import Uncertain, collocation_nodes
from hypate.scaling.engine.robust import (
    RobustBayesianOptimizer,
    RobustModel,
    reduce_samples,
)
from hypate.scaling.engine.settings import OptimizerSettings, RunContext, SettingError
from hypate.scaling.engine.store import Evaluation, EvaluationStore

SIGMA = 0.1  # the uncertain input: xi ~ N(1, 0.1)
K = 10.0     # sensitivity of f to xi per unit x: K * SIGMA = 1


def f(z: np.ndarray) -> float:
    """f = (x - 0.3)^2 + (K x (xi - 1))^2: nominal optimum x = 0.3; E[f] = (x - 0.3)^2 +
    x^2 (K sigma)^2 is least at x = 0.3 / (1 + (K sigma)^2) = 0.15."""
    x, xi = z
    return (x - 0.3) ** 2 + (K * x * (xi - 1.0)) ** 2


XI = Uncertain("xi", "normal", SIGMA)


def _samples(n: int, seed: int = 0) -> np.ndarray:
    return collocation_nodes([XI], n, seed)


class _Quadratic:
    """Exact moments of a joint quadratic, for the reduction tests (a 'model' of (x, xi))."""

    def predict_moments(self, Z):
        return self.predict_with_gradients(Z)[:2]

    def predict_with_gradients(self, Z):
        Z = np.atleast_2d(Z)
        x, xi = Z[:, :1], Z[:, 1:2]
        mu = np.hstack([(x - 0.3) ** 2 + (K * x * (xi - 1.0)) ** 2, np.sin(3 * x) * xi])
        sd = np.hstack([0.1 + x ** 2 * xi, 0.2 + 0 * x])
        dmu = np.stack([np.hstack([2 * (x - 0.3) + 2 * K ** 2 * x * (xi - 1) ** 2,
                                   2 * K ** 2 * x ** 2 * (xi - 1)]),
                        np.hstack([3 * np.cos(3 * x) * xi, np.sin(3 * x)])], axis=1)
        dsd = np.stack([np.hstack([2 * x * xi, x ** 2]), np.zeros((len(Z), 2))], axis=1)
        return mu, sd, dmu, dsd


@pytest.mark.parametrize("statistic", ["mean", "mean+2std", "q90"])
def test_robust_model_gradients_match_finite_differences(statistic):
    model = RobustModel(_Quadratic(), 1, _samples(32), statistic)
    X = np.array([[0.21], [0.47], [0.83]])
    R, _, dR, dS = model.predict_with_gradients(X)
    h = 1e-6
    Rp, Sp = model.predict_moments(X + h)
    Rm, Sm = model.predict_moments(X - h)
    # the quantile's sample pair may not change within +-h: central differences at 1e-6
    assert np.allclose(dR[..., 0], (Rp - Rm) / (2 * h), rtol=1e-5, atol=1e-7)
    assert np.allclose(dS[..., 0], (Sp - Sm) / (2 * h), rtol=1e-5, atol=1e-7)
    assert np.allclose(R, model.predict_moments(X)[0], rtol=0, atol=0)


def test_reductions_are_the_sample_statistics():
    rng = np.random.default_rng(1)
    mu = rng.normal(size=(4, 33, 2))
    sd = rng.uniform(0.1, 1.0, size=(4, 33, 2))
    for statistic, expected in (("mean", mu.mean(axis=1)),
                                ("mean+2std", mu.mean(axis=1) + 2 * mu.std(axis=1)),
                                ("q90", np.quantile(mu, 0.9, axis=1))):
        R, _, _, _ = reduce_samples(mu, sd, statistic)
        assert np.allclose(R, expected, rtol=0, atol=1e-14)


def _robust(n_init=8, n_iter=22, seed=0, store=None, statistic="mean"):
    problem = FunctionProblem(f, [(0.0, 1.0), XI.support()])
    return RobustBayesianOptimizer(problem, _settings(n_init, n_iter, seed),
                                   RunContext(store=store),
                                   n_design=1, samples=_samples(32), statistic=statistic,
                                   candidates=_samples(128, seed=1))


def _settings(n_init, n_iter, seed):
    return OptimizerSettings(acquisition="lcb", n_init=n_init, n_iter=n_iter, seed=seed)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_robust_optimum_of_a_closed_form_is_found(seed):
    """E[f] = (x - 0.3)^2 + x^2 is least at x = 0.15 (E[f] = 0.045); the nominal optimum
    x = 0.3 has E[f] = 0.09, twice as much. 8 + 22 evaluations of (x, xi)."""
    opt = _robust(seed=seed)
    result = opt.run()
    designs, R, _ = opt.robust_estimates(result_records(opt, result))
    k = int(np.argmin(R[:, 0]))
    x_best = designs[k][0]

    def expected(x: float) -> float:
        return (x - 0.3) ** 2 + (x * K * SIGMA) ** 2

    assert abs(x_best - 0.15) < 0.03, x_best
    assert expected(x_best) <= 1.05 * expected(0.15)
    # the surrogate's statistic there: within 10 % of the closed form
    assert abs(R[k, 0] - expected(x_best)) < 0.1 * expected(x_best)
    nominal = BayesianOptimizer(FunctionProblem(lambda x: f([x[0], 1.0]), [(0.0, 1.0)]),
                                acquisition="lcb", n_init=8, n_iter=22, seed=seed).run()
    x_nominal = nominal.X[int(np.nanargmin(nominal.F[:, 0])), 0]
    assert abs(x_nominal - 0.3) < 0.01


def result_records(opt, result):
    """Evaluation records of a result (the store's rows)."""
    return [Evaluation(x=row, F=F, G=np.zeros(0)) for row, F in zip(result.X, result.F)]


def test_resumed_robust_run_replays_the_stored_pairs(tmp_path):
    full = _robust(n_iter=6, store=str(tmp_path / "full.sqlite")).run()
    with EvaluationStore(tmp_path / "part.sqlite") as store:
        _robust(n_iter=3, store=store).run()
    resumed = _robust(n_iter=6, store=str(tmp_path / "part.sqlite")).run()
    assert np.array_equal(full.X, resumed.X) and np.array_equal(full.F, resumed.F)


def test_robust_settings_are_checked():
    problem = FunctionProblem(f, [(0.0, 1.0), XI.support()])
    with pytest.raises(SettingError, match="n_design"):
        RobustBayesianOptimizer(problem, _settings(4, 1, 0), n_design=2,
                                samples=_samples(8), statistic="mean")
    with pytest.raises(SettingError, match="samples"):
        RobustBayesianOptimizer(problem, _settings(4, 1, 0), n_design=1,
                                samples=np.array([[0.1], [1.0]]), statistic="mean")
    with pytest.raises(SettingError, match="statistic"):
        RobustBayesianOptimizer(problem, _settings(4, 1, 0), n_design=1,
                                samples=_samples(8), statistic="q95")
