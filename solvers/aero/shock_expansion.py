"""Shock-expansion aerothermodynamics: the built-in higher-fidelity sample source of the ROM.

A *non-pointwise* inviscid/viscous-interaction model (Dissertation Sec. 2.4, the role played by
CFD in Sec. 7.1), used to generate ROM snapshots and to check the ROM:

* **Effective shape** (Eq. 2.33): the local flow inclination along the wall is
  ``theta = atan(w_s + delta_s^CC + w_dot / V_inf)``, with the Cox-Crabtree displacement
  slope ``delta_s^CC`` (Eqs. 2.34-2.36, :class:`~solvers.aero.analytic.BoundaryLayerShape`,
  including the wall-temperature-gradient term) and the quasi-steady surface velocity
  ``w_dot / V_inf`` (the same local angle that piston theory uses, Eq. 2.31).
* **Pressure** by the shock-expansion method, marched along flow-aligned strips: the free
  stream meets the leading edge of the rigid wall ahead of the panel, is turned by an oblique
  shock onto the effective shape of the first rigid-wall segment (exact theta-beta-M relation,
  weak solution, closed-form root of the cubic), expands isentropically (Prandtl-Meyer) along
  the rigid wall, and then, node by node along the panel, every compression corner is an
  oblique shock and every expansion corner a Prandtl-Meyer fan (exact calorically-perfect-gas
  relations; total temperature conserved, entropy rises across each shock).
* **Heat flux** by Eckert's reference enthalpy (Eqs. 2.39-2.43) with the *local* edge state
  of the march (``p_e, T_e``; ``V_e^2 = 2 c_p (T_0 - T_e)``) rather than the isentropic
  relation of Eq. (2.44).

Strips are the grid rows of :class:`~solvers.aero.base.SurfacePoints` (point ``k = j n_x + i``),
marched in increasing ``x``; this is exact for ``flow_angle = 0`` and a strip-theory
approximation otherwise (Eq. 2.36). Every strip is marched simultaneously (NumPy arrays of
shape ``(n_x, n_strips)``); many states can be marched in one call
(:meth:`ShockExpansionFluid.evaluate_batch`), which is how ROM samples are generated.

Jacobians (when requested) are central finite differences batched over strips: perturbing
all nodes with the same streamwise index at once is exact for ``flow_angle = 0`` because
strips are independent. ``dp/dw_dot = dp/dw_s / V_inf`` exactly (both enter through
``theta``).
"""
from __future__ import annotations

import math
import warnings

import numpy as np
import scipy.sparse as sp
from hypate.solvers.aero.analytic import RECOVERY_EXPONENT, BoundaryLayerShape
from hypate.solvers.aero.base import (
    Array,
    BlockJacobians,
    FluidLoads,
    FluidModel,
    SurfacePoints,
    SurfaceState,
)
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition, sutherland_viscosity
from numpy.typing import ArrayLike

__all__ = [
    "ShockExpansionFluid",
    "oblique_shock",
    "oblique_shock_angle",
    "max_deflection",
    "prandtl_meyer",
    "inverse_prandtl_meyer",
    "expansion",
    "eckert_heat_flux_edge",
    "eckert_edge_with_derivatives",
]

#: Complex step of :func:`eckert_edge_with_derivatives` (relative to the pressure scale and
#: in kelvin): far below round-off, so the derivatives are exact to machine precision.
_COMPLEX_STEP = 1e-30

#: Number of segments the first rigid-wall shock is spread over: the first shock turns the
#: flow onto the secant of the effective shape over ``x_le0 / RIGID_SEGMENTS``.
RIGID_SEGMENTS = 32


# -- exact perfect-gas relations --------------------------------------------------------
def max_deflection(mach: ArrayLike, gamma: float = 1.4) -> Array:
    """Largest deflection angle (rad) with an attached oblique shock at upstream Mach ``mach``.

    From d theta / d beta = 0 of the theta-beta-M relation (closed form for sin^2 beta*).
    """
    M2 = np.asarray(mach, float) ** 2
    g = gamma
    s2 = ((g + 1.0) * M2 - 4.0 + np.sqrt((g + 1.0) * ((g + 1.0) * M2**2 + 8.0 * (g - 1.0) * M2
                                                      + 16.0))) / (4.0 * g * M2)
    beta = np.arcsin(np.sqrt(s2))
    return _theta_from_beta(np.sqrt(M2), beta, g)


def _theta_from_beta(M: Array, beta: Array, g: float) -> Array:
    """theta-beta-M relation:
    tan theta = 2 cot beta (M^2 sin^2 beta - 1)/(M^2 (g + cos 2beta) + 2)."""
    return np.arctan(2.0 / np.tan(beta) * (M**2 * np.sin(beta) ** 2 - 1.0)
                     / (M**2 * (g + np.cos(2.0 * beta)) + 2.0))


def oblique_shock_angle(mach: ArrayLike, theta: ArrayLike, gamma: float = 1.4) -> Array:
    """Weak oblique-shock wave angle beta (rad) for deflection ``theta`` (rad) at Mach ``mach``.

    Closed-form root of the cubic in tan(beta) of the theta-beta-M relation (weak solution,
    Thompson's trigonometric form), polished by two Newton steps on the relation itself.
    ``theta`` must lie in (0, theta_max]; at ``theta -> 0`` it tends to the Mach angle.
    """
    M = np.asarray(mach, float)
    th = np.asarray(theta, float)
    M, th = np.broadcast_arrays(M, th)
    g = gamma
    M2 = M * M
    t = np.tan(th)
    a1 = 1.0 + 0.5 * (g - 1.0) * M2
    lam2 = (M2 - 1.0) ** 2 - 3.0 * a1 * (1.0 + 0.5 * (g + 1.0) * M2) * t * t
    lam = np.sqrt(np.maximum(lam2, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        chi = ((M2 - 1.0) ** 3 - 9.0 * a1 * (a1 + 0.25 * (g + 1.0) * M2 * M2) * t * t) / lam**3
        tan_b = (M2 - 1.0 + 2.0 * lam * np.cos((4.0 * np.pi + np.arccos(np.clip(chi, -1.0, 1.0)))
                                               / 3.0)) / (3.0 * a1 * t)
    mu = np.arcsin(1.0 / M)
    # weak-shock asymptote beta ~ mu + (g + 1) M^2 theta / (4 (M^2 - 1)) for small theta,
    # where the closed form suffers from cancellation
    guess = mu + 0.25 * (g + 1.0) * M2 * th / (M2 - 1.0)
    beta = np.where((th > 1e-3) & np.isfinite(tan_b), np.arctan(tan_b), guess)
    # Newton polish on f(beta) = theta(beta) - theta, derivative by the complex step
    for _ in range(4):
        h = 1e-30
        fc = _theta_from_beta(M.astype(complex), beta + 1j * h, g)
        f = fc.real - th
        df = fc.imag / h
        beta = np.where(th > 0.0, beta - f / np.where(df == 0.0, 1.0, df), mu)
    return beta


def oblique_shock(mach: ArrayLike, theta: ArrayLike, gamma: float = 1.4
                  ) -> tuple[Array, Array, Array]:
    """Downstream Mach number, static-pressure ratio p2/p1 and temperature ratio T2/T1 across a
    weak oblique shock turning the flow by ``theta`` (rad), exact perfect-gas relations.

    ``theta = 0`` returns the upstream state (Mach wave).
    """
    M = np.asarray(mach, float)
    th = np.asarray(theta, float)
    M, th = np.broadcast_arrays(M, th)
    g = gamma
    beta = oblique_shock_angle(M, th, g)
    Mn1 = M * np.sin(beta)
    Mn1_2 = np.maximum(Mn1 * Mn1, 1.0)
    p_ratio = 1.0 + 2.0 * g / (g + 1.0) * (Mn1_2 - 1.0)
    rho_ratio = (g + 1.0) * Mn1_2 / ((g - 1.0) * Mn1_2 + 2.0)
    T_ratio = p_ratio / rho_ratio
    Mn2_2 = (1.0 + 0.5 * (g - 1.0) * Mn1_2) / (g * Mn1_2 - 0.5 * (g - 1.0))
    M2 = np.sqrt(Mn2_2) / np.sin(beta - th)
    weak = th <= 0.0
    return (np.where(weak, M, M2), np.where(weak, 1.0, p_ratio), np.where(weak, 1.0, T_ratio))


def prandtl_meyer(mach: ArrayLike, gamma: float = 1.4) -> Array:
    """Prandtl-Meyer function nu(M) (rad)."""
    M = np.asarray(mach, float)
    k = math.sqrt((gamma + 1.0) / (gamma - 1.0))
    r = np.sqrt(M * M - 1.0)
    return k * np.arctan(r / k) - np.arctan(r)


def inverse_prandtl_meyer(nu: ArrayLike, mach_guess: ArrayLike, gamma: float = 1.4) -> Array:
    """Mach number with nu(M) = ``nu`` (Newton from ``mach_guess``; quadratic convergence)."""
    nu = np.asarray(nu, float)
    M = np.array(np.broadcast_to(np.asarray(mach_guess, float), nu.shape), dtype=float)
    nu_max = 0.5 * math.pi * (math.sqrt((gamma + 1.0) / (gamma - 1.0)) - 1.0)
    nu_c = np.minimum(nu, nu_max * (1.0 - 1e-9))
    for _ in range(60):
        f = prandtl_meyer(M, gamma) - nu_c
        dnu = np.sqrt(M * M - 1.0) / (M * (1.0 + 0.5 * (gamma - 1.0) * M * M))
        step = f / dnu
        M_new = np.maximum(M - step, 0.5 * (M + 1.0))  # stay supersonic
        converged = np.all(np.abs(M_new - M) <= 1e-13 * M_new)
        M = M_new
        if converged:
            break
    return M


def expansion(mach: ArrayLike, dtheta: ArrayLike, gamma: float = 1.4
              ) -> tuple[Array, Array, Array]:
    """Prandtl-Meyer expansion by ``dtheta >= 0`` (rad): downstream Mach, p2/p1, T2/T1
    (isentropic)."""
    M1 = np.asarray(mach, float)
    M2 = inverse_prandtl_meyer(prandtl_meyer(M1, gamma) + np.asarray(dtheta, float), M1, gamma)
    T_ratio = (1.0 + 0.5 * (gamma - 1.0) * M1 * M1) / (1.0 + 0.5 * (gamma - 1.0) * M2 * M2)
    return M2, T_ratio ** (gamma / (gamma - 1.0)), T_ratio


def turn(mach: Array, dtheta: Array, gamma: float) -> tuple[Array, Array, Array]:
    """Turn a supersonic stream by ``dtheta`` (rad; > 0 compression through an oblique shock,
    < 0 Prandtl-Meyer expansion). Returns downstream Mach, p2/p1 and T2/T1."""
    comp = dtheta > 0.0
    th_max = max_deflection(mach, gamma)
    if np.any(dtheta > th_max):
        warnings.warn("a compression corner exceeds the attached-shock limit theta_max; the "
                      "turn is clipped to 0.999 theta_max (detached shock not modelled)",
                      RuntimeWarning, stacklevel=3)
    Ms, ps, Ts = oblique_shock(mach, np.clip(np.where(comp, dtheta, 0.0), 0.0, 0.999 * th_max),
                               gamma)
    Me, pe, Te = expansion(mach, np.where(comp, 0.0, -dtheta), gamma)
    return np.where(comp, Ms, Me), np.where(comp, ps, pe), np.where(comp, Ts, Te)


# -- Eckert with a given edge state -------------------------------------------------------
def eckert_heat_flux_edge(flow: FlowCondition, p_e: ArrayLike, T_e: ArrayLike, T_w: ArrayLike,
                          x_le: ArrayLike, regime: str = "turbulent") -> Array:
    """Eckert reference-enthalpy heat flux (W/m^2) with a *given* edge state, Eqs. (2.39)-(2.43).

    Same law as :func:`hypate.solvers.aero.analytic.eckert_heat_flux` but the edge temperature comes
    from the shock-expansion march (entropy of the shocks included) instead of Eq. (2.44);
    the edge velocity follows from the conserved total temperature,
    ``V_e^2 = 2 c_p (T_0 - T_e)``. Complex inputs are kept (complex-step derivatives).
    """
    if regime not in RECOVERY_EXPONENT:
        raise InputError("simulation.boundary_layer", "must be 'turbulent' or 'laminar'")
    R, cp, pr = flow.gas_constant, flow.cp, flow.prandtl
    p_e, T_e, T_w, x_le = (np.asarray(v, complex if np.iscomplexobj(v) else float)
                           for v in (p_e, T_e, T_w, x_le))
    V_e2 = 2.0 * cp * (flow.stagnation_temperature - T_e)
    V_e = np.sqrt(V_e2)
    T_aw = T_e + pr ** RECOVERY_EXPONENT[regime] * V_e2 / (2.0 * cp)  # Eq. (2.41)
    T_r = 0.28 * T_e + 0.5 * T_w + 0.22 * T_aw  # Eq. (2.43), H = c_p T
    rho_r = p_e / (R * T_r)
    re = rho_r * V_e * x_le / sutherland_viscosity(T_r)
    c_f = 0.370 * np.log10(re) ** -2.584 if regime == "turbulent" else 0.664 * re**-0.5
    stanton = c_f / (2.0 * pr ** (2.0 / 3.0))  # Eq. (2.40)
    return stanton * rho_r * V_e * cp * (T_aw - T_w)  # Eq. (2.39)


def eckert_edge_with_derivatives(flow: FlowCondition, p_e: ArrayLike, T_e: ArrayLike,
                                 T_w: ArrayLike, x_le: ArrayLike, regime: str = "turbulent"
                                 ) -> tuple[Array, Array, Array, Array]:
    """:func:`eckert_heat_flux_edge` and its partials dq/dp_e, dq/dT_e, dq/dT_w (arrays of
    the broadcast shape of the inputs).

    The law is analytic in its three arguments (no branch, no absolute value; the square
    root and logarithm see positive real parts), so the complex step gives the partials to
    machine precision; the three steps go through one vectorized call.
    """
    p_e, T_e, T_w, x_le = np.broadcast_arrays(*(np.asarray(v, float)
                                                for v in (p_e, T_e, T_w, x_le)))
    q = eckert_heat_flux_edge(flow, p_e, T_e, T_w, x_le, regime)
    h = 1j * _COMPLEX_STEP
    h_p = _COMPLEX_STEP * flow.pressure  # the pressure step on the pressure's scale
    P = np.stack([p_e + h * flow.pressure, p_e + 0j, p_e + 0j])
    TE = np.stack([T_e + 0j, T_e + h, T_e + 0j])
    TW = np.stack([T_w + 0j, T_w + 0j, T_w + h])
    dq = np.imag(eckert_heat_flux_edge(flow, P, TE, TW, np.stack([x_le] * 3), regime))
    return q, dq[0] / h_p, dq[1] / _COMPLEX_STEP, dq[2] / _COMPLEX_STEP


# -- the model --------------------------------------------------------------------------
class ShockExpansionFluid(FluidModel):
    """Shock-expansion pressure + Cox-Crabtree effective shape + local-edge Eckert heat flux.

    Parameters
    ----------
    boundary_layer : bool
        Include the Cox-Crabtree displacement slope in the effective shape (Eq. 2.33).
    heating : {"eckert", "none"}
    regime : {"turbulent", "laminar"}
        Regime of the Eckert flux (the Cox-Crabtree thickness is the turbulent law, Eq. 2.35).
    fd_step : float
        Relative step of the finite-difference Jacobians (slope step ``fd_step``, wall
        temperature step ``fd_step * T_w``).
    """

    name = "shock-expansion"

    def __init__(self, boundary_layer: bool = True, heating: str = "eckert",
                 regime: str = "turbulent", fd_step: float = 1e-6) -> None:
        if heating not in ("eckert", "none"):
            raise InputError("simulation.heating", "must be 'eckert' or 'none'")
        if regime not in RECOVERY_EXPONENT:
            raise InputError("simulation.boundary_layer", "must be 'turbulent' or 'laminar'")
        self.boundary_layer = bool(boundary_layer)
        self.heating = heating
        self.regime = regime
        self.fd_step = float(fd_step)

    # ---------------------------------------------------------------- kernels
    def _effective_angle(self, points: SurfacePoints, slope: Array, velocity: Array, T_w: Array,
                         flow: FlowCondition) -> tuple[Array, Array]:
        """theta at the nodes and at the end of the rigid wall, shapes (m, n) and (m, n_y).

        ``slope``, ``velocity``, ``T_w`` have shape (m, n) (m states).
        """
        n_x, n_y = points.shape
        tan_t = slope + velocity / flow.velocity
        x_first = points.x_le.reshape(n_y, n_x)[:, 0]
        if self.boundary_layer:
            bl = BoundaryLayerShape(flow)
            dT = (points.streamwise_derivative @ T_w.T).T
            d_s, _, _ = bl.slope(points.x_le[None, :], T_w, dT)
            tan_t = tan_t + d_s
            T_first = T_w.reshape(T_w.shape[0], n_y, n_x)[:, :, 0]
            d_end, _, _ = bl.slope(x_first[None, :], T_first, 0.0)
            x1 = x_first / RIGID_SEGMENTS
            d_1 = bl.thickness(x1[None, :], T_first) / x1[None, :]
            theta_rigid = np.stack([np.arctan(d_1), np.arctan(d_end)])
        else:
            theta_rigid = np.zeros((2,) + (T_w.shape[0], n_y))
        return np.arctan(tan_t), theta_rigid

    def _march(self, points: SurfacePoints, theta: Array, theta_rigid: Array,
               flow: FlowCondition) -> tuple[Array, Array]:
        """Static pressure and temperature at the nodes, shape (m, n): the march."""
        g = flow.gamma
        n_x, n_y = points.shape
        m = theta.shape[0]
        th = theta.reshape(m, n_y, n_x)
        M = np.full((m, n_y), flow.mach)
        p = np.full((m, n_y), flow.pressure)
        T = np.full((m, n_y), flow.temperature)
        prev = np.zeros((m, n_y))
        if self.boundary_layer:  # rigid wall: leading-edge shock, then isentropic expansion
            for target in theta_rigid:
                M, pr, Tr = turn(M, target - prev, g)
                p, T, prev = p * pr, T * Tr, target
        P = np.empty((m, n_y, n_x))
        TT = np.empty((m, n_y, n_x))
        for i in range(n_x):
            M, pr, Tr = turn(M, th[:, :, i] - prev, g)
            p, T, prev = p * pr, T * Tr, th[:, :, i]
            P[:, :, i], TT[:, :, i] = p, T
        return P.reshape(m, -1), TT.reshape(m, -1)

    def evaluate_batch(self, points: SurfacePoints, slope: ArrayLike, velocity: ArrayLike,
                       wall_temperature: ArrayLike, flow: FlowCondition
                       ) -> tuple[Array, Array]:
        """Pressure ``p - p_inf`` and heat flux for ``m`` wall states at once.

        Parameters
        ----------
        points : SurfacePoints
        slope, velocity, wall_temperature : array_like of shape (m, n)
        flow : FlowCondition

        Returns
        -------
        pressure, heat_flux : ndarray of shape (m, n)
        """
        n = points.n
        slope = np.atleast_2d(np.asarray(slope, float))
        m = slope.shape[0]
        velocity = np.broadcast_to(np.asarray(velocity, float), (m, n))
        T_w = np.broadcast_to(np.asarray(wall_temperature, float), (m, n))
        if slope.shape != (m, n):
            raise InputError("state", f"slope must have shape (m, {n}); got {slope.shape}")
        if int(np.prod(points.shape)) != n:
            raise InputError("fluid_grid", "shock-expansion needs a structured grid of points")
        if np.any(T_w <= 0.0) or not np.all(np.isfinite(T_w)):
            raise InputError("state.wall_temperature", "must be positive and finite (K)")
        theta, theta_rigid = self._effective_angle(points, slope, velocity, T_w, flow)
        p_abs, T_e = self._march(points, theta, theta_rigid, flow)
        if self.heating == "eckert":
            q = eckert_heat_flux_edge(flow, p_abs, T_e, T_w, points.x_le[None, :], self.regime)
        else:
            q = np.zeros_like(p_abs)
        return p_abs - flow.pressure, q

    # ---------------------------------------------------------------- interface
    def evaluate(self, points: SurfacePoints, state: SurfaceState, flow: FlowCondition,
                 jacobians: bool = False) -> FluidLoads:
        """Pressure and heat flux (Jacobians by batched central differences when asked)."""
        n = points.n
        s = np.asarray(state.slope, float)[None, :]
        v = np.asarray(state.velocity, float)[None, :]
        T = np.asarray(state.wall_temperature, float)[None, :]
        p, q = self.evaluate_batch(points, s, v, T, flow)
        loads = FluidLoads(pressure=p[0], heat_flux=q[0])
        if not jacobians:
            return loads
        n_x, n_y = points.shape
        independent = points.flow_angle == 0.0
        groups = ([np.arange(n_y) * n_x + i for i in range(n_x)] if independent
                  else [np.array([k]) for k in range(n)])
        G = len(groups)
        hs = self.fd_step
        hT = self.fd_step * np.maximum(T[0], 1.0)
        Es = np.zeros((G, n))
        for gi, idx in enumerate(groups):
            Es[gi, idx] = 1.0
        sl = np.concatenate([s + hs * Es, s - hs * Es, np.repeat(s, 2 * G, axis=0)])
        Tw = np.concatenate([np.repeat(T, 2 * G, axis=0), T + hT * Es, T - hT * Es])
        pp, qq = self.evaluate_batch(points, sl, np.repeat(v, 4 * G, axis=0), Tw, flow)
        dps = (pp[:G] - pp[G:2 * G]) / (2.0 * hs)  # row g: d p / d (slope in group g)
        dqs = (qq[:G] - qq[G:2 * G]) / (2.0 * hs)
        dpT = pp[2 * G:3 * G] - pp[3 * G:]
        dqT = qq[2 * G:3 * G] - qq[3 * G:]
        # scatter: column k of the Jacobian is the response of k's group, restricted to the
        # strip of k (strips do not interact when flow_angle == 0)
        strip = np.repeat(np.arange(n_y), n_x)
        J = {name: np.zeros((n, n)) for name in ("ps", "qs", "pT", "qT")}
        for gi, idx in enumerate(groups):
            for k in idx:
                rows = np.flatnonzero(strip == strip[k]) if independent else np.arange(n)
                J["ps"][rows, k] = dps[gi, rows]
                J["qs"][rows, k] = dqs[gi, rows]
                J["pT"][rows, k] = dpT[gi, rows] / (2.0 * hT[k])
                J["qT"][rows, k] = dqT[gi, rows] / (2.0 * hT[k])
        V = flow.velocity
        # sparse (the marching couples only points of one strip, upstream-triangular), so
        # the coupled Newton and the LSA can factor K - K_A directly
        csr = {k: sp.csr_matrix(v) for k, v in J.items()}
        zero = sp.csr_matrix((n, n))
        loads.jacobians = BlockJacobians({
            "dp_dw": zero, "dp_dws": csr["ps"], "dp_dwdot": csr["ps"] / V, "dp_dTw": csr["pT"],
            "dq_dw": zero.copy(), "dq_dws": csr["qs"], "dq_dwdot": csr["qs"] / V,
            "dq_dTw": csr["qT"]})
        return loads
