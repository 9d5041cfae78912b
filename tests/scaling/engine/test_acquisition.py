"""Acquisition functions Eqs. (6.14)-(6.28): hand values, finite-difference gradients,
exact HVEI/HVPoI against Monte Carlo (scaling/acquisition.py)."""
from __future__ import annotations

import numpy as np
import pytest
from conftest import assert_matches_richardson, richardson_derivative
from hypate.scaling.engine.acquisition import (
    ACQUISITIONS,
    MULTI_OBJECTIVE_ACQUISITIONS,
    SINGLE_OBJECTIVE_ACQUISITIONS,
    AcquisitionContext,
    ChebyshevLCB,
    ExpectedImprovement,
    HypervolumeEI,
    HypervolumeLCB,
    HypervolumePoI,
    LowerConfidenceBound,
    ProbabilityOfImprovement,
    WeightedMetricLCB,
    WeightedSumLCB,
)
from hypate.scaling.engine.criteria import (
    expected_hypervolume_improvement,
    expected_improvement,
    hypervolume_lcb,
    lower_confidence_bound,
    monte_carlo_hvei,
    probability_hypervolume_improvement,
    probability_of_improvement,
)
from hypate.scaling.engine.pareto import (
    hypervolume_improvement,
    nondominated_boxes,
    pareto_front,
)
from hypate.solvers.numerics.kriging import KrigingRegressor
from scipy.stats import norm


# --------------------------------------------------------------- hand values
def test_ei_poi_lcb_hand_values():
    mu, s, best = np.array([0.5]), np.array([1.0]), 0.0
    # issue: minimization, mu = 0.5, sigma = 1, J_min = 0 -> EI = 0.1978 (4 digits)
    ei = expected_improvement(mu, s, best)[0][0]
    assert ei == pytest.approx(0.1978, abs=5e-5)
    # closed form z Phi(z) + phi(z), z = -0.5 (scipy's norm as the independent oracle)
    assert ei == pytest.approx(-0.5 * norm.cdf(-0.5) + norm.pdf(-0.5), rel=1e-14)
    # generalized EI, v = 0.5: z = (0 - 0.5 - 0.5) / 1 = -1
    assert expected_improvement(mu, s, best, v=0.5)[0][0] == pytest.approx(
        -norm.cdf(-1.0) + norm.pdf(-1.0), rel=1e-14)
    # PoI = P(J <= J_min) = Phi(-0.5) = 0.30854
    assert probability_of_improvement(mu, s, best)[0][0] == pytest.approx(0.3085375387, rel=1e-9)
    # LCB = mu - v sigma
    assert lower_confidence_bound(mu, s, 2.0)[0][0] == -1.5
    # sigma -> 0: EI -> max(J_min - mu, 0)
    assert expected_improvement(np.array([-0.25]), np.array([0.0]), 0.0)[0][0] == 0.25


@pytest.mark.parametrize("fn", [probability_of_improvement, expected_improvement])
def test_scalar_partials_match_central_differences(fn):
    mu, s = np.array([0.3, -0.2, 1.1]), np.array([0.7, 0.4, 0.2])
    val, dmu, ds = fn(mu, s, 0.1)
    h = 2e-6  # smooth functions of O(1) arguments
    # tolerance: the differences' own measured error (conftest.richardson_derivative)
    fd, bound = richardson_derivative(lambda t: fn(mu + t, s, 0.1)[0], h)
    assert_matches_richardson(dmu, fd, bound, "d/dmu")
    fd, bound = richardson_derivative(lambda t: fn(mu, s + t, 0.1)[0], h)
    assert_matches_richardson(ds, fd, bound, "d/dsigma")


# ------------------------------------------------------------------- models
def _model(m=2, seed=0, n=12):
    rng = np.random.default_rng(seed)
    X = rng.random((n, 2))
    Y = np.c_[np.sin(3 * X[:, 0]) + X[:, 1], (X[:, 0] - 0.4) ** 2 + np.cos(2 * X[:, 1])][:, :m]
    theta0 = np.tile([0.0, np.log(0.4), np.log(0.4)], (m, 1))
    gp = KrigingRegressor(bounds=np.array([[0.0, 1.0], [0.0, 1.0]]), theta0=theta0,
                          optimize=False).fit(X, Y)
    return gp, X, Y


def _acquisitions():
    gp, X, Y = _model()
    gp1, _, Y1 = _model(m=1)
    front = pareto_front(Y)
    ref = Y.max(axis=0) + 0.2
    return [
        ProbabilityOfImprovement(gp1, Y1.min()),
        ExpectedImprovement(gp1, Y1.min()),
        ExpectedImprovement(gp1, Y1.min(), v=0.5),
        LowerConfidenceBound(gp1, v=2.0),
        WeightedMetricLCB(gp, [0.3, 0.7], g=1.0),
        WeightedMetricLCB(gp, [0.3, 0.7], g=2.0, ideal=Y.min(0) - 1.0),
        WeightedMetricLCB(gp, [0.5, 0.5], g=np.inf),
        HypervolumePoI(gp, front, ref),
        HypervolumeEI(gp, front, ref),
        HypervolumeLCB(gp, front, ref, v=1.0),
        HypervolumeLCB(gp, front, ref, v=0.0),
    ]


@pytest.mark.parametrize("acq", _acquisitions(), ids=lambda a: type(a).__name__)
def test_acquisition_gradients_match_central_differences(acq):
    Xq = np.random.default_rng(7).random((25, 2))
    val, grad = acq.value_and_gradient(Xq)
    np.testing.assert_allclose(val, acq(Xq), rtol=1e-12, atol=1e-15)
    h = 2e-6
    cols = [richardson_derivative(lambda t, e=e: acq(Xq + t * e), h) for e in np.eye(2)]
    fd, bound = (np.stack([c[k] for c in cols], axis=1) for k in (0, 1))
    # max/min/argmin kinks (Chebyshev, HVLCB branches) are measure-zero: skip points within
    # h of one (there the difference's measured truncation explodes or the analytic one-
    # sided gradient misses it), at most 2 of 25; elsewhere the tolerance is the
    # difference's own measured error (conftest.richardson_derivative)
    bad = np.any(np.abs(grad - fd) > 2.0 * bound, axis=1)
    assert bad.sum() <= 2, np.flatnonzero(bad)
    np.testing.assert_array_equal(acq.gradient(Xq), grad)


# -------------------------------------------------------- HV acquisitions
def _front_and_moments():
    rng = np.random.default_rng(3)
    t = np.sort(rng.random(8))
    front = np.c_[t, 1.0 - np.sqrt(t)] * [1.0, 1.0]
    ref = np.array([1.2, 1.2])
    mu = np.array([[0.35, 0.30], [0.8, 0.05], [0.1, 0.9], [0.3, 0.3]])
    sd = np.array([[0.15, 0.2], [0.05, 0.1], [0.3, 0.05], [0.3, 0.3]])
    return front, ref, mu, sd


def test_exact_hvei_matches_monte_carlo():
    front, ref, mu, sd = _front_and_moments()
    boxes = nondominated_boxes(front, ref)
    exact = expected_hypervolume_improvement(mu, sd, *boxes)[0]
    rng = np.random.default_rng(0)
    for i in range(len(mu)):
        Y = mu[i] + sd[i] * rng.standard_normal((100_000, 2))
        hvi = hypervolume_improvement(Y, *boxes)
        mc = hvi.mean()
        se = hvi.std() / np.sqrt(len(hvi))
        # acceptance: within 1 % of a 1e5-sample estimate (fixed seed). The estimate's own
        # standard error is 0.3-0.5 % here, so also require agreement within 4 standard
        # errors: a wrong closed form (e.g. a missing box) would miss both.
        assert se < 0.005 * mc
        assert exact[i] == pytest.approx(mc, rel=0.01)
        assert abs(exact[i] - mc) < 4 * se


def test_exact_hvei_matches_monte_carlo_in_3d():
    rng = np.random.default_rng(5)
    front = pareto_front(rng.random((10, 3)))
    ref = np.full(3, 1.1)
    boxes = nondominated_boxes(front, ref)
    mu, sd = np.array([[0.3, 0.4, 0.35]]), np.array([[0.2, 0.15, 0.25]])
    exact = expected_hypervolume_improvement(mu, sd, *boxes)[0][0]
    mc = monte_carlo_hvei(mu, sd, *boxes, rng.standard_normal((100_000, 3)))[0][0]
    assert exact == pytest.approx(mc, rel=0.01)


def test_hvpoi_is_probability_of_non_dominance():
    front, ref, mu, sd = _front_and_moments()
    boxes = nondominated_boxes(front, ref)
    p = probability_hypervolume_improvement(mu, sd, *boxes)[0]
    rng = np.random.default_rng(1)
    for i in range(len(mu)):
        Y = mu[i] + sd[i] * rng.standard_normal((100_000, 2))
        freq = np.mean(hypervolume_improvement(Y, *boxes) > 0)
        # binomial standard error <= 0.5 / sqrt(1e5) = 1.6e-3; 5 sigma
        assert p[i] == pytest.approx(freq, abs=8e-3)


def test_hvlcb_is_eq_6_28_and_continuous():
    front, ref, _, _ = _front_and_moments()
    boxes = nondominated_boxes(front, ref)
    improving = np.array([[0.2, 0.2]])
    dominated = np.array([[0.9, 0.9]])
    val, _ = hypervolume_lcb(improving, *boxes)
    assert val[0] == pytest.approx(hypervolume_improvement(improving, *boxes)[0]) and val[0] > 0
    # dominated: minus the distance to the attainment surface; (0.9, 0.9) is dominated by
    # the front points; the distance is to the nearest non-dominated box
    val_d, _ = hypervolume_lcb(dominated, *boxes)
    lo, up = boxes
    delta = dominated[:, None] - np.clip(dominated[:, None], lo, up)
    assert val_d[0] == pytest.approx(-np.sqrt((delta**2).sum(-1)).min()) and val_d[0] < 0
    # continuity across the attainment surface: a front point is on it (value 0)
    on = front[[3]]
    assert hypervolume_lcb(on, *boxes)[0][0] == pytest.approx(0.0, abs=1e-15)
    eps = 1e-9
    for step in (-eps, eps):
        assert abs(hypervolume_lcb(on + step, *boxes)[0][0]) < 1e-8


def test_hv_acquisitions_precompute_boxes():
    gp, X, Y = _model()
    a = HypervolumeEI(gp, Y, Y.max(0) + 0.1)
    lower, upper = a.boxes
    assert len(lower) == len(a.pareto_front) + 1  # 2-D staircase: k + 1 strips
    assert a.maximize and HypervolumeLCB(gp, Y, Y.max(0) + 0.1).maximize
    assert not LowerConfidenceBound(gp).maximize


# ------------------------------------------------------------------------- registry
class _Line:
    """mu = x (one or two outputs), sigma = 0.1: enough to build every acquisition."""

    def __init__(self, m):
        self.m = m

    def predict_moments(self, X):
        return np.repeat(X[:, :1], self.m, axis=1), np.full((len(X), self.m), 0.1)

    def predict_with_gradients(self, X):
        mu, sd = self.predict_moments(X)
        dmu = np.zeros((len(X), self.m, X.shape[1]))
        dmu[:, :, 0] = 1.0
        return mu, sd, dmu, np.zeros_like(dmu)


def test_registry_builds_every_named_acquisition_from_a_context():
    assert SINGLE_OBJECTIVE_ACQUISITIONS == ("lcb", "ei", "poi")
    assert MULTI_OBJECTIVE_ACQUISITIONS == ("hvlcb", "hvei", "hvpoi", "ws", "cheb", "wm", "mmei",
                                            "mmlcb", "mmlogei")
    X = np.array([[0.2, 0.5], [0.7, 0.1]])
    for name, cls in ACQUISITIONS.items():
        m = 2 if cls.multi_objective else 1
        ctx = AcquisitionContext(best_f=0.3, pareto_front=np.array([[0.3, 0.6], [0.6, 0.3]])[:, :m],
                                 ref_point=np.full(m, 1.0), ideal=np.zeros(m), scale=np.ones(m),
                                 rng=np.random.default_rng(0), g=3.0)
        acq = cls.from_context(_Line(m), ctx)
        assert type(acq) is cls and acq(X).shape == (2,), name
    ctx = AcquisitionContext(0.3, np.zeros((0, 2)), np.ones(2), np.zeros(2), np.ones(2),
                             np.random.default_rng(0), v=0.5)
    assert ACQUISITIONS["ws"].from_context(_Line(2), ctx).g == 1.0
    assert ACQUISITIONS["cheb"].from_context(_Line(2), ctx).g == np.inf
    assert ACQUISITIONS["hvlcb"].from_context(_Line(2), ctx).v == 0.5
    assert ACQUISITIONS["lcb"].from_context(_Line(1), ctx).v == 0.5
    # default exploration weights when the context sets none
    ctx0 = AcquisitionContext(0.3, np.zeros((0, 2)), np.ones(2), np.zeros(2), np.ones(2),
                              np.random.default_rng(0))
    assert ACQUISITIONS["hvlcb"].from_context(_Line(2), ctx0).v == 1.5
    assert ACQUISITIONS["ei"].from_context(_Line(1), ctx0).v == 0.0
    assert isinstance(ChebyshevLCB(_Line(2), [0.5, 0.5]), WeightedSumLCB)


def test_one_default_acquisition_rule(tmp_path) -> None:
    """Wherever no acquisition is named -- the engine, hypate.minimize's budget plan, the
    ask/tell loop, a study -- the default is default_acquisition's: EI for one objective,
    HVLCB (indirect) or the Chebyshev LCB (direct) for several."""
    from conftest import tiny_study_text
    from hypate.scaling.engine.acquisition import default_acquisition
    from hypate.scaling.engine.asktell import AskTellOptimizer
    from hypate.scaling.engine.benchmarks import get_benchmark
    from hypate.scaling.engine.functional import plan_budget
    from hypate.scaling.engine.optimizer import BayesianOptimizer
    from hypate.scaling.workflow.vocabulary.study import load_study

    assert (default_acquisition(1), default_acquisition(2), default_acquisition(3, "direct")) \
        == ("ei", "hvlcb", "cheb")
    for bad in ((0,), (2, "sideways"), (1, "sideways")):
        with pytest.raises(ValueError):
            default_acquisition(*bad)
    for m in (1, 2):
        problem = get_benchmark("branin" if m == 1 else "branincurrin").problem
        assert BayesianOptimizer(problem).acquisition == default_acquisition(m)
        assert plan_budget(2, m, 30, None, None, None).acquisition == default_acquisition(m)
        with AskTellOptimizer([(0.0, 1.0)] * 2, n_objectives=m) as loop:
            assert loop.budget.acquisition == default_acquisition(m)
    text = tiny_study_text()
    assert 'acquisition = "' not in text  # the tiny study names none
    for approach, expected in (("indirect", "hvlcb"), ("direct", "cheb")):
        path = tmp_path / f"{approach}.toml"
        path.write_text(text.replace("[optimizer]", f'[optimizer]\napproach = "{approach}"'))
        assert load_study(path).acquisition == expected

