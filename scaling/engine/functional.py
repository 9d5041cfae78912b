"""A plain Python function as a pymoo problem, so the engine optimizes it like any other.

``fun(x) -> float`` (one objective) or ``-> sequence of floats`` (several), with ``x`` an
ndarray of shape (d,); the engine evaluates designs one at a time (each evaluation is
assumed expensive), so the loop over the rows of a batch is not a hot path.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from pymoo.core.problem import Problem


class FunctionProblem(Problem):
    """pymoo problem of a callable on a box (objectives minimized, no constraints).

    Parameters
    ----------
    fun : callable
        ``fun(x)`` with ``x`` of shape (d,), returning one number or ``n_obj`` numbers.
    bounds : sequence of (lower, upper)
        Finite bounds of each variable, lower < upper.
    n_obj : int
        Number of objectives ``fun`` returns.
    """

    def __init__(self, fun: Callable[[np.ndarray], float | Sequence[float]],
                 bounds: Sequence[tuple[float, float]], n_obj: int = 1) -> None:
        b = np.asarray(bounds, dtype=float)
        if b.ndim != 2 or b.shape[1] != 2 or len(b) == 0:
            raise ValueError(f"bounds must be a sequence of (lower, upper) pairs; got shape "
                             f"{b.shape}")
        if not (np.all(np.isfinite(b)) and np.all(b[:, 0] < b[:, 1])):
            raise ValueError("bounds must be finite with lower < upper for every variable")
        if n_obj < 1:
            raise ValueError(f"n_obj must be >= 1; got {n_obj}")
        self.fun = fun
        super().__init__(n_var=len(b), n_obj=int(n_obj), xl=b[:, 0], xu=b[:, 1])

    def _evaluate(self, x, out, *args, **kwargs):  # noqa: ANN001, ANN002, ANN003 - pymoo API
        X = np.atleast_2d(np.asarray(x, dtype=float))
        F = np.array([np.atleast_1d(np.asarray(self.fun(row), dtype=float)) for row in X])
        if F.shape != (len(X), self.n_obj):
            raise ValueError(f"fun must return {self.n_obj} number(s) per design; got "
                             f"shape {F.shape[1:]}")
        out["F"] = F


def objective_count(fun: Callable[[np.ndarray], float | Sequence[float]],
                    bounds: Sequence[tuple[float, float]]) -> int:
    """How many objectives ``fun`` returns, from one call at the centre of the box."""
    centre = np.asarray(bounds, dtype=float).mean(axis=1)
    return int(np.atleast_1d(np.asarray(fun(centre), dtype=float)).size)
