"""The documented Python API of hypate (:mod:`hypate` loads it on first use).

:func:`load_study`, :func:`run_study`, :class:`BayesianOptimizer`, :func:`minimize`: see the
package docstring of :mod:`hypate`.
"""
from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from hypate.scaling.engine.functional import FunctionProblem, objective_count
from hypate.scaling.engine.optimizer import BayesianOptimizer
from hypate.scaling.engine.store import EvaluationStore
from hypate.scaling.report.html import write_report_safely
from hypate.scaling.workflow import run as _run
from hypate.scaling.workflow.run import RunOutcome
from hypate.scaling.workflow.rundir import rank_designs
from hypate.scaling.workflow.study import Study, load_study
from pymoo.core.problem import Problem
from scipy.optimize import OptimizeResult

__all__ = ["BayesianOptimizer", "RunOutcome", "Study", "load_study", "minimize", "run_study"]


def run_study(study: Study, out: str | Path, *,
              on_written: Callable[[Path], object] | None = write_report_safely,
              **options: Any) -> RunOutcome:
    """Run (or, with ``resume=True``, continue) ``study`` into the directory ``out`` and
    write its report, exactly as ``hypate run STUDY --out OUT`` does.

    ``options`` are those of :func:`hypate.scaling.workflow.run.run_study` (``resume``,
    ``workers``, ``scheduler``, ``seed``, ``progress``, ``seed_runs``); ``on_written=None``
    skips the report.
    """
    return _run.run_study(study, out, on_written=on_written, **options)


def minimize(fun: Callable[[np.ndarray], Any] | Problem,
             bounds: Any = None, *, n_evaluations: int = 50, seed: int | None = None,
             n_obj: int | None = None, n_init: int | None = None,
             acquisition: str | None = None, refine: int | None = None) -> OptimizeResult:
    """Minimize an expensive function by Bayesian optimization (kriging + SLSQP multistart).

    Parameters
    ----------
    fun : callable or pymoo Problem
        ``fun(x) -> float`` or ``-> sequence of floats`` (several objectives), ``x`` of shape
        (d,); or a pymoo ``Problem`` (then ``bounds`` is taken from it).
    bounds : sequence of (lower, upper)
        Finite bounds of each variable (a callable needs them).
    n_evaluations : int
        Budget of evaluations of ``fun`` (the initial design included).
    seed : int or None
        Seed of every random choice (``None``: 0). The same seed gives the same result.
    n_obj : int or None
        Objectives ``fun`` returns; ``None`` asks ``fun`` once at the centre of the box (one
        extra call, not counted in the budget).
    n_init : int or None
        Initial optimal-Latin-hypercube samples; ``None``: ``max(2 d + 1, n_evaluations // 5)``.
    acquisition : str or None
        ``"lcb"``, ``"ei"``, ``"poi"`` (one objective) or ``"hvlcb"``, ``"hvei"``, ``"hvpoi"``
        (several); ``None``: EI for one objective, HVLCB for several.
    refine : int or None
        Final evaluations at the minimum of the kriging mean (LCB with ``v = 0``; one
        objective only). EI keeps exploring where the model is unsure; a few purely
        exploiting steps then settle the last digits of the optimum (Branin, 40 evaluations,
        seeds 0-9: within 1e-4 of the minimum with 5, 1e-3 to 2e-3 without).
        ``None``: 5 for one objective (fewer for a small budget), 0 for several.

    Returns
    -------
    scipy.optimize.OptimizeResult
        ``x``, ``fun`` (best design and its objective(s); for several objectives the design
        with the smallest largest objective), ``nfev``, ``success``, ``message``,
        ``pareto_x`` / ``pareto_fun`` (the Pareto set), and ``evaluations`` (a DataFrame:
        ``x0..``, ``f0..``, status, message, warnings, seconds, iteration).

    Examples
    --------
    >>> import numpy as np, hypate
    >>> def branin(x):
    ...     b, c = 5.1 / (4 * np.pi**2), 5 / np.pi
    ...     return ((x[1] - b * x[0]**2 + c * x[0] - 6)**2
    ...             + 10 * (1 - 1 / (8 * np.pi)) * np.cos(x[0]) + 10)
    >>> res = hypate.minimize(branin, bounds=[(-5, 10), (0, 15)], n_evaluations=40, seed=0)
    >>> bool(abs(res.fun - 0.397887) < 1e-3)
    True
    """
    if isinstance(fun, Problem):
        problem = fun
    else:
        if bounds is None:
            raise ValueError("bounds: a callable needs the (lower, upper) of every variable")
        problem = FunctionProblem(fun, bounds,
                                  n_obj if n_obj is not None else objective_count(fun, bounds))
    d, m = int(problem.n_var), int(problem.n_obj)
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
    seed = 0 if seed is None else int(seed)
    with EvaluationStore(":memory:") as store:
        common = {"n_init": n0, "seed": seed, "store": store}
        result = BayesianOptimizer(problem, acquisition=acquisition or (
            "ei" if m == 1 else "hvlcb"), n_iter=n_iter, **common).run()
        if n_refine and result.feasible.any():
            # the same store, continued: iterations n_iter + 1 ... are purely exploiting
            result = BayesianOptimizer(problem, acquisition="lcb", v=0.0,
                                       n_iter=n_iter + n_refine, **common).run()
    evaluations: pd.DataFrame = result.data.copy()
    ok = np.flatnonzero(result.feasible)
    if ok.size == 0:
        return OptimizeResult(x=None, fun=None, nfev=len(evaluations), success=False,
                              message="no evaluation succeeded", evaluations=evaluations)
    best = ok[rank_designs(result.F[ok])[0]]
    x, f = result.X[best], result.F[best]
    return OptimizeResult(x=x, fun=float(f[0]) if m == 1 else f, nfev=len(evaluations),
                          success=True, message=f"{len(evaluations)} evaluations",
                          pareto_x=result.pareto_set(), pareto_fun=result.pareto_front(),
                          evaluations=evaluations)
