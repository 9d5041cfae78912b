"""One categorical variable in the BO engine (scaling/engine/mixed.py and the optimizer's
mixed proposal): one-hot surrogate coordinates, exact gradients in the continuous
variables, stratified initial levels, per-level inner search."""
from __future__ import annotations

import numpy as np
import pytest
from conftest import assert_matches_richardson, richardson_jacobian
from hypate.scaling.engine.coordinates import LogLinearCoordinates, WarpedModel
from hypate.scaling.engine.mixed import (
    Categorical,
    LevelSlice,
    MixedCoordinates,
    sliced_constraints,
)
from hypate.scaling.engine.optimizer import BayesianOptimizer
from hypate.scaling.engine.problem import CheapConstraint
from hypate.scaling.engine.settings import SettingError
from hypate.scaling.engine.surrogate import fit_surrogate
from pymoo.core.problem import Problem

#: Minimum and offset of each level of :class:`_ShiftedBowls`: level 1 holds the global
#: minimum 0 at (0.7, 0.3); the others are 0.25 and 0.1 above it elsewhere.
CENTRES = np.array([[0.2, 0.2], [0.7, 0.3], [0.4, 0.8]])
OFFSETS = np.array([0.25, 0.0, 0.1])


class _ShiftedBowls(Problem):
    """f(x, c) = |x - a_c|^2 + b_c on [0, 1]^2 x {0, 1, 2} (the level in the middle)."""

    def __init__(self):
        super().__init__(n_var=3, n_obj=1, xl=np.array([0.0, 0.0, 0.0]),
                         xu=np.array([1.0, 2.0, 1.0]))

    def _evaluate(self, X, out, *args, **kwargs):
        level = np.rint(X[:, 1]).astype(int)
        x = X[:, [0, 2]]
        out["F"] = (np.sum((x - CENTRES[level]) ** 2, axis=1) + OFFSETS[level])[:, None]


CAT = Categorical(index=1, levels=3)


def _data(n=24, seed=0):
    rng = np.random.default_rng(seed)
    X = np.c_[rng.random(n), rng.integers(0, 3, n), rng.random(n)]
    out = {}
    _ShiftedBowls()._evaluate(X, out)
    return X, out["F"]


def test_one_hot_coordinates_and_their_jacobian():
    X = np.array([[0.3, 2.0, 0.9], [0.1, 0.0, 0.5], [0.6, 1.2, 0.2]])
    coords = MixedCoordinates(CAT, 3)
    Z = coords(X)
    np.testing.assert_array_equal(Z, [[0.3, 0.9, 0, 0, 1], [0.1, 0.5, 1, 0, 0],
                                      [0.6, 0.2, 0, 1, 0]])  # 1.2 -> nearest level 1
    J = coords.jacobian(X)
    assert J.shape == (3, 5, 3)
    np.testing.assert_array_equal(J[0], [[1, 0, 0], [0, 0, 1], [0, 0, 0], [0, 0, 0],
                                         [0, 0, 0]])
    np.testing.assert_array_equal(coords.box(np.array([[0, 1], [0, 2], [0, 1.0]])),
                                  [[0, 1], [0, 1], [0, 1], [0, 1], [0, 1]])


def test_mixed_kriging_gradients_in_the_continuous_variables_match_finite_differences():
    X, F = _data()
    bounds = np.array([[0.05, 1.0], [0.0, 2.0], [0.05, 1.0]])
    X[:, [0, 2]] = 0.05 + 0.95 * X[:, [0, 2]]
    for inner in (None, LogLinearCoordinates(np.array([[1.0, 1.0], [1.0, -1.0]]))):
        coords = MixedCoordinates(CAT, 3, inner)
        gp = fit_surrogate(coords(X), F, coords.box(bounds), rng=0)
        model = WarpedModel(gp, coords)
        for level in range(3):
            sliced = LevelSlice(model, CAT, level)
            xc = np.array([0.37, 0.61])
            mean, _, dmean, dstd = sliced.predict_with_gradients(xc[None])
            assert dmean.shape == (1, 1, 2)
            for k, grad in enumerate((dmean, dstd)):
                ref, bound = richardson_jacobian(
                    lambda v, k=k, s=sliced: s.predict_moments(v[None])[k][0], xc, 1e-3)
                assert_matches_richardson(grad[0], ref, bound, label=(inner is None, level, k))
            # the slice is the full model at that level
            full = model.predict_moments(CAT.insert(xc[None], level))
            np.testing.assert_allclose(mean, full[0], rtol=0, atol=0)


def test_levels_share_information_and_the_data_are_interpolated():
    X, F = _data(30)
    coords = MixedCoordinates(CAT, 3)
    gp = fit_surrogate(coords(X), F, coords.box(np.array([[0, 1], [0, 2], [0, 1.0]])), rng=0)
    mean, std = WarpedModel(gp, coords).predict_moments(X)
    # kriging interpolates its data (zero nugget up to the jitter): mean = data, std ~ 0
    np.testing.assert_allclose(mean, F, atol=1e-5)
    assert float(std.max()) < 1e-3


def test_sliced_cheap_constraints_keep_values_and_drop_the_level_column():
    c = CheapConstraint(fun=lambda x: np.array([x[0] + 2 * x[1] - x[2]]),
                        jac=lambda x: np.array([[1.0, 2.0, -1.0]]), kind="ineq")
    (s,) = sliced_constraints([c], CAT, 2)
    xc = np.array([0.3, 0.4])
    assert s.fun(xc)[0] == pytest.approx(0.3 + 4.0 - 0.4)
    np.testing.assert_array_equal(s.jac(xc), [[1.0, -1.0]])
    assert s.kind == "ineq"


def test_initial_design_balances_the_levels():
    opt = BayesianOptimizer(_ShiftedBowls(), n_init=9, n_iter=0, categorical=CAT)
    X = opt.initial_design()
    assert np.all(np.isin(X[:, 1], [0.0, 1.0, 2.0]))
    np.testing.assert_array_equal(np.bincount(X[:, 1].astype(int)), [3, 3, 3])


def test_mixed_bo_finds_the_best_level_and_its_minimum():
    # 9 + 15 evaluations for 3 levels: one fixed-level run of the same budget each would
    # take 72; the mixed run must name level 1 and reach f <= 0.01 (a bowl of radius 0.1)
    for seed in range(3):
        res = BayesianOptimizer(_ShiftedBowls(), n_init=9, n_iter=15, categorical=CAT,
                                acquisition="ei", seed=seed).run()
        assert np.all(np.isin(res.X[:, 1], [0.0, 1.0, 2.0]))
        best = int(np.argmin(res.F[:, 0]))
        assert res.X[best, 1] == 1.0, seed
        assert res.F[best, 0] <= 0.01, (seed, res.F[best, 0])


def test_categorical_settings_are_checked():
    with pytest.raises(SettingError, match="categorical"):
        BayesianOptimizer(_ShiftedBowls(), categorical=Categorical(index=0, levels=3))
    with pytest.raises(SettingError, match="polish"):
        BayesianOptimizer(_ShiftedBowls(), categorical=CAT, polish=5)
    with pytest.raises(ValueError, match="levels"):
        Categorical(index=1, levels=1)
