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

A fluid ROM (``aero = "rom:PATH"``, Sec. 2.4.4; e.g. the CFD ROM of the Sec. 7.1 panel)
takes piston theory's place: at each lambda the panel sees the ROM's reference free stream
(its Mach number unless another is given, its temperature) at the static pressure of that
lambda, ``p = lambda D / (gamma M a^3)``, and the aerodynamic stiffness is the ROM's
Jacobian there (Eqs. 2.74-2.76). An inviscid ROM at its own Mach number scales exactly with
``p`` (the Euler flow has no other scale), so its onset is the CFD's; lambda keeps piston
theory's definition, so the two onsets compare directly.

Time domain (``lco_amplitude``, ``lco_onset``): loosely coupled S2 runs (Sec. 5.3.1) of the
heated panel released from a small sinusoidal deflection at fixed lambda; the limit-cycle
amplitude is half the peak-to-peak centre deflection over the tail of the run, and the
onset is the zero of a straight-line fit of amplitude^2 against lambda (the normal form of
a supercritical Hopf bifurcation, ``A^2 ~ (lambda - lambda_cr)``), as the dissertation's
"time domain" column of Sec. 7.2.3.
"""
from __future__ import annotations

import contextlib
import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from hypate.solvers.aero.analytic import AnalyticFluid
from hypate.solvers.aero.base import FluidModel
from hypate.solvers.aero.factory import ROM_PREFIX, make_fluid_model
from hypate.solvers.coupling.lc import run_lc
from hypate.solvers.coupling.model import PanelModel
from hypate.solvers.coupling.newton import EquilibriumError
from hypate.solvers.coupling.stability import StabilityResult, gep, pep
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition
from hypate.solvers.laminate import laminate
from hypate.solvers.panel import PanelSpec
from hypate.solvers.settings import SimulationSettings
from hypate.solvers.structure.modal import buckling_delta_T, modes
from hypate.solvers.structure.model import StructuralModel


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
    """LSA of a heated panel under first-order (or full) piston theory, or a fluid ROM, at
    any lambda.

    Parameters
    ----------
    panel : PanelSpec
    delta_T_ratio : float
        Uniform temperature rise as a multiple of the critical buckling rise.
    aero : {"pt1", "pt"} or "rom:PATH"
        Piston-theory order (the linear sweep parameter is exact for "pt1"), or a ROM file
        (module docstring).
    mach : float or None
        Free-stream Mach number (piston theory: enters only the aerodynamic damping of the
        PEP; default 10). None: 10, or a ROM's reference Mach number.
    mass_ratio : float
        mu = rho_inf a / (rho_s h); with lambda it fixes the aerodynamic damping (PEP) and
        the free-stream temperature of piston theory (a ROM keeps its reference one).
    """

    def __init__(self, panel: PanelSpec, delta_T_ratio: float = 0.0, aero: str = "pt1",
                 mach: float | None = None, mass_ratio: float = 5.355e-4) -> None:
        self.fluid = _fluid(aero)
        #: The ROM's reference free stream (None: piston theory).
        self.rom_reference: FlowCondition | None = getattr(self.fluid, "reference", None)
        if mach is None:
            mach = 10.0 if self.rom_reference is None else float(self.rom_reference.mach)
        if not (delta_T_ratio >= 0.0 and math.isfinite(delta_T_ratio)):
            raise InputError("--delta-T-ratio", "must be >= 0")
        self.panel = panel
        self.structure = StructuralModel(panel)
        st = self.structure
        T0 = panel.initial_temperature
        self.D = float(laminate(panel, T0).D[..., 0, 0])
        self.T_cr = (float(buckling_delta_T(st).critical_delta_T) if delta_T_ratio > 0
                     else float("nan"))
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
        if self.rom_reference is not None:  # a ROM: its reference free stream at p
            return FlowCondition.from_static(self.mach, p, float(self.rom_reference.temperature))
        T = p / (self._rho * 287.05)
        return FlowCondition.from_static(self.mach, p, T)

    def _model(self, lam: float) -> PanelModel:
        settings = SimulationSettings(time_step=1.0, duration=1.0, lsa_modes=6, passes=1)
        return PanelModel(self.panel, self._flow(lam), self.fluid, settings,
                          structure=self.structure)

    # -- one lambda --------------------------------------------------------------------
    def _operators(self, u: np.ndarray, lam: float):
        m = self.model if self.aero == "pt1" else self._model(lam)
        scale = lam if self.aero == "pt1" else 1.0
        T = np.full(m.thermal.n_nodes, self.T)
        with self._quiet():
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
        with self._quiet():
            u, _ = m._newton(u_start, T, scale)
        return u

    def _quiet(self) -> contextlib.AbstractContextManager:
        """A ROM's heat flux (unused: no heating here) has no meaning at the vanishing
        pressure of lambda -> 0 (Eckert's Reynolds number below 1): its NaN is not reported."""
        if self.rom_reference is None:
            return contextlib.nullcontext()
        return np.errstate(invalid="ignore", divide="ignore")

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

    # -- time domain (S2 transients) -----------------------------------------------
    def _transient_model(self, lam: float, periods: float, dt: float | None,
                         initial_deflection: float) -> tuple[PanelModel, float]:
        """S2 model at lambda with the uniform rise and a frozen thermal field; (model, dt)."""
        T1 = 2.0 * math.pi / self.omega_1
        step = T1 / 100.0 if dt is None else float(dt)
        if not (step > 0 and periods > 0):
            raise InputError("lco", "dt and periods must be > 0")
        settings = SimulationSettings(time_step=step, duration=periods * T1, lsa_modes=1,
                                    keep_fields=False, initial_temperature_rise=self.delta_T,
                                    initial_deflection=initial_deflection)
        # purely aeroelastic: no heating and no radiation, so the thermal field stays frozen
        # at the uniform rise (PanelModel.thermal_frozen)
        panel = dataclasses.replace(self.panel, emissivity=0.0)
        model = PanelModel(panel, self._flow(lam), self.fluid, settings,
                           structure=self.structure)
        return model, step

    def lco_amplitude(self, lam: float, *, periods: float = 40.0,
                      dt: float | None = None, initial_deflection: float = 0.01,
                      tail: float = 0.25, rho_bar: float = 0.8) -> float:
        """Limit-cycle amplitude (over the thickness) of an S2 transient at ``lambda``.

        Parameters
        ----------
        lam : float
            Nondimensional dynamic pressure.
        periods : float
            Run length in periods ``T1 = 2 pi / omega_1`` of the unheated panel's first mode.
        dt : float, optional
            Time step (s); default ``T1 / 100``. At ``T1 / 50`` the S2 interface energy
            error (Sec. 5.3.3) acts as negative damping of the nearly undamped flutter mode:
            on the 8 x 8 panel at T_cr the runs at lambda = 330 and 338 grew (LSA onset
            340.8); at ``T1 / 100`` they decay.
        initial_deflection : float
            Amplitude of the initial ``sin sin`` deflection in thicknesses (the perturbation).
        tail : float
            Fraction of the run, counted from its end, over which the amplitude is measured.
        rho_bar : float
            Generalized-alpha spectral radius at infinity. Default 0.8: with rho_bar = 1
            (no algorithmic dissipation) the loosely coupled S2 run of the 8 x 8 panel at
            ``T1 / 50`` grew without bound even below the LSA onset (the explicit aerodynamic
            load feeds the undamped high-frequency bending modes); 0.8 damps those strongly
            while the algorithmic damping of the flutter mode (``omega dt ~ 0.1``) is
            O((omega dt)^3).

        Returns
        -------
        float
            Half the peak-to-peak centre deflection / h over the tail window; ~0 when the
            perturbation decays (flat or post-buckled static equilibrium), inf when the run
            diverges.
        """
        model, _ = self._transient_model( lam, periods, dt, initial_deflection)
        resp = run_lc(model, "s2", rho_bar=rho_bar, stop_on_snap=False)
        if resp.status == "failed":
            return float("inf")
        w = np.asarray(resp.center_deflection) / self.panel.thickness
        return lco_amplitude_from_signal(np.asarray(resp.times), w, tail)


    def lco_onset(self, lo: float, hi: float, *, n: int = 4,
                   threshold: float = 1e-3, **kwargs) -> LCOOnset:
        """Time-domain flutter onset from ``n`` S2 runs at evenly spaced lambda in [lo, hi].

        The amplitude^2 of the runs with a limit cycle is fitted by a straight line in lambda
        (supercritical Hopf normal form) and its zero is the onset. ``lo`` and ``hi`` should
        bracket a range a few percent above the onset, where the limit cycle settles within
        the run (right at the onset the approach to the cycle is arbitrarily slow).

        Parameters
        ----------
        lo, hi : float
            Lambda range of the runs.
        n : int
            Number of runs (>= 2).
        threshold : float
            Amplitude (over h) below which a run counts as having no limit cycle.
        **kwargs
            Passed to :meth:`FlutterAnalysis.lco_amplitude`.

        Returns
        -------
        LCOOnset
        """
        if n < 2 or not hi > lo:
            raise InputError("lco", "need n >= 2 and hi > lo")
        lams = np.linspace(lo, hi, n)
        amps = np.array([self.lco_amplitude(float(x), **kwargs) for x in lams])
        fin = np.isfinite(amps)
        onset = onset_from_amplitudes(lams[fin], amps[fin], threshold)
        return LCOOnset(onset, [(float(x), float(a)) for x, a in zip(lams, amps)])

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
                assert prev_lam is not None  # set with prev_div
                div_hi = self._bisect(prev_lam, float(lam), lambda x: self.flat_stability(x).status
                                      == "divergence", rtol)
            prev_lam, prev_div = float(lam), flat_div
            if res.status == "flutter":
                lo = history[-2][0] if len(history) > 1 else 0.0
                onset = self._bisect(lo, float(lam), lambda x: self.stability(x)[0].status
                                     != "flutter", rtol)
                break
        divergence = None
        if div_lo is not None:
            if div_hi is None:
                assert prev_lam is not None  # div_lo was set in the sweep, so was prev_lam
                div_hi = float(prev_lam) if onset is None else onset
            divergence = (div_lo, div_hi)
        freq = None
        if onset is not None:
            res = self.stability(onset * (1 + 2 * rtol))[0]
            freq = float(abs(res.lambda_p[res.critical].imag) / self.omega_1)
        return FlutterResult(lambda_cr=onset, instability_type="flutter" if onset else None,
                             frequency_ratio=freq,
                             divergence_range=divergence,
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


def lco_amplitude_from_signal(times: np.ndarray, w: np.ndarray, tail: float = 0.25) -> float:
    """Half the peak-to-peak value of ``w`` over the last ``tail`` fraction of the record.

    Parameters
    ----------
    times : ndarray of shape (n,)
        Sample times (ascending).
    w : ndarray of shape (n,)
        Signal (e.g. the centre deflection over the thickness).
    tail : float
        Fraction (0, 1] of the time span, counted from its end, that is examined.

    Returns
    -------
    float
        ``(max - min) / 2`` of the samples in the tail window (a static offset, e.g. a
        post-buckled equilibrium, does not count as amplitude).
    """
    t = np.asarray(times, dtype=float)
    x = np.asarray(w, dtype=float)
    if t.shape != x.shape or t.size < 2:
        raise InputError("lco", "times and signal must be equal-length arrays of >= 2 samples")
    if not 0.0 < tail <= 1.0:
        raise InputError("lco.tail", "must be in (0, 1]")
    window = x[t >= t[-1] - tail * (t[-1] - t[0])]
    return 0.5 * float(window.max() - window.min())


def onset_from_amplitudes(lams: np.ndarray, amps: np.ndarray, threshold: float = 1e-3
                          ) -> float | None:
    """Zero of the least-squares line ``A^2 = c (lambda - lambda_0)`` through the runs with a
    limit cycle (amplitude above ``threshold``); None with fewer than two such runs."""
    lam = np.asarray(lams, dtype=float)
    a = np.asarray(amps, dtype=float)
    keep = a > threshold
    if np.count_nonzero(keep) < 2:
        return None
    slope, icpt = np.polyfit(lam[keep], a[keep] ** 2, 1)
    if not slope > 0.0:
        return None
    return float(-icpt / slope)


@dataclass(frozen=True)
class LCOOnset:
    """Time-domain flutter onset: the amplitude curve and the fitted onset."""

    lambda_onset: float | None
    curve: list[tuple[float, float]]


def _fluid(aero: str) -> FluidModel:
    """The sweep's fluid model: piston theory without heating, or a ROM file (``--aero``
    errors)."""
    if aero in ("pt1", "pt"):
        return AnalyticFluid(aero, heating="none")
    if not aero.startswith(ROM_PREFIX):
        raise InputError("--aero", f"the flutter sweep takes 'pt1', 'pt' or 'rom:PATH'; "
                         f"got {aero!r}")
    try:
        return make_fluid_model(aero, heating="none")
    except InputError as exc:
        raise InputError("--aero", exc.message) from None
