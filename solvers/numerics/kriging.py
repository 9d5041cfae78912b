"""Kriging (Gaussian-process) regression with analytic input gradients.

Dissertation Appendix A.1: the prediction at ``x`` is Gaussian, Eq. (A.5), with mean and
variance from Eq. (A.6) and input gradients from Eq. (A.8). Here the regression part is an
ordinary-kriging constant absorbed by standardizing the outputs (``f = 1``, ``beta_f`` = the
sample mean), so Eq. (A.6a) reduces to ``mu = y_mean + y_std * r(x)^T R^{-1} y_s`` and
Eq. (A.6b) to ``sigma^2 = y_std^2 * (c - r^T R^{-1} r)`` (the ``t``-term of the universal
kriging variance is dropped, as in scikit-learn's GaussianProcessRegressor).

Hyperparameters (a constant amplitude ``c`` and one length scale per input, i.e. a
diagonal ``Theta`` in Eq. (A.4)) are found by maximizing the log marginal likelihood with
scikit-learn's :class:`~sklearn.gaussian_process.GaussianProcessRegressor` (L-BFGS-B in
log space, with seeded random restarts). Prediction and its gradients are evaluated by the
vectorized NumPy code below so that the mean, the standard deviation and their gradients
come from one consistent set of formulas.

Inputs are scaled to the unit box ``[0, 1]^d`` (from ``bounds`` or the data range) and each
output column is standardized. A multi-output ``y`` of shape ``(n, m)`` gets ``m``
independent models (one hyperparameter set each) that share the scaled inputs; this is what
the multi-objective optimizer (Eq. (6.9), diagonal covariance) and the POD-kriging ROM
(one model per POD coefficient) need.
"""
from __future__ import annotations

import copy
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from hypate.solvers.numerics.random import as_rng
from scipy.linalg import cho_solve, cholesky, solve_triangular
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.exceptions import ConvergenceWarning
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel, Matern

__all__ = ["KrigingRegressor", "KERNELS", "KernelName", "ColumnFit", "Mapper", "fit_together"]

#: Kernels offered (anisotropic, times a constant amplitude).
KERNELS: tuple[str, ...] = ("matern52", "rbf")
KernelName = Literal["matern52", "rbf"]

_SQRT5 = np.sqrt(5.0)


def kernel_matrix(
    U: np.ndarray,
    V: np.ndarray,
    amplitude: float,
    length_scale: np.ndarray,
    kernel: str,
    *,
    gradient: bool = False,
) -> tuple[np.ndarray, np.ndarray | None]:
    """Correlation ``c r(u, v)`` (Eq. (A.3)-(A.4)) and its gradient with respect to ``u``.

    Parameters
    ----------
    U : ndarray of shape (N, d)
        Query points (unit-box coordinates).
    V : ndarray of shape (n, d)
        Training points (unit-box coordinates).
    amplitude : float
        Constant kernel ``c``.
    length_scale : ndarray of shape (d,)
        Anisotropic length scales.
    kernel : {"matern52", "rbf"}
        Matern-5/2 ``c (1 + sqrt5 r + 5 r^2 / 3) exp(-sqrt5 r)`` or squared exponential
        ``c exp(-r^2 / 2)`` with ``r^2 = sum_j (u_j - v_j)^2 / l_j^2``.
    gradient : bool
        Also return ``dk/du`` of shape (N, n, d).

    Returns
    -------
    K : ndarray of shape (N, n)
    dK : ndarray of shape (N, n, d) or None
    """
    D = U[:, None, :] - V[None, :, :]
    inv_l2 = 1.0 / np.asarray(length_scale) ** 2
    r2 = np.einsum("Nnd,d,Nnd->Nn", D, inv_l2, D)
    if kernel == "matern52":
        r = np.sqrt(r2)
        e = np.exp(-_SQRT5 * r)
        K = amplitude * (1.0 + _SQRT5 * r + (5.0 / 3.0) * r2) * e
        if not gradient:
            return K, None
        # d/du_j: c * (-5/3) (1 + sqrt5 r) exp(-sqrt5 r) (u_j - v_j) / l_j^2 (smooth at r = 0)
        fac = -(5.0 / 3.0) * amplitude * (1.0 + _SQRT5 * r) * e
        return K, fac[..., None] * D * inv_l2
    if kernel == "rbf":
        K = amplitude * np.exp(-0.5 * r2)
        if not gradient:
            return K, None
        return K, -K[..., None] * D * inv_l2
    raise ValueError(f"kernel must be one of {KERNELS}, got {kernel!r}")


def _sk_kernel(kernel: str, theta: np.ndarray, length_scale_bounds: tuple[float, float],
               amplitude_bounds: tuple[float, float]):
    c = ConstantKernel(np.exp(theta[0]), amplitude_bounds)
    ls = np.exp(theta[1:])
    if kernel == "matern52":
        return c * Matern(ls, length_scale_bounds, nu=2.5)
    return c * RBF(ls, length_scale_bounds)


@dataclass(frozen=True)
class ColumnFit:
    """The likelihood optimization of one output column: plain data, so that a process
    pool can run it (:func:`fit_together`). Calling it returns ``(theta, lml)``."""

    U: np.ndarray                 # training inputs in the unit box, (n, d)
    Ys: np.ndarray                # the standardized outputs, (n, m)
    column: int                   # the one fitted here
    start: np.ndarray             # starting log-hyperparameters [log c, log l]
    seed: int                     # of the random restarts
    kernel: str
    nugget: float
    n_restarts: int
    length_scale_bounds: tuple[float, float]
    amplitude_bounds: tuple[float, float]

    def __call__(self) -> tuple[np.ndarray, float]:
        """Maximize the log marginal likelihood (sklearn, log-space L-BFGS-B + restarts);
        a singular correlation matrix keeps the start (likelihood NaN)."""
        d = self.U.shape[1]
        lsb, ab = np.log(self.length_scale_bounds), np.log(self.amplitude_bounds)
        lo = np.r_[ab[0], np.full(d, lsb[0])]
        hi = np.r_[ab[1], np.full(d, lsb[1])]
        start = np.clip(self.start, lo, hi)
        gpr = GaussianProcessRegressor(
            _sk_kernel(self.kernel, start, self.length_scale_bounds, self.amplitude_bounds),
            alpha=self.nugget, n_restarts_optimizer=self.n_restarts, normalize_y=False,
            random_state=np.random.RandomState(self.seed), copy_X_train=False)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)
            try:
                # a column view, as a serial fit takes it: a contiguous copy (what a
                # pickled column would be) rounds differently, at 1e-13
                gpr.fit(self.U, self.Ys[:, self.column])
            except np.linalg.LinAlgError:
                return start, float("nan")
        return gpr.kernel_.theta.copy(), float(gpr.log_marginal_likelihood_value_)


def _run(task: ColumnFit) -> tuple[np.ndarray, float]:
    return task()


#: ``map(fn, items)`` returning ``[fn(item) for item in items]`` in order, e.g. spread over
#: the worker processes of an optimization run.
Mapper = Callable[[Callable[[Any], Any], Sequence[Any]], list]


def fit_together(jobs: Sequence[tuple[KrigingRegressor, np.ndarray, np.ndarray]],
                 mapper: Mapper | None = None) -> list[KrigingRegressor]:
    """Fit several regressors (``(regressor, X, y)`` each) with one ``mapper`` call over
    all their columns' likelihood optimizations.

    The columns are independent and their restart seeds are drawn (in order) before any
    is optimized, so the result does not depend on how ``mapper`` spreads them: the same
    hyperparameters as ``regressor.fit(X, y)`` one after another.
    """
    plans = [reg._column_fits(X, y) for reg, X, y in jobs]
    tasks = [t for plan in plans for t in plan if isinstance(t, ColumnFit)]
    done = iter((mapper or (lambda fn, items: [fn(i) for i in items]))(_run, tasks))
    fitted = []
    for (reg, _, _), plan in zip(jobs, plans):
        results = []
        for t in plan:
            if isinstance(t, ColumnFit):
                theta, lml = next(done)
                if np.isnan(lml):
                    warnings.warn("likelihood optimization failed (singular correlation "
                                  "matrix); keeping the starting hyperparameters",
                                  RuntimeWarning, stacklevel=3)
                results.append((theta, lml))
            else:
                results.append((t, float("nan")))
        fitted.append(reg._finish_fit(results))
    return fitted


class KrigingRegressor(RegressorMixin, BaseEstimator):
    """Ordinary kriging with analytic gradients of the predictive mean and std.

    Parameters
    ----------
    kernel : {"matern52", "rbf"}
        Anisotropic Matern-5/2 or RBF correlation, times a constant amplitude.
    bounds : array-like of shape (d, 2) or None
        Input box mapped to ``[0, 1]^d``; ``None`` uses the training data range.
    n_restarts : int
        Random restarts of the marginal-likelihood optimization (in addition to the
        default start ``c = 1``, ``l = 0.5``, or ``theta0`` when given).
    nugget : float
        Jitter added to the diagonal of the standardized correlation matrix.
    length_scale_bounds : tuple of float
        Bounds of each length scale, in unit-box coordinates.
    amplitude_bounds : tuple of float
        Bounds of the constant amplitude (outputs are standardized).
    theta0 : array-like of shape (m, d + 1) or None
        Starting log-hyperparameters ``[log c, log l_1, ..., log l_d]`` per output (a warm
        start). ``None`` starts at ``c = 1``, ``l = 0.5``.
    optimize : bool
        ``False`` keeps ``theta0`` fixed (no likelihood optimization).
    rng : numpy.random.Generator, int or None
        Seed for the restarts.

    Attributes
    ----------
    X_train_ : ndarray of shape (n, d)
    U_train_ : ndarray of shape (n, d)
        Training inputs in unit-box coordinates.
    lower_, scale_ : ndarray of shape (d,)
        ``u = (x - lower_) / scale_``.
    y_mean_, y_std_ : ndarray of shape (m,)
    theta_ : ndarray of shape (m, d + 1)
        Fitted log-hyperparameters ``[log c, log l]``.
    amplitude_ : ndarray of shape (m,)
    length_scale_ : ndarray of shape (m, d)
    L_ : ndarray of shape (m, n, n)
        Lower Cholesky factors of ``c R + nugget I``.
    alpha_ : ndarray of shape (m, n)
        ``(c R + nugget I)^{-1} y_s`` (``beta_r`` of Eq. (A.7c), standardized).
    log_marginal_likelihood_ : ndarray of shape (m,)
    n_outputs_ : int
    """

    def __init__(
        self,
        kernel: KernelName = "matern52",
        bounds: np.ndarray | None = None,
        n_restarts: int = 2,
        nugget: float = 1e-8,
        length_scale_bounds: tuple[float, float] = (1e-2, 1e2),
        amplitude_bounds: tuple[float, float] = (1e-2, 1e2),
        theta0: np.ndarray | None = None,
        optimize: bool = True,
        rng: np.random.Generator | int | None = None,
    ) -> None:
        self.kernel = kernel
        self.bounds = bounds
        self.n_restarts = n_restarts
        self.nugget = nugget
        self.length_scale_bounds = length_scale_bounds
        self.amplitude_bounds = amplitude_bounds
        self.theta0 = theta0
        self.optimize = optimize
        self.rng = rng

    # ------------------------------------------------------------------ fitting
    def fit(self, X: np.ndarray, y: np.ndarray) -> KrigingRegressor:
        """Fit one kriging model per output column.

        Parameters
        ----------
        X : ndarray of shape (n, d)
        y : ndarray of shape (n,) or (n, m)

        Returns
        -------
        self
        """
        return fit_together([(self, X, y)])[0]

    def _column_fits(self, X: np.ndarray, y: np.ndarray) -> list[ColumnFit | np.ndarray]:
        """The first half of a fit: check and scale the data, and return each column's
        likelihood optimization (a :class:`ColumnFit`), or its fixed hyperparameters."""
        if self.kernel not in KERNELS:
            raise ValueError(f"kernel must be one of {KERNELS}, got {self.kernel!r}")
        X = np.atleast_2d(np.asarray(X, dtype=float))
        y = np.asarray(y, dtype=float)
        self._y_1d = y.ndim == 1
        Y = y[:, None] if y.ndim == 1 else y
        n, d = X.shape
        if Y.shape[0] != n:
            raise ValueError(f"X has {n} rows but y has {Y.shape[0]}")
        if not (np.all(np.isfinite(X)) and np.all(np.isfinite(Y))):
            raise ValueError("X and y must be finite")
        m = Y.shape[1]
        if self.bounds is None:
            lo, hi = X.min(axis=0), X.max(axis=0)
        else:
            b = np.asarray(self.bounds, dtype=float)
            lo, hi = b[:, 0], b[:, 1]
        span = hi - lo
        self.lower_ = lo
        self.scale_ = np.where(span > 0, span, 1.0)
        self.X_train_ = X.copy()
        self.U_train_ = (X - self.lower_) / self.scale_
        self.y_mean_ = Y.mean(axis=0)
        std = Y.std(axis=0)
        self.y_std_ = np.where(std > 0, std, 1.0)
        Ys = (Y - self.y_mean_) / self.y_std_
        self.n_outputs_ = m
        self.n_features_in_ = d

        self._Ys_ = Ys
        rng = as_rng(self.rng)
        theta0 = None if self.theta0 is None else np.atleast_2d(np.asarray(self.theta0, float))
        if theta0 is not None and theta0.shape != (m, d + 1):
            raise ValueError(f"theta0 must have shape {(m, d + 1)}, got {theta0.shape}")
        if not self.optimize and theta0 is None:
            raise ValueError("optimize=False needs theta0")
        tasks: list[ColumnFit | np.ndarray] = []
        for j in range(m):
            start = theta0[j] if theta0 is not None else np.r_[0.0, np.full(d, np.log(0.5))]
            if self.optimize and n >= 2:
                # the seeds are drawn in column order, before any column is optimized: a
                # mapped (parallel) fit draws exactly what a serial one does
                tasks.append(ColumnFit(self.U_train_, Ys, j, np.asarray(start, float),
                                       int(rng.integers(2**31)), self.kernel, self.nugget,
                                       self.n_restarts, self.length_scale_bounds,
                                       self.amplitude_bounds))
            else:
                tasks.append(np.asarray(start, float))
        return tasks

    def _finish_fit(self, results: Sequence[tuple[np.ndarray, float]]) -> KrigingRegressor:
        """Take the columns' hyperparameters and factorize (the second half of a fit)."""
        self.theta_ = np.array([theta for theta, _ in results])
        self.log_marginal_likelihood_ = np.array([lml for _, lml in results])
        Ys = self._Ys_
        del self._Ys_
        self._factorize(Ys)
        return self

    def _factorize(self, Ys: np.ndarray) -> None:
        n = self.U_train_.shape[0]
        m = self.n_outputs_
        self.amplitude_ = np.exp(self.theta_[:, 0])
        self.length_scale_ = np.exp(self.theta_[:, 1:])
        self.L_ = np.empty((m, n, n))
        self.alpha_ = np.empty((m, n))
        for j in range(m):
            K, _ = kernel_matrix(self.U_train_, self.U_train_, self.amplitude_[j],
                                 self.length_scale_[j], self.kernel)
            K[np.diag_indices_from(K)] += self.nugget
            jitter = 0.0
            for _attempt in range(6):
                try:
                    L = cholesky(K + jitter * np.eye(n), lower=True, check_finite=False)
                    break
                except np.linalg.LinAlgError:
                    jitter = max(10.0 * jitter, 1e-8 * self.amplitude_[j])
            else:  # pragma: no cover - K + 1e-3 c I is always positive definite
                raise np.linalg.LinAlgError("correlation matrix is not positive definite")
            if jitter:
                warnings.warn(f"added jitter {jitter:.1e} to the correlation matrix",
                              RuntimeWarning, stacklevel=3)
            self.L_[j] = L
            self.alpha_[j] = cho_solve((L, True), Ys[:, j], check_finite=False)

    def condition(self, X: np.ndarray, y: np.ndarray) -> KrigingRegressor:
        """Return a copy refitted to new data with the same hyperparameters (no optimization).

        Used for fantasies (kriging believer / constant liar batches).

        Parameters
        ----------
        X : ndarray of shape (n', d)
        y : ndarray of shape (n',) or (n', m)
        """
        self._check_fitted()
        X = np.atleast_2d(np.asarray(X, dtype=float))
        y = np.asarray(y, dtype=float)
        Y = y[:, None] if y.ndim == 1 else y
        if Y.shape != (X.shape[0], self.n_outputs_):
            raise ValueError(f"y must have {self.n_outputs_} column(s) and {X.shape[0]} rows")
        new = copy.copy(self)
        new.theta0 = self.theta_.copy()
        new.optimize = False
        new.X_train_ = X.copy()
        new.U_train_ = (X - self.lower_) / self.scale_
        # keep the output standardization the hyperparameters were fitted with
        new._factorize((Y - self.y_mean_) / self.y_std_)
        return new

    # --------------------------------------------------------------- prediction
    def _check_fitted(self) -> None:
        if not hasattr(self, "alpha_"):
            raise AttributeError("KrigingRegressor is not fitted; call fit(X, y) first")

    def _predict_all(self, X: np.ndarray, gradient: bool):
        """Mean, std (N, m) and, if requested, their gradients (N, m, d) in x."""
        self._check_fitted()
        X = np.atleast_2d(np.asarray(X, dtype=float))
        U = (X - self.lower_) / self.scale_
        N, d = U.shape
        m = self.n_outputs_
        mu = np.empty((N, m))
        var = np.empty((N, m))
        dmu = np.empty((N, m, d)) if gradient else None
        dvar = np.empty((N, m, d)) if gradient else None
        for j in range(m):
            K, dK = kernel_matrix(U, self.U_train_, self.amplitude_[j], self.length_scale_[j],
                                  self.kernel, gradient=gradient)
            mu[:, j] = K @ self.alpha_[j]  # Eq. (A.6a), standardized
            V = solve_triangular(self.L_[j], K.T, lower=True, check_finite=False)
            var[:, j] = self.amplitude_[j] - np.einsum("nN,nN->N", V, V)  # Eq. (A.6b)
            if gradient:
                assert dmu is not None and dvar is not None and dK is not None  # with the gradient
                dmu[:, j] = np.einsum("Nnd,n->Nd", dK, self.alpha_[j])  # Eq. (A.8a)
                W = solve_triangular(self.L_[j], V, lower=True, trans=1, check_finite=False)
                dvar[:, j] = -2.0 * np.einsum("nN,Nnd->Nd", W, dK)  # Eq. (A.8b)
        var = np.maximum(var, 0.0)
        sd_s = np.sqrt(var)
        mean = self.y_mean_ + self.y_std_ * mu
        std = self.y_std_ * sd_s
        if not gradient:
            return mean, std, None, None
        inv_scale = 1.0 / self.scale_
        dmean = self.y_std_[None, :, None] * dmu * inv_scale
        # d sigma = d(sigma^2) / (2 sigma); zero where sigma vanishes (at data points)
        safe = sd_s > 1e-12
        fac = np.where(safe, 0.5 / np.where(safe, sd_s, 1.0), 0.0)
        dstd = (self.y_std_ * fac)[:, :, None] * dvar * inv_scale
        return mean, std, dmean, dstd

    def _shape(self, a):
        if a is None:
            return None
        return a[:, 0] if self._y_1d else a

    def predict(self, X: np.ndarray, return_std: bool = False):
        """Predictive mean (and standard deviation), Eq. (A.6).

        Parameters
        ----------
        X : ndarray of shape (N, d)
        return_std : bool

        Returns
        -------
        mean : ndarray of shape (N,) or (N, m)
        std : ndarray of shape (N,) or (N, m), only if ``return_std``
        """
        mean, std, _, _ = self._predict_all(X, gradient=False)
        if return_std:
            return self._shape(mean), self._shape(std)
        return self._shape(mean)

    def predict_gradient(self, X: np.ndarray) -> np.ndarray:
        """Gradient of the predictive mean with respect to x, Eq. (A.8a).

        Returns
        -------
        ndarray of shape (N, d) or (N, m, d)
        """
        return self._shape(self._predict_all(X, gradient=True)[2])

    def predict_std_gradient(self, X: np.ndarray) -> np.ndarray:
        """Gradient of the predictive standard deviation, from Eq. (A.8b) as
        ``d sigma = d sigma^2 / (2 sigma)`` (zero where ``sigma = 0``).

        Returns
        -------
        ndarray of shape (N, d) or (N, m, d)
        """
        return self._shape(self._predict_all(X, gradient=True)[3])

    def predict_with_gradients(self, X: np.ndarray):
        """Mean, std and both gradients in one pass, always multi-output shaped.

        Returns
        -------
        mean, std : ndarray of shape (N, m)
        dmean, dstd : ndarray of shape (N, m, d)
        """
        return self._predict_all(X, gradient=True)

    def predict_mean(self, X: np.ndarray, gradient: bool = False):
        """Predictive mean (N, m) and, with ``gradient``, its gradient (N, m, d): the mean
        part of :meth:`predict_with_gradients` without the variance. Outputs with equal
        length scales share one kernel evaluation (the amplitude factors out of ``K`` and
        ``dK``), so a model whose outputs mostly share their hyperparameters (POD-kriging
        beyond its separately optimized modes) costs a few kernel matrices, not one each.

        Returns
        -------
        mean : ndarray of shape (N, m)
        dmean : ndarray of shape (N, m, d), or None
        """
        self._check_fitted()
        X = np.atleast_2d(np.asarray(X, dtype=float))
        U = (X - self.lower_) / self.scale_
        N, d = U.shape
        m = self.n_outputs_
        mu = np.empty((N, m))
        dmu = np.empty((N, m, d)) if gradient else None
        groups: dict[bytes, list[int]] = {}
        for j in range(m):
            groups.setdefault(np.asarray(self.length_scale_[j], float).tobytes(), []).append(j)
        for cols in groups.values():
            K, dK = kernel_matrix(U, self.U_train_, 1.0, self.length_scale_[cols[0]],
                                  self.kernel, gradient=gradient)
            A = np.stack([self.amplitude_[j] * self.alpha_[j] for j in cols], axis=1)
            mu[:, cols] = K @ A  # Eq. (A.6a), standardized
            if gradient:
                assert dmu is not None and dK is not None  # with the gradient
                # Eq. (A.8a): sum_n dK[N, n, d] A[n, g] as one BLAS product (an einsum
                # here was 40x slower: 1 ms a call, a tenth of a CFD-ROM simulation)
                dmu[:, cols] = np.matmul(dK.transpose(0, 2, 1), A).transpose(0, 2, 1)
        mean = self.y_mean_ + self.y_std_ * mu
        if not gradient:
            return mean, None
        return mean, self.y_std_[None, :, None] * dmu * (1.0 / self.scale_)

    def predict_moments(self, X: np.ndarray):
        """Mean and std, always multi-output shaped ``(N, m)`` (no gradients)."""
        mean, std, _, _ = self._predict_all(X, gradient=False)
        return mean, std

    def leave_one_out(self) -> tuple[np.ndarray, np.ndarray]:
        """Leave-one-out predictions at the training points, hyperparameters fixed.

        The model without point ``i`` predicts there (Eq. (A.6) on the other ``n - 1``
        points) ``y_i - alpha_i / [K^-1]_ii`` with variance ``1 / [K^-1]_ii`` minus the
        nugget (the closed form of Dubrule 1983; Rasmussen & Williams, Eq. (5.12)), all
        ``n`` at the cost of one inverse of the factorized ``K``. At a training point the
        interpolating model itself says nothing (its std is ~0); this says how well the
        rest of the data predict it.

        Returns
        -------
        mean, std : ndarray of shape (n, m)
        """
        self._check_fitted()
        n, m = self.U_train_.shape[0], self.n_outputs_
        mean, std = np.empty((n, m)), np.empty((n, m))
        eye = np.eye(n)
        for j in range(m):
            L = self.L_[j]
            Kinv_diag = np.diag(cho_solve((L, True), eye, check_finite=False))
            ys = L @ (L.T @ self.alpha_[j])  # the standardized training outputs
            mean[:, j] = ys - self.alpha_[j] / Kinv_diag
            std[:, j] = np.sqrt(np.maximum(1.0 / Kinv_diag - self.nugget, 0.0))
        return self.y_mean_ + self.y_std_ * mean, self.y_std_ * std
