"""Recursive co-kriging (scaling.engine.multifidelity) on the standard two-fidelity test
functions: better than single-fidelity kriging at equal high-fidelity samples, exact at its
high-fidelity data, and analytic gradients equal to central differences."""
from __future__ import annotations

import numpy as np
import pytest
from hypate.scaling.engine.multifidelity import (
    MultiFidelityKriging,
    MultiFidelityModel,
    gls_coefficients,
)
from hypate.solvers.numerics.kriging import KrigingRegressor
from scipy.stats import qmc


def forrester(x: np.ndarray) -> np.ndarray:
    return (6 * x - 2) ** 2 * np.sin(12 * x - 4)


def forrester_low(x: np.ndarray) -> np.ndarray:
    return 0.5 * forrester(x) + 10 * (x - 0.5) - 5


def park(X: np.ndarray) -> np.ndarray:
    x1, x2, x3, x4 = X.T
    return (x1 / 2 * (np.sqrt(1 + (x2 + x3**2) * x4 / x1**2) - 1)
            + (x1 + 3 * x4) * np.exp(1 + np.sin(x3)))


def park_low(X: np.ndarray) -> np.ndarray:
    x1, x2, x3, _ = X.T
    return (1 + np.sin(x1) / 10) * park(X) - 2 * x1 + x2**2 + x3**2 + 0.5


def _rmse(pred: np.ndarray, truth: np.ndarray) -> float:
    return float(np.sqrt(np.mean((pred - truth) ** 2)))


@pytest.fixture(scope="module")
def forrester_models():
    b = np.array([[0.0, 1.0]])
    Xl, Xh = np.linspace(0, 1, 11)[:, None], np.array([[0.0], [0.4], [0.6], [1.0]])
    mf = MultiFidelityKriging(b).fit([Xl, Xh], [forrester_low(Xl[:, 0]), forrester(Xh[:, 0])])
    sf = KrigingRegressor(bounds=b, n_restarts=2, rng=0).fit(Xh, forrester(Xh[:, 0]))
    return mf, sf, Xh


def test_forrester_multi_fidelity_beats_single_fidelity(forrester_models):
    # Forrester et al. (2007): 11 low + 4 high samples. Measured RMSE on 201 points:
    # co-kriging 2.93, kriging on the 4 high samples 5.45 (ratio 0.54); asked < 0.7.
    mf, sf, Xh = forrester_models
    x = np.linspace(0, 1, 201)[:, None]
    ratio = _rmse(mf.predict(x), forrester(x[:, 0])) / _rmse(sf.predict(x), forrester(x[:, 0]))
    assert ratio < 0.7
    # the top level interpolates its own data
    assert mf.predict(Xh) == pytest.approx(forrester(Xh[:, 0]), rel=1e-5, abs=1e-6)


def test_park_multi_fidelity_beats_single_fidelity():
    # Park (1991) 4-D pair: 80 low (LHS) + the first 20 of them high (nested). Measured RMSE
    # on 1024 Sobol points: 0.040 against 0.073 (ratio 0.55); asked < 0.75.
    b = np.array([[0.0, 1.0]] * 4)
    Xl = qmc.LatinHypercube(4, seed=1).random(80) * 0.99 + 0.01
    Xh = Xl[:20]
    mf = MultiFidelityKriging(b).fit([Xl, Xh], [park_low(Xl), park(Xh)])
    sf = KrigingRegressor(bounds=b, n_restarts=2, rng=0).fit(Xh, park(Xh))
    Xt = qmc.Sobol(4, seed=5).random(1024) * 0.99 + 0.01
    assert _rmse(mf.predict(Xt), park(Xt)) < 0.75 * _rmse(sf.predict(Xt), park(Xt))
    # nested design: the low level is known at the high samples, so is the top level
    _, std = mf.predict(Xh, return_std=True)
    assert np.max(std) < 1e-2 * np.std(park(Xh))


def test_mean_and_std_gradients_match_central_differences(forrester_models):
    mf, _, _ = forrester_models
    x = np.array([[0.13], [0.3], [0.77], [0.91]])
    _, _, dm, ds = mf.predict_with_gradients(x)
    h = 1e-6
    mp, sp = mf.predict(x + h, return_std=True)
    mm, sm = mf.predict(x - h, return_std=True)
    # central differences err by O(h^2 f''') + rounding O(eps f / h) ~ 1e-9 relative here
    assert dm[:, 0] == pytest.approx((mp - mm) / (2 * h), rel=1e-6, abs=1e-6)
    assert ds[:, 0] == pytest.approx((sp - sm) / (2 * h), rel=1e-5, abs=1e-6)


def test_levels_must_pair_up():
    with pytest.raises(ValueError, match="one \\(X, y\\) pair"):
        MultiFidelityKriging(np.array([[0.0, 1.0]])).fit([np.zeros((2, 1))], [])


def test_gls_coefficients_equal_the_normal_equations():
    rng = np.random.default_rng(3)
    A = rng.standard_normal((7, 7))
    K = A @ A.T + 7 * np.eye(7)
    F, y = np.column_stack([np.ones(7), rng.standard_normal(7)]), rng.standard_normal(7)
    Ki = np.linalg.inv(K)
    expected = np.linalg.solve(F.T @ Ki @ F, F.T @ Ki @ y)
    got = gls_coefficients(np.linalg.cholesky(K), F, y)
    assert got == pytest.approx(expected, rel=1e-10)
    # any positive multiple of the correlation gives the same coefficients
    assert gls_coefficients(np.linalg.cholesky(3.7 * K), F, y) == pytest.approx(got, rel=1e-10)


def test_rho_recovers_a_known_linear_relation():
    # top = 2 low + 1 exactly (a constant discrepancy): rho = 2 within 1e-3
    b = np.array([[0.0, 1.0]])
    Xl, Xh = np.linspace(0, 1, 11)[:, None], np.array([[0.05], [0.35], [0.55], [0.85], [1.0]])
    mf = MultiFidelityKriging(b).fit([Xl, Xh], [forrester_low(Xl[:, 0]),
                                                2 * forrester_low(Xh[:, 0]) + 1])
    assert mf.rho[1] == pytest.approx(2.0, rel=1e-3)


@pytest.mark.parametrize("level", [0, 1])
def test_believing_a_level_keeps_every_mean_and_shrinks_its_variance_share(forrester_models,
                                                                           level):
    """Kriging believer on one level (the batch proposal's fantasy): the mean of a kriging
    model with a known trend at its own prediction does not move (to 1e-9 of the output
    scale); the top-level variance at the design drops by exactly the believed level's share
    ``(prod_{j > l} rho_j)^2 sigma_l^2`` less what that level keeps after the fantasy."""
    mf = forrester_models[0]
    x0 = np.array([0.23])
    std0 = mf.predict(x0[None], return_std=True)[1][0]
    new = mf.condition(x0, level)
    x = np.linspace(0, 1, 101)[:, None]
    assert new.predict(x) == pytest.approx(mf.predict(x), abs=1e-9 * np.ptp(mf.predict(x)))
    gain = float(np.prod(mf.rho[level + 1:]))
    before = [m.predict_moments(x0[None])[1][0, 0] for m in mf.levels]
    after = [m.predict_moments(x0[None])[1][0, 0] for m in new.levels]
    assert after[level] < 0.1 * before[level]  # the believed level is pinned at x0
    assert [a for t, a in enumerate(after) if t != level] == \
        [b for t, b in enumerate(before) if t != level]  # the other levels are untouched
    drop = std0**2 - new.predict(x0[None], return_std=True)[1][0] ** 2
    assert drop == pytest.approx(gain**2 * (before[level] ** 2 - after[level] ** 2), rel=1e-6)
    assert len(new.targets[level]) == len(mf.targets[level]) + 1
    assert mf.predict(x0[None], return_std=True)[1][0] == std0  # the original is unchanged


def test_believing_a_fidelity_maps_it_to_its_model_level(forrester_models):
    """With fidelity 1 left out of the fit (too few samples), fidelity 2 is model level 1."""
    mf = forrester_models[0]
    x0 = np.array([0.55])
    new = MultiFidelityModel([mf], levels=[0, 2]).condition(x0, 2)
    assert new.levels == [0, 2]
    assert len(new.models[0].targets[1]) == len(mf.targets[1]) + 1
    assert len(new.models[0].targets[0]) == len(mf.targets[0])
    with pytest.raises(ValueError):
        MultiFidelityModel([mf], levels=[0, 2]).condition(x0, 1)
