"""The one simulation-settings type (:class:`SimulationSettings`) and its defaults."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from hypate.solvers.aero.factory import AERO_NAMES, is_aero_name
from hypate.solvers.errors import InputError
from hypate.solvers.thermal.schedule import check_schedule

#: Most time steps of one simulation (a study's ``steps`` has the same bound).
MAX_STEPS = 100_000
#: Largest ``continuation_steps`` (increments of one re-solved TC step).
MAX_CONTINUATION_STEPS = 100
#: The values of the string settings (for the type checker; checked at run time below).
Scheme = Literal["tc", "s1", "s2"]
Heating = Literal["eckert", "none"]
BoundaryLayer = Literal["turbulent", "laminar"]
#: Coupled schemes: tightly coupled quasi-steady, loosely coupled S1 and S2.
SCHEMES: tuple[str, ...] = ("tc", "s1", "s2")
HEATINGS: tuple[str, ...] = ("eckert", "none")
BOUNDARY_LAYERS: tuple[str, ...] = ("turbulent", "laminar")


@dataclass(frozen=True)
class SimulationSettings:
    """THE settings of one simulated test article (SI units), with THE defaults.

    Case files (``[simulation]``), study files (``[simulation]``), the scaling problem and
    the coupled schemes all build and read this one type, so the defaults cannot disagree
    and what the similarity table sees is what the simulator runs.

    Attributes
    ----------
    scheme : {"tc", "s1", "s2"}
        Tightly coupled quasi-steady with LSA (Sec. 5.3.2) or loosely coupled S1/S2
        (Sec. 5.3.1).
    aero, heating, boundary_layer : str
        Fluid model (:data:`hypate.solvers.aero.factory.AERO_NAMES` or ``rom:PATH``),
        ``"eckert"`` | ``"none"``, ``"turbulent"`` | ``"laminar"``.
    rho_bar : float
        Generalized-alpha spectral radius at infinity (Eq. 3.45) of the transient schemes:
        0.5 damps the stiff in-plane modes.
    time_step, duration : float
        s.
    radiation_temperature : float or None
        Surroundings of the upper-surface radiation (K); None = free-stream temperature.
        A radiant heater of the scaling problem sets this to T_rad.
    radiation_schedule : tuple of float or None
        A time-scheduled heater instead (Sec. 9.2.3 Case 2 with ``T_rad(t)``): control
        temperatures (K) at the equally spaced fractions ``0 .. 1`` of ``duration``,
        interpolated linearly in time
        (:class:`hypate.solvers.thermal.schedule.HeaterSchedule`); None: the constant
        ``radiation_temperature``. The two cannot both be set.
    external_pressure : float
        Uniform pressure on the panel's lower surface minus p_inf (Pa): positive pushes
        the panel towards +z (into the flow).
    external_heat_flux : float
        Uniform external heat flux q_ext (W/m^2) absorbed by the upper surface (a design
        or what-if value; a radiant heater is ``radiation_temperature``), the q_ext of
        ``Bi_ext = q_ext h / (k T_T)`` (Eq. 6.1d): added to the fluid heat flux delivered to
        the thermal model, ``Q = H_TF (q + q_ext)`` (Eq. 5.1b). Not ramped by ``run_lc``'s
        ``ramp_time`` and not part of the recorded (fluid) heat flux. 0 = none (the results
        are exactly those without it).
    lsa_modes : int
        Eigenvalues computed per LSA.
    lsa_every : int
        LSA every this many steps (1 = every step).
    unstable_steps : int
        Consecutive unstable LSA results that end the run.
    continuation_steps : int
        0 (the scheme of Sec. 5.4.3 as it is): a TC step's equilibrium is one Newton from
        the last state. N > 0: a step whose equilibrium the LSA finds divergent, or whose
        deflection field moved by more than half its size, is followed from the last state
        by continuation in N increments of the temperature, and the continued state is
        kept when it is a stable equilibrium all the way (the quasi-steady path's branch:
        one Newton across a large step from the flat, pre-buckling state converges to the
        unstable equilibrium between the buckled branches or to the branch the panel does
        not buckle onto, by a hair's difference in the design). Where the path has no
        equilibrium (a snap-through) or the continuation finds the same state, the step is
        as without it.
    passes : int
        Maximum thermal/aeroelastic fixed-point passes per step (1 = one of each).
    pass_tol : float
        Relative change of T and u that ends the passes.
    newton_rtol : float
        Residual tolerance of the aeroelastic Newton (relative to the load scale).
    newton_max_iter : int
    fluid_density : int
        Fluid points per shell-node spacing (transfer grid).
    thermal_alpha : float
        Crank-Nicolson alpha-bar.
    keep_fields : bool
        Store nodal u and T for every step in the response.
    initial_temperature_rise : float
        Uniform temperature rise (K) of the panel at t = 0 over its stress-free initial
        temperature (the uniformly heated panel of Sec. 9.1).
    initial_deflection : float
        Amplitude of an initial deflection ``w0 = A h sin(pi x/a) sin(pi y/b)`` in units of
        the thickness (a perturbation that lets a flat heated panel leave the trivial state).
    """

    scheme: Scheme = "tc"
    aero: str = "pt-bl"
    heating: Heating = "eckert"
    boundary_layer: BoundaryLayer = "turbulent"
    time_step: float = 1.0
    duration: float = 160.0
    radiation_temperature: float | None = None
    radiation_schedule: tuple[float, ...] | None = None
    external_pressure: float = 0.0
    external_heat_flux: float = 0.0
    lsa_modes: int = 6
    lsa_every: int = 1
    unstable_steps: int = 2
    continuation_steps: int = 0
    passes: int = 1
    pass_tol: float = 1e-5
    newton_rtol: float = 1e-8
    newton_max_iter: int = 30
    fluid_density: int = 2
    thermal_alpha: float = 0.5
    keep_fields: bool = True
    initial_temperature_rise: float = 0.0
    initial_deflection: float = 0.0
    rho_bar: float = 0.5

    def __post_init__(self) -> None:
        if self.scheme not in SCHEMES:
            raise InputError("simulation.scheme", f"must be one of {', '.join(SCHEMES)}")
        if not is_aero_name(self.aero):
            raise InputError("simulation.aero", f"must be one of {', '.join(AERO_NAMES)} or "
                             f"'rom:PATH'; got {self.aero!r}")
        if self.heating not in HEATINGS:
            raise InputError("simulation.heating", f"must be one of {', '.join(HEATINGS)}")
        if self.boundary_layer not in BOUNDARY_LAYERS:
            raise InputError("simulation.boundary_layer",
                             f"must be one of {', '.join(BOUNDARY_LAYERS)}")
        if not 0.0 <= self.rho_bar <= 1.0:
            raise InputError("simulation.rho_bar", f"must be in [0, 1]; got {self.rho_bar:g}")
        if not (self.time_step > 0 and math.isfinite(self.time_step)):
            raise InputError("simulation.time_step", "must be > 0 (s)")
        if not (self.duration >= self.time_step and math.isfinite(self.duration)):
            raise InputError("simulation.duration", "must be finite and at least one "
                             f"time_step (s); got {self.duration:g}")
        if self.duration / self.time_step > MAX_STEPS + 0.5:
            raise InputError("simulation.duration", f"duration / time_step = "
                             f"{self.duration / self.time_step:.6g} steps; at most {MAX_STEPS}")
        if self.unstable_steps < 1:
            raise InputError("simulation.unstable_steps", "must be >= 1")
        if not 0 <= self.continuation_steps <= MAX_CONTINUATION_STEPS:
            raise InputError("simulation.continuation_steps",
                             f"must be an integer in [0, {MAX_CONTINUATION_STEPS}]; "
                             f"got {self.continuation_steps}")
        if self.passes < 1:
            raise InputError("simulation.passes", "must be >= 1")
        if self.radiation_schedule is not None:
            if self.radiation_temperature is not None:
                raise InputError("simulation.radiation_schedule", "a heater schedule and a "
                                 "constant radiation_temperature cannot both be set")
            object.__setattr__(self, "radiation_schedule",
                               check_schedule(self.radiation_schedule))
        if not math.isfinite(self.external_heat_flux):
            raise InputError("simulation.external_heat_flux", "must be finite (W/m^2)")

    @property
    def n_steps(self) -> int:
        return int(round(self.duration / self.time_step))


#: The defaults, for the file schemas that offer these settings as keys.
DEFAULTS = SimulationSettings()

__all__ = ["BOUNDARY_LAYERS", "DEFAULTS", "HEATINGS", "MAX_STEPS", "SCHEMES",
           "SimulationSettings"]
