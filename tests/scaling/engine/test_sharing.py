"""The run's workers lend a hand to the proposal (scaling.engine.sharing): the kriging
columns' likelihood optimizations and the SLSQP starts are spread over this process and a
pool, and every result is the serial one, bit for bit."""
from __future__ import annotations

import pickle
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor

import numpy as np
import pytest
from hypate.scaling.engine.acquisition import ACQUISITIONS, AcquisitionContext
from hypate.scaling.engine.inner import optimize_acquisition
from hypate.scaling.engine.pareto import non_dominated_mask
from hypate.scaling.engine.sharing import WorkerMap
from hypate.scaling.engine.surrogate import surrogate_regressor
from hypate.solvers.numerics.kriging import ColumnFit, KrigingRegressor, fit_together

BOUNDS = np.array([[0.0, 1.0]] * 3)


def _data(n=24, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.random((n, 3))
    F = np.c_[np.sin(5 * X[:, 0]) + X[:, 1] ** 2, np.cos(3 * X[:, 2]) * X[:, 0],
              (X[:, 1] > 0.6).astype(float)]
    return X, F


def _square(v: int) -> int:
    return v * v


@pytest.fixture(scope="module")
def pool():
    with ProcessPoolExecutor(2) as ex:
        yield ex


@pytest.mark.parametrize("n,width", [(0, 2), (1, 2), (5, 2), (7, 3), (3, 8)])
def test_the_map_keeps_the_order_for_any_width(pool, n, width):
    assert WorkerMap(pool, width)(_square, range(n)) == [v * v for v in range(n)]


class _Refusing:
    workers = 2

    def submit(self, fn, *args):
        raise RuntimeError("cannot schedule new futures after shutdown")


def test_a_share_the_executor_cannot_take_is_computed_here(pool):
    # refused at submission, and a closure that does not pickle for the process pool
    assert WorkerMap(_Refusing())(_square, range(5)) == [0, 1, 4, 9, 16]
    offset = 3
    assert WorkerMap(pool)(lambda v: v + offset, range(4)) == [3, 4, 5, 6]


def test_a_pickled_column_fit_is_the_one_fitted_here():
    # a contiguous copy of a column rounds differently (1e-13) from the column view a
    # serial fit takes: the task carries the whole matrix and the column's index
    X, F = _data()
    tasks = surrogate_regressor(BOUNDS, rng=0)._column_fits(X, F)
    for task in tasks:
        assert isinstance(task, ColumnFit)
        theta, lml = task()
        theta_p, lml_p = pickle.loads(pickle.dumps(task))()
        assert np.array_equal(theta, theta_p) and lml == lml_p


def test_models_fitted_together_on_workers_equal_the_serial_fits(pool):
    X, F = _data()
    rng_a, rng_b = np.random.default_rng(7), np.random.default_rng(7)
    serial = [KrigingRegressor(bounds=BOUNDS, rng=rng_a).fit(X, F[:, :2]),
              KrigingRegressor(bounds=BOUNDS, rng=rng_a, nugget=0.05).fit(X, F[:, 2:])]
    shared = fit_together([(KrigingRegressor(bounds=BOUNDS, rng=rng_b), X, F[:, :2]),
                           (KrigingRegressor(bounds=BOUNDS, rng=rng_b, nugget=0.05), X,
                            F[:, 2:])], WorkerMap(pool))
    for a, b in zip(serial, shared):
        assert np.array_equal(a.theta_, b.theta_)
        assert np.array_equal(a.alpha_, b.alpha_)
        assert np.array_equal(a.L_, b.L_)
    # the random restarts drew the same seeds: the generators are in the same state
    assert rng_a.integers(2**31) == rng_b.integers(2**31)


@pytest.mark.parametrize("make", [lambda: ThreadPoolExecutor(2), lambda: ProcessPoolExecutor(2)])
def test_starts_polished_on_workers_give_the_serial_proposal(make):
    X, F = _data()
    model = surrogate_regressor(BOUNDS, rng=1).fit(X, F[:, :2])
    Y = F[:, :2]
    front = Y[non_dominated_mask(Y)]
    ctx = AcquisitionContext(0.0, front, Y.max(axis=0) + 0.1, Y.min(axis=0), np.ptp(Y, axis=0),
                             np.random.default_rng(3), v=1.5)
    acq = ACQUISITIONS["hvlcb"].from_context(model, ctx)
    kw = dict(n_raw=64, n_starts=5, X_avoid=X, rng=11)  # a seed: a fresh generator per call
    x_serial, v_serial = optimize_acquisition(acq, BOUNDS, **kw)
    with make() as ex:
        x_shared, v_shared = optimize_acquisition(acq, BOUNDS, mapper=WorkerMap(ex), **kw)
    assert np.array_equal(x_serial, x_shared) and v_serial == v_shared
