"""Fluid ROM: POD-kriging with correction and scaling (Dissertation Sec. 2.4, App. A-B).

Building blocks
---------------
* :class:`PodBasis` -- snapshot POD (Eqs. A.9-A.13) of mean-centred snapshots,
  ``y ~ y_mean + Psi_P y_P``; the number of modes is the smallest with the energy error
  of Eq. (A.14) below ``tolerance`` (default 0.5 %).
* :class:`PodKriging` -- Eq. (2.56): one kriging model per POD coefficient (the project's
  :class:`hypate.solvers.numerics.kriging.KrigingRegressor`, ordinary kriging on scikit-learn) on top of a
  polynomial regression trend fitted by least squares (the ``beta_f^T f(d)`` part of
  Eqs. 2.58/A.2; the GP then interpolates the residual, ``beta_r^T r(d)``); analytic
  Jacobian ``dy/dd`` (Eq. 2.59 = trend gradient + Eq. A.8a).
* :class:`RomFluid` -- the ROM as a :class:`~solvers.aero.base.FluidModel`:

  - *scaled and corrected* ROM (Sec. 2.4.4): inputs ``d = [xi a, mean T_w]`` (Eq. 2.64)
    at the reference condition and geometry; heat-flux correction (Eq. 2.65, Eckert with
    piston-theory edge pressure); pressure correction "pt" (Eq. 2.67) or "bl"
    (Eqs. 2.68-2.72 with the Cox-Crabtree ratio R_delta, Eq. 2.70); unsteady correction by
    piston theory (Eqs. 2.55, 2.73); Jacobians (Eqs. 2.74-2.76 and their heat-flux and
    wall-temperature analogues);
  - *conventional* ROM (Eq. 2.62): inputs ``d = [M, p_inf, T_inf, a, mean T_w]``, no
    correction (for comparison), same unsteady correction.

Projection of the wall state onto the ROM inputs
------------------------------------------------
The panel geometry of a ROM is its reference geometry (length ``a_ref``, width ``b_ref``,
leading-edge distance ``L_le,ref``, thickness ``h_ref``). A panel evaluated with the ROM must
be geometrically similar: its scale ratio ``xi = L_ref / L`` is ``L_le,ref / L_le`` (read from
``points.x_le - x cos(beta) - y sin(beta)``) and every point maps to the reference point
``xi (x, y)``. The deformation modes are ``phi_k(x, y) = sin(m pi xi x / a_ref)
sin(n pi xi y / b_ref)`` (``n = 0``: uniform across) and the modal amplitudes are the
area-weighted least-squares projection of ``w`` on the points:

    q = P w,   P = (Phi^T W Phi)^{-1} Phi^T W,   W = diag(points.weights),

so that the ROM input is ``a = xi q / h_ref`` (amplitudes of the reference-size deformation
in units of the reference thickness; Eq. 2.64) and ``dd/dw = (xi / h_ref) P``. The mean wall
temperature is the area-weighted mean ``mean T_w = sum(W T_w) / sum(W)``. The ROM outputs
live on the reference grid; on other points they are interpolated (piecewise linear in
``x``, bilinear in ``(x, y)``), so the coupled solvers may use any fluid grid.

External snapshots (``[source] kind = "snapshots"``)
----------------------------------------------------
*NPZ* (``numpy.savez``; loaded with ``allow_pickle=False``):

* ``inputs`` -- float array (N_s, N_S + 1): the modal amplitudes ``a_1 .. a_NS`` in units of
  the panel thickness, in the order of the ``[[modes]]`` of the build file, then the
  uniform wall temperature (K);
* ``pressure`` -- float array (N_s, n): ``p - p_inf`` (Pa) on the points;
* ``heat_flux`` -- float array (N_s, n): heat flux into the wall (W/m^2);
* ``x``, ``y`` -- optional float arrays (n,): point coordinates (m, panel frame, x from the
  panel's leading edge); checked against the build file's grid (tolerance 1e-6 a).

The points are the ``[grid]`` of the build file, ordered ``k = j n_x + i`` (x fastest).

*CSV* (header row required, one row per sample and point, any row order):
``sample,a1,...,aNS,T_w,x,y,pressure,heat_flux`` -- ``sample`` an integer id, the inputs
repeated on each row of a sample (they must agree), ``x``/``y`` the point (m) which must
match a grid point, ``pressure`` ``p - p_inf`` (Pa), ``heat_flux`` (W/m^2).
Every sample must give every grid point exactly once.

Persistence
-----------
:meth:`RomFluid.save` writes a ``.npz`` without object arrays (``FORMAT_VERSION``, kind,
reference condition, panel geometry, grid, modes, training ranges, POD bases and kriging
data; a SHA-256 digest of the content). :func:`load_rom` validates version, digest, shapes
and finiteness and raises :class:`~solvers.errors.InputError` otherwise. Loading refits the
kriging Cholesky factors with the stored hyperparameters (no optimization).

Sample planning (Sec. 2.4.5, App. B)
------------------------------------
:func:`olh_plan` (scipy.stats.qmc Latin hypercube, centred-discrepancy optimized),
:func:`generate_samples` (chunks submitted to a ``concurrent.futures.Executor``),
:func:`smart_order` (kNN graph -> n_C balanced groups by k-means -> minimum spanning tree per
group -> breadth-first order from the sample nearest to the naive solution; each sample
restarts from the nearest sample computed before it in its group, or from the naive
solution; total restart distance Eq. 2.82) and :func:`write_plan_csv`.
"""
from __future__ import annotations

import csv
import hashlib
import math
import warnings
import zipfile
import zlib
from collections.abc import Sequence
from concurrent.futures import Executor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import scipy.sparse as sp
import scipy.sparse.csgraph as csgraph
from hypate.solvers.aero.analytic import (
    BoundaryLayerShape,
    eckert_with_derivatives,
    piston_pressure,
)
from hypate.solvers.aero.base import Array, FluidLoads, FluidModel, SurfacePoints, SurfaceState
from hypate.solvers.aero.shock_expansion import ShockExpansionFluid
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition
from hypate.solvers.numerics.kriging import KrigingRegressor
from hypate.solvers.numerics.random import as_rng, latin_hypercube
from sklearn.cluster import KMeans
from sklearn.neighbors import kneighbors_graph

__all__ = [
    "FORMAT_VERSION", "PodBasis", "PodKriging", "RomGeometry", "RomFluid", "load_rom",
    "save_rom", "build_rom", "build_rom_from_config", "olh_plan", "generate_samples",
    "smart_order", "SmartOrder", "write_plan_csv", "read_snapshots", "nrmse",
    "eq76_wall_temperature",
]

#: Version of the NPZ layout written by :func:`save_rom`.
FORMAT_VERSION = 1
#: Relative tolerance of the geometric-similarity check of a panel against the ROM.
GEOMETRY_TOL = 1e-3
#: Up to this many surface points the (dense, low-rank) Jacobians are returned as CSR
#: matrices so that solvers can assemble them like the analytic models' sparse blocks;
#: above, as dense ndarrays.
SPARSE_JACOBIAN_MAX = 600


# ======================================================================================
# POD and POD-kriging
# ======================================================================================
#: Smallest absolute pressure ratio kept by the BL correction (vacuum floor).
_VACUUM = 1e-9


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

    def __init__(self, tolerance: float = 0.005, kernel: str = "rbf", trend: str = "linear",
                 n_restarts: int = 2, rng: np.random.Generator | int | None = None,
                 optimized_modes: int = 3) -> None:
        self.tolerance = tolerance
        self.optimized_modes = optimized_modes
        self.kernel = kernel
        self.trend = trend
        self.n_restarts = n_restarts
        self.rng = rng

    def fit(self, D: Array, Y: Array, bounds: Array | None = None) -> PodKriging:
        """Fit on inputs ``D`` (N_s, N_d) and snapshots ``Y`` (N_s, n).

        ``bounds`` (N_d, 2) define the unit box of the trend and the kriging (default: data
        range).
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
        self.gp_ = self._fit_gps(D, R)
        self.D_ = D
        self.C_ = C
        return self

    def _fit_gps(self, D: Array, R: Array) -> KrigingRegressor:
        """One kriging model per POD coefficient (Eq. 2.58) with its own hyperparameters.

        The likelihood is maximized (with ``n_restarts`` restarts) for the first
        coefficient; each further coefficient starts from the previous optimum (warm start,
        no restarts); beyond ``optimized_modes`` the hyperparameters are inherited. One
        multi-output :class:`KrigingRegressor` with the fixed hyperparameters then serves
        every prediction.
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
        return KrigingRegressor(kernel=self.kernel, bounds=self.bounds_,
                                theta0=np.array(thetas), optimize=False).fit(D, R)

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
            return F @ self.beta_f_ + self.gp_.predict_moments(D)[0], None
        mean, _, dmean, _ = self.gp_.predict_with_gradients(D)
        lo, hi = self.bounds_[:, 0], self.bounds_[:, 1]
        inv = 1.0 / np.where(hi > lo, hi - lo, 1.0)
        dtrend = np.einsum("Nqd,qp->Npd", dF, self.beta_f_) * inv  # d f/d d beta_f
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
        self = cls(tolerance=float(g("tolerance")), kernel=str(g("kernel")),
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


# ======================================================================================
# geometry: modes, points, scaling
# ======================================================================================
@dataclass(frozen=True)
class RomGeometry:
    """Reference panel of a ROM: geometry, fluid grid and deformation modes.

    Attributes
    ----------
    kind : {"2d", "3d"}
    length, width, leading_edge_length, thickness : float
        a_ref, b_ref, L_le,ref, h_ref (m).
    flow_angle : float
        beta (rad).
    n_x, n_y : int
        Reference grid (edges included; "2d": n_y = 1 at mid-span).
    modes : ndarray of int, shape (N_S, 2)
        (m, n) half-wave numbers of each deformation mode.
    """

    kind: str
    length: float
    width: float
    leading_edge_length: float
    thickness: float
    flow_angle: float
    n_x: int
    n_y: int
    modes: np.ndarray

    @property
    def n_modes(self) -> int:
        return int(self.modes.shape[0])

    def points(self, scale: float = 1.0) -> SurfacePoints:
        """Grid of the panel scaled by ``1/scale`` (``scale = xi = L_ref/L``)."""
        return SurfacePoints.grid(self.length / scale, self.width / scale,
                                  self.leading_edge_length / scale, self.n_x, self.n_y,
                                  self.flow_angle)

    def mode_shapes(self, x_ref: Array, y_ref: Array, slope: bool = False) -> Array:
        """Mode shapes phi (n, N_S) at reference coordinates, or d phi / d s_ref along the
        flow (per metre of the reference panel) when ``slope``."""
        m = self.modes[:, 0][None, :].astype(float)
        nn = self.modes[:, 1][None, :].astype(float)
        kx = m * np.pi / self.length
        ky = nn * np.pi / self.width
        X, Y = np.asarray(x_ref, float)[:, None], np.asarray(y_ref, float)[:, None]
        if self.kind == "2d":
            Y = np.full_like(X, 0.5 * self.width)
        sx, cx = np.sin(kx * X), np.cos(kx * X)
        sy = np.where(nn > 0, np.sin(ky * Y), 1.0)
        cy = np.where(nn > 0, np.cos(ky * Y), 0.0)
        if not slope:
            return sx * sy
        c, s = math.cos(self.flow_angle), math.sin(self.flow_angle)
        dy = 0.0 if self.kind == "2d" else s * sx * ky * cy
        return c * kx * cx * sy + dy

    def deformation(self, amplitudes: Array, scale: float = 1.0) -> tuple[Array, Array]:
        """Displacement and streamwise slope (m, n) on :meth:`points` (``scale``) for modal
        amplitudes (m, N_S) in units of the *reference* thickness (geometric scaling: the
        scaled panel is ``1/scale`` as thick and deflects ``1/scale`` as much)."""
        A = np.atleast_2d(np.asarray(amplitudes, float))
        pts = self.points(scale)
        xr, yr = pts.x * scale, pts.y * scale
        h = self.thickness / scale
        w = h * A @ self.mode_shapes(xr, yr).T
        ws = h * scale * A @ self.mode_shapes(xr, yr, slope=True).T
        return w, ws

    def as_array(self) -> np.ndarray:
        return np.array([self.length, self.width, self.leading_edge_length, self.thickness,
                         self.flow_angle, self.n_x, self.n_y], float)


def eq76_wall_temperature(x_norm: Array, b: Array, t_range: Sequence[float] = (200.0, 900.0)
                          ) -> Array:
    """Wall temperature of data set 3 (Eq. 7.6), ``T = (b1 + b2 x + b5 sin 2 pi x) 1e3`` K,
    rescaled into ``t_range`` by Eqs. (7.4)-(7.5).

    Parameters
    ----------
    x_norm : ndarray of shape (n,)
        x / a on the panel.
    b : ndarray of shape (m, 3)
        (b1, b2, b5) per sample (Table 7.1: b1 in [0.2, 0.9], b2, b5 in [-0.3, 0.3]).

    Returns
    -------
    ndarray of shape (m, n)
    """
    b = np.atleast_2d(np.asarray(b, float))
    x = np.asarray(x_norm, float)[None, :]
    T = 1e3 * (b[:, :1] + b[:, 1:2] * x + b[:, 2:3] * np.sin(2.0 * np.pi * x))
    t_lo, t_hi = t_range
    T_max = np.minimum(t_hi, T.max(axis=1, keepdims=True))
    T_min = np.maximum(t_lo, T.min(axis=1, keepdims=True))
    span = np.maximum(T.max(axis=1, keepdims=True) - T.min(axis=1, keepdims=True), 1e-12)
    # Eqs. (7.4)-(7.5) read literally rescale the variation by (T_max - T_min)/(T_w,max -
    # T_w,min) and shift the minimum to t_lo; applied only where the profile leaves the range
    outside = (T.max(axis=1, keepdims=True) > t_hi) | (T.min(axis=1, keepdims=True) < t_lo)
    fac = np.minimum((T_max - T_min) / span, (t_hi - t_lo) / span)
    T_new = (T - T.min(axis=1, keepdims=True)) * fac + np.maximum(T_min, t_lo)
    T_new = np.minimum(T_new, t_hi)
    return np.where(outside, T_new, T)


def _interpolation_matrix(geom: RomGeometry, x_ref: Array, y_ref: Array) -> sp.csr_matrix:
    """Piecewise-(bi)linear interpolation from the reference grid to points (n_pts, n_rom)."""
    xs = np.linspace(0.0, geom.length, geom.n_x)

    def weights_1d(grid: Array, v: Array) -> tuple[Array, Array]:
        i = np.clip(np.searchsorted(grid, v) - 1, 0, grid.size - 2)
        t = np.clip((v - grid[i]) / (grid[i + 1] - grid[i]), 0.0, 1.0)
        return i, t

    n = x_ref.size
    ix, tx = weights_1d(xs, x_ref)
    if geom.n_y == 1:
        rows = np.repeat(np.arange(n), 2)
        cols = np.stack([ix, ix + 1], axis=1).ravel()
        vals = np.stack([1.0 - tx, tx], axis=1).ravel()
    else:
        ys = np.linspace(0.0, geom.width, geom.n_y)
        iy, ty = weights_1d(ys, y_ref)
        rows = np.repeat(np.arange(n), 4)
        cols = np.stack([iy * geom.n_x + ix, iy * geom.n_x + ix + 1, (iy + 1) * geom.n_x + ix,
                         (iy + 1) * geom.n_x + ix + 1], axis=1).ravel()
        vals = np.stack([(1 - ty) * (1 - tx), (1 - ty) * tx, ty * (1 - tx), ty * tx],
                        axis=1).ravel()
    return sp.csr_matrix((vals, (rows, cols)), shape=(n, geom.n_x * geom.n_y))


# ======================================================================================
# the ROM fluid model
# ======================================================================================
@dataclass
class _PointCache:
    points: SurfacePoints
    scale: float
    interp: sp.csr_matrix
    identity: bool
    projection: Array  # (N_S, n): q = P w (m)
    mean_weights: Array  # (n,): mean T_w = mean_weights @ T_w
    x_le_ref: Array


class RomFluid(FluidModel):
    """The fluid ROM as a drop-in :class:`FluidModel` (Sec. 2.4.4).

    Parameters
    ----------
    geometry : RomGeometry
        Reference panel, grid and deformation modes.
    reference : FlowCondition
        Reference condition c_ref of the samples.
    pressure_model, heat_model : PodKriging
        Fitted POD-kriging models of ``p - p_inf`` and of the heat flux.
    kind : {"scaled", "conventional"}
        "scaled": inputs ``[xi a, mean T_w]`` (Eq. 2.64) with correction and scaling;
        "conventional": inputs ``[M, p_inf, T_inf, a, mean T_w]`` (Eq. 2.62), no correction.
    correction : {"bl", "pt"}
        Pressure correction: boundary-layer (Eq. 2.72) or piston-theory (Eq. 2.67).
    unsteady : bool
        Add the piston-theory unsteady correction (Eq. 2.55).
    regime : {"turbulent", "laminar"}
        Regime of the Eckert heat-flux correction (Eq. 2.65).
    scale : float or None
        Geometric scale ratio xi = L_ref / L of the evaluated panel; ``None`` infers it from
        the points (``L_le,ref / L_le``).
    source : dict
        Description of the sample source (``{"kind": ..., "boundary_layer": ..., "regime":
        ...}``), kept for ``rom check``.
    edge_pressure : {"rom", "pt"}
        Edge pressure of the Eckert fluxes in the heat-flux correction (Eq. 2.65): the
        corrected ROM pressure on the panel over the ROM pressure on the reference ("rom",
        default), or piston theory on both ("pt", Eq. 2.44 as written).
    """

    def __init__(self, geometry: RomGeometry, reference: FlowCondition,
                 pressure_model: PodKriging, heat_model: PodKriging, kind: str = "scaled",
                 correction: str = "bl", unsteady: bool = True, regime: str = "turbulent",
                 scale: float | None = None, source: dict[str, Any] | None = None,
                 edge_pressure: str = "rom") -> None:
        if edge_pressure not in ("rom", "pt"):
            raise InputError("rom.edge_pressure", "must be 'rom' or 'pt'")
        self.edge_pressure = edge_pressure
        if kind not in ("scaled", "conventional"):
            raise InputError("rom.kind", "must be 'scaled' or 'conventional'")
        if correction not in ("bl", "pt"):
            raise InputError("rom.correction", "must be 'bl' or 'pt'")
        self.geometry = geometry
        self.reference = reference
        self.pressure_model = pressure_model
        self.heat_model = heat_model
        self.kind = kind
        self.correction = correction
        self.unsteady = unsteady
        self.regime = regime
        self.scale = scale
        self.source = dict(source or {"kind": "unknown"})
        self.name = f"rom-{kind}-{correction}"
        self._cache: _PointCache | None = None

    # -- inputs ---------------------------------------------------------------------------
    @property
    def n_inputs(self) -> int:
        return self.geometry.n_modes + (4 if self.kind == "conventional" else 1)

    @property
    def input_bounds(self) -> Array:
        """Training ranges of the inputs (N_d, 2)."""
        return self.pressure_model.bounds_

    def input_names(self) -> list[str]:
        modes = [f"a{k + 1}" for k in range(self.geometry.n_modes)]
        cond = ["mach", "pressure", "temperature"] if self.kind == "conventional" else []
        return cond + modes + ["T_w"]

    def with_options(self, correction: str | None = None, unsteady: bool | None = None,
                     scale: float | None = None, edge_pressure: str | None = None
                     ) -> RomFluid:
        """A copy with other correction settings (shares the fitted models)."""
        return RomFluid(self.geometry, self.reference, self.pressure_model, self.heat_model,
                        self.kind, correction or self.correction,
                        self.unsteady if unsteady is None else unsteady, self.regime,
                        scale if scale is not None else self.scale, self.source,
                        edge_pressure or self.edge_pressure)

    def _points(self, points: SurfacePoints) -> _PointCache:
        c = self._cache
        if c is not None and c.points is points:
            return c
        g = self.geometry
        if g.kind == "2d" and points.shape[1] != 1:
            raise InputError("rom", "this ROM describes a 2D panel (one line of points); the "
                             f"case has {points.shape[1]} spanwise points")
        if abs(points.flow_angle - g.flow_angle) > 1e-9:
            raise InputError("rom", f"flow angle {math.degrees(points.flow_angle):g} deg does "
                             f"not match the ROM's {math.degrees(g.flow_angle):g} deg")
        cb, sb = math.cos(points.flow_angle), math.sin(points.flow_angle)
        l_le = points.x_le - cb * points.x - (sb * points.y if g.kind == "3d" else 0.0)
        L_le = float(np.mean(l_le))
        if L_le <= 0.0 or np.ptp(l_le) > 1e-9 * max(L_le, 1.0):
            raise InputError("rom", "cannot read the leading-edge distance from the points")
        scale = self.scale if self.scale is not None else g.leading_edge_length / L_le
        if abs(scale * L_le - g.leading_edge_length) > GEOMETRY_TOL * g.leading_edge_length:
            raise InputError("rom", f"panel mismatch: L_le = {L_le:g} m at scale {scale:g} is "
                             f"not the ROM's {g.leading_edge_length:g} m / scale")
        xr = points.x * scale
        yr = points.y * scale if g.kind == "3d" else np.full(points.n, 0.5 * g.width)
        tol = GEOMETRY_TOL * g.length
        if xr.min() < -tol or xr.max() > g.length + tol or abs(xr.max() - g.length) > 0.05 * g.length:
            raise InputError("rom", f"panel mismatch: the panel length {points.x.max():g} m "
                             f"x scale {scale:g} is not the ROM's {g.length:g} m (the ROM "
                             "needs a geometrically similar panel: same a/L_le)")
        if g.kind == "3d" and (yr.min() < -tol or yr.max() > g.width + tol
                               or abs(yr.max() - g.width) > 0.05 * g.width):
            raise InputError("rom", f"panel mismatch: the panel width x scale {scale:g} is not "
                             f"the ROM's {g.width:g} m")
        ref_pts = g.points(1.0)
        identity = points.n == ref_pts.n and np.allclose(xr, ref_pts.x, atol=tol) and (
            g.kind == "2d" or np.allclose(yr, ref_pts.y, atol=tol))
        interp = sp.identity(points.n, format="csr") if identity else _interpolation_matrix(
            g, np.clip(xr, 0, g.length), np.clip(yr, 0, g.width))
        Phi = g.mode_shapes(xr, yr)
        W = points.weights
        G = Phi.T @ (W[:, None] * Phi)
        try:
            P = np.linalg.solve(G, Phi.T * W[None, :])
        except np.linalg.LinAlgError:
            raise InputError("rom", "the points cannot resolve the ROM's deformation modes "
                             "(refine the fluid grid)") from None
        self._cache = _PointCache(points, float(scale), interp, identity, P, W / W.sum(),
                                  points.x_le * scale)
        return self._cache

    def inputs(self, points: SurfacePoints, state: SurfaceState, flow: FlowCondition) -> Array:
        """The ROM input d for a wall state (Eq. 2.64 or 2.62)."""
        c = self._points(points)
        a = c.scale / self.geometry.thickness * (c.projection @ np.asarray(state.displacement))
        T_mean = float(c.mean_weights @ np.asarray(state.wall_temperature))
        if self.kind == "conventional":
            return np.r_[flow.mach, flow.pressure, flow.temperature, a, T_mean]
        return np.r_[a, T_mean]

    def _check_range(self, d: Array) -> None:
        lo, hi = self.input_bounds[:, 0], self.input_bounds[:, 1]
        span = np.where(hi > lo, hi - lo, 1.0)
        out = (d < lo - 0.05 * span) | (d > hi + 0.05 * span)
        if np.any(out):
            names = [n for n, o in zip(self.input_names(), out) if o]
            warnings.warn(f"ROM extrapolation: inputs {', '.join(names)} outside the training "
                          "ranges (by > 5 %)", RuntimeWarning, stacklevel=3)

    # -- evaluation ------------------------------------------------------------------------
    def evaluate(self, points: SurfacePoints, state: SurfaceState, flow: FlowCondition,
                 jacobians: bool = False) -> FluidLoads:
        """Pressure ``p - p_inf`` and heat flux, Eq. (2.73); Jacobians Eqs. (2.74)-(2.76)."""
        c = self._points(points)
        g = self.geometry
        n = points.n
        xi = c.scale
        ws = np.asarray(state.slope, float)
        wdot = np.asarray(state.velocity, float)
        T_w = np.asarray(state.wall_temperature, float)
        if np.any(T_w <= 0.0) or not np.all(np.isfinite(T_w)):
            raise InputError("state.wall_temperature", "must be positive and finite (K)")
        d = self.inputs(points, state, flow)
        self._check_range(d)
        n_s = g.n_modes
        i_a = slice(3, 3 + n_s) if self.kind == "conventional" else slice(0, n_s)
        # POD-kriging outputs on the points, Eqs. (2.56), (2.59)
        p_r, dp_r = self.pressure_model.predict_jacobian(d)
        q_r, dq_r = self.heat_model.predict_jacobian(d)
        I = c.interp
        p_pk, q_pk = I @ p_r, I @ q_r
        dp_pk, dq_pk = I @ dp_r, I @ dq_r  # (n, N_d)
        dd_dw = (xi / g.thickness) * c.projection  # (N_S, n)
        dd_dT = c.mean_weights  # d(mean T_w)/dT_w

        gam, M, p_inf, a_inf = flow.gamma, flow.mach, flow.pressure, flow.speed_of_sound
        cref = self.reference
        zero_n = np.zeros(n)
        if self.kind == "conventional":
            if abs(xi - 1.0) > GEOMETRY_TOL:
                raise InputError("rom", "a conventional ROM has no geometric scaling; use the "
                                 "reference panel (scale 1)")
            p_st, q = p_pk, q_pk
            dpst_dws = zero_n
            dpst_dd = dp_pk
            dpst_dTloc = None
            dq_dd = dq_pk
            dq_dws = zero_n
            dq_dTloc = np.zeros((n, n))
        else:
            T_bar = d[-1]
            # -- pressure correction
            fac = (p_inf * M) / (cref.pressure * cref.mach)
            if self.correction == "pt":  # Eq. (2.67)
                p_st = fac * p_pk
                dpst_dd = fac * dp_pk
                dpst_dws = zero_n
                dpst_dTloc = None
            else:  # BL correction, Eqs. (2.68)-(2.72)
                S = points.streamwise_derivative
                bl = BoundaryLayerShape(flow)
                bl_r = BoundaryLayerShape(cref)
                s_c, s_c_dT, s_c_dTs = bl.slope(points.x_le, T_w, S @ T_w)
                s_r, s_r_dT, _ = bl_r.slope(c.x_le_ref, np.full(n, T_bar), zero_n)
                # Eq. (2.70) with the local wall temperature (and its gradient) on the panel
                # and the uniform mean on the reference: d delta/ds is dimensionless, so the
                # ratio compares the scaled panel at x with the reference at xi x
                R = s_c / s_r
                dR_dT = s_c_dT / s_r
                dR_dTs = s_c_dTs / s_r
                dR_dTbar = -s_c * s_r_dT / s_r**2
                ge = (cref.gamma - 1.0) / (2.0 * cref.gamma)
                # vacuum floor (as piston theory, Eq. 2.30): states with a negative absolute
                # pressure only occur in Newton overshoots; there p = -p_inf, derivative 0
                base_pk = 1.0 + p_pk / cref.pressure
                vac = base_pk <= _VACUUM
                base_pk = np.where(vac, _VACUUM, base_pk)
                E = base_pk**ge - 1.0
                B = 1.0 + (1.0 - R) * 0.5 * (gam - 1.0) * M * ws + R * (M / cref.mach) * E
                vac = vac | (B <= _VACUUM)
                B = np.where(vac, _VACUUM, B)
                ex = 2.0 * gam / (gam - 1.0)
                p_st = p_inf * B**ex - p_inf  # Eq. (2.72)
                Lam_u = p_inf * ex * B ** (ex - 1.0)  # Eq. (2.76a) times p_inf 2 gamma/(gamma-1)
                dB_dpk = R * (M / cref.mach) * ge * base_pk ** (ge - 1.0) / cref.pressure
                dB_dR = -0.5 * (gam - 1.0) * M * ws + (M / cref.mach) * E
                dpst_dd = (Lam_u * dB_dpk)[:, None] * dp_pk  # Eq. (2.75), second term
                dpst_dd[:, -1] += Lam_u * dB_dR * dR_dTbar
                dpst_dws = Lam_u * (1.0 - R) * 0.5 * (gam - 1.0) * M  # Eq. (2.75), first term
                dpst_dTloc = (np.diag(Lam_u * dB_dR * dR_dT)
                              + (sp.diags(Lam_u * dB_dR * dR_dTs) @ S).toarray())
                if np.any(vac):
                    p_st = np.where(vac, -p_inf, p_st)
                    dpst_dd[vac] = 0.0
                    dpst_dws = np.where(vac, 0.0, dpst_dws)
                    dpst_dTloc[vac] = 0.0
            # -- heat-flux correction, Eq. (2.65): ratio of Eckert fluxes; the edge pressure
            # (Eq. 2.44: the wall pressure) is the corrected ROM pressure on the panel and
            # the ROM pressure on the reference ("rom"), or piston theory on both ("pt")
            if self.edge_pressure == "rom":
                pe, pe_r = p_st, p_pk
                dpe_dd, dpe_dws, dpe_dTloc = dpst_dd, dpst_dws, dpst_dTloc
                dper_dd, dper_dws = dp_pk, zero_n
            else:
                pe, dpe_m = piston_pressure(M * ws, p_inf, gam, "pt")
                pe_r, dper_m = piston_pressure(cref.mach * ws, cref.pressure, cref.gamma, "pt")
                dpe_dd = dper_dd = np.zeros_like(dp_pk)
                dpe_dws, dper_dws, dpe_dTloc = dpe_m * M, dper_m * cref.mach, None
            num, dnum_dp, dnum_dT = eckert_with_derivatives(flow, p_inf + pe, T_w, points.x_le,
                                                            self.regime)
            den, dden_dp, dden_dT = eckert_with_derivatives(
                cref, cref.pressure + pe_r, np.full(n, T_bar), c.x_le_ref, self.regime)
            if np.any(np.abs(den) < 1e-9 * np.max(np.abs(den))):
                warnings.warn("heat-flux correction: the reference Eckert flux vanishes at "
                              "some points (wall at the adiabatic temperature)",
                              RuntimeWarning, stacklevel=2)
            r = num / den
            q = r * q_pk
            a_num = q_pk * dnum_dp / den  # dq / d p_e (panel)
            a_den = -q * dden_dp / den  # dq / d p_e (reference)
            dq_dd = r[:, None] * dq_pk + a_num[:, None] * dpe_dd + a_den[:, None] * dper_dd
            dq_dd[:, -1] += -q * dden_dT / den
            dq_dws = a_num * dpe_dws + a_den * dper_dws
            dq_dTloc = np.diag(q_pk * dnum_dT / den)
            if dpe_dTloc is not None:
                dq_dTloc = dq_dTloc + a_num[:, None] * dpe_dTloc
        # -- unsteady correction, Eq. (2.55)
        if self.unsteady:
            p1, dp1 = piston_pressure(M * ws + wdot / a_inf, p_inf, gam, "pt")
            p0, dp0 = piston_pressure(M * ws, p_inf, gam, "pt")
            p_uns = p1 - p0
            dpu_dws = M * (dp1 - dp0)
            dpu_dwdot = dp1 / a_inf
        else:
            p_uns, dpu_dws, dpu_dwdot = zero_n, zero_n, zero_n
        loads = FluidLoads(pressure=p_st + p_uns, heat_flux=q)
        if not jacobians:
            return loads
        # -- Jacobians (dense; the deformation parts are rank N_S, the mean-T_w parts rank 1)
        dp_dw = dpst_dd[:, i_a] @ dd_dw  # Eqs. (2.74a), (2.75)
        dq_dw = dq_dd[:, i_a] @ dd_dw
        dp_dT = np.outer(dpst_dd[:, -1], dd_dT)
        if dpst_dTloc is not None:
            dp_dT += dpst_dTloc
        dq_dT = np.outer(dq_dd[:, -1], dd_dT) + dq_dTloc
        jac = {
            "dp_dw": dp_dw, "dp_dws": np.diag(dpst_dws + dpu_dws),
            "dp_dwdot": np.diag(dpu_dwdot), "dp_dTw": dp_dT,
            "dq_dw": dq_dw, "dq_dws": np.diag(dq_dws), "dq_dwdot": np.zeros((n, n)),
            "dq_dTw": dq_dT,
        }
        if n <= SPARSE_JACOBIAN_MAX:  # small grids: CSR so solvers can assemble directly
            jac = {k: sp.csr_matrix(v) for k, v in jac.items()}
        loads.jacobians = jac
        return loads

    # -- persistence -------------------------------------------------------------------------
    def save(self, path: str | Path) -> None:
        """Write the ROM to ``path`` (``.npz``, no pickled objects); see :func:`save_rom`."""
        save_rom(self, path)


def _digest(arrays: dict[str, np.ndarray]) -> str:
    h = hashlib.sha256()
    for key in sorted(arrays):
        a = np.ascontiguousarray(arrays[key])
        h.update(key.encode())
        h.update(str(a.dtype).encode())
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()


def save_rom(rom: RomFluid, path: str | Path) -> None:
    """Save a ROM as NPZ (plain arrays only; ``numpy.load(..., allow_pickle=False)`` reads it).

    Keys: ``format_version``, ``kind``, ``correction``, ``regime``, ``reference``
    ([M, p, T, gamma, R, Pr, altitude or nan]), ``geometry`` ([a, b, L_le, h, beta, n_x,
    n_y]), ``panel_kind``, ``modes`` (N_S, 2), ``input_names``, ``input_bounds`` (N_d, 2)
    (training ranges), ``source`` ([kind, boundary_layer, regime] as strings), the
    ``pressure_*`` and ``heat_flux_*`` POD-kriging arrays and ``digest`` (SHA-256 of the
    rest).
    """
    ref = rom.reference
    g = rom.geometry
    arrays: dict[str, np.ndarray] = {
        "format_version": np.array(FORMAT_VERSION),
        "kind": np.array(rom.kind), "correction": np.array(rom.correction),
        "regime": np.array(rom.regime),
        "reference": np.array([ref.mach, ref.pressure, ref.temperature, ref.gamma,
                               ref.gas_constant, ref.prandtl,
                               np.nan if ref.altitude is None else ref.altitude]),
        "geometry": g.as_array(), "panel_kind": np.array(g.kind),
        "modes": np.asarray(g.modes, np.int64),
        "input_names": np.array(rom.input_names()),
        "input_bounds": rom.input_bounds,
        "source": np.array([str(rom.source.get("kind", "unknown")),
                            str(rom.source.get("boundary_layer", True)),
                            str(rom.source.get("regime", rom.regime))]),
    }
    arrays.update(rom.pressure_model.state("pressure"))
    arrays.update(rom.heat_model.state("heat_flux"))
    arrays["digest"] = np.array(_digest(arrays))
    path = Path(path)
    with open(path, "wb") as fh:
        np.savez_compressed(fh, **arrays)


def load_rom(path: str | Path, correction: str | None = None, unsteady: bool = True,
             scale: float | None = None, regime: str | None = None) -> RomFluid:
    """Load a ROM written by :func:`save_rom`.

    ``correction``, ``unsteady``, ``scale`` are :class:`RomFluid` options; ``regime``
    (the Eckert regime of the heat-flux correction) defaults to the one stored.

    Every problem (missing or unreadable file, wrong format version, digest mismatch,
    missing keys, inconsistent shapes, non-finite values) raises :class:`InputError`.
    """
    path = Path(path)
    field = f"rom:{path}"
    if not path.is_file():
        raise InputError(field, "file not found")
    try:
        with np.load(path, allow_pickle=False) as npz:
            data = {k: npz[k] for k in npz.files}
    except (zipfile.BadZipFile, zlib.error, EOFError) as exc:
        raise InputError(field, f"corrupted ROM file ({exc})") from None
    except (OSError, ValueError, KeyError) as exc:
        raise InputError(field, f"not a readable ROM file ({type(exc).__name__}: {exc})") \
            from None
    try:
        version = int(data["format_version"])
        if version != FORMAT_VERSION:
            raise InputError(field, f"format version {version} is not supported (this "
                             f"version reads {FORMAT_VERSION})")
        digest = str(data.pop("digest"))
        if _digest(data) != digest:
            raise InputError(field, "corrupted ROM file (content digest mismatch)")
        ref = data["reference"].astype(float)
        geo = data["geometry"].astype(float)
        if ref.shape != (7,) or geo.shape != (7,):
            raise InputError(field, "reference/geometry arrays have the wrong shape")
        reference = FlowCondition(mach=ref[0], pressure=ref[1], temperature=ref[2],
                                  gamma=ref[3], gas_constant=ref[4], prandtl=ref[5],
                                  altitude=None if np.isnan(ref[6]) else float(ref[6]))
        modes = np.asarray(data["modes"], np.int64)
        if modes.ndim != 2 or modes.shape[1] != 2 or modes.shape[0] < 1:
            raise InputError(field, "modes must have shape (N_S, 2)")
        geometry = RomGeometry(str(data["panel_kind"]), geo[0], geo[1], geo[2], geo[3],
                               geo[4], int(geo[5]), int(geo[6]), modes)
        if geometry.kind not in ("2d", "3d") or min(geo[:4]) <= 0:
            raise InputError(field, "invalid panel geometry")
        kind = str(data["kind"])
        p_model = PodKriging.from_state(data, "pressure")
        q_model = PodKriging.from_state(data, "heat_flux")
        src = [str(s) for s in data["source"]]
    except KeyError as exc:
        raise InputError(field, f"missing key {exc.args[0]!r} (not a hypate ROM file?)") \
            from None
    except (TypeError, ValueError) as exc:
        if isinstance(exc, InputError):
            raise
        raise InputError(field, f"malformed ROM file ({exc})") from None
    n = geometry.n_x * geometry.n_y
    n_d = geometry.n_modes + (4 if kind == "conventional" else 1)
    for name, model in (("pressure", p_model), ("heat_flux", q_model)):
        if model.pod_.modes_.shape[0] != n:
            raise InputError(field, f"{name} modes have {model.pod_.modes_.shape[0]} points; "
                             f"the grid has {n}")
        if model.D_.shape[1] != n_d:
            raise InputError(field, f"{name} inputs have {model.D_.shape[1]} columns; a "
                             f"{kind} ROM with {geometry.n_modes} modes needs {n_d}")
        for arr in (model.pod_.mean_, model.pod_.modes_, model.D_, model.C_, model.beta_f_):
            if not np.all(np.isfinite(arr)):
                raise InputError(field, f"{name} arrays contain non-finite values")
    source = {"kind": src[0], "boundary_layer": src[1] == "True", "regime": src[2]}
    return RomFluid(geometry, reference, p_model, q_model, kind,
                    correction or str(data["correction"]), unsteady,
                    regime or str(data["regime"]), scale, source)


# ======================================================================================
# samples: plans, generation, external snapshots, smart ordering
# ======================================================================================
def olh_plan(bounds: Array, n: int, rng: np.random.Generator | int | None = None) -> Array:
    """Optimal Latin hypercube plan (Sec. 2.4.5; scipy.stats.qmc, centred-discrepancy
    optimized) of ``n`` points in the box ``bounds`` (d, 2)."""
    return latin_hypercube(n, np.asarray(bounds, float), rng, optimization="random-cd")


def _source_chunk(geometry: RomGeometry, source_opts: dict[str, Any], flow: FlowCondition,
                  scale: float, amplitudes: Array, wall_temperature: Array
                  ) -> tuple[Array, Array]:
    """Worker: shock-expansion samples for a chunk (module-level for process pools)."""

    src = ShockExpansionFluid(boundary_layer=source_opts.get("boundary_layer", True),
                              regime=source_opts.get("regime", "turbulent"))
    pts = geometry.points(scale)
    _, ws = geometry.deformation(amplitudes, scale)
    return src.evaluate_batch(pts, ws, 0.0, wall_temperature, flow)


def generate_samples(geometry: RomGeometry, amplitudes: Array, wall_temperature: Array,
                     flow: FlowCondition, scale: float = 1.0,
                     source: dict[str, Any] | None = None, executor: Executor | None = None,
                     chunk_size: int = 50) -> tuple[Array, Array]:
    """Source snapshots (pressure ``p - p_inf`` and heat flux, each (N, n)) for modal
    amplitudes (N, N_S) in units of the reference thickness and wall temperatures (N,)
    uniform or (N, n), on the panel scaled by ``1/scale``.

    Chunks of ``chunk_size`` samples go to ``executor`` (any ``concurrent.futures.Executor``,
    e.g. a ``ProcessPoolExecutor`` or a dask ``Client``); ``None`` runs them in-process.
    """
    A = np.atleast_2d(np.asarray(amplitudes, float))
    N = A.shape[0]
    n = geometry.n_x * geometry.n_y
    T = np.asarray(wall_temperature, float)
    T = np.repeat(T[:, None], n, axis=1) if T.ndim == 1 else T
    if T.shape != (N, n):
        raise InputError("samples", f"wall temperatures must have shape ({N},) or ({N}, {n})")
    opts = dict(source or {"kind": "shock-expansion"})
    if opts.get("kind", "shock-expansion") != "shock-expansion":
        raise InputError("source.kind", "only the built-in 'shock-expansion' source can "
                         "generate samples")
    bounds = list(range(0, N, chunk_size)) + [N]
    jobs = [(A[s:e], T[s:e]) for s, e in zip(bounds[:-1], bounds[1:])]
    if executor is None:
        parts = [_source_chunk(geometry, opts, flow, scale, a, t) for a, t in jobs]
    else:
        futures = [executor.submit(_source_chunk, geometry, opts, flow, scale, a, t)
                   for a, t in jobs]
        parts = [f.result() for f in futures]
    return np.concatenate([p for p, _ in parts]), np.concatenate([q for _, q in parts])


def read_snapshots(path: str | Path, geometry: RomGeometry) -> tuple[Array, Array, Array]:
    """External snapshots (NPZ or CSV; layout in the module docstring).

    Returns
    -------
    inputs : ndarray of shape (N_s, N_S + 1)
    pressure, heat_flux : ndarray of shape (N_s, n)
    """
    path = Path(path)
    field = f"source.path ({path})"
    if not path.is_file():
        raise InputError(field, "file not found")
    pts = geometry.points(1.0)
    n, n_s = pts.n, geometry.n_modes
    tol = 1e-6 * geometry.length
    if path.suffix.lower() == ".npz":
        try:
            with np.load(path, allow_pickle=False) as npz:
                data = {k: npz[k] for k in npz.files}
        except (zipfile.BadZipFile, zlib.error, EOFError, OSError, ValueError) as exc:
            raise InputError(field, f"not a readable NPZ file ({type(exc).__name__})") from None
        missing = [k for k in ("inputs", "pressure", "heat_flux") if k not in data]
        if missing:
            raise InputError(field, f"missing arrays {', '.join(missing)}")
        D = np.asarray(data["inputs"], float)
        P = np.asarray(data["pressure"], float)
        Q = np.asarray(data["heat_flux"], float)
        for key, ref in (("x", pts.x), ("y", pts.y)):
            if key in data:
                v = np.asarray(data[key], float)
                if v.shape != (n,) or (key == "x" or geometry.kind == "3d") and np.max(
                        np.abs(v - ref)) > tol:
                    raise InputError(field, f"{key} does not match the build file's grid "
                                     f"({geometry.n_x} x {geometry.n_y} points, edges included)")
    elif path.suffix.lower() == ".csv":
        D, P, Q = _read_snapshots_csv(path, geometry, field)
    else:
        raise InputError(field, "snapshots must be a .npz or .csv file")
    N = D.shape[0] if D.ndim == 2 else -1
    if D.ndim != 2 or D.shape[1] != n_s + 1:
        raise InputError(field, f"inputs must have shape (N_s, {n_s + 1}) = modal amplitudes "
                         f"a1..a{n_s} and the wall temperature; got {D.shape}")
    for name, Y in (("pressure", P), ("heat_flux", Q)):
        if Y.shape != (N, n):
            raise InputError(field, f"{name} must have shape ({N}, {n}); got {Y.shape}")
    if not all(np.all(np.isfinite(a)) for a in (D, P, Q)):
        raise InputError(field, "snapshots contain non-finite values")
    if np.any(D[:, -1] <= 0.0):
        raise InputError(field, "wall temperatures must be > 0 K")
    return D, P, Q


def _read_snapshots_csv(path: Path, geometry: RomGeometry, field: str
                        ) -> tuple[Array, Array, Array]:
    n_s = geometry.n_modes
    cols = ["sample"] + [f"a{k + 1}" for k in range(n_s)] + ["T_w", "x", "y", "pressure",
                                                            "heat_flux"]
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            reader = csv.reader(fh)
            header = [h.strip() for h in next(reader)]
            rows = [r for r in reader if r]
    except (OSError, UnicodeDecodeError, StopIteration) as exc:
        raise InputError(field, f"cannot read CSV ({type(exc).__name__})") from None
    if header != cols:
        raise InputError(field, f"CSV header must be {','.join(cols)}")
    try:
        arr = np.array(rows, dtype=float)
    except ValueError:
        raise InputError(field, "CSV contains non-numeric values") from None
    if arr.ndim != 2 or arr.shape[1] != len(cols):
        raise InputError(field, "CSV rows have the wrong number of columns")
    pts = geometry.points(1.0)
    n = pts.n
    tol = 1e-6 * geometry.length
    ix = np.rint(arr[:, 1 + n_s + 1] / geometry.length * (geometry.n_x - 1)).astype(int)
    if geometry.n_y > 1:
        iy = np.rint(arr[:, 1 + n_s + 2] / geometry.width * (geometry.n_y - 1)).astype(int)
    else:
        iy = np.zeros(arr.shape[0], int)
    k = iy * geometry.n_x + ix
    if np.any((k < 0) | (k >= n)) or np.any(np.abs(pts.x[np.clip(k, 0, n - 1)]
                                                   - arr[:, 1 + n_s + 1]) > tol):
        raise InputError(field, "CSV points do not match the build file's grid")
    ids, inv = np.unique(arr[:, 0], return_inverse=True)
    N = ids.size
    D = np.full((N, n_s + 1), np.nan)
    P = np.full((N, n), np.nan)
    Q = np.full((N, n), np.nan)
    counts = np.zeros((N, n), int)
    np.add.at(counts, (inv, k), 1)
    if np.any(counts != 1):
        raise InputError(field, "every sample must give every grid point exactly once")
    P[inv, k] = arr[:, -2]
    Q[inv, k] = arr[:, -1]
    D[inv] = arr[:, 1:2 + n_s]
    ins = arr[:, 1:2 + n_s]
    if np.any(np.abs(ins - D[inv]) > 1e-9 * (1.0 + np.abs(ins))):
        raise InputError(field, "the inputs of a sample differ between its rows")
    return D, P, Q


@dataclass
class SmartOrder:
    """A smart-ordered sample plan (App. B).

    Attributes
    ----------
    group : ndarray of int, shape (N,)
        Group (CPU set) of each sample.
    position : ndarray of int, shape (N,)
        Position of the sample within its group's sequence.
    parent : ndarray of int, shape (N,)
        Sample each one restarts from (-1: the naive solution w_0).
    distance : ndarray of shape (N,)
        d_CFD to the restart solution, Eq. (2.81).
    total_distance : float
        Eq. (2.82) for this ordering.
    naive_distance : float
        Eq. (2.82) when every sample restarts from w_0.
    """

    group: np.ndarray
    position: np.ndarray
    parent: np.ndarray
    distance: np.ndarray
    total_distance: float
    naive_distance: float

    @property
    def ratio(self) -> float:
        """naive_distance / total_distance (> 1: the smart ordering saves)."""
        return self.naive_distance / self.total_distance

    def sequence(self, g: int) -> np.ndarray:
        """Sample indices of group ``g`` in computing order."""
        idx = np.flatnonzero(self.group == g)
        return idx[np.argsort(self.position[idx])]


def _balanced_groups(X: Array, n_groups: int, rng: np.random.Generator) -> Array:
    """Partition into ``n_groups`` equal-sized groups: k-means centroids, then a greedy
    capacity-constrained assignment by increasing distance (a METIS-free graph partition)."""

    N = X.shape[0]
    if n_groups == 1:
        return np.zeros(N, int)
    km = KMeans(n_clusters=n_groups, n_init=10, random_state=int(rng.integers(2**31))).fit(X)
    dist = np.linalg.norm(X[:, None, :] - km.cluster_centers_[None, :, :], axis=2)
    cap = np.full(n_groups, N // n_groups)
    cap[: N % n_groups] += 1
    group = np.full(N, -1)
    for flat in np.argsort(dist, axis=None):
        i, g = divmod(int(flat), n_groups)
        if group[i] < 0 and cap[g] > 0:
            group[i] = g
            cap[g] -= 1
    return group


def smart_order(samples: Array, naive: Array, n_groups: int = 1,
                scales: Array | None = None, k: int | None = None,
                rng: np.random.Generator | int | None = None) -> SmartOrder:
    """Smart ordering of sample computations (Sec. 2.4.5, App. B).

    Parameters
    ----------
    samples : ndarray of shape (N, d)
        Sample inputs (e.g. [c, a, b]).
    naive : ndarray of shape (d,)
        Inputs of the naive solution w_0 (undeformed panel, mid-range wall temperature).
    n_groups : int
        n_C groups of CPUs computing in parallel.
    scales : ndarray of shape (d,) or None
        Nondimensionalization: d_CFD = ||(x - x*) / scales|| (Eq. 2.81 with D_i = 1/scale_i^2,
        read as a weighted Euclidean distance); default the sample range of each input.
    k : int or None
        Neighbours in the kNN graph; default the smallest k >= 5 making it connected.
    rng : numpy.random.Generator, int or None
        Seed of the k-means partition.
    """

    X = np.asarray(samples, float)
    N, dim = X.shape
    if n_groups < 1 or n_groups > N:
        raise InputError("n_groups", f"must be in [1, {N}]")
    if scales is None:
        scales = np.ptp(X, axis=0)
    scales = np.where(np.asarray(scales, float) > 0, scales, 1.0)
    Z = X / scales
    z0 = np.asarray(naive, float) / scales
    rng = as_rng(rng)
    # step 2: kNN graph, k large enough to be connected
    kk = min(k or 5, N - 1)
    while True:
        G = kneighbors_graph(Z, kk, mode="distance")
        G = G.maximum(G.T)
        if csgraph.connected_components(G, directed=False)[0] == 1 or kk >= N - 1:
            break
        kk = min(2 * kk, N - 1)
    # step 3: equal-sized groups
    group = _balanced_groups(Z, n_groups, rng)
    position = np.zeros(N, int)
    parent = np.full(N, -1)
    distance = np.zeros(N)
    d0 = np.linalg.norm(Z - z0, axis=1)
    for g in range(n_groups):
        idx = np.flatnonzero(group == g)
        sub = G[idx][:, idx]
        # step 4: MST of the group's kNN subgraph (complete graph if the subgraph splits)
        if csgraph.connected_components(sub, directed=False)[0] > 1:
            sub = sp.csr_matrix(np.linalg.norm(Z[idx, None] - Z[None, idx], axis=2))
        T = csgraph.minimum_spanning_tree(sub)
        T = T.maximum(T.T)
        # step 5: breadth-first from the sample nearest to w_0; restart each sample from the
        # nearest solution already computed in its group (its MST parent or better) or w_0
        root = int(np.argmin(d0[idx]))
        order, _ = csgraph.breadth_first_order(T, root, directed=False)
        Zg = Z[idx[order]]
        for pos, local in enumerate(order):
            i = idx[local]
            position[i] = pos
            best, best_d = -1, d0[i]
            if pos:
                dd = np.linalg.norm(Zg[:pos] - Z[i], axis=1)
                j = int(np.argmin(dd))
                if dd[j] < best_d:
                    best, best_d = int(idx[order[j]]), float(dd[j])
            parent[i], distance[i] = best, best_d
    return SmartOrder(group, position, parent, distance, float(distance.sum()),
                      float(d0.sum()))


def write_plan_csv(path: str | Path, samples: Array, order: SmartOrder,
                   names: Sequence[str]) -> None:
    """Export a smart-ordered plan for an external CFD campaign.

    Columns: ``group, position, sample, restart_from`` (-1 = naive solution),
    ``distance`` (Eq. 2.81), then one column per input (``names``). Rows are sorted by group
    and position, i.e. each group's computing order.
    """
    X = np.asarray(samples, float)
    if len(names) != X.shape[1]:
        raise InputError("names", f"need {X.shape[1]} input names")
    rows = sorted(range(X.shape[0]), key=lambda i: (order.group[i], order.position[i]))
    with open(path, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(["group", "position", "sample", "restart_from", "distance", *names])
        for i in rows:
            w.writerow([int(order.group[i]), int(order.position[i]), i, int(order.parent[i]),
                        f"{order.distance[i]:.6g}", *[f"{v:.10g}" for v in X[i]]])


# ======================================================================================
# error metric and building
# ======================================================================================
def nrmse(reference: Array, predicted: Array, weights: Array) -> Array:
    """Normalized RMS error of each row, Eq. (7.7), as a fraction:
    ``sqrt(sum(w e^2) / sum(w)) / (max(y_ref) - min(y_ref))``."""
    Y = np.atleast_2d(reference)
    E = np.atleast_2d(predicted) - Y
    w = np.asarray(weights, float)
    rms = np.sqrt((E**2 @ w) / w.sum())
    return rms / np.maximum(np.ptp(Y, axis=1), 1e-300)


def build_rom(geometry: RomGeometry, reference: FlowCondition, inputs: Array,
              pressure: Array, heat_flux: Array, *, bounds: Array | None = None,
              kind: str = "scaled", tolerance: float = 0.005, kernel: str = "rbf",
              trend: str = "linear", n_restarts: int = 2,
              source: dict[str, Any] | None = None, regime: str = "turbulent",
              rng: np.random.Generator | int | None = None,
              optimized_modes: int = 3) -> RomFluid:
    """Fit a ROM from samples ``inputs`` (N_s, N_d) and snapshots (N_s, n) each."""
    rng = as_rng(rng)
    p_model = PodKriging(tolerance, kernel, trend, n_restarts, rng, optimized_modes).fit(
        inputs, pressure, bounds)
    q_model = PodKriging(tolerance, kernel, trend, n_restarts, rng, optimized_modes).fit(
        inputs, heat_flux, bounds)
    return RomFluid(geometry, reference, p_model, q_model, kind=kind, regime=regime,
                    source=source)


def geometry_from_config(cfg: Any) -> RomGeometry:
    """:class:`RomGeometry` of a :class:`~solvers.aero.rom_config.RomBuildConfig`."""
    p = cfg.panel
    modes = np.array([[m.m, m.n] for m in cfg.modes], np.int64)
    return RomGeometry(p.kind, p.length, p.width, p.leading_edge_length, p.thickness,
                       math.radians(p.flow_angle), cfg.grid.n_x, cfg.grid.n_y, modes)


def build_rom_from_config(cfg: Any, base_dir: str | Path | None = None,
                          executor: Executor | None = None, samples: int | None = None
                          ) -> RomFluid:
    """Build the ROM described by a :class:`~solvers.aero.rom_config.RomBuildConfig`:
    OLH plan + built-in source (or external snapshots) + POD-kriging.

    ``samples`` overrides ``[training] samples``.
    """
    geometry = geometry_from_config(cfg)
    reference = cfg.reference.flow()
    tr = cfg.training
    rng = np.random.default_rng(tr.seed)
    a_bounds = np.array([m.range for m in cfg.modes], float)
    t_bounds = np.array([cfg.wall_temperature.range], float)
    src = {"kind": cfg.source.kind, "boundary_layer": cfg.source.boundary_layer,
           "regime": cfg.source.regime}
    n_s = geometry.n_modes
    if cfg.conventional is not None:
        if cfg.source.kind != "shock-expansion":
            raise InputError("conventional", "the conventional ROM is built from the "
                             "built-in source")
        N = samples or tr.samples
        box = np.vstack([[cfg.conventional.mach], [cfg.conventional.altitude], a_bounds,
                         t_bounds])
        plan = olh_plan(box, N, rng)
        P = np.empty((N, geometry.n_x * geometry.n_y))
        Q = np.empty_like(P)
        D = np.empty((N, n_s + 4))
        for i, row in enumerate(plan):
            flow = FlowCondition.from_altitude(row[0], row[1])
            P[i:i + 1], Q[i:i + 1] = generate_samples(geometry, row[None, 2:2 + n_s],
                                                      row[None, -1], flow, source=src)
            D[i] = np.r_[flow.mach, flow.pressure, flow.temperature, row[2:]]
        return build_rom(geometry, reference, D, P, Q, kind="conventional",
                         tolerance=tr.pod_tolerance, kernel=tr.kernel, trend=tr.trend,
                         n_restarts=tr.restarts, source=src, regime=cfg.source.regime, rng=rng,
                     optimized_modes=tr.optimized_modes)
    bounds = np.vstack([a_bounds, t_bounds])
    if cfg.source.kind == "snapshots":
        path = Path(cfg.source.path)
        if base_dir is not None and not path.is_absolute():
            path = Path(base_dir) / path
        D, P, Q = read_snapshots(path, geometry)
        bounds = np.stack([np.minimum(bounds[:, 0], D.min(axis=0)),
                           np.maximum(bounds[:, 1], D.max(axis=0))], axis=1)
    else:
        D = olh_plan(bounds, samples or tr.samples, rng)
        P, Q = generate_samples(geometry, D[:, :n_s], D[:, -1], reference, source=src,
                                executor=executor)
    return build_rom(geometry, reference, D, P, Q, bounds=bounds, tolerance=tr.pod_tolerance,
                     kernel=tr.kernel, trend=tr.trend, n_restarts=tr.restarts, source=src,
                     regime=cfg.source.regime, rng=rng)


def check_samples(rom: RomFluid, n_samples: int, temperature: str = "uniform",
                  rng: np.random.Generator | int | None = None) -> tuple[Array, Array]:
    """Fresh check inputs: modal amplitudes (N, N_S) and wall temperatures (N, n).

    ``temperature = "uniform"`` draws an OLH plan of the training box (amplitudes and a
    uniform wall temperature, as data set 2 of Sec. 7.1); ``"eq76"`` follows data set 3:
    the first three modes from their training ranges (others zero) and the non-uniform wall
    temperature of Eq. (7.6) with b1 in [0.2, 0.9], b2, b5 in [-0.3, 0.3] (Table 7.1),
    rescaled into the training temperature range by Eqs. (7.4)-(7.5).
    """
    g = rom.geometry
    n_s = g.n_modes
    i_a = slice(3, 3 + n_s) if rom.kind == "conventional" else slice(0, n_s)
    box = np.vstack([rom.input_bounds[i_a], rom.input_bounds[-1:]])
    rng = as_rng(rng)
    x_norm = g.points(1.0).x / g.length
    if temperature == "uniform":
        X = olh_plan(box, n_samples, rng)
        return X[:, :n_s], np.repeat(X[:, -1:], x_norm.size, axis=1)
    if temperature != "eq76":
        raise InputError("--temperature", "must be 'uniform' or 'eq76'")
    k = min(3, n_s)
    X = olh_plan(np.vstack([box[:k], [[0.2, 0.9], [-0.3, 0.3], [-0.3, 0.3]]]), n_samples, rng)
    A = np.zeros((n_samples, n_s))
    A[:, :k] = X[:, :k]
    return A, eq76_wall_temperature(x_norm, X[:, k:], tuple(rom.input_bounds[-1]))


def check_rom(rom: RomFluid, n_samples: int = 100, flow: FlowCondition | None = None,
              scale: float = 1.0, temperature: str = "uniform",
              rng: np.random.Generator | int | None = None, executor: Executor | None = None
              ) -> dict[str, float]:
    """Mean NRMSE (Eq. 7.7, fractions) of the ROM against the built-in source on fresh
    samples at ``flow`` (default: the reference condition) and geometric scale ``scale``.

    Returns ``{"pressure_nrmse", "heat_flux_nrmse", "samples"}``.
    """
    if rom.source.get("kind") != "shock-expansion":
        raise InputError("rom", "this ROM was trained on external snapshots; checking it "
                         "needs the built-in source (rebuild with [source] kind = "
                         "'shock-expansion') or your own held-out snapshots")
    if n_samples < 1:
        raise InputError("--samples", "must be >= 1")
    if not scale > 0.0:
        raise InputError("--scale", "must be > 0")
    flow = flow or rom.reference
    g = rom.geometry
    A, T = check_samples(rom, n_samples, temperature, rng)
    P, Q = generate_samples(g, A, T, flow, scale, rom.source, executor)
    pts = g.points(scale)
    w, ws = g.deformation(A, scale)
    fluid = rom.with_options(scale=None)
    pr = np.empty_like(P)
    qr = np.empty_like(Q)
    zero = np.zeros(pts.n)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        for i in range(n_samples):
            loads = fluid.evaluate(pts, SurfaceState(w[i], ws[i], zero, T[i]), flow)
            pr[i], qr[i] = loads.pressure, loads.heat_flux
    return {"pressure_nrmse": float(nrmse(P, pr, pts.weights).mean()),
            "heat_flux_nrmse": float(nrmse(Q, qr, pts.weights).mean()),
            "samples": int(n_samples)}
