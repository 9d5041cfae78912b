"""POD and POD-kriging of fluid snapshots (Dissertation Sec. 2.4.3, App. A).

* :class:`PodBasis` -- snapshot POD (Eqs. A.9-A.13) of mean-centred snapshots,
  ``y ~ y_mean + Psi_P y_P``; the number of modes is the smallest with the energy error
  of Eq. (A.14) below ``tolerance`` (default 0.5 %).
* :class:`PodKriging` -- Eq. (2.56): one kriging model per POD coefficient (the project's
  :class:`hypate.solvers.numerics.kriging.KrigingRegressor`, ordinary kriging on
  scikit-learn) on top of a polynomial regression trend fitted by least squares (the
  ``beta_f^T f(d)`` part of Eqs. 2.58/A.2; the GP then interpolates the residual,
  ``beta_r^T r(d)``); analytic Jacobian ``dy/dd`` (Eq. 2.59 = trend gradient + Eq. A.8a).

Both know nothing of panels or flows: inputs ``d`` and snapshots ``y`` are plain arrays.
"""
from __future__ import annotations

from collections.abc import Callable
from typing import cast

import numpy as np
from hypate.solvers.aero.base import Array
from hypate.solvers.errors import InputError
from hypate.solvers.numerics.kriging import KernelName, KrigingRegressor
from hypate.solvers.numerics.random import as_rng

__all__ = ["PodBasis", "PodKriging"]


class PodBasis:
    """Snapshot POD, Eqs. (A.9)-(A.14), of mean-centred snapshots.

    Parameters
    ----------
    tolerance : float
        Energy criterion of Eq. (A.14): keep the fewest modes with eps_POD < tolerance.
    max_modes : int or None
        Optional cap on the number of modes.
    """

    def __init__(self, tolerance: float = 0.005, max_modes: int | None = None) -> None:
        self.tolerance = tolerance
        self.max_modes = max_modes

    def fit(self, Y: Array) -> PodBasis:
        """``Y`` of shape (N_s, n): one snapshot per row (the transposed S_P of Eq. A.9)."""
        Y = np.asarray(Y, float)
        self.mean_ = Y.mean(axis=0)
        U, s, _ = np.linalg.svd((Y - self.mean_).T, full_matrices=False)  # Eq. (A.10)
        energy = s**2
        total = energy.sum()
        if total <= 0.0:
            n_p = 1
        else:
            tail = np.sqrt(np.maximum(1.0 - np.cumsum(energy) / total, 0.0))  # Eq. (A.14)
            n_p = int(np.argmax(tail < self.tolerance)) + 1 if np.any(tail < self.tolerance) \
                else s.size
        if self.max_modes is not None:
            n_p = min(n_p, self.max_modes)
        self.modes_ = U[:, :n_p]  # Eq. (A.11)
        self.singular_values_ = s
        self.error_ = float(np.sqrt(energy[n_p:].sum() / total)) if total > 0 else 0.0
        return self

    def project(self, Y: Array) -> Array:
        """POD coefficients y_P = Psi_P^T (y - y_mean), Eq. (A.13)."""
        return (np.asarray(Y, float) - self.mean_) @ self.modes_

    def reconstruct(self, C: Array) -> Array:
        """y = y_mean + Psi_P y_P."""
        return self.mean_ + np.asarray(C, float) @ self.modes_.T


def _trend_basis(U: Array, trend: str, gradient: bool = False):
    """Regression basis f(u) of Eq. (A.2) on unit-box inputs ``U`` (N, d): constant, linear
    or full quadratic; with ``gradient`` also df/du of shape (N, q, d)."""
    N, d = U.shape
    cols = [np.ones(N)]
    grads = [np.zeros((N, d))]
    if trend in ("linear", "quadratic"):
        for j in range(d):
            cols.append(U[:, j])
            g = np.zeros((N, d))
            g[:, j] = 1.0
            grads.append(g)
    if trend == "quadratic":
        for j in range(d):
            for k in range(j, d):
                cols.append(U[:, j] * U[:, k])
                g = np.zeros((N, d))
                g[:, j] += U[:, k]
                g[:, k] += U[:, j]
                grads.append(g)
    F = np.stack(cols, axis=1)
    if not gradient:
        return F, None
    return F, np.stack(grads, axis=1)


class PodKriging:
    """POD-kriging model, Eqs. (2.56)-(2.59).

    Parameters
    ----------
    tolerance : float
        POD energy criterion, Eq. (A.14).
    kernel : {"rbf", "matern52"}
        Correlation function (Eq. A.4 is "rbf").
    trend : {"constant", "linear", "quadratic"}
        Regression basis f(d) of Eq. (A.2). A quadratic trend falls back to linear when the
        samples are fewer than twice its terms.
    n_restarts : int
        Restarts of the likelihood optimization (first POD coefficient; see
        :meth:`_fit_gps`).
    rng : numpy.random.Generator, int or None
    optimized_modes : int
        POD coefficients whose hyperparameters are optimized; later ones inherit.
    """

    def __init__(self, tolerance: float = 0.005, kernel: KernelName = "rbf",
                 trend: str = "linear", n_restarts: int = 2,
                 rng: np.random.Generator | int | None = None, optimized_modes: int = 3) -> None:
        self.tolerance = tolerance
        self.optimized_modes = optimized_modes
        self.kernel = kernel
        self.trend = trend
        self.n_restarts = n_restarts
        self.rng = rng

    def fit(self, D: Array, Y: Array, bounds: Array | None = None,
            progress: Callable[[int, int], None] | None = None) -> PodKriging:
        """Fit on inputs ``D`` (N_s, N_d) and snapshots ``Y`` (N_s, n).

        Parameters
        ----------
        D : ndarray of shape (N_s, N_d)
        Y : ndarray of shape (N_s, n)
        bounds : ndarray of shape (N_d, 2), optional
            Unit box of the trend and the kriging (default: data range).
        progress : callable, optional
            ``progress(done, total)`` after the POD and after each kriging fit (one per
            optimized POD coefficient, then the multi-output model): ``total`` is
            ``min(optimized_modes, N_p) + 2``.
        """
        D = np.asarray(D, float)
        Y = np.asarray(Y, float)
        if D.ndim != 2 or Y.ndim != 2 or D.shape[0] != Y.shape[0]:
            raise InputError("samples", f"inputs {D.shape} and snapshots {Y.shape} must have "
                             "one row per sample")
        if not (np.all(np.isfinite(D)) and np.all(np.isfinite(Y))):
            raise InputError("samples", "inputs and snapshots must be finite")
        if bounds is None:
            bounds = np.stack([D.min(axis=0), D.max(axis=0)], axis=1)
        self.bounds_ = np.asarray(bounds, float)
        self.pod_ = PodBasis(self.tolerance).fit(Y)
        total = min(self.optimized_modes, self.n_modes) + 2

        def report(done: int) -> None:
            if progress is not None:
                progress(done, total)

        report(1)
        C = self.pod_.project(Y)
        trend = self.trend
        if trend == "quadratic" and D.shape[0] < 2 * _trend_basis(D[:1], "quadratic")[0].shape[1]:
            trend = "linear"
        if D.shape[0] < 2 * (D.shape[1] + 1):
            trend = "constant"
        self.trend_ = trend
        F, _ = _trend_basis(self._unit(D), trend)
        self.beta_f_, *_ = np.linalg.lstsq(F, C, rcond=None)  # least-squares trend, Eq. (A.2)
        R = C - F @ self.beta_f_
        self.gp_ = self._fit_gps(D, R, report)
        self.D_ = D
        self.C_ = C
        return self

    def _fit_gps(self, D: Array, R: Array, report: Callable[[int], None]) -> KrigingRegressor:
        """One kriging model per POD coefficient (Eq. 2.58) with its own hyperparameters.

        The likelihood is maximized (with ``n_restarts`` restarts) for the first
        coefficient; each further coefficient starts from the previous optimum (warm start,
        no restarts); beyond ``optimized_modes`` the hyperparameters are inherited. One
        multi-output :class:`KrigingRegressor` with the fixed hyperparameters then serves
        every prediction. ``report(done)`` follows :meth:`fit`'s ``progress`` count.
        """
        rng = as_rng(self.rng)
        n_p = R.shape[1]
        thetas: list[Array] = []
        for j in range(n_p):
            if j >= self.optimized_modes:
                thetas.append(thetas[-1])
                continue
            gp = KrigingRegressor(kernel=self.kernel, bounds=self.bounds_,
                                  n_restarts=self.n_restarts if j == 0 else 0,
                                  theta0=None if j == 0 else thetas[-1][None, :],
                                  rng=rng).fit(D, R[:, j])
            thetas.append(gp.theta_[0])
            report(j + 2)
        gp = KrigingRegressor(kernel=self.kernel, bounds=self.bounds_,
                              theta0=np.array(thetas), optimize=False).fit(D, R)
        report(min(self.optimized_modes, n_p) + 2)
        return gp

    def _unit(self, D: Array) -> Array:
        lo, hi = self.bounds_[:, 0], self.bounds_[:, 1]
        return (D - lo) / np.where(hi > lo, hi - lo, 1.0)

    @property
    def n_modes(self) -> int:
        return int(self.pod_.modes_.shape[1])

    def predict_coefficients(self, D: Array, gradient: bool = False):
        """POD coefficients y^krg(d) (N, N_p) and, with ``gradient``, dy^krg/dd (N, N_p, N_d)."""
        D = np.atleast_2d(np.asarray(D, float))
        F, dF = _trend_basis(self._unit(D), self.trend_, gradient)
        if not gradient:
            return F @ self.beta_f_ + self.gp_.predict_mean(D)[0], None
        mean, dmean = self.gp_.predict_mean(D, gradient=True)
        lo, hi = self.bounds_[:, 0], self.bounds_[:, 1]
        inv = 1.0 / np.where(hi > lo, hi - lo, 1.0)
        # d f/d d beta_f, sum over q as one BLAS product
        dtrend = np.matmul(dF.transpose(0, 2, 1), self.beta_f_).transpose(0, 2, 1) * inv
        return F @ self.beta_f_ + mean, dtrend + dmean  # Eq. (2.59)

    def predict(self, D: Array) -> Array:
        """Full-order prediction y^pk(d) = y_mean + Psi_P y^krg(d), shape (N, n)."""
        return self.pod_.reconstruct(self.predict_coefficients(D)[0])

    def predict_jacobian(self, d: Array) -> tuple[Array, Array]:
        """y^pk at one input (n,) and dy^pk/dd (n, N_d), Eq. (2.59)."""
        c, dc = self.predict_coefficients(np.asarray(d, float)[None, :], gradient=True)
        return self.pod_.reconstruct(c)[0], self.pod_.modes_ @ dc[0]

    # -- persistence -------------------------------------------------------------------
    def state(self, prefix: str) -> dict[str, np.ndarray]:
        """Plain arrays describing the fitted model (no objects)."""
        return {
            f"{prefix}_mean": self.pod_.mean_, f"{prefix}_modes": self.pod_.modes_,
            f"{prefix}_singular_values": self.pod_.singular_values_,
            f"{prefix}_inputs": self.D_, f"{prefix}_coefficients": self.C_,
            f"{prefix}_beta_f": self.beta_f_, f"{prefix}_theta": self.gp_.theta_,
            f"{prefix}_bounds": self.bounds_, f"{prefix}_trend": np.array(self.trend_),
            f"{prefix}_kernel": np.array(self.kernel),
            f"{prefix}_nugget": np.array(self.gp_.nugget),
            f"{prefix}_tolerance": np.array(self.tolerance),
        }

    @classmethod
    def from_state(cls, data: dict[str, np.ndarray], prefix: str) -> PodKriging:
        """Rebuild from :meth:`state` arrays (kriging refactorized, hyperparameters fixed)."""
        g = lambda key: data[f"{prefix}_{key}"]  # noqa: E731
        self = cls(tolerance=float(g("tolerance")),
                   kernel=cast(KernelName, str(g("kernel"))),  # checked below
                   trend=str(g("trend")))
        self.trend_ = str(g("trend"))
        if self.trend_ not in ("constant", "linear", "quadratic") or self.kernel not in (
                "rbf", "matern52"):
            raise InputError("rom", f"unknown kriging settings in {prefix!r}")
        pod = PodBasis(self.tolerance)
        pod.mean_, pod.modes_ = np.asarray(g("mean"), float), np.asarray(g("modes"), float)
        pod.singular_values_ = np.asarray(g("singular_values"), float)
        pod.error_ = float("nan")
        self.pod_ = pod
        self.D_, self.C_ = np.asarray(g("inputs"), float), np.asarray(g("coefficients"), float)
        self.bounds_ = np.asarray(g("bounds"), float)
        self.beta_f_ = np.asarray(g("beta_f"), float)
        n_s, n_d = self.D_.shape
        n, n_p = pod.modes_.shape
        n_f = _trend_basis(np.zeros((1, n_d)), self.trend_)[0].shape[1]
        theta = np.asarray(g("theta"), float)
        expected = {"mean": (n,), "coefficients": (n_s, n_p), "bounds": (n_d, 2),
                    "beta_f": (n_f, n_p), "theta": (n_p, n_d + 1)}
        got = {"mean": pod.mean_.shape, "coefficients": self.C_.shape,
               "bounds": self.bounds_.shape, "beta_f": self.beta_f_.shape, "theta": theta.shape}
        for key, shape in expected.items():
            if got[key] != shape:
                raise InputError("rom", f"{prefix}_{key} has shape {got[key]}, expected {shape}")
        R = self.C_ - _trend_basis(self._unit(self.D_), self.trend_)[0] @ self.beta_f_
        self.gp_ = KrigingRegressor(kernel=self.kernel, bounds=self.bounds_,
                                    nugget=float(g("nugget")), theta0=theta,
                                    optimize=False).fit(self.D_, R)
        return self
