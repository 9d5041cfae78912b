"""The fluid-model interface shared by every fidelity (DESIGN.md, "Contracts: Fluid model").

A fluid model receives the state of the wall on a set of surface points -- normal
displacement ``w``, its streamwise slope ``w_s`` (along the flow direction), normal velocity
``w_dot`` and wall temperature ``T_w`` -- plus a :class:`~solvers.flow.FlowCondition`, and
returns the aerodynamic overpressure ``p - p_inf`` and the heat flux into the wall ``q`` on
those points. On request it also returns the Jacobians with respect to each input, a
:class:`FluidJacobians`: the ``(n, n)`` blocks (scipy.sparse for the pointwise analytic
models and the shock-expansion strips; dense or low-rank for a ROM) and, where a fidelity
can give it, the cheap pointwise coefficient form (:meth:`FluidJacobians.pressure_coefficients`,
:meth:`FluidJacobians.tw_coefficients`). The coupled solvers compose them with the transfer
matrices (the slope operator gives dp/du_F = dp/dw + dp/dw_s @ S) through that interface
only; they never know which fidelity they hold.

Sign convention: ``w`` is positive along +z (out of the panel, into the flow side), the
slope ``w_s`` is d w / d s along the flow, and a positive overpressure pushes the wall
towards -z.
"""
from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition
from numpy.typing import NDArray

Array = NDArray[np.float64]


def _first_derivative_1d(n: int, h: float) -> sp.csr_matrix:
    """Second-order finite-difference d/dx on ``n`` uniform points (one-sided at the ends)."""
    if n == 1:
        return sp.csr_matrix((1, 1))
    if n == 2:
        return sp.csr_matrix(np.array([[-1.0, 1.0], [-1.0, 1.0]]) / h)
    D = sp.diags([np.full(n - 1, -0.5 / h), np.full(n - 1, 0.5 / h)], [-1, 1],
                 shape=(n, n), format="lil")
    D[0, :3] = np.array([-1.5, 2.0, -0.5]) / h
    D[n - 1, n - 3:] = np.array([0.5, -2.0, 1.5]) / h
    return D.tocsr()


@dataclass(frozen=True, eq=False)
class SurfacePoints:
    """Points on the panel's upper surface where the fluid model is evaluated.

    Attributes
    ----------
    x, y : ndarray of shape (n,)
        Panel coordinates (m): x streamwise from the panel's leading edge, y spanwise.
    x_le : ndarray of shape (n,)
        Distance from the leading edge of the rigid wall ahead of the panel, measured
        along the flow direction (m): ``L_le + x cos(beta) + y sin(beta)`` (strip theory,
        Eq. 2.36).
    streamwise_derivative : scipy.sparse matrix of shape (n, n)
        Operator S giving d f / d s along the flow for a field f on these points.
    weights : ndarray of shape (n,)
        Area weights (m^2) for integrals over the surface (trapezoidal rule).
    shape : tuple of int
        (n_x, n_y) of the structured grid; point k = j * n_x + i.
    """

    x: Array
    y: Array
    x_le: Array
    streamwise_derivative: sp.csr_matrix
    weights: Array
    shape: tuple[int, int]
    flow_angle: float = 0.0

    @property
    def n(self) -> int:
        return int(self.x.size)

    @classmethod
    def grid(cls, length: float, width: float, leading_edge_length: float, n_x: int,
             n_y: int, flow_angle: float = 0.0) -> SurfacePoints:
        """A uniform ``n_x`` x ``n_y`` grid of points over [0, a] x [0, b] (edges included).

        ``n_y = 1`` gives a single line of points at y = b/2 (2D panel).
        """
        if n_x < 2:
            raise InputError("fluid_grid", "needs at least 2 points streamwise")
        if n_y < 1:
            raise InputError("fluid_grid", "needs at least 1 point spanwise")
        if leading_edge_length < 0.0:
            raise InputError("panel.leading_edge_length", "must be >= 0 (m)")
        xs = np.linspace(0.0, length, n_x)
        ys = np.linspace(0.0, width, n_y) if n_y > 1 else np.array([0.5 * width])
        X, Y = np.meshgrid(xs, ys)  # (n_y, n_x): point k = j * n_x + i
        x, y = X.ravel(), Y.ravel()
        c, s = math.cos(flow_angle), math.sin(flow_angle)
        x_le = leading_edge_length + c * x + s * y
        if np.any(x_le <= 0.0):
            raise InputError("panel.leading_edge_length",
                             "the flow must reach every panel point after the leading edge "
                             "(x_le > 0); increase L_le or reduce the flow angle")
        Dx = _first_derivative_1d(n_x, xs[1] - xs[0])
        S = c * sp.kron(sp.identity(n_y), Dx)
        wx = np.full(n_x, xs[1] - xs[0])
        wx[[0, -1]] *= 0.5
        if n_y > 1:
            Dy = _first_derivative_1d(n_y, ys[1] - ys[0])
            S = S + s * sp.kron(Dy, sp.identity(n_x))
            wy = np.full(n_y, ys[1] - ys[0])
            wy[[0, -1]] *= 0.5
        else:
            wy = np.array([width])
        return cls(x=x, y=y, x_le=x_le, streamwise_derivative=sp.csr_matrix(S),
                   weights=np.outer(wy, wx).ravel(), shape=(n_x, n_y), flow_angle=flow_angle)


@dataclass(frozen=True)
class SurfaceState:
    """Wall state on the surface points, each of shape (n,) (SI units)."""

    displacement: Array
    slope: Array
    velocity: Array
    wall_temperature: Array

    @classmethod
    def flat(cls, n: int, wall_temperature: float | Array) -> SurfaceState:
        """Undeformed, motionless wall."""
        z = np.zeros(n)
        return cls(z, z.copy(), z.copy(), np.broadcast_to(
            np.asarray(wall_temperature, dtype=float), (n,)).copy())


#: Names of the Jacobian blocks: d(output)/d(input).
JACOBIAN_KEYS = ("dp_dw", "dp_dws", "dp_dwdot", "dp_dTw", "dq_dw", "dq_dws", "dq_dwdot",
                 "dq_dTw")


class FluidJacobians(Mapping):
    """The Jacobians of a fluid model's output on its surface points (Eq. 5.34 needs them).

    A read-only mapping from each key of :data:`JACOBIAN_KEYS` (``"dp_dws"`` = dp/dw_s, ...)
    to an ``(n, n)`` block: scipy.sparse, ndarray or any object supporting ``@`` and
    ``toarray()``. A fidelity whose Jacobians have the pointwise form (each output at a point
    depends on the inputs at that point only, up to the streamwise derivative ``S`` of the
    points, :attr:`SurfacePoints.streamwise_derivative`) also gives their coefficients, so the
    coupled solvers can form the transferred matrices on fixed patterns without building the
    blocks; the default is None ("not of that form"), and the blocks are then used.
    """

    def pressure_coefficients(self) -> tuple[Array, Array] | None:
        """The pointwise form of the pressure Jacobian, ``(s, v)`` of shape (n,) each, with
        ``dp/dw = 0``, ``dp/dw_s = diag(s)`` and ``dp/dw_dot = diag(v)``; None when the
        pressure Jacobian is not of that form."""
        return None

    def tw_coefficients(self) -> tuple[Array, Array | None] | None:
        """The pointwise form of the wall-temperature heat-flux Jacobian, ``(a, b)`` with
        ``dq/dT_w = diag(a) + diag(b) S`` (``b`` None: ``diag(a)`` alone); None when it is not
        of that form. May be costly (called only when the thermal Newton needs it)."""
        return None


class BlockJacobians(FluidJacobians):
    """:class:`FluidJacobians` given as their blocks only (no pointwise form).

    Parameters
    ----------
    blocks : mapping
        Each key of :data:`JACOBIAN_KEYS` (or none, for no Jacobians) to its ``(n, n)`` block.
    """

    def __init__(self, blocks: Mapping[str, object]) -> None:
        self._blocks = dict(blocks)

    def __getitem__(self, key: str) -> object:
        return self._blocks[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self._blocks)

    def __len__(self) -> int:
        return len(self._blocks)


@dataclass
class FluidLoads:
    """Fluid model output on the surface points.

    Attributes
    ----------
    pressure : ndarray of shape (n,)
        Overpressure p - p_inf (Pa); positive pushes the wall towards -z.
    heat_flux : ndarray of shape (n,)
        Heat flux into the wall (W/m^2).
    jacobians : FluidJacobians
        When requested: the Jacobians (empty otherwise). A fidelity may also assign a plain
        mapping of blocks (each key of :data:`JACOBIAN_KEYS` to an ``(n, n)`` matrix): it is
        held as :class:`BlockJacobians`, so every consumer sees the one interface.
    """

    pressure: Array
    heat_flux: Array
    jacobians: FluidJacobians = field(default_factory=lambda: BlockJacobians({}))

    def __setattr__(self, name: str, value: object) -> None:
        if name == "jacobians" and not isinstance(value, FluidJacobians):
            value = BlockJacobians(value)  # type: ignore[arg-type]
        super().__setattr__(name, value)


class FluidModel(ABC):
    """A fluid model of any fidelity (analytic, ROM, user snapshots)."""

    #: Short name used in configs ("pt", "pt-bl", "rom:PATH", ...).
    name: str = "fluid"
    #: Wall heating of the model: "none" when its heat flux is identically zero (a coupled
    #: run with no other heat source then skips the thermal steps), else the law's name.
    heating: str = "eckert"

    @abstractmethod
    def evaluate(self, points: SurfacePoints, state: SurfaceState, flow: FlowCondition,
                 jacobians: bool = False) -> FluidLoads:
        """Pressure and heat flux on ``points`` (and the Jacobians when asked)."""


def dense(matrix: Any) -> Array:
    """A Jacobian block as a dense array (for tests and small problems)."""
    if sp.issparse(matrix):
        return matrix.toarray()
    if hasattr(matrix, "toarray"):
        return np.asarray(matrix.toarray())
    return np.asarray(matrix)
