"""Robust Bayesian optimization: designs whose objectives stay low under scattered inputs
(Sec. 10.2's robust design by surrogate-based stochastic collocation; beyond the
dissertation).

The problem's variables are the design ``x`` (the first ``n_design``) followed by the
uncertain inputs ``xi`` (e.g. factors on the tunnel's p0 and the model's modulus). One
kriging model per objective is fitted over ``(x, xi)`` jointly on every evaluation, and the
acquisition sees, per objective, the *robust statistic* of that model over the inputs' own
distribution (:class:`RobustModel`): the model's mean at ``m`` fixed samples of ``xi``
(scrambled Sobol of the distribution, the same every iteration) reduced to the mean,
``mean + 2 std`` or the 90 % quantile (numpy's "linear" quantile: a weighted pair of
samples, so its gradient is the same pair's). Each iteration then

1. maximizes the study's acquisition (HVLCB, ...) of the robust statistics over ``x`` alone,
   with the cheap constraints of the design and the predicted failure probability averaged
   over ``xi`` as its model constraint;
2. picks the uncertain inputs at which to simulate that design: the candidate ``xi`` with
   the largest predicted variance of the objectives (each scaled by its spread), the most
   informative point of the design's scatter (Beland & Nair's variance rule for
   environmental inputs);
3. simulates the pair ``(x, xi)`` and stores it like any evaluation (a resumed run replays
   it: the inputs are part of the stored campaign).

The statistic's uncertainty is approximated by the same reduction of the model's standard
deviations (for the mean: the weighted mean of the ``sigma``'s, an upper bound of the
posterior standard deviation of the weighted mean, Cauchy-Schwarz) -- the confidence bound
that the hypervolume acquisitions need.

Evaluations known before the run (``prior``, e.g. a nominal campaign of the same study at
``xi = 1``) enter every fit but are neither stored nor counted in the budget.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from hypate.scaling.engine.inner import optimize_acquisition
from hypate.scaling.engine.optimizer import BayesianOptimizer
from hypate.scaling.engine.pareto import non_dominated_mask
from hypate.scaling.engine.problem import project_designs
from hypate.scaling.engine.propagation import ROBUST_STATISTICS
from hypate.scaling.engine.settings import OptimizerSettings, RunContext, SettingError
from hypate.scaling.engine.store import Evaluation
from hypate.scaling.engine.surrogate import ProbabilisticConstraint
from hypate.solvers.numerics.random import latin_hypercube

#: Quantile of the "q90" statistic.
Q90 = 0.9


def statistic_weights(values: np.ndarray, statistic: str) -> np.ndarray | None:
    """Weights ``W`` (same shape as ``values`` (N, m, k)) with ``sum_j W[:, j] values[:, j]``
    the statistic over the ``m`` samples, for the linear statistics ("mean", "q90");
    None for "mean+2std" (not linear in the values)."""
    n, m, k = values.shape
    if statistic == "mean":
        return np.full(values.shape, 1.0 / m)
    if statistic == "q90":
        pos = Q90 * (m - 1)
        i0 = int(np.floor(pos))
        i1 = min(i0 + 1, m - 1)
        frac = pos - i0
        order = np.argsort(values, axis=1, kind="stable")
        W = np.zeros(values.shape)
        rows, cols = np.arange(n)[:, None], np.arange(k)[None, :]
        W[rows, order[:, i0, :], cols] += 1.0 - frac
        W[rows, order[:, i1, :], cols] += frac
        return W
    return None


def reduce_samples(mu: np.ndarray, sd: np.ndarray, statistic: str,
                   dmu: np.ndarray | None = None, dsd: np.ndarray | None = None):
    """The statistic over axis 1 of sample values ``mu`` (N, m, k) and its standard deviation
    from ``sd``; with ``dmu``, ``dsd`` (N, m, k, d) also their gradients (N, k, d)."""
    W = statistic_weights(mu, statistic)
    S = sd.mean(axis=1)
    dS = None if dsd is None else dsd.mean(axis=1)
    if W is not None:
        R = np.sum(W * mu, axis=1)
        if statistic != "mean":
            S = np.sum(W * sd, axis=1)
            dS = None if dsd is None else np.sum(W[..., None] * dsd, axis=1)
        dR = None if dmu is None else np.sum(W[..., None] * dmu, axis=1)
        return R, S, dR, dS
    if statistic != "mean+2std":
        raise ValueError(f"statistic must be one of {ROBUST_STATISTICS}, got {statistic!r}")
    mean = mu.mean(axis=1)
    dev = mu - mean[:, None]
    std = np.sqrt(np.mean(dev * dev, axis=1))
    R = mean + 2.0 * std
    if dmu is None:
        return R, S, None, None
    dmean = dmu.mean(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        dstd = np.mean(dev[..., None] * (dmu - dmean[:, None]), axis=1) / std[..., None]
    dR = dmean + 2.0 * np.where(std[..., None] > 0, dstd, 0.0)
    return R, S, dR, dS


#: Smoothing of the failure-indicator kriging of the robust search (standardized nugget,
#: unit-box length scales); the optimizer's proposals use a classifier (SuccessModel).
FAILURE_NUGGET = 0.05
FAILURE_LENGTH_SCALES = (0.15, 1e2)
#: Largest predicted failure indicator the robust search accepts for a proposal.
FAILURE_THRESHOLD = 0.15

class RobustModel:
    """The robust statistic of a joint model over the uncertain inputs' samples, as a model
    of the design alone (``predict_moments``, ``predict_with_gradients``: the acquisitions'
    :class:`~hypate.scaling.engine.acquisition.Model`).

    Parameters
    ----------
    joint : model over (x, xi)
        ``predict_moments`` / ``predict_with_gradients`` on rows ``(x, xi)``.
    n_design : int
        Length of ``x``.
    samples : ndarray of shape (m, n_inputs)
        The uncertain inputs' samples (their distribution; equal weights).
    statistic : {"mean", "mean+2std", "q90"}
    """

    def __init__(self, joint: Any, n_design: int, samples: np.ndarray, statistic: str) -> None:
        if statistic not in ROBUST_STATISTICS:
            raise ValueError(f"statistic must be one of {ROBUST_STATISTICS}, got {statistic!r}")
        self.joint = joint
        self.n_design = int(n_design)
        self.samples = np.atleast_2d(np.asarray(samples, dtype=float))
        self.statistic = statistic

    def _rows(self, X: np.ndarray) -> np.ndarray:
        X = np.atleast_2d(np.asarray(X, dtype=float))
        m = len(self.samples)
        return np.hstack([np.repeat(X, m, axis=0), np.tile(self.samples, (len(X), 1))])

    def predict_moments(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Statistic and its standard deviation per design, shapes (N, k)."""
        n, m = len(np.atleast_2d(X)), len(self.samples)
        mu, sd = self.joint.predict_moments(self._rows(X))
        R, S, _, _ = reduce_samples(mu.reshape(n, m, -1), sd.reshape(n, m, -1), self.statistic)
        return R, S

    def predict_with_gradients(self, X: np.ndarray):
        """Statistic, standard deviation and their gradients in ``x`` ((N, k), (N, k, d))."""
        n, m, d = len(np.atleast_2d(X)), len(self.samples), self.n_design
        mu, sd, dmu, dsd = self.joint.predict_with_gradients(self._rows(X))
        k = mu.shape[1]
        return reduce_samples(mu.reshape(n, m, k), sd.reshape(n, m, k), self.statistic,
                              dmu[..., :d].reshape(n, m, k, d), dsd[..., :d].reshape(n, m, k, d))


class RobustBayesianOptimizer(BayesianOptimizer):
    """Bayesian optimization of a robust statistic over the design variables of a problem
    whose last variables are uncertain inputs (module docstring).

    Parameters
    ----------
    problem : pymoo.core.problem.Problem
        Variables ``(x, xi)``: ``n_design`` design variables, then the uncertain inputs
        (bounds: the support the samples cover); no expensive constraints.
    settings : OptimizerSettings
        As for :class:`~hypate.scaling.engine.optimizer.BayesianOptimizer`; the cheap
        constraints act on ``x``; ``coordinates`` (if any) on ``(x, xi)``; one proposal per
        iteration and no polish.
    context : RunContext or None
        As for :class:`~hypate.scaling.engine.optimizer.BayesianOptimizer`.
    n_design : int
    samples : ndarray of shape (m, n_inputs)
        The inputs' distribution as equally weighted samples (the statistic's quadrature).
    statistic : {"mean", "mean+2std", "q90"}
    candidates : ndarray of shape (c, n_inputs), optional
        Where the inputs of a proposal may be placed (default: ``samples``).
    prior : sequence of Evaluation
        Evaluations of ``(x, xi)`` made before the run (fitted, not stored, not counted).
    """

    def __init__(self, problem: Any, settings: OptimizerSettings,
                 context: RunContext | None = None, *, n_design: int,
                 samples: np.ndarray, statistic: str, candidates: np.ndarray | None = None,
                 prior: Sequence[Evaluation] = ()) -> None:
        super().__init__(problem, settings, context)
        n_inputs = self.n_var - int(n_design)
        if not 0 < int(n_design) < self.n_var:
            raise SettingError("n_design", f"between 1 and {self.n_var - 1} (the variables "
                               "are the design, then at least one uncertain input)", n_design)
        samples = np.atleast_2d(np.asarray(samples, dtype=float))
        candidates = samples if candidates is None else np.atleast_2d(
            np.asarray(candidates, dtype=float))
        lo, hi = self.bounds[n_design:, 0], self.bounds[n_design:, 1]
        for name, S in (("samples", samples), ("candidates", candidates)):
            if S.ndim != 2 or S.shape[1] != n_inputs or len(S) < 2:
                raise SettingError(name, f"at least 2 rows of {n_inputs} uncertain inputs",
                                   S.shape)
            if np.any(S < lo) or np.any(S > hi):
                raise SettingError(name, "inside the uncertain inputs' bounds", "outside")
        if statistic not in ROBUST_STATISTICS:
            raise SettingError("statistic", f"one of {ROBUST_STATISTICS}", statistic)
        if self.n_constr:
            raise SettingError("problem", "no expensive constraints (a robust statistic of a "
                               "constraint is not modelled)", self.n_constr)
        if self.settings.batch_size != 1:
            raise SettingError("batch_size", "1 for a robust optimization",
                               self.settings.batch_size)
        if self.settings.polish:
            raise SettingError("polish", "0 for a robust optimization", self.settings.polish)
        self.n_design = int(n_design)
        self.samples = samples
        self.candidates = candidates
        self.statistic = statistic
        self.prior = list(prior)
        self.design_bounds = self.bounds[: self.n_design]

    # -------------------------------------------------------------- designs
    def _project(self, X: np.ndarray) -> np.ndarray:
        """Designs (rows of x) projected onto the cheap constraints."""
        return project_designs(X, self.settings.cheap_constraints, self.design_bounds)

    def initial_design(self) -> np.ndarray:
        """OLH over (x, xi), the designs projected onto the cheap constraints."""
        Z = latin_hypercube(self.settings.n_init, self.bounds, self._rng(0))
        if len(Z):
            Z[:, : self.n_design] = self._project(Z[:, : self.n_design])
        return Z

    def _fallback_point(self, X_avoid: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        z = latin_hypercube(1, self.bounds, rng)[0]
        z[: self.n_design] = self._project(z[None, : self.n_design])[0]
        return z

    def fit(self, records: Sequence[Evaluation], rng: np.random.Generator):
        """The joint objective model and the failure model (None if nothing failed) on the
        prior and the given evaluations."""
        every = self.prior + list(records)
        X, F, _, ok, _ = self._arrays(every)
        data, histories = self.objective_data(every, X, self._model_space(F), ok)
        model = self.objective_model(self.surrogates([data], rng)[0], histories, X[ok], rng)
        failure = None
        if not np.all(ok):
            failure = self.surrogate(X, (~ok).astype(float)[:, None], rng, nugget=FAILURE_NUGGET,
                                     length_scale_bounds=FAILURE_LENGTH_SCALES)
        return model, failure

    def designs(self, records: Sequence[Evaluation]) -> np.ndarray:
        """The distinct designs (x of the successful evaluations, prior included), sorted."""
        X, _, _, ok, _ = self._arrays(self.prior + list(records))
        return np.unique(np.round(X[ok, : self.n_design], 12), axis=0)

    def robust_estimates(self, records: Sequence[Evaluation], model: Any | None = None
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The distinct designs of the prior and ``records`` with their surrogate robust
        statistics (in the objectives' units) and standard deviations (model space).

        Returns
        -------
        designs : ndarray (p, n_design)
        statistic, std : ndarray (p, n_obj)
        """
        if model is None:
            model, _ = self.fit(records, self._rng(self.settings.n_iter + 1))
        designs = self.designs(records)
        R, S = RobustModel(model, self.n_design, self.samples, self.statistic
                           ).predict_moments(designs)
        if self.settings.output_transform == "log" and self.statistic != "mean+2std":
            R = np.exp(R)  # mean and quantiles of ln J: ln of J's geometric mean / quantile
        return designs, R, S

    # ------------------------------------------------------------ proposal
    def propose(self, records: list[Evaluation], iteration: int) -> np.ndarray:
        """One ``(x, xi)``: the acquisition of the robust statistics over ``x``, then the
        most uncertain ``xi`` for that design (module docstring)."""
        st = self.settings
        rng = self._rng(iteration)
        _, F, _, ok, _ = self._arrays(self.prior + records)
        if ok.sum() < 2:
            return latin_hypercube(1, self.bounds, rng)
        model, failure = self.fit(records, rng)
        robust = RobustModel(model, self.n_design, self.samples, self.statistic)
        constraints = [] if failure is None else [ProbabilisticConstraint(
            RobustModel(failure, self.n_design, self.samples, "mean"), p_min=0.5,
            threshold=FAILURE_THRESHOLD)]
        designs = self.designs(records)
        R_obs, _ = robust.predict_moments(designs)
        acq = self._build_acquisition(robust, R_obs, np.ones(len(R_obs), bool), R_obs, rng,
                                      iteration)
        best = designs[non_dominated_mask(R_obs)] if self.n_obj > 1 else \
            designs[np.argsort(R_obs[:, 0], kind="stable")[:3]]
        best = best[rng.permutation(len(best))[:5]]
        span = self.design_bounds[:, 1] - self.design_bounds[:, 0]
        extra = best + 1e-3 * span * rng.standard_normal(best.shape)
        try:
            # a design already simulated may be proposed again (at other inputs): no X_avoid
            x, _ = optimize_acquisition(
                acq, self.design_bounds, n_raw=st.n_raw, n_starts=st.n_starts,
                cheap_constraints=st.cheap_constraints, model_constraints=constraints,
                extra_starts=extra, rng=rng)
        except RuntimeError:
            return self._fallback_point(np.zeros((0, self.n_var)), rng)[None]
        return np.r_[x, self.informative_inputs(model, x, self._model_space(F[ok]))][None]

    def informative_inputs(self, model: Any, x: np.ndarray, F: np.ndarray) -> np.ndarray:
        """The candidate inputs with the largest predicted variance of the objectives at
        design ``x`` (each objective scaled by the spread of its observations ``F``; ties:
        the first candidate)."""
        Z = np.hstack([np.repeat(x[None], len(self.candidates), axis=0), self.candidates])
        _, sd = model.predict_moments(Z)
        spread = np.std(F, axis=0) if len(F) > 1 else np.ones(self.n_obj)
        score = np.sum((sd / np.where(spread > 0, spread, 1.0)) ** 2, axis=1)
        return self.candidates[int(np.argmax(score))].copy()


__all__ = ["RobustBayesianOptimizer", "RobustModel", "reduce_samples", "statistic_weights"]
