"""The acquisition criteria as pure functions of the predicted moments, Eqs. (6.11)-(6.28).

Each returns the criterion and its partial derivatives with respect to the predicted mean
and standard deviation; :mod:`hypate.scaling.engine.acquisition` wraps them in classes and
does the chain rule to x-gradients once. The hypervolume criteria integrate over the disjoint
box decomposition of the non-dominated region
(:func:`hypate.scaling.engine.pareto.nondominated_boxes`).
"""
from __future__ import annotations

import numpy as np
from hypate.scaling.engine.pareto import hypervolume_improvement
from scipy.special import ndtr

__all__ = [
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
