"""Optimal Latin hypercube designs (solvers/numerics/random.py, Sec. 6.3.3)."""
from __future__ import annotations

import numpy as np
import pytest
from hypate.solvers.numerics.random import latin_hypercube, raw_latin_hypercube
from scipy.stats import qmc


def _is_latin(U: np.ndarray) -> bool:
    n = len(U)
    strata = np.floor(U * n).astype(int)
    return all(np.array_equal(np.sort(s), np.arange(n)) for s in strata.T)


def test_latin_hypercube_is_latin_and_scaled():
    bounds = np.array([[-5.0, 10.0], [0.0, 15.0], [1.0, 2.0]])
    X = latin_hypercube(17, bounds, rng=3)
    assert X.shape == (17, 3)
    assert np.all(X >= bounds[:, 0]) and np.all(X <= bounds[:, 1])
    assert _is_latin((X - bounds[:, 0]) / (bounds[:, 1] - bounds[:, 0]))
    np.testing.assert_array_equal(X, latin_hypercube(17, bounds, rng=3))
    assert not np.array_equal(X, latin_hypercube(17, bounds, rng=4))


def test_optimized_design_has_lower_discrepancy_than_plain_lhs():
    unit = np.array([[0.0, 1.0]] * 4)
    cd_opt = qmc.discrepancy(latin_hypercube(40, unit, rng=0))
    cd_plain = np.mean([qmc.discrepancy(latin_hypercube(40, unit, rng=s, optimization=None))
                        for s in range(10)])
    assert cd_opt < cd_plain


@pytest.mark.parametrize("seed", range(3))
def test_raw_points_are_olh_symmetries(seed):
    """Column permutations and reflections keep the LHS property and the centred
    discrepancy (its formula is symmetric under both), so every draw is as good as the
    cached optimized design: a different point set with the discrepancy of any other draw
    (round-off of the sums: 1e-10)."""
    unit = np.array([[0.0, 1.0]] * 5)
    U = raw_latin_hypercube(64, unit, rng=seed)
    other = raw_latin_hypercube(64, unit, rng=seed + 10)
    assert _is_latin(U)
    assert not np.array_equal(np.sort(U, axis=0), np.sort(other, axis=0))
    assert qmc.discrepancy(U) == pytest.approx(qmc.discrepancy(other), rel=1e-10)
    np.testing.assert_array_equal(U, raw_latin_hypercube(64, unit, rng=seed))
