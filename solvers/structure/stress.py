"""Ply stresses of the DCS9 shell at the load-bearing surfaces (Eqs. 3.2, 3.6-3.8).

What a model goes through structurally, for the admissibility of a design: at every 3 x 3
Gauss point of every element, at the bottom and top surface of each load-bearing layer
(a solid material; a honeycomb core or smeared stiffeners are not stressed as solids, so in
a sandwich these are the face sheets), the plane-stress state of classical lamination
theory::

    eps(z)   = eps0 + z chi                                   (Eq. 3.2, von Karman eps0)
    sigma(z) = Q(T(z)) [R(theta) eps(z) - eps_T(T(z))]        (Eqs. 3.6, 3.8; material axes)

with the layer's reduced stiffness ``Q`` (Eq. 3.8) and secant thermal strain from the
stress-free temperature at the local temperature ``T(z)`` (the thermal node levels at the
layer's faces, interpolated in-plane with the shape functions). The membrane and bending
resultants of Eq. (3.7) are the through-thickness integrals of exactly this stress, so a
laminate whose temperature is linear through each layer gives back ``N = A eps0 + B chi -
N_T`` and ``M = B eps0 + D chi - M_T``; the surface values add the self-equilibrated part of
a nonlinear through-thickness profile. Transverse shear vanishes at the surfaces.

The von Mises stress of plane stress, ``sqrt(s1^2 - s1 s2 + s2^2 + 3 t12^2)``, is invariant
under the in-plane rotation, so it is formed in the material axes. Everything is vectorized
over elements, Gauss points and surfaces; the only loop is over the layers.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from hypate.solvers.laminate import strain_rotation
from hypate.solvers.panel import PanelSpec
from hypate.solvers.structure.element import generalized_strain
from numpy.typing import NDArray

Array = NDArray[np.float64]


def von_mises(sigma: Array) -> Array:
    """Plane-stress von Mises stress of ``sigma = (s1, s2, t12)`` (last axis), Pa."""
    s1, s2, t = sigma[..., 0], sigma[..., 1], sigma[..., 2]
    return np.sqrt(np.maximum(s1 * s1 - s1 * s2 + s2 * s2 + 3.0 * t * t, 0.0))


@dataclass(frozen=True)
class Surface:
    """One stressed surface: the bottom or top face of a load-bearing layer."""

    layer: int
    z: float
    level: int


def stressed_surfaces(panel: PanelSpec) -> list[Surface]:
    """The bottom and top faces of every load-bearing layer (its material's
    ``load_bearing``), with their z (mid-surface at 0) and thermal level index."""
    out: list[Surface] = []
    level = 0
    z = panel.interfaces
    for k, layer in enumerate(panel.layers):
        n = max(int(layer.sublayers), 1)
        if layer.material.load_bearing:
            out += [Surface(k, float(z[k]), level), Surface(k, float(z[k + 1]), level + n)]
        level += n
    return out


@dataclass(frozen=True)
class StressPeak:
    """The largest surface stress of one state.

    Attributes
    ----------
    von_mises : float
        Maximum von Mises stress over the surfaces (Pa); NaN with no load-bearing layer.
    location : (float, float, float)
        Where it occurs: x, y on the panel (m) and z through the thickness (m, mid-surface 0).
    layer : int
        The layer (bottom = 0), -1 with none.
    ratio : float
        Maximum over the surfaces of ``von Mises / yield(T)`` at the local temperature
        (NaN where no layer states a yield strength): the stress utilization.
    ratio_location : (float, float, float)
        Where the ratio peaks.
    ratio_stress : float
        The von Mises stress there (Pa): ``ratio_stress / ratio`` is the local yield strength.
    """

    von_mises: float
    location: tuple[float, float, float]
    layer: int
    ratio: float
    ratio_location: tuple[float, float, float]
    ratio_stress: float


class SurfaceStress:
    """Surface stresses of one structural model (see the module docstring).

    Parameters
    ----------
    structure : StructuralModel
        The shell model: its mesh, 3 x 3 quadrature and curvatures.
    """

    def __init__(self, structure) -> None:
        self.structure = structure
        panel: PanelSpec = structure.panel
        self.surfaces = stressed_surfaces(panel)
        q = structure.q3
        mesh = structure.mesh
        #: x, y (m) of every 3 x 3 Gauss point, shape (n_elem, 9, 2).
        self.points_xy = np.einsum("qa,eai->eqi", q.N, mesh.coords[mesh.elements])
        self._T0 = float(panel.initial_temperature)

    def fields(self, u: Array, T_profile: Array) -> tuple[Array, Array]:
        """Von Mises stress and its ratio to the yield strength at every surface point.

        Parameters
        ----------
        u : ndarray of shape (n_dof,)
            Nodal DOFs (m, rad).
        T_profile : ndarray of shape (n_nodes, n_levels)
            Temperature at the thermal levels of every shell node (K).

        Returns
        -------
        vm, ratio : ndarray of shape (n_surfaces, n_elem, 9)
            Pa and ``vm / yield(T)`` (NaN where the layer states no yield strength).
        """
        st = self.structure
        E = st.mesh.n_elem
        e6 = generalized_strain(st.q3, st.element_dofs(u), st.kx, st.ky, nonlinear=True)
        T_pts = st.at_points(np.asarray(T_profile, float), st.q3)          # (E, 9, L)
        vm = np.empty((len(self.surfaces), E, e6.shape[1]))
        ratio = np.empty_like(vm)
        for i, s in enumerate(self.surfaces):
            layer = st.panel.layers[s.layer]
            mat = layer.material
            T = T_pts[..., s.level]
            eps = e6[..., :3] + s.z * e6[..., 3:]                            # global axes
            if layer.angle != 0.0:
                eps = eps @ strain_rotation(layer.angle).T                    # material axes
            eT, _ = mat.thermal_strain(T, self._T0)                          # (E, 9, 2)
            mech = eps - np.concatenate([eT, np.zeros(eT.shape[:-1] + (1,))], axis=-1)
            Q, _, _ = mat.lamina_values(T)                                   # (E, 9, 3, 3)
            sigma = np.einsum("...ij,...j->...i", Q, mech)
            vm[i] = von_mises(sigma)
            ratio[i] = vm[i] / mat.yield_at(T)
        return vm, ratio

    def peak(self, u: Array, T_profile: Array) -> StressPeak:
        """The largest von Mises stress and utilization of one state (:class:`StressPeak`)."""
        if not self.surfaces:
            nan3 = (float("nan"),) * 3
            return StressPeak(float("nan"), nan3, -1, float("nan"), nan3, float("nan"))
        vm, ratio = self.fields(u, T_profile)
        k = int(np.argmax(vm))
        where = self._where(k, vm.shape)
        r = np.where(np.isnan(ratio), -np.inf, ratio)
        j = int(np.argmax(r))
        has_ratio = bool(np.isfinite(r.flat[j]))
        nan = float("nan")
        return StressPeak(float(vm.flat[k]), where[0], where[1],
                          float(ratio.flat[j]) if has_ratio else nan,
                          self._where(j, vm.shape)[0] if has_ratio else (nan,) * 3,
                          float(vm.flat[j]) if has_ratio else nan)

    def _where(self, flat: int, shape: tuple[int, ...]) -> tuple[tuple[float, float, float], int]:
        i, e, q = np.unravel_index(flat, shape)
        s = self.surfaces[int(i)]
        x, y = self.points_xy[int(e), int(q)]
        return (float(x), float(y), s.z), s.layer
