"""Bayesian optimization loop (Sec. 6.3.1, updating approach) for any pymoo Problem.

Direct approach: the weighted metric ``S_g`` (Eq. (6.11); ``g = 1`` weighted sum,
``g = inf`` Chebyshev) of the objectives' confidence bounds. Indirect approach: hypervolume
acquisitions (HVLCB, HVEI, HVPoI; Eqs. (6.25)-(6.28)) producing a Pareto set.
Single-objective problems use PoI, EI or LCB (Eqs. (6.14)-(6.22)).

Each iteration (Sec. 6.3.1 step 4):

1. fit kriging surrogates of the objectives (or of the histories they are composed from,
   ``surrogate = "histories"``, :mod:`hypate.scaling.engine.histories`) on the successful
   evaluations, of the expensive constraints (``G <= 0``) and, if any evaluation failed,
   a classifier of success;
2. maximize the acquisition by :func:`hypate.scaling.engine.inner.optimize_acquisition`: raw
   optimal-Latin-hypercube points, the best ``n_starts`` polished by SLSQP with gradients, the
   cheap constraints enforced exactly and the surrogate constraints
   (:class:`hypate.scaling.engine.surrogate.ProbabilisticConstraint`: predicted probability of
   feasibility of each expensive constraint ``>= p_feasible``) and, if any evaluation
   failed, the predicted probability of success of a Gaussian-process classifier
   ``>= p_success`` (:class:`~hypate.scaling.engine.failures.SuccessModel`) as SLSQP
   inequalities;
3. for batches ``q > 1`` repeat 2 on a fantasized model (kriging believer: the predicted
   mean is appended as if observed; constant liar: the best value so far);
4. evaluate the batch through a ``concurrent.futures``-style executor (anything with
   ``submit(fn, *args)`` returning futures with ``.result(timeout)``: a
   ``ProcessPoolExecutor`` or a ``dask.distributed.Client``) or in-process, and commit
   each finished evaluation to the store before the next proposal. Infrastructure faults
   are re-submitted, not stored (:func:`hypate.scaling.engine.executors.run_batch`); a lost
   pool or cluster ends the run with
   :class:`~hypate.scaling.engine.faults.InfrastructureError`.

With an executor, steps 1 and 2 borrow its workers: the columns' likelihood optimizations
and the SLSQP starts are spread over this process and the pool
(:class:`hypate.scaling.engine.sharing.WorkerMap`), with the serial results bit for bit.

Options: the algorithm's :class:`~hypate.scaling.engine.settings.OptimizerSettings` and the
run's :class:`~hypate.scaling.engine.settings.RunContext`; acquisitions by name from
:data:`~hypate.scaling.engine.acquisition.ACQUISITIONS`; evaluations are
:class:`~hypate.scaling.engine.problem.Outcome` records committed as ``Evaluation`` rows.

The pieces that stand alone have their own modules: inner (the acquisition's SLSQP
multistart), acquisition, executors, sharing (the workers' hand in a proposal), mixed (the
per-level proposal of a categorical variable), polish (the final local search) and
check (the leave-one-out check of the final surrogates).

Reproducibility: the random numbers of iteration ``t`` come from
``numpy.random.default_rng([seed, t])`` and a proposal depends only on the evaluations of
earlier iterations, so a resumed run proposes exactly what the uninterrupted run proposed.

Size: about 700 lines (issue 42's limit): the loop, the proposal (one method with its batch
and exploitation rules) and the surrogate plumbing; the next addition moves a piece out
(e.g. the classic convergence rule ``_converged`` next to the stopping rule).
"""
from __future__ import annotations

import dataclasses
import time
import warnings
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np
from hypate.scaling.engine.acquisition import (
    ACQUISITIONS,
    MULTI_OBJECTIVE_ACQUISITIONS,
    SINGLE_OBJECTIVE_ACQUISITIONS,
    Acquisition,
    AcquisitionContext,
    AcquisitionFactory,
    MinMaxEI,
    MinMaxLCB,
    default_acquisition,
)
from hypate.scaling.engine.check import SurrogateCheck, leave_one_out_check
from hypate.scaling.engine.coordinates import LogLinearCoordinates, WarpedModel
from hypate.scaling.engine.executors import run_batch
from hypate.scaling.engine.failures import SuccessModel
from hypate.scaling.engine.histories import (
    HISTORIES,
    SAMPLES,
    HistoriesModel,
    HistoryBasis,
    normal_samples,
)
from hypate.scaling.engine.inner import Resolution, optimize_acquisition, surrogate_metric
from hypate.scaling.engine.mixed import MixedCoordinates, propose_by_level
from hypate.scaling.engine.pareto import hypervolume, non_dominated_mask, pareto_front
from hypate.scaling.engine.polish import polish_best, polish_composition
from hypate.scaling.engine.problem import (
    Outcome,
    evaluate_design,
    project_unit,
    scipy_constraints,
)
from hypate.scaling.engine.result import OptimizationResult
from hypate.scaling.engine.settings import OptimizerSettings, RunContext, SettingError
from hypate.scaling.engine.sharing import WorkerMap
from hypate.scaling.engine.stopping import Stopping, check
from hypate.scaling.engine.store import (
    Evaluation,
    EvaluationStore,
    evaluations_to_dataframe,
)
from hypate.scaling.engine.surrogate import ProbabilisticConstraint, surrogate_regressor
from hypate.solvers.numerics.kriging import fit_together
from hypate.solvers.numerics.random import latin_hypercube, raw_latin_hypercube
from hypate.solvers.numerics.threads import blas_threads

__all__ = ["BayesianOptimizer", "SurrogateCheck"]

#: Smallest objective value of the log transform (ln 1e-12 = -27.6).
LOG_FLOOR = 1e-12
#: The random stream of the stopping rule's candidates (apart from the proposal's).
STOP_STREAM = 7


# --------------------------------------------------------------------- optimizer
class BayesianOptimizer:
    """Surrogate-based (Bayesian) optimization of a pymoo Problem, Sec. 6.3.

    Parameters
    ----------
    problem : pymoo.core.problem.Problem
        Objectives minimized, constraints ``G <= 0`` (equalities ``H`` become
        ``|H| - eq_tol <= 0``); finite bounds ``xl``, ``xu``.
    settings : OptimizerSettings or None
        The algorithm's options (``None``: the defaults).
    context : RunContext or None
        Where the evaluations run and go: executor, time limit, store, callback, BLAS
        threads (``None``: in-process, in memory).
    **overrides
        Fields of :class:`OptimizerSettings` or :class:`RunContext` replacing those of
        ``settings`` / ``context`` (``BayesianOptimizer(problem, n_init=8, store="r.sqlite")``).

    Raises
    ------
    SettingError
        A setting outside its range, or one that does not fit the problem.
    TypeError
        An override that is a field of neither.
    """

    def __init__(self, problem: Any, settings: OptimizerSettings | None = None,
                 context: RunContext | None = None, **overrides: Any) -> None:
        own, where = set(OptimizerSettings.names()), set(RunContext.names())
        if unknown := sorted(set(overrides) - own - where):
            raise TypeError(f"unknown optimizer setting(s) {unknown}: the settings are the "
                            "fields of OptimizerSettings and RunContext")
        self.settings = dataclasses.replace(settings or OptimizerSettings(),
                                            **{k: v for k, v in overrides.items() if k in own})
        self.context = dataclasses.replace(context or RunContext(),
                                           **{k: v for k, v in overrides.items() if k in where})
        self.problem = problem
        self.n_var = int(problem.n_var)
        self.n_obj = int(problem.n_obj)
        self.n_constr = int(problem.n_ieq_constr) + int(problem.n_eq_constr)
        self.bounds = np.c_[np.asarray(problem.xl, float), np.asarray(problem.xu, float)]
        if self.bounds.shape != (self.n_var, 2) or not np.all(np.isfinite(self.bounds)):
            raise ValueError("problem needs finite bounds xl, xu of length n_var")
        self._check_fit(self.settings)
        s = self.settings
        if s.acquisition is None:
            self.acquisition: str | AcquisitionFactory = default_acquisition(self.n_obj)
        else:
            self.acquisition = s.acquisition
        self.ref_point = None if s.ref_point is None else np.asarray(s.ref_point, dtype=float)
        #: Why the run ended (``settings.stopping``): updated at every check of the rule.
        self.stopping = Stopping(rule=None if s.stopping is None
                                 else dataclasses.asdict(s.stopping))
        #: How the objectives compose from the histories (None: model the objectives).
        self.composition = None
        if s.surrogate == "histories":
            compose = getattr(problem, "composition", None)
            self.composition = compose() if callable(compose) else None
        self.polish_composition = polish_composition(s, problem, self.composition)
        self.weights = (np.full(self.n_obj, 1.0 / self.n_obj) if s.weights is None
                        else np.asarray(s.weights, dtype=float))

    def _check_fit(self, s: OptimizerSettings) -> None:
        """The settings that depend on the problem: acquisition, vector lengths, bounds."""
        if isinstance(s.acquisition, str):
            valid = (SINGLE_OBJECTIVE_ACQUISITIONS if self.n_obj == 1
                     else MULTI_OBJECTIVE_ACQUISITIONS)
            if s.acquisition not in valid:
                raise SettingError("acquisition", f"for {self.n_obj} objective(s) one of "
                                   f"{valid}", s.acquisition)
        for name in ("ref_point", "weights"):
            vec = getattr(s, name)
            if vec is not None and len(vec) != self.n_obj:
                raise SettingError(name, f"{self.n_obj} numbers (one per objective)", vec)
        cat = s.categorical
        n_cont = self.n_var if cat is None else self.n_var - len(cat.indices)
        if cat is not None:
            if (bad := cat.problem_mismatch(self.bounds)) is not None:
                raise SettingError("categorical", *bad)
            if s.polish:
                raise SettingError("polish", "0 with a categorical variable", s.polish)
        if s.coordinates is not None:
            if s.coordinates.matrix.shape != (n_cont, n_cont):
                raise SettingError("coordinates", f"a {n_cont} x {n_cont} matrix (the "
                                   "continuous variables)", s.coordinates.matrix.shape)
            cont = (self.bounds if cat is None
                    else np.delete(self.bounds, list(cat.indices), axis=0))
            if not np.all(cont > 0.0):
                raise ValueError("log-linear coordinates need positive bounds xl, xu")

    # -------------------------------------------------------------- helpers
    def _rng(self, iteration: int) -> np.random.Generator:
        """Random numbers of one iteration, from ``(seed, iteration)`` (resume-safe)."""
        return np.random.default_rng([self.settings.seed, iteration + 1])

    def _arrays(self, records: list[Evaluation]):
        n = len(records)
        X = np.array([r.x for r in records], dtype=float).reshape(n, self.n_var)
        F = np.array([r.F for r in records], dtype=float).reshape(n, self.n_obj)
        G = np.array([r.G for r in records], dtype=float).reshape(n, self.n_constr)
        ok = np.array([r.ok for r in records], dtype=bool)
        feas = ok & np.all(G <= 0.0, axis=1)
        return X, F, G, ok, feas

    def initial_design(self) -> np.ndarray:
        """The iteration-0 OLH design (projected onto the cheap constraints)."""
        X = latin_hypercube(self.settings.n_init, self.bounds, self._rng(0))
        cat = self.settings.categorical
        if cat is not None and len(X):  # the LHS columns' strata become balanced levels
            X = cat.stratified(X)
        if self.settings.cheap_constraints and len(X):
            lo, span = self.bounds[:, 0], self.bounds[:, 1] - self.bounds[:, 0]
            cons = scipy_constraints(self.settings.cheap_constraints, lo, span)
            X = np.array([lo + project_unit((x - lo) / span, cons) * span for x in X])
            if cat is not None:
                X = cat.snap(X)
        return X

    def surrogate(self, X: np.ndarray, Y: np.ndarray,
                  rng: np.random.Generator | int | None = None, **kw: Any):
        """The surrogate the optimizer fits to data ``Y(X)``: kriging in its input
        coordinates (``settings.coordinates``, e.g. similarity parameters), queried in ``x``.

        Parameters
        ----------
        X : ndarray of shape (n, d)
            Designs.
        Y : ndarray of shape (n, m)
            Values (objectives as the surrogates see them, constraints, ...).
        rng : numpy.random.Generator, int or None
            Random restarts of the likelihood optimization.
        **kw
            Further options of :func:`hypate.scaling.engine.surrogate.fit_surrogate`
            (``nugget``, ``length_scale_bounds``).

        Returns
        -------
        KrigingRegressor or WarpedModel
            Fitted, with ``predict_moments``, ``predict_with_gradients`` and ``condition``.
        """
        return self.surrogates([(X, Y, kw)], rng)[0]

    def surrogates(self, data: Sequence[tuple[np.ndarray, np.ndarray, dict[str, Any]]],
                   rng: np.random.Generator | int | None = None) -> list:
        """:meth:`surrogate` of each ``(X, Y, options)``, in order, with all their columns'
        likelihood optimizations spread over the run's workers (:attr:`worker_map`): the
        same models as one :meth:`surrogate` call after another."""
        s = self.settings
        coords: LogLinearCoordinates | MixedCoordinates | None = s.coordinates
        if s.categorical is not None:
            coords = MixedCoordinates(s.categorical, self.n_var, s.coordinates)
        box = self.bounds if coords is None else coords.box(self.bounds)
        jobs = [(surrogate_regressor(box, kernel=s.kernel, n_restarts=s.n_restarts, rng=rng,
                                     **kw),
                 X if coords is None else coords(X), np.asarray(Y, float).reshape(len(Y), -1))
                for X, Y, kw in data]
        fitted = fit_together(jobs, self.worker_map)
        return fitted if coords is None else [WarpedModel(gp, coords) for gp in fitted]

    @property
    def worker_map(self) -> WorkerMap | None:
        """The run's executor lent to the proposal's independent pieces (None: in-process,
        ``--workers 1``)."""
        ex = self.context.executor
        return None if ex is None else WorkerMap(ex, blas=self.context.blas_threads)

    def resolution(self, model: Any) -> Resolution | None:
        """The objective surrogates' metric (:func:`~hypate.scaling.engine.inner.
        surrogate_metric`); None when ``settings.resolution`` is 0 or a variable is
        categorical (a level indicator has no inward direction)."""
        radius = self.settings.resolution
        if radius <= 0.0 or self.settings.categorical is not None:
            return None
        return surrogate_metric(model, radius, self.n_var)

    def _model_space(self, F: np.ndarray) -> np.ndarray:
        """Objective values as the surrogates see them (:attr:`output_transform`)."""
        if self.settings.output_transform == "log":
            with np.errstate(invalid="ignore"):
                return np.log(np.maximum(F, LOG_FLOOR))
        return F

    def leave_one_out(self, result: OptimizationResult, row: int) -> SurrogateCheck:
        """The final surrogates' leave-one-out prediction of evaluation ``row`` of
        ``result`` (:func:`hypate.scaling.engine.check.leave_one_out_check`; the surrogates
        as the optimizer fits them, with the random numbers of iteration ``n_iter + 1``)."""
        def fit(X: np.ndarray, F: np.ndarray) -> Any:
            return self.surrogate(X, F, self._rng(self.settings.n_iter + 1))

        return leave_one_out_check(result, row, fit, self._model_space,
                                   self.settings.output_transform)

    def _reference_point(self, F_feas: np.ndarray) -> np.ndarray | None:
        if self.ref_point is not None:
            return self._model_space(self.ref_point)
        if len(F_feas) == 0:
            return None
        P = pareto_front(F_feas)
        ideal, nadir = P.min(axis=0), P.max(axis=0)
        return nadir + 0.1 * np.where(nadir > ideal, nadir - ideal, np.maximum(abs(nadir), 1.0))

    def exploration_weight(self, iteration: int) -> float | None:
        """``v`` of iteration ``t``: ``settings.v`` (``None``: the acquisition's default), or
        with ``settings.v_final`` the linear fall from it at ``t = 1`` to ``v_final`` at
        ``t = n_iter`` (``"auto"``: the acquisition's ``default_v_final``). An acquisition
        without a weight (PoI) or without a known start (a user's factory and ``v`` unset)
        keeps ``settings.v``."""
        s = self.settings
        cls = ACQUISITIONS[self.acquisition] if isinstance(self.acquisition, str) else None
        v_final = getattr(cls, "default_v_final", None) if s.v_final == "auto" else s.v_final
        v0 = s.v if s.v is not None else getattr(cls, "default_v", None)
        if v_final is None or v0 is None:
            return s.v
        frac = min(max((iteration - 1) / max(s.n_iter - 1, 1), 0.0), 1.0)
        return v0 + (v_final - v0) * frac

    def _build_acquisition(self, model, F_obs: np.ndarray, feas: np.ndarray, F_ok: np.ndarray,
                           rng: np.random.Generator, iteration: int = 1) -> Acquisition:
        F_feas = F_obs[feas]
        base = F_feas if len(F_feas) else F_ok
        best_f = float(base[:, 0].min()) if len(base) else 0.0
        ideal = base.min(axis=0) if len(base) else np.zeros(self.n_obj)
        nadir = base.max(axis=0) if len(base) else np.ones(self.n_obj)
        scale = np.where(nadir > ideal, nadir - ideal, 1.0)
        ref = self._reference_point(base)
        front = pareto_front(F_feas) if len(F_feas) else np.zeros((0, self.n_obj))
        if ref is None:
            ref = nadir + scale
        ctx = AcquisitionContext(best_f, front, ref, ideal, scale, rng,
                                 v=self.exploration_weight(iteration),
                                 weights=self.weights, g=self.settings.g)
        if self.exploiting(iteration) and self.n_obj > 1:
            # the last iterations: the surrogates' best design point, no exploration
            return MinMaxLCB.from_context(model, dataclasses.replace(ctx, v=0.0))
        if callable(self.acquisition):
            return self.acquisition(model, ctx)
        return ACQUISITIONS[self.acquisition].from_context(model, ctx)

    def exploiting(self, iteration: int) -> bool:
        """Whether iteration ``t`` is one of the last ``settings.exploit_last``: it proposes
        the design the surrogates predict best by the design-point criterion (the mean of
        ``max_j J_j``, :class:`~hypate.scaling.engine.acquisition.MinMaxLCB` at ``v = 0``),
        with every enforced constraint and the success of its simulation required at
        probability ``settings.p_exploit``: the design a test engineer would build, checked
        on the simulator."""
        s = self.settings
        return s.exploit_last > 0 and iteration > s.n_iter - s.exploit_last

    # ------------------------------------------------------------ proposal
    def propose(self, records: list[Evaluation], iteration: int) -> np.ndarray:
        """The ``batch_size`` designs of one iteration from the evaluations so far.

        Parameters
        ----------
        records : list of Evaluation
            Every evaluation of earlier iterations.
        iteration : int
            ``t >= 1`` (seeds the iteration's random numbers).

        Returns
        -------
        ndarray of shape (batch_size, d)
        """
        st = self.settings
        rng = self._rng(iteration)
        X, F, G, ok, feas = self._arrays(records)
        F = self._model_space(F)
        if ok.sum() < 2:
            # nothing to model: explore with an OLH point far from the samples
            U = latin_hypercube(st.batch_size, self.bounds, rng)
            return U if st.categorical is None else st.categorical.snap(U)
        # objectives (or their histories), expensive constraints, failure indicator:
        # fitted together
        objectives, histories = self.objective_data(records, X, F, ok)
        data = [objectives]
        if self.n_constr:
            data.append((X[ok], G[ok], {}))
        fitted, *others = self.surrogates(data, rng)
        model = self.objective_model(fitted, histories, X[ok], rng)
        model_constraints: list[Any] = []
        safe = self.exploiting(iteration)
        if self.n_constr:
            model_constraints.append(ProbabilisticConstraint(
                others.pop(0), p_min=max(st.p_feasible, st.p_exploit) if safe else st.p_feasible))
        if not np.all(ok):  # the failed evaluations' region: a calibrated classifier
            model_constraints.append(self.success_model(
                X, ok, rng, max(st.p_success, st.p_exploit) if safe else st.p_success))
        if st.stopping is not None and self.n_obj > 1 and self._stops(model, records, X, F, ok,
                                                                      feas, iteration):
            return np.zeros((0, self.n_var))  # converged: no more designs
        # exploitation starts: the best feasible designs (nudged off the data points)
        F_good = np.where(feas[:, None], F, np.inf)
        if self.n_obj == 1:
            best_idx = np.argsort(F_good[:, 0], kind="stable")[:3]
        else:
            idx = np.flatnonzero(feas)
            best_idx = idx[non_dominated_mask(F[idx])] if len(idx) else idx
            best_idx = best_idx[rng.permutation(len(best_idx))[:5]]
        span = self.bounds[:, 1] - self.bounds[:, 0]
        resolution = self.resolution(model)
        X_obs, F_obs, feas_obs = X[ok], F[ok], feas[ok]
        pending: list[np.ndarray] = []
        cur_model = model
        workers = self.worker_map
        for b in range(st.batch_size):
            # the acquisition first: a Monte Carlo HVEI draws its base samples from rng
            acq = (self._build_acquisition(cur_model, F_obs, feas_obs, F[ok], rng, iteration)
                   if st.categorical is None else None)
            extra = X[best_idx] + 1e-3 * span * rng.standard_normal((len(best_idx), self.n_var))
            X_avoid = np.vstack([X] + [p[None] for p in pending])
            try:
                if acq is not None:
                    x, _ = optimize_acquisition(
                        acq, self.bounds, n_raw=st.n_raw, n_starts=st.n_starts,
                        cheap_constraints=st.cheap_constraints,
                        model_constraints=model_constraints, X_avoid=X_avoid,
                        min_distance=st.min_distance, extra_starts=extra, rng=rng,
                        resolution=resolution, mapper=workers)
                else:
                    assert st.categorical is not None  # no acquisition: a categorical one
                    x = propose_by_level(
                        st.categorical, cur_model, model_constraints, self.bounds,
                        lambda m: self._build_acquisition(m, F_obs, feas_obs, F[ok], rng,  # noqa: B023 - called within this iteration
                                                          iteration),
                        X_avoid, extra, rng, n_raw=st.n_raw, n_starts=st.n_starts,
                        cheap_constraints=st.cheap_constraints, min_distance=st.min_distance)
            except RuntimeError as exc:
                # every start infeasible or already sampled: fall back to a fresh OLH point
                warnings.warn(f"iteration {iteration}: {exc}; proposing a space-filling point",
                              RuntimeWarning, stacklevel=2)
                x = self._fallback_point(X_avoid, rng)
            pending.append(x)
            if b + 1 < st.batch_size:
                if st.batch_strategy == "believer":
                    y_f = cur_model.predict_moments(x[None])[0][0]
                else:
                    base = F_obs[feas_obs] if feas_obs.any() else F_obs
                    y_f = base.min(axis=0)
                X_obs = np.vstack([X_obs, x])
                F_obs = np.vstack([F_obs, y_f])
                feas_obs = np.r_[feas_obs, True]
                cur_model = model.condition(X_obs, F_obs)
        return np.array(pending)

    def _stops(self, model: Any, records: list[Evaluation], X: np.ndarray, F: np.ndarray,
               ok: np.ndarray, feas: np.ndarray, iteration: int) -> bool:
        """The stopping rule of ``iterations = "auto"`` (:mod:`hypate.scaling.engine.stopping`)
        with the surrogates just fitted; the evidence is kept in :attr:`stopping`."""
        rule = self.settings.stopping
        assert rule is not None  # checked only with a stopping rule (propose)
        if iteration <= rule.min_iterations:
            return False
        it = np.array([r.iteration for r in records])[ok]
        Fo, fe = F[ok], feas[ok]
        c = np.where(fe, np.max(Fo, axis=1), np.inf)
        best = int(np.argmin(c)) if np.isfinite(c).any() else None
        try:
            loo = model.leave_one_out()
        except (AttributeError, np.linalg.LinAlgError):
            loo = None
        gain = np.inf
        if best is not None:
            here = np.random.default_rng([self.settings.seed, iteration, STOP_STREAM])
            lo, span = self.bounds[:, 0], self.bounds[:, 1] - self.bounds[:, 0]
            cand = np.vstack([lo + here.random((self.settings.n_raw, self.n_var)) * span,
                              X[ok][fe]])
            if self.settings.categorical is not None:
                cand = self.settings.categorical.snap(cand)
            gain = float(np.max(MinMaxEI(model, float(c[best]), rng=here)(cand)))
        stop, evidence = check(rule, iteration, Fo, fe, it, loo, best, gain)
        self.stopping = Stopping("converged" if stop else "cap", iteration if stop else None,
                                 evidence, dataclasses.asdict(rule))
        return stop

    def success_model(self, X: np.ndarray, ok: np.ndarray, rng: np.random.Generator,
                      p_min: float | None = None) -> SuccessModel:
        """The probability of success of a proposal (:class:`SuccessModel`, a Gaussian-
        process classifier on the surrogates' input coordinates), required to reach
        ``p_min`` (default ``settings.p_success``)."""
        s = self.settings
        coords: LogLinearCoordinates | MixedCoordinates | None = s.coordinates
        if s.categorical is not None:
            coords = MixedCoordinates(s.categorical, self.n_var, s.coordinates)
        return SuccessModel(X, ok, self.bounds, transform=coords,
                            box=None if coords is None else coords.box(self.bounds),
                            p_min=s.p_success if p_min is None else p_min,
                            rng=int(rng.integers(2**31)))

    def objective_data(self, records: Sequence[Evaluation], X: np.ndarray, F: np.ndarray,
                       ok: np.ndarray) -> tuple[tuple[np.ndarray, np.ndarray, dict],
                                                tuple[HistoryBasis, np.ndarray] | None]:
        """What the objective surrogate is fitted to: ``(X_ok, Y, options)`` -- the
        objectives (model space) or, with ``surrogate = "histories"``, the POD coefficients of
        the histories -- and the histories' basis and coefficients (None: objectives)."""
        histories = self._histories(list(records), ok)
        return (X[ok], F[ok] if histories is None else histories[1], {}), histories

    def objective_model(self, fitted: Any, histories: tuple[HistoryBasis, np.ndarray] | None,
                        X_ok: np.ndarray, rng: np.random.Generator) -> Any:
        """The objective model from the fitted surrogate of :meth:`objective_data`: itself,
        or the :class:`HistoriesModel` composing J from the coefficients' surrogate (its base
        samples drawn from ``rng``)."""
        if histories is None:
            return fitted
        assert self.composition is not None  # histories are fitted only with it
        basis, A = histories
        return HistoriesModel(fitted, basis, self.composition, self.settings.output_transform,
                              normal_samples(SAMPLES, A.shape[1], int(rng.integers(2**31))),
                              X_ok, A)

    def _histories(self, records: list[Evaluation], ok: np.ndarray
                   ) -> tuple[HistoryBasis, np.ndarray] | None:
        """The POD basis of the successful evaluations' histories and their coefficients
        (``surrogate = "histories"``); None to model the objectives (no composition, or
        an evaluation without its histories)."""
        if self.composition is None:
            return None
        rows = [r.aux.get(HISTORIES) for r, good in zip(records, ok) if good]
        if any(h is None for h in rows):
            return None
        H = np.asarray(rows, dtype=float)
        if H.ndim != 2 or H.shape[1] != self.composition.targets.size or \
                not np.all(np.isfinite(H)):
            return None
        basis = HistoryBasis.fit(H, self.composition)
        return basis, basis.coefficients(H, self.composition)

    def _fallback_point(self, X_avoid: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """The OLH point farthest from the samples, projected onto the cheap constraints."""
        lo, span = self.bounds[:, 0], self.bounds[:, 1] - self.bounds[:, 0]
        unit_box = np.c_[np.zeros(self.n_var), np.ones(self.n_var)]
        U = raw_latin_hypercube(self.settings.n_raw, unit_box, rng)
        U_avoid = (X_avoid - lo) / span
        dist = np.min(np.linalg.norm(U[:, None] - U_avoid[None], axis=2), axis=1)
        u = U[int(np.argmax(dist))]
        if self.settings.cheap_constraints:
            u = project_unit(u, scipy_constraints(self.settings.cheap_constraints, lo, span))
        x = lo + u * span
        cat = self.settings.categorical
        return x if cat is None else cat.snap(x)[0]

    # ----------------------------------------------------------- evaluation
    def _evaluate(self, X: np.ndarray, iteration: int, indices: Sequence[int],
                  store: EvaluationStore, records: list[Evaluation]) -> None:
        """Evaluate designs, committing each result (in batch order) before going on.

        Through :func:`hypate.scaling.engine.executors.run_batch`: an infrastructure fault
        (a lost worker or scheduler, a broken pool) is not a result, the evaluation is
        re-submitted; a design that killed its worker alone
        :data:`~hypate.scaling.engine.faults.SOLO_DEATHS` times is stored as a failure.

        Raises
        ------
        InfrastructureError
            The pool or cluster is gone. The results finished before are committed; no row
            is stored for the unfinished designs, so that a resumed run evaluates exactly
            those and ends with the campaign of an uninterrupted one.
        """
        timeout = self.context.timeout
        calls = [(self.problem, x, timeout) for x in X]

        def failure(message: str, seconds: float) -> Outcome:
            return Outcome.failure(self.n_obj, self.n_constr, "error", message, seconds)

        for k, outcome in run_batch(self.context.executor, evaluate_design, calls,
                                    on_failure=failure):
            self._record(X[k], outcome, iteration, indices[k], store, records)

    def _record(self, x: np.ndarray, outcome: Outcome, iteration: int, index: int,
                store: EvaluationStore, records: list[Evaluation]) -> None:
        """Commit one evaluation to the store, then tell the callback."""
        ev = Evaluation.from_outcome(x, outcome, iteration=iteration, batch_index=index,
                                     seed=self.settings.seed)
        store.append(ev)
        records.append(ev)
        if self.context.callback is not None:
            self.context.callback(ev)

    # ------------------------------------------------------------------ run
    def _open_store(self) -> tuple[EvaluationStore, bool]:
        store = self.context.store
        if isinstance(store, EvaluationStore):
            return store, False
        return EvaluationStore(":memory:" if store is None else store), True

    def _budget_left(self, records: list[Evaluation]) -> int:
        if self.settings.max_evaluations is None:
            return 1 << 60
        return self.settings.max_evaluations - sum(r.iteration >= 0 for r in records)

    def _converged(self, records: list[Evaluation], iteration: int) -> bool:
        if self.settings.convergence_tol is None or iteration <= self.settings.convergence_window:
            return False
        X, F, G, ok, feas = self._arrays(records)
        it = np.array([r.iteration for r in records])
        before = it < iteration - self.settings.convergence_window
        if self.n_obj == 1:
            now = F[feas, 0].min(initial=np.inf)
            old = F[feas & before, 0].min(initial=np.inf)
            if not np.isfinite(old):
                return False
            return abs(old - now) <= self.settings.convergence_tol * max(abs(old), 1e-12)
        ref = self._reference_point(F[feas])
        if ref is None:
            return False
        now, old = hypervolume(F[feas], ref), hypervolume(F[feas & before], ref)
        return old > 0 and (now - old) <= self.settings.convergence_tol * old

    def _polish(self, store: EvaluationStore, records: list[Evaluation]) -> None:
        """Final local search from the best feasible design (``polish``, ``polish_method``;
        :func:`hypate.scaling.engine.polish.polish_best`), stored as iteration n_iter + 1."""
        t = self.settings.n_iter + 1

        def evaluate(x: np.ndarray, k: int) -> Evaluation:
            self._evaluate(x[None], t, [k], store, records)
            return records[-1]

        polish_best(self.settings, self.bounds, records, evaluate,
                    lambda: self._budget_left(records), self.polish_composition)

    def run(self) -> OptimizationResult:
        """Run (or resume) the optimization.

        Returns
        -------
        OptimizationResult
        """
        store, owned = self._open_store()
        try:
            return self._run(store)
        finally:
            if owned and self.context.store is not None:
                store.close()

    def _run(self, store: EvaluationStore) -> OptimizationResult:
        for key, val in (("seed", self.settings.seed), ("n_var", self.n_var), ("n_obj", self.n_obj),
                         ("n_constr", self.n_constr), ("n_init", self.settings.n_init),
                         ("batch_size", self.settings.batch_size)):
            store.set_meta(key, val)
        records = store.load()
        done = {(r.iteration, r.batch_index) for r in records}
        overhead: list[float] = []
        # iteration 0: initial design
        X0 = self.initial_design()
        todo = [i for i in range(len(X0)) if (0, i) not in done]
        todo = todo[: max(0, self._budget_left(records))]
        if todo and self.context.executor is not None:
            with ThreadPoolExecutor(1) as here:
                # the inner optimization's start design is built once per process (about
                # 0.5 s): here, while the workers evaluate the initial design, instead of
                # in the first proposal
                here.submit(raw_latin_hypercube, self.settings.n_raw, self.bounds, 0)
                self._evaluate(X0[todo], 0, todo, store, records)
        elif todo:
            self._evaluate(X0[todo], 0, todo, store, records)
        for t in range(1, self.settings.n_iter + 1):
            if all((t, i) in done for i in range(self.settings.batch_size)):
                continue  # replayed from the store
            if self._budget_left(records) <= 0 or self._converged(records, t):
                break
            t0 = time.perf_counter()
            prior = [r for r in records if r.iteration < t]
            with blas_threads(self.context.blas_threads):
                Xb = self.propose(prior, t)
            overhead.append(time.perf_counter() - t0)
            if not len(Xb):  # the stopping rule held (iterations = "auto")
                break
            todo = [i for i in range(self.settings.batch_size) if (t, i) not in done]
            stored = {r.batch_index: r.x for r in records if r.iteration == t}
            for i, x in stored.items():
                if not np.allclose(x, Xb[i], rtol=0, atol=1e-9):
                    warnings.warn(f"iteration {t}: resumed proposal differs from the stored one",
                                  RuntimeWarning, stacklevel=2)
            todo = todo[: max(0, self._budget_left(records))]
            self._evaluate(Xb[todo], t, todo, store, records)
        self._polish(store, records)
        data = evaluations_to_dataframe(records) if records else evaluations_to_dataframe([])
        X, F, G, ok, feas = self._arrays(records)
        ref = self._reference_point(F[feas]) if self.n_obj > 1 else None
        return OptimizationResult(data=data, n_var=self.n_var, n_obj=self.n_obj, ref_point=ref,
                                  seconds_per_iteration=np.array(overhead),
                                  stopping=None if self.settings.stopping is None
                                  else self.stopping.to_dict())
