"""Surrogates of objectives/constraints and the probability-of-feasibility constraint."""
from __future__ import annotations

import numpy as np
import pytest
from conftest import assert_matches_richardson, richardson_derivative
from hypate.scaling.engine.surrogate import ProbabilisticConstraint, fit_surrogate
from scipy.stats import norm

BOUNDS = np.array([[-1.0, 2.0], [0.0, 3.0]])


def _data(n=15, seed=0):
    rng = np.random.default_rng(seed)
    X = BOUNDS[:, 0] + rng.random((n, 2)) * (BOUNDS[:, 1] - BOUNDS[:, 0])
    G = np.c_[np.sin(2.0 * X[:, 0]) + 0.5 * np.cos(3.0 * X[:, 1]) - 0.2, np.sin(X[:, 0]) - 0.5]
    return X, G


def test_fit_surrogate_one_model_per_column():
    X, G = _data()
    gp = fit_surrogate(X, G, BOUNDS, rng=0)
    mu, sd = gp.predict_moments(X[:3])
    assert mu.shape == (3, 2) and gp.theta_.shape == (2, 3)
    # interpolation at the data (nugget-limited, see tests/kriging/test_gp.py)
    np.testing.assert_allclose(mu, G[:3], atol=1e-3 * G.std())
    # unit-box scaling comes from the design bounds, not the data range
    np.testing.assert_array_equal(gp.lower_, BOUNDS[:, 0])


@pytest.mark.parametrize("p_min", [0.1, 0.5, 0.9])
def test_constraint_sign_is_probability_of_feasibility(p_min):
    X, G = _data()
    pc = ProbabilisticConstraint(fit_surrogate(X[:, :], G[:, :1], BOUNDS, rng=0), p_min=p_min)
    Xq = BOUNDS[:, 0] + np.random.default_rng(1).random((200, 2)) * 3.0
    c = pc(Xq)[:, 0]
    p = pc.probability(Xq)
    mu, sd = pc.model.predict_moments(Xq)
    # closed form: P(G <= 0) = Phi(-mu / sigma)
    np.testing.assert_allclose(p, norm.cdf(-mu[:, 0] / sd[:, 0]), rtol=1e-10)
    # c <= 0 exactly where the probability reaches p_min (away from round-off at equality)
    clear = np.abs(p - p_min) > 1e-9
    np.testing.assert_array_equal((c <= 0)[clear], (p >= p_min)[clear])


def test_constraint_jacobian_matches_central_differences():
    X, G = _data()
    pc = ProbabilisticConstraint(fit_surrogate(X, G, BOUNDS, rng=0), p_min=0.2, threshold=0.1)
    Xq = np.array([[0.3, 1.7], [1.5, 0.4]])
    J = pc.jacobian(Xq)
    h = 2e-6
    cols = [richardson_derivative(lambda t, e=e: pc(Xq + t * e), h) for e in np.eye(2)]
    fd, bound = (np.stack([c[k] for c in cols], axis=-1) for k in (0, 1))
    # tolerance: the difference's own measured error, the fitted model's rounding included
    assert_matches_richardson(J, fd, bound, "dc/dx")


def test_p_min_must_be_a_probability():
    X, G = _data()
    with pytest.raises(ValueError):
        ProbabilisticConstraint(fit_surrogate(X, G, BOUNDS, rng=0), p_min=1.0)
