"""Physical description of a panel: frozen dataclasses in SI units.

:class:`PanelSpec` is what every solver receives; :mod:`hypate.solvers.config` builds it from a
validated TOML file. Angles are radians here (degrees only at the config/CLI boundary).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from hypate.solvers.materials import Material


@dataclass(frozen=True)
class Layer:
    """One lamina of the stack (listed bottom to top in :class:`PanelSpec`).

    Attributes
    ----------
    material : Material
    thickness : float
        m.
    angle : float
        Rotation of the material 1-axis from the panel x-axis (rad).
    sublayers : int
        Thermal sub-layers (8-node hexahedra through this layer).
    """

    material: Material
    thickness: float
    angle: float = 0.0
    sublayers: int = 1


@dataclass(frozen=True)
class PanelSpec:
    """A rectangular skin panel.

    Attributes
    ----------
    kind : {"3d", "2d"}
        "2d" is a cylindrical-bending strip (one element across, v = psi_y = 0).
    length, width : float
        a (streamwise) and b (spanwise), m. For "2d" the width is nominal (per unit span).
    boundary : {"simply_supported", "clamped"}
        Edges immovable in-plane.
    leading_edge_length : float
        L_le, rigid wall ahead of the panel (m).
    flow_angle : float
        beta, rad.
    mesh : tuple of int
        Shell elements (streamwise, spanwise). A "2d" strip is one element across: its mesh
        is normalized to ``(nx, 1)`` on construction (``(nx,)`` or any ``ny`` given), so the
        shell mesh, the thermal grid and the transfer matrices all read ``panel.mesh``.
    initial_temperature : float
        K; also the stress-free temperature.
    emissivity : float
        Upper-surface emissivity.
    damping : tuple of float
        Proportional damping (zeta_M, zeta_K), Eq. (3.44).
    radius_x, radius_y : float
        Shell radii of curvature R_x, R_y (m); ``inf`` for a flat panel.
    layers : tuple of Layer
        Bottom to top.
    """

    layers: tuple[Layer, ...]
    kind: str = "3d"
    length: float = 1.0
    width: float = 1.0
    boundary: str = "simply_supported"
    leading_edge_length: float = 1.0
    flow_angle: float = 0.0
    mesh: tuple[int, int] = (8, 8)
    initial_temperature: float = 300.0
    emissivity: float = 0.85
    damping: tuple[float, float] = (0.0, 0.0)
    radius_x: float = math.inf
    radius_y: float = math.inf
    name: str = field(default="panel", compare=False)

    def __post_init__(self) -> None:
        if self.kind == "2d":
            # the one place of the rule "a 2d strip has ny = 1" (frozen: set through object)
            object.__setattr__(self, "mesh", (self.mesh[0], 1))

    @property
    def thickness(self) -> float:
        """Total thickness h (m)."""
        return float(sum(layer.thickness for layer in self.layers))

    @property
    def interfaces(self) -> np.ndarray:
        """z of the layer interfaces, bottom to top, mid-surface at z = 0 (shape (n+1,))."""
        z = np.concatenate([[0.0], np.cumsum([layer.thickness for layer in self.layers])])
        return z - 0.5 * z[-1]

    def mass_per_area(self, temperature: float | None = None) -> float:
        """Areal mass (kg/m^2) at ``temperature`` (default: the initial temperature)."""
        T = self.initial_temperature if temperature is None else temperature
        return float(sum(layer.material.density(T) * layer.thickness for layer in self.layers))


def thermal_levels(panel: PanelSpec) -> np.ndarray:
    """z of the thermal node levels (bottom to top, mid-surface at 0), shape (n_levels,).

    Each layer is split into ``sublayers`` equal 8-node-hexahedron layers (HTSH, Sec. 4.2),
    so the through-thickness temperature is piecewise linear between these levels.
    """
    z = [panel.interfaces[0]]
    for layer, z0 in zip(panel.layers, panel.interfaces[:-1]):
        n = max(int(layer.sublayers), 1)
        z.extend(z0 + layer.thickness * np.arange(1, n + 1) / n)
    return np.asarray(z)


def layer_of_level_interval(panel: PanelSpec) -> np.ndarray:
    """Layer index of each interval between consecutive thermal levels, shape (n_levels-1,)."""
    return np.repeat(np.arange(len(panel.layers)),
                     [max(int(layer.sublayers), 1) for layer in panel.layers])
