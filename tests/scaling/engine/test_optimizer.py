"""The BO loop, the multistart inner optimization, constraints, failures, batches,
executors and resume (scaling/engine/optimizer.py).

Size: about 825 lines, one test file for one module (the tests mirror the tree); the
executor and fault cases have their own files (test_executors.py, tests/reliability/)."""
from __future__ import annotations

import dataclasses
import re
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor

import numpy as np
import pandas as pd
import pytest
from conftest import (
    assert_matches_richardson,
    richardson_derivative,
    richardson_jacobian,
)
from hypate.scaling.engine.acquisition import Acquisition, ExpectedImprovement
from hypate.scaling.engine.benchmarks import (
    Branin,
    BraninCurrin,
    FailingProblem,
    Hartmann6,
    SlowProblem,
    get_benchmark,
)
from hypate.scaling.engine.coordinates import LogLinearCoordinates
from hypate.scaling.engine.inner import Resolution, optimize_acquisition
from hypate.scaling.engine.optimizer import BayesianOptimizer
from hypate.scaling.engine.pareto import hypervolume, non_dominated_mask
from hypate.scaling.engine.problem import (
    CHEAP_TOL,
    CheapConstraint,
    Outcome,
    evaluate_design,
)
from hypate.scaling.engine.settings import OptimizerSettings, RunContext, SettingError
from hypate.scaling.engine.store import Evaluation, EvaluationStore
from hypate.solvers.numerics.kriging import KrigingRegressor
from pymoo.core.problem import Problem


# --------------------------------------------------------------- inner optimization
class _SurfaceModel:
    """A noise-free "surrogate" whose mean is a 2-D test surface with an analytic gradient
    (several local maxima; the global one near (0.18, 0.78)) and whose sigma is zero."""

    @staticmethod
    def f(X):
        x, y = X[:, 0], X[:, 1]
        g1 = np.exp(-((x - 0.18) ** 2 + (y - 0.78) ** 2) / 0.01)
        g2 = 0.8 * np.exp(-((x - 0.7) ** 2 + (y - 0.3) ** 2) / 0.02)
        val = g1 + g2 + 0.3 * np.sin(7 * x) * np.cos(5 * y)
        dx = -2 * (x - 0.18) / 0.01 * g1 - 2 * (x - 0.7) / 0.02 * g2 \
            + 2.1 * np.cos(7 * x) * np.cos(5 * y)
        dy = -2 * (y - 0.78) / 0.01 * g1 - 2 * (y - 0.3) / 0.02 * g2 \
            - 1.5 * np.sin(7 * x) * np.sin(5 * y)
        return val, np.stack([dx, dy], axis=1)

    def predict_moments(self, X):
        val, _ = self.f(X)
        return val[:, None], np.zeros((len(X), 1))

    def predict_with_gradients(self, X):
        val, grad = self.f(X)
        return val[:, None], np.zeros((len(X), 1)), grad[:, None, :], np.zeros((len(X), 1, 2))


class _Surface(Acquisition):
    """The surface itself as a maximized acquisition: C = mu (dC/dmu = 1, dC/dsigma = 0)."""

    def __init__(self):
        super().__init__(_SurfaceModel())

    @staticmethod
    def f(X):
        return _SurfaceModel.f(np.atleast_2d(X))[0]

    def _from_moments(self, mu, sigma):
        return mu[:, 0], np.ones_like(mu), np.zeros_like(sigma)


def _grid(n=801):
    t = np.linspace(0, 1, n)
    return np.stack(np.meshgrid(t, t, indexing="ij"), -1).reshape(-1, 2)


def test_inner_optimization_finds_global_optimum_of_test_surface():
    acq = _Surface()
    G = _grid()
    best_grid = acq(G).max()
    x, val = optimize_acquisition(acq, np.array([[0.0, 1.0], [0.0, 1.0]]), n_raw=128,
                                  n_starts=5, rng=0)
    # a grid of spacing 1/800 misses the optimum by <= curvature * h^2 ~ 1e-4
    assert val >= best_grid - 1e-6
    assert val == pytest.approx(acq(x[None])[0])


def test_inner_optimization_finds_global_max_of_ei_on_a_gp():
    rng = np.random.default_rng(0)
    X = rng.random((8, 2))
    y = np.sin(6 * X[:, 0]) * np.cos(4 * X[:, 1]) + X[:, 0]
    gp = KrigingRegressor(bounds=np.array([[0, 1.0], [0, 1.0]]),
                          theta0=[[0.0, np.log(0.2), np.log(0.2)]], optimize=False).fit(X, y)
    acq = ExpectedImprovement(gp, y.min())
    grid_max = acq(_grid(401)).max()
    x, val = optimize_acquisition(acq, np.array([[0.0, 1.0], [0.0, 1.0]]), rng=1)
    assert val >= grid_max * (1 - 1e-6)


def test_inner_optimization_respects_cheap_constraints_exactly():
    acq = _Surface()
    # equality: x + y = 1.1 ; inequality: x^2 + y^2 <= 0.7 (pymoo sign: g <= 0)
    eq = CheapConstraint(lambda x: x[0] + x[1] - 1.1, lambda x: np.array([1.0, 1.0]), "eq")
    ineq = CheapConstraint(lambda x: x[0] ** 2 + x[1] ** 2 - 0.7, lambda x: 2 * x, "ineq")
    x, val = optimize_acquisition(acq, np.array([[0.0, 1.0], [0.0, 1.0]]),
                                  cheap_constraints=(eq, ineq), rng=0)
    assert abs(x[0] + x[1] - 1.1) <= CHEAP_TOL
    assert x[0] ** 2 + x[1] ** 2 - 0.7 <= CHEAP_TOL
    # global optimum on the feasible segment (dense 1-D grid along x + y = 1.1)
    t = np.linspace(0.1, 1.0, 200001)
    seg = np.c_[t, 1.1 - t]
    seg = seg[np.sum(seg**2, 1) <= 0.7]
    assert val >= acq(seg).max() - 1e-7


def test_candidates_near_samples_are_rejected():
    acq = _Surface()
    x_best, _ = optimize_acquisition(acq, np.array([[0.0, 1.0], [0.0, 1.0]]), rng=0)
    x2, _ = optimize_acquisition(acq, np.array([[0.0, 1.0], [0.0, 1.0]]), rng=0,
                                 X_avoid=x_best[None], min_distance=0.05)
    assert np.linalg.norm(x2 - x_best) >= 0.05


class _RampModel(_SurfaceModel):
    """A noise-free "surrogate" rising towards the face x = 1 of the unit square, best at
    (1, 0.5): one that believes the objective keeps falling beyond that bound."""

    @staticmethod
    def f(X):
        X = np.atleast_2d(X)
        val = X[:, 0] - (X[:, 1] - 0.5) ** 2
        return val, np.stack([np.ones(len(X)), -2.0 * (X[:, 1] - 0.5)], axis=1)


class _Ramp(_Surface):
    """The ramp as a maximized acquisition (C = mu, as :class:`_Surface`)."""

    def __init__(self):
        Acquisition.__init__(self, _RampModel())


def _unit_metric(length, radius):
    """The metric of a surrogate with length scales ``length`` on the unit square."""
    unit = np.asarray(length, float)
    return Resolution(lambda X: np.atleast_2d(X) / unit, lambda W: np.atleast_2d(W) * unit,
                      radius, np.eye(2))


def test_a_refined_bound_sample_is_probed_inward_once():
    acq, box = _Ramp(), np.array([[0.0, 1.0], [0.0, 1.0]])
    metric = _unit_metric([0.4, 0.1], 0.05)  # sphere: 0.02 across the face, 0.005 along y
    sample = np.array([[1.0, 0.5]])
    # without the probe, the search refines the bound sample (lands on it, min_distance 0)
    x, _ = optimize_acquisition(acq, box, X_avoid=sample, min_distance=0.0, rng=0)
    assert np.allclose(x, sample[0], atol=1e-6)
    x, _ = optimize_acquisition(acq, box, X_avoid=sample, min_distance=0.0, rng=0,
                                resolution=metric)
    w = (x - sample[0]) / [0.4, 0.1]
    assert np.linalg.norm(w) == pytest.approx(0.05, rel=1e-5)  # on the sphere
    # off the face nearly along its normal (cos >= 0.9): it measures the inward trend
    assert 1.0 - x[0] >= 0.9 * 0.05 * 0.4 * (1 - 1e-9)
    # with that probe stored, the bound sample has an inward neighbour: no second probe
    x2, _ = optimize_acquisition(acq, box, X_avoid=np.vstack([sample, x]), min_distance=0.0,
                                 rng=0, resolution=metric)
    assert np.allclose(x2, sample[0], atol=1e-6)
    # an interior best (the surface's maximum) is never probed: same proposal as without
    interior = _Surface()
    xi, _ = optimize_acquisition(interior, box, rng=3)
    xj, _ = optimize_acquisition(interior, box, X_avoid=xi[None], min_distance=0.0, rng=3,
                                 resolution=metric)
    np.testing.assert_array_equal(xi, xj)


# ------------------------------------------------------------------- single objective
def test_branin_ei_reaches_minimum_in_40_evaluations():
    res = BayesianOptimizer(Branin(), acquisition="ei", n_init=10, n_iter=30, seed=0).run()
    assert len(res.data) == 40
    # acceptance: within 1e-3 of 0.397887 in <= 40 evaluations
    assert res.best_history()[-1] - Branin.optimum <= 1e-3
    assert np.all(np.diff(res.best_history()) <= 0)


class _Quadratic(Problem):
    """min x0^2 + x1^2 s.t. G = 1 - x0 - x1 <= 0 (expensive); optimum (1/2, 1/2), f = 1/2."""

    def __init__(self):
        super().__init__(n_var=2, n_obj=1, n_ieq_constr=1, xl=np.zeros(2), xu=np.ones(2) * 2)

    def _evaluate(self, X, out, *args, **kwargs):
        out["F"] = (X**2).sum(1)[:, None]
        out["G"] = (1.0 - X.sum(1))[:, None]


def test_expensive_constraint_gets_a_surrogate():
    res = BayesianOptimizer(_Quadratic(), acquisition="ei", n_init=8, n_iter=17, seed=0).run()
    best = res.best()
    assert best["g0"] <= 0
    # the constrained optimum 1/2 lies on the constraint; 25 evaluations get within 1e-2
    assert best["f0"] == pytest.approx(0.5, abs=1e-2)


def test_cheap_constraints_hold_for_every_proposal():
    eq = CheapConstraint(lambda x: x[0] - 0.5 * x[1] - 1.0, lambda x: np.array([1.0, -0.5]), "eq")
    ineq = CheapConstraint(lambda x: (x[0] - 2.5) ** 2 + (x[1] - 3) ** 2 - 25.0,
                           lambda x: np.array([2 * (x[0] - 2.5), 2 * (x[1] - 3)]))
    res = BayesianOptimizer(Branin(), acquisition="lcb", n_init=5, n_iter=8,
                            cheap_constraints=(eq, ineq), seed=2).run()
    for x in res.X:  # initial design included
        assert abs(x[0] - 0.5 * x[1] - 1.0) <= CHEAP_TOL
        assert (x[0] - 2.5) ** 2 + (x[1] - 3) ** 2 - 25.0 <= CHEAP_TOL


# ------------------------------------------------------------------ multi-objective
def test_multi_objective_results():
    bench = get_benchmark("branincurrin")
    res = BayesianOptimizer(bench.problem, acquisition="hvei", n_init=6, n_iter=6,
                            ref_point=bench.ref_point, seed=0).run()
    hv = res.hypervolume_history()
    assert len(hv) == 12 and np.all(np.diff(hv) >= 0)
    assert hv[-1] == pytest.approx(hypervolume(res.F, bench.ref_point), rel=1e-15)
    P = res.pareto_front()
    assert np.all(non_dominated_mask(P))
    # best design under a weighting is the S_g-argmin among the evaluations (Eq. (6.11))
    F = res.F
    ideal, nadir = P.min(0), P.max(0)
    s = ((F - ideal) / (nadir - ideal)) @ np.array([0.2, 0.8])
    assert res.best([0.2, 0.8], g=1.0).name == int(np.argmin(s))
    assert isinstance(res.data, pd.DataFrame) and list(res.data["iteration"][:7]) == [0] * 6 + [1]


class _TwoParabolas(Problem):
    """f1 = x0^2 + x1^2, f2 = (x0 - 1)^2 + x1^2: the Pareto set is {x1 = 0, 0 <= x0 <= 1}."""

    def __init__(self):
        super().__init__(n_var=2, n_obj=2, xl=np.array([-1.0, -1.0]), xu=np.array([2.0, 1.0]))

    def _evaluate(self, X, out, *args, **kwargs):
        out["F"] = np.c_[(X**2).sum(1), (X[:, 0] - 1) ** 2 + X[:, 1] ** 2]


def test_pareto_set_and_front_are_row_aligned():
    """Row i of pareto_set() has the objectives of row i of pareto_front() (issue 42: the
    set came in evaluation order, the front sorted by f1)."""
    problem = _TwoParabolas()
    res = BayesianOptimizer(problem, acquisition="hvlcb", n_init=6, n_iter=6, seed=0).run()
    X, P = res.pareto_set(), res.pareto_front()
    assert len(X) == len(P) >= 3
    np.testing.assert_array_equal(problem.evaluate(X), P)  # the same floats: exact
    assert np.all(np.diff(P[:, 0]) >= 0)
    np.testing.assert_array_equal(res.X[res.pareto_indices()], X)


@pytest.mark.parametrize("acq,tol", [("ws", 0.05), ("cheb", 0.05), ("hvlcb", 0.05),
                                     ("hvei", 0.05), ("hvpoi", 0.2)])
def test_direct_and_indirect_approaches_converge_to_pareto_set(acq, tol):
    res = BayesianOptimizer(_TwoParabolas(), acquisition=acq, n_init=6, n_iter=10, seed=1).run()
    bo = res.X[6:]
    # late proposals concentrate near the Pareto set x1 = 0 (x1 ranges over [-1, 1]); the
    # purely exploitative HVPoI (Sec. 6.3.2.1) converges more slowly, hence its looser bound
    assert np.median(np.abs(bo[-5:, 1])) < tol
    assert abs(res.best([0.5, 0.5], g=1.0)["x1"]) < tol


def test_exploiting_iterations_propose_the_min_max_design():
    """``exploit_last``: the last iterations propose the surrogates' minimum of max(f1, f2)
    (closed form for _TwoParabolas: x = (0.5, 0), max f = 0.25); without it the same
    iterations are still exploring (x0 = 0.75 at iteration 5, seed 1)."""
    def late(exploit_last):
        res = BayesianOptimizer(_TwoParabolas(), acquisition="hvlcb", n_init=8, n_iter=6,
                                seed=1, exploit_last=exploit_last).run()
        it = res.data["iteration"].to_numpy()
        return res.X[it >= 5], res.F[it >= 5]

    X, F = late(2)
    assert np.abs(X - [0.5, 0.0]).max() < 0.02
    assert F.max(axis=1).max() < 0.25 + 0.001
    X, _ = late(0)
    assert np.abs(X - [0.5, 0.0]).max() > 0.2


# -------------------------------------------------------------- reproducibility/resume
class _Counting(Problem):
    """Forward to ZDT1 (d = 3) and count evaluated designs."""

    def __init__(self):
        self.inner = get_benchmark("zdt1", n_var=3).problem
        super().__init__(n_var=3, n_obj=2, xl=self.inner.xl, xu=self.inner.xu)
        self.count = 0

    def _evaluate(self, X, out, *args, **kwargs):
        self.count += len(X)
        out["F"] = self.inner.evaluate(X, return_as_dictionary=True)["F"]


class _Kill(Exception):
    pass


def _killer(after):
    seen = []

    def cb(ev):
        seen.append(ev)
        if len(seen) == after:
            raise _Kill
    return cb


@pytest.mark.parametrize("batch_size,kill_after", [(1, 9), (2, 11)])
def test_killed_and_resumed_run_equals_uninterrupted_run(tmp_path, batch_size, kill_after):
    kw = dict(acquisition="hvlcb", n_init=6, n_iter=5, batch_size=batch_size,
              ref_point=[11.0, 11.0], seed=3)
    full = BayesianOptimizer(_Counting(), store=tmp_path / "full.sqlite", **kw).run()
    path = tmp_path / "killed.sqlite"
    with pytest.raises(_Kill):
        BayesianOptimizer(_Counting(), store=path, callback=_killer(kill_after), **kw).run()
    assert len(EvaluationStore(path)) == kill_after  # every finished evaluation committed
    prob = _Counting()
    resumed = BayesianOptimizer(prob, store=path, **kw).run()
    # nothing re-evaluated
    assert prob.count == len(full.data) - kill_after
    cols = ["iteration", "batch_index"] + [c for c in full.data if c[0] in "xf"]
    pd.testing.assert_frame_equal(resumed.data[cols], full.data[cols], check_exact=True)
    # resuming a finished run evaluates nothing
    prob2 = _Counting()
    again = BayesianOptimizer(prob2, store=path, **kw).run()
    assert prob2.count == 0 and len(again.data) == len(full.data)


def test_budget_stop_then_resume_and_seed_determinism(tmp_path):
    kw = dict(acquisition="ei", n_init=5, n_iter=4, seed=11)
    a = BayesianOptimizer(Branin(), **kw).run()
    b = BayesianOptimizer(Branin(), **kw).run()
    np.testing.assert_array_equal(a.X, b.X)  # identical seed -> identical proposals
    c = BayesianOptimizer(Branin(), **{**kw, "seed": 12}).run()
    assert not np.array_equal(a.X, c.X)
    path = tmp_path / "budget.sqlite"
    part = BayesianOptimizer(Branin(), store=path, max_evaluations=7, **kw).run()
    assert len(part.data) == 7
    rest = BayesianOptimizer(Branin(), store=path, **kw).run()
    np.testing.assert_array_equal(rest.X, a.X)
    with pytest.raises(ValueError, match="seed"):
        BayesianOptimizer(Branin(), store=path, **{**kw, "seed": 1}).run()


def _recycle(path, X0, F0):
    """Earlier evaluations stored as iteration -1, the way the workflow recycles samples."""
    with EvaluationStore(path) as store:
        for i, (x, f) in enumerate(zip(X0, F0)):
            store.append(Evaluation(x=x, F=f, G=np.zeros(0), message="recycled",
                                    iteration=-1, batch_index=i, seed=0))
    return path


def test_recycled_samples_are_used_and_stored(tmp_path):
    p = Branin()
    X0 = np.array([[-3.0, 12.0], [3.0, 2.0], [9.0, 2.5], [0.0, 5.0], [5.0, 10.0]])
    F0 = p.evaluate(X0, return_as_dictionary=True)["F"]
    prob = _CountingBranin()
    store = _recycle(tmp_path / "r.sqlite", X0, F0)
    res = BayesianOptimizer(prob, acquisition="ei", n_init=0, n_iter=3, seed=0,
                            store=store).run()
    assert prob.count == 3  # the recycled designs are not evaluated again
    assert list(res.data["iteration"]) == [-1] * 5 + [1, 2, 3]
    np.testing.assert_array_equal(res.X[:5], X0)


class _CountingMixin:
    """Counts the designs a problem evaluates (put before the problem class)."""

    count = 0

    def _evaluate(self, X, out, *args, **kwargs):
        self.count += len(X)
        super()._evaluate(X, out, *args, **kwargs)


class _CountingBranin(_CountingMixin, Branin):
    pass


# ------------------------------------------------------------------------- failures
def test_failures_are_recorded_and_avoided():
    prob = FailingProblem(Branin(), threshold=0.6, nan_threshold=0.9)
    res = BayesianOptimizer(prob, acquisition="ei", n_init=10, n_iter=20, seed=0).run()
    st = res.data["status"]
    assert len(res.data) == 30
    assert (st == "error").sum() >= 1
    assert set(st) <= {"ok", "error", "invalid"}
    assert all(m == "RuntimeError: solver diverged" for m in res.data["message"][st == "error"])
    assert res.data.loc[st == "error", "f0"].isna().all()
    assert (st == "invalid").sum() >= 1  # NaN objectives in the band u1 > 0.9
    # the failure model steers away: the initial OLH fails in proportion to the failing
    # region (44 % of the box), the BO iterations far less often (the boundary of the
    # failing region passes close to Branin's minimum, so some probing is expected)
    U = (res.X - prob.xl) / (prob.xu - prob.xl)
    fail_bo = np.mean((st != "ok").to_numpy()[10:])
    assert fail_bo < 0.25
    assert np.mean((st != "ok").to_numpy()[:10]) >= 0.3
    # best found among successful points: Branin's minimum at (pi, 2.275) has u0 = 0.543,
    # u1 = 0.152, which is admissible; 1e-2 after 30 evaluations despite the failures
    assert res.best_history()[-1] - Branin.optimum < 1e-2
    assert np.all(U[(st == "ok").to_numpy(), 0] <= 0.6)


def test_evaluations_are_frozen_typed_records():
    good = evaluate_design(Branin(), np.array([np.pi, 2.275]))
    assert isinstance(good, Outcome) and good.ok and good.F.shape == (1,) and good.G.shape == (0,)
    assert good.F[0] == pytest.approx(Branin.optimum, abs=1e-5)
    bad = evaluate_design(FailingProblem(Branin(), threshold=0.0), np.array([5.0, 5.0]))
    assert (bad.status, bad.message) == ("error", "RuntimeError: solver diverged")
    assert np.isnan(bad.F).all() and not bad.ok
    with pytest.raises(dataclasses.FrozenInstanceError):
        bad.status = "ok"
    ev = Evaluation.from_outcome([5.0, 5.0], bad, iteration=2, batch_index=1, seed=0)
    assert (ev.iteration, ev.batch_index, ev.status, ev.ok) == (2, 1, "error", False)
    with pytest.raises(dataclasses.FrozenInstanceError):
        ev.message = ""


class _Sleepy(Problem):
    def __init__(self):
        super().__init__(n_var=2, n_obj=1, xl=np.zeros(2), xu=np.ones(2))

    def _evaluate(self, X, out, *args, **kwargs):
        import time

        if X[0, 0] > 0.8:
            time.sleep(0.5)
        out["F"] = ((X - 0.3) ** 2).sum(1)[:, None]


def test_timeout_through_an_executor_is_a_failure():
    with ThreadPoolExecutor(2) as ex:
        res = BayesianOptimizer(_Sleepy(), acquisition="ei", n_init=10, n_iter=2, timeout=0.2,
                                executor=ex, batch_size=2, seed=0).run()
    st = res.data["status"].to_numpy()
    slow = res.X[:, 0] > 0.8
    assert slow.any() and np.all(st[slow] == "timeout") and np.all(st[~slow] == "ok")


# ------------------------------------------------------------------ executors/batches
def test_executors_give_the_same_run_as_in_process():
    kw = dict(acquisition="hvlcb", n_init=6, n_iter=3, batch_size=2, ref_point=[18.0, 6.0],
              seed=4)
    base = BayesianOptimizer(BraninCurrin(), **kw).run()
    assert len(base.data) == 12
    with ThreadPoolExecutor(2) as ex:
        thr = BayesianOptimizer(BraninCurrin(), executor=ex, **kw).run()
    with ProcessPoolExecutor(2) as ex:
        proc = BayesianOptimizer(BraninCurrin(), executor=ex, **kw).run()
    np.testing.assert_array_equal(thr.X, base.X)
    np.testing.assert_array_equal(proc.F, base.F)
    # believer batch: the two designs of an iteration differ
    assert np.linalg.norm(base.X[6] - base.X[7]) > 1e-3


def test_dask_client_works_unchanged():
    distributed = pytest.importorskip("distributed")
    kw = dict(acquisition="ei", n_init=4, n_iter=2, batch_size=2, seed=0)
    base = BayesianOptimizer(Branin(), **kw).run()
    with distributed.Client(processes=False, n_workers=1, threads_per_worker=2,
                            dashboard_address=None) as client:
        res = BayesianOptimizer(Branin(), executor=client, **kw).run()
    np.testing.assert_array_equal(res.X, base.X)
    assert list(res.data["status"]) == ["ok"] * 8


def test_constant_liar_batches():
    res = BayesianOptimizer(Branin(), acquisition="lcb", n_init=6, n_iter=3, batch_size=3,
                            batch_strategy="liar", seed=0).run()
    assert len(res.data) == 15
    X = res.X
    d = np.linalg.norm(X[:, None] - X[None], axis=2) + np.eye(15)
    assert d.min() > 1e-6  # no duplicates


def test_convergence_stop():
    res = BayesianOptimizer(Branin(), acquisition="ei", n_init=6, n_iter=40, seed=0,
                            convergence_tol=0.5, convergence_window=2).run()
    assert len(res.data) < 46


def test_log_output_transform_models_ln_f_and_keeps_the_optimum():
    # The surrogate sees ln F: the context's best value is ln(min F) and the model
    # interpolates ln F at the samples; Branin (F >= 0.398) is still solved.
    seen = []

    def factory(model, ctx):
        seen.append((ctx.best_f, model))
        from hypate.scaling.engine.acquisition import LowerConfidenceBound
        return LowerConfidenceBound(model, v=2.0)

    opt = BayesianOptimizer(Branin(), acquisition=factory, n_init=10, n_iter=25, seed=0,
                            output_transform="log")
    res = opt.run()
    F = res.F[:, 0]
    best_f, model = seen[-1]
    assert best_f == pytest.approx(np.log(F[:-1].min()), rel=1e-12)
    mu, _ = model.predict_moments(res.X[:-1])
    assert np.allclose(mu[:, 0], np.log(F[:-1]), atol=1e-4)
    assert res.best_history()[-1] - Branin.optimum <= 1e-2
    with pytest.raises(ValueError):
        BayesianOptimizer(Branin(), output_transform="sqrt")


def test_bad_settings_raise():
    with pytest.raises(ValueError):
        BayesianOptimizer(Branin(), acquisition="hvlcb")
    with pytest.raises(ValueError):
        BayesianOptimizer(BraninCurrin(), acquisition="ei")
    with pytest.raises(ValueError):
        BayesianOptimizer(Branin(), batch_strategy="optimist")


@pytest.mark.parametrize("field,value,allowed", [
    ("n_init", -1, "integer >= 0"), ("batch_size", 0, "integer >= 1"),
    ("n_iter", 2.5, "integer >= 0"), ("p_feasible", 1.0, "(0, 1)"),
    ("polish_step", 0.6, "(0, 0.5]"), ("timeout", 0.0, "(0, inf)"), ("g", 0.5, "[1, inf]"),
    ("kernel", "cubic", "one of"), ("acquisition", "hvlcbb", "one of"),
    ("weights", [0.5, -0.5], ">= 0"), ("executor", object(), "submit"),
    ("v_final", -0.5, "[0, inf)"), ("blas_threads", 0, "integer >= 1"),
])
def test_settings_name_the_field_and_its_range(field, value, allowed):
    cls = RunContext if field in RunContext.names() else OptimizerSettings
    with pytest.raises(SettingError, match=re.escape(allowed)) as err:
        cls(**{field: value})
    assert err.value.field == field and str(err.value).startswith(field)


def test_the_run_context_is_apart_from_the_algorithm(tmp_path):
    """executor, time limit, store, callback and BLAS threads are the run's context, not
    the algorithm's settings; keyword overrides reach the one that has the field."""
    assert not set(RunContext.names()) & set(OptimizerSettings.names())
    seen = []
    opt = BayesianOptimizer(Branin(), n_init=4, n_iter=1, seed=1,
                            store=str(tmp_path / "r.sqlite"), callback=seen.append)
    assert opt.context.store == str(tmp_path / "r.sqlite") and opt.settings.n_init == 4
    result = opt.run()
    assert len(seen) == len(result.X) == 5
    again = BayesianOptimizer(Branin(), OptimizerSettings(n_init=4, n_iter=1, seed=1)).run()
    np.testing.assert_array_equal(result.X, again.X)  # the context changes no design
    with pytest.raises(TypeError, match="RunContext"):
        BayesianOptimizer(Branin(), workers=2)


def test_settings_object_and_keyword_overrides_agree():
    settings = OptimizerSettings(acquisition="ei", n_init=5, n_iter=2, seed=3)
    a = BayesianOptimizer(Branin(), settings).run()
    b = BayesianOptimizer(Branin(), acquisition="ei", n_init=5, n_iter=2, seed=3).run()
    c = BayesianOptimizer(Branin(), OptimizerSettings(acquisition="ei", n_init=5), n_iter=2,
                          seed=3).run()
    np.testing.assert_array_equal(a.X, b.X)
    np.testing.assert_array_equal(a.X, c.X)
    assert settings.n_iter == 2  # the override made a new settings object
    with pytest.raises(TypeError, match="initial_samples"):
        BayesianOptimizer(Branin(), initial_samples=None)
    with pytest.raises(SettingError, match="weights"):
        BayesianOptimizer(BraninCurrin(), weights=[1.0, 1.0, 1.0])


# ----------------------------------------------------------------------------- slow
def _branin_hits(acq):
    hits = []
    for seed in range(5):
        res = BayesianOptimizer(Branin(), acquisition=acq, n_init=10, n_iter=30, seed=seed).run()
        hits.append(res.best_history()[39] - Branin.optimum <= 1e-3)
    return hits


@pytest.mark.slow
@pytest.mark.parametrize("acq", ["lcb", "ei"])
def test_branin_four_of_five_seeds(acq):
    assert sum(_branin_hits(acq)) >= 4


@pytest.mark.slow
@pytest.mark.parametrize("acq", ["lcb", "ei"])
def test_hartmann6_four_of_five_seeds(acq):
    hits = 0
    for seed in range(5):
        res = BayesianOptimizer(Hartmann6(), acquisition=acq, n_init=10, n_iter=90,
                                seed=seed).run()
        hits += res.best_history()[99] - Hartmann6.optimum <= 0.05
    assert hits >= 4


@pytest.mark.slow
def test_batch_of_two_halves_wall_time_on_two_workers(tmp_path):
    import time

    bench = get_benchmark("branincurrin")
    X0 = np.array([[0.1, 0.9], [0.5, 0.5], [0.9, 0.1], [0.3, 0.2], [0.7, 0.8], [0.2, 0.5]])
    F0 = bench.problem.evaluate(X0, return_as_dictionary=True)["F"]
    runs = {}
    for q in (1, 2):
        with ProcessPoolExecutor(2) as ex:
            ex.submit(int, 0).result()  # start the workers before timing
            t0 = time.perf_counter()
            store = _recycle(tmp_path / f"q{q}.sqlite", X0, F0)
            res = BayesianOptimizer(SlowProblem(bench.problem, 1.0), acquisition="hvlcb",
                                    n_init=0, n_iter=20 // q, batch_size=q, executor=ex,
                                    store=store, ref_point=bench.ref_point, seed=0).run()
            runs[q] = (time.perf_counter() - t0, res.hypervolume_history()[-1])
    assert runs[2][0] <= 0.6 * runs[1][0], runs
    assert runs[2][1] == pytest.approx(runs[1][1], rel=0.05), runs


def test_test_surface_gradient_matches_central_differences():
    # the oracle of the inner-optimization tests: its analytic gradient, within the
    # difference's own measured error (conftest.richardson_derivative)
    acq = _Surface()
    X = np.random.default_rng(0).uniform(0, 1, (20, 2))
    _, g = acq.value_and_gradient(X)
    cols = [richardson_derivative(lambda t, e=e: acq.f(X + t * e), 2e-6) for e in np.eye(2)]
    fd, bound = (np.stack([c[k] for c in cols], axis=1) for k in (0, 1))
    assert_matches_richardson(g, fd, bound, "surface gradient")


# -------------------------------------------------------------- input coordinates
class _ObliqueValley(Problem):
    """A narrow curved valley ``x2 = 1.5 x1^3`` (a similarity parameter ``x2 / x1^3``
    matched) whose floor rises gently towards ``x1 = 2``: straight and axis-aligned in
    ``z = (ln x1, ln x2 - 3 ln x1)``, oblique and curved in ``x``."""

    exponents = np.array([[1.0, 0.0], [-3.0, 1.0]])

    def __init__(self):
        super().__init__(n_var=2, n_obj=1, xl=np.array([0.5, 0.1]), xu=np.array([4.0, 100.0]))

    def _evaluate(self, X, out, *args, **kwargs):
        z = np.log(X) @ self.exponents.T
        out["F"] = np.sqrt(100.0 * (z[:, 1] - np.log(1.5)) ** 2
                           + 0.05 * (z[:, 0] - np.log(2.0)) ** 2 + 1e-4)


def test_log_linear_coordinates_jacobian_and_box():
    rng = np.random.default_rng(3)
    A = np.array([[1.0, 0.0, 0.0], [-3.0, 1.0, 0.0], [-2.0, 0.5, 1.0]])
    coords = LogLinearCoordinates(A)
    bounds = np.array([[2e-4, 1.2e-3], [3e3, 1.1e4], [0.5, 4.5]])
    X = bounds[:, 0] * (bounds[:, 1] / bounds[:, 0]) ** rng.random((5, 3))
    J = coords.jacobian(X)
    for i in range(5):  # extrapolated central differences, relative step 2e-6
        fd, bound = richardson_jacobian(lambda x: coords(x[None])[0], X[i], 2e-6 * X[i])
        # tolerance: the difference's own measured error (conftest.richardson_derivative)
        assert_matches_richardson(J[i], fd, bound, ("dz/dx", i))
    # the box is the tight bounding box of the image: every corner inside, bounds attained
    corners = np.array(np.meshgrid(*bounds, indexing="ij")).reshape(3, -1).T
    Z, box = coords(corners), coords.box(bounds)
    assert np.allclose(Z.min(axis=0), box[:, 0], rtol=1e-12)
    assert np.allclose(Z.max(axis=0), box[:, 1], rtol=1e-12)
    with pytest.raises(ValueError, match="singular"):
        LogLinearCoordinates(np.array([[1.0, 2.0], [2.0, 4.0]]))


def test_warped_surrogate_gradients_match_finite_differences():
    prob = _ObliqueValley()
    opt = BayesianOptimizer(prob, n_init=12, n_iter=0, seed=1,
                            coordinates=LogLinearCoordinates(prob.exponents))
    res = opt.run()
    model = opt.surrogate(res.X, res.F, np.random.default_rng(0))
    # the surrogate interpolates its data in x
    mu, _ = model.predict_moments(res.X)
    assert np.allclose(mu[:, 0], res.F[:, 0], atol=1e-4)
    x = np.array([[1.3, 7.0], [2.5, 30.0]])
    mean, std, dmean, dstd = model.predict_with_gradients(x)
    # Tolerance: the Richardson bound of the difference itself (measured truncation and
    # rounding, so it holds on any floating-point kernels). The old check (h = 1e-6 x,
    # rel 1e-5) sat at the rounding error of the GP's own prediction and failed on some
    # machines. Step 1e-4 x: truncation ~1e-8 relative; a wrong chain-rule factor is off
    # by O(1) and fails.
    for j in range(2):
        e = np.zeros(2)
        e[j] = 1.0
        for i in range(2):
            def moments(t, i=i, e=e):
                return np.concatenate(model.predict_moments(x[i:i + 1] + t * e))[:, 0]
            fd, bound = richardson_derivative(moments, 1e-4 * x[i, j])
            assert bound.max() < 1e-3 * np.abs(fd).max()  # the difference resolves the slope
            assert_matches_richardson([dmean[i, 0, j], dstd[i, 0, j]], fd, bound, (i, j))


def test_similarity_coordinates_find_an_oblique_valley():
    # Three seeds, 8 + 40 evaluations each. Measured best F: design coordinates 0.10, 0.20,
    # 0.13 (stuck on the valley's far end); similarity coordinates 0.035, 0.084, 0.045.
    prob = _ObliqueValley()
    plain, warped = [], []
    for seed in range(3):
        for coords, out in ((None, plain), (LogLinearCoordinates(prob.exponents), warped)):
            res = BayesianOptimizer(prob, acquisition="lcb", n_init=8, n_iter=40, seed=seed,
                                    coordinates=coords, output_transform="log").run()
            out.append(res.F[:, 0].min())
    assert max(warped) < 0.1
    assert np.median(warped) < 0.5 * np.median(plain)
    with pytest.raises(ValueError, match="positive"):
        BayesianOptimizer(Branin(), coordinates=LogLinearCoordinates.log(2))


class _CountingValley(_CountingMixin, _ObliqueValley):
    pass


def test_polish_descends_from_the_best_design_and_resumes(tmp_path):
    # 6 OLH points, no BO iteration, 30 Nelder-Mead evaluations in similarity coordinates:
    # the polish starts at the best sample and only improves on it; every polish point
    # stays in the box; a run killed during the polish resumes without re-evaluating and
    # ends with the uninterrupted run's evaluations.
    coords = LogLinearCoordinates(_ObliqueValley.exponents)
    kw = dict(acquisition="lcb", n_init=6, n_iter=0, seed=4, coordinates=coords, polish=30)
    full = BayesianOptimizer(_ObliqueValley(), store=tmp_path / "full.sqlite", **kw).run()
    it = full.data["iteration"].to_numpy()
    assert (it == 1).sum() == 30
    start, end = full.F[it == 0, 0].min(), full.F[:, 0].min()
    assert end < 0.5 * start
    prob = _ObliqueValley()
    assert np.all(full.X >= prob.xl) and np.all(full.X <= prob.xu)
    path = tmp_path / "killed.sqlite"
    with pytest.raises(_Kill):
        BayesianOptimizer(_ObliqueValley(), store=path, callback=_killer(20), **kw).run()
    counting = _CountingValley()
    resumed = BayesianOptimizer(counting, store=path, **kw).run()
    assert counting.count == len(full.data) - 20
    cols = ["iteration", "batch_index"] + [c for c in full.data if c[0] in "xf"]
    pd.testing.assert_frame_equal(resumed.data[cols], full.data[cols], check_exact=True)


class _TwoBowls(Problem):
    """``f_j = |x - c_j|^2``: max(f1, f2) is smallest at the centres' midpoint, where it is
    ``|c_1 - c_2|^2 / 4`` (the two bowls are equal there)."""

    centres = np.array([[0.3, 0.4], [0.7, 0.6]])

    def __init__(self):
        super().__init__(n_var=2, n_obj=2, xl=np.zeros(2), xu=np.ones(2))

    def _evaluate(self, X, out, *args, **kwargs):
        out["F"] = np.stack([np.sum((X - c) ** 2, axis=1) for c in self.centres], axis=1)


def test_polish_of_two_objectives_descends_on_the_design_point_score():
    # with two objectives the polish minimizes max(f1, f2) (the "minmax" design point):
    # from the best of 6 OLH points, 40 Nelder-Mead evaluations reach the closed-form
    # minimum |c1 - c2|^2 / 4 = 0.02 within 2 % (the simplex converges on the kink where
    # the two bowls are equal), and the design point is the polish's best
    res = BayesianOptimizer(_TwoBowls(), acquisition="hvlcb", n_init=6, n_iter=0, seed=1,
                            polish=40).run()
    it = res.data["iteration"].to_numpy()
    assert (it == 1).sum() == 40
    score = res.F.max(axis=1)
    exact = float(np.sum(np.diff(_TwoBowls.centres, axis=0) ** 2)) / 4.0
    assert score[it == 0].min() > 1.5 * exact     # the samples were far from it
    assert score.min() == pytest.approx(exact, rel=0.02)
    assert res.design_point() == int(np.argmin(score))


def test_polish_keeps_cheap_constraints():
    eq = CheapConstraint(lambda x: x[0] - 0.5 * x[1] - 1.0, lambda x: np.array([1.0, -0.5]), "eq")
    res = BayesianOptimizer(Branin(), acquisition="lcb", n_init=5, n_iter=2, polish=12,
                            cheap_constraints=(eq,), seed=2).run()
    assert (res.data["iteration"] == 3).sum() == 12
    for x in res.X:
        assert abs(x[0] - 0.5 * x[1] - 1.0) <= CHEAP_TOL


@pytest.mark.parametrize("transform", ["none", "log"])
def test_leave_one_out_check_predicts_a_design_from_the_other_evaluations(transform):
    # with failures in the run (rows the surrogates never see): the check at the best design
    # equals the final surrogate conditioned on every other successful evaluation
    prob = FailingProblem(Branin(), threshold=0.6, nan_threshold=0.9)
    opt = BayesianOptimizer(prob, acquisition="ei", n_init=10, n_iter=10, seed=1,
                            output_transform=transform)
    res = opt.run()
    ok = res.ok
    assert not ok.all()
    row = int(np.flatnonzero(ok)[np.argmin(res.F[ok, 0])])
    check = opt.leave_one_out(res, row)
    F = res.F[ok] if transform == "none" else np.log(res.F[ok])
    gp = opt.surrogate(res.X[ok], F, opt._rng(opt.settings.n_iter + 1))
    others = np.flatnonzero(ok) != row
    mu, sd = gp.condition(res.X[ok][others], F[others]).predict_moments(res.X[row:row + 1])
    back = np.exp if transform == "log" else (lambda v: v)
    assert check.observed[0] == res.F[row, 0]
    np.testing.assert_allclose(check.mean, back(mu[0]), rtol=1e-7)
    np.testing.assert_allclose(check.std, sd[0], rtol=1e-5)
    np.testing.assert_allclose(check.z, (F[~others][0] - mu[0]) / sd[0], rtol=1e-5)
    assert check.lower[0] < check.mean[0] < check.upper[0]
    with pytest.raises(ValueError, match="not a successful evaluation"):
        opt.leave_one_out(res, int(np.flatnonzero(~ok)[0]))


class _LastBitsBranin(Branin):
    """Branin whose values differ from the exact ones in their last bits, as another
    machine's floating-point kernels make them: a relative perturbation of 4 ulp."""

    def _evaluate(self, X, out, *args, **kwargs):
        super()._evaluate(X, out, *args, **kwargs)
        out["F"] = out["F"] * (1.0 + 4.0 * np.finfo(float).eps)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_last_bits_change_the_path_not_the_answer(seed):
    # a proposal depends on the last bits of every value before it (likelihood optimum,
    # SLSQP end point), so two machines' runs part ways; both must still find the minimum:
    # Branin's three minima all have f* = 0.397887, and 40 evaluations reach it within 1e-3
    # (measured on seeds 0-2: designs part by up to 1.6e-4, both runs end within 5e-5)
    exact = BayesianOptimizer(Branin(), acquisition="lcb", n_init=10, n_iter=30, seed=seed).run()
    other = BayesianOptimizer(_LastBitsBranin(), acquisition="lcb", n_init=10, n_iter=30,
                              seed=seed).run()
    for res in (exact, other):
        assert res.best_history()[-1] - Branin.optimum < 1e-3
