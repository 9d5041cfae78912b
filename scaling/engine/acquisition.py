"""Acquisition functions, Eqs. (6.14)-(6.28), as small classes over pure math helpers.

Every class takes a fitted model exposing ``predict_moments(X) -> (mu, sigma)`` and
``predict_with_gradients(X) -> (mu, sigma, dmu, dsigma)`` with shapes ``(N, m)`` and
``(N, m, d)`` (:class:`hypate.solvers.numerics.kriging.KrigingRegressor` does), and offers ``__call__(X)`` (shape
``(N,)``) and ``gradient(X)`` (shape ``(N, d)``), vectorized over the rows of ``X``. The
chain rule ``dC/dx = dC/dmu dmu/dx + dC/dsigma dsigma/dx`` (Eqs. (6.15), (6.20), (6.22))
is done once in :class:`Acquisition`; each subclass only supplies ``C(mu, sigma)`` and its
two partial derivatives. ``maximize`` tells the inner optimizer the sense (it minimizes the
negative of a maximization-type acquisition).

The hypervolume acquisitions precompute the non-dominated set and the disjoint box
decomposition of the non-dominated region (:func:`hypate.scaling.engine.pareto.nondominated_boxes`) in the
constructor. With independent Gaussian objectives (Eq. (6.9), diagonal covariance) the
integrals Eq. (6.25) and Eq. (6.27) factorize per box and per objective, so HVPoI and HVEI
are exact sums of products of one-dimensional Gaussian integrals (for any number of
objectives whose grid decomposition fits in ``max_cells``; otherwise HVEI falls back to a
Monte Carlo estimate with fixed base samples, which is smooth in x).
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Protocol

import numpy as np
from hypate.scaling.engine.pareto import hypervolume_improvement, nondominated_boxes, pareto_front
from hypate.solvers.numerics.random import as_rng
from scipy.special import ndtr

__all__ = [
    "Model",
    "Acquisition",
    "ProbabilityOfImprovement",
    "ExpectedImprovement",
    "LowerConfidenceBound",
    "WeightedMetricLCB",
    "HypervolumePoI",
    "HypervolumeEI",
    "HypervolumeLCB",
    "probability_of_improvement",
    "expected_improvement",
    "lower_confidence_bound",
    "weighted_metric",
    "expected_hypervolume_improvement",
    "probability_hypervolume_improvement",
    "hypervolume_lcb",
    "monte_carlo_hvei",
]

_INV_SQRT_2PI = 1.0 / np.sqrt(2.0 * np.pi)
_SIGMA_FLOOR = 1e-12


class Model(Protocol):
    """What an acquisition needs from a surrogate (shapes (N, m) and (N, m, d))."""

    def predict_moments(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...

    def predict_with_gradients(
        self, X: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]: ...


def _pdf(z: np.ndarray) -> np.ndarray:
    return _INV_SQRT_2PI * np.exp(-0.5 * z * z)


# ----------------------------------------------------------------- pure math helpers
def probability_of_improvement(mu, sigma, best_f: float):
    """PoI ``P(J <= J_min) = Phi(z0)``, ``z0 = (J_min - mu) / sigma``, Eq. (6.14).

    (Eq. (6.14) prints ``1 - Phi(z0)``; the probability of *improving* on ``J_min`` under
    ``J ~ N(mu, sigma^2)`` is ``Phi(z0)``, and its gradient is then Eq. (6.15) with the
    opposite sign.)

    Returns
    -------
    value, d_mu, d_sigma : ndarray, same shape as ``mu``
    """
    s = np.maximum(sigma, _SIGMA_FLOOR)
    z = (best_f - mu) / s
    pdf = _pdf(z)
    return ndtr(z), -pdf / s, -pdf * z / s


def expected_improvement(mu, sigma, best_f: float, v: float = 0.0):
    """Generalized EI for ``g = 1``, Eq. (6.19), with partials of Eq. (6.20).

    ``C = sigma [z Phi(z) + phi(z)]``, ``z = (J_min - v sigma - mu) / sigma``, written as
    ``(J_min - v sigma - mu) Phi(z) + sigma phi(z)`` so that ``sigma -> 0`` is exact.

    Returns
    -------
    value, d_mu, d_sigma : ndarray, same shape as ``mu``
    """
    s = np.maximum(sigma, _SIGMA_FLOOR)
    diff = best_f - v * s - mu
    z = diff / s
    cdf, pdf = ndtr(z), _pdf(z)
    return diff * cdf + s * pdf, -cdf, pdf - v * cdf


def lower_confidence_bound(mu, sigma, v: float):
    """LCB ``mu - v sigma``, Eq. (6.21), partials of Eq. (6.22).

    Returns
    -------
    value, d_mu, d_sigma : ndarray, same shape as ``mu``
    """
    return mu - v * sigma, np.ones_like(mu), np.full_like(sigma, -v)


def weighted_metric(J: np.ndarray, weights: np.ndarray, g: float):
    """Weighted metric ``S_g(J) = [sum_j (c_j J_j)^g]^(1/g)``, Eq. (6.11).

    ``g = 1`` is the weighted sum Eq. (6.12) (valid for any sign of ``J``); ``g = inf`` the
    Chebyshev metric Eq. (6.13); for ``1 < g < inf`` negative ``c_j J_j`` are clipped to 0.

    Parameters
    ----------
    J : ndarray of shape (N, m)
    weights : ndarray of shape (m,)
    g : float

    Returns
    -------
    value : ndarray of shape (N,)
    dS_dJ : ndarray of shape (N, m)
    """
    c = np.asarray(weights, dtype=float)
    cJ = J * c
    if g == 1:
        return cJ.sum(axis=1), np.broadcast_to(c, J.shape).copy()
    if np.isinf(g):
        k = np.argmax(cJ, axis=1)
        grad = np.zeros_like(J)
        grad[np.arange(len(J)), k] = c[k]
        return cJ[np.arange(len(J)), k], grad
    p = np.maximum(cJ, 0.0)
    s = np.sum(p**g, axis=1)
    val = s ** (1.0 / g)
    safe = s > 0
    fac = np.where(safe, np.where(safe, s, 1.0) ** (1.0 / g - 1.0), 0.0)
    return val, fac[:, None] * p ** (g - 1.0) * c


def _product_over_boxes(fac, dfac_mu, dfac_s):
    """``sum_c prod_j fac[:, c, j]`` and its partials w.r.t. mu_j and sigma_j."""
    val = np.prod(fac, axis=2).sum(axis=1)
    m = fac.shape[2]
    d_mu = np.empty((fac.shape[0], m))
    d_s = np.empty((fac.shape[0], m))
    for j in range(m):  # loop over objectives only
        others = np.prod(np.delete(fac, j, axis=2), axis=2)
        d_mu[:, j] = np.sum(others * dfac_mu[:, :, j], axis=1)
        d_s[:, j] = np.sum(others * dfac_s[:, :, j], axis=1)
    return val, d_mu, d_s


def _psi(a, mu, s):
    """``E[(a - Y)^+]`` for ``Y ~ N(mu, s^2)`` with partials (``a = -inf`` gives 0)."""
    with np.errstate(invalid="ignore"):
        z = (a - mu) / s
        cdf, pdf = ndtr(z), _pdf(z)
        val = np.where(np.isneginf(a), 0.0, (a - mu) * cdf + s * pdf)
    return val, np.where(np.isneginf(a), 0.0, -cdf), np.where(np.isneginf(a), 0.0, pdf)


def expected_hypervolume_improvement(mu, sigma, lower, upper):
    """Exact HVEI, Eq. (6.27), by the box decomposition.

    ``E[I_H] = sum_c prod_j (psi_j(u_cj) - psi_j(l_cj))`` with ``psi_j(a) = E[(a - Y_j)^+]``
    because ``(u - max(l, y))^+ = (u - y)^+ - (l - y)^+`` for ``l <= u``.

    Parameters
    ----------
    mu, sigma : ndarray of shape (N, m)
    lower, upper : ndarray of shape (B, m)

    Returns
    -------
    value : ndarray of shape (N,)
    d_mu, d_sigma : ndarray of shape (N, m)
    """
    s = np.maximum(sigma, _SIGMA_FLOOR)[:, None, :]
    mu3 = mu[:, None, :]
    pu, pu_m, pu_s = _psi(upper[None], mu3, s)
    pl, pl_m, pl_s = _psi(lower[None], mu3, s)
    return _product_over_boxes(pu - pl, pu_m - pl_m, pu_s - pl_s)


def probability_hypervolume_improvement(mu, sigma, lower, upper):
    """Exact HVPoI, Eqs. (6.25)-(6.26): ``sum_c prod_j [Phi(u_cj) - Phi(l_cj)]`` (standardized).

    Returns
    -------
    value : ndarray of shape (N,)
    d_mu, d_sigma : ndarray of shape (N, m)
    """
    s = np.maximum(sigma, _SIGMA_FLOOR)[:, None, :]
    mu3 = mu[:, None, :]
    with np.errstate(invalid="ignore"):
        zu = (upper[None] - mu3) / s
        zl = (lower[None] - mu3) / s
    pdf_u = _pdf(zu)
    pdf_l = np.where(np.isneginf(zl), 0.0, _pdf(np.where(np.isneginf(zl), 0.0, zl)))
    zl_safe = np.where(np.isneginf(zl), 0.0, zl)
    fac = ndtr(zu) - ndtr(zl)
    d_mu = (-pdf_u + pdf_l) / s
    d_s = (-pdf_u * zu + pdf_l * zl_safe) / s
    return _product_over_boxes(fac, d_mu, d_s)


def hypervolume_lcb(J0, lower, upper):
    """HVLCB at the optimistic point ``J0 = mu - v sigma``, Eq. (6.28) (to be maximized).

    ``I_H(J0)`` where ``J0`` improves the Pareto set; otherwise the negative distance from
    ``J0`` to the non-dominated region (zero on its boundary, so the function is continuous;
    Eq. (6.28) measures the distance to the nearest Pareto point, which jumps at the
    boundary and is replaced here by the distance to the attainment surface).

    Parameters
    ----------
    J0 : ndarray of shape (N, m)
    lower, upper : ndarray of shape (B, m)

    Returns
    -------
    value : ndarray of shape (N,)
    d_J0 : ndarray of shape (N, m)
    """
    hvi, dhvi = hypervolume_improvement(J0, lower, upper, gradient=True)
    # distance to each box: || J0 - clip(J0, lower, upper) ||
    delta = J0[:, None, :] - np.clip(J0[:, None, :], lower[None], upper[None])
    dist2 = np.einsum("Nbm,Nbm->Nb", delta, delta)
    k = np.argmin(dist2, axis=1)
    rows = np.arange(len(J0))
    dist = np.sqrt(dist2[rows, k])
    dvec = delta[rows, k]
    ddist = np.where(dist[:, None] > 0, dvec / np.where(dist > 0, dist, 1.0)[:, None], 0.0)
    improves = hvi > 0
    return np.where(improves, hvi, -dist), np.where(improves[:, None], dhvi, -ddist)


def monte_carlo_hvei(mu, sigma, lower, upper, base_samples):
    """Monte Carlo HVEI ``mean_s I_H(mu + sigma z_s)`` with fixed base samples (smooth in x).

    Parameters
    ----------
    mu, sigma : ndarray of shape (N, m)
    lower, upper : ndarray of shape (B, m)
    base_samples : ndarray of shape (S, m)
        Standard normal draws, fixed across calls (common random numbers).

    Returns
    -------
    value : ndarray of shape (N,)
    d_mu, d_sigma : ndarray of shape (N, m)
    """
    N, m = mu.shape
    S = base_samples.shape[0]
    Y = (mu[:, None, :] + sigma[:, None, :] * base_samples[None]).reshape(N * S, m)
    hvi, g = hypervolume_improvement(Y, lower, upper, gradient=True)
    g = g.reshape(N, S, m)
    return hvi.reshape(N, S).mean(axis=1), g.mean(axis=1), np.mean(g * base_samples[None], axis=1)


# ------------------------------------------------------------------------- classes
class Acquisition(ABC):
    """Base class: chain rule from ``(mu, sigma)`` partials to x-gradients.

    Parameters
    ----------
    model : Model
        Fitted surrogate of the objective(s).
    """

    #: ``True`` if larger is better (the inner optimizer minimizes ``-C``).
    maximize: bool = True

    def __init__(self, model: Model) -> None:
        self.model = model

    @abstractmethod
    def _from_moments(self, mu: np.ndarray, sigma: np.ndarray):
        """Return ``C (N,)``, ``dC/dmu (N, m)``, ``dC/dsigma (N, m)``."""

    def __call__(self, X: np.ndarray) -> np.ndarray:
        """Acquisition values, shape (N,)."""
        mu, sigma = self.model.predict_moments(np.atleast_2d(X))
        return self._from_moments(mu, sigma)[0]

    def gradient(self, X: np.ndarray) -> np.ndarray:
        """Gradient with respect to x, shape (N, d)."""
        return self.value_and_gradient(X)[1]

    def value_and_gradient(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Values (N,) and gradients (N, d) from one model evaluation."""
        mu, sigma, dmu, dsigma = self.model.predict_with_gradients(np.atleast_2d(X))
        val, a, b = self._from_moments(mu, sigma)
        grad = np.einsum("Nm,Nmd->Nd", a, dmu) + np.einsum("Nm,Nmd->Nd", b, dsigma)
        return val, grad


class _SingleObjective(Acquisition):
    def __init__(self, model: Model, output: int = 0) -> None:
        super().__init__(model)
        self.output = output

    def _from_moments(self, mu, sigma):
        j = self.output
        val, a, b = self._scalar(mu[:, j], sigma[:, j])
        da = np.zeros_like(mu)
        db = np.zeros_like(mu)
        da[:, j], db[:, j] = a, b
        return val, da, db

    @abstractmethod
    def _scalar(self, mu, sigma): ...


class ProbabilityOfImprovement(_SingleObjective):
    """PoI, Eqs. (6.14)-(6.15), maximized.

    Parameters
    ----------
    model : Model
    best_f : float
        ``J_min``, the best feasible objective value sampled so far.
    output : int
        Column of the model to use.
    """

    def __init__(self, model: Model, best_f: float, output: int = 0) -> None:
        super().__init__(model, output)
        self.best_f = float(best_f)

    def _scalar(self, mu, sigma):
        return probability_of_improvement(mu, sigma, self.best_f)


class ExpectedImprovement(_SingleObjective):
    """Generalized EI with ``g = 1``, Eqs. (6.16)-(6.20), maximized.

    Parameters
    ----------
    model : Model
    best_f : float
        ``J_min``.
    v : float
        Exploration weight of Eq. (6.17) (``v = 0``: classical EI).
    output : int
    """

    def __init__(self, model: Model, best_f: float, v: float = 0.0, output: int = 0) -> None:
        super().__init__(model, output)
        self.best_f = float(best_f)
        self.v = float(v)

    def _scalar(self, mu, sigma):
        return expected_improvement(mu, sigma, self.best_f, self.v)


class LowerConfidenceBound(_SingleObjective):
    """LCB ``mu - v sigma``, Eqs. (6.21)-(6.22), minimized.

    Parameters
    ----------
    model : Model
    v : float
        Exploration weight (``v > 0``).
    output : int
    """

    maximize = False

    def __init__(self, model: Model, v: float = 2.0, output: int = 0) -> None:
        super().__init__(model, output)
        self.v = float(v)

    def _scalar(self, mu, sigma):
        return lower_confidence_bound(mu, sigma, self.v)


class WeightedMetricLCB(Acquisition):
    """Direct approach: weighted metric Eq. (6.11) of the objectives' LCBs, minimized.

    ``C(x) = S_g(c, (mu - v sigma - ideal) / scale)``, i.e. Eq. (6.10a) with each objective
    replaced by its lower confidence bound Eq. (6.21) and normalized.

    Parameters
    ----------
    model : Model
        Surrogate of all ``m`` objectives.
    weights : ndarray of shape (m,)
        ``c`` of Eq. (6.11).
    g : float
        ``1`` weighted sum, ``inf`` Chebyshev, or any ``g >= 1``.
    v : float
        LCB exploration weight.
    ideal, scale : ndarray of shape (m,) or None
        Normalization ``(J - ideal) / scale`` (defaults 0 and 1, i.e. Eq. (6.11) as written).
    """

    maximize = False

    def __init__(self, model: Model, weights: np.ndarray, g: float = 1.0, v: float = 2.0,
                 ideal: np.ndarray | None = None, scale: np.ndarray | None = None) -> None:
        super().__init__(model)
        if g < 1:
            raise ValueError(f"g must be >= 1, got {g}")
        self.weights = np.asarray(weights, dtype=float)
        self.g = float(g)
        self.v = float(v)
        self.ideal = np.zeros_like(self.weights) if ideal is None else np.asarray(ideal, float)
        self.scale = np.ones_like(self.weights) if scale is None else np.asarray(scale, float)

    def _from_moments(self, mu, sigma):
        Z = (mu - self.v * sigma - self.ideal) / self.scale
        val, dZ = weighted_metric(Z, self.weights, self.g)
        return val, dZ / self.scale, -self.v * dZ / self.scale


class _Hypervolume(Acquisition):
    """Shared constructor: Pareto set and box decomposition, computed once."""

    def __init__(self, model: Model, pareto_front_: np.ndarray, ref_point: np.ndarray,
                 max_cells: int = 200_000) -> None:
        super().__init__(model)
        self.ref_point = np.asarray(ref_point, dtype=float)
        m = self.ref_point.size
        F = np.asarray(pareto_front_, dtype=float).reshape(-1, m)
        self.pareto_front = pareto_front(F) if len(F) else F
        boxes = nondominated_boxes(self.pareto_front, self.ref_point, max_cells=max_cells)
        self.boxes = boxes


class HypervolumePoI(_Hypervolume):
    """HVPoI, Eqs. (6.25)-(6.26): probability that the objectives improve the Pareto set.

    Parameters
    ----------
    model : Model
    pareto_front_ : ndarray of shape (k, m)
        Current Pareto set (objective values).
    ref_point : ndarray of shape (m,)
    max_cells : int
        Largest grid decomposition accepted for ``m > 2``.
    """

    def __init__(self, model: Model, pareto_front_: np.ndarray, ref_point: np.ndarray,
                 max_cells: int = 200_000) -> None:
        super().__init__(model, pareto_front_, ref_point, max_cells)
        if self.boxes is None:
            raise ValueError("Pareto set too large for the grid decomposition; raise max_cells")

    def _from_moments(self, mu, sigma):
        return probability_hypervolume_improvement(mu, sigma, *self.boxes)


class HypervolumeEI(_Hypervolume):
    """HVEI, Eq. (6.27): expected hypervolume improvement.

    Exact by the box decomposition when it exists; otherwise a Monte Carlo estimate with
    ``n_samples`` fixed standard-normal base samples over a reduced Pareto set.

    Parameters
    ----------
    model : Model
    pareto_front_ : ndarray of shape (k, m)
    ref_point : ndarray of shape (m,)
    max_cells : int
    n_samples : int
        Monte Carlo samples (only when the exact decomposition is too large).
    rng : numpy.random.Generator, int or None
        Base samples of the Monte Carlo estimate.
    """

    def __init__(self, model: Model, pareto_front_: np.ndarray, ref_point: np.ndarray,
                 max_cells: int = 200_000, n_samples: int = 256,
                 rng: np.random.Generator | int | None = None) -> None:
        super().__init__(model, pareto_front_, ref_point, max_cells)
        self.base_samples = None
        if self.boxes is None:
            m = self.ref_point.size
            k_max = max(1, int(max_cells ** (1.0 / m)) - 1)
            # keep the k_max Pareto points of largest exclusive contribution proxy
            F = self.pareto_front
            keep = np.argsort(np.prod(self.ref_point - F, axis=1))[::-1][:k_max]
            self.boxes = nondominated_boxes(F[keep], self.ref_point, max_cells=max_cells)
            self.base_samples = as_rng(rng).standard_normal((n_samples, m))

    def _from_moments(self, mu, sigma):
        if self.base_samples is not None:
            return monte_carlo_hvei(mu, sigma, *self.boxes, self.base_samples)
        return expected_hypervolume_improvement(mu, sigma, *self.boxes)


class HypervolumeLCB(_Hypervolume):
    """HVLCB, Eq. (6.28), maximized: hypervolume improvement of ``J0 = mu - v sigma``.

    Parameters
    ----------
    model : Model
    pareto_front_ : ndarray of shape (k, m)
    ref_point : ndarray of shape (m,)
    v : float
        LCB exploration weight.
    max_cells : int
    """

    def __init__(self, model: Model, pareto_front_: np.ndarray, ref_point: np.ndarray,
                 v: float = 1.5, max_cells: int = 200_000) -> None:
        super().__init__(model, pareto_front_, ref_point, max_cells)
        if self.boxes is None:
            raise ValueError("Pareto set too large for the grid decomposition; raise max_cells")
        self.v = float(v)

    def _from_moments(self, mu, sigma):
        val, dJ = hypervolume_lcb(mu - self.v * sigma, *self.boxes)
        return val, dJ, -self.v * dJ


# short aliases used in the optimizer and the CLI
PoI, EI, LCB = ProbabilityOfImprovement, ExpectedImprovement, LowerConfidenceBound
HVPoI, HVEI, HVLCB = HypervolumePoI, HypervolumeEI, HypervolumeLCB
