"""Structured meshes of 9-node quadrilaterals for rectangular panels.

Grid contract (shared with the thermal solver): the in-plane nodes form a
``(2 nx + 1) x (2 ny + 1)`` grid, ``x`` in ``[0, a]`` streamwise and ``y`` in ``[0, b]``;
**node id = j * (2 nx + 1) + i** for grid index ``i`` along x and ``j`` along y.

Element ``e = ej * nx + ei`` covers grid indices ``i = 2 ei .. 2 ei + 2`` and
``j = 2 ej .. 2 ej + 2``. Its local node ``3 s + r`` (``r, s`` in ``{0, 1, 2}``) sits at the
parametric point ``(xi, eta) = (r - 1, s - 1)``, matching the shape functions
``N_{3s+r} = f_r(xi) f_s(eta)`` of Eq. (3.31) (local numbering differs from Fig. 3.2 only by
a permutation).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from hypate.solvers.errors import InputError
from hypate.solvers.panel import PanelSpec
from numpy.typing import NDArray

IntArray = NDArray[np.int64]
Array = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class ShellMesh:
    """A structured 9-node quadrilateral mesh of the rectangle ``[0, a] x [0, b]``.

    Attributes
    ----------
    a, b : float
        Panel length (x) and width (y), m.
    nx, ny : int
        Elements along x and y.
    coords : ndarray of shape (n_nodes, 2)
        Node coordinates (x, y), m.
    elements : ndarray of shape (n_elem, 9)
        Connectivity, local node ``3 s + r`` at parametric ``(r - 1, s - 1)``.
    edges : dict of str to ndarray
        Node ids on ``"x0"`` (x = 0), ``"xa"`` (x = a), ``"y0"`` (y = 0), ``"yb"`` (y = b),
        each ordered along the edge.
    center : int
        Id of the node at ``(a/2, b/2)`` (the nearest grid node if nx or ny is odd).
    """

    a: float
    b: float
    nx: int
    ny: int
    coords: Array
    elements: IntArray
    edges: dict[str, IntArray]
    center: int

    @property
    def n_nodes(self) -> int:
        return int(self.coords.shape[0])

    @property
    def n_elem(self) -> int:
        return int(self.elements.shape[0])

    @property
    def grid_shape(self) -> tuple[int, int]:
        """``(2 ny + 1, 2 nx + 1)``: reshape a nodal array to ``(j, i)`` with this."""
        return (2 * self.ny + 1, 2 * self.nx + 1)

    @property
    def x(self) -> Array:
        return self.coords[:, 0]

    @property
    def y(self) -> Array:
        return self.coords[:, 1]

    @property
    def boundary_nodes(self) -> IntArray:
        """All edge nodes, sorted, without duplicates."""
        return np.unique(np.concatenate(list(self.edges.values())))

    def node_id(self, i: int | IntArray, j: int | IntArray) -> int | IntArray:
        """Node id of grid indices ``(i, j)``."""
        return j * (2 * self.nx + 1) + i


def shell_mesh(a: float, b: float, nx: int, ny: int) -> ShellMesh:
    """Build the structured 9-node mesh of ``[0, a] x [0, b]`` with ``nx x ny`` elements.

    Parameters
    ----------
    a, b : float
        Length (x, streamwise) and width (y), m, positive.
    nx, ny : int
        Number of elements along x and y, >= 1.
    """
    if not (a > 0.0 and b > 0.0):
        raise InputError("panel.length/width", "must be > 0 (m)")
    if int(nx) != nx or int(ny) != ny or nx < 1 or ny < 1:
        raise InputError("panel.mesh", "element counts must be integers >= 1")
    nx, ny = int(nx), int(ny)
    ni, nj = 2 * nx + 1, 2 * ny + 1
    xs = np.linspace(0.0, a, ni)
    ys = np.linspace(0.0, b, nj)
    X, Y = np.meshgrid(xs, ys)  # shape (nj, ni): node id = j * ni + i
    coords = np.column_stack([X.ravel(), Y.ravel()])
    ei2, ej2 = np.meshgrid(np.arange(nx), np.arange(ny))  # (ny, nx), e = ej * nx + ei
    ei, ej = ei2.ravel(), ej2.ravel()
    r = np.tile(np.arange(3), 3)
    s = np.repeat(np.arange(3), 3)
    elements = (2 * ej[:, None] + s[None, :]) * ni + (2 * ei[:, None] + r[None, :])
    ids = np.arange(ni * nj).reshape(nj, ni)
    edges = {"x0": ids[:, 0].copy(), "xa": ids[:, -1].copy(),
             "y0": ids[0, :].copy(), "yb": ids[-1, :].copy()}
    center = int(ids[nj // 2, ni // 2])
    return ShellMesh(a=float(a), b=float(b), nx=nx, ny=ny, coords=coords,
                     elements=elements.astype(np.int64), edges=edges, center=center)


def panel_mesh(panel: PanelSpec) -> ShellMesh:
    """The shell mesh of a panel: ``panel.mesh`` elements (``(nx, 1)`` for a "2d" strip,
    normalized by :class:`~hypate.solvers.panel.PanelSpec`)."""
    if panel.kind not in ("3d", "2d"):
        raise InputError("panel.kind", "must be '3d' or '2d'")
    nx, ny = panel.mesh
    return shell_mesh(panel.length, panel.width, nx, ny)
