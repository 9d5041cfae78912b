"""Failure as data: a calibrated probability of success of the next evaluation.

Failed evaluations (a simulation that diverges, flutters before the prototype's end, ...)
cluster in regions of the design space. :class:`SuccessModel` is a Gaussian-process
classifier of the evaluations' outcome (scikit-learn's ``GaussianProcessClassifier``:
a latent Matern-5/2 process with a logistic link, Laplace approximation, hyperparameters
by the approximate marginal likelihood), on the surrogates' input coordinates scaled to the
unit box. Its predicted probability of success is a probability -- not the 0/1 regression
of an indicator with a hand-set threshold -- so a proposal can be required to succeed with
probability ``p_min`` (:meth:`SuccessModel.__call__`, an inequality of the inner SLSQP with
a central-difference Jacobian).

:func:`held_out_calibration` measures whether the probabilities mean what they say: each
evaluation predicted by the model fitted to the others (leave-one-out), with the Brier
score and the observed success rate per bin of predicted probability.
"""
from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from sklearn.exceptions import ConvergenceWarning
from sklearn.gaussian_process import GaussianProcessClassifier
from sklearn.gaussian_process.kernels import ConstantKernel, Matern

__all__ = ["SuccessModel", "Calibration", "held_out_calibration", "P_SUCCESS"]

#: Default smallest predicted probability of success of a proposal (the optimizer's
#: ``p_success``: see :class:`~hypate.scaling.engine.settings.OptimizerSettings`).
P_SUCCESS = 0.85
#: Central-difference step of the Jacobian, in the unit box.
FD_STEP = 1e-4
#: Length-scale bounds of the latent process (unit box): failures are regions, not points.
LENGTH_SCALES = (0.1, 10.0)


class SuccessModel:
    """Probability that an evaluation at ``x`` succeeds (module docstring).

    Parameters
    ----------
    X : ndarray of shape (n, d)
        Evaluated designs (every one, failed or not).
    ok : ndarray of bool, shape (n,)
        Which succeeded (at least one of each outcome).
    bounds : ndarray of shape (d, 2)
        The design box (the Jacobian's steps are :data:`FD_STEP` of its spans).
    transform : callable, optional
        Designs to the surrogates' input coordinates (identity by default).
    box : ndarray of shape (d', 2), optional
        The coordinates' box the classifier's inputs are scaled to (default ``bounds``).
    p_min : float in (0, 1)
        The probability a proposal must reach.
    rng : int or None
        Seed of the hyperparameter restarts.
    """

    def __init__(self, X: np.ndarray, ok: np.ndarray, bounds: np.ndarray,
                 transform: Callable[[np.ndarray], np.ndarray] | None = None,
                 box: np.ndarray | None = None, p_min: float = P_SUCCESS,
                 rng: int | None = 0) -> None:
        ok = np.asarray(ok, bool)
        if ok.all() or not ok.any():
            raise ValueError("a success model needs successes and failures")
        if not 0.0 < p_min < 1.0:
            raise ValueError(f"p_min must be in (0, 1), got {p_min}")
        self.transform = transform  # None: the design itself (picklable either way)
        bounds = np.asarray(bounds, float)
        self.step = FD_STEP * (bounds[:, 1] - bounds[:, 0])
        box = bounds if box is None else np.asarray(box, float)
        self.lower, self.scale = box[:, 0], box[:, 1] - box[:, 0]
        self.p_min = float(p_min)
        d = box.shape[0]
        kernel = ConstantKernel(1.0, (1e-2, 1e2)) * Matern(
            length_scale=np.full(d, 0.5), length_scale_bounds=LENGTH_SCALES, nu=2.5)
        self.classifier = GaussianProcessClassifier(kernel, n_restarts_optimizer=1,
                                                    random_state=rng)
        with warnings.catch_warnings():
            # a hyperparameter at its bound is expected with few failures (a flat latent
            # process): the fit is still the likelihood's best inside the bounds
            warnings.simplefilter("ignore", ConvergenceWarning)
            self.classifier.fit(self._unit(np.atleast_2d(X)), ok.astype(int))

    def _unit(self, X: np.ndarray) -> np.ndarray:
        Z = np.atleast_2d(np.asarray(X, float))
        if self.transform is not None:
            Z = self.transform(Z)
        return (Z - self.lower) / self.scale

    def probability(self, X: np.ndarray) -> np.ndarray:
        """Predicted probability of success, shape (N,)."""
        return self.classifier.predict_proba(self._unit(X))[:, 1]

    # -- the inner optimization's constraint protocol ------------------------------------
    def __call__(self, X: np.ndarray) -> np.ndarray:
        """``p_min - P(success)``, shape (N, 1); satisfied where <= 0."""
        return (self.p_min - self.probability(X))[:, None]

    def jacobian(self, X: np.ndarray) -> np.ndarray:
        """Central differences of :meth:`__call__` in x, shape (N, 1, d)."""
        X = np.atleast_2d(np.asarray(X, float))
        N, d = X.shape
        J = np.empty((N, 1, d))
        for i in range(d):
            E = np.zeros(d)
            E[i] = self.step[i]
            J[:, 0, i] = -(self.probability(X + E) - self.probability(X - E)) / \
                (2 * self.step[i])
        return J


@dataclass(frozen=True)
class Calibration:
    """Leave-one-out calibration of a success model.

    Attributes
    ----------
    predicted : ndarray of shape (n,)
        Each evaluation's probability of success by the model fitted to the others.
    observed : ndarray of bool, shape (n,)
    brier : float
        Mean squared difference of the two (0 perfect; the base rate's own score is
        ``rate (1 - rate)``).
    base_rate_brier : float
    bins : list of (float, float, float, int)
        Per bin of predicted probability: its range (low, high), the observed success rate,
        and the count.
    """

    predicted: np.ndarray
    observed: np.ndarray
    brier: float
    base_rate_brier: float
    bins: list[tuple[float, float, float, int]]


def held_out_calibration(X: np.ndarray, ok: np.ndarray, bounds: np.ndarray,
                         edges: tuple[float, ...] = (0.0, 0.5, 0.8, 0.95, 1.0)
                         ) -> Calibration:
    """Leave-one-out predictions of a success model on evaluations ``X``, ``ok``
    (module docstring); every fold needs both outcomes among its training evaluations."""
    X = np.atleast_2d(np.asarray(X, float))
    ok = np.asarray(ok, bool)
    pred = np.empty(len(ok))
    for i in range(len(ok)):
        keep = np.arange(len(ok)) != i
        pred[i] = SuccessModel(X[keep], ok[keep], bounds).probability(X[i:i + 1])[0]
    brier = float(np.mean((pred - ok) ** 2))
    rate = float(ok.mean())
    bins = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        sel = (pred >= lo) & ((pred < hi) if hi < 1.0 else (pred <= hi))
        bins.append((lo, hi, float(ok[sel].mean()) if sel.any() else float("nan"),
                     int(sel.sum())))
    return Calibration(pred, ok, brier, rate * (1.0 - rate), bins)
