"""A plain Python function as a pymoo problem, so the engine optimizes it like any other,
and the budget plan shared by ``hypate.minimize`` and the ask/tell ``hypate.Optimizer``.

``fun(x) -> float`` (one objective) or ``-> sequence of floats`` (several), with ``x`` an
ndarray of shape (d,); expensive constraints ``g(x) <= 0`` are evaluated right after it, at
the same design (:mod:`hypate.scaling.engine.constraints`). The engine evaluates designs
one at a time (each evaluation is assumed expensive), so the loop over the rows of a batch
is not a hot path.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from hypate.scaling.engine.acquisition import default_acquisition
from numpy.typing import ArrayLike
from pymoo.core.problem import Problem

__all__ = ["Budget", "FunctionProblem", "check_bounds", "objective_count", "plan_budget"]


def check_bounds(bounds: ArrayLike) -> np.ndarray:
    """``bounds`` as an array of shape (d, 2), checked.

    Raises
    ------
    ValueError
        Not a non-empty sequence of finite ``(lower, upper)`` pairs with lower < upper.
    """
    try:
        b = np.asarray(bounds, dtype=float)
    except (TypeError, ValueError):
        raise ValueError("bounds must be a sequence of (lower, upper) pairs of numbers") \
            from None
    if b.ndim != 2 or b.shape[1] != 2 or len(b) == 0:
        raise ValueError(f"bounds must be a sequence of (lower, upper) pairs; got shape "
                         f"{b.shape}")
    if not (np.all(np.isfinite(b)) and np.all(b[:, 0] < b[:, 1])):
        raise ValueError("bounds must be finite with lower < upper for every variable")
    return b


class FunctionProblem(Problem):
    """pymoo problem of a callable on a box (objectives minimized), with expensive
    inequality constraints evaluated at the same designs.

    Parameters
    ----------
    fun : callable
        ``fun(x)`` with ``x`` of shape (d,), returning one number or ``n_obj`` numbers.
    bounds : sequence of (lower, upper)
        Finite bounds of each variable, lower < upper.
    n_obj : int
        Number of objectives ``fun`` returns.
    constraints : sequence of callable
        Expensive constraints ``g(x) -> float``, feasible where ``g(x) <= 0`` (pymoo's
        ``G``), each called once per design right after ``fun``
        (:class:`~hypate.scaling.engine.constraints.ExpensiveConstraint`).
    """

    def __init__(self, fun: Callable[[np.ndarray], float | Sequence[float]],
                 bounds: ArrayLike, n_obj: int = 1,
                 constraints: Sequence[Callable[[np.ndarray], float]] = ()) -> None:
        b = check_bounds(bounds)
        if n_obj < 1:
            raise ValueError(f"n_obj must be >= 1; got {n_obj}")
        self.fun = fun
        self.constraints = tuple(constraints)
        super().__init__(n_var=len(b), n_obj=int(n_obj), n_ieq_constr=len(self.constraints),
                         xl=b[:, 0], xu=b[:, 1])

    def _evaluate(self, x, out, *args, **kwargs):  # noqa: ANN001, ANN002, ANN003 - pymoo API
        X = np.atleast_2d(np.asarray(x, dtype=float))
        F = np.array([np.atleast_1d(np.asarray(self.fun(row), dtype=float)) for row in X])
        if F.shape != (len(X), self.n_obj):
            raise ValueError(f"fun must return {self.n_obj} number(s) per design; got "
                             f"shape {F.shape[1:]}")
        out["F"] = F
        if self.constraints:
            out["G"] = np.array([[float(g(row)) for g in self.constraints] for row in X])


def objective_count(fun: Callable[[np.ndarray], float | Sequence[float]],
                    bounds: ArrayLike) -> int:
    """How many objectives ``fun`` returns, from one call at the centre of the box."""
    centre = np.asarray(bounds, dtype=float).mean(axis=1)
    return int(np.atleast_1d(np.asarray(fun(centre), dtype=float)).size)


@dataclass(frozen=True)
class Budget:
    """How ``n_evaluations`` are spent (:func:`plan_budget`).

    Attributes
    ----------
    n_init : int
        Initial optimal-Latin-hypercube designs.
    n_iter : int
        Proposals by the acquisition.
    refine : int
        Final proposals at the minimum of the kriging mean (LCB with ``v = 0``).
    acquisition : str
        The acquisition of the ``n_iter`` proposals.
    """

    n_init: int
    n_iter: int
    refine: int
    acquisition: str

    @property
    def total(self) -> int:
        return self.n_init + self.n_iter + self.refine


def plan_budget(d: int, m: int, n_evaluations: int, n_init: int | None = None,
                refine: int | None = None, acquisition: str | None = None) -> Budget:
    """The budget plan of ``hypate.minimize`` (and of an ask/tell ``hypate.Optimizer`` given
    its ``n_evaluations``): initial design, acquisition proposals, exploiting proposals.

    Parameters
    ----------
    d, m : int
        Variables and objectives.
    n_evaluations : int
        The whole budget, ``>= 2 d + 2``.
    n_init : int or None
        ``None``: ``max(2 d + 1, n_evaluations // 5)``.
    refine : int or None
        ``None``: ``min(5, n_evaluations // 8)`` for one objective, 0 for several. EI keeps
        exploring where the model is unsure; a few purely exploiting steps then settle the
        last digits of the optimum (Branin, 40 evaluations, seeds 0-9: within 1e-4 of the
        minimum with 5, 1e-3 to 2e-3 without).
    acquisition : str or None
        ``None``: ``"ei"`` for one objective, ``"hvlcb"`` for several.

    Returns
    -------
    Budget

    Raises
    ------
    ValueError
        A budget below ``2 d + 2``, ``refine`` with several objectives, or parts that do
        not fit in the budget (the message names the argument).
    """
    if n_evaluations < 2 * d + 2:
        raise ValueError(f"n_evaluations: need at least 2 d + 2 = {2 * d + 2}; got "
                         f"{n_evaluations}")
    n0 = n_init if n_init is not None else max(2 * d + 1, n_evaluations // 5)
    n_refine = (min(5, n_evaluations // 8) if m == 1 else 0) if refine is None else int(refine)
    if m > 1 and n_refine:
        raise ValueError("refine: only for one objective")
    n_iter = n_evaluations - n0 - n_refine
    if n0 < 1 or n_refine < 0 or n_iter < 0:
        raise ValueError(f"n_init + refine: must leave room in n_evaluations = {n_evaluations}; "
                         f"got n_init {n0}, refine {n_refine}")
    return Budget(n0, n_iter, n_refine, acquisition or default_acquisition(m))
