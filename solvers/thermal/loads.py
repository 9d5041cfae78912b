"""Thermal boundary conditions of a step (Eqs. 4.24, 4.26-4.27): the condition on each
surface (prescribed flux, convection, radiation; a flux may be a function of the wall
temperature) and the prescribed temperatures.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

Array = NDArray[np.float64]
IntArray = NDArray[np.int64]


#: A wall heat-flux model: ``flux(T_wall) -> (q, dq_dT)`` with ``T_wall`` the surface nodal
#: temperatures, shape (n_inplane,), ``q`` the nodal flux into the surface (W/m^2), shape
#: (n_inplane,), and ``dq_dT`` its derivative: ``None`` (zero), shape (n_inplane,) for a
#: nodal (diagonal) dependence, or an (n_inplane, n_inplane) dense/sparse matrix.
FluxFunction = Callable[[Array], tuple[Array, Array | sp.spmatrix | None]]


@dataclass(frozen=True, eq=False)
class SurfaceCondition:
    """Thermal condition on the upper or lower surface (Eq. 4.24); default: insulated.

    Attributes
    ----------
    flux : None, float, ndarray or FluxFunction
        Heat flux *into* the surface (W/m^2): a uniform value; nodal values of shape
        (n_inplane,) (consistent load ``M_s q`` with the surface mass matrix); values at the
        2 x 2 Gauss points of shape (n_cells, 4); or a callable ``flux(T_wall) ->
        (q, dq_dT)`` evaluated at the Crank-Nicolson temperature ``T^alpha`` of the surface
        nodes, so an aerodynamic heat flux can be implicit in the wall temperature
        (its derivative enters the Newton Jacobian, Eq. 4.30b). ``dq_dT`` may also be a
        zero-argument callable returning it: it is then called only when the Jacobian is
        needed (a residual-only evaluation skips it).
    emissivity : float
        Emissivity for radiation ``eps sigma (T^4 - T_rad^4)`` leaving the surface; 0 = off.
    T_rad : float
        Temperature of the radiative surroundings (K).
    h : float
        Convection coefficient (W/(m^2 K)); 0 = off.
    T_ambient : float or ndarray of shape (n_inplane,)
        Convection reference (e.g. adiabatic-wall) temperature (K).
    nodal_load : bool
        If True, ``flux`` (array or callable) gives nodal heat *inputs* in W, shape
        (n_inplane,), used as they are (e.g. ``H_TF q`` from a fluid grid, Eq. 5.1b), and a
        callable's derivative is in W/K. This keeps a cell-local ``dq/dT_w`` on the fixed
        sparsity pattern (banded solver); ``M_s`` times it would reach two cells away.
    """

    flux: float | Array | FluxFunction | None = None
    emissivity: float = 0.0
    T_rad: float = 0.0
    h: float = 0.0
    T_ambient: float | Array = 0.0
    nodal_load: bool = False

    @property
    def is_insulated(self) -> bool:
        return self.flux is None and self.emissivity == 0.0 and self.h == 0.0


@dataclass(frozen=True, eq=False)
class ThermalLoads:
    """All thermal boundary conditions of a step (sides of the panel are insulated).

    Attributes
    ----------
    top, bottom : SurfaceCondition
        Upper (``z = +h/2``, flow side) and lower surface.
    prescribed_nodes : ndarray of int, optional
        Thermal node ids with prescribed temperature (Eq. 4.26).
    prescribed_values : float or ndarray, optional
        Their temperatures (K), broadcast to ``prescribed_nodes``.
    penalty : float
        Penalty number alpha-tilde of Eq. (4.27) relative to the largest diagonal entry of
        the unconstrained system (the absolute value is ``penalty * max diag``).
    """

    top: SurfaceCondition = field(default_factory=SurfaceCondition)
    bottom: SurfaceCondition = field(default_factory=SurfaceCondition)
    prescribed_nodes: IntArray | None = None
    prescribed_values: float | Array | None = None
    penalty: float = 1e10


def uniform_loads(q: float, emissivity: float, T_rad: float) -> ThermalLoads:
    """Uniform flux ``q`` into the upper surface, radiation to ``T_rad`` (the CLI case)."""
    return ThermalLoads(top=SurfaceCondition(flux=float(q), emissivity=float(emissivity),
                                             T_rad=float(T_rad)))
