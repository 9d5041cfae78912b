"""The study file's schema (TOML): its sections as pydantic models and their cross-key
checks; :mod:`.study` builds a :class:`~.study.Study` from the validated ``StudyFile``.

Public keys (documented in the README, used by the shipped ``studies/optimization/*.toml``)::

    [study]        name, description, kind ("quasi_steady" | "aeroelastic"), objectives,
                   xi, time_scaling ("fourier" | "fourier_thickness" | "structural"),
                   projection ("center" | "modal" | "fields")
    [prototype]    case (path of a case file, relative to the study), delta_T,
                   temperature_independent, mach, altitude (override the case's flight
                   condition: ``mach`` alone keeps the case's static p and T, ``altitude``
                   (m, 1976 standard atmosphere) needs ``mach`` or a case Mach number)
    [simulation]   time_step, steps, aero, heating, boundary_layer, initial_deflection,
                   lsa_modes, unstable_steps, continuation_steps, rho_bar, mesh,
                   simulator (the user's own: "package.module:function" or
                   "file.py:function", vocabulary.external)
    [model]        material (a library name or a [materials.NAME] of the study), thickness,
                   sublayers, boundary, emissivity, initial_temperature,
                   temperature_independent
    [materials.NAME]  user materials, the schema of case files (solvers.config)
    [tunnel]       name (shipped: ideal, WT5, WT6, WT7) or an inline envelope (mach /
                   mach_values, p0, T0 ...), mach (the nozzle to use)
    [variables]    NAME = [lower, upper] or "tunnel" (the envelope's bounds), a heater
                   schedule T_rad = { schedule = n, range = [lo, hi], shape = "free" |
                   "increasing" | "decreasing" }, or the model material as a categorical variable
                   material = ["ti6242", "inconel718", ...] (vocabulary.design_space)
    [fixed]        NAME = value (design values that are not optimized)
    [constraints]  equality = ["T_inf"]
    [admissibility]  temperature, data, stress, size, duration, envelope: each "constraint" |
                   "report" | "off" (stress also "auto", its default) or a table
                   { mode, margin, safety_factor (stress), injection_time (duration, s) }
                   (scaling.workflow.vocabulary.admissibility)
    [optimizer]    approach, acquisition, v, weights, initial_samples, iterations,
                   batch_size, seed, classical_seed, transform ("none" | "log"),
                   coordinates ("design" | "log" | "similarity": the surrogates' inputs;
                   "similarity" = logs of the matched similarity parameters, completed
                   by their null space), polish (final local-search evaluations of the
                   design-point score max(J) from the best design; "minmax" only),
                   polish_method ("nelder-mead" | "gauss-newton"), timeout,
                   design_point ("minmax" | "weighted" | "knee": how the design point
                   is chosen, see engine.design_point.design_point_index; default "minmax")
    [sweep]        one optimization per sweep point into sub-directories of one run
                   directory (``hypate run``; Sec. 9.1.3, 9.2.2, 9.2.4):
                   xi = [2, 3, 4]            geometric scales (sub-directories ``xi_2`` ...)
                   mach = [...], altitude = [...] (m)   flight conditions: the grid
                   conditions = [[M, H], ...]          or an explicit list (``M6_H25km``)
                   (xi and conditions may be combined: xi outer, conditions inner; grid
                   points are visited in serpentine order, so consecutive points are
                   neighbours)
                   recycle = 10          best designs of the previous point re-evaluated
                                         as part of the next point's initial sample
                                         (Sec. 9.2.4; for a new xi they are first mapped
                                         by the refined law, see scaling.laws)
                   predict = true        for a new xi, also seed with the refined law's
                                         prediction (needs 2 finished scales)
                   initial_samples, iterations   budget of every point after the first
                                         (default: [optimizer]'s; Table 9.11 uses 0 / 20)
    [[fidelity]]   cheaper levels of the study's own simulation, cheapest first: name, mesh,
                   time_step_factor, initial_samples; the last one only names the study's
                   own [simulation] (multi-fidelity BO, scaling.workflow.vocabulary.fidelity)
    [uncertainty], [robust]   scatter of the model and tunnel (vocabulary.uncertainty)
    [laws]         refined scaling laws of a sweep (``hypate laws``, scaling.laws):
                   analytical.NAME = k        analytical exponent override (xi^k)
                   exponent_bounds.NAME = [lo, hi]    constrain the fitted exponent (cvxpy)
                   monotone.NAME = "increasing" | "decreasing"  (k >= 0 | k <= 0, cvxpy)

Every error is an :class:`~solvers.errors.InputError` naming its key; nothing runs on a bad
file.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Annotated, Any, Literal

from hypate.scaling.engine.acquisition import (
    ACQUISITIONS,
    MULTI_OBJECTIVE_ACQUISITIONS,
    SINGLE_OBJECTIVE_ACQUISITIONS,
)
from hypate.scaling.workflow.vocabulary import uncertainty as scatter
from hypate.scaling.workflow.vocabulary.admissibility import AdmissibilitySection
from hypate.scaling.workflow.vocabulary.design_space import (
    VariableEntry,
)
from hypate.scaling.workflow.vocabulary.fidelity import (
    FidelitySection,
    check_fidelity,
)
from hypate.scaling.workflow.vocabulary.spec import EQUALITY_CONSTRAINTS
from hypate.scaling.workflow.vocabulary.variables import CATEGORICAL, OPTIMIZABLE
from hypate.solvers.config import (
    MAX_MESH,
    InputModel,
    MaterialConfig,
    Pair,
    SimulationKeys,
)
from hypate.solvers.settings import DEFAULTS, MAX_STEPS
from pydantic import Field, field_validator, model_validator

PosFloat = Annotated[float, Field(gt=0.0)]
#: Largest seed: the store keeps it as a signed 64-bit SQLite integer (``[0, 2**63)``).
MAX_SEED = 2**63 - 1


class StudySection(InputModel):
    #: A plain file name: the default run directory is ``runs/NAME``.
    name: str = "study"
    description: str = ""
    #: measured wall time of a whole run (free text, e.g. "4.5 min on 2 cores"), for
    #: ``hypate studies``; empty: not measured
    duration: str = ""
    kind: Literal["quasi_steady", "aeroelastic"] = "quasi_steady"
    objectives: Annotated[list[Literal["J_u", "J_T", "J_s"]], Field(min_length=1, max_length=2)
                          ] = ["J_u", "J_T"]
    xi: Annotated[float, Field(ge=1.0, le=100.0)] = 1.0
    time_scaling: Literal["fourier", "fourier_thickness", "structural"] = "fourier"
    projection: Literal["center", "modal", "fields"] = "center"

    @model_validator(mode="after")
    def _plain_name(self) -> StudySection:
        # runs/NAME must stay in runs/: no separators, no . or .., nothing hidden or empty
        name = self.name
        if (not name or name in (".", "..") or name.startswith(".") or "\0" in name
                or any(sep in name for sep in ("/", "\\"))):
            raise ValueError(f"name: {name!r} must be a plain file name (the run directory "
                             "runs/NAME): no /, \\, leading . or ..")
        return self


class PrototypeSection(InputModel):
    case: str
    delta_T: Annotated[float, Field(gt=0.0, le=2000.0)] | None = None
    temperature_independent: bool = False
    mach: Annotated[float, Field(gt=1.0, le=30.0)] | None = None
    altitude: Annotated[float, Field(ge=0.0, le=86000.0)] | None = None


Scale = Annotated[float, Field(ge=1.0, le=100.0)]
Mach = Annotated[float, Field(gt=1.0, le=30.0)]
Altitude = Annotated[float, Field(ge=0.0, le=86000.0)]


class SweepSection(InputModel):
    xi: Annotated[list[Scale], Field(min_length=1)] | None = None
    mach: Annotated[list[Mach], Field(min_length=1)] | None = None
    altitude: Annotated[list[Altitude], Field(min_length=1)] | None = None
    conditions: Annotated[list[Pair], Field(min_length=1)] | None = None
    recycle: Annotated[int, Field(ge=0, le=1000)] = 10
    predict: bool = True
    initial_samples: Annotated[int, Field(ge=0, le=10000)] | None = None
    iterations: Annotated[int, Field(ge=0, le=100000)] | None = None

    @model_validator(mode="after")
    def _check(self) -> SweepSection:
        if self.conditions is not None and (self.mach is not None or self.altitude is not None):
            raise ValueError("conditions: give either conditions or mach/altitude, not both")
        if self.xi is None and self.mach is None and self.altitude is None \
                and self.conditions is None:
            raise ValueError("xi: a sweep needs xi, mach/altitude or conditions")
        for i, (m, h) in enumerate(self.conditions or []):
            if not (1.0 < m <= 30.0 and 0.0 <= h <= 86000.0):
                raise ValueError(f"conditions[{i}]: need [M, H] with 1 < M <= 30 and "
                                 f"0 <= H <= 86000 m; got [{m:g}, {h:g}]")
        for name in ("xi", "mach", "altitude"):
            values = getattr(self, name)
            if values is not None and len(set(values)) != len(values):
                raise ValueError(f"{name}: repeated value")
        return self

    def grid(self) -> list[tuple[float | None, float | None, float | None]]:
        """``(xi, mach, altitude)`` of every point in the order they are run (None: the
        study's own). Scales in the listed order, each over the flight conditions; a
        ``mach`` x ``altitude`` grid in serpentine order (Mach outer, the altitude direction
        alternating), so that consecutive points are neighbours and recycled samples
        (Sec. 9.2.4) come from the closest condition already solved."""
        conditions: list[tuple[float | None, float | None]]
        if self.conditions is not None:
            conditions = [(float(m), float(h)) for m, h in self.conditions]
        elif self.mach is not None or self.altitude is not None:
            machs: Sequence[float | None] = self.mach or [None]
            alts: Sequence[float | None] = self.altitude or [None]
            conditions = []
            for i, m in enumerate(machs):
                row = alts if i % 2 == 0 else list(reversed(alts))
                conditions.extend((m, h) for h in row)
        else:
            conditions = [(None, None)]
        scales: list[float | None] = list(self.xi) if self.xi is not None else [None]
        return [(xi, m, h) for xi in scales for m, h in conditions]


class LawsSection(InputModel):
    analytical: dict[str, float] = {}
    exponent_bounds: dict[str, Pair] = {}
    monotone: dict[str, Literal["increasing", "decreasing"]] = {}

    @model_validator(mode="after")
    def _check(self) -> LawsSection:
        for name, (lo, hi) in self.exponent_bounds.items():
            if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
                raise ValueError(f"exponent_bounds.{name}: need finite [lower, upper] with "
                                 f"lower <= upper")
        return self


class SimulationSection(SimulationKeys):
    """``[simulation]`` of a study: the keys it shares with a case file
    (:class:`~hypate.solvers.config.SimulationKeys`: one key set, one set of limits, the
    defaults of :class:`SimulationSettings`), plus ``steps`` (of the prototype time step), a
    ``mesh`` override (a case file's limits) and the user's own ``simulator``."""

    steps: Annotated[int, Field(ge=1, le=MAX_STEPS)] = DEFAULTS.n_steps
    mesh: Annotated[list[Annotated[int, Field(ge=1, le=MAX_MESH)]],
                    Field(min_length=2, max_length=2)] | None = None
    #: The user's own simulator, ``"package.module:function"`` or ``"file.py:function"``
    #: (scaling.workflow.vocabulary.external); None: hypate's.
    simulator: str | None = None

    @model_validator(mode="after")
    def _finite_duration(self) -> SimulationSection:
        if not math.isfinite(self.time_step * self.steps):  # 1e308 s passes gt=0
            raise ValueError(f"time_step: {self.steps} steps of {self.time_step:g} s last "
                             "longer than a float holds; a time step must be finite, in s")
        return self


class ModelSection(InputModel):
    material: str = "ti6242"
    thickness: Annotated[float, Field(gt=0.0, le=0.1)] | None = None
    sublayers: Annotated[int, Field(ge=1, le=50)] = 1
    boundary: Literal["simply_supported", "clamped"] | None = None
    emissivity: Annotated[float, Field(ge=0.0, le=1.0)] | None = None
    initial_temperature: Annotated[float, Field(gt=0.0, le=5000.0)] = 300.0
    temperature_independent: bool = False


class ConstraintsSection(InputModel):
    equality: list[str] = []

    @model_validator(mode="after")
    def _known(self) -> ConstraintsSection:
        for name in self.equality:
            if name not in EQUALITY_CONSTRAINTS:
                raise ValueError(f"equality: unknown constraint {name!r}; available: "
                                 f"{', '.join(EQUALITY_CONSTRAINTS)}")
        return self


class OptimizerSection(InputModel):
    approach: Literal["indirect", "direct"] = "indirect"
    #: a name of the engine's registry (:data:`hypate.scaling.engine.acquisition.ACQUISITIONS`)
    acquisition: str | None = None
    v: Annotated[float, Field(ge=0.0, le=100.0)] | None = None
    #: The exploration weight of the last iteration (v falls linearly to it; None: constant v).
    v_final: Annotated[float, Field(ge=0.0, le=100.0)] | None = None
    weights: list[Annotated[float, Field(ge=0.0)]] | None = None
    initial_samples: Annotated[int, Field(ge=1, le=10000)] = 20
    #: BO iterations, or "auto": stop when converged (scaling.engine.stopping), at most
    #: ``max_iterations``, never before ``min_iterations``
    iterations: Annotated[int, Field(ge=0, le=100000)] | Literal["auto"] = 50
    max_iterations: Annotated[int, Field(ge=1, le=100000)] = 40
    min_iterations: Annotated[int, Field(ge=1, le=100000)] = 8
    batch_size: Annotated[int, Field(ge=1, le=64)] = 1
    #: At most 2**63 - 1: the store keeps it as a signed 64-bit SQLite integer.
    seed: Annotated[int, Field(ge=0, le=MAX_SEED)] = 0
    classical_seed: bool = True
    transform: Literal["none", "log"] = "none"
    coordinates: Literal["design", "log", "similarity"] = "design"
    polish: Annotated[int, Field(ge=0, le=10000)] = 0
    #: The polish's local search (scaling.engine.polish): a simplex on max(J), or
    #: Gauss-Newton on the histories J is composed from (not the "fields" projection)
    polish_method: Literal["nelder-mead", "gauss-newton"] = "nelder-mead"
    timeout: PosFloat | None = None
    #: How the design point is chosen from the feasible evaluations (rundir.DESIGN_POINT_RULES;
    #: "weighted" uses ``weights``).
    design_point: Literal["minmax", "weighted", "knee"] = "minmax"
    #: What the objective surrogates model: the objectives, or the nondimensional
    #: histories J is composed from (scaling.engine.histories).
    surrogate: Literal["objectives", "histories"] = "objectives"
    #: Probability a proposal must have of holding every enforced admissibility check
    #: (simulated ones: their surrogates) and of its simulation succeeding (the failure
    #: classifier); engine defaults when unset.
    p_feasible: Annotated[float, Field(gt=0.0, lt=1.0)] | None = None
    p_success: Annotated[float, Field(gt=0.0, lt=1.0)] | None = None
    #: The last iterations proposing the surrogates' best design point, every enforced
    #: check and the simulation's success at probability ``p_exploit`` (engine default 0.95)
    exploit_last: Annotated[int, Field(ge=0, le=1000)] = 0
    p_exploit: Annotated[float, Field(gt=0.0, lt=1.0)] | None = None

    @field_validator("acquisition")
    @classmethod
    def _registered(cls, name: str | None) -> str | None:
        if name is not None and name not in ACQUISITIONS:
            raise ValueError(f"must be one of {', '.join(ACQUISITIONS)}")
        return name


class StudyFile(InputModel):
    study: StudySection = StudySection()
    prototype: PrototypeSection
    simulation: SimulationSection = SimulationSection()
    model: ModelSection = ModelSection()
    tunnel: dict[str, Any] | None = None
    variables: dict[str, VariableEntry]
    fixed: dict[str, float] = {}
    constraints: ConstraintsSection = ConstraintsSection()
    admissibility: AdmissibilitySection = AdmissibilitySection()
    optimizer: OptimizerSection = OptimizerSection()
    sweep: SweepSection | None = None
    laws: LawsSection = LawsSection()
    materials: dict[str, MaterialConfig] = {}
    uncertainty: dict[str, scatter.UncertainEntry] = {}
    robust: scatter.RobustSection | None = None
    fidelity: list[FidelitySection] = []


    @model_validator(mode="after")
    def _check(self) -> StudyFile:
        if not self.variables:
            raise ValueError("variables: at least one design variable is needed")
        for name in list(self.variables) + list(self.fixed):
            if name not in OPTIMIZABLE:
                raise ValueError(f"{'variables' if name in self.variables else 'fixed'}.{name}:"
                                 f" unknown design variable; known: {', '.join(OPTIMIZABLE)}")
        n_obj = len(self.study.objectives)
        acq = self.optimizer.acquisition
        if acq is not None:
            single = not ACQUISITIONS[acq].multi_objective
            if single != (n_obj == 1):
                raise ValueError(f"optimizer.acquisition: {acq!r} does not fit "
                                 f"{n_obj} objective(s) "
                                 f"({'/'.join(SINGLE_OBJECTIVE_ACQUISITIONS)} for one; "
                                 f"{'/'.join(MULTI_OBJECTIVE_ACQUISITIONS)} for two)")
        opt = self.optimizer
        if opt.iterations == "auto" and opt.min_iterations >= opt.max_iterations:
            raise ValueError(f"optimizer.min_iterations: must be below max_iterations "
                             f"({opt.max_iterations}); got {opt.min_iterations}")
        if opt.surrogate == "histories" and self.fidelity:
            raise ValueError("optimizer.surrogate: \"histories\" is not available for a "
                             "multi-fidelity study (its levels' histories differ in length; "
                             "the co-kriging models the objectives): use \"objectives\"")
        if opt.iterations == "auto" and (self.robust is not None or self.fidelity):
            raise ValueError("optimizer.iterations: \"auto\" stops a single-fidelity search "
                             "(not a [robust] or [[fidelity]] one); give a number")
        if (opt.polish and opt.polish_method == "gauss-newton"
                and self.study.projection == "fields"):
            raise ValueError("optimizer.polish_method: \"gauss-newton\" linearizes the "
                             "histories J is composed from; the \"fields\" projection has "
                             "none (projection \"center\" or \"modal\", or \"nelder-mead\")")
        if self.optimizer.polish and n_obj != 1 and self.optimizer.design_point != "minmax":
            raise ValueError(f"optimizer.polish: the polish minimizes max(J) (the \"minmax\" "
                             f"design point); with {n_obj} objectives and design_point = "
                             f"{self.optimizer.design_point!r} set polish = 0")
        if self.optimizer.weights is not None and len(self.optimizer.weights) != n_obj:
            raise ValueError(f"optimizer.weights: need {n_obj} values")
        if self.robust is not None and not self.uncertainty:
            raise ValueError("robust: needs an [uncertainty] table")  # nothing to be robust to
        for name in CATEGORICAL:
            if name in self.fixed:
                raise ValueError(f"fixed.{name}: a categorical variable is not a number; "
                                 f"set [model] {name} = \"NAME\" instead")
            if name not in self.variables:
                continue
            if name in self.model.model_fields_set:
                raise ValueError(f"model.{name}: the {name} is a design variable "
                                 f"(variables.{name}); give one or the other")
            if self.robust is not None:  # the robust search's joint space is continuous
                raise ValueError(f"robust: a categorical variables.{name} cannot be searched "
                                 "robustly; run one robust study per value")
            if self.optimizer.polish:
                raise ValueError(f"optimizer.polish: a local polish cannot step "
                                 f"between the values of variables.{name}; set it to 0")
        self.admissibility.rules()  # "auto" only for stress
        opt = self.optimizer
        check_fidelity(self.fidelity, steps=self.simulation.steps,
                       categorical=any(n in self.variables for n in CATEGORICAL),
                       robust=self.robust is not None, sweep=self.sweep is not None,
                       polish=opt.polish, coordinates=opt.coordinates)
        return self


__all__ = ["MAX_SEED", "ConstraintsSection", "LawsSection", "ModelSection", "OptimizerSection",
           "PosFloat", "PrototypeSection", "SimulationSection", "StudyFile", "StudySection",
           "SweepSection"]
