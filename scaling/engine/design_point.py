"""The design point: which evaluation a run recommends (Sec. 9.2.3), one rule for the whole
package -- the optimizer's result, :func:`hypate.minimize`, the run directory, the sweep's
recycling and ``--seed-from`` all rank designs here.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from hypate.scaling.engine.pareto import non_dominated_mask

#: The design-point rules (``[optimizer] design_point``); the first is the default.
DESIGN_POINT_RULES = ("minmax", "weighted", "knee")


def worst_objective(F: np.ndarray) -> np.ndarray:
    """The design-point score of each row of ``F`` (n, m): its largest objective,
    ``max(J_u, J_T)`` (Sec. 9.2.3's min-max criterion; the objective itself for one)."""
    return np.asarray(F, dtype=float).max(axis=1)


def rank_designs(F: np.ndarray) -> np.ndarray:
    """Row indices of ``F`` from the best design to the worst by :func:`worst_objective`
    (stable: of equal scores the earlier evaluation comes first). THE "best design" order:
    the sweep recycling and ``--seed-from`` take their designs in this order, and it is the
    default ("minmax") design-point rule of :func:`design_point_index`."""
    return np.argsort(worst_objective(F), kind="stable")


def normalized_front(F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``F`` scaled by the range of its Pareto set, and that Pareto mask.

    Parameters
    ----------
    F : ndarray of shape (n, m)
        Finite objectives of the candidate designs.

    Returns
    -------
    Fn : ndarray of shape (n, m)
        ``(F - min_P) / (max_P - min_P)`` per objective, min/max over the Pareto set P
        (an objective constant on P keeps the range 1, so it adds nothing to a choice).
    mask : ndarray of bool, shape (n,)
        The Pareto set of ``F``.
    """
    F = np.asarray(F, dtype=float)
    mask = non_dominated_mask(F)
    lo, hi = F[mask].min(axis=0), F[mask].max(axis=0)
    span = np.where(hi > lo, hi - lo, 1.0)
    return (F - lo) / span, mask


def weighted_scores(F: np.ndarray, weights: Sequence[float] | None = None) -> np.ndarray:
    """The "weighted" score of each row: ``sum_k w_k Fn_k`` with ``Fn`` of
    :func:`normalized_front` and weights normalized to sum 1 (equal when None)."""
    Fn, _ = normalized_front(F)
    w = np.ones(Fn.shape[1]) if weights is None else np.asarray(weights, dtype=float)
    if w.shape != (Fn.shape[1],) or not np.all(w >= 0) or w.sum() <= 0:
        raise ValueError(f"weights must be {Fn.shape[1]} non-negative values, not all zero")
    return Fn @ (w / w.sum())


def knee_distances(F: np.ndarray) -> np.ndarray:
    """The "knee" score of each row: its distance to the straight line through the two
    extreme points of the normalized Pareto front (largest = knee); NaN off the front.

    In the normalized objectives of :func:`normalized_front` the extreme points of a
    two-objective front are (0, 1) and (1, 0), so the distance of a front point is
    ``(1 - Fn_1 - Fn_2) / sqrt(2)``; with more objectives the line becomes the hyperplane
    ``sum_k Fn_k = 1`` through the per-objective extremes, distance
    ``(1 - sum_k Fn_k) / sqrt(m)``. Signed: points beyond the line (a concave front) come
    out negative, and the largest value is still the most "bulging" compromise.
    """
    Fn, mask = normalized_front(F)
    m = Fn.shape[1]
    d = (1.0 - Fn.sum(axis=1)) / np.sqrt(m)
    return np.where(mask, d, np.nan)


def design_point_index(F: np.ndarray, rule: str = DESIGN_POINT_RULES[0],
                       weights: Sequence[float] | None = None) -> int:
    """Row of ``F`` chosen as the design point by ``rule``.

    Parameters
    ----------
    F : ndarray of shape (n, m), n >= 1
        Finite objectives of the feasible evaluations, in store order.
    rule : {"minmax", "weighted", "knee"}
        ``minmax``: the smallest ``max_k J_k`` (Sec. 9.2.3; :func:`rank_designs`);
        ``weighted``: the Pareto point with the smallest :func:`weighted_scores` (study
        weights, equal if None; the minimum over all designs is on the front anyway);
        ``knee``: the Pareto point farthest from the line through the two extreme points of
        the normalized front (:func:`knee_distances`). With one objective every rule is the
        minimum. Ties go to the earlier evaluation.
    weights : sequence of float, optional
        Objective weights of ``weighted``.

    Raises
    ------
    ValueError
        Unknown ``rule`` or empty ``F``.
    """
    F = np.atleast_2d(np.asarray(F, dtype=float))
    if rule not in DESIGN_POINT_RULES:
        raise ValueError(f"design-point rule {rule!r}: must be one of "
                         f"{', '.join(DESIGN_POINT_RULES)}")
    if F.shape[0] == 0:
        raise ValueError("no design to choose from")
    if rule == "minmax" or F.shape[1] == 1:
        return int(rank_designs(F)[0])
    if rule == "weighted":
        # over the Pareto set only: with a zero weight a dominated design could tie
        _, mask = normalized_front(F)
        return int(np.argmin(np.where(mask, weighted_scores(F, weights), np.inf)))
    d = knee_distances(F)
    return int(np.nanargmax(d))


def describe_rule(rule: str, n_objectives: int,
                  weights: Sequence[float] | None = None) -> str:
    """One sentence stating how ``rule`` chose the design point (for the report)."""
    if n_objectives <= 1:
        return "the feasible evaluation with the smallest objective"
    if rule == "weighted":
        w = "equal weights" if weights is None else \
            "weights " + ", ".join(f"{x:g}" for x in weights)
        return ("the feasible evaluation with the smallest weighted sum of the objectives "
                f"({w}), each normalized by its range over the Pareto set ('weighted')")
    if rule == "knee":
        return ("the knee of the Pareto front: the Pareto point farthest from the straight "
                "line through the two extreme points of the front, objectives normalized by "
                "their range over the Pareto set ('knee')")
    return ("the feasible evaluation with the smallest max(J_u, J_T), the larger of its "
            "two errors (Sec. 9.2.3 min-max criterion, 'minmax')")
