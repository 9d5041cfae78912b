"""The fluid ROM as a :class:`~hypate.solvers.aero.base.FluidModel` (Sec. 2.4.4).

:class:`RomFluid` evaluates two POD-kriging models (pressure ``p - p_inf`` and heat flux):

- *scaled and corrected* ROM (Sec. 2.4.4): inputs ``d = [xi a, mean T_w]`` (Eq. 2.64)
  at the reference condition and geometry; heat-flux correction (Eq. 2.65, Eckert with
  piston-theory edge pressure); pressure correction "pt" (Eq. 2.67) or "bl"
  (Eqs. 2.68-2.72 with the Cox-Crabtree ratio R_delta, Eq. 2.70); unsteady correction by
  piston theory (Eqs. 2.55, 2.73); Jacobians (Eqs. 2.74-2.76 and their heat-flux and
  wall-temperature analogues);
- *conventional* ROM (Eq. 2.62): inputs ``d = [M, p_inf, T_inf, a, mean T_w]``, no
  correction (for comparison), same unsteady correction.

Projection of the wall state onto the ROM inputs
------------------------------------------------
The panel geometry of a ROM is its reference geometry (length ``a_ref``, width ``b_ref``,
leading-edge distance ``L_le,ref``, thickness ``h_ref``). A panel evaluated with the ROM must
be geometrically similar: its scale ratio ``xi = L_ref / L`` is ``L_le,ref / L_le`` (read from
``points.x_le - x cos(beta) - y sin(beta)``) and every point maps to the reference point
``xi (x, y)``. The deformation modes are ``phi_k(x, y) = sin(m pi xi x / a_ref)
sin(n pi xi y / b_ref)`` (``n = 0``: uniform across) and the modal amplitudes are the
area-weighted least-squares projection of ``w`` on the points:

    q = P w,   P = (Phi^T W Phi)^{-1} Phi^T W,   W = diag(points.weights),

so that the ROM input is ``a = xi q / h_ref`` (amplitudes of the reference-size deformation
in units of the reference thickness; Eq. 2.64) and ``dd/dw = (xi / h_ref) P``. The mean wall
temperature is the area-weighted mean ``mean T_w = sum(W T_w) / sum(W)``. The ROM outputs
live on the reference grid; on other points they are interpolated (piecewise linear in
``x``, bilinear in ``(x, y)``), so the coupled solvers may use any fluid grid.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp
from hypate.solvers.aero.analytic import (
    BoundaryLayerShape,
    eckert_with_derivatives,
    piston_pressure,
)
from hypate.solvers.aero.base import (
    Array,
    FluidLoads,
    FluidModel,
    SurfacePoints,
    SurfaceState,
)
from hypate.solvers.aero.rom.geometry import RomGeometry, interpolation_matrix
from hypate.solvers.aero.rom.pod import PodKriging
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition

__all__ = ["GEOMETRY_TOL", "SPARSE_JACOBIAN_MAX", "RomFluid"]

#: Relative tolerance of the geometric-similarity check of a panel against the ROM.
GEOMETRY_TOL = 1e-3
#: Up to this many surface points the (dense, low-rank) Jacobians are returned as CSR
#: matrices so that solvers can assemble them like the analytic models' sparse blocks;
#: above, as dense ndarrays.
SPARSE_JACOBIAN_MAX = 600
#: Smallest absolute pressure ratio kept by the BL correction (vacuum floor).
_VACUUM = 1e-9


@dataclass
class _PointCache:
    points: SurfacePoints
    scale: float
    interp: sp.csr_matrix
    identity: bool
    projection: Array  # (N_S, n): q = P w (m)
    mean_weights: Array  # (n,): mean T_w = mean_weights @ T_w
    x_le_ref: Array


class RomFluid(FluidModel):
    """The fluid ROM as a drop-in :class:`FluidModel` (Sec. 2.4.4).

    Parameters
    ----------
    geometry : RomGeometry
        Reference panel, grid and deformation modes.
    reference : FlowCondition
        Reference condition c_ref of the samples.
    pressure_model, heat_model : PodKriging
        Fitted POD-kriging models of ``p - p_inf`` and of the heat flux.
    kind : {"scaled", "conventional"}
        "scaled": inputs ``[xi a, mean T_w]`` (Eq. 2.64) with correction and scaling;
        "conventional": inputs ``[M, p_inf, T_inf, a, mean T_w]`` (Eq. 2.62), no correction.
    correction : {"bl", "pt"}
        Pressure correction: boundary-layer (Eq. 2.72) or piston-theory (Eq. 2.67).
    unsteady : bool
        Add the piston-theory unsteady correction (Eq. 2.55).
    regime : {"turbulent", "laminar"}
        Regime of the Eckert heat-flux correction (Eq. 2.65).
    scale : float or None
        Geometric scale ratio xi = L_ref / L of the evaluated panel; ``None`` infers it from
        the points (``L_le,ref / L_le``).
    source : dict
        Description of the sample source (``{"kind": ..., "boundary_layer": ..., "regime":
        ...}``), kept for ``rom check``.
    edge_pressure : {"rom", "pt"}
        Edge pressure of the Eckert fluxes in the heat-flux correction (Eq. 2.65): the
        corrected ROM pressure on the panel over the ROM pressure on the reference ("rom",
        default), or piston theory on both ("pt", Eq. 2.44 as written).
    provenance : dict, optional
        Where the snapshots came from (CFD source: solver, version, model, resolution,
        counts, convergence figures), kept for ``rom check``.
    holdout : tuple of ndarray, optional
        ``(inputs, pressure, heat_flux)`` of snapshots kept out of the fit, for ``rom
        check``.
    """

    def __init__(self, geometry: RomGeometry, reference: FlowCondition,
                 pressure_model: PodKriging, heat_model: PodKriging, kind: str = "scaled",
                 correction: str = "bl", unsteady: bool = True, regime: str = "turbulent",
                 scale: float | None = None, source: dict[str, Any] | None = None,
                 edge_pressure: str = "rom", provenance: dict[str, Any] | None = None,
                 holdout: tuple[Array, Array, Array] | None = None) -> None:
        if edge_pressure not in ("rom", "pt"):
            raise InputError("rom.edge_pressure", "must be 'rom' or 'pt'")
        self.edge_pressure = edge_pressure
        if kind not in ("scaled", "conventional"):
            raise InputError("rom.kind", "must be 'scaled' or 'conventional'")
        if correction not in ("bl", "pt"):
            raise InputError("rom.correction", "must be 'bl' or 'pt'")
        self.geometry = geometry
        self.reference = reference
        self.pressure_model = pressure_model
        self.heat_model = heat_model
        self.kind = kind
        self.correction = correction
        self.unsteady = unsteady
        self.regime = regime
        self.scale = scale
        self.source = dict(source or {"kind": "unknown"})
        self.provenance = dict(provenance or {})
        self.holdout = holdout
        self.name = f"rom-{kind}-{correction}"
        self._cache: _PointCache | None = None

    # -- inputs ---------------------------------------------------------------------------
    @property
    def n_inputs(self) -> int:
        return self.geometry.n_modes + (4 if self.kind == "conventional" else 1)

    @property
    def input_bounds(self) -> Array:
        """Training ranges of the inputs (N_d, 2)."""
        return self.pressure_model.bounds_

    def input_names(self) -> list[str]:
        modes = [f"a{k + 1}" for k in range(self.geometry.n_modes)]
        cond = ["mach", "pressure", "temperature"] if self.kind == "conventional" else []
        return cond + modes + ["T_w"]

    def with_options(self, correction: str | None = None, unsteady: bool | None = None,
                     scale: float | None = None, edge_pressure: str | None = None
                     ) -> RomFluid:
        """A copy with other correction settings (shares the fitted models)."""
        return RomFluid(self.geometry, self.reference, self.pressure_model, self.heat_model,
                        self.kind, correction or self.correction,
                        self.unsteady if unsteady is None else unsteady, self.regime,
                        scale if scale is not None else self.scale, self.source,
                        edge_pressure or self.edge_pressure, self.provenance, self.holdout)

    def _points(self, points: SurfacePoints) -> _PointCache:
        c = self._cache
        if c is not None and c.points is points:
            return c
        g = self.geometry
        if g.kind == "2d" and points.shape[1] != 1:
            raise InputError("rom", "this ROM describes a 2D panel (one line of points); the "
                             f"case has {points.shape[1]} spanwise points")
        if abs(points.flow_angle - g.flow_angle) > 1e-9:
            raise InputError("rom", f"flow angle {math.degrees(points.flow_angle):g} deg does "
                             f"not match the ROM's {math.degrees(g.flow_angle):g} deg")
        cb, sb = math.cos(points.flow_angle), math.sin(points.flow_angle)
        l_le = points.x_le - cb * points.x - (sb * points.y if g.kind == "3d" else 0.0)
        L_le = float(np.mean(l_le))
        if L_le <= 0.0 or np.ptp(l_le) > 1e-9 * max(L_le, 1.0):
            raise InputError("rom", "cannot read the leading-edge distance from the points")
        scale = self.scale if self.scale is not None else g.leading_edge_length / L_le
        if abs(scale * L_le - g.leading_edge_length) > GEOMETRY_TOL * g.leading_edge_length:
            raise InputError("rom", f"panel mismatch: L_le = {L_le:g} m at scale {scale:g} is "
                             f"not the ROM's {g.leading_edge_length:g} m / scale")
        xr = points.x * scale
        yr = points.y * scale if g.kind == "3d" else np.full(points.n, 0.5 * g.width)
        tol = GEOMETRY_TOL * g.length
        if (xr.min() < -tol or xr.max() > g.length + tol
                or abs(xr.max() - g.length) > 0.05 * g.length):
            raise InputError("rom", f"panel mismatch: the panel length {points.x.max():g} m "
                             f"x scale {scale:g} is not the ROM's {g.length:g} m (the ROM "
                             "needs a geometrically similar panel: same a/L_le)")
        if g.kind == "3d" and (yr.min() < -tol or yr.max() > g.width + tol
                               or abs(yr.max() - g.width) > 0.05 * g.width):
            raise InputError("rom", f"panel mismatch: the panel width x scale {scale:g} is not "
                             f"the ROM's {g.width:g} m")
        ref_pts = g.points(1.0)
        identity = points.n == ref_pts.n and np.allclose(xr, ref_pts.x, atol=tol) and (
            g.kind == "2d" or np.allclose(yr, ref_pts.y, atol=tol))
        interp = sp.identity(points.n, format="csr") if identity else interpolation_matrix(
            g, np.clip(xr, 0, g.length), np.clip(yr, 0, g.width))
        Phi = g.mode_shapes(xr, yr)
        W = points.weights
        G = Phi.T @ (W[:, None] * Phi)
        try:
            P = np.linalg.solve(G, Phi.T * W[None, :])
        except np.linalg.LinAlgError:
            raise InputError("rom", "the points cannot resolve the ROM's deformation modes "
                             "(refine the fluid grid)") from None
        self._cache = _PointCache(points, float(scale), interp, identity, P, W / W.sum(),
                                  points.x_le * scale)
        return self._cache

    def inputs(self, points: SurfacePoints, state: SurfaceState, flow: FlowCondition) -> Array:
        """The ROM input d for a wall state (Eq. 2.64 or 2.62)."""
        c = self._points(points)
        a = c.scale / self.geometry.thickness * (c.projection @ np.asarray(state.displacement))
        T_mean = float(c.mean_weights @ np.asarray(state.wall_temperature))
        if self.kind == "conventional":
            return np.r_[flow.mach, flow.pressure, flow.temperature, a, T_mean]
        return np.r_[a, T_mean]

    def _check_range(self, d: Array) -> None:
        lo, hi = self.input_bounds[:, 0], self.input_bounds[:, 1]
        span = np.where(hi > lo, hi - lo, 1.0)
        out = (d < lo - 0.05 * span) | (d > hi + 0.05 * span)
        if np.any(out):
            names = [n for n, o in zip(self.input_names(), out) if o]
            warnings.warn(f"ROM extrapolation: inputs {', '.join(names)} outside the training "
                          "ranges (by > 5 %)", RuntimeWarning, stacklevel=3)

    # -- evaluation ------------------------------------------------------------------------
    def evaluate(self, points: SurfacePoints, state: SurfaceState, flow: FlowCondition,
                 jacobians: bool = False) -> FluidLoads:
        """Pressure ``p - p_inf`` and heat flux, Eq. (2.73); Jacobians Eqs. (2.74)-(2.76)."""
        # Long on purpose (~145 lines): the pressure, heat-flux and unsteady corrections
        # share the POD-kriging outputs and their input derivatives, and every partial of a
        # correction chains into the Jacobians at the end; the comment headings below mark
        # the sections (a split would hand some twenty arrays between helpers).
        c = self._points(points)
        g = self.geometry
        n = points.n
        xi = c.scale
        ws = np.asarray(state.slope, float)
        wdot = np.asarray(state.velocity, float)
        T_w = np.asarray(state.wall_temperature, float)
        if np.any(T_w <= 0.0) or not np.all(np.isfinite(T_w)):
            raise InputError("state.wall_temperature", "must be positive and finite (K)")
        d = self.inputs(points, state, flow)
        self._check_range(d)
        n_s = g.n_modes
        i_a = slice(3, 3 + n_s) if self.kind == "conventional" else slice(0, n_s)
        # POD-kriging outputs on the points, Eqs. (2.56), (2.59)
        p_r, dp_r = self.pressure_model.predict_jacobian(d)
        q_r, dq_r = self.heat_model.predict_jacobian(d)
        I = c.interp
        p_pk, q_pk = I @ p_r, I @ q_r
        dp_pk, dq_pk = I @ dp_r, I @ dq_r  # (n, N_d)
        dd_dw = (xi / g.thickness) * c.projection  # (N_S, n)
        dd_dT = c.mean_weights  # d(mean T_w)/dT_w

        gam, M, p_inf, a_inf = flow.gamma, flow.mach, flow.pressure, flow.speed_of_sound
        cref = self.reference
        zero_n = np.zeros(n)
        if self.kind == "conventional":
            if abs(xi - 1.0) > GEOMETRY_TOL:
                raise InputError("rom", "a conventional ROM has no geometric scaling; use the "
                                 "reference panel (scale 1)")
            p_st, q = p_pk, q_pk
            dpst_dws = zero_n
            dpst_dd = dp_pk
            dpst_dTloc = None
            dq_dd = dq_pk
            dq_dws = zero_n
            dq_dTloc = np.zeros((n, n))
        else:
            T_bar = d[-1]
            # -- pressure correction
            fac = (p_inf * M) / (cref.pressure * cref.mach)
            if self.correction == "pt":  # Eq. (2.67)
                p_st = fac * p_pk
                dpst_dd = fac * dp_pk
                dpst_dws = zero_n
                dpst_dTloc = None
            else:  # BL correction, Eqs. (2.68)-(2.72)
                S = points.streamwise_derivative
                bl = BoundaryLayerShape(flow)
                bl_r = BoundaryLayerShape(cref)
                s_c, s_c_dT, s_c_dTs = bl.slope(points.x_le, T_w, S @ T_w)
                s_r, s_r_dT, _ = bl_r.slope(c.x_le_ref, np.full(n, T_bar), zero_n)
                # Eq. (2.70) with the local wall temperature (and its gradient) on the panel
                # and the uniform mean on the reference: d delta/ds is dimensionless, so the
                # ratio compares the scaled panel at x with the reference at xi x
                R = s_c / s_r
                dR_dT = s_c_dT / s_r
                dR_dTs = s_c_dTs / s_r
                dR_dTbar = -s_c * s_r_dT / s_r**2
                ge = (cref.gamma - 1.0) / (2.0 * cref.gamma)
                # vacuum floor (as piston theory, Eq. 2.30): states with a negative absolute
                # pressure only occur in Newton overshoots; there p = -p_inf, derivative 0
                base_pk = 1.0 + p_pk / cref.pressure
                vac = base_pk <= _VACUUM
                base_pk = np.where(vac, _VACUUM, base_pk)
                E = base_pk**ge - 1.0
                B = 1.0 + (1.0 - R) * 0.5 * (gam - 1.0) * M * ws + R * (M / cref.mach) * E
                vac = vac | (B <= _VACUUM)
                B = np.where(vac, _VACUUM, B)
                ex = 2.0 * gam / (gam - 1.0)
                p_st = p_inf * B**ex - p_inf  # Eq. (2.72)
                Lam_u = p_inf * ex * B ** (ex - 1.0)  # Eq. (2.76a) times p_inf 2 gamma/(gamma-1)
                dB_dpk = R * (M / cref.mach) * ge * base_pk ** (ge - 1.0) / cref.pressure
                dB_dR = -0.5 * (gam - 1.0) * M * ws + (M / cref.mach) * E
                dpst_dd = (Lam_u * dB_dpk)[:, None] * dp_pk  # Eq. (2.75), second term
                dpst_dd[:, -1] += Lam_u * dB_dR * dR_dTbar
                dpst_dws = Lam_u * (1.0 - R) * 0.5 * (gam - 1.0) * M  # Eq. (2.75), first term
                dpst_dTloc = (np.diag(Lam_u * dB_dR * dR_dT)
                              + (sp.diags(Lam_u * dB_dR * dR_dTs) @ S).toarray())
                if np.any(vac):
                    p_st = np.where(vac, -p_inf, p_st)
                    dpst_dd[vac] = 0.0
                    dpst_dws = np.where(vac, 0.0, dpst_dws)
                    dpst_dTloc[vac] = 0.0
            # -- heat-flux correction, Eq. (2.65): ratio of Eckert fluxes; the edge pressure
            # (Eq. 2.44: the wall pressure) is the corrected ROM pressure on the panel and
            # the ROM pressure on the reference ("rom"), or piston theory on both ("pt")
            if self.edge_pressure == "rom":
                pe, pe_r = p_st, p_pk
                dpe_dd, dpe_dws, dpe_dTloc = dpst_dd, dpst_dws, dpst_dTloc
                dper_dd, dper_dws = dp_pk, zero_n
            else:
                pe, dpe_m = piston_pressure(M * ws, p_inf, gam, "pt")
                pe_r, dper_m = piston_pressure(cref.mach * ws, cref.pressure, cref.gamma, "pt")
                dpe_dd = dper_dd = np.zeros_like(dp_pk)
                dpe_dws, dper_dws, dpe_dTloc = dpe_m * M, dper_m * cref.mach, None
            num, dnum_dp, dnum_dT = eckert_with_derivatives(flow, p_inf + pe, T_w, points.x_le,
                                                            self.regime)
            den, dden_dp, dden_dT = eckert_with_derivatives(
                cref, cref.pressure + pe_r, np.full(n, T_bar), c.x_le_ref, self.regime)
            if np.any(np.abs(den) < 1e-9 * np.max(np.abs(den))):
                warnings.warn("heat-flux correction: the reference Eckert flux vanishes at "
                              "some points (wall at the adiabatic temperature)",
                              RuntimeWarning, stacklevel=2)
            r = num / den
            q = r * q_pk
            a_num = q_pk * dnum_dp / den  # dq / d p_e (panel)
            a_den = -q * dden_dp / den  # dq / d p_e (reference)
            dq_dd = r[:, None] * dq_pk + a_num[:, None] * dpe_dd + a_den[:, None] * dper_dd
            dq_dd[:, -1] += -q * dden_dT / den
            dq_dws = a_num * dpe_dws + a_den * dper_dws
            dq_dTloc = np.diag(q_pk * dnum_dT / den)
            if dpe_dTloc is not None:
                dq_dTloc = dq_dTloc + a_num[:, None] * dpe_dTloc
        # -- unsteady correction, Eq. (2.55)
        if self.unsteady:
            p1, dp1 = piston_pressure(M * ws + wdot / a_inf, p_inf, gam, "pt")
            p0, dp0 = piston_pressure(M * ws, p_inf, gam, "pt")
            p_uns = p1 - p0
            dpu_dws = M * (dp1 - dp0)
            dpu_dwdot = dp1 / a_inf
        else:
            p_uns, dpu_dws, dpu_dwdot = zero_n, zero_n, zero_n
        loads = FluidLoads(pressure=p_st + p_uns, heat_flux=q)
        if not jacobians:
            return loads
        # -- Jacobians (dense; the deformation parts are rank N_S, the mean-T_w parts rank 1)
        dp_dw = dpst_dd[:, i_a] @ dd_dw  # Eqs. (2.74a), (2.75)
        dq_dw = dq_dd[:, i_a] @ dd_dw
        dp_dT = np.outer(dpst_dd[:, -1], dd_dT)
        if dpst_dTloc is not None:
            dp_dT += dpst_dTloc
        dq_dT = np.outer(dq_dd[:, -1], dd_dT) + dq_dTloc
        jac = {
            "dp_dw": dp_dw, "dp_dws": np.diag(dpst_dws + dpu_dws),
            "dp_dwdot": np.diag(dpu_dwdot), "dp_dTw": dp_dT,
            "dq_dw": dq_dw, "dq_dws": np.diag(dq_dws), "dq_dwdot": np.zeros((n, n)),
            "dq_dTw": dq_dT,
        }
        if n <= SPARSE_JACOBIAN_MAX:  # small grids: CSR so solvers can assemble directly
            jac = {k: sp.csr_matrix(v) for k, v in jac.items()}
        loads.jacobians = jac
        return loads
