"""Analytical aerothermodynamics (Dissertation Sec. 2.3), pointwise and vectorized.

Pressure: full piston theory (Eq. 2.30), first and third order (Eq. 2.32), linearized
supersonic theory (Eq. 2.37), each on the normal Mach number (Eq. 2.31); optionally on the
*effective shape* (Eq. 2.33) with the Cox-Crabtree boundary-layer thickness (Eqs. 2.34-2.35)
applied along the flow direction (strip theory, Eq. 2.36).

Heat flux: Eckert's reference enthalpy method (Eqs. 2.39-2.44) for a calorically perfect
gas (H = c_p T, so Eq. 2.43 reads T_r = 0.28 T_e + 0.5 T_w + 0.22 T_aw), laminar or
turbulent, with the edge state from the local pressure of the model (Eq. 2.44).

Pointwise derivatives of the Eckert flux are taken by the complex step (exact to machine
precision, not a finite difference); the rest is differentiated analytically.
"""
from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from functools import partial

import numpy as np
import scipy.sparse as sp
from hypate.solvers.aero.base import (
    Array,
    FluidJacobians,
    FluidLoads,
    FluidModel,
    SurfacePoints,
    SurfaceState,
)
from hypate.solvers.errors import InputError
from hypate.solvers.flow import SUTHERLAND_S, FlowCondition, sutherland_viscosity
from numpy.typing import ArrayLike

#: Pressure laws accepted by :class:`AnalyticFluid`.
PRESSURE_MODELS = ("pt", "pt1", "pt3", "ls")
#: Cox-Crabtree turbulent coefficients (Eq. 2.35): delta** = 0.016 x Re^-m, delta* = 0.020 ...
CC_MOMENTUM, CC_DISPLACEMENT, CC_EXPONENT = 0.016, 0.020, 1.0 / 7.0
#: Eckert recovery-factor exponents and skin-friction laws (Eq. 2.42).
RECOVERY_EXPONENT = {"turbulent": 1.0 / 3.0, "laminar": 0.5}
_COMPLEX_STEP = 1e-30


# -- pressure laws ---------------------------------------------------------------------
def normal_mach(flow: FlowCondition, slope: ArrayLike, velocity: ArrayLike) -> Array:
    """Normal Mach number M_n = M u_{F,x} + u_F_dot / a (Eq. 2.31)."""
    return flow.mach * np.asarray(slope, float) + np.asarray(velocity, float) / flow.speed_of_sound


def piston_pressure(mn: ArrayLike, p_inf: float, gamma: float, order: str = "pt"
                    ) -> tuple[Array, Array]:
    """Piston-theory overpressure p - p_inf and d/dM_n.

    ``order`` is "pt" (full, Eq. 2.30), "pt1" (Eq. 2.32a) or "pt3" (Eq. 2.32b). The full
    law is floored at vacuum (p = 0) where 1 + (gamma-1)/2 M_n <= 0.
    """
    mn = np.asarray(mn)
    if order == "pt1":
        return gamma * p_inf * mn, np.full(mn.shape, gamma * p_inf)
    if order == "pt3":
        c2, c3 = (1.0 + gamma) / 4.0, (1.0 + gamma) / 12.0
        p = gamma * p_inf * mn * (1.0 + c2 * mn + c3 * mn**2)
        return p, gamma * p_inf * (1.0 + 2.0 * c2 * mn + 3.0 * c3 * mn**2)
    if order != "pt":
        raise InputError("simulation.aero", f"unknown piston-theory order {order!r}")
    expo = 2.0 * gamma / (gamma - 1.0)
    base = 1.0 + 0.5 * (gamma - 1.0) * mn
    vacuum = np.real(base) <= 0.0
    base = np.where(vacuum, 1.0, base)
    p = np.where(vacuum, -p_inf, p_inf * base**expo - p_inf)
    dp = np.where(vacuum, 0.0, p_inf * expo * 0.5 * (gamma - 1.0) * base ** (expo - 1.0))
    return p, dp


def linearized_supersonic_pressure(flow: FlowCondition, slope: ArrayLike, velocity: ArrayLike
                                   ) -> tuple[Array, Array, Array]:
    """Linearized supersonic theory (Eq. 2.37): p, dp/d(slope), dp/d(velocity)."""
    M, g, pinf = flow.mach, flow.gamma, flow.pressure
    c = g * pinf * M / np.sqrt(M * M - 1.0)
    cv = c * (M * M - 2.0) / (M * M - 1.0) / flow.speed_of_sound
    slope, velocity = np.asarray(slope, float), np.asarray(velocity, float)
    p = c * M * slope + cv * velocity
    return p, np.full(p.shape, c * M), np.full(p.shape, cv)


# -- boundary layer (effective shape) ------------------------------------------------------
@dataclass(frozen=True)
class BoundaryLayerShape:
    """Cox-Crabtree displacement of the effective shape, Eqs. (2.34)-(2.36).

    ``delta(x, T_w) = (g-1)/(g+1) (d** + d* T_w/T0) M^2 C_w^m`` with turbulent
    ``d** = 0.016 x Re_x^-m``, ``d* = 0.020 x Re_x^-m``, ``m = 1/7`` and the Chapman-Rubesin
    coefficient ``C_w = mu(T_w) T_inf / (mu_inf T_w)``. Because ``delta ~ x^(6/7) f(T_w)``,
    its slope along the flow is ``delta [6/(7 x) + (ln f)' dT_w/ds]``.
    """

    flow: FlowCondition

    def _log_f_derivatives(self, T: Array) -> tuple[Array, Array]:
        T0, m = self.flow.stagnation_temperature, CC_EXPONENT
        a, b = CC_MOMENTUM, CC_DISPLACEMENT / T0
        lin = a + b * T
        d1 = b / lin + m * (0.5 / T - 1.0 / (T + SUTHERLAND_S))
        d2 = -(b / lin) ** 2 + m * (-0.5 / T**2 + 1.0 / (T + SUTHERLAND_S) ** 2)
        return d1, d2

    def thickness(self, x_le: ArrayLike, T_w: ArrayLike) -> Array:
        """delta^CC (m) at distance ``x_le`` from the leading edge, wall temperature T_w."""
        f = self.flow
        x, T = np.asarray(x_le, float), np.asarray(T_w, float)
        m = CC_EXPONENT
        re_x = f.reynolds_per_meter * x
        c_w = sutherland_viscosity(T) * f.temperature / (f.viscosity * T)
        core = (CC_MOMENTUM + CC_DISPLACEMENT * T / f.stagnation_temperature) * x / re_x**m
        return (f.gamma - 1.0) / (f.gamma + 1.0) * core * f.mach**2 * c_w**m

    def slope(self, x_le: ArrayLike, T_w: ArrayLike, dTw_ds: ArrayLike
              ) -> tuple[Array, Array, Array]:
        """d delta / ds along the flow and its partials w.r.t. T_w and dT_w/ds (pointwise)."""
        x, T, Ts = (np.asarray(v, float) for v in (x_le, T_w, dTw_ds))
        d = self.thickness(x, T)
        L1, L2 = self._log_f_derivatives(T)
        geo = (1.0 - CC_EXPONENT) / x
        ds = d * (geo + L1 * Ts)
        d_ds_dT = d * L1 * (geo + L1 * Ts) + d * L2 * Ts
        d_ds_dTs = d * L1
        return ds, d_ds_dT, d_ds_dTs


# -- Eckert heat flux ----------------------------------------------------------------------
def eckert_heat_flux(flow: FlowCondition, p_e: ArrayLike, T_w: np.ndarray | float,
                     x_le: ArrayLike, regime: str = "turbulent") -> Array:
    """Eckert reference-enthalpy heat flux into the wall (W/m^2), Eqs. (2.39)-(2.44).

    Parameters
    ----------
    p_e : array_like
        Absolute edge pressure (Pa), equal to the wall pressure of the pressure model.
    T_w : ndarray or float
        Wall temperature (K).
    x_le : array_like
        Distance from the leading edge (m).
    regime : {"turbulent", "laminar"}

    Works on complex inputs (used for complex-step derivatives).
    """
    if regime not in RECOVERY_EXPONENT:
        raise InputError("simulation.boundary_layer", "must be 'turbulent' or 'laminar'")
    g, R, cp, pr = flow.gamma, flow.gas_constant, flow.cp, flow.prandtl
    T0 = flow.stagnation_temperature
    # Eq. (2.44): isentropic expansion/compression from the free stream to the edge. The
    # edge pressure is kept inside (1e-3 p_inf, 0.95 p_0): beyond, the edge velocity would
    # vanish or turn imaginary (only reached by Newton overshoots, never at a solution).
    lo, hi = 1e-3 * flow.pressure, 0.95 * flow.stagnation_pressure
    p_e = np.where(np.real(p_e) < lo, lo, np.where(np.real(p_e) > hi, hi, p_e))
    T_e = flow.temperature * (p_e / flow.pressure) ** ((g - 1.0) / g)
    V_e2 = 2.0 * cp * (T0 - T_e)  # energy equation, same as M_e sqrt(gamma R T_e) squared
    V_e = np.sqrt(V_e2)
    T_aw = T_e + pr ** RECOVERY_EXPONENT[regime] * V_e2 / (2.0 * cp)  # Eq. (2.41)
    T_r = 0.28 * T_e + 0.5 * T_w + 0.22 * T_aw  # Eq. (2.43) with H = c_p T
    rho_r = p_e / (R * T_r)
    re = rho_r * V_e * x_le / sutherland_viscosity(T_r)
    if regime == "turbulent":
        c_f = 0.370 * (np.log10(re)) ** -2.584  # Eq. (2.42)
    else:
        c_f = 0.664 * re**-0.5
    stanton = c_f / (2.0 * pr ** (2.0 / 3.0))  # Eq. (2.40)
    return stanton * rho_r * V_e * cp * (T_aw - T_w)  # Eq. (2.39)


def eckert_with_derivatives(flow: FlowCondition, p_e: Array, T_w: Array, x_le: Array,
                            regime: str) -> tuple[Array, Array, Array]:
    """q and its partials dq/dp_e, dq/dT_w (complex step, machine precision)."""
    q = eckert_heat_flux(flow, p_e, T_w, x_le, regime)
    dq_dp, dq_dT = eckert_derivatives(flow, p_e, T_w, x_le, regime)
    return np.real(q), dq_dp, dq_dT


def eckert_derivatives(flow: FlowCondition, p_e: Array, T_w: Array, x_le: Array,
                       regime: str) -> tuple[Array, Array]:
    """dq/dp_e and dq/dT_w of the Eckert flux (complex step, machine precision)."""
    h = _COMPLEX_STEP
    # both complex steps in one vectorized call (the same numbers as two calls)
    n = np.size(p_e)
    pc = np.concatenate([np.asarray(p_e) + 1j * h * flow.pressure,
                         np.asarray(p_e, dtype=complex)])
    Tc = np.concatenate([np.asarray(T_w, dtype=complex), np.asarray(T_w) + 1j * h])
    xc = np.concatenate([np.broadcast_to(x_le, np.shape(p_e)),
                         np.broadcast_to(x_le, np.shape(p_e))])
    qc = np.imag(eckert_heat_flux(flow, pc, Tc, xc, regime))
    return qc[:n] / (h * flow.pressure), qc[n:] / h


def adiabatic_wall_temperature(flow: FlowCondition, p_e: ArrayLike, regime: str = "turbulent"
                               ) -> Array:
    """T_aw at edge pressure p_e (Eq. 2.41); the Eckert flux vanishes at T_w = T_aw."""
    g = flow.gamma
    T_e = flow.temperature * (np.asarray(p_e, float) / flow.pressure) ** ((g - 1.0) / g)
    return T_e + flow.prandtl ** RECOVERY_EXPONENT[regime] * (flow.stagnation_temperature - T_e)


# -- the fluid model -------------------------------------------------------------------
class PointwiseJacobians(FluidJacobians):
    """The Jacobians of a pointwise model, kept as their diagonals.

    The :class:`~hypate.solvers.aero.base.FluidJacobians` of the analytic laws: the sparse
    ``(n, n)`` blocks are built on first access; the coupling reads the diagonals through
    :meth:`pressure_coefficients` and :meth:`tw_coefficients` (a pointwise Jacobian is
    diagonal, except the effective-shape wall-temperature term ``diag(a) + diag(b) S``), so
    the hot path never builds sparse matrices.

    Attributes
    ----------
    dp_ds, dp_dv : ndarray (n,)
        dp/d(slope) and dp/d(normal velocity).
    dq_dpe, dq_dT : ndarray (n,)
        Partials of the heat flux w.r.t. the edge pressure and the wall temperature;
        computed on first access when ``heat_derivatives`` (a callable returning both) is
        given instead (the structural Newton and the LSA never need them).
    d_s_dT, d_s_dTs : ndarray (n,) or None
        Partials of the effective-shape slope w.r.t. T_w and dT_w/ds (None: no effective
        shape); ``S`` the streamwise-derivative operator.
    """

    def __init__(self, n: int, dp_ds: Array, dp_dv: Array, dq_dpe: Array | None,
                 dq_dT: Array | None, d_s_dT: Array | None = None,
                 d_s_dTs: Array | None = None, S: sp.spmatrix | None = None,
                 heat_derivatives=None) -> None:
        self.n = n
        self.dp_ds, self.dp_dv = dp_ds, dp_dv
        self._dq: tuple[Array, Array] | None = None
        if dq_dpe is not None:
            assert dq_dT is not None  # the two partials are given together or not at all
            self._dq = (dq_dpe, dq_dT)
        self._heat_derivatives = heat_derivatives
        self.d_s_dT, self.d_s_dTs, self.S = d_s_dT, d_s_dTs, S
        self._built: dict[str, object] | None = None

    def _heat(self) -> tuple[Array, Array]:
        if self._dq is None:
            self._dq = self._heat_derivatives()
        return self._dq

    @property
    def dq_dpe(self) -> Array:
        return self._heat()[0]

    @property
    def dq_dT(self) -> Array:
        return self._heat()[1]

    @property
    def effective_shape(self) -> bool:
        return self.d_s_dT is not None

    def pressure_coefficients(self) -> tuple[Array, Array]:
        """``dp/dw = 0``, ``dp/dw_s = diag(dp_ds)``, ``dp/dw_dot = diag(dp_dv)``: (dp_ds, dp_dv)."""
        return self.dp_ds, self.dp_dv

    def tw_coefficients(self) -> tuple[Array, Array | None]:
        """``dq/dT_w = diag(a) + diag(b) S``: (a, b); b None without the effective shape."""
        if not self.effective_shape:
            return self.dq_dT, None
        f = self.dq_dpe * self.dp_ds
        assert self.d_s_dT is not None and self.d_s_dTs is not None  # given with the shape
        return self.dq_dT + f * self.d_s_dT, f * self.d_s_dTs

    def _build(self) -> dict[str, object]:
        if self._built is None:
            n = self.n
            zero = sp.csr_matrix((n, n))
            dp_dTw: object = zero
            if self.effective_shape:
                dp_dTw = sp.diags(self.dp_ds) @ (sp.diags(self.d_s_dT)
                                                 + sp.diags(self.d_s_dTs) @ self.S)
            Dq = sp.diags(self.dq_dpe)
            self._built = {
                "dp_dw": zero, "dp_dws": sp.diags(self.dp_ds).tocsr(),
                "dp_dwdot": sp.diags(self.dp_dv).tocsr(), "dp_dTw": sp.csr_matrix(dp_dTw),
                "dq_dw": zero, "dq_dws": (Dq @ sp.diags(self.dp_ds)).tocsr(),
                "dq_dwdot": (Dq @ sp.diags(self.dp_dv)).tocsr(),
                "dq_dTw": (sp.diags(self.dq_dT) + Dq @ sp.csr_matrix(dp_dTw)).tocsr(),
            }
        return self._built

    def __getitem__(self, key: str) -> object:
        return self._build()[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self._build())

    def __len__(self) -> int:
        return 8


class AnalyticFluid(FluidModel):
    """Pointwise analytical fluid model.

    Parameters
    ----------
    pressure : {"pt", "pt1", "pt3", "ls"}
        Pressure law.
    effective_shape : bool
        Add the Cox-Crabtree boundary-layer slope to the wall slope (Eq. 2.33).
    heating : {"eckert", "none"}
    regime : {"turbulent", "laminar"}
        Boundary-layer regime of the Eckert flux.
    """

    def __init__(self, pressure: str = "pt", effective_shape: bool = False,
                 heating: str = "eckert", regime: str = "turbulent") -> None:
        if pressure not in PRESSURE_MODELS:
            raise InputError("simulation.aero", f"pressure model must be one of "
                             f"{', '.join(PRESSURE_MODELS)}; got {pressure!r}")
        if heating not in ("eckert", "none"):
            raise InputError("simulation.heating", "must be 'eckert' or 'none'")
        if regime not in RECOVERY_EXPONENT:
            raise InputError("simulation.boundary_layer", "must be 'turbulent' or 'laminar'")
        if effective_shape and pressure == "ls":
            raise InputError("simulation.aero", "the effective shape is defined for piston "
                             "theory (pt, pt1, pt3), not for 'ls'")
        self.pressure_model = pressure
        self.effective_shape = effective_shape
        self.heating = heating
        self.regime = regime
        self.name = pressure + ("-bl" if effective_shape else "")

    def evaluate(self, points: SurfacePoints, state: SurfaceState, flow: FlowCondition,
                 jacobians: bool = False) -> FluidLoads:
        n = points.n
        slope = np.asarray(state.slope, float)
        velocity = np.asarray(state.velocity, float)
        T_w = np.asarray(state.wall_temperature, float)
        S = points.streamwise_derivative
        d_s_dT = d_s_dTs = None
        if self.pressure_model == "ls":
            p, dp_ds, dp_dv = linearized_supersonic_pressure(flow, slope, velocity)
        else:
            eff = slope
            if self.effective_shape:
                bl = BoundaryLayerShape(flow)
                dTw_ds = S @ T_w
                d_s, d_s_dT, d_s_dTs = bl.slope(points.x_le, T_w, dTw_ds)
                eff = slope + d_s
            mn = normal_mach(flow, eff, velocity)
            p, dp_dmn = piston_pressure(mn, flow.pressure, flow.gamma, self.pressure_model)
            dp_ds = dp_dmn * flow.mach
            dp_dv = dp_dmn / flow.speed_of_sound
            # effective shape: d(delta_s)/dT_w = diag(d_s_dT) + diag(d_s_dTs) S (chain rule
            # through S T_w), so dp/dT_w = diag(dp_ds) (diag(d_s_dT) + diag(d_s_dTs) S)
        heat_derivatives = None
        if self.heating == "eckert":
            p_e = flow.pressure + p
            q = np.real(eckert_heat_flux(flow, p_e, T_w, points.x_le, self.regime))
            dq_dpe = dq_dT = None  # on demand (only the thermal Jacobian needs them)
            heat_derivatives = partial(eckert_derivatives, flow, p_e, T_w, points.x_le,
                                       self.regime)
        else:
            q, dq_dpe, dq_dT = np.zeros(n), np.zeros(n), np.zeros(n)
        loads = FluidLoads(pressure=p, heat_flux=q)
        if jacobians:
            bl_eff = self.effective_shape and self.pressure_model != "ls"
            loads.jacobians = PointwiseJacobians(
                n, np.asarray(dp_ds, float), np.asarray(dp_dv, float), dq_dpe, dq_dT,
                d_s_dT if bl_eff else None, d_s_dTs if bl_eff else None, S if bl_eff else None,
                heat_derivatives=heat_derivatives)
        return loads
