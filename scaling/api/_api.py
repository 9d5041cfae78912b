"""The documented Python API of hypate (:mod:`hypate` loads it on first use): see the package
docstring of :mod:`hypate` for its names.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from hypate.scaling.engine.asktell import AskTellOptimizer
from hypate.scaling.engine.constraints import sort_constraints
from hypate.scaling.engine.functional import (
    FunctionProblem,
    check_bounds,
    objective_count,
    plan_budget,
)
from hypate.scaling.engine.optimizer import BayesianOptimizer
from hypate.scaling.engine.problem import CheapConstraint
from hypate.scaling.engine.result import OptimizationResult
from hypate.scaling.engine.settings import OptimizerSettings, RunContext
from hypate.scaling.engine.store import EvaluationStore
from hypate.scaling.report.html import write_report_safely
from hypate.scaling.workflow.campaigns.execute import Outcome, execute
from hypate.scaling.workflow.campaigns.run import RunOutcome
from hypate.scaling.workflow.vocabulary.external import SimulatedHistories
from hypate.scaling.workflow.vocabulary.objectives import ModelFailure
from hypate.scaling.workflow.vocabulary.study import Study, load_study
from pymoo.core.problem import Problem
from scipy.optimize import OptimizeResult

__all__ = ["BayesianOptimizer", "CheapConstraint", "ModelFailure", "Optimizer",
           "OptimizerSettings", "RunContext", "RunOutcome", "SimulatedHistories", "Study",
           "load_study", "minimize", "run_study"]


def run_study(study: Study, out: str | Path | None = None, *,
              on_written: Callable[[Path], object] | None = write_report_safely,
              **options: Any) -> Outcome | None:
    """Run (or, with ``resume=True``, continue) ``study`` exactly as ``hypate run STUDY
    --out OUT`` does: the same runner (:func:`hypate.scaling.workflow.campaigns.execute.execute`)
    decides between a single campaign, a robust one, one per seed and one per ``[sweep]``
    point, and writes the same files (a sweep's ``sweep.json``, a ``seeds=N`` run's
    ``seeds.json``).

    Parameters
    ----------
    study : Study
    out : path, optional
        The run directory; default ``runs/<study name>`` (``-2``, ``-3`` ... when it
        exists; with ``resume=True`` the latest).
    on_written : callable or None
        Called with each finished run directory; default: write its report (``None``
        skips it).
    **options
        Those of :func:`~hypate.scaling.workflow.campaigns.execute.execute`: ``resume``,
        ``workers``, ``scheduler``, ``seed``, ``seeds`` (a number of seeds), ``seed_runs``,
        ``progress``, ``force``.

    Returns
    -------
    RunOutcome, SweepOutcome or SeedsOutcome
        A :class:`RunOutcome` for a single or robust study (``.evaluations``,
        ``.pareto``, ``.design_point``).
    """
    return execute(study, out, on_written=on_written, **options)


def _scipy_result(result: OptimizationResult, evaluations: pd.DataFrame) -> OptimizeResult:
    """The scipy-style result of an engine result: the best feasible design by the design-
    point ranking (the smallest largest objective), the row-aligned Pareto set."""
    m = result.n_obj
    ok = np.flatnonzero(result.feasible)
    if ok.size == 0:
        why = "no evaluation succeeded" if not result.ok.any() else \
            "no successful evaluation satisfies the constraints"
        return OptimizeResult(x=None, fun=None, nfev=len(evaluations), success=False,
                              message=why, evaluations=evaluations,
                              pareto_x=np.zeros((0, result.n_var)), pareto_fun=np.zeros((0, m)))
    best = result.design_point()
    x, f = result.X[best], result.F[best]
    return OptimizeResult(x=x, fun=float(f[0]) if m == 1 else f, nfev=len(evaluations),
                          success=True, message=f"{len(evaluations)} evaluations",
                          pareto_x=result.pareto_set(), pareto_fun=result.pareto_front(),
                          evaluations=evaluations)


def minimize(fun: Callable[[np.ndarray], Any] | Problem,
             bounds: Any = None, *, n_evaluations: int = 50, seed: int | None = None,
             n_obj: int | None = None, n_init: int | None = None,
             acquisition: str | None = None, refine: int | None = None,
             constraints: Sequence[Any] | None = None,
             names: Sequence[str] | None = None,
             objective_names: Sequence[str] | None = None) -> OptimizeResult:
    """Minimize an expensive function by Bayesian optimization (kriging + SLSQP multistart).

    Parameters
    ----------
    fun : callable or pymoo Problem
        ``fun(x) -> float`` or ``-> sequence of floats`` (several objectives), ``x`` of shape
        (d,); or a pymoo ``Problem`` (then ``bounds`` is taken from it, and its own
        constraints ``G <= 0`` are expensive ones).
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
    constraints : sequence, optional
        Each entry one of (:mod:`hypate.scaling.engine.constraints`):

        - a callable ``g(x) -> float``, feasible where ``g(x) <= 0``: **expensive**. It is
          called once per evaluation, right after ``fun`` at the same design, and modelled
          by kriging; every proposal must be feasible with predicted probability 0.5, and
          only designs that satisfy it enter ``x`` and the Pareto set. (Objectives and
          constraints from one simulation: a pymoo ``Problem`` with ``G``.)
        - :class:`CheapConstraint` ``(fun, jac, kind)``, ``fun(x) <= 0`` (``kind="ineq"``)
          or ``fun(x) == 0`` (``"eq"``) with its Jacobian: **cheap**, handed to the inner
          SLSQP exactly (every design, the initial ones projected, satisfies it to SLSQP's
          precision: 1e-8 with its Jacobian, about 1e-7 with a finite-difference one),
          never counted as an evaluation.
        - a scipy-style dict ``{"type": "ineq" | "eq", "fun", "jac", "args", "cheap"}``
          with scipy's sign: an ``"ineq"`` holds where ``fun(x) >= 0`` (converted to
          ``-fun(x) <= 0``). Cheap when it has ``"jac"`` or ``"cheap": True`` (then a
          forward-difference Jacobian), else an expensive inequality. An equality must be
          cheap.
    names : sequence of str, optional
        The variables' names, the column names of ``res.evaluations`` (default ``x0..``).
    objective_names : sequence of str, optional
        The objectives' names there (default ``f0..``).

    Returns
    -------
    scipy.optimize.OptimizeResult
        ``x``, ``fun`` (best feasible design and its objective(s); for several objectives
        the design with the smallest largest objective), ``nfev``, ``success``,
        ``message``, ``pareto_x`` / ``pareto_fun`` (the feasible Pareto set and its
        objectives, row-aligned -- ``pareto_fun[i]`` are the objectives of
        ``pareto_x[i]`` -- sorted by the first objective), and ``evaluations`` (a
        DataFrame, one row per evaluation: the variables and objectives by name,
        constraints ``g0..``, status, message, warnings, seconds, iteration).

    Raises
    ------
    ValueError
        Bad bounds, budget, names or constraints (the message names the argument).

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
        if constraints:
            raise ValueError("constraints: a pymoo Problem states its own (G, H)")
        cheap: tuple[CheapConstraint, ...] = ()
    else:
        if bounds is None:
            raise ValueError("bounds: a callable needs the (lower, upper) of every variable")
        box = check_bounds(bounds)
        sorted_ = sort_constraints(constraints, box)
        cheap = sorted_.cheap
        problem = FunctionProblem(fun, box, n_obj if n_obj is not None else
                                  objective_count(fun, box), constraints=sorted_.expensive)
    d, m = int(problem.n_var), int(problem.n_obj)
    plan = plan_budget(d, m, n_evaluations, n_init, refine, acquisition)
    seed = 0 if seed is None else int(seed)
    with EvaluationStore(":memory:") as store:
        common: dict[str, Any] = {"n_init": plan.n_init, "seed": seed, "store": store,
                                  "cheap_constraints": cheap}
        result = BayesianOptimizer(problem, acquisition=plan.acquisition, n_iter=plan.n_iter,
                                   **common).run()
        if plan.refine and result.feasible.any():
            # the same store, continued: iterations n_iter + 1 ... are purely exploiting
            result = BayesianOptimizer(problem, acquisition="lcb", v=0.0,
                                       n_iter=plan.n_iter + plan.refine, **common).run()
    return _scipy_result(result, result.named_data(names, objective_names))


class Optimizer(AskTellOptimizer):
    """Bayesian optimization driven by your own evaluations: ``ask`` for designs, evaluate
    them anywhere (a cluster job, an experiment), ``tell`` the results.

    The engine of :func:`minimize` (:class:`BayesianOptimizer`: its initial design, then its
    proposals from the evaluations told so far), with the same crash-safe store: given a
    ``store`` path, every told result is committed at once, and an optimizer opened later
    on the same store resumes, handing out again the designs asked and never told (a
    killed loop, resumed, ends with the evaluations of an uninterrupted one). Asking one
    design at a time with ``n_evaluations`` set gives exactly the designs :func:`minimize`
    evaluates for the same function, budget and seed.

    Parameters
    ----------
    bounds : sequence of (lower, upper)
        Finite bounds of each of the ``d`` variables.
    n_objectives : int
        Objectives told per design.
    seed : int or None
        Seed of every random choice (``None``: 0).
    n_constraints : int
        Expensive constraints told per design, ``tell(X, Y, G)``, feasible where ``G <= 0``.
    constraints : sequence of CheapConstraint or dict, optional
        Cheap constraints every design asked satisfies (as :func:`minimize`'s cheap ones).
    n_init : int or None
        Initial designs; ``None``: ``max(2 d + 1, n_evaluations // 5)``, or ``2 d + 1``
        without a budget.
    n_evaluations : int or None
        The planned budget, which shapes the proposals as in :func:`minimize` (the last
        ``min(5, n_evaluations // 8)`` of one objective at the minimum of the kriging mean;
        HVLCB's exploration weight falling over it). Not a cap.
    acquisition : str or None
        As :func:`minimize`.
    store : str, Path or None
        SQLite store (``None``: in memory); an existing one is resumed.
    names, objective_names, constraint_names : sequence of str, optional
        Column names of :attr:`evaluations`.
    **settings
        Further engine settings (``v``, ``p_feasible``, ``kernel``, ...; the fields of
        :class:`hypate.scaling.engine.settings.OptimizerSettings` the loop does not decide,
        and ``blas_threads`` of :class:`~hypate.scaling.engine.settings.RunContext`).

    Examples
    --------
    >>> import numpy as np, hypate
    >>> opt = hypate.Optimizer([(-5, 10), (0, 15)], seed=0, n_evaluations=12)
    >>> X = opt.ask(3)                     # evaluate these three anywhere
    >>> X.shape
    (3, 2)
    >>> opt.tell(X, [np.sum(x**2) for x in X])
    >>> opt.n_told
    3
    """

    def result(self) -> OptimizeResult:
        """The evaluations told so far, as :func:`minimize` returns them.

        Returns
        -------
        scipy.optimize.OptimizeResult
            ``x``, ``fun``, ``nfev``, ``success``, ``message``, ``pareto_x``,
            ``pareto_fun`` (row-aligned) and ``evaluations`` (:attr:`evaluations`).
        """
        return _scipy_result(self.history(), self.evaluations)
