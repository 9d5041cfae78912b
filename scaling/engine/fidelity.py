"""Multi-fidelity Bayesian optimization: cheaper versions of the simulation inform the
search, the designs and the Pareto front are the top fidelity's (issue 19; beyond the
dissertation's single-fidelity Sec. 6.3).

The problem's last variable is the fidelity level ``l = 0 .. s - 1`` (cheapest first, the
top level the study's own simulation; an integer-valued float, so that the store keeps it
with the design and a resumed run replays it). One recursive co-kriging model per objective
(:class:`~hypate.scaling.engine.multifidelity.MultiFidelityKriging`) is fitted on every
level's successful evaluations; the acquisition (HVLCB, ...) is that of its top-level
prediction against the top level's observed front. Each iteration

0. promotes a lower level's design to the top when the model predicts it better than every
   top-level evaluation so far (:meth:`MultiFidelityOptimizer.promotion`): the design point
   is always a top-level evaluation, and a cheap level that finds a better design has not
   helped until the top level confirms it;
1. otherwise maximizes the acquisition over the design (the cheap constraints, SLSQP
   multistart);
2. chooses the level by expected gain per unit of simulation cost: the share of the top-level
   predictive variance at the design that level ``l``'s own model carries
   (:meth:`~hypate.scaling.engine.multifidelity.MultiFidelityModel.level_variances`, each
   objective scaled by its top-level spread), divided by level ``l``'s cost per simulation
   (the given ``costs``: a deterministic cost model, not the measured seconds, which vary
   from run to run and would make two runs of one seed differ);
3. simulates the design at that level.

A batch (``batch_size`` q > 1, for q workers) repeats 1-2 on the model that believes the
members chosen so far (kriging believer,
:meth:`~hypate.scaling.engine.multifidelity.MultiFidelityModel.condition`: each member's
own level takes its predicted mean as an observation, which lowers the variance there and,
at the top level, adds the believed result to the front), so the next member looks
elsewhere or at another level; the promotion can only be a batch's first member.

The initial design is nested (Le Gratiet's recursive form is exact on nested designs): the
top level's ``n_init`` OLH designs are simulated at every level, each lower level ``l``
adds ``low_samples[l]`` OLH designs of its own.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from hypate.scaling.engine.inner import optimize_acquisition
from hypate.scaling.engine.multifidelity import MultiFidelityKriging, MultiFidelityModel
from hypate.scaling.engine.optimizer import BayesianOptimizer
from hypate.scaling.engine.problem import project_designs
from hypate.scaling.engine.settings import OptimizerSettings, RunContext, SettingError
from hypate.scaling.engine.store import Evaluation
from hypate.solvers.numerics.random import latin_hypercube

#: Fewest successful evaluations of a level for it to enter the fit.
MIN_LEVEL_SAMPLES = 2


class MultiFidelityOptimizer(BayesianOptimizer):
    """Bayesian optimization over the design with fidelity levels (module docstring).

    Parameters
    ----------
    problem : pymoo.core.problem.Problem
        Variables ``(x, level)``; the last one's bounds are ``[0, s - 1]``; no expensive
        constraints.
    settings : OptimizerSettings
        ``n_init``: top-level initial designs; ``batch_size`` proposals per iteration (the
        believer's batch); no polish, no surrogate coordinates.
    context : RunContext or None
        As for :class:`~hypate.scaling.engine.optimizer.BayesianOptimizer`.
    costs : sequence of float
        Cost of one simulation of each level (cheapest first; any common unit).
    low_samples : sequence of int
        Extra initial designs of each lower level (``s - 1`` numbers).
    """

    def __init__(self, problem: Any, settings: OptimizerSettings,
                 context: RunContext | None = None, *, costs: Sequence[float],
                 low_samples: Sequence[int]) -> None:
        super().__init__(problem, settings, context)
        self.n_levels = len(costs)
        if self.n_levels < 2:
            raise SettingError("costs", "one positive number per fidelity level (at least 2)",
                               list(costs))
        if not all(np.isfinite(c) and c > 0 for c in costs):
            raise SettingError("costs", "positive seconds per level", list(costs))
        if len(low_samples) != self.n_levels - 1 or any(int(n) < 0 for n in low_samples):
            raise SettingError("low_samples", f"{self.n_levels - 1} counts >= 0",
                               list(low_samples))
        if not np.allclose(self.bounds[-1], [0.0, self.n_levels - 1]):
            raise SettingError("problem", f"the last variable is the level, bounds [0, "
                               f"{self.n_levels - 1}]", self.bounds[-1].tolist())
        s = self.settings
        if (self.n_constr or s.polish or s.coordinates is not None
                or (s.batch_size > 1 and s.batch_strategy != "believer")):
            raise SettingError("settings", "no expensive constraints, no polish, no surrogate "
                               "coordinates and batches by the kriging believer for "
                               "multi-fidelity BO", (self.n_constr, s.polish,
                                                     s.batch_strategy))
        self.costs = np.asarray(costs, float)
        self.low_samples = [int(n) for n in low_samples]
        self.n_design = self.n_var - 1
        self.design_bounds = self.bounds[: self.n_design]
        self.top = self.n_levels - 1

    # -------------------------------------------------------------- designs
    def _project(self, X: np.ndarray) -> np.ndarray:
        """Designs (rows of x) projected onto the cheap constraints."""
        return project_designs(X, self.settings.cheap_constraints, self.design_bounds)

    def initial_design(self) -> np.ndarray:
        """Nested OLH: the top designs at every level, cheapest level first, plus each lower
        level's own designs."""
        top = self._project(latin_hypercube(self.settings.n_init, self.design_bounds,
                                            self._rng(0)))
        rows = []
        for level in range(self.n_levels):
            extra = (self._project(latin_hypercube(self.low_samples[level], self.design_bounds,
                                                   np.random.default_rng([self.settings.seed,
                                                                          0, level])))
                     if level < self.top and self.low_samples[level] else
                     np.zeros((0, self.n_design)))
            X = np.vstack([top, extra])
            rows.append(np.hstack([X, np.full((len(X), 1), float(level))]))
        return np.vstack(rows)

    def _by_level(self, records: Sequence[Evaluation]):
        X, F, _, ok, _ = self._arrays(list(records))
        level = np.rint(X[:, -1]).astype(int)
        return X[:, :-1], self._model_space(F), ok, level

    def fit(self, records: Sequence[Evaluation], rng: np.random.Generator
            ) -> MultiFidelityModel | None:
        """Co-kriging per objective on the levels with enough successful evaluations
        (None if the top level has fewer than :data:`MIN_LEVEL_SAMPLES`)."""
        X, F, ok, level = self._by_level(records)
        use = [t for t in range(self.n_levels)
               if np.count_nonzero(ok & (level == t)) >= MIN_LEVEL_SAMPLES]
        if self.top not in use:
            return None
        seed = int(rng.integers(2**31))
        models = []
        for j in range(self.n_obj):
            mf = MultiFidelityKriging(self.design_bounds, n_restarts=self.settings.n_restarts,
                                      rng=seed)
            mf.fit([X[ok & (level == t)] for t in use], [F[ok & (level == t), j] for t in use])
            models.append(mf)
        return MultiFidelityModel(models, use)

    # ------------------------------------------------------------ proposal
    def propose(self, records: list[Evaluation], iteration: int) -> np.ndarray:
        """``batch_size`` rows ``(x, level)``: the top level's acquisition over ``x``, then
        the level of the largest expected gain per second (module docstring); each further
        member of a batch on the model that believes the ones before it
        (:meth:`~hypate.scaling.engine.multifidelity.MultiFidelityModel.condition`)."""
        rng = self._rng(iteration)
        X, F, ok, level = self._by_level(records)
        model = self.fit(records, rng)
        q = self.settings.batch_size
        if model is None:  # nothing to model at the top yet: explore it
            U = self._project(latin_hypercube(q, self.design_bounds, rng))
            return np.hstack([U, np.full((q, 1), float(self.top))])
        top = ok & (level == self.top)
        F_top = F[top]
        promoted = self.promotion(model, X, ok, level, F_top)
        rows: list[np.ndarray] = []
        F_believed = F_top
        for b in range(q):
            if b == 0 and promoted is not None:
                row = np.r_[promoted, float(self.top)]
            else:
                row = self._propose_one(model, X, ok, level, F_believed, rows, rng,
                                        iteration, records)
            rows.append(row)
            if b + 1 < q:
                lev = int(row[-1])  # one of model.levels (choose_level's, or the top)
                if lev == self.top:  # the believed top-level result joins the front
                    mean = model.predict_moments(row[None, :-1])[0]
                    F_believed = np.vstack([F_believed, mean])
                model = model.condition(row[:-1], lev)
        return np.array(rows)

    def _propose_one(self, model: MultiFidelityModel, X: np.ndarray, ok: np.ndarray,
                     level: np.ndarray, F_believed: np.ndarray, pending: list[np.ndarray],
                     rng: np.random.Generator, iteration: int,
                     records: Sequence[Evaluation]) -> np.ndarray:
        """One ``(x, level)``: the acquisition of ``model`` against the (believed) top-level
        front over ``x``, then :meth:`choose_level`. ``x`` keeps ``min_distance`` from the
        top level's designs (a lower level's earlier design may come back at the top: the
        promotion's way) and from every design ``pending`` in this batch, at any level (so
        no two members share a design). When the search fails, a random OLH design at the
        top (as before batches; it may fall near a pending one)."""
        st = self.settings
        top = ok & (level == self.top)
        F_top = F_believed[: np.count_nonzero(top)]
        acq = self._build_acquisition(model, F_believed, np.ones(len(F_believed), bool),
                                      F_top, rng, iteration)
        span = self.design_bounds[:, 1] - self.design_bounds[:, 0]
        best = X[top][np.argsort(np.max(F_top, axis=1), kind="stable")[:3]]
        extra = best + 1e-3 * span * rng.standard_normal(best.shape)
        X_avoid = np.vstack([X[level == self.top]] + [p[None, :-1] for p in pending])
        try:
            x, _ = optimize_acquisition(
                acq, self.design_bounds, n_raw=st.n_raw, n_starts=st.n_starts,
                cheap_constraints=st.cheap_constraints, X_avoid=X_avoid,
                min_distance=st.min_distance, extra_starts=extra, rng=rng)
        except RuntimeError:
            x = self._project(latin_hypercube(1, self.design_bounds, rng))[0]
            return np.r_[x, float(self.top)]
        return np.r_[x, float(self.choose_level(model, x, records))]

    def promotion(self, model: MultiFidelityModel, X: np.ndarray, ok: np.ndarray,
                  level: np.ndarray, F_top: np.ndarray) -> np.ndarray | None:
        """The lower-level design, not yet simulated at the top (farther than
        ``min_distance`` in the unit box from every top-level design), whose predicted
        top-level worst objective ``max_j mu_j`` (the min-max design-point rule, in the
        model's output space) is the smallest and beats the top level's best observed one;
        None if there is none."""
        low = ok & (level < self.top)
        if not np.any(low) or len(F_top) == 0:
            return None
        span = self.design_bounds[:, 1] - self.design_bounds[:, 0]
        cand = np.unique(X[low], axis=0)
        X_top = X[level == self.top]
        if len(X_top):
            gap = np.linalg.norm((cand[:, None, :] - X_top[None]) / span, axis=2).min(axis=1)
            cand = cand[gap > self.settings.min_distance]
        if not len(cand):
            return None
        worst = np.max(model.predict_moments(cand)[0], axis=1)
        k = int(np.argmin(worst))
        return cand[k] if worst[k] < float(np.min(np.max(F_top, axis=1))) else None

    def choose_level(self, model: MultiFidelityModel, x: np.ndarray,
                     records: Sequence[Evaluation]) -> int:
        """The level of the largest variance share per second at ``x``; a level that has
        already simulated ``x`` (within ``min_distance`` of the unit box) is skipped."""
        X, F, ok, level = self._by_level(records)
        use = model.levels
        shares = model.level_variances(x)                    # (m, len(use))
        top = F[ok & (level == self.top)]
        spread = np.std(top, axis=0) if len(top) > 1 else np.ones(self.n_obj)
        gain = np.sum(shares / np.maximum(spread, 1e-300)[:, None] ** 2, axis=0)
        cost = self.costs[use]
        span = self.design_bounds[:, 1] - self.design_bounds[:, 0]
        order = np.argsort(-(gain / cost), kind="stable")
        for k in order:
            t = use[k]
            near = np.linalg.norm((X[level == t] - x) / span, axis=1) if np.any(level == t) \
                else np.array([np.inf])
            if t == self.top or near.min() > self.settings.min_distance:
                return int(t)
        return self.top


__all__ = ["MultiFidelityOptimizer"]
