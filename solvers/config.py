"""Panel and case configuration files (TOML), validated with pydantic.

Public schema (keys are a contract; see README "Case files"):

* ``[panel]`` geometry, boundary conditions, mesh, initial temperature, emissivity, damping,
  and ``[[panel.layers]]`` listed bottom to top;
* ``[materials.NAME]`` user materials: isotropic (``density``, ``youngs_modulus``,
  ``poisson_ratio``, ``thermal_expansion``, ``conductivity``, ``specific_heat``),
  orthotropic (``density``, ``E1``, ``E2``, ``G12``, ``G13``, ``G23``, ``nu12``, ``alpha1``,
  ``alpha2``, ``k1``, ``k2``, ``k3``, ``specific_heat``), each a constant or a table
  ``[[T, value], ...]``; or derived: ``kind = "honeycomb"`` (``base``,
  ``relative_density``, ``cell_size``, ``core_thickness``, ``wall_emissivity``) and
  ``kind = "stiffener"`` (``base``, ``t1``, ``l1``, ``t2``, ``l2``, Eq. 8.10);
* ``[flow]`` ``mach`` and exactly one of ``altitude`` | (``p0``, ``T0``) |
  (``pressure``, ``temperature``);
* ``[simulation]`` ``scheme``, ``aero``, ``heating``, ``boundary_layer``, ``time_step``,
  ``duration``; optional ``external_heat_flux`` (uniform q_ext absorbed by the upper
  surface, W/m^2, within +-1e7; Eq. 6.1d).

Every error becomes :class:`~solvers.errors.InputError` naming the key path
(``panel.layers[0].thickness``) and the allowed range.
"""
from __future__ import annotations

import dataclasses
import difflib
import math
import tomllib
import types
import typing
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal, cast

from hypate.solvers import materials as mat
from hypate.solvers.aero.factory import AERO_NAMES, is_aero_name
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition
from hypate.solvers.panel import Layer, PanelSpec
from hypate.solvers.settings import (
    DEFAULTS,
    MAX_CONTINUATION_STEPS,
    MAX_STEPS,
    SimulationSettings,
)
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator
from pydantic.fields import FieldInfo


class InputModel(BaseModel):
    """Base of every input-file schema (case, study and ROM build files).

    Unknown keys are errors, and values are taken as written: no string-to-number,
    number-to-string or bool-to-number coercion (``"16"`` is not 16, ``true`` is not 1, ``2.0``
    is not an integer), and a float must be finite (no ``inf``/``nan``). An integer is still
    accepted where a float is meant (``length = 1``). Pairs are lists of two, not tuples:
    strict validation takes a tuple only as a tuple, and TOML has none.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True, allow_inf_nan=False)


#: ``[lower, upper]``, ``[T, value]`` ...: a list of two finite numbers.
Pair = Annotated[list[float], Field(min_length=2, max_length=2)]
#: A material property: a constant or a table ``[[T, value], ...]``.
PropertySpec = float | list[Pair]
Positive = Annotated[float, Field(gt=0.0)]
#: Most elements along one side of a panel mesh (a case's ``[panel] mesh``, a study's
#: ``[simulation] mesh`` override).
MAX_MESH = 200


class LayerConfig(InputModel):
    material: str
    thickness: Annotated[float, Field(gt=0.0, le=1.0)]
    angle: Annotated[float, Field(ge=-180.0, le=180.0)] = 0.0
    sublayers: Annotated[int, Field(ge=1, le=50)] = 1


class PanelConfig(InputModel):
    kind: Literal["3d", "2d"] = "3d"
    length: Annotated[float, Field(gt=0.0, le=100.0)] = 1.0
    width: Annotated[float, Field(gt=0.0, le=100.0)] = 1.0
    boundary: Literal["simply_supported", "clamped"] = "simply_supported"
    leading_edge_length: Annotated[float, Field(ge=0.0, le=100.0)] = 1.0
    flow_angle: Annotated[float, Field(ge=-90.0, le=90.0)] = 0.0
    mesh: Annotated[list[Annotated[int, Field(ge=1, le=MAX_MESH)]],
                    Field(min_length=1, max_length=2)] = [8, 8]
    initial_temperature: Annotated[float, Field(gt=0.0, le=5000.0)] = 300.0
    emissivity: Annotated[float, Field(ge=0.0, le=1.0)] = 0.85
    damping: Annotated[list[Annotated[float, Field(ge=0.0)]],
                       Field(min_length=2, max_length=2)] = [0.0, 0.0]
    radius_x: Annotated[float, Field(gt=0.0)] = math.inf
    radius_y: Annotated[float, Field(gt=0.0)] = math.inf
    layers: Annotated[list[LayerConfig], Field(min_length=1, max_length=100)]

    @model_validator(mode="after")
    def _mesh_matches_kind(self) -> PanelConfig:
        if self.kind == "3d" and len(self.mesh) != 2:
            raise ValueError("mesh: a 3d panel needs [nx, ny] elements")
        if self.kind == "2d" and len(self.mesh) == 2 and self.mesh[1] != 1:
            raise ValueError("mesh: a 2d strip has one element across; use [nx] or [nx, 1]")
        return self


class MaterialConfig(InputModel):
    kind: Literal["isotropic", "orthotropic", "honeycomb", "stiffener"] | None = None
    reference_temperature: Annotated[float, Field(gt=0.0)] = 300.0
    # isotropic
    density: PropertySpec | None = None
    youngs_modulus: PropertySpec | None = None
    poisson_ratio: PropertySpec | None = None
    thermal_expansion: PropertySpec | None = None
    conductivity: PropertySpec | None = None
    specific_heat: PropertySpec | None = None
    # orthotropic
    E1: PropertySpec | None = None
    E2: PropertySpec | None = None
    G12: PropertySpec | None = None
    G13: PropertySpec | None = None
    G23: PropertySpec | None = None
    nu12: PropertySpec | None = None
    alpha1: PropertySpec | None = None
    alpha2: PropertySpec | None = None
    k1: PropertySpec | None = None
    k2: PropertySpec | None = None
    k3: PropertySpec | None = None
    # derived
    base: str | None = None
    relative_density: float | None = None
    cell_size: float | None = None
    core_thickness: float | None = None
    wall_emissivity: float = 0.8
    t1: float | None = None
    l1: float | None = None
    t2: float | None = None
    l2: float | None = None
    # limits (solvers.materials.MaterialLimits; a core or stiffener takes its base's)
    service_temperature: Annotated[float, Field(gt=0.0, le=5000.0)] | None = None
    yield_strength: PropertySpec | None = None
    trusted_range: Pair | None = None
    sources: str = ""


class FlowConfig(InputModel):
    mach: float
    altitude: float | None = None
    p0: float | None = None
    T0: float | None = None
    pressure: float | None = None
    temperature: float | None = None

    @model_validator(mode="after")
    def _exactly_one_state(self) -> FlowConfig:
        given = {"altitude": self.altitude is not None,
                 "p0/T0": self.p0 is not None or self.T0 is not None,
                 "pressure/temperature": self.pressure is not None or self.temperature is not None}
        if sum(given.values()) != 1:
            named = [k for k, v in given.items() if v] or ["none"]
            raise ValueError("give exactly one of altitude | (p0, T0) | (pressure, temperature);"
                             f" got {', '.join(named)}")
        if given["p0/T0"] and (self.p0 is None or self.T0 is None):
            raise ValueError("p0 and T0 must be given together")
        if given["pressure/temperature"] and (self.pressure is None or self.temperature is None):
            raise ValueError("pressure and temperature must be given together")
        return self


class SimulationKeys(InputModel):
    """The ``[simulation]`` keys a case file and a study share: one key set, one set of
    limits, the defaults of :class:`SimulationSettings` (:data:`DEFAULTS`). A case file adds
    its scheme, duration and external loads (:class:`SimulationConfig`); a study its step
    count, mesh and simulator (``scaling.workflow.vocabulary.study_file.SimulationSection``)."""

    aero: str = DEFAULTS.aero
    heating: Literal["eckert", "none"] = DEFAULTS.heating
    boundary_layer: Literal["turbulent", "laminar"] = DEFAULTS.boundary_layer
    time_step: Positive = DEFAULTS.time_step
    initial_deflection: Annotated[float, Field(ge=-10.0, le=10.0)] = DEFAULTS.initial_deflection
    lsa_modes: Annotated[int, Field(ge=1, le=50)] = DEFAULTS.lsa_modes
    unstable_steps: Annotated[int, Field(ge=1, le=1000)] = DEFAULTS.unstable_steps
    continuation_steps: Annotated[int, Field(ge=0, le=MAX_CONTINUATION_STEPS)] = \
        DEFAULTS.continuation_steps
    rho_bar: Annotated[float, Field(ge=0.0, le=1.0)] = DEFAULTS.rho_bar


class SimulationConfig(SimulationKeys):
    """``[simulation]`` of a case file: the shared keys (:class:`SimulationKeys`) and the
    rest of :class:`SimulationSettings`' keys, with its defaults (one set,
    :data:`hypate.solvers.settings.DEFAULTS`)."""

    scheme: Literal["s1", "s2", "tc"] = DEFAULTS.scheme
    duration: Positive = DEFAULTS.duration
    radiation_temperature: Annotated[float, Field(gt=0.0, le=5000.0)] | None = \
        DEFAULTS.radiation_temperature
    external_pressure: Annotated[float, Field(ge=-1e7, le=1e7)] = DEFAULTS.external_pressure
    external_heat_flux: Annotated[float, Field(ge=-1e7, le=1e7)] = \
        DEFAULTS.external_heat_flux
    passes: Annotated[int, Field(ge=1, le=20)] = DEFAULTS.passes
    fluid_density: Annotated[int, Field(ge=1, le=8)] = DEFAULTS.fluid_density

    @model_validator(mode="after")
    def _check(self) -> SimulationConfig:
        if not is_aero_name(self.aero):
            raise ValueError(f"aero: must be one of {', '.join(AERO_NAMES)} or 'rom:PATH'; "
                             f"got {self.aero!r}")
        if self.duration < self.time_step:
            raise ValueError("duration: must be at least one time_step")
        if self.duration / self.time_step > MAX_STEPS + 0.5:  # inf too: never an int
            raise ValueError(f"duration: duration / time_step = "
                             f"{self.duration / self.time_step:.6g} steps; at most {MAX_STEPS}")
        return self


def settings_from_config(sim: SimulationConfig) -> SimulationSettings:
    """The :class:`SimulationSettings` of a validated case-file ``[simulation]`` table."""
    return SimulationSettings(**sim.model_dump())


class CaseConfig(InputModel):
    panel: PanelConfig
    materials: dict[str, MaterialConfig] = {}
    flow: FlowConfig | None = None
    simulation: SimulationConfig | None = None


# -- conversion to physics objects ----------------------------------------------------------
@dataclass(frozen=True)
class Case:
    """A validated case: panel, optional flow condition and simulation settings."""

    panel: PanelSpec
    flow: FlowCondition | None
    simulation: SimulationConfig | None
    source: str = "<memory>"


def _loc(loc: tuple[Any, ...]) -> str:
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += ("." if out else "") + str(part)
    return out


#: Tags pydantic puts into an error location to say which member of a union failed (they
#: are not keys of the file): ``float``, ``list[list[float]]``, ``str`` ...
_UNION_TAGS = ("float", "int", "str", "list[float]", "list[list[float]]")


def _is_tag(part: Any) -> bool:
    return isinstance(part, str) and (part.startswith("function-") or part in _UNION_TAGS)


def _unwrap(annotation: Any) -> tuple[Any, list[Any]]:
    """``annotation`` without ``Annotated[...]`` and ``| None``, and the constraints
    (``annotated_types.Gt`` ...) the stripped ``Annotated`` carried."""
    metadata: list[Any] = []
    while True:
        if typing.get_origin(annotation) is Annotated:
            annotation, *extra = typing.get_args(annotation)
            for item in extra:
                metadata.extend(item.metadata if isinstance(item, FieldInfo) else [item])
        elif typing.get_origin(annotation) in (typing.Union, types.UnionType) and len(
                members := [a for a in typing.get_args(annotation) if a is not type(None)]) == 1:
            annotation = members[0]
        else:
            return annotation, metadata


def _schema_at(model: type[BaseModel] | None, loc: tuple[Any, ...]) -> tuple[Any, list[Any]]:
    """The annotation at ``loc`` (key path, union tags removed) of ``model``'s schema and
    its constraints; ``(None, [])`` where the schema does not tell (unknown key, a union of
    several types)."""
    annotation: Any = model
    metadata: list[Any] = []
    for part in loc:
        if isinstance(annotation, type) and issubclass(annotation, BaseModel):
            field = annotation.model_fields.get(part) if isinstance(part, str) else None
            if field is None:
                return None, []
            annotation, metadata = _unwrap(field.annotation)
            metadata = list(field.metadata) + metadata
            continue
        origin, args = typing.get_origin(annotation), typing.get_args(annotation)
        if origin is list and isinstance(part, int):
            annotation, metadata = _unwrap(args[0])
        elif origin is dict and isinstance(part, str):
            annotation, metadata = _unwrap(args[1])
        else:
            return None, []
    return annotation, metadata


def allowed_keys(model: type[BaseModel] | None, loc: tuple[Any, ...]) -> list[str]:
    """The keys the schema allows where ``loc`` (a pydantic error location) points: the
    fields of the model that holds ``loc[-1]`` (empty when unknown)."""
    holder, _ = _schema_at(model, tuple(p for p in loc[:-1] if not _is_tag(p)))
    if isinstance(holder, type) and issubclass(holder, BaseModel):
        return list(holder.model_fields)
    return []


#: What a scalar annotation asks for, in words.
_EXPECTED = {int: "an integer", float: "a finite number", bool: "true or false",
             str: "a string"}
#: pydantic error types of a scalar of the wrong type or out of its range.
_SCALAR_ERRORS = ("int_type", "int_from_float", "int_parsing", "float_type", "float_parsing",
                  "finite_number", "bool_type", "bool_parsing", "string_type", "greater_than",
                  "greater_than_equal", "less_than", "less_than_equal")


def _allowed_range(metadata: list[Any]) -> str:
    """``"in (0, 1]"``, ``">= 1"`` ... from ``annotated_types`` constraints (``""``: none)."""
    bound = {type(m).__name__: getattr(m, type(m).__name__.lower()) for m in metadata
             if type(m).__name__ in ("Gt", "Ge", "Lt", "Le")}  # annotated_types bounds
    low = ("(", bound["Gt"]) if "Gt" in bound else ("[", bound["Ge"]) if "Ge" in bound else None
    high = (")", bound["Lt"]) if "Lt" in bound else ("]", bound["Le"]) if "Le" in bound else None
    def text(v: float) -> str:  # an integer bound exactly (a seed's 2**63 - 1)
        return str(v) if isinstance(v, int) else f"{v:g}"

    if low and high:
        return f"in {low[0]}{text(low[1])}, {text(high[1])}{high[0]}"
    if low:
        return f"{'>' if low[0] == '(' else '>='} {text(low[1])}"
    if high:
        return f"{'<' if high[0] == ')' else '<='} {text(high[1])}"
    return ""


def _got(value: Any) -> str:
    kind = {str: " (a string)", bool: " (a boolean)"}.get(type(value), "")
    return f"got {value!r}{kind}"


def did_you_mean(name: str | int, choices: list[str]) -> str:
    """``"; did you mean 'x'?"`` for the closest of ``choices`` to ``name``, or ``""``."""
    close = difflib.get_close_matches(str(name), choices, n=1, cutoff=0.6)
    return f"; did you mean {close[0]!r}?" if close else ""


def pydantic_input_error(exc: ValidationError, prefix: str = "",
                         model: type[BaseModel] | None = None) -> InputError:
    """The most telling pydantic error as an :class:`InputError` naming the key path.

    With the schema ``model``, a scalar of the wrong type or range is reported as what the
    key takes (``must be an integer in [1, 10000]; got '16' (a string)``) and an unknown key
    gets the closest allowed key suggested. Of the errors of a union (one per member) the
    one deepest into the value is taken: it is the member the value was meant to be.
    """
    errors = exc.errors()
    # a misspelt key also makes the meant one "missing": report the unknown key
    err = max(errors, key=lambda e: (e["type"] == "extra_forbidden", len(e["loc"])))
    loc = tuple(p for p in err["loc"] if not _is_tag(p))
    path = ".".join(p for p in (prefix, _loc(loc)) if p)
    msg = err["msg"].removeprefix("Value error, ")
    annotation, metadata = _schema_at(model, loc)
    if err["type"] == "extra_forbidden":
        msg = "unknown key (not part of the schema)" + did_you_mean(
            err["loc"][-1], allowed_keys(model, tuple(err["loc"])))
    elif err["type"] == "missing":
        msg = "required key is missing"
    elif err["type"] in _SCALAR_ERRORS and annotation in _EXPECTED:
        msg = " ".join(filter(None, ("must be", _EXPECTED[annotation],
                                     _allowed_range(metadata)))) + f"; {_got(err['input'])}"
    elif "input" in err and not isinstance(err["input"], dict | list):
        msg += f" ({_got(err['input'])})"
    # model-level validators name their key at the start of the message ("mesh: ...")
    if ": " in msg and msg.split(": ", 1)[0].replace(".", "_").isidentifier() \
            and err["type"] == "value_error":
        key, msg = msg.split(": ", 1)
        path = ".".join(p for p in (path, key) if p)
    return InputError(path or "file", msg)


def _build_material(name: str, cfg: MaterialConfig, resolved: dict[str, mat.Material],
                    raw: dict[str, MaterialConfig], stack: tuple[str, ...] = ()) -> mat.Material:
    field = f"materials.{name}"
    given = cfg.model_dump(exclude_unset=True)
    kind = cfg.kind
    if kind is None:
        kind = "orthotropic" if "E1" in given else "isotropic"
    limits = mat.limits_from_table(name, {k: given[k] for k in mat.LIMIT_KEYS + ("sources",)
                                          if given.get(k) is not None})
    if kind == "isotropic":
        missing = [k for k in mat.ISOTROPIC_KEYS if given.get(k) is None]
        if missing:
            raise InputError(field, f"isotropic material needs {', '.join(missing)}")
        return dataclasses.replace(mat.isotropic(
            name, reference_temperature=cfg.reference_temperature,
            **{k: given[k] for k in mat.ISOTROPIC_KEYS}), limits=limits)
    if kind == "orthotropic":
        missing = [k for k in mat.ORTHOTROPIC_KEYS if given.get(k) is None]
        if missing:
            raise InputError(field, f"orthotropic material needs {', '.join(missing)}")
        return dataclasses.replace(mat.orthotropic(
            name, reference_temperature=cfg.reference_temperature,
            **{k: given[k] for k in mat.ORTHOTROPIC_KEYS}), limits=limits)
    for key in mat.LIMIT_KEYS:
        if given.get(key) is not None:
            raise InputError(f"{field}.{key}", f"a {kind} layer takes the limits of its base "
                             f"material ({cfg.base!r}); set them there")
    if cfg.base is None:
        raise InputError(f"{field}.base", f"a {kind} material needs a base material name")
    if cfg.base in stack:
        raise InputError(f"{field}.base", "circular material reference")
    base = resolve_material(cfg.base, resolved, raw, stack + (name,), f"{field}.base")
    if kind == "honeycomb":
        for key in ("relative_density", "cell_size", "core_thickness"):
            if given.get(key) is None:
                raise InputError(f"{field}.{key}", "required for a honeycomb core")
        # given (not None) by the check above
        assert cfg.relative_density is not None and cfg.cell_size is not None
        assert cfg.core_thickness is not None
        return mat.honeycomb_core(base, cfg.relative_density, cfg.cell_size,
                                  cfg.core_thickness, cfg.wall_emissivity, name=name)
    return mat.homogenized_stiffener(base, cfg.t1 or 0.0, cfg.l1 or 0.0, cfg.t2 or 0.0,
                                     cfg.l2 or 0.0, name=name)


def resolve_material(name: str, resolved: dict[str, mat.Material],
                     raw: dict[str, MaterialConfig], stack: tuple[str, ...] = (),
                     field: str = "material") -> mat.Material:
    """A material by name: the file's ``[materials.NAME]`` first, then the library."""
    if name in resolved:
        return resolved[name]
    if name in raw:
        try:
            m = _build_material(name, raw[name], resolved, raw, stack)
        except InputError as exc:
            if exc.field.startswith("materials."):
                raise
            raise InputError(f"materials.{exc.field}", exc.message) from None
    elif name in mat.LIBRARY:
        m = mat.library_material(name)
    else:
        known = sorted(set(mat.LIBRARY) | set(raw))
        raise InputError(field, f"unknown material {name!r}; known: {', '.join(known)}")
    resolved[name] = m
    return m


def build_panel(cfg: PanelConfig, materials: dict[str, MaterialConfig] | None = None,
                name: str = "panel") -> PanelSpec:
    """A :class:`PanelSpec` from a validated ``[panel]`` table."""
    raw = dict(materials or {})
    resolved: dict[str, mat.Material] = {}
    layers = []
    for i, lc in enumerate(cfg.layers):
        m = resolve_material(lc.material, resolved, raw, field=f"panel.layers[{i}].material")
        layers.append(Layer(m, lc.thickness, math.radians(lc.angle), lc.sublayers))
    panel = PanelSpec(layers=tuple(layers), kind=cfg.kind, length=cfg.length,
                      width=cfg.width, boundary=cfg.boundary,
                      leading_edge_length=cfg.leading_edge_length,
                      flow_angle=math.radians(cfg.flow_angle),
                      # a 2d strip's [nx]: PanelSpec completes it to (nx, 1)
                      mesh=cast("tuple[int, int]", tuple(cfg.mesh)),
                      initial_temperature=cfg.initial_temperature, emissivity=cfg.emissivity,
                      damping=(cfg.damping[0], cfg.damping[1]), radius_x=cfg.radius_x,
                      radius_y=cfg.radius_y, name=name)
    if panel.thickness >= 0.2 * min(panel.length, panel.width if cfg.kind == "3d"
                                    else panel.length):
        raise InputError("panel.layers", f"total thickness {panel.thickness:g} m is not thin "
                         "relative to the panel size (shell theory needs h < a/5)")
    return panel


def build_flow(cfg: FlowConfig) -> FlowCondition:
    """A :class:`FlowCondition` from a validated ``[flow]`` table (errors name ``flow.KEY``)."""
    try:
        if cfg.altitude is not None:
            return FlowCondition.from_altitude(cfg.mach, cfg.altitude)
        # FlowConfig's validator: exactly one state, each given in full
        if cfg.p0 is not None:
            assert cfg.T0 is not None
            return FlowCondition.from_stagnation(cfg.mach, cfg.p0, cfg.T0)
        assert cfg.pressure is not None and cfg.temperature is not None
        return FlowCondition.from_static(cfg.mach, cfg.pressure, cfg.temperature)
    except InputError as exc:
        raise InputError(f"flow.{exc.field}", exc.message) from None


#: Deepest nesting of tables and arrays accepted in a TOML file (a study needs 4).
MAX_TOML_DEPTH = 32


def toml_depth(value: Any) -> int:
    """Nesting depth of parsed TOML data: 0 for a scalar, 1 for a table or array of
    scalars, ... (iterative: any depth is measured without recursion)."""
    deepest, stack = 0, [(value, 0)]
    while stack:
        item, depth = stack.pop()
        children = (item.values() if isinstance(item, dict) else
                    item if isinstance(item, list) else None)
        if children is None:
            deepest = max(deepest, depth)
            continue
        deepest = max(deepest, depth + 1)
        stack.extend((child, depth + 1) for child in children)
    return deepest


def read_toml(path: str | Path) -> dict[str, Any]:
    """Parse a TOML file; syntax errors, missing or unreadable files, directories and
    nesting deeper than :data:`MAX_TOML_DEPTH` become :class:`InputError`."""
    path = Path(path)
    if path.is_dir():
        raise InputError(str(path), "is a directory, not a TOML file")
    if not path.is_file():
        raise InputError(str(path), "file not found")
    too_deep = f"tables and arrays nested more than {MAX_TOML_DEPTH} levels deep"
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except RecursionError:  # the parser recurses once per level
        raise InputError(str(path), too_deep) from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(str(path), f"TOML syntax error: {exc}") from None
    except UnicodeDecodeError:
        raise InputError(str(path), "not a UTF-8 text file") from None
    except OSError as exc:  # no permission, a device ...
        raise InputError(str(path), f"cannot be read ({exc.strerror or exc})") from None
    if toml_depth(data) > MAX_TOML_DEPTH:
        raise InputError(str(path), too_deep)
    return data


def parse_case(data: dict[str, Any], source: str = "<memory>") -> Case:
    """Validate a parsed case dictionary and build the physics objects."""
    try:
        cfg = CaseConfig.model_validate(data)
    except ValidationError as exc:
        raise pydantic_input_error(exc, model=CaseConfig) from None
    panel = build_panel(cfg.panel, cfg.materials, name=Path(source).stem)
    flow = build_flow(cfg.flow) if cfg.flow is not None else None
    return Case(panel=panel, flow=flow, simulation=cfg.simulation, source=source)


def load_case(path: str | Path) -> Case:
    """Read and validate a case file (``[panel]`` + optional ``[flow]``, ``[simulation]``)."""
    return parse_case(read_toml(path), source=str(path))


def load_panel(path: str | Path) -> PanelSpec:
    """Read and validate a panel file; ``[flow]``/``[simulation]`` may be present."""
    return load_case(path).panel


def summary(case: Case) -> list[str]:
    """Short human-readable summary lines (``hypate validate``)."""
    p = case.panel
    size = (f"{p.length:g} m x {p.width:g} m" if p.kind == "3d"
            else f"{p.length:g} m strip (2d, cylindrical bending)")
    lines = [f"panel: {p.kind}, {size}, {p.boundary.replace('_', ' ')}, "
             f"mesh {p.mesh[0]} x {p.mesh[1]}, L_le = {p.leading_edge_length:g} m",
             f"layers (bottom to top): {len(p.layers)}"]
    for i, layer in enumerate(p.layers):
        lines.append(f"  [{i}] {layer.material.name}: {layer.thickness * 1e3:g} mm, "
                     f"angle {math.degrees(layer.angle):g} deg, "
                     f"{layer.sublayers} thermal sub-layer(s)")
    lines.append(f"total thickness: {p.thickness * 1e3:g} mm")
    lines.append(f"mass per area: {p.mass_per_area():.4g} kg/m^2 at {p.initial_temperature:g} K")
    if case.flow is not None:
        f = case.flow
        lines.append(f"flow: M = {f.mach:g}, p = {f.pressure:.6g} Pa, T = {f.temperature:.6g} K, "
                     f"q = {f.dynamic_pressure:.6g} Pa, Re/m = {f.reynolds_per_meter:.4g}")
    else:
        lines.append("flow: none")
    if case.simulation is not None:
        s = case.simulation
        lines.append(f"simulation: scheme {s.scheme}, aero {s.aero}, heating {s.heating} "
                     f"({s.boundary_layer}), dt = {s.time_step:g} s, duration {s.duration:g} s")
    return lines
