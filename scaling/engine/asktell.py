"""Ask/tell: the engine driven by whoever evaluates the designs.

An external code on a cluster, a physical experiment or a person in the loop evaluates the
designs; the engine only proposes them (``ask``) and learns their results (``tell``).
Nothing here is a second optimizer: every design comes from one
:class:`~hypate.scaling.engine.optimizer.BayesianOptimizer` -- its
:meth:`~hypate.scaling.engine.optimizer.BayesianOptimizer.initial_design` first, then its
:meth:`~hypate.scaling.engine.optimizer.BayesianOptimizer.propose` on the evaluations told
so far -- and every told result is committed to the same crash-safe
:class:`~hypate.scaling.engine.store.EvaluationStore` row the optimizer's own loop writes.

Slots. Each design asked has a slot ``(iteration, batch_index)`` as in the optimizer's own
loop: ``(0, i)`` the i-th initial design, ``(t, b)`` the b-th design of the t-th proposal
(``t = 1, 2, ...``; one ``ask`` of ``n`` model-based designs is one proposal of a batch of
``n``, kriging-believer fantasies inside it), ``(-1, j)`` a design told without being asked.
With ``ask(1)`` at a time and a budget, the designs are exactly those
``hypate.minimize`` evaluates for the same function, budget and seed.

Resuming. Each ask is recorded in the store's metadata (``asks``: its slots, and for a
proposal the number of evaluations it was proposed from) before its designs are handed
out. A new optimizer on the same store first hands out again the designs asked and never
told, recomputed exactly (a proposal depends only on the evaluations before it and on its
iteration's random numbers), then goes on: a loop killed at any point and resumed ends with
the evaluations of an uninterrupted one.
"""
from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any, cast

import numpy as np
import pandas as pd
from hypate.scaling.engine.acquisition import default_acquisition
from hypate.scaling.engine.constraints import sort_constraints
from hypate.scaling.engine.functional import Budget, check_bounds, plan_budget
from hypate.scaling.engine.optimizer import BayesianOptimizer
from hypate.scaling.engine.problem import STATUS_OK
from hypate.scaling.engine.result import OptimizationResult
from hypate.scaling.engine.settings import OptimizerSettings, RunContext
from hypate.scaling.engine.store import Evaluation, EvaluationStore, evaluations_to_dataframe
from hypate.solvers.numerics.threads import blas_threads
from pymoo.core.problem import Problem

__all__ = ["AskTellOptimizer", "OWNED_SETTINGS"]

#: Optimizer settings an ask/tell loop decides itself (the caller evaluates, so there is no
#: executor, time limit, callback or polish; the budget plan sets the iterations).
OWNED_SETTINGS = frozenset((
    "n_init", "n_iter", "seed", "store", "cheap_constraints", "batch_size", "executor",
    "timeout", "callback", "polish", "polish_method", "polish_step", "max_evaluations",
    "convergence_tol", "convergence_window", "stopping", "categorical", "acquisition"))
#: Store metadata key of the asks (module docstring).
ASKS = "asks"
#: Largest distance, as a fraction of each variable's range, between a told design and the
#: asked one it is taken for (a design written to a file and read back loses last digits).
MATCH_TOL = 1e-9
#: Message of a design told as failed (NaN objectives).
FAILED_MESSAGE = "told as NaN: the evaluation failed"


class _ToldProblem(Problem):
    """The problem of an ask/tell loop: bounds and counts only; its designs are evaluated
    outside and told."""

    def __init__(self, bounds: np.ndarray, n_obj: int, n_constr: int) -> None:
        super().__init__(n_var=len(bounds), n_obj=n_obj, n_ieq_constr=n_constr,
                         xl=bounds[:, 0], xu=bounds[:, 1])

    def _evaluate(self, x, out, *args, **kwargs):  # noqa: ANN001, ANN002, ANN003 - pymoo API
        raise TypeError("an ask/tell problem is evaluated by its caller: tell the results")


def _count(name: str, value: Any, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ValueError(f"{name}: must be an integer >= {minimum}; got {value!r}")
    return int(value)


class AskTellOptimizer:
    """Bayesian optimization driven from outside: ``ask`` for designs, ``tell`` their results.

    Parameters
    ----------
    bounds : sequence of (lower, upper)
        Finite bounds of each of the ``d`` variables.
    n_objectives : int
        Objectives told per design (minimized).
    n_constraints : int
        Expensive constraints told per design (``tell(X, Y, G)``), feasible where
        ``G <= 0``; modelled by kriging, each proposal feasible with predicted probability
        ``p_feasible``.
    constraints : sequence of CheapConstraint or dict, optional
        Cheap constraints enforced exactly in every design asked
        (:func:`~hypate.scaling.engine.constraints.sort_constraints`: a
        :class:`~hypate.scaling.engine.problem.CheapConstraint`, or a scipy-style dict with
        ``"jac"`` or ``"cheap": True``). Expensive ones are told: ``n_constraints``.
    seed : int or None
        Seed of every random choice (``None``: 0); the same seed and results give the same
        designs.
    n_init : int or None
        Initial optimal-Latin-hypercube designs; ``None``: as
        :func:`~hypate.scaling.engine.functional.plan_budget` with ``n_evaluations``, else
        ``2 d + 1``.
    n_evaluations : int or None
        The planned budget: the designs after the initial ones are proposed by the
        acquisition, the last ``refine`` (one objective: ``min(5, n_evaluations // 8)``)
        at the minimum of the kriging mean, and HVLCB's exploration weight falls over it
        (:func:`~hypate.scaling.engine.functional.plan_budget`). Not a cap: asking beyond
        it goes on exploiting. ``None``: the acquisition throughout, a constant weight.
    acquisition : str or None
        As ``hypate.minimize``; ``None``: EI for one objective, HVLCB for several.
    store : str, Path, EvaluationStore or None
        SQLite store of the told evaluations (``None``: in memory; a path's missing folders
        are created). An existing store is resumed (module docstring); one of another problem, seed
        or budget is refused.
    names : sequence of str, optional
        Variable names of :attr:`evaluations` (default ``x0, x1, ...``).
    objective_names, constraint_names : sequence of str, optional
        Their names (default ``f0, ...`` and ``g0, ...``).
    **settings
        Further fields of :class:`~hypate.scaling.engine.settings.OptimizerSettings`
        (``v``, ``p_feasible``, ``kernel``, ...) and ``blas_threads`` of
        :class:`~hypate.scaling.engine.settings.RunContext`, except those the loop decides
        (:data:`OWNED_SETTINGS`).

    Raises
    ------
    ValueError
        A bad bound, count, name list or budget (the message names the argument), or a
        store holding another problem.
    TypeError
        An expensive entry in ``constraints``, or a setting the loop decides.
    """

    def __init__(self, bounds: Sequence[tuple[float, float]], *, n_objectives: int = 1,
                 n_constraints: int = 0, constraints: Sequence[Any] | None = None,
                 seed: int | None = None, n_init: int | None = None,
                 n_evaluations: int | None = None, acquisition: str | None = None,
                 store: str | Path | EvaluationStore | None = None,
                 names: Sequence[str] | None = None,
                 objective_names: Sequence[str] | None = None,
                 constraint_names: Sequence[str] | None = None, **settings: Any) -> None:
        b = check_bounds(bounds)
        d = len(b)
        m = _count("n_objectives", n_objectives, 1)
        k = _count("n_constraints", n_constraints, 0)
        owned = sorted(set(settings) & OWNED_SETTINGS)
        if owned:
            raise TypeError(f"{owned}: decided by the ask/tell loop (pass n_init, "
                            "n_evaluations, seed, acquisition, constraints, store)")
        sorted_ = sort_constraints(constraints, b)
        if sorted_.expensive:
            raise TypeError("constraints: an ask/tell loop enforces cheap constraints only "
                            "(a CheapConstraint, or a dict with 'jac' or 'cheap': True); "
                            "expensive ones are told with the objectives: n_constraints and "
                            "tell(X, Y, G)")
        if n_evaluations is not None:
            plan = plan_budget(d, m, _count("n_evaluations", n_evaluations, 1), n_init, None,
                               acquisition)
        else:
            if "v_final" in settings and settings["v_final"] is not None:
                raise ValueError("v_final: the exploration weight falls over a budget; give "
                                 "n_evaluations")
            settings = {**settings, "v_final": None}
            n0 = 2 * d + 1 if n_init is None else _count("n_init", n_init, 1)
            plan = Budget(n0, 0, 0, acquisition or default_acquisition(m))
        self.budget = plan
        self.n_evaluations = n_evaluations
        self.seed = 0 if seed is None else _count("seed", seed, 0)
        self.names = self._names("names", names, "x", d)
        self.objective_names = self._names("objective_names", objective_names, "f", m)
        self.constraint_names = self._names("constraint_names", constraint_names, "g", k)
        self.problem = _ToldProblem(b, m, k)
        where = {k: settings.pop(k) for k in list(settings) if k in RunContext.names()}
        #: The proposals' BLAS threads (the loop's only run context: the caller evaluates).
        self.context = RunContext(**where)
        self.settings = OptimizerSettings(
            acquisition=plan.acquisition, n_init=plan.n_init, n_iter=plan.n_iter,
            seed=self.seed, cheap_constraints=sorted_.cheap, **settings)
        #: The optimizer whose designs are handed out (its settings; proposals of a batch
        #: of n use a copy with ``batch_size = n``).
        self.optimizer = BayesianOptimizer(self.problem, self.settings)
        self._initial = self.optimizer.initial_design()
        self._engines: dict[tuple[bool, int], BayesianOptimizer] = {}
        self._owned = not isinstance(store, EvaluationStore)
        if store is not None and not isinstance(store, EvaluationStore):
            Path(store).parent.mkdir(parents=True, exist_ok=True)
        self.store = store if isinstance(store, EvaluationStore) else \
            EvaluationStore(":memory:" if store is None else store)
        try:
            for key, val in (("seed", self.seed), ("n_var", d), ("n_obj", m), ("n_constr", k),
                             ("n_init", plan.n_init), ("n_evaluations", n_evaluations),
                             ("acquisition", plan.acquisition)):
                self.store.set_meta(key, val)
        except ValueError:
            self.close()
            raise
        self._records = self.store.load()
        # the ASKS record is the JSON list of dicts this class stores (get_meta: object)
        self._asks: list[dict[str, Any]] = list(
            cast("list[dict[str, Any]]", self.store.get_meta(ASKS) or []))
        told = {(r.iteration, r.batch_index) for r in self._records}
        #: Slots asked before (maybe by a killed process) and never told: handed out first.
        self._unanswered = [tuple(s) for a in self._asks for s in a["slots"]
                            if tuple(s) not in told]
        #: Slots handed out by this object and not told yet: slot -> (x, time asked).
        self._pending: dict[tuple[int, int], tuple[np.ndarray, float]] = {}
        self._proposals: dict[int, np.ndarray] = {}

    @staticmethod
    def _names(arg: str, given: Sequence[str] | None, prefix: str, n: int) -> list[str]:
        if given is None:
            return [f"{prefix}{i}" for i in range(n)]
        out = [str(v) for v in given]
        if len(out) != n or len(set(out)) != n:
            raise ValueError(f"{arg}: need {n} distinct names; got {list(given)!r}")
        return out

    # ------------------------------------------------------------------ state
    @property
    def n_told(self) -> int:
        """Evaluations told (and stored) so far."""
        return len(self._records)

    @property
    def records(self) -> list[Evaluation]:
        """Every told evaluation, in the order told (a copy)."""
        return list(self._records)

    def _engine(self, exploit: bool, batch: int) -> BayesianOptimizer:
        """The optimizer proposing a batch of ``batch`` designs; exploiting: the minimum of
        the kriging mean (LCB at ``v = 0``), as ``hypate.minimize``'s refine steps."""
        key = (exploit, batch)
        if key not in self._engines:
            s = dataclasses.replace(self.settings, batch_size=batch)
            if exploit:
                s = dataclasses.replace(s, acquisition="lcb", v=0.0,
                                        n_iter=self.budget.n_iter + self.budget.refine)
            self._engines[key] = BayesianOptimizer(self.problem, s)
        return self._engines[key]

    def _proposal(self, ask: dict[str, Any]) -> np.ndarray:
        """The designs of one recorded proposal, from the evaluations it was made from."""
        t = int(ask["iteration"])
        if t not in self._proposals:
            engine = self._engine(bool(ask["exploit"]), int(ask["size"]))
            with blas_threads(self.context.blas_threads):
                self._proposals[t] = engine.propose(self._records[: int(ask["records"])], t)
        return self._proposals[t]

    def _design(self, slot: tuple[int, int]) -> np.ndarray:
        """The design of an asked slot (recomputed for a proposal)."""
        t, b = slot
        if t == 0:
            return self._initial[b]
        ask = next(a for a in self._asks if a.get("iteration") == t)
        return self._proposal(ask)[b]

    # -------------------------------------------------------------------- ask
    def ask(self, n: int = 1) -> np.ndarray:
        """The next ``n`` designs to evaluate.

        The rest of the initial design first, then designs proposed together by the
        acquisition from the evaluations told so far (one proposal of a batch of the
        remaining number). After a restart on a store, the designs asked before and never
        told come back first, and alone (module docstring): their results must be told
        before anything new is proposed, as in the uninterrupted loop.

        Parameters
        ----------
        n : int >= 1

        Returns
        -------
        ndarray of shape (n, d)
            Fewer rows only when designs asked before a restart come back.

        Raises
        ------
        ValueError
            ``n`` not a positive integer.
        RuntimeError
            New designs must be proposed while designs of an earlier proposal are not told
            yet: the proposal would not know them (tell them first, NaN for a failure; for
            evaluations in parallel ask for the whole batch at once).
        """
        n = _count("n", n, 1)
        if self._unanswered:
            slots = self._unanswered[:n]
            del self._unanswered[:n]
            return self._hand_out(slots)
        next_initial = 1 + max((int(s[1]) for a in self._asks for s in a["slots"]
                                if s[0] == 0), default=-1)
        slots = [(0, i) for i in range(next_initial, min(next_initial + n, self.budget.n_init))]
        left = n - len(slots)
        if left and any(s[0] >= 1 for s in self._pending):
            waiting = sorted(s for s in self._pending if s[0] >= 1)
            raise RuntimeError(f"ask: {len(waiting)} proposed design(s) not told yet "
                               f"(slots {waiting}); tell them first (NaN for a failed "
                               "evaluation), or ask for the whole batch at once")
        new_asks: list[dict[str, Any]] = []
        if slots:
            new_asks.append({"slots": [list(s) for s in slots]})
        if left:
            t = 1 + max((int(a["iteration"]) for a in self._asks if a.get("iteration")),
                        default=0)
            asked = self.budget.n_init + sum(int(a["size"]) for a in self._asks
                                             if a.get("iteration"))
            exploit = (self.n_evaluations is not None and self.budget.refine > 0
                       and asked >= self.n_evaluations - self.budget.refine)
            new_asks.append({"slots": [[t, b] for b in range(left)], "iteration": t,
                             "size": left, "records": len(self._records),
                             "exploit": exploit})
            slots += [(t, b) for b in range(left)]
        # recorded before the designs are handed out (module docstring)
        self._asks += new_asks
        self.store.set_meta(ASKS, self._asks, replace=True)
        return self._hand_out(slots)

    def _hand_out(self, slots: list[tuple[int, int]]) -> np.ndarray:
        """The designs of ``slots``, noted as pending."""
        X = np.array([self._design(s) for s in slots], dtype=float)
        now = time.perf_counter()
        for s, x in zip(slots, X):
            self._pending[s] = (x, now)
        return X.reshape(len(slots), self.problem.n_var)

    # ------------------------------------------------------------------- tell
    def _match(self, x: np.ndarray, span: np.ndarray) -> tuple[int, int] | None:
        """The asked slot whose design ``x`` is (None: a design of the caller's own)."""
        for slot, (y, _) in self._pending.items():
            if np.max(np.abs(x - y) / span) <= MATCH_TOL:
                return slot
        for slot in self._unanswered:
            if np.max(np.abs(x - self._design(slot)) / span) <= MATCH_TOL:
                return slot
        return None

    def tell(self, X: np.ndarray, Y: np.ndarray, G: np.ndarray | None = None) -> None:
        """Store the results of evaluated designs (each committed before the next).

        Parameters
        ----------
        X : ndarray of shape (n, d), or (d,) for one design
            The designs evaluated: asked ones, or designs of the caller's own (stored as
            iteration -1, and used like any other).
        Y : ndarray of shape (n, n_objectives); (n,) for one objective
            Their objectives. A row of NaN is a failed evaluation (stored with status
            ``"error"``; the engine models where evaluations fail and steers away); any
            other non-finite value makes the row ``"invalid"``.
        G : ndarray of shape (n, n_constraints); (n,) for one constraint
            Their expensive constraints, feasible where ``G <= 0`` (required when
            ``n_constraints > 0``, refused otherwise).

        Raises
        ------
        ValueError
            A shape that does not fit, or a design outside the bounds (the message names
            the argument).
        """
        d, m, k = self.problem.n_var, self.problem.n_obj, self.problem.n_ieq_constr
        Xa = np.asarray(X, dtype=float)
        Xa = Xa.reshape(1, d) if Xa.shape == (d,) else Xa
        if Xa.ndim != 2 or Xa.shape[1] != d:
            raise ValueError(f"X: must have shape (n, {d}) or ({d},); got {np.shape(X)}")
        n = len(Xa)
        Ya = self._rows("Y", Y, n, m)
        if k == 0 and G is not None:
            raise ValueError("G: this optimizer has n_constraints = 0")
        if k and G is None:
            raise ValueError(f"G: the {k} constraint value(s) of every design are needed")
        Ga = self._rows("G", G, n, k) if k else np.zeros((n, 0))
        lo, hi = self.optimizer.bounds[:, 0], self.optimizer.bounds[:, 1]
        span = hi - lo
        outside = np.flatnonzero(np.any((Xa < lo - MATCH_TOL * span)
                                        | (Xa > hi + MATCH_TOL * span), axis=1))
        if outside.size:
            raise ValueError(f"X: row(s) {outside.tolist()} lie outside the bounds")
        now = time.perf_counter()
        for x, f, g in zip(Xa, Ya, Ga):
            slot = self._match(x, span)
            if slot is None:
                slot = (-1, sum(r.iteration == -1 for r in self._records))
                seconds = 0.0
            elif slot in self._pending:
                seconds = now - self._pending.pop(slot)[1]
            else:
                self._unanswered.remove(slot)
                seconds = 0.0
            values = np.r_[f, g]
            if np.all(np.isfinite(values)):
                status, message = STATUS_OK, ""
            elif np.all(np.isnan(f)):
                status, message = "error", FAILED_MESSAGE
            else:
                status, message = "invalid", "non-finite objective or constraint"
            ev = Evaluation(x=x, F=f, G=g, status=status, message=message, seconds=seconds,
                            iteration=slot[0], batch_index=slot[1], seed=self.seed)
            self.store.append(ev)
            self._records.append(ev)

    @staticmethod
    def _rows(arg: str, values: Any, n: int, width: int) -> np.ndarray:
        a = np.asarray(values, dtype=float)
        if width == 1 and a.shape in ((n,), ()) and a.size == n:
            a = a.reshape(n, 1)
        elif n == 1 and a.shape == (width,):
            a = a.reshape(1, width)
        if a.shape != (n, width):
            raise ValueError(f"{arg}: must have shape ({n}, {width})"
                             + (f" or ({n},)" if width == 1 else "") + f"; got {a.shape}")
        return a

    # ----------------------------------------------------------------- results
    def history(self) -> OptimizationResult:
        """Every told evaluation as the engine's result (Pareto set, hypervolume, ...)."""
        return OptimizationResult(data=evaluations_to_dataframe(self._records),
                                  n_var=self.problem.n_var, n_obj=self.problem.n_obj)

    @property
    def evaluations(self) -> pd.DataFrame:
        """Every told evaluation, one row each: the variables, objectives and constraints by
        name, ``iteration``, ``batch_index``, ``status``, ``message``, ``seconds`` (from ask
        to tell in this process; 0 for a design not asked here), ``seed``."""
        return self.history().named_data(self.names, self.objective_names,
                                         self.constraint_names)

    def close(self) -> None:
        """Close the store (if this object opened it)."""
        if self._owned:
            self.store.close()

    def __enter__(self) -> AskTellOptimizer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
