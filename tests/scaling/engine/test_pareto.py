"""Pareto dominance, exact hypervolume and the box decomposition (scaling/pareto.py)."""
from __future__ import annotations

import numpy as np
import pytest
from conftest import assert_matches_richardson, richardson_derivative
from hypate.scaling.engine.pareto import (
    hypervolume,
    hypervolume_2d,
    hypervolume_improvement,
    non_dominated_mask,
    nondominated_boxes,
    pareto_front,
    pareto_order,
)
from pymoo.indicators.hv import HV
from pymoo.util.nds.non_dominated_sorting import NonDominatedSorting


@pytest.mark.parametrize("seed", range(5))
def test_2d_hypervolume_equals_pymoo(seed):
    rng = np.random.default_rng(seed)
    F = rng.random((60, 2)) * 12.0  # some points beyond the reference point
    F = np.vstack([F, F[:5]])  # duplicates
    ref = np.array([11.0, 11.0])
    ours = hypervolume_2d(F, ref)
    theirs = HV(ref_point=ref)(F[np.all(F < ref, axis=1)])
    # acceptance: equal to pymoo to 1e-12 (both are exact sums of rectangle areas)
    assert abs(ours - theirs) <= 1e-12 * max(1.0, abs(theirs))


def test_hypervolume_of_analytic_zdt1_front():
    # ZDT1 front f2 = 1 - sqrt(f1): HV w.r.t. [11, 11] is 121 - 1/3; a staircase of n
    # points underestimates by about the area between curve and steps, O(1/n).
    f1 = np.linspace(0.0, 1.0, 2001)
    F = np.c_[f1, 1.0 - np.sqrt(f1)]
    hv = hypervolume(F, [11.0, 11.0])
    assert 121 - 1 / 3 - 1e-3 < hv < 121 - 1 / 3


def test_3d_hypervolume_uses_pymoo():
    rng = np.random.default_rng(0)
    F = rng.random((30, 3))
    ref = np.full(3, 1.2)
    assert hypervolume(F, ref) == pytest.approx(HV(ref_point=ref)(F), rel=1e-12)


@pytest.mark.parametrize("m", [2, 3])
def test_non_dominated_mask_matches_pymoo(m):
    """2-D uses a sweep, more objectives a blocked pairwise test: both against pymoo."""
    rng = np.random.default_rng(1)
    F = np.round(rng.random((300, m)), 1)  # ties and duplicates
    ours = np.flatnonzero(non_dominated_mask(F))
    theirs = np.sort(NonDominatedSorting().do(F, only_non_dominated_front=True))
    np.testing.assert_array_equal(ours, theirs)
    P = pareto_front(F)
    assert np.all(np.diff(P[:, 0]) >= 0) and len(np.unique(P, axis=0)) == len(P)


@pytest.mark.parametrize("m", [2, 3])
def test_boxes_tile_the_non_dominated_region(m):
    """Invariant: HV(front) + volume(boxes within [ideal, ref]) = volume([ideal, ref])."""
    rng = np.random.default_rng(m)
    F = rng.random((15, m))
    ref = np.full(m, 1.1)
    lower, upper = nondominated_boxes(F, ref)
    floor = np.zeros(m)  # every point is >= 0: clip -inf lower bounds there
    vol = np.prod(upper - np.maximum(lower, floor), axis=1).sum()
    assert vol + hypervolume(F, ref) == pytest.approx(np.prod(ref - floor), rel=1e-12)
    # disjoint: the centre of each box lies in no other box
    lo = np.maximum(lower, floor)
    centres = 0.5 * (lo + upper)
    inside = np.all((centres[:, None] > lo[None]) & (centres[:, None] < upper[None]), axis=2)
    np.testing.assert_array_equal(inside, np.eye(len(lo), dtype=bool))


@pytest.mark.parametrize("m", [2, 3])
def test_hypervolume_improvement_equals_difference_of_hypervolumes(m):
    """Eq. (6.23): I_H(y) = H(F u {y}) - H(F), with its gradient by central differences."""
    rng = np.random.default_rng(10 + m)
    F = pareto_front(rng.random((12, m)))
    ref = np.full(m, 1.1)
    Y = rng.random((20, m)) * 0.9
    hvi, grad = hypervolume_improvement(Y, *nondominated_boxes(F, ref), gradient=True)
    direct = np.array([hypervolume(np.vstack([F, y]), ref) - hypervolume(F, ref) for y in Y])
    np.testing.assert_allclose(hvi, direct, rtol=1e-10, atol=1e-14)
    # I_H is piecewise polynomial (degree m - 1 in each coordinate): the extrapolated
    # difference is exact up to round-off off the kinks, where a coordinate of y meets one
    # of the front's (none within the 2e-7 stencil here); tolerance: its own measured
    # error (conftest.richardson_derivative)
    boxes = nondominated_boxes(F, ref)
    for j in range(m):
        assert np.abs(Y[:, j, None] - np.r_[F[:, j], ref[j]][None, :]).min() > 2e-7
        e = np.eye(m)[j]
        fd, bound = richardson_derivative(lambda t: hypervolume_improvement(Y + t * e, *boxes),
                                          2e-7)
        assert_matches_richardson(grad[:, j], fd, bound, j)


def test_empty_front_box_is_everything_below_reference():
    lower, upper = nondominated_boxes(np.zeros((0, 2)), np.array([1.0, 2.0]))
    assert np.all(np.isneginf(lower)) and np.array_equal(upper, [[1.0, 2.0]])
    assert hypervolume(np.zeros((0, 2)), [1.0, 2.0]) == 0.0


def test_pareto_order_keeps_rows_and_sorts_by_the_objectives_in_turn():
    # rows 0, 2, 3, 5 are non-dominated; 3 and 5 are duplicates, both kept, in row order
    F = np.array([[3.0, 1.0], [3.0, 2.0], [1.0, 3.0], [2.0, 2.0], [4.0, 4.0], [2.0, 2.0]])
    idx = pareto_order(F)
    np.testing.assert_array_equal(idx, [2, 3, 5, 0])
    np.testing.assert_array_equal(F[idx], pareto_front(F, unique=False))
    # a tie in the first objective is broken by the second (three objectives)
    np.testing.assert_array_equal(pareto_order(np.array([[1.0, 2.0, 1.0], [1.0, 1.0, 2.0]])),
                                  [1, 0])
    assert pareto_order(np.zeros((0, 2))).size == 0
