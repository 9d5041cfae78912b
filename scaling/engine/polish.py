"""The final Nelder-Mead polish of a run (``OptimizerSettings.polish``).

After the Bayesian iterations, a derivative-free simplex search of the design-point score
(:func:`~hypate.scaling.engine.design_point.worst_objective`: the objective itself, or
``max_j J_j`` of two or more -- Sec. 9.2.3's min-max criterion) starts from the best
feasible design, in the surrogates' coordinates (``settings.coordinates``, e.g. similarity
parameters in log space, or the unit box), with the cheap constraints enforced by
projection. Each new design it asks for is a real evaluation, stored as iteration
``n_iter + 1`` (batch index = its order); a design already evaluated (to 1e-9 of each
range) is not simulated again. A resumed run replays the stored evaluations in order, so it
ends where the uninterrupted run did. The search stops after ``settings.polish`` new
evaluations or when the evaluation budget is spent.
"""
from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Sequence

import numpy as np
from hypate.scaling.engine.design_point import worst_objective
from hypate.scaling.engine.problem import project_unit, scipy_constraints
from hypate.scaling.engine.settings import OptimizerSettings
from hypate.scaling.engine.store import Evaluation
from scipy.optimize import minimize

__all__ = ["polish_best"]


class _PolishDone(Exception):
    """The polish budget is spent."""


def _feasible(ev: Evaluation) -> bool:
    return bool(ev.ok and np.all(np.asarray(ev.G) <= 0.0))


def _score(ev: Evaluation) -> float:
    """The design-point score of a feasible evaluation (module docstring)."""
    return float(worst_objective(np.atleast_2d(np.asarray(ev.F, float)))[0])


def polish_best(settings: OptimizerSettings, bounds: np.ndarray, records: Sequence[Evaluation],
                evaluate: Callable[[np.ndarray, int], Evaluation],
                budget_left: Callable[[], int]) -> None:
    """Nelder-Mead on the design-point score from the best feasible design of ``records``
    (module docstring).

    Parameters
    ----------
    settings : OptimizerSettings
        ``polish`` (new evaluations), ``polish_step`` (the initial simplex's edge, a share
        of each coordinate's range), ``n_iter``, ``coordinates``, ``cheap_constraints``.
    bounds : ndarray of shape (d, 2)
    records : sequence of Evaluation
        The run's evaluations (a resumed polish's own among them, iteration ``n_iter + 1``).
    evaluate : callable
        ``evaluate(x, k)``: simulate design ``x`` as the polish's ``k``-th evaluation, commit
        it and return its record.
    budget_left : callable
        Evaluations the run may still make.
    """
    if settings.polish <= 0:
        return
    t = settings.n_iter + 1
    before = [r for r in records if r.iteration < t]
    feasible = [r for r in before if _feasible(r)]
    if not feasible:
        return
    lo, hi = bounds[:, 0], bounds[:, 1]
    span = hi - lo
    n_var = len(lo)
    x_best = np.asarray(feasible[int(np.argmin([_score(r) for r in feasible]))].x, float)
    coords = settings.coordinates
    if coords is None:  # the unit box
        z0, z_span = (x_best - lo) / span, np.ones(n_var)
    else:
        box = coords.box(bounds)
        z0, z_span = coords(x_best)[0], box[:, 1] - box[:, 0]
        A_inv = np.linalg.inv(coords.matrix)
    cheap = settings.cheap_constraints
    cons = scipy_constraints(cheap, lo, span) if cheap else []
    stored = {r.batch_index: r for r in records if r.iteration == t}
    def key(x: np.ndarray) -> tuple[float, ...]:
        # a design's place in the unit box to 1e-9 of each range: the simplex's arithmetic
        # revisits a design with float noise (5e-16 of p0), which is not simulated again
        return tuple(np.round((np.asarray(x, float) - lo) / span, 9))

    seen = {key(r.x): r for r in before}
    count = [0]

    def design(z: np.ndarray) -> np.ndarray:
        x = lo + z * span if coords is None else np.exp(A_inv @ z)
        x = np.clip(x, lo, hi)
        if cons:
            x = lo + project_unit((x - lo) / span, cons) * span
        return x

    def value(z: np.ndarray) -> float:
        x = design(z)
        ev = seen.get(key(x))
        if ev is None:
            k = count[0]
            if k >= settings.polish or budget_left() <= 0:
                raise _PolishDone
            if k in stored:
                ev = stored[k]
                if not np.allclose(ev.x, x, rtol=0, atol=1e-9):
                    warnings.warn("polish: resumed point differs from the stored one",
                                  RuntimeWarning, stacklevel=2)
            else:
                ev = evaluate(x, k)
            count[0] += 1
            seen[key(x)] = ev
        score = _score(ev) if _feasible(ev) else math.inf
        return score if np.isfinite(score) else math.inf

    step = settings.polish_step * z_span
    simplex = z0 + np.vstack([np.zeros(n_var), np.diag(step)])
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            minimize(value, z0, method="Nelder-Mead",
                     options={"initial_simplex": simplex, "maxfev": 100 * settings.polish,
                              "xatol": 1e-9, "fatol": 0.0})
    except _PolishDone:
        pass
