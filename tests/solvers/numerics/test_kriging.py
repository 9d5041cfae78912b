"""Tests of the kriging core (Appendix A.1): interpolation, analytic gradients (Eq. (A.8))
against central finite differences, agreement with scikit-learn, estimator API."""
from __future__ import annotations

import numpy as np
import pytest
from conftest import assert_matches_richardson, richardson_derivative
from hypate.solvers.numerics.kriging import KERNELS, KrigingRegressor
from sklearn.base import clone
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel, Matern


def _data(n=20, d=3, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.uniform(-2.0, 3.0, (n, d))
    y = np.c_[np.sin(2.0 * X[:, 0]) + 0.3 * X[:, 1] ** 2, X.sum(axis=1) + np.cos(X[:, -1])]
    return X, y


def _fixed(kernel, X, y, length=0.3):
    """A well-conditioned model with fixed hyperparameters (c = 1, l = 0.3 in the unit box)."""
    d = X.shape[1]
    theta0 = np.tile(np.r_[0.0, np.full(d, np.log(length))], (y.shape[1], 1))
    return KrigingRegressor(kernel, bounds=np.c_[np.full(d, -2.0), np.full(d, 3.0)],
                            theta0=theta0, optimize=False).fit(X, y)


def _central_fd(f, X, h):
    """Extrapolated central differences of ``f`` along each input and their measured error
    bounds (conftest.richardson_derivative), stacked on the last axis."""
    cols = [richardson_derivative(lambda t, e=e: f(X + t * e), h) for e in np.eye(X.shape[1])]
    return np.stack([c[0] for c in cols], axis=-1), np.stack([c[1] for c in cols], axis=-1)


@pytest.mark.parametrize("kernel", KERNELS)
def test_interpolates_with_vanishing_variance(kernel):
    X, y = _data()
    gp = KrigingRegressor(kernel, rng=0).fit(X, y)
    mu, sd = gp.predict(X, return_std=True)
    scale = y.std(axis=0)
    # nugget 1e-8 (standardized) => posterior variance at a sample ~1e-8 c, i.e. sd ~1e-4 of
    # the output scale; the mean misfit is of the same order. 1e-3 leaves a decade of margin.
    assert np.all(np.abs(mu - y) <= 1e-3 * scale)
    assert np.all(sd <= 1e-3 * scale)
    # away from the data the model is uncertain
    _, sd_far = gp.predict(np.full((1, 3), 10.0), return_std=True)
    assert np.all(sd_far > 0.1 * scale)


@pytest.mark.parametrize("kernel", KERNELS)
def test_mean_and_std_gradients_match_central_differences(kernel):
    X, y = _data()
    gp = _fixed(kernel, X, y)
    Xq = np.random.default_rng(1).uniform(-2.0, 3.0, (7, 3))
    mu, sd, dmu, dsd = gp.predict_with_gradients(Xq)
    h = 2e-5  # truncation ~h^2 |f'''| ~1e-10, rounding ~eps_f/h ~1e-11: both measured
    fd_mu, tol_mu = _central_fd(lambda Z: gp.predict(Z), Xq, h)
    fd_sd, tol_sd = _central_fd(lambda Z: gp.predict(Z, return_std=True)[1], Xq, h)
    # tolerance: the differences' own measured error (conftest.richardson_derivative)
    assert_matches_richardson(dmu, fd_mu, tol_mu, "d mean")
    assert_matches_richardson(dsd, fd_sd, tol_sd, "d std")
    # the public single-purpose methods return the same arrays
    np.testing.assert_array_equal(gp.predict_gradient(Xq), dmu)
    np.testing.assert_array_equal(gp.predict_std_gradient(Xq), dsd)


@pytest.mark.parametrize("kernel", KERNELS)
def test_fitted_model_gradients_match_central_differences(kernel):
    """Same check on likelihood-fitted hyperparameters (less well conditioned)."""
    X, y = _data(n=25, seed=3)
    gp = KrigingRegressor(kernel, rng=0, length_scale_bounds=(1e-2, 3.0)).fit(X, y[:, 0])
    Xq = np.random.default_rng(4).uniform(-2.0, 3.0, (5, 3))
    h = 2e-4  # larger step: the condition number (~1e7) amplifies round-off
    fd_mu, tol_mu = _central_fd(gp.predict, Xq, h)
    fd_sd, tol_sd = _central_fd(lambda Z: gp.predict(Z, return_std=True)[1], Xq, h)
    dmu, dsd = gp.predict_gradient(Xq), gp.predict_std_gradient(Xq)
    assert dmu.shape == (5, 3)
    # tolerance: the differences' own measured error, rounding included
    assert_matches_richardson(dmu, fd_mu, tol_mu, "d mean")
    assert_matches_richardson(dsd, fd_sd, tol_sd, "d std")


@pytest.mark.parametrize("kernel", KERNELS)
def test_prediction_equals_sklearn_with_same_hyperparameters(kernel):
    """Oracle: scikit-learn's GaussianProcessRegressor on the same scaled data."""
    X, y = _data()
    gp = KrigingRegressor(kernel, rng=0).fit(X, y[:, 1])
    U = (X - gp.lower_) / gp.scale_
    ys = (y[:, 1] - gp.y_mean_[0]) / gp.y_std_[0]
    c, ls = gp.amplitude_[0], gp.length_scale_[0]
    k = ConstantKernel(c, "fixed") * (Matern(ls, "fixed", nu=2.5) if kernel == "matern52"
                                      else RBF(ls, "fixed"))
    sk = GaussianProcessRegressor(k, alpha=gp.nugget, optimizer=None).fit(U, ys)
    Xq = np.random.default_rng(2).uniform(-2.0, 3.0, (10, 3))
    m_sk, s_sk = sk.predict((Xq - gp.lower_) / gp.scale_, return_std=True)
    mu, sd = gp.predict(Xq, return_std=True)
    # same formulas, different order of floating-point operations
    np.testing.assert_allclose(mu, gp.y_mean_[0] + gp.y_std_[0] * m_sk, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(sd, gp.y_std_[0] * s_sk, rtol=1e-7, atol=1e-9)


def test_estimator_api_and_shapes():
    X, y = _data()
    gp = KrigingRegressor("rbf", n_restarts=1, rng=5)
    assert clone(gp).get_params() == gp.get_params()
    with pytest.raises(AttributeError):
        gp.predict(X)
    assert gp.fit(X, y) is gp
    assert gp.theta_.shape == (2, 4) and gp.n_outputs_ == 2
    assert gp.predict(X[:4]).shape == (4, 2)
    assert gp.predict_gradient(X[:4]).shape == (4, 2, 3)
    gp1 = KrigingRegressor(rng=5).fit(X, y[:, 0])
    mu, sd = gp1.predict(X[:4], return_std=True)
    assert mu.shape == (4,) and sd.shape == (4,)
    assert gp1.predict_std_gradient(X[:4]).shape == (4, 3)
    with pytest.raises(ValueError):
        KrigingRegressor("cubic").fit(X, y)


def test_restarts_are_seeded():
    X, y = _data()
    a = KrigingRegressor(n_restarts=3, rng=11).fit(X, y).theta_
    b = KrigingRegressor(n_restarts=3, rng=11).fit(X, y).theta_
    np.testing.assert_array_equal(a, b)


def test_condition_keeps_hyperparameters_and_interpolates_new_data():
    X, y = _data()
    gp = KrigingRegressor(rng=0).fit(X, y)
    x_new = np.array([[0.1, 0.2, 0.3]])
    y_new = np.array([[5.0, -5.0]])
    g2 = gp.condition(np.vstack([X, x_new]), np.vstack([y, y_new]))
    np.testing.assert_array_equal(g2.theta_, gp.theta_)
    mu, sd = g2.predict(x_new, return_std=True)
    np.testing.assert_allclose(mu, y_new, atol=1e-3 * np.abs(y_new).max())
    assert np.all(sd < 1e-3 * y.std(axis=0))
    # the original model is untouched
    assert gp.X_train_.shape[0] == X.shape[0]


@pytest.mark.parametrize("kernel", KERNELS)
def test_leave_one_out_equals_the_model_refitted_without_each_point(kernel):
    # the closed form against its definition: condition on the other n - 1 points (same
    # hyperparameters and output standardization) and predict at the left-out one
    X, y = _data(n=15)
    gp = _fixed(kernel, X, y)
    mean, std = gp.leave_one_out()
    for i in range(len(X)):
        keep = np.arange(len(X)) != i
        mu_i, sd_i = gp.condition(X[keep], y[keep]).predict_moments(X[i:i + 1])
        # both sides are one Cholesky solve of a matrix of condition ~1e4: 1e-8 relative
        np.testing.assert_allclose(mean[i], mu_i[0], rtol=1e-8, atol=1e-8 * np.abs(y).max())
        np.testing.assert_allclose(std[i], sd_i[0], rtol=1e-6, atol=1e-8)
    assert np.all(std > 1e-3 * y.std(axis=0))  # unlike the interpolating model's own std


@pytest.mark.parametrize("kernel", KERNELS)
def test_mean_only_prediction_with_shared_length_scales(kernel):
    """predict_mean: the mean and its gradient of predict_with_gradients (which the
    central-difference test above checks), with outputs of equal length scales sharing one
    kernel evaluation -- here four outputs, three of them sharing (other amplitudes)."""
    X, y = _data(n=25)
    Y = np.c_[y, 2.0 * y[:, 0] - y[:, 1], np.sin(X[:, 2])]
    d = X.shape[1]
    shared = np.log([0.3, 0.5, 0.4])
    theta0 = np.array([np.r_[0.0, shared], np.r_[0.7, shared], np.r_[0.0, np.log([0.2, 0.6, 0.3])],
                       np.r_[-0.5, shared]])
    gp = KrigingRegressor(kernel, bounds=np.c_[np.full(d, -2.0), np.full(d, 3.0)],
                          theta0=theta0, optimize=False).fit(X, Y)
    Xq = np.random.default_rng(2).uniform(-2.0, 3.0, (9, d))
    mu, _, dmu, _ = gp.predict_with_gradients(Xq)
    mean, dmean = gp.predict_mean(Xq, gradient=True)
    np.testing.assert_allclose(mean, mu, rtol=1e-12, atol=1e-12 * np.abs(mu).max())
    np.testing.assert_allclose(dmean, dmu, rtol=1e-11, atol=1e-11 * np.abs(dmu).max())
    only, none = gp.predict_mean(Xq)
    assert none is None
    np.testing.assert_array_equal(only, mean)
