"""Grey-box surrogates: model the histories the objectives are computed from, not the
objectives (composite-function Bayesian optimization).

A scaling study's objectives are known functions of the model's nondimensional response
histories against the prototype's, which are fixed (Eqs. 6.4, 9.6): relative RMS errors
``J_j = sqrt(sum_g c_jg ||h_g - t_g||^2)`` over groups ``g`` of the history vector ``h``
(the deflection series, the temperature series) with targets ``t``. Kriging ``J`` itself
fits the V-shaped valley of a norm, whose bottom (where the histories cross the
prototype's) is a kink the surrogate smooths away. Here the engine models the smooth
histories instead and composes J from them:

1. **POD** of each group's histories over the successful evaluations (the fluid ROM's
   machinery in spirit, App. A): ``h_g = m_g + Phi_g a_g`` with orthonormal ``Phi_g``
   keeping :data:`ENERGY` of the variance (at most ``n - 1`` modes);
2. **kriging** of the coefficients ``a`` (independent columns, the optimizer's own
   surrogates: its coordinates, categorical levels and workers);
3. **composition with its uncertainty, sampled**: with ``a ~ N(mu(x), diag sigma(x)^2)``,
   ``||h_g - t_g||^2 = rho_g + ||b_g + a_g||^2`` exactly (``b_g = Phi_g^T (m_g - t_g)``,
   ``rho_g`` the part of ``m_g - t_g`` outside the basis), evaluated at
   :data:`SAMPLES` fixed quasi-random normal draws (scrambled Sobol, one set per model:
   common random numbers, so the result is smooth and deterministic in x). The predictive
   mean and standard deviation of each J (or of ln J, ``transform="log"``) are the
   samples' moments; their gradients follow by the reparameterization
   ``a = mu + sigma eps``.

:class:`HistoriesModel` therefore has the objective model's interface
(``predict_moments``, ``predict_with_gradients``, ``condition``, ``leave_one_out``): every
acquisition, the batch's kriging believer and the inner SLSQP use it unchanged.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.special import ndtri
from scipy.stats import qmc

__all__ = ["ENERGY", "HISTORIES", "SAMPLES", "Composition", "HistoryBasis",
           "HistoriesModel", "normal_samples"]

#: The auxiliary output (``aux`` key of an evaluation) holding its history vector.
HISTORIES = "histories"

#: Variance fraction each group's POD keeps.
ENERGY = 1.0 - 1e-6
#: Quasi-random normal samples of the composition.
SAMPLES = 128
#: Smallest J of the log transform (ln 1e-12).
LOG_FLOOR = 1e-12


@dataclass(frozen=True)
class Composition:
    """Objectives as relative RMS errors of history groups against targets.

    ``J_j = sqrt(sum_g weights[j, g] ||h[groups[g]] - targets[groups[g]]||^2)``.

    Attributes
    ----------
    targets : ndarray of shape (L,)
        The prototype's histories.
    groups : tuple of ndarray of int
        Index sets of the groups in ``h`` (disjoint).
    weights : ndarray of shape (m, G)
        Nonnegative weight of group ``g`` in objective ``j``.
    """

    targets: np.ndarray
    groups: tuple[np.ndarray, ...]
    weights: np.ndarray

    def __post_init__(self) -> None:
        W = np.atleast_2d(np.asarray(self.weights, float))
        if W.shape[1] != len(self.groups) or np.any(W < 0.0):
            raise ValueError("weights must be (objectives, groups), nonnegative")
        object.__setattr__(self, "weights", W)

    @property
    def n_objectives(self) -> int:
        return int(self.weights.shape[0])

    def __call__(self, H: np.ndarray) -> np.ndarray:
        """The objectives of histories ``H`` (n, L), shape (n, m)."""
        H = np.atleast_2d(np.asarray(H, float))
        S = np.stack([np.sum((H[:, g] - self.targets[g]) ** 2, axis=1) for g in self.groups],
                     axis=1)
        return np.sqrt(S @ self.weights.T)


@dataclass(frozen=True)
class HistoryBasis:
    """Per-group POD of the training histories (module docstring, step 1).

    Attributes
    ----------
    means : tuple of ndarray
        ``m_g``, the mean history of each group.
    modes : tuple of ndarray of shape (L_g, K_g)
        Orthonormal POD modes ``Phi_g``.
    offsets : ndarray of shape (K,)
        ``b = Phi^T (m - t)`` of every mode, groups concatenated.
    residual : ndarray of shape (G,)
        ``rho_g = ||(I - Phi_g Phi_g^T)(m_g - t_g)||^2``.
    slices : tuple of slice
        The coefficients of each group in the concatenated coefficient vector.
    """

    means: tuple[np.ndarray, ...]
    modes: tuple[np.ndarray, ...]
    offsets: np.ndarray
    residual: np.ndarray
    slices: tuple[slice, ...]

    @classmethod
    def fit(cls, H: np.ndarray, composition: Composition, energy: float = ENERGY
            ) -> HistoryBasis:
        """POD of the rows of ``H`` (n, L) per group of ``composition``."""
        H = np.asarray(H, float)
        means, modes, offsets, residual, slices = [], [], [], [], []
        start = 0
        for g in composition.groups:
            Hg = H[:, g]
            m = Hg.mean(axis=0)
            _, s, Vt = np.linalg.svd(Hg - m, full_matrices=False)
            e = s**2
            if e.sum() > 0.0:
                k = int(np.searchsorted(np.cumsum(e) / e.sum(), energy) + 1)
                k = max(1, min(k, int(np.sum(s > 1e-12 * s[0]))))
            else:  # every history alike: one (arbitrary) mode with zero coefficients
                k = 1
            Phi = Vt[:k].T
            d = m - composition.targets[g]
            b = Phi.T @ d
            means.append(m)
            modes.append(Phi)
            offsets.append(b)
            residual.append(max(float(d @ d - b @ b), 0.0))
            slices.append(slice(start, start + k))
            start += k
        return cls(tuple(means), tuple(modes), np.concatenate(offsets), np.array(residual),
                   tuple(slices))

    @property
    def n_coefficients(self) -> int:
        return int(self.offsets.size)

    def coefficients(self, H: np.ndarray, composition: Composition) -> np.ndarray:
        """``a = Phi^T (h - m)`` of histories ``H`` (n, L), shape (n, K)."""
        H = np.atleast_2d(np.asarray(H, float))
        return np.concatenate([(H[:, g] - m) @ Phi for g, m, Phi in
                               zip(composition.groups, self.means, self.modes)], axis=1)


def normal_samples(n: int, dim: int, seed: int) -> np.ndarray:
    """``n`` scrambled-Sobol standard normal draws of dimension ``dim`` (fixed by seed)."""
    U = qmc.Sobol(dim, scramble=True, seed=seed).random(n)
    return ndtri(np.clip(U, 1e-12, 1.0 - 1e-12))


class HistoriesModel:
    """The objectives' surrogate composed from a surrogate of the histories' POD
    coefficients (module docstring).

    Parameters
    ----------
    coefficients : fitted model
        Kriging of the coefficients (``predict_moments``, ``predict_with_gradients``,
        ``condition``, ``leave_one_out``; columns as :class:`HistoryBasis`).
    basis : HistoryBasis
    composition : Composition
    transform : {"none", "log"}
        The objectives as the optimizer models them (``"log"``: ln J).
    eps : ndarray of shape (S, K)
        Standard normal base samples (:func:`normal_samples`).
    X, A : ndarray of shape (n, d) and (n, K)
        The training designs and their coefficients (the believer extends them).
    """

    def __init__(self, coefficients: Any, basis: HistoryBasis, composition: Composition,
                 transform: str, eps: np.ndarray, X: np.ndarray, A: np.ndarray) -> None:
        self.coefficients = coefficients
        self.basis = basis
        self.composition = composition
        self.transform = transform
        self.eps = np.asarray(eps, float)
        self.X, self.A = np.asarray(X, float), np.asarray(A, float)
        # the weight of every coefficient's group in every objective, and the residuals
        G = len(composition.groups)
        self._group_of = np.concatenate([np.full(sl.stop - sl.start, g)
                                         for g, sl in enumerate(basis.slices)])
        self._onehot = np.eye(G)[self._group_of]                      # (K, G)

    # -- composition ---------------------------------------------------------------------
    def _samples(self, mu: np.ndarray, sd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``c = b + a`` at every sample (N, S, K) and the objectives J (N, S, m)."""
        C = self.basis.offsets + mu[:, None, :] + sd[:, None, :] * self.eps[None]
        S = (C * C) @ self._onehot + self.basis.residual                # (N, S, G)
        J2 = S @ self.composition.weights.T                            # (N, S, m)
        return C, np.sqrt(np.maximum(J2, 0.0))

    def _out(self, J: np.ndarray) -> np.ndarray:
        return np.log(np.maximum(J, LOG_FLOOR)) if self.transform == "log" else J

    def predict_moments(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Mean and standard deviation of each objective (model space), shape (N, m)."""
        mu, sd = self.coefficients.predict_moments(np.atleast_2d(X))
        _, J = self._samples(mu, sd)
        Y = self._out(J)
        return Y.mean(axis=1), Y.std(axis=1)

    def sample_with_gradients(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The objectives at the base samples (model space), shape (N, S, m), and their
        gradients (N, S, m, d): the reparameterization ``a = mu + sigma eps`` through the
        composition (the samples are joint across the objectives: one history each)."""
        mu, sd, dmu, dsd = self.coefficients.predict_with_gradients(np.atleast_2d(X))
        C, J = self._samples(mu, sd)                                    # (N,S,K), (N,S,m)
        # dJ_j/dc_k = w_{j, g(k)} c_k / J_j   (J^2 = sum_g w_jg (rho_g + ||c_g||^2))
        Wk = self.composition.weights[:, self._group_of]                # (m, K)
        Jsafe = np.maximum(J, LOG_FLOOR)
        dJdc = (C[:, :, None, :] * Wk[None, None]) / Jsafe[..., None]   # (N, S, m, K)
        if self.transform == "log":
            dJdc = dJdc / Jsafe[..., None]
        # dc_k/dx = dmu_k + eps_k dsd_k
        dc = dmu[:, None] + self.eps[None, :, :, None] * dsd[:, None]    # (N, S, K, d)
        return self._out(J), np.einsum("nsmk,nskd->nsmd", dJdc, dc)

    def predict_with_gradients(self, X: np.ndarray
                               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Mean, std (N, m) and their gradients (N, m, d): the samples' moments
        (:meth:`sample_with_gradients`)."""
        Y, dY = self.sample_with_gradients(X)
        mean = Y.mean(axis=1)
        dmean = dY.mean(axis=1)
        dev = Y - mean[:, None]
        std = np.sqrt(np.mean(dev**2, axis=1))
        safe = np.where(std > 1e-15, std, 1.0)
        dstd = np.einsum("nsm,nsmd->nmd", dev, dY - dmean[:, None]) / Y.shape[1] / \
            safe[..., None]
        dstd = np.where((std > 1e-15)[..., None], dstd, 0.0)
        return mean, std, dmean, dstd

    # -- the optimizer's other uses ------------------------------------------------------
    def condition(self, X: np.ndarray, F: np.ndarray) -> HistoriesModel:
        """The kriging believer (batches): the rows of ``X`` beyond the training data take
        the coefficients' predicted means as observations (the hyperparameters kept);
        ``F`` (the believed objectives) is implied by them and not used."""
        X = np.atleast_2d(np.asarray(X, float))
        n = self.X.shape[0]
        if X.shape[0] < n or not np.array_equal(X[:n], self.X):
            raise ValueError("condition() extends the training designs with new rows")
        A = np.vstack([self.A, self.coefficients.predict_moments(X[n:])[0]])
        return HistoriesModel(self.coefficients.condition(X, A), self.basis,
                              self.composition, self.transform, self.eps, X, A)

    def leave_one_out(self) -> tuple[np.ndarray, np.ndarray]:
        """Leave-one-out moments of the objectives at the training designs: the
        coefficients' leave-one-out moments through the composition."""
        mu, sd = self.coefficients.leave_one_out()
        _, J = self._samples(mu, sd)
        Y = self._out(J)
        return Y.mean(axis=1), Y.std(axis=1)
