"""The fluid ROM as a :class:`~hypate.solvers.aero.base.FluidModel` (Sec. 2.4.4).

:class:`RomFluid` evaluates two POD-kriging models (pressure ``p - p_inf`` and heat flux),
or three (an Euler CFD ROM: pressure, heat flux and the edge temperature, below):

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

Inviscid ROMs and any leading-edge distance
-------------------------------------------
A ROM learnt from inviscid snapshots (the OpenFOAM source's Euler model, or the
shock-expansion source without its boundary layer) holds no boundary layer. On a flat
plate at zero incidence the inviscid flow ahead of the panel is the free stream whatever
``L_le``, so its panel pressure does not depend on ``L_le`` and the Euler equations have no
length scale: such a ROM accepts a panel of any ``a / L_le``. Its scale is read from the
panel length, ``xi = a_ref / a``; its BL correction (Eq. 2.72) keeps ``R_delta = 1`` (Eq.
2.70 rescales a boundary layer's displacement slope, and the effective slope of Eq. 2.68 of
an inviscid snapshot is the panel's own shock-expansion departure from piston theory, not a
boundary layer); and the heat-flux correction (Eq. 2.65) evaluates the reference Eckert flux
at the reference panel's own distance from its leading edge, ``L_le,ref + xi s`` (``s``
along the flow from the panel's leading edge), and the corrected flux at the panel's actual
``L_le + s``.

The heat flux of an Euler CFD ROM
---------------------------------
The heat flux of an Euler snapshot is no CFD result: it is Eckert's reference-temperature
flux (Eqs. 2.39-2.43) on the CFD wall pressure and wall-cell (edge) temperature ``T_e`` at
the snapshot's wall temperature. Inviscid ``p`` and ``T_e`` depend on the deformation
only, while ``q`` also depends on ``T_w``; so such a ROM kriges ``T_e`` as a third
POD-kriging field and forms its reference heat flux on the reference grid by the same law,

    q_pk(d) = q_Eckert(p_ref + p_pk(d), T_e,pk(d), mean T_w, L_le,ref + x),

with ``dq_pk/dd`` by the chain rule through ``p_pk``, ``T_e,pk`` and ``mean T_w`` (the
law's partials by complex step). Everything after -- the correction of Eq. (2.65), the
unsteady correction, the strips, the Jacobians -- takes this ``q_pk`` where the kriged
heat flux stands otherwise (the kriged heat flux is still fitted and stored, for
comparison). A ROM without the field evaluates its kriged heat flux as before.

Strip-wise evaluation of a 2-D ROM on a 3-D panel
-------------------------------------------------
A 2-D ROM (one line of points) evaluated on the structured grid of a 3-D panel aligned
with the flow (``beta = 0``) is applied strip by strip, the strip theory of Eq. (2.36):
each streamwise line of points ``y = y_j`` is a 2-D panel with its own inputs (the
projection of ``w(x, y_j)`` on the streamwise modes and the strip's mean wall temperature)
and its own POD-kriging prediction; the Jacobians are block-diagonal over the strips.
"""
from __future__ import annotations

import functools
import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, cast

import numpy as np
import scipy.sparse as sp
from hypate.solvers.aero.analytic import (
    BoundaryLayerShape,
    eckert_with_derivatives,
    piston_pressure,
)
from hypate.solvers.aero.base import (
    Array,
    BlockJacobians,
    FluidLoads,
    FluidModel,
    SurfacePoints,
    SurfaceState,
)
from hypate.solvers.aero.rom.geometry import RomGeometry, interpolation_matrix
from hypate.solvers.aero.rom.pod import PodKriging
from hypate.solvers.aero.shock_expansion import (
    eckert_edge_with_derivatives,
    eckert_heat_flux_edge,
)
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
    """What a set of points needs from the ROM, computed once per points object.

    The points fall into ``n_groups`` groups of ``m`` points each (point ``k`` in group
    ``k // m``): one group holding every point, or the streamwise strips of a 3-D grid when
    a 2-D ROM is applied strip-wise. Every group sees the same streamwise stations, so the
    interpolation, projection and mean weights are those of one group.
    """

    points: SurfacePoints
    scale: float
    n_groups: int
    interp: sp.csr_matrix  # (m, n_rom): ROM grid -> the points of one group
    identity: bool
    projection: Array  # (N_S, m): q = P w on one group (m)
    mean_weights: Array  # (m,): mean T_w = mean_weights @ T_w on one group
    x_le_ref: Array  # (n,): the reference panel's distance from its leading edge


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
        the points (``L_le,ref / L_le``; an inviscid ROM: ``a_ref / a``).
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
    edge_temperature_model : PodKriging, optional
        Fitted POD-kriging model of the edge temperature ``T_e`` (K) of Euler snapshots:
        the reference heat flux is then Eckert's on the kriged ``p`` and ``T_e`` (module
        docstring) instead of ``heat_model`` (scaled ROMs only).
    """

    def __init__(self, geometry: RomGeometry, reference: FlowCondition,
                 pressure_model: PodKriging, heat_model: PodKriging, kind: str = "scaled",
                 correction: str = "bl", unsteady: bool = True, regime: str = "turbulent",
                 scale: float | None = None, source: dict[str, Any] | None = None,
                 edge_pressure: str = "rom", provenance: dict[str, Any] | None = None,
                 holdout: tuple[Array, Array, Array] | None = None,
                 edge_temperature_model: PodKriging | None = None) -> None:
        if edge_pressure not in ("rom", "pt"):
            raise InputError("rom.edge_pressure", "must be 'rom' or 'pt'")
        self.edge_pressure = edge_pressure
        if kind not in ("scaled", "conventional"):
            raise InputError("rom.kind", "must be 'scaled' or 'conventional'")
        if correction not in ("bl", "pt"):
            raise InputError("rom.correction", "must be 'bl' or 'pt'")
        if edge_temperature_model is not None and kind != "scaled":
            raise InputError("rom.edge_temperature", "an edge-temperature model needs a "
                             "scaled ROM (its Eckert flux is at the reference condition)")
        self.geometry = geometry
        self.reference = reference
        self.edge_temperature_model = edge_temperature_model
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

    @property
    def inviscid(self) -> bool:
        """Whether the snapshots hold no boundary layer (the OpenFOAM source's Euler model, or
        the shock-expansion source without its effective shape): then the ROM serves panels
        of any ``a / L_le`` (module docstring)."""
        kind = self.source.get("kind")
        if kind == "openfoam":
            return (self.source.get("model") or self.provenance.get("model")) == "euler"
        if kind == "shock-expansion":
            return not self.source.get("boundary_layer", True)
        return False

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
                        edge_pressure or self.edge_pressure, self.provenance, self.holdout,
                        self.edge_temperature_model)

    def _points(self, points: SurfacePoints) -> _PointCache:
        c = self._cache
        if c is not None and c.points is points:
            return c
        g = self.geometry
        n_x, n_y = points.shape
        strips = g.kind == "2d" and n_y > 1
        if strips and not (n_x * n_y == points.n
                           and np.allclose(points.x.reshape(n_y, n_x), points.x[None, :n_x])):
            raise InputError("rom", "a 2D ROM is applied strip-wise to a structured grid of "
                             "points (point k = j n_x + i)")
        if abs(points.flow_angle - g.flow_angle) > 1e-9:
            raise InputError("rom", f"flow angle {math.degrees(points.flow_angle):g} deg does "
                             f"not match the ROM's {math.degrees(g.flow_angle):g} deg"
                             + (" (a 2D ROM is applied strip-wise along the flow)"
                                if strips else ""))
        cb, sb = math.cos(points.flow_angle), math.sin(points.flow_angle)
        s_flow = cb * points.x + (sb * points.y if g.kind == "3d" else 0.0)
        l_le = points.x_le - s_flow
        L_le = float(np.mean(l_le))
        if L_le <= 0.0 or np.ptp(l_le) > 1e-9 * max(L_le, 1.0):
            raise InputError("rom", "cannot read the leading-edge distance from the points")
        a = float(points.x.max())
        if self.inviscid:  # any L_le: the scale of the panel length (module docstring)
            scale = self.scale if self.scale is not None else g.length / a
        else:
            scale = self.scale if self.scale is not None else g.leading_edge_length / L_le
            if abs(scale * L_le - g.leading_edge_length) > GEOMETRY_TOL * g.leading_edge_length:
                raise InputError("rom", f"panel mismatch: L_le = {L_le:g} m at scale {scale:g} "
                                 f"is not the ROM's {g.leading_edge_length:g} m / scale (a ROM "
                                 "with a boundary layer in its snapshots needs the same a/L_le)")
        m = n_x if strips else points.n
        sel = slice(0, m)  # the points of one group (the first strip, or all)
        xr = points.x[sel] * scale
        yr = (points.y[sel] * scale if g.kind == "3d"
              else np.full(m, 0.5 * g.width))
        tol = GEOMETRY_TOL * g.length
        if (xr.min() < -tol or xr.max() > g.length + tol
                or abs(xr.max() - g.length) > 0.05 * g.length):
            raise InputError("rom", f"panel mismatch: the panel length {a:g} m x scale "
                             f"{scale:g} is not the ROM's {g.length:g} m" + (
                                 "" if self.inviscid else " (a ROM with a boundary layer in "
                                 "its snapshots needs a geometrically similar panel: same "
                                 "a/L_le; an inviscid ROM takes any)"))
        if g.kind == "3d" and (yr.min() < -tol or yr.max() > g.width + tol
                               or abs(yr.max() - g.width) > 0.05 * g.width):
            raise InputError("rom", f"panel mismatch: the panel width x scale {scale:g} is not "
                             f"the ROM's {g.width:g} m")
        ref_pts = g.points(1.0)
        identity = m == ref_pts.n and np.allclose(xr, ref_pts.x, atol=tol) and (
            g.kind == "2d" or np.allclose(yr, ref_pts.y, atol=tol))
        interp = sp.identity(m, format="csr") if identity else interpolation_matrix(
            g, np.clip(xr, 0, g.length), np.clip(yr, 0, g.width))
        Phi = g.mode_shapes(xr, yr)
        W = points.weights[sel]
        G = Phi.T @ (W[:, None] * Phi)
        try:
            # float64 (numpy's stub: solve gives floating)
            P = cast(Array, np.linalg.solve(G, Phi.T * W[None, :]))
        except np.linalg.LinAlgError:
            raise InputError("rom", "the points cannot resolve the ROM's deformation modes "
                             "(refine the fluid grid)") from None
        # Eq. (2.65)'s reference flux: the reference panel at xi s from its own leading edge
        x_le_ref = (g.leading_edge_length + scale * s_flow if self.inviscid
                    else points.x_le * scale)
        self._cache = _PointCache(points, float(scale), n_y if strips else 1, interp,
                                  identity, P, W / W.sum(), x_le_ref)
        return self._cache

    def _group_inputs(self, c: _PointCache, state: SurfaceState, flow: FlowCondition
                      ) -> Array:
        """The ROM inputs of every group of points, (n_groups, N_d) (Eq. 2.64 or 2.62)."""
        w = np.asarray(state.displacement, float).reshape(c.n_groups, -1)
        T = np.asarray(state.wall_temperature, float).reshape(c.n_groups, -1)
        a = (c.scale / self.geometry.thickness) * (w @ c.projection.T)
        d = np.column_stack([a, T @ c.mean_weights])
        if self.kind == "conventional":
            d = np.column_stack([np.tile([flow.mach, flow.pressure, flow.temperature],
                                         (c.n_groups, 1)), d])
        return d

    def inputs(self, points: SurfacePoints, state: SurfaceState, flow: FlowCondition) -> Array:
        """The ROM input d for a wall state (Eq. 2.64 or 2.62): shape (N_d,), or (n_y, N_d)
        for a 2-D ROM applied strip-wise to a 3-D grid (one row per strip)."""
        c = self._points(points)
        d = self._group_inputs(c, state, flow)
        return d[0] if c.n_groups == 1 else d

    def _check_range(self, d: Array) -> None:
        lo, hi = self.input_bounds[:, 0], self.input_bounds[:, 1]
        span = np.where(hi > lo, hi - lo, 1.0)
        out = np.any((d < lo - 0.05 * span) | (d > hi + 0.05 * span), axis=0)
        if np.any(out):
            names = [n for n, o in zip(self.input_names(), out) if o]
            warnings.warn(f"ROM extrapolation: inputs {', '.join(names)} outside the training "
                          "ranges (by > 5 %)", RuntimeWarning, stacklevel=3)

    # -- evaluation ------------------------------------------------------------------------
    @property
    def heat_flux_law(self) -> str:
        """How the reference heat flux is formed (for ``rom check``)."""
        if self.edge_temperature_model is None:
            return "POD-kriging of the snapshots' heat flux"
        return ("Eckert reference temperature (Eqs. 2.39-2.43) on the POD-kriged wall "
                "pressure and edge temperature")

    @property
    def _eckert_regime(self) -> str:
        """Regime of the snapshots' Eckert flux (the correction's may be overridden)."""
        return str(self.source.get("regime", self.regime))

    @functools.cached_property
    def _reference_x_le(self) -> Array:
        """Distance of the reference grid points from the leading edge (m), (n_rom,)."""
        return self.geometry.points(1.0).x_le

    @staticmethod
    def _kriged(model: PodKriging, d: Array) -> tuple[Array, Array]:
        """POD-kriging output on the ROM grid (G, n_rom) and its input derivative
        (n_rom, G, N_d) at the inputs ``d`` (G, N_d), Eqs. (2.56), (2.59)."""
        coef, dcoef = model.predict_coefficients(d, gradient=True)
        y = model.pod_.reconstruct(coef)  # (G, n_rom)
        # sum_p modes[r, p] dcoef[g, p, d] as one BLAS product (einsum: 25x slower)
        return y, np.tensordot(model.pod_.modes_, dcoef, axes=([1], [1]))  # (n_rom, G, N_d)

    def _kriged_heat_flux(self, d: Array, p: Array, dp: Array) -> tuple[Array, Array]:
        """The reference heat flux on the ROM grid and its input derivative, as
        :meth:`_kriged`: the kriged heat flux, or Eckert on the kriged pressure ``p``
        (with ``dp``) and edge temperature at the group's mean wall temperature."""
        if self.edge_temperature_model is None:
            return self._kriged(self.heat_model, d)
        T_e, dT_e = self._kriged(self.edge_temperature_model, d)
        ref = self.reference
        T_w = np.broadcast_to(d[:, -1:], p.shape)
        q, dq_dp, dq_dTe, dq_dTw = eckert_edge_with_derivatives(
            ref, ref.pressure + p, T_e, T_w, self._reference_x_le, self._eckert_regime)
        dq = dq_dp.T[:, :, None] * dp + dq_dTe.T[:, :, None] * dT_e  # chain rule
        dq[:, :, -1] += dq_dTw.T  # the mean wall temperature is the last input
        return q, dq

    def reference_loads(self, inputs: Array) -> tuple[Array, Array]:
        """``p - p_inf`` and heat flux on the ROM grid at the reference condition and
        geometry for inputs (N, N_d): the POD-kriging outputs, which the corrections
        return unchanged there with a uniform wall temperature (Eqs. 2.65, 2.72)."""
        D = np.atleast_2d(np.asarray(inputs, float))
        p = self.pressure_model.predict(D)
        if self.edge_temperature_model is None:
            return p, self.heat_model.predict(D)
        ref = self.reference
        T_e = self.edge_temperature_model.predict(D)
        return p, eckert_heat_flux_edge(ref, ref.pressure + p, T_e,
                                        np.broadcast_to(D[:, -1:], p.shape),
                                        self._reference_x_le, self._eckert_regime)

    @staticmethod
    def _on_points(c: _PointCache, y: Array, dy: Array) -> tuple[Array, Array]:
        """A ROM-grid output (G, n_rom) with its derivative (n_rom, G, N_d) on the points
        (n,), and the derivative with respect to the inputs of the point's own group
        (n, N_d)."""
        G, n_d = dy.shape[1:]
        I = c.interp  # (m, n_rom)
        y_pts = (I @ y.T).T.reshape(-1)
        dy_pts = (I @ dy.reshape(dy.shape[0], G * n_d)).reshape(-1, G, n_d)
        return y_pts, dy_pts.transpose(1, 0, 2).reshape(-1, n_d)

    def evaluate(self, points: SurfacePoints, state: SurfaceState, flow: FlowCondition,
                 jacobians: bool = False) -> FluidLoads:
        """Pressure ``p - p_inf`` and heat flux, Eq. (2.73); Jacobians Eqs. (2.74)-(2.76)."""
        # Long on purpose (~150 lines): the pressure, heat-flux and unsteady corrections
        # share the POD-kriging outputs and their input derivatives, and every partial of a
        # correction chains into the Jacobians at the end; the comment headings below mark
        # the sections (a split would hand some twenty arrays between helpers). Every
        # pointwise array refers to the inputs d of the point's own group (strip).
        c = self._points(points)
        g = self.geometry
        n = points.n
        xi = c.scale
        ws = np.asarray(state.slope, float)
        wdot = np.asarray(state.velocity, float)
        T_w = np.asarray(state.wall_temperature, float)
        if np.any(T_w <= 0.0) or not np.all(np.isfinite(T_w)):
            raise InputError("state.wall_temperature", "must be positive and finite (K)")
        d = self._group_inputs(c, state, flow)  # (n_groups, N_d)
        self._check_range(d)
        m = n // c.n_groups
        n_s = g.n_modes
        i_a = slice(3, 3 + n_s) if self.kind == "conventional" else slice(0, n_s)
        # POD-kriging outputs on the points, Eqs. (2.56), (2.59); the heat flux kriged or
        # formed from the kriged pressure and edge temperature (module docstring)
        p_g, dp_g = self._kriged(self.pressure_model, d)
        p_pk, dp_pk = self._on_points(c, p_g, dp_g)
        q_pk, dq_pk = self._on_points(c, *self._kriged_heat_flux(d, p_g, dp_g))
        dd_dw = (xi / g.thickness) * c.projection  # (N_S, m) within a group
        T_bar = np.repeat(d[:, -1], m)  # each point's group mean

        gam, M, p_inf, a_inf = flow.gamma, flow.mach, flow.pressure, flow.speed_of_sound
        cref = self.reference
        zero_n = np.zeros(n)
        dpst_dTloc = dq_dTloc = None  # local wall-temperature partials (sparse), if any
        if self.kind == "conventional":
            if abs(xi - 1.0) > GEOMETRY_TOL:
                raise InputError("rom", "a conventional ROM has no geometric scaling; use the "
                                 "reference panel (scale 1)")
            p_st, q = p_pk, q_pk
            dpst_dws = zero_n
            dpst_dd = dp_pk
            dq_dd = dq_pk
            dq_dws = zero_n
        else:
            # -- pressure correction
            fac = (p_inf * M) / (cref.pressure * cref.mach)
            if self.correction == "pt":  # Eq. (2.67)
                p_st = fac * p_pk
                dpst_dd = fac * dp_pk
                dpst_dws = zero_n
            else:  # BL correction, Eqs. (2.68)-(2.72)
                if self.inviscid:  # no boundary layer in the snapshots: R_delta = 1
                    R, dR_dT, dR_dTs, dR_dTbar = np.ones(n), zero_n, zero_n, zero_n
                else:
                    S = points.streamwise_derivative
                    bl = BoundaryLayerShape(flow)
                    bl_r = BoundaryLayerShape(cref)
                    s_c, s_c_dT, s_c_dTs = bl.slope(points.x_le, T_w, S @ T_w)
                    s_r, s_r_dT, _ = bl_r.slope(c.x_le_ref, T_bar, zero_n)
                    # Eq. (2.70) with the local wall temperature (and its gradient) on the
                    # panel and the uniform mean on the reference: d delta/ds is
                    # dimensionless, so the ratio compares the scaled panel at x with the
                    # reference at xi x
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
                if np.any(vac):
                    p_st = np.where(vac, -p_inf, p_st)
                    dpst_dd[vac] = 0.0
                    dpst_dws = np.where(vac, 0.0, dpst_dws)
                if not self.inviscid:
                    k_T = np.where(vac, 0.0, Lam_u * dB_dR)
                    dpst_dTloc = (sp.diags(k_T * dR_dT)
                                  + sp.diags(k_T * dR_dTs) @ points.streamwise_derivative)
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
                cref, cref.pressure + pe_r, T_bar, c.x_le_ref, self.regime)
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
            dq_dTloc = sp.diags(q_pk * dnum_dT / den)
            if dpe_dTloc is not None:
                dq_dTloc = dq_dTloc + sp.diags(a_num) @ dpe_dTloc
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
        # -- Jacobians: the deformation parts are rank N_S and the mean-T_w parts rank 1
        # within each group (block-diagonal over the strips), the rest pointwise
        groups = c.n_groups

        def blocks(left: Array, right: Array) -> Array:
            """Per group ``left_g @ right`` with left (n, k) and right (k, m): (G, m, m)."""
            return left.reshape(groups, m, -1) @ right

        def assemble(block: Array, local: sp.spmatrix | None) -> object:
            if groups == 1:
                out = block[0] if local is None else block[0] + local.toarray()
                return sp.csr_matrix(out) if n <= SPARSE_JACOBIAN_MAX else out
            # block-diagonal CSR built directly: row g m + i holds block[g, i, :] in columns
            # g m .. g m + m - 1 (scipy's block_diag costs more than the blocks themselves)
            cols = (np.arange(groups)[:, None, None] * m
                    + np.zeros((1, m, 1), int) + np.arange(m)[None, None, :])
            out = sp.csr_matrix((block.reshape(-1), cols.reshape(-1),
                                 np.arange(0, n * m + 1, m)), shape=(n, n))
            return out if local is None else (out + local).tocsr()

        mw = c.mean_weights[None, :]
        diag: Callable[[Array], object] = (
            (lambda v: sp.diags(v, format="csr")) if (groups > 1 or n <= SPARSE_JACOBIAN_MAX)
            else cast(Callable[[Array], object], np.diag))  # (mypy joins the two to `function`)
        jac = {
            "dp_dw": assemble(blocks(dpst_dd[:, i_a], dd_dw), None),  # Eqs. (2.74a), (2.75)
            "dp_dws": diag(dpst_dws + dpu_dws), "dp_dwdot": diag(dpu_dwdot),
            "dp_dTw": assemble(blocks(dpst_dd[:, -1:], mw), dpst_dTloc),
            "dq_dw": assemble(blocks(dq_dd[:, i_a], dd_dw), None),
            "dq_dws": diag(dq_dws),
            "dq_dwdot": sp.csr_matrix((n, n)) if diag is not np.diag else np.zeros((n, n)),
            "dq_dTw": assemble(blocks(dq_dd[:, -1:], mw), dq_dTloc),
        }
        loads.jacobians = BlockJacobians(jac)
        return loads
