"""Compressible laminar flat-plate boundary layer: the exact similarity solution.

The reference the laminar Eckert estimate (Eqs. 2.39-2.43) approximates, for verifying a
CFD heat flux (README, "CFD snapshots"). Zero pressure gradient, calorically perfect gas
with a constant Prandtl number and a viscosity law ``mu(T)`` (Sutherland by default: the
Eucken conductivity of OpenFOAM's Sutherland transport keeps ``Pr`` constant). With the
Illingworth-Levy (Howarth-Dorodnitsyn) variables ``xi = rho_e mu_e u_e x``, ``eta = u_e /
sqrt(2 xi) int rho dy``, ``f' = u / u_e``, ``g = T / T_e`` and the Chapman-Rubesin
parameter ``C = rho mu / (rho_e mu_e) = mu(g T_e) / (mu(T_e) g)`` the momentum and energy
equations are the ordinary differential equations (White, *Viscous Fluid Flow*, Sec. 7-3)

    (C f'')' + f f'' = 0,
    (C g' / Pr)' + f g' + (gamma - 1) M_e^2 C f''^2 = 0,

with ``f(0) = f'(0) = 0``, ``g(0) = T_w / T_e``, ``f'(inf) = g(inf) = 1``, solved as a
boundary-value problem (``scipy.integrate.solve_bvp``) on a truncated ``eta`` range. The
wall heat flux into the wall and the skin friction follow as

    q_w = (c_p T_e / Pr) C_w g'(0) sqrt(rho_e mu_e u_e / (2 x)),
    c_f = sqrt(2) C_w f''(0) / sqrt(Re_x).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from hypate.solvers.aero.base import Array
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition, sutherland_viscosity
from numpy.typing import ArrayLike
from scipy.integrate import solve_bvp

__all__ = ["SimilarityProfile", "edge_state", "laminar_similarity", "similarity_heat_flux"]

#: Truncation of the outer boundary in eta: the profiles reach their edge values there to
#: < 1e-8 for the Mach numbers and wall temperatures of the checks (tested: doubling it
#: changes g'(0) by < 1e-6).
ETA_MAX = 12.0


@dataclass(frozen=True)
class SimilarityProfile:
    """A solved similarity profile on ``eta`` (all dimensionless)."""

    eta: Array
    f: Array
    velocity: Array  # f' = u / u_e
    temperature: Array  # g = T / T_e
    chapman_rubesin: Array  # C(eta)
    shear: float  # f''(0)
    heat: float  # g'(0): > 0 when heat flows into the wall

    @property
    def wall_chapman_rubesin(self) -> float:
        return float(self.chapman_rubesin[0])


def laminar_similarity(mach_e: float, T_e: float, T_w: float, gamma: float, prandtl: float,
                       viscosity: Callable[[Array], Array] = sutherland_viscosity,
                       eta_max: float = ETA_MAX, tol: float = 1e-8) -> SimilarityProfile:
    """Solve the compressible similarity equations (module docstring) for an edge Mach
    number ``mach_e``, edge temperature ``T_e`` (K) and wall temperature ``T_w`` (K)."""
    for name, value in (("mach_e", mach_e), ("T_e", T_e), ("T_w", T_w), ("prandtl", prandtl)):
        if not (np.isfinite(value) and value > 0.0):
            raise InputError(name, f"must be a positive number; got {value:g}")
    if not gamma > 1.0:
        raise InputError("gamma", f"must be > 1 (a perfect gas); got {gamma:g}")
    g_w = T_w / T_e
    e = (gamma - 1.0) * mach_e**2
    mu_e = float(viscosity(np.asarray(T_e, float)))

    def chapman(g: Array) -> Array:
        return viscosity(np.maximum(g, 1e-3) * T_e) / (mu_e * np.maximum(g, 1e-3))

    # unknowns y = [f, f', C f'', g, C g' / Pr]
    def rhs(_eta: Array, y: Array) -> Array:
        C = chapman(y[3])
        fpp, gp = y[2] / C, prandtl * y[4] / C
        return np.vstack([y[1], fpp, -y[0] * fpp, gp, -y[0] * gp - e * C * fpp**2])

    def bc(ya: Array, yb: Array) -> Array:
        return np.array([ya[0], ya[1], ya[3] - g_w, yb[1] - 1.0, yb[3] - 1.0])

    # start from Blasius-like velocity and the Crocco-Busemann temperature (recovery sqrt(Pr))
    eta = np.linspace(0.0, eta_max, 241)
    fp = 1.0 - np.exp(-eta)
    g_aw = 1.0 + 0.5 * np.sqrt(prandtl) * e
    g = g_w + (g_aw - g_w) * fp - 0.5 * np.sqrt(prandtl) * e * fp**2
    C0 = chapman(g)
    y0 = np.vstack([eta - fp, fp, C0 * np.exp(-eta),
                    g, C0 / prandtl * np.gradient(g, eta)])
    sol = solve_bvp(rhs, bc, eta, y0, tol=tol, max_nodes=200000)
    if not sol.success:
        raise RuntimeError(f"similarity solution did not converge: {sol.message}")
    x = sol.x
    y = sol.y
    C = chapman(y[3])
    return SimilarityProfile(eta=x, f=y[0], velocity=y[1], temperature=y[3],
                             chapman_rubesin=C, shear=float(y[2, 0] / C[0]),
                             heat=float(prandtl * y[4, 0] / C[0]))


def edge_state(flow: FlowCondition, p_e: float) -> tuple[float, float, float]:
    """Edge temperature (K), velocity (m/s) and Mach number at edge pressure ``p_e`` (Pa):
    the isentropic compression or expansion of the free stream, Eq. (2.44) (as the Eckert
    estimate forms it)."""
    g = flow.gamma
    T_e = flow.temperature * (p_e / flow.pressure) ** ((g - 1.0) / g)
    u_e = float(np.sqrt(2.0 * flow.cp * (flow.stagnation_temperature - T_e)))
    return float(T_e), u_e, u_e / float(np.sqrt(g * flow.gas_constant * T_e))


def similarity_heat_flux(flow: FlowCondition, p_e: float, T_w: float, x_le: ArrayLike,
                         viscosity: Callable[[Array], Array] = sutherland_viscosity) -> Array:
    """Laminar heat flux into the wall (W/m^2) at distances ``x_le`` (m) from the leading
    edge of a flat plate at wall temperature ``T_w`` (K) under the edge pressure ``p_e``
    (Pa; one value: zero pressure gradient), with ``flow``'s gas (its ``prandtl``)."""
    T_e, u_e, M_e = edge_state(flow, float(p_e))
    s = laminar_similarity(M_e, T_e, T_w, flow.gamma, flow.prandtl, viscosity)
    rho_e = p_e / (flow.gas_constant * T_e)
    mu_e = float(viscosity(np.asarray(T_e, float)))
    x = np.asarray(x_le, float)
    if not np.all(x > 0.0):
        raise InputError("x_le", "must be > 0 (m from the leading edge)")
    return (flow.cp * T_e / flow.prandtl) * s.wall_chapman_rubesin * s.heat * np.sqrt(
        rho_e * mu_e * u_e / (2.0 * x))
