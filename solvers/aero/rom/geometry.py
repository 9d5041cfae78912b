"""The reference panel of a fluid ROM: geometry, fluid grid, deformation modes (Sec. 2.4.4).

:class:`RomGeometry` holds the reference panel (``a_ref``, ``b_ref``, ``L_le,ref``,
``h_ref``, flow angle), its grid of surface points and the sinusoidal deformation modes
``phi_k(x, y) = sin(m pi x / a_ref) sin(n pi y / b_ref)`` (``n = 0``: uniform across;
Eq. 7.1 for the 2D panel). :func:`interpolation_matrix` maps outputs on the reference grid
to other points (piecewise linear in ``x``, bilinear in ``(x, y)``), and
:func:`eq76_wall_temperature` is the non-uniform wall temperature of data set 3 (Eq. 7.6).
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from hypate.solvers.aero.base import Array, SurfacePoints
from numpy.typing import NDArray

__all__ = ["MAX_N_X", "MAX_N_Y", "RomGeometry", "eq76_wall_temperature",
           "interpolation_matrix"]

#: Largest reference grid (points streamwise, spanwise) of a ROM: the ``[grid]`` limits of a
#: build file, checked again when a ROM file is loaded.
MAX_N_X, MAX_N_Y = 1000, 200


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


def interpolation_matrix(geom: RomGeometry, x_ref: Array, y_ref: Array) -> sp.csr_matrix:
    """Piecewise-(bi)linear interpolation from the reference grid to points (n_pts, n_rom)."""
    xs = np.linspace(0.0, geom.length, geom.n_x)

    def weights_1d(grid: Array, v: Array) -> tuple[NDArray[np.intp], Array]:
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
