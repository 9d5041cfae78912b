"""Structured 8-node hexahedron mesh for the HTSH thermal element (Sec. 4.2).

The thermal mesh stacks copies of the shell mesh's in-plane node grid at the thermal node
levels of :func:`hypate.solvers.panel.thermal_levels`, so transferring temperatures to the shell is
an index operation, not a search.

Numbering contract (shared with the shell mesh and the coupled solver)
----------------------------------------------------------------------
* In-plane grid of a panel with ``mesh = (nx, ny)`` nine-node shell elements:
  ``(2 nx + 1) x (2 ny + 1)`` points, ``x`` in ``[0, a]``, ``y`` in ``[0, b]``, uniformly
  spaced; in-plane node id ``p = j (2 nx + 1) + i`` (``i`` along x, ``j`` along y).
* Thermal node id ``n = k n_inplane + p`` with ``k = 0`` at the bottom surface.
* One hexahedron spans one grid cell in-plane (``2 nx x 2 ny`` cells) and one level interval
  through the thickness; element id ``e = k n_cells + c`` with cell id
  ``c = j (2 nx) + i``.
* Local node order of the hexahedron follows Eq. (4.18): local node
  ``(i - 1) + 2 (j - 1) + 4 (k - 1)`` has shape function ``f_i(eta1) f_j(eta2) f_k(eta3)``,
  i.e. x fastest, then y, then z.
* Surface quadrilaterals of the upper (lower) surface use the same in-plane cells with local
  order x fastest, then y.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from hypate.solvers.errors import InputError
from hypate.solvers.panel import PanelSpec, layer_of_level_interval, thermal_levels
from numpy.typing import NDArray

IntArray = NDArray[np.int64]
Array = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class HexMesh:
    """A structured stack of 8-node hexahedra (all boxes aligned with x, y, z).

    Attributes
    ----------
    x : ndarray of shape (n_x,)
        In-plane grid coordinates along x (m), ``n_x = 2 nx + 1``.
    y : ndarray of shape (n_y,)
        In-plane grid coordinates along y (m), ``n_y = 2 ny + 1``.
    z : ndarray of shape (n_levels,)
        Thermal node levels, bottom to top, mid-surface at 0 (m).
    elements : ndarray of shape (n_elem, 8)
        Node ids of each hexahedron in the local order of Eq. (4.18).
    element_size : ndarray of shape (n_elem, 3)
        Edge lengths (h_x, h_y, h_z) of each box (m).
    element_layer : ndarray of shape (n_elem,)
        Index of the panel layer containing each element.
    faces : ndarray of shape (n_cells, 4)
        In-plane node ids of each grid cell (x fastest, then y); add
        ``k * n_inplane`` for the nodes of level ``k``.
    face_size : ndarray of shape (n_cells, 2)
        (h_x, h_y) of each cell (m).
    """

    x: Array
    y: Array
    z: Array
    elements: IntArray
    element_size: Array
    element_layer: IntArray
    faces: IntArray
    face_size: Array

    @property
    def n_inplane(self) -> int:
        """Number of in-plane grid points."""
        return int(self.x.size * self.y.size)

    @property
    def n_levels(self) -> int:
        """Number of thermal node levels through the thickness."""
        return int(self.z.size)

    @property
    def n_nodes(self) -> int:
        """Total number of thermal nodes (= ``n_levels * n_inplane``)."""
        return self.n_levels * self.n_inplane

    @property
    def n_cells(self) -> int:
        """Number of in-plane grid cells (hexahedra per level interval)."""
        return int(self.faces.shape[0])

    @property
    def n_elements(self) -> int:
        return int(self.elements.shape[0])

    @property
    def area(self) -> float:
        """Planform area (m^2)."""
        return float((self.x[-1] - self.x[0]) * (self.y[-1] - self.y[0]))

    def level_nodes(self, k: int) -> IntArray:
        """Node ids of level ``k`` (negative counts from the top), shape (n_inplane,)."""
        k = int(k) % self.n_levels
        return k * self.n_inplane + np.arange(self.n_inplane)

    @property
    def top_nodes(self) -> IntArray:
        """Node ids of the upper surface, shape (n_inplane,), in in-plane id order."""
        return self.level_nodes(-1)

    @property
    def bottom_nodes(self) -> IntArray:
        """Node ids of the lower surface, shape (n_inplane,), in in-plane id order."""
        return self.level_nodes(0)

    def coordinates(self) -> Array:
        """Node coordinates, shape (n_nodes, 3), in thermal node id order (m)."""
        X, Y = np.meshgrid(self.x, self.y)  # (n_y, n_x): row j, column i
        xy = np.column_stack([X.ravel(), Y.ravel()])
        n_in = self.n_inplane
        out = np.empty((self.n_nodes, 3))
        out[:, :2] = np.tile(xy, (self.n_levels, 1))
        out[:, 2] = np.repeat(self.z, n_in)
        return out


def inplane_grid(panel: PanelSpec) -> tuple[Array, Array]:
    """Coordinates of the shared in-plane node grid (m), shapes (2nx+1,), (2ny+1,).

    ``panel.mesh`` is the shell mesh (a "2d" strip's is ``(nx, 1)``, normalized by
    :class:`~hypate.solvers.panel.PanelSpec`).
    """
    nx, ny = (int(v) for v in panel.mesh)
    if nx < 1 or ny < 1:
        raise InputError("panel.mesh", "needs at least one element in each direction")
    if not (panel.length > 0.0 and panel.width > 0.0):
        raise InputError("panel.length", "length and width must be > 0 (m)")
    return (np.linspace(0.0, panel.length, 2 * nx + 1),
            np.linspace(0.0, panel.width, 2 * ny + 1))


def build_hex_mesh(panel: PanelSpec) -> HexMesh:
    """The HTSH hexahedron mesh of a panel (numbering in the module docstring).

    Parameters
    ----------
    panel : PanelSpec
        Layers (bottom to top) with their ``sublayers``, planform size and shell mesh.

    Returns
    -------
    HexMesh
    """
    if not panel.layers:
        raise InputError("panel.layers", "needs at least one layer")
    for n, layer in enumerate(panel.layers):
        if not layer.thickness > 0.0:
            raise InputError(f"panel.layers[{n}].thickness", "must be > 0 (m)")
    x, y = inplane_grid(panel)
    z = thermal_levels(panel)
    nxn, nyn, nl = x.size, y.size, z.size
    n_in = nxn * nyn
    # Grid cells: lower-left in-plane node of cell (i, j) is j * nxn + i.
    ci, cj = np.meshgrid(np.arange(nxn - 1), np.arange(nyn - 1))  # (nyn-1, nxn-1)
    ll = (cj * nxn + ci).ravel()
    faces = np.column_stack([ll, ll + 1, ll + nxn, ll + nxn + 1]).astype(np.int64)
    hx = np.diff(x)[ci.ravel()]
    hy = np.diff(y)[cj.ravel()]
    face_size = np.column_stack([hx, hy])
    n_cells = faces.shape[0]
    k = np.arange(nl - 1)
    bottom = faces[None, :, :] + (k * n_in)[:, None, None]  # (n_int, n_cells, 4)
    elements = np.concatenate([bottom, bottom + n_in], axis=2).reshape(-1, 8)
    hz = np.diff(z)
    size = np.empty((elements.shape[0], 3))
    size[:, 0] = np.tile(hx, nl - 1)
    size[:, 1] = np.tile(hy, nl - 1)
    size[:, 2] = np.repeat(hz, n_cells)
    element_layer = np.repeat(layer_of_level_interval(panel), n_cells).astype(np.int64)
    return HexMesh(x=x, y=y, z=z, elements=elements.astype(np.int64), element_size=size,
                   element_layer=element_layer, faces=faces, face_size=face_size)
