"""Configurations: one test article (the prototype in flight or a model in a tunnel) and how
design variables (:mod:`.variables`) build a model configuration from a template
(:func:`apply_design`). SI units; the similarity parameters of a configuration are
:mod:`.similarity`'s. :func:`simulate_configuration` runs the simulator on one
configuration with its own settings.
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from hypate.scaling.workflow.vocabulary.variables import (
    CATEGORICAL,
    DESIGN_VARIABLES,
    LAYER_PATTERN,
    SCHEDULE_POINTS,
    DesignVariable,
    is_design_variable,
    schedule_point,
)
from hypate.solvers.aero.factory import make_fluid_model
from hypate.solvers.coupling.lc import run_lc
from hypate.solvers.coupling.model import PanelModel
from hypate.solvers.coupling.response import Response
from hypate.solvers.coupling.tc import run_tc
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition
from hypate.solvers.materials import STEFAN_BOLTZMANN, Material
from hypate.solvers.panel import PanelSpec
from hypate.solvers.settings import SimulationSettings
from hypate.solvers.thermal.schedule import HeaterSchedule


# -- inputs ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class ReferenceTemperatures:
    """Reference temperatures (K); ``None`` means the default rule (Eq. 9.7).

    Attributes
    ----------
    wall : float or None
        ``T_w``; default the panel's initial temperature.
    structural : float or None
        ``T_S`` (stiffness, expansion, density); default ``T_w``.
    thermal : float or None
        ``T_T`` (conductivity, heat capacity); default ``T_w``.
    fluid : float or None
        ``T_F`` (viscosity, fluid conductivity); default the free-stream temperature.
    """

    wall: float | None = None
    structural: float | None = None
    thermal: float | None = None
    fluid: float | None = None

    def resolve(self, panel: PanelSpec, flow: FlowCondition) -> ReferenceTemperatures:
        """All four temperatures filled in by the default rule, validated positive."""
        wall = float(panel.initial_temperature if self.wall is None else self.wall)
        out = ReferenceTemperatures(
            wall=wall,
            structural=float(wall if self.structural is None else self.structural),
            thermal=float(wall if self.thermal is None else self.thermal),
            fluid=float(flow.temperature if self.fluid is None else self.fluid))
        for key in ("wall", "structural", "thermal", "fluid"):
            value = getattr(out, key)
            if not (math.isfinite(value) and value > 0.0):
                raise InputError(f"temperatures.{key}", f"must be a positive temperature (K); "
                                 f"got {value:g}")
        return out


@dataclass(frozen=True)
class Configuration:
    """One test article (prototype in flight or model in a tunnel), SI units.

    Attributes
    ----------
    panel : PanelSpec
    flow : FlowCondition
    temperatures : ReferenceTemperatures or None
        Reference temperatures; ``None`` or ``None`` fields follow the defaults of Eq. (9.7)
        (see the module docstring).
    delta_T : float or None
        Uniform temperature rise Delta T (K) of Eq. (9.1a); ``None`` if not applicable.
    time : float or None
        Reference time t (s), e.g. the time step or the duration, for the time parameters of
        Eq. (6.1b); ``None`` leaves them out. :meth:`with_time_step` sets it to the time
        step the simulation runs.
    simulation : SimulationSettings
        How this article is simulated -- scheme, fluid model, time step, and the external
        loads the similarity parameters see: ``external_pressure`` p_ext (Pa, Eq. 6.1e),
        ``external_heat_flux`` q_ext (W/m^2, Eq. 6.1d), ``radiation_temperature`` T_rad (K,
        a radiant heater) or ``radiation_schedule`` (a heater scheduled over the test's
        nondimensional time). The configuration keeps no copy of them (its properties of
        those names read these), so what the similarity table sees is what the simulator
        runs.
    """

    panel: PanelSpec
    flow: FlowCondition
    temperatures: ReferenceTemperatures | None = None
    delta_T: float | None = None
    time: float | None = None
    simulation: SimulationSettings = field(default_factory=SimulationSettings)

    @property
    def external_pressure(self) -> float:
        """p_ext (Pa), Eq. (6.1e): the simulation's external pressure."""
        return float(self.simulation.external_pressure)

    @property
    def external_heat_flux(self) -> float:
        """Explicit q_ext (W/m^2), Eq. (6.1d): the simulation's external heat flux."""
        return float(self.simulation.external_heat_flux)

    @property
    def radiation_temperature(self) -> float | None:
        """Radiant heater temperature T_rad (K), None without a constant heater."""
        return self.simulation.radiation_temperature

    @property
    def radiation_schedule(self) -> HeaterSchedule | None:
        """The heater schedule ``T_rad(t)`` over this article's duration, None without one."""
        sim = self.simulation
        return (None if sim.radiation_schedule is None
                else HeaterSchedule(sim.radiation_schedule, sim.duration))

    def with_time_step(self, time_step: float) -> Configuration:
        """This configuration simulated with ``time_step`` (same number of steps) and with
        that step as the reference time of its similarity parameters (Eq. 6.1b)."""
        sim = self.simulation
        return dataclasses.replace(self, time=float(time_step), simulation=dataclasses.replace(
            sim, time_step=float(time_step), duration=float(time_step) * sim.n_steps))

    def run_settings(self, keep_fields: bool = False) -> SimulationSettings:
        """The settings of this configuration's simulation: its own, with the uniform
        temperature rise Delta T (Eq. 9.1a) as the initial state."""
        return dataclasses.replace(self.simulation, keep_fields=keep_fields,
                                   initial_temperature_rise=float(self.delta_T or 0.0))

    @property
    def heat_flux(self) -> float:
        """Total external heat flux q_ext (W/m^2) absorbed by the upper surface (Eq. 6.1d):
        with a heater schedule, its time mean over the test (``emissivity sigma`` times
        :meth:`HeaterSchedule.mean_fourth_power`)."""
        q = float(self.external_heat_flux)
        if self.radiation_temperature is not None:
            q += self.panel.emissivity * STEFAN_BOLTZMANN * self.radiation_temperature**4
        schedule = self.radiation_schedule
        if schedule is not None:
            q += self.panel.emissivity * STEFAN_BOLTZMANN * schedule.mean_fourth_power()
        return q

    def resolved_temperatures(self) -> ReferenceTemperatures:
        """The reference temperatures with the defaults of Eq. (9.7) filled in."""
        temps = self.temperatures if self.temperatures is not None else ReferenceTemperatures()
        return temps.resolve(self.panel, self.flow)


# -- building model configurations from design variables ------------------------------------------


def scaled_panel(template: PanelSpec, *, length: float | None = None,
                 thickness: float | None = None, leading_edge_length: float | None = None,
                 width: float | None = None) -> PanelSpec:
    """A copy of ``template`` with a new length (width scaled with it unless given), total
    thickness (all layers scaled proportionally) and/or leading-edge length."""
    changes: dict[str, Any] = {}
    if length is not None:
        positive("L", length, "m")
        changes["length"] = float(length)
        changes["width"] = float(template.width * length / template.length)
    if width is not None:
        changes["width"] = positive("width", width, "m")
    if leading_edge_length is not None:
        changes["leading_edge_length"] = positive("L_le", leading_edge_length, "m")
    if thickness is not None:
        factor = positive("h", thickness, "m") / template.thickness
        changes["layers"] = tuple(dataclasses.replace(layer, thickness=layer.thickness * factor)
                                  for layer in template.layers)
    return dataclasses.replace(template, **changes)


def with_material(config: Configuration, material: Material) -> Configuration:
    """``config`` with every layer of its panel made of ``material`` (a categorical model
    material: the model is one material, its layup and thicknesses kept)."""
    panel = config.panel
    layers = tuple(dataclasses.replace(layer, material=material) for layer in panel.layers)
    return dataclasses.replace(config, panel=dataclasses.replace(panel, layers=layers))


def with_choice(config: Configuration, name: str, value: Any) -> Configuration:
    """``config`` with categorical variable ``name`` set to its chosen ``value`` (a study's
    level, as the study resolved it) at its row's target: a panel's ``material`` is every
    layer's (:func:`with_material`), any other target field takes the value as it is and
    is checked where its part is built (e.g. ``PanelSpec.boundary``)."""
    var = DESIGN_VARIABLES[name]
    if var.kind != "categorical":
        raise InputError(f"design.{name}", "is not a categorical variable")
    part, target = var.target
    if (part, target) == ("panel", "material"):
        return with_material(config, value)
    if part == "configuration":
        return dataclasses.replace(config, **{target: value})
    return dataclasses.replace(config, **{
        part: dataclasses.replace(getattr(config, part), **{target: value})})


def positive(name: str, value: float, unit: str) -> float:
    value = float(value)
    if not (math.isfinite(value) and value > 0.0):
        raise InputError(f"design.{name}", f"must be a positive number ({unit}); got {value:g}")
    return value


def apply_design(template: Configuration, design: Mapping[str, float]) -> Configuration:
    """The configuration obtained by setting design variables on a template.

    Parameters
    ----------
    template : Configuration
        Model template: material layup, aspect ratio, Mach number, fixed values.
    design : mapping
        ``{name: value}`` with names from
        :data:`hypate.scaling.workflow.vocabulary.variables.DESIGN_VARIABLES`:

        * ``L`` (width follows at the template's aspect ratio), ``width``, ``L_le``,
          ``h`` (layers scaled proportionally; applied before any ``h[k]``), ``h[k]``,
          ``emissivity``;
        * tunnel setting ``M``, ``p0``, ``T0`` (isentropic nozzle; unspecified ones from the
          template flow's stagnation state) or static ``p_inf``, ``T_inf`` (Mach from
          ``M`` or the template); the two groups ``p0``/``T0`` and ``p_inf``/``T_inf``
          cannot be mixed;
        * ``delta_T``, ``time``, ``p_ext``, ``q_ext``, ``T_rad``;
        * ``T_rad[0]`` .. ``T_rad[n-1]`` (all of them, 2 <= n <= 12, not with ``T_rad``):
          a heater schedule, the control temperatures at the nondimensional times
          ``k / (n - 1)`` of the test (``SimulationSettings.radiation_schedule``);
        * ``T_w`` sets ``T_w = T_S = T_T`` (Eq. 9.7).

    Raises
    ------
    InputError
        Unknown names, non-positive values, mixed stagnation/static flow variables.
    """

    unknown = [n for n in design if not is_design_variable(n) or n.endswith("[k]")]
    if unknown:
        raise InputError(f"design.{unknown[0]}", "unknown design variable; known: "
                         f"{', '.join(DESIGN_VARIABLES)}")
    categorical = [n for n in design if n in CATEGORICAL]
    if categorical:  # a level number means nothing without the study's list of values
        raise InputError(f"design.{categorical[0]}", "is categorical: the scaling problem "
                         "sets it (ScalingProblem.configure), not a number")
    # every row's value into the part its target names (field -> (row, value)), in the
    # table's order; each part checks its values as it is composed: panel, flow, reference
    # temperatures, configuration, loads (the first bad value of a design is reported)
    parts: dict[str, dict[str, tuple[DesignVariable, Any]]] = {part: {} for part in PARTS}
    for name, var in DESIGN_VARIABLES.items():
        if var.target and design.get(name) is not None:
            part, *fields = var.target
            parts[part].update({f: (var, design[name]) for f in fields})
    changes: dict[str, Any] = {"panel": _panel(template.panel, parts["panel"], design),
                               "flow": _flow(template.flow, parts["flow"]),
                               "temperatures": template.temperatures}
    if parts["temperatures"]:
        changes["temperatures"] = dataclasses.replace(
            template.temperatures or ReferenceTemperatures(), **_values(parts["temperatures"]))
    changes.update(_values(parts["configuration"]))
    loads = _values(parts["simulation"])
    schedule = heater_schedule(design)
    if schedule is not None:
        loads.update(radiation_schedule=schedule, radiation_temperature=None)
    if loads:
        changes["simulation"] = dataclasses.replace(template.simulation, **loads)
    return dataclasses.replace(template, **changes)


#: The parts of a configuration a design variable's target names (variables.DesignVariable).
PARTS = ("panel", "flow", "simulation", "temperatures", "configuration")
#: Panel fields set by :func:`scaled_panel` (a length scales the width, a thickness every
#: layer); the other panel fields are replaced as they are.
_SCALED = ("length", "thickness", "leading_edge_length", "width")
#: Static flow fields; the stagnation ones cannot be mixed with them.
_STATIC = ("pressure", "temperature")
_STAGNATION = ("stagnation_pressure", "stagnation_temperature")


def _checked(var: DesignVariable, value: Any) -> float:
    """A design value as its row's ``check`` allows it (``design.NAME`` errors)."""
    if var.check == "positive":
        return positive(var.name, value, var.unit)
    value = float(value)
    if var.check == "fraction" and not 0.0 <= value <= 1.0:
        raise InputError(f"design.{var.name}", f"must be in [0, 1]; got {value:g}")
    return value


def _values(part: dict[str, tuple[DesignVariable, Any]]) -> dict[str, Any]:
    """A part's fields, each value checked by its row."""
    return {f: _checked(var, value) for f, (var, value) in part.items()}


def _panel(panel: PanelSpec, values: dict[str, tuple[DesignVariable, Any]],
           design: Mapping[str, float]) -> PanelSpec:
    """The panel part: the scaled fields (checked by :func:`scaled_panel`), then the
    layers' own thicknesses ``h[k]``, then the other fields."""
    scaled: dict[str, Any] = {f: values[f][1] for f in _SCALED if f in values}
    panel = scaled_panel(panel, **scaled)
    layer_changes = {int(m.group(1)): design[n] for n in design
                     if (m := LAYER_PATTERN.match(n)) is not None}
    if layer_changes:
        layers = list(panel.layers)
        for k, value in layer_changes.items():
            if k >= len(layers):
                raise InputError(f"design.h[{k}]", f"the panel has {len(layers)} layers")
            layers[k] = dataclasses.replace(layers[k], thickness=positive(f"h[{k}]", value,
                                                                            "m"))
        panel = dataclasses.replace(panel, layers=tuple(layers))
    rest = _values({f: v for f, v in values.items() if f not in _SCALED})
    return dataclasses.replace(panel, **rest) if rest else panel


def _flow(flow: FlowCondition, values: dict[str, tuple[DesignVariable, Any]]
          ) -> FlowCondition:
    """The flow part: an isentropic nozzle's stagnation state or a static state at the
    design's (or the template's) Mach number; unspecified values from the template."""
    static = [values[f][0].name for f in _STATIC if f in values]
    stag = [values[f][0].name for f in _STAGNATION if f in values]
    if stag and static:
        raise InputError(f"design.{static[0]}", "cannot mix stagnation (p0, T0) and static "
                         "(p_inf, T_inf) flow variables")
    get = {f: float(v) for f, (_, v) in values.items()}
    mach = get.get("mach", float(flow.mach))
    try:
        if static:
            return FlowCondition.from_static(mach, get.get("pressure", float(flow.pressure)),
                                             get.get("temperature", float(flow.temperature)))
        if stag or "mach" in values:
            return FlowCondition.from_stagnation(
                mach, get.get("stagnation_pressure", float(flow.stagnation_pressure)),
                get.get("stagnation_temperature", float(flow.stagnation_temperature)))
    except InputError as exc:
        raise InputError(f"design.{exc.field}", exc.message) from None
    return flow


def nominal_values(config: Configuration) -> dict[str, float]:
    """The value of every optimizable continuous design variable ``config`` holds, read back
    through its row's target (:mod:`hypate.scaling.workflow.vocabulary.variables`): a robust
    study's nominal values, the defaults of a recycled design, the prototype's values of the
    laws. A quantity the configuration does not have (no heater: ``T_rad``; no ``delta_T``)
    is left out."""
    out: dict[str, float] = {}
    for name, var in DESIGN_VARIABLES.items():
        if not (var.optimizable and var.target) or var.kind == "categorical":
            continue
        part, f = var.target[0], var.target[1]
        holder = config if part == "configuration" else getattr(config, part)
        value = None if holder is None else getattr(holder, f)
        if value is not None:
            out[name] = float(value)
    return out


def heater_schedule(design: Mapping[str, float]) -> tuple[float, ...] | None:
    """The control temperatures ``T_rad[0] .. T_rad[n-1]`` of a design (K), in order, or
    None without any: the heater of the radiation condition (Eq. 4.24) scheduled over the
    test, Sec. 9.2.3 Case 2 with ``T_rad(t)`` for the constant ``T_rad`` of Table 9.7.

    Raises
    ------
    InputError
        ``design.T_rad[k]``: a missing point, fewer than 2 or more than 12 points, a
        temperature that is not positive, or a constant ``T_rad`` as well.
    """
    points = {p[1]: float(v) for n, v in design.items() if (p := schedule_point(n)) is not None}
    if not points:
        return None
    n = max(points) + 1
    lo, hi = SCHEDULE_POINTS
    if "T_rad" in design:
        raise InputError("design.T_rad", "a constant T_rad and a schedule T_rad[k] cannot "
                         "both be set")
    missing = [k for k in range(n) if k not in points]
    if missing:
        raise InputError(f"design.T_rad[{missing[0]}]", f"a schedule of {n} points needs "
                         f"T_rad[0] .. T_rad[{n - 1}]")
    if not lo <= n <= hi:
        raise InputError(f"design.T_rad[{n - 1}]", f"a schedule has {lo} to {hi} control "
                         f"points; got {n}")
    return tuple(positive(f"T_rad[{k}]", points[k], "K") for k in range(n))


__all__ = ["PARTS", "Configuration", "ReferenceTemperatures", "apply_design", "heater_schedule",
           "nominal_values", "positive", "scaled_panel", "with_material"]


def simulate_configuration(config: Configuration, keep_fields: bool = False) -> Response:
    """Run the simulator on one configuration with its own settings
    (:meth:`Configuration.run_settings`): what the similarity table of ``config`` describes
    is what runs. The TC scheme runs with LSA each step; the aeroelastic S2 scheme records
    every step and runs past a snap-through (the comparison needs the whole history). The
    explicit external heat flux q_ext (Eq. 6.1d) heats the upper surface; a radiant heater's
    part of q_ext is the radiation exchange with ``radiation_temperature``.
    """
    settings = config.run_settings(keep_fields=keep_fields)
    fluid = make_fluid_model(settings.aero, settings.heating, settings.boundary_layer)
    model = PanelModel(config.panel, config.flow, fluid, settings)
    if settings.scheme == "tc":
        return run_tc(model)
    return run_lc(model, settings.scheme, record_every=1, stop_on_snap=False)
