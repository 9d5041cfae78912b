"""Study files (TOML): a scaling problem plus optimizer settings, validated.

The file's keys, their sections and cross-key checks are the schema of :mod:`.study_file`
(its docstring is the key reference); this module builds the :class:`Study` from a validated
``StudyFile`` (:func:`parse_study`, :func:`load_study`). What derives from a parsed study
(the sweep's points, the study of one point, its plain data) lives in :mod:`.derived`.
Every error is an :class:`~solvers.errors.InputError` naming its key; nothing runs on a bad
file.
"""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any, cast, overload

from hypate.scaling.engine.acquisition import default_acquisition
from hypate.scaling.engine.stopping import StoppingRule
from hypate.scaling.workflow.vocabulary import uncertainty as scatter
from hypate.scaling.workflow.vocabulary.configuration import Configuration
from hypate.scaling.workflow.vocabulary.design_space import study_levels, study_variables
from hypate.scaling.workflow.vocabulary.external import load_simulator, resolve_simulator
from hypate.scaling.workflow.vocabulary.fidelity import (
    FidelitySection,
    default_low_samples,
    level_data,
)
from hypate.scaling.workflow.vocabulary.problem import ScalingProblem
from hypate.scaling.workflow.vocabulary.shipped import resolve, resolve_aero
from hypate.scaling.workflow.vocabulary.spec import OBJECTIVES, ScalingSpec
from hypate.scaling.workflow.vocabulary.study_file import (
    MAX_SEED,
    ConstraintsSection,
    LawsSection,
    ModelSection,
    OptimizerSection,
    PosFloat,
    PrototypeSection,
    SimulationSection,
    StudyFile,
    StudySection,
    SweepSection,
)  # the schema's names, importable from here as before the split (__all__)
from hypate.scaling.workflow.vocabulary.tunnels import TunnelEnvelope, resolve_tunnel
from hypate.scaling.workflow.vocabulary.variables import HARD_LIMITS
from hypate.solvers import materials as mat
from hypate.solvers.aero.factory import AERO_NAMES, is_aero_name
from hypate.solvers.config import (
    load_case,
    pydantic_input_error,
    read_toml,
    resolve_material,
)
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition
from hypate.solvers.panel import Layer, PanelSpec
from hypate.solvers.settings import SimulationSettings
from pydantic import ValidationError


@dataclasses.dataclass(frozen=True)
class Study:
    """A validated study: the scaling spec, the tunnel and the optimizer settings."""

    path: str
    name: str
    description: str
    spec: ScalingSpec
    tunnel: TunnelEnvelope | None
    optimizer: OptimizerSection
    raw: StudyFile
    uncertainty: scatter.Uncertainty | None = None  # [uncertainty] / [robust]; None: nominal
    #: The ``[[fidelity]]`` levels below the study's own, cheapest first: (name, spec,
    #: section); empty for a single-fidelity study (scaling.workflow.vocabulary.fidelity).
    lower_levels: tuple[tuple[str, ScalingSpec, FidelitySection], ...] = ()

    @property
    def level_names(self) -> list[str]:
        """Every fidelity level's name, cheapest first (empty: single fidelity)."""
        if not self.lower_levels:
            return []
        return [name for name, _, _ in self.lower_levels] + [self.raw.fidelity[-1].name]

    @property
    def sweep(self) -> SweepSection | None:
        """The ``[sweep]`` table (None: a single optimization)."""
        return self.raw.sweep

    @property
    def budget(self) -> int:
        """Evaluations the optimizer may spend (initial samples + iterations x batch + polish),
        per sweep point for a sweep study."""
        opt = self.optimizer
        nested = opt.initial_samples * len(self.lower_levels) + sum(  # the lower levels' share
            default_low_samples(f, opt.initial_samples) for _, _, f in self.lower_levels)
        return opt.initial_samples + nested + self.iteration_cap * opt.batch_size + opt.polish

    @property
    def iteration_cap(self) -> int:
        """The iterations the optimizer may run: ``iterations``, or with ``"auto"`` its
        ``max_iterations`` (the hard cap of the stopping rule)."""
        opt = self.optimizer
        return opt.max_iterations if opt.iterations == "auto" else int(opt.iterations)

    @property
    def stopping_rule(self) -> StoppingRule | None:
        """The stopping rule of ``iterations = "auto"`` (None: a fixed count)."""
        opt = self.optimizer
        return (StoppingRule(min_iterations=opt.min_iterations) if opt.iterations == "auto"
                else None)

    def summary(self) -> list[str]:
        """A few lines describing the study (``hypate validate``)."""
        spec, sim = self.spec, self.raw.simulation
        lines = [f"study {self.name}: {self.description or '(no description)'}",
                 f"kind {self.raw.study.kind}, objectives {', '.join(spec.objectives)}, "
                 f"xi = {spec.xi:g}, time scaling {spec.time_scaling}",
                 f"prototype case {self.raw.prototype.case}; model "
                 f"{' / '.join(spec.material_names) or self.raw.model.material}"
                 + (f" in tunnel {self.tunnel.name}" if self.tunnel is not None else ""),
                 f"simulation: {sim.steps} steps of {sim.time_step:g} s, aero {sim.aero}, "
                 f"heating {sim.heating}"]
        lines += [f"variable {v.name} in {{{', '.join(spec.level_names(v.name))}}}"
                  if v.name in spec.levels else f"variable {v.name} in [{v.lower:g}, {v.upper:g}]"
                  for v in spec.variables]
        lines += [f"fixed {k} = {v:g}" for k, v in spec.fixed.items()]
        lines.append("admissibility: " + ", ".join(
            f"{r.name} {r.mode}" + (f" (margin {r.margin:g})" if r.margin else "")
            for r in spec.admissibility.rules))
        lines += [f"fidelity {name}: mesh {'x'.join(map(str, sp.model.panel.mesh))}, "
                  f"{round(sp.simulation.duration / sp.simulation.time_step)} steps"
                  for name, sp in zip(self.level_names, [s for _, s, _ in self.lower_levels]
                                      + [spec])]
        sweep = f", {len(self.sweep.grid())} sweep points" if self.sweep is not None else ""
        lines.append(f"optimizer: {self.acquisition}, {self.budget} evaluations{sweep}, "
                     f"seed {self.optimizer.seed}")
        if (unc := self.uncertainty) is not None:
            lines += [f"uncertain {u.name}: {u.describe()}" for u in unc.inputs] + [
                f"robust: {unc.statistic}, order-{unc.order} chaos, {unc.n_samples} runs"]
        return lines

    @property
    def acquisition(self) -> str:
        opt = self.optimizer
        if opt.acquisition is not None:
            return opt.acquisition
        return default_acquisition(len(self.spec.objectives), opt.approach)


def constant_material(m: mat.Material, T: float) -> mat.Material:
    """``m`` with every property frozen at temperature ``T`` (Sec. 9.1, Table 9.1)."""
    @overload
    def c(prop: mat.Property) -> mat.Property: ...
    @overload
    def c(prop: None) -> None: ...
    def c(prop: mat.Property | None) -> mat.Property | None:
        return None if prop is None else mat.Property.constant(prop.name, float(prop(T)))

    return dataclasses.replace(
        m, density=c(m.density), E1=c(m.E1), E2=c(m.E2), nu12=c(m.nu12), G12=c(m.G12),
        G13=c(m.G13), G23=c(m.G23), alpha1=c(m.alpha1), alpha2=c(m.alpha2), k1=c(m.k1),
        k2=c(m.k2), k3=c(m.k3), specific_heat=c(m.specific_heat),
        base=None if m.base is None else constant_material(m.base, T),
        description=f"{m.name} at {T:g} K (temperature independent)")


def _freeze(panel: PanelSpec, T: float) -> PanelSpec:
    layers = tuple(dataclasses.replace(layer, material=constant_material(layer.material, T))
                   for layer in panel.layers)
    return dataclasses.replace(panel, layers=layers)


def simulation_settings(kind: str, sim: SimulationSection) -> SimulationSettings:
    """The one settings type from a study's ``[simulation]``: the prototype's time step and
    step count; ``kind`` picks the scheme (quasi-steady: TC with LSA, aeroelastic: S2)."""
    return SimulationSettings(
        scheme="tc" if kind == "quasi_steady" else "s2", aero=sim.aero, heating=sim.heating,
        boundary_layer=sim.boundary_layer, time_step=sim.time_step,
        duration=sim.time_step * sim.steps, lsa_modes=sim.lsa_modes,
        unstable_steps=sim.unstable_steps, continuation_steps=sim.continuation_steps,
        rho_bar=sim.rho_bar,
        initial_deflection=sim.initial_deflection)


def model_materials(cfg: StudyFile) -> tuple[tuple[str, mat.Material], ...]:
    """The model's material(s) by name: ``[model] material``, or every value of a
    categorical ``[variables] material`` list (library names or the study's
    ``[materials.NAME]``), frozen at the initial temperature for a temperature-independent
    model."""
    m = cfg.model
    names = study_levels(cfg.variables).get("material", (m.material,))
    field = "variables.material" if "material" in cfg.variables else "model.material"
    resolved: dict[str, mat.Material] = {}
    out = []
    for name in names:
        material = resolve_material(name, resolved, cfg.materials, field=field)
        if m.temperature_independent:
            material = constant_material(material, m.initial_temperature)
        out.append((name, material))
    return tuple(out)


def study_choices(cfg: StudyFile, materials: tuple[tuple[str, mat.Material], ...]
                  ) -> tuple[tuple[str, tuple[tuple[str, Any], ...]], ...]:
    """The ``ScalingSpec.choices`` of a study: each categorical ``[variables]`` entry's
    values, the material's resolved (``materials``: :func:`model_materials`), any other's
    the names themselves (its row's ``choices``, checked by the schema)."""
    return tuple((name, materials if name == "material" else tuple((n, n) for n in names))
                 for name, names in study_levels(cfg.variables).items())


def parse_study(data: dict[str, Any], path: str | Path = "<memory>") -> Study:
    """Validate a parsed study and build its :class:`ScalingSpec` (nothing is simulated)."""
    try:
        cfg = StudyFile.model_validate(data)
    except ValidationError as exc:
        raise pydantic_input_error(exc, model=StudyFile) from None
    base = Path(path).parent if str(path) != "<memory>" else Path.cwd()
    case_path = resolve(cfg.prototype.case, "case", base)
    try:
        case = load_case(case_path)
    except InputError as exc:
        raise InputError(f"prototype.case ({exc.field})", exc.message) from None
    if case.flow is None:
        raise InputError("prototype.case", f"{case_path} has no [flow] table")
    sim_cfg = cfg.simulation
    if sim_cfg.aero != (aero := resolve_aero(sim_cfg.aero, base)):  # a ROM found elsewhere
        sim_cfg = sim_cfg.model_copy(update={"aero": aero})
    proto_panel = case.panel
    if sim_cfg.mesh is not None:
        # validated: exactly two entries
        proto_panel = dataclasses.replace(proto_panel,
                                          mesh=cast("tuple[int, int]", tuple(sim_cfg.mesh)))
    if cfg.prototype.temperature_independent:
        proto_panel = _freeze(proto_panel, proto_panel.initial_temperature)
    proto_flow = case.flow
    if cfg.prototype.altitude is not None:
        proto_flow = FlowCondition.from_altitude(
            cfg.prototype.mach if cfg.prototype.mach is not None else case.flow.mach,
            cfg.prototype.altitude)
    elif cfg.prototype.mach is not None:
        proto_flow = FlowCondition.from_static(cfg.prototype.mach, case.flow.pressure,
                                               case.flow.temperature)
    simulation = simulation_settings(cfg.study.kind, sim_cfg)
    prototype = Configuration(panel=proto_panel, flow=proto_flow, delta_T=cfg.prototype.delta_T,
                              simulation=simulation)

    tunnel = None
    if cfg.tunnel is not None:
        tun = dict(cfg.tunnel)
        spec_tun: str | dict[str, Any] = tun["name"] if set(tun) == {"name"} else tun
        tunnel = resolve_tunnel(spec_tun, field="tunnel")

    # -- model template -------------------------------------------------------------------
    m = cfg.model
    xi = cfg.study.xi
    materials = model_materials(cfg)
    material = materials[0][1]
    thickness = m.thickness if m.thickness is not None else proto_panel.thickness / xi
    model_panel = PanelSpec(
        layers=(Layer(material, thickness, 0.0, m.sublayers),), kind=proto_panel.kind,
        length=proto_panel.length / xi, width=proto_panel.width / xi,
        boundary=m.boundary or proto_panel.boundary,
        leading_edge_length=proto_panel.leading_edge_length / xi,
        flow_angle=proto_panel.flow_angle, mesh=proto_panel.mesh,
        initial_temperature=m.initial_temperature,
        emissivity=proto_panel.emissivity if m.emissivity is None else m.emissivity,
        damping=proto_panel.damping, name="model")
    if tunnel is not None:
        lo_p, hi_p = tunnel.p0
        lo_T, hi_T = tunnel.T0
        mach = (tunnel.mach_values[0] if tunnel.mach_values
                else 0.5 * (tunnel.mach_bounds[0] + tunnel.mach_bounds[1]))
        if "M" in cfg.fixed:
            mach = cfg.fixed["M"]
        model_flow = FlowCondition.from_stagnation(mach, math.sqrt(lo_p * hi_p),
                                                   math.sqrt(lo_T * hi_T))
    else:
        model_flow = case.flow
    model = Configuration(panel=model_panel, flow=model_flow, delta_T=cfg.prototype.delta_T,
                          simulation=simulation)

    variables, increasing, decreasing = study_variables(cfg.variables, tunnel)
    if tunnel is not None and tunnel.mach_values and len(tunnel.mach_values) > 1 \
            and "M" not in cfg.fixed:
        raise InputError("fixed.M", f"tunnel {tunnel.name} has several nozzles "
                         f"{list(tunnel.mach_values)}: fix M (one study per nozzle, Eq. 6.7)")
    if tunnel is not None and tunnel.mach_values and "M" in cfg.variables:
        raise InputError("variables.M", f"tunnel {tunnel.name} has discrete Mach numbers "
                         f"{list(tunnel.mach_values)}; M cannot be a continuous variable")
    for name, value in cfg.fixed.items():
        lo, hi = HARD_LIMITS[name]
        if not (lo <= value <= hi):
            raise InputError(f"fixed.{name}", f"must be within [{lo:g}, {hi:g}]; got {value:g}")
    fixed = dict(cfg.fixed)
    aero = sim_cfg.aero
    if not is_aero_name(aero):
        raise InputError("simulation.aero", f"must be one of {', '.join(AERO_NAMES)} or "
                         f"'rom:PATH'; got {aero!r}")
    simulator = None
    if sim_cfg.simulator is not None:
        if cfg.study.projection != "center":
            raise InputError("simulation.simulator", f"the user's simulator returns the centre "
                             f"deflection: projection must be \"center\", not "
                             f"{cfg.study.projection!r}")
        simulator = resolve_simulator(sim_cfg.simulator, base)
        load_simulator(simulator)  # refused now, not at the first simulation
    spec = ScalingSpec(prototype=prototype, model=model, variables=variables, fixed=fixed,
                       objectives=tuple(cfg.study.objectives),
                       time_scaling=cfg.study.time_scaling, projection=cfg.study.projection,
                       equalities=tuple(cfg.constraints.equality), xi=xi,
                       increasing=increasing, decreasing=decreasing,
                       choices=study_choices(cfg, materials),
                       tunnel=tunnel, admissibility=cfg.admissibility.rules(),
                       simulator=simulator)
    uncertainty = scatter.parse_uncertainty(  # without [robust]: a nominal design
        cfg.uncertainty, cfg.robust or scatter.RobustSection(optimize=False),
        ScalingProblem(spec)) if cfg.uncertainty else None
    lower = tuple((f.name, parse_study(level_data(data, f), path).spec, f)
                  for f in cfg.fidelity[:-1])
    return Study(path=str(path), name=cfg.study.name, description=cfg.study.description,
                 spec=spec, tunnel=tunnel, optimizer=cfg.optimizer, raw=cfg,
                 uncertainty=uncertainty, lower_levels=lower)


def load_study(path: str | Path) -> Study:
    """Read and validate a study file (a path, or a shipped study's name: ``"quickstart"``)."""
    path = resolve(path, "study")
    return parse_study(read_toml(path), path)


__all__ = ["MAX_SEED", "OBJECTIVES", "ConstraintsSection", "LawsSection", "ModelSection",
           "OptimizerSection", "PosFloat", "PrototypeSection", "SimulationSection", "Study",
           "StudyFile", "StudySection", "SweepSection", "constant_material", "load_study",
           "model_materials", "parse_study", "simulation_settings", "study_choices"]
