"""Categorical variables in the BO engine (scaling/engine/mixed.py and the optimizer's
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


# -- two categorical variables ----------------------------------------------------------------
#: Categorical entries 0 (2 levels) and 2 (3 levels) of a 4-variable design: 6 combinations.
TWO = Categorical(index=(0, 2), levels=(2, 3))


class _TwoChoiceBowls(Problem):
    """f(x, a, b) = |x - c_ab|^2 + o_ab on {0, 1} x [0, 1] x {0, 1, 2} x [0, 1]: the global
    minimum 0 at combination (a, b) = (1, 0), x = (0.3, 0.6); every other combination is
    at least 0.08 above it (a bowl of its own elsewhere)."""

    CENTRES = np.array([[0.2, 0.2], [0.8, 0.3], [0.5, 0.8], [0.3, 0.6], [0.7, 0.7],
                        [0.1, 0.9]])
    OFFSETS = np.array([0.15, 0.08, 0.2, 0.0, 0.12, 0.3])

    def __init__(self):
        super().__init__(n_var=4, n_obj=1, xl=np.zeros(4), xu=np.array([1.0, 1.0, 2.0, 1.0]))

    def _evaluate(self, X, out, *args, **kwargs):
        combo = 3 * np.rint(X[:, 0]).astype(int) + np.rint(X[:, 2]).astype(int)
        x = X[:, [1, 3]]
        out["F"] = (np.sum((x - self.CENTRES[combo]) ** 2, axis=1)
                    + self.OFFSETS[combo])[:, None]


def test_combinations_are_mixed_radix_numbers_of_the_levels():
    X = np.array([[1.0, 0.25, 2.0, 0.75], [0.2, 0.5, 0.6, 0.1]])
    # (1, 2) -> 1 * 3 + 2 = 5; (0.2, 0.6) snaps to (0, 1) -> 1
    np.testing.assert_array_equal(TWO.level(X), [5, 1])
    assert TWO.count == 6
    for level in range(6):
        a, b = TWO.levels_of(level)
        assert (a, b) == divmod(level, 3)
        full = TWO.insert(np.array([[0.4, 0.9]]), level)
        np.testing.assert_array_equal(full, [[a, 0.4, b, 0.9]])
        assert TWO.level(full)[0] == level
        np.testing.assert_array_equal(TWO.continuous(full), [[0.4, 0.9]])
    # one variable given as integers is the same thing as one given as tuples
    np.testing.assert_array_equal(Categorical(1, 3).level(X), Categorical((1,), (3,)).level(X))


def test_two_variables_one_hot_blocks_and_their_jacobian():
    X = np.array([[1.0, 0.25, 2.0, 0.75], [0.0, 0.5, 1.0, 0.1]])
    coords = MixedCoordinates(TWO, 4)
    assert coords.n_z == 2 + 2 + 3
    np.testing.assert_array_equal(coords(X), [[0.25, 0.75, 0, 1, 0, 0, 1],
                                              [0.5, 0.1, 1, 0, 0, 1, 0]])
    J = coords.jacobian(X)
    assert J.shape == (2, 7, 4)
    np.testing.assert_array_equal(J[0, :2], [[0, 1, 0, 0], [0, 0, 0, 1]])
    assert not J[:, 2:].any()
    box = coords.box(np.array([[0, 1], [0.1, 0.9], [0, 2], [0.2, 0.8]]))
    np.testing.assert_array_equal(box, [[0.1, 0.9], [0.2, 0.8]] + [[0, 1]] * 5)


def test_two_variables_initial_design_balances_each_one():
    opt = BayesianOptimizer(_TwoChoiceBowls(), n_init=12, n_iter=0, categorical=TWO)
    X = opt.initial_design()
    np.testing.assert_array_equal(np.bincount(X[:, 0].astype(int)), [6, 6])
    np.testing.assert_array_equal(np.bincount(X[:, 2].astype(int)), [4, 4, 4])


def test_mixed_bo_with_two_categorical_variables_finds_the_best_combination():
    # 12 + 18 evaluations over 6 combinations: the run must name (a, b) = (1, 0) and reach
    # f <= 0.01 (a bowl of radius 0.1 around its minimum; the next combination is 0.08 up)
    for seed in range(3):
        res = BayesianOptimizer(_TwoChoiceBowls(), n_init=12, n_iter=18, categorical=TWO,
                                acquisition="ei", seed=seed).run()
        best = int(np.argmin(res.F[:, 0]))
        assert (res.X[best, 0], res.X[best, 2]) == (1.0, 0.0), seed
        assert res.F[best, 0] <= 0.01, (seed, res.F[best, 0])


def test_two_variables_are_checked():
    with pytest.raises(ValueError, match="twice"):
        Categorical(index=(1, 1), levels=(2, 3))
    with pytest.raises(ValueError, match="one entry per variable"):
        Categorical(index=(0, 2), levels=(2,))
    with pytest.raises(ValueError, match="combinations"):
        Categorical(index=(0, 1, 2), levels=(8, 8, 2))
    with pytest.raises(SettingError, match="categorical"):  # entry 2 has bounds [0, 2]
        BayesianOptimizer(_TwoChoiceBowls(), categorical=Categorical((0, 2), (2, 2)))
