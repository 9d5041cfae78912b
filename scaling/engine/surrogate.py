"""Kriging surrogates of objectives, expensive constraints and the failure region.

The kriging core lives in the neutral package :mod:`kriging` (shared with the fluid ROM);
this module adapts it to the optimizer (Sec. 6.3.1, step 4(a)):

* :func:`fit_surrogate` fits one independent kriging model per column (Eq. (6.9) with a
  diagonal covariance) on the unit-scaled design box.
* :class:`ProbabilisticConstraint` turns surrogates of constraints ``G(x) <= t`` into the
  smooth inequality ``mu(x) - t + z sigma(x) <= 0`` with ``z = Phi^{-1}(p_min)``, i.e. the
  predicted *probability of feasibility* ``Phi((t - mu) / sigma) >= p_min`` for each
  constraint. The inner SLSQP enforces it with analytic gradients (Eq. (A.8)).
  Expensive constraints use ``t = 0``; the failure-region model is a smoothed kriging
  (nugget 0.05, length scales >= 0.15 of the box) of the 0/1 failure indicator with a
  small ``t`` (0.15 in the optimizer: proposals on the fuzzy edge ``t = 1/2`` of a failure
  region fail half the time); the smoothing spreads a failure over a neighbourhood instead
  of a spike at the failed point.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from hypate.solvers.numerics.kriging import KrigingRegressor
from scipy.special import ndtr, ndtri

if TYPE_CHECKING:
    from hypate.scaling.engine.acquisition import Model

__all__ = ["fit_surrogate", "surrogate_regressor", "ProbabilisticConstraint"]


def surrogate_regressor(
    bounds: np.ndarray,
    *,
    kernel: Literal["matern52", "rbf"] = "matern52",
    n_restarts: int = 2,
    nugget: float = 1e-8,
    length_scale_bounds: tuple[float, float] = (1e-2, 1e2),
    rng: np.random.Generator | int | None = None,
) -> KrigingRegressor:
    """The optimizer's kriging regressor, unfitted (e.g. for
    :func:`hypate.solvers.numerics.kriging.fit_together`).

    Parameters
    ----------
    bounds : ndarray of shape (d, 2)
        Design box (inputs are scaled to the unit box).
    kernel : {"matern52", "rbf"}
    n_restarts : int
        Random restarts of the likelihood optimization.
    nugget : float
        Diagonal jitter (standardized outputs); larger values smooth (regression).
    length_scale_bounds : tuple of float
        In unit-box coordinates.
    rng : numpy.random.Generator, int or None
    """
    return KrigingRegressor(kernel=kernel, bounds=np.asarray(bounds, float), n_restarts=n_restarts,
                            nugget=nugget, length_scale_bounds=length_scale_bounds, rng=rng)


def fit_surrogate(X: np.ndarray, Y: np.ndarray, bounds: np.ndarray,
                  **options: Any) -> KrigingRegressor:
    """Fit independent kriging models to the columns of ``Y``.

    Parameters
    ----------
    X : ndarray of shape (n, d)
    Y : ndarray of shape (n, m)
    bounds : ndarray of shape (d, 2)
    **options
        Those of :func:`surrogate_regressor` (``kernel``, ``n_restarts``, ``nugget``,
        ``length_scale_bounds``, ``rng``).

    Returns
    -------
    KrigingRegressor
        Fitted, with ``predict_moments`` and ``predict_with_gradients``.
    """
    Y = np.asarray(Y, dtype=float)
    return surrogate_regressor(bounds, **options).fit(X, Y.reshape(len(Y), -1))


class ProbabilisticConstraint:
    """``P(G_j(x) <= t) >= p_min`` for every surrogate column ``j``, as ``c(x) <= 0``.

    Parameters
    ----------
    model : KrigingRegressor or another :class:`~hypate.scaling.engine.acquisition.Model`
        Surrogate of ``k`` constraint functions (``(N, k)`` moments).
    p_min : float
        Required probability of feasibility, in (0, 1).
    threshold : float
        ``t``: the constraint is ``G <= t``.
    """

    def __init__(self, model: Model, p_min: float = 0.5, threshold: float = 0.0) -> None:
        if not 0.0 < p_min < 1.0:
            raise ValueError(f"p_min must be in (0, 1), got {p_min}")
        self.model = model
        self.p_min = float(p_min)
        self.threshold = float(threshold)
        self.z = float(ndtri(p_min))

    def __call__(self, X: np.ndarray) -> np.ndarray:
        """Constraint values ``mu - t + z sigma``, shape (N, k); feasible where <= 0."""
        mu, sd = self.model.predict_moments(np.atleast_2d(X))
        return mu - self.threshold + self.z * sd

    def jacobian(self, X: np.ndarray) -> np.ndarray:
        """Jacobian of :meth:`__call__`, shape (N, k, d)."""
        _, _, dmu, dsd = self.model.predict_with_gradients(np.atleast_2d(X))
        return dmu + self.z * dsd

    def probability(self, X: np.ndarray) -> np.ndarray:
        """Predicted probability of feasibility ``prod_j Phi((t - mu_j) / sigma_j)``, (N,)."""

        mu, sd = self.model.predict_moments(np.atleast_2d(X))
        return np.prod(ndtr((self.threshold - mu) / np.maximum(sd, 1e-12)), axis=1)
