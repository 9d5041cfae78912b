"""Panel flutter by linearized stability analysis (Sec. 7.2.3, Eqs. 5.33-5.37).

A sweep of the nondimensional dynamic pressure ``lambda = gamma p M a^3 / D`` (Eq. 6.2a,
the natural parameter of first-order piston theory) for a panel uniformly heated to
``R * T_cr``. At each lambda the LSA is taken about the aeroelastic equilibrium:

* the flat (pre-buckling) state while it is statically stable;
* where the flat state is divergent (zero frequency, positive damping -- the range
  reported as ``divergence_range``, the "type I" response of a thermally buckled panel),
  about the post-buckled aeroelastic equilibrium found by Newton from the buckling mode.

The flutter onset ``lambda_cr`` is the first lambda where a complex eigenvalue pair crosses
into positive damping; it is refined by bisection.

With first-order piston theory the aerodynamic stiffness is linear in lambda, so it is
assembled once for lambda = 1 and scaled.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from solvers.aero.analytic import AnalyticFluid
from solvers.coupling import CouplingSettings, EquilibriumError, PanelModel
from solvers.errors import InputError
from solvers.flow import FlowCondition
from solvers.laminate import laminate
from solvers.panel import PanelSpec
from solvers.stability import StabilityResult, gep, pep
from solvers.structure import StructuralModel, buckling_delta_T, modes


@dataclass(frozen=True)
class FlutterResult:
    """Outcome of a lambda sweep (public JSON of ``hypate flutter``)."""

    lambda_cr: float | None
    instability_type: str | None
    frequency_ratio: float | None
    divergence_range: tuple[float, float] | None
    delta_T: float
    critical_delta_T: float
    sweep: list[tuple[float, str]]

    def to_dict(self) -> dict:
        return {"lambda_cr": self.lambda_cr, "instability_type": self.instability_type,
                "frequency_ratio": self.frequency_ratio,
                "divergence_range": list(self.divergence_range) if self.divergence_range else None,
                "delta_T": self.delta_T, "critical_delta_T": self.critical_delta_T}


class FlutterAnalysis:
    """LSA of a heated panel under first-order (or full) piston theory at any lambda.

    Parameters
    ----------
    panel : PanelSpec
    delta_T_ratio : float
        Uniform temperature rise as a multiple of the critical buckling rise.
    aero : {"pt1", "pt"}
        Piston-theory order (the linear sweep parameter is exact for "pt1").
    mach : float
        Free-stream Mach number (enters only the aerodynamic damping of the PEP).
    mass_ratio : float
        mu = rho_inf a / (rho_s h); with lambda it fixes the aerodynamic damping (PEP).
    """

    def __init__(self, panel: PanelSpec, delta_T_ratio: float = 0.0, aero: str = "pt1",
                 mach: float = 10.0, mass_ratio: float = 5.355e-4) -> None:
        if aero not in ("pt1", "pt"):
            raise InputError("--aero", "the flutter sweep supports 'pt1' and 'pt'")
        if not (delta_T_ratio >= 0.0 and math.isfinite(delta_T_ratio)):
            raise InputError("--delta-T-ratio", "must be >= 0")
        self.panel = panel
        self.structure = StructuralModel(panel)
        st = self.structure
        T0 = panel.initial_temperature
        self.D = float(laminate(panel, T0).D[..., 0, 0])
        self.T_cr = float(buckling_delta_T(st).critical_delta_T) if delta_T_ratio > 0 else float("nan")
        self.delta_T = delta_T_ratio * self.T_cr if delta_T_ratio > 0 else 0.0
        self.T = T0 + self.delta_T
        self.omega_1 = 2.0 * math.pi * float(modes(st, count=1).frequencies_hz[0])
        self.mach = float(mach)
        self.mass_ratio = float(mass_ratio)
        self.aero = aero
        # reference flow at lambda = 1; the density follows from the mass ratio
        rho_s = panel.mass_per_area() / panel.thickness
        rho = mass_ratio * rho_s * panel.thickness / panel.length
        self._rho = rho
        self.model = self._model(1.0)
        # flat pre-buckling state: in-plane thermal expansion against the immovable edges
        fac = st.factor(st.linear_stiffness(self.T))
        self.u_flat = fac.solve(st.thermal_load(self.T)) if self.delta_T else np.zeros(st.n_dof)
        self.u_flat[2::5] = 0.0

    def _flow(self, lam: float) -> FlowCondition:
        g = 1.4
        p = max(lam, 1e-9) * self.D / (g * self.mach * self.panel.length**3)
        T = p / (self._rho * 287.05)
        return FlowCondition.from_static(self.mach, p, T)

    def _model(self, lam: float) -> PanelModel:
        settings = CouplingSettings(time_step=1.0, duration=1.0, lsa_modes=6, passes=1)
        return PanelModel(self.panel, self._flow(lam), AnalyticFluid(self.aero, heating="none"),
                          settings, structure=self.structure)

    # -- one lambda --------------------------------------------------------------------
    def _operators(self, u: np.ndarray, lam: float):
        m = self.model if self.aero == "pt1" else self._model(lam)
        scale = lam if self.aero == "pt1" else 1.0
        T = np.full(m.thermal.n_nodes, self.T)
        loads = m.fluid_loads(u, m.wall_temperature(T), jacobians=True)
        st = self.structure
        K = st.tangent(u, self.T)
        M = st.mass(self.T)
        return m, K, M, scale * m.aero_stiffness(loads), scale * m.aero_damping(loads)

    def flat_stability(self, lam: float, method: str = "gep") -> StabilityResult:
        """LSA about the flat pre-buckling state."""
        return self._lsa(self.u_flat, lam, method)

    def _lsa(self, u: np.ndarray, lam: float, method: str) -> StabilityResult:
        _, K, M, KA, CA = self._operators(u, lam)
        free = self.structure.free_dofs
        if method == "pep":
            return pep(K, M, None, KA, CA, count=6, free=free)
        return gep(K, M, KA, count=6, free=free)

    def buckled_equilibrium(self, lam: float, u_start: np.ndarray | None = None) -> np.ndarray:
        """Post-buckled aeroelastic equilibrium at lambda (Newton from the buckling mode)."""
        m = self.model if self.aero == "pt1" else self._model(lam)
        scale = lam if self.aero == "pt1" else 1.0
        st = self.structure
        if u_start is None:
            shape = buckling_delta_T(st).shapes[:, 0]
            w = shape[2::5]
            u_start = self.u_flat + self.panel.thickness * shape / max(np.abs(w).max(), 1e-300)
        T = np.full(m.thermal.n_nodes, self.T)
        u, _ = m._newton(u_start, T, scale)
        return u

    def stability(self, lam: float, method: str = "gep",
                  u_start: np.ndarray | None = None) -> tuple[StabilityResult, bool, np.ndarray]:
        """LSA about the equilibrium at lambda; returns (result, flat_divergent, state)."""
        flat = self.flat_stability(lam, method)
        if flat.status != "divergence":
            return flat, False, self.u_flat
        try:
            u = self.buckled_equilibrium(lam, u_start)
        except EquilibriumError:
            return flat, True, self.u_flat
        return self._lsa(u, lam, method), True, u

    # -- sweep ---------------------------------------------------------------------------
    def sweep(self, lam_max: float = 1000.0, step: float = 10.0, rtol: float = 1e-4
              ) -> FlutterResult:
        """Sweep lambda in [0, lam_max]; bisect the flutter onset and the divergence end."""
        lams = np.arange(0.0, lam_max + 0.5 * step, step)
        history: list[tuple[float, str]] = []
        div_lo = div_hi = None
        prev_lam, prev_div, u_prev = None, None, None
        onset = None
        for lam in lams:
            res, flat_div, u = self.stability(float(lam), u_start=u_prev)
            u_prev = u if flat_div else None
            history.append((float(lam), res.status))
            if flat_div and div_lo is None:
                div_lo = float(lam)
            if prev_div and not flat_div and div_hi is None:
                div_hi = self._bisect(prev_lam, float(lam), lambda x: self.flat_stability(x).status
                                      == "divergence", rtol)
            prev_lam, prev_div = float(lam), flat_div
            if res.status == "flutter":
                lo = history[-2][0] if len(history) > 1 else 0.0
                onset = self._bisect(lo, float(lam), lambda x: self.stability(x)[0].status
                                     != "flutter", rtol)
                break
        if div_lo is not None and div_hi is None:
            div_hi = float(prev_lam) if onset is None else onset
        freq = None
        if onset is not None:
            res = self.stability(onset * (1 + 2 * rtol))[0]
            freq = float(abs(res.lambda_p[res.critical].imag) / self.omega_1)
        return FlutterResult(lambda_cr=onset, instability_type="flutter" if onset else None,
                             frequency_ratio=freq,
                             divergence_range=(div_lo, div_hi) if div_lo is not None else None,
                             delta_T=self.delta_T, critical_delta_T=self.T_cr, sweep=history)

    @staticmethod
    def _bisect(lo: float, hi: float, below, rtol: float) -> float:
        """Boundary between ``below(x)`` true (at lo) and false (at hi)."""
        while hi - lo > rtol * max(hi, 1.0):
            mid = 0.5 * (lo + hi)
            if below(mid):
                lo = mid
            else:
                hi = mid
        return 0.5 * (lo + hi)
