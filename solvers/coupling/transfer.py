"""Information exchange between the structural, thermal and fluid grids (Sec. 5.2, Eq. 5.1).

Structure/thermal -> fluid (Eqs. 5.1c-d) interpolate with the elements' own shape functions
(the mortar idea for matching surfaces): the normal displacement and its streamwise slope
from the 9-node shell shape functions (the slope uses their exact derivatives), the wall
temperature from the bilinear top faces of the thermal hexahedra.

Fluid -> structure/thermal (Eqs. 5.1a-b) use the transposes weighted by the fluid grid's
quadrature weights (quadrature projection), ``H_SF = -H_FS^T W`` and ``H_TF = H_FT^T W``.
Because the shape functions are a partition of unity, total force and total heat input are
the same on both sides, and ``F_S . u = -p^T W u_F`` so the work is conserved exactly.

All matrices are scipy.sparse CSR, built once. :class:`PointwiseTransfer` composes them with
the Jacobians of a pointwise fluid model (``diag(s)``, ``diag(a) + diag(b) S``): the products
are linear in the coefficient vectors, so each is one sparse mat-vec on a fixed pattern.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.sparse as sp
from hypate.solvers.aero.base import SurfacePoints
from hypate.solvers.numerics.sparse import triple_product_operator
from hypate.solvers.panel import PanelSpec
from hypate.solvers.structure.element import NDOF, shape_functions
from numpy.typing import NDArray

Array = NDArray[np.float64]

#: Index of the normal displacement w among the 5 shell DOFs (u, v, w, psi_x, psi_y).
W_DOF = 2


def _locate(coord: Array, length: float, n_cells: int) -> tuple[NDArray[np.int64], Array]:
    """Cell index and local coordinate in [-1, 1] of points on a uniform 1D grid."""
    h = length / n_cells
    # A point on an element edge belongs to the downstream element (slopes jump there):
    # snap coord / h to the integer within round-off, else 1 ulp decides the element, and
    # geometrically similar panels (L = 1 and L = 1/3) get different piston-theory slopes.
    r = coord / h
    r = np.where(np.abs(r - np.rint(r)) <= 1e-9, np.rint(r), r)
    cell = np.clip(np.floor(r).astype(np.int64), 0, n_cells - 1)
    local = 2.0 * (coord - (cell + 0.5) * h) / h
    return cell, local


@dataclass(frozen=True, eq=False)
class Transfer:
    """Transfer matrices between the shell, thermal and fluid grids (Eq. 5.1).

    Attributes
    ----------
    H_FS : sparse (n_f, n_dof)
        u_F = H_FS u: normal displacement (and, applied to u_dot, normal velocity).
    H_FS_slope : sparse (n_f, n_dof)
        Streamwise slope d u_F / d s = (cos beta d/dx + sin beta d/dy) of the shell's w.
    H_SF : sparse (n_dof, n_f)
        F_S = H_SF p: consistent nodal loads of the overpressure (towards -z).
    H_FT : sparse (n_f, n_T)
        T_w = H_FT T: wall temperature from the top thermal nodes.
    H_TF : sparse (n_T, n_f)
        Q_T = H_TF q: consistent heat input of the wall heat flux.
    """

    points: SurfacePoints
    H_FS: sp.csr_matrix
    H_FS_slope: sp.csr_matrix
    H_SF: sp.csr_matrix
    H_FT: sp.csr_matrix
    H_TF: sp.csr_matrix

    @classmethod
    def build(cls, panel: PanelSpec, points: SurfacePoints, n_thermal_levels: int) -> Transfer:
        """Transfer matrices for ``panel`` (its shell mesh and thermal stack) and ``points``.

        ``n_thermal_levels`` is the number of thermal node levels (top level = last).
        """
        nx, ny = panel.mesh
        a, b = panel.length, panel.width
        n_i, n_j = 2 * nx + 1, 2 * ny + 1
        n_nodes = n_i * n_j
        n_dof = NDOF * n_nodes
        n_f = points.n
        # -- shell: element containing each point, local (xi, eta), 9-node shape functions
        ex, xi = _locate(points.x, a, nx)
        ey, eta = _locate(points.y, b, ny)
        N, dN = shape_functions(xi, eta)
        if panel.kind == "2d":
            # a strip in cylindrical bending: each fluid point stands for a spanwise-uniform
            # line, so interpolation and loads use the span average of the shape functions
            # (int f_s(eta) d eta / 2 = 1/6, 2/3, 1/6 for the three node rows)
            N, dN = _span_averaged(xi)
        r = np.arange(9) % 3
        s = np.arange(9) // 3
        nodes = (2 * ey[:, None] + s[None, :]) * n_i + 2 * ex[:, None] + r[None, :]  # (n_f, 9)
        rows = np.repeat(np.arange(n_f), 9)
        cols = (NDOF * nodes + W_DOF).ravel()
        H_FS = sp.csr_matrix((N.ravel(), (rows, cols)), shape=(n_f, n_dof))
        c, sn = math.cos(points.flow_angle), math.sin(points.flow_angle)
        dNdx = dN[..., 0] * (2.0 * nx / a)
        dNdy = dN[..., 1] * (2.0 * ny / b)
        slope = c * dNdx + (sn * dNdy if panel.kind == "3d" else 0.0)
        H_slope = sp.csr_matrix((np.asarray(slope).ravel(), (rows, cols)), shape=(n_f, n_dof))
        W = sp.diags(points.weights)
        H_SF = (-(H_FS.T @ W)).tocsr()
        # -- thermal: bilinear top faces on the (n_i x n_j) in-plane grid, top level
        cx, lx = _locate(points.x, a, n_i - 1)
        cy, ly = _locate(points.y, b, n_j - 1)
        fx = np.stack([0.5 * (1 - lx), 0.5 * (1 + lx)], axis=1)
        fy = np.stack([0.5 * (1 - ly), 0.5 * (1 + ly)], axis=1)
        Nb = np.einsum("pj,pi->pji", fy, fx).reshape(-1, 4)
        di = np.array([0, 1, 0, 1])
        dj = np.array([0, 0, 1, 1])
        if panel.kind == "2d":
            # span average of the bilinear functions over the 3 node rows: 1/4, 1/2, 1/4
            Nb = np.einsum("j,pi->pji", np.array([0.25, 0.5, 0.25]), fx).reshape(-1, 6)
            di = np.array([0, 1, 0, 1, 0, 1])
            dj = np.array([0, 0, 1, 1, 2, 2])
            cy = np.zeros_like(cy)
        inplane = (cy[:, None] + dj[None, :]) * n_i + cx[:, None] + di[None, :]
        top = (n_thermal_levels - 1) * n_nodes
        n_T = n_thermal_levels * n_nodes
        H_FT = sp.csr_matrix((Nb.ravel(), (np.repeat(np.arange(n_f), di.size),
                                           (top + inplane).ravel())), shape=(n_f, n_T))
        H_TF = (H_FT.T @ W).tocsr()
        return cls(points=points, H_FS=H_FS, H_FS_slope=H_slope, H_SF=H_SF, H_FT=H_FT, H_TF=H_TF)


class PointwiseTransfer:
    """The transferred Jacobians of a pointwise fluid model, each map built on first use.

    For the pointwise form of :class:`~hypate.solvers.aero.base.FluidJacobians`
    (``dp/dw_s = diag(s)``, ``dp/dw_dot = diag(v)``, ``dq/dT_w = diag(a) + diag(b) S``) the
    matrices of Eq. (5.34) and the wall-flux derivative of Eq. (5.31a) are formed as data on
    fixed patterns by :func:`~hypate.solvers.numerics.sparse.triple_product_operator`.

    Parameters
    ----------
    transfer : Transfer
    structural_pattern : scipy.sparse.csr_matrix of shape (n_dof, n_dof)
        The structural matrices' pattern (only indptr/indices are used).
    H_TF_top, H_FT_top : scipy.sparse.csr_matrix
        ``H_TF`` and ``H_FT`` restricted to the top thermal nodes (Eqs. 5.1b, 5.1d).
    """

    def __init__(self, transfer: Transfer, structural_pattern: sp.csr_matrix,
                 H_TF_top: sp.csr_matrix, H_FT_top: sp.csr_matrix) -> None:
        self.transfer = transfer
        self.pattern = structural_pattern
        self.H_TF_top, self.H_FT_top = H_TF_top, H_FT_top

    @cached_property
    def stiffness_data(self) -> sp.csr_matrix:
        """The map ``s -> data of K_A = H_SF diag(s) H_FS_slope`` on the structural pattern
        (Eq. 5.34 with ``dp/dw = 0``): K_A added to K's data, for the solvers."""
        tr, pat = self.transfer, self.pattern
        return triple_product_operator(tr.H_SF, tr.H_FS_slope, (pat.indptr, pat.indices))[0]

    @cached_property
    def _stiffness_own(self) -> tuple[sp.csr_matrix, Array, Array]:
        return triple_product_operator(self.transfer.H_SF, self.transfer.H_FS_slope)

    @cached_property
    def _damping_own(self) -> tuple[sp.csr_matrix, Array, Array]:
        return triple_product_operator(self.transfer.H_SF, self.transfer.H_FS)

    @cached_property
    def _wall_flux(self) -> tuple[sp.csr_matrix, sp.csr_matrix, Array, Array]:
        """The maps a -> data of ``H_TF diag(a) H_FT`` and b -> data of ``H_TF diag(b) S
        H_FT`` (top nodes) on the union of their patterns, and that pattern."""
        S = self.transfer.points.streamwise_derivative
        L, Ra, Rb = self.H_TF_top, self.H_FT_top, S @ self.H_FT_top
        _, ip_a, ix_a = triple_product_operator(L, Ra)
        _, ip_b, ix_b = triple_product_operator(L, Rb)
        n_in = L.shape[0]
        union = sp.csr_matrix((np.ones(ix_a.size), ix_a, ip_a), shape=(n_in, n_in)) + \
            sp.csr_matrix((np.ones(ix_b.size), ix_b, ip_b), shape=(n_in, n_in))
        union.sort_indices()
        qpat = (union.indptr.astype(np.int32), union.indices.astype(np.int32))
        return (triple_product_operator(L, Ra, qpat)[0], triple_product_operator(L, Rb, qpat)[0],
                *qpat)

    def stiffness(self, s: Array) -> sp.csr_matrix:
        """``K_A = H_SF diag(s) H_FS_slope`` (Eq. 5.34) on its own compact pattern."""
        T, indptr, indices = self._stiffness_own
        n = self.pattern.shape[0]
        return sp.csr_matrix((T @ s, indices, indptr), shape=(n, n))

    def damping(self, v: Array) -> sp.csr_matrix:
        """``C_A = H_SF diag(v) H_FS`` (Eq. 5.34) on its own compact pattern."""
        T, indptr, indices = self._damping_own
        n = self.pattern.shape[0]
        return sp.csr_matrix((T @ v, indices, indptr), shape=(n, n))

    def wall_flux_derivative(self, a: Array, b: Array | None) -> sp.csr_matrix:
        """``H_TF (diag(a) + diag(b) S) H_FT`` on the top thermal nodes (W/K): the derivative
        of the nodal heat input with respect to their temperatures (Eqs. 5.1b, 5.31a)."""
        Ta, Tb, indptr, indices = self._wall_flux
        data = Ta @ a
        if b is not None:
            data = data + Tb @ b
        n_top = self.H_TF_top.shape[0]
        return sp.csr_matrix((data, indices, indptr), shape=(n_top, n_top))


def _span_averaged(xi: Array) -> tuple[Array, Array]:
    """9-node shape functions and derivatives averaged over eta in [-1, 1] (2d strips)."""
    f = np.stack([0.5 * xi * (xi - 1.0), 1.0 - xi * xi, 0.5 * xi * (xi + 1.0)], axis=-1)
    df = np.stack([xi - 0.5, -2.0 * xi, xi + 0.5], axis=-1)
    g = np.array([1.0, 4.0, 1.0]) / 6.0  # averages of the eta functions
    N = np.einsum("s,pr->psr", g, f).reshape(-1, 9)
    dNx = np.einsum("s,pr->psr", g, df).reshape(-1, 9)
    return N, np.stack([dNx, np.zeros_like(dNx)], axis=-1)


def fluid_points(panel: PanelSpec, density: int = 2) -> SurfacePoints:
    """The fluid surface grid of a panel: ``density`` points per shell-node spacing.

    ``density = 2`` places 4 nx + 1 points streamwise (twice as dense as the shell nodes); a
    "2d" strip gets a single line of points at mid-span.
    """
    nx, ny = panel.mesh
    n_x = 2 * density * nx + 1
    n_y = 1 if panel.kind == "2d" else 2 * density * ny + 1
    return SurfacePoints.grid(panel.length, panel.width, panel.leading_edge_length, n_x, n_y,
                              panel.flow_angle)
