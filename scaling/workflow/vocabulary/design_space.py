"""The ``[variables]`` table of a study: the design variables and their bounds.

Each entry is one of

* ``NAME = [lower, upper]`` -- bounds in SI units, inside the variable's hard limits
  (:data:`hypate.scaling.workflow.vocabulary.variables.HARD_LIMITS`) and the tunnel envelope;
* ``NAME = "tunnel"`` -- the bounds the study's tunnel gives (``M``, ``p0``, ``T0``,
  Table 9.6);
* ``T_rad = { schedule = n, range = [lo, hi], shape = "free" | "increasing" |
  "decreasing" }`` -- a
  time-scheduled radiant heater (Sec. 9.2.3 Case 2 with ``T_rad(t)`` instead of a constant):
  the heater temperature is piecewise linear in the nondimensional time ``t / t_end`` of
  the test, with ``n`` (2-12) control points equally spaced from ``t = 0`` to ``t_end``.
  They are ``n`` design variables ``T_rad[0] .. T_rad[n-1]``, each in ``range`` (K,
  ``0 < lo < hi``). ``shape = "increasing"`` asks ``T_rad[k] <= T_rad[k+1]``,
  ``"decreasing"`` ``T_rad[k] >= T_rad[k+1]`` (a front-loaded heater: heat while the
  prototype heats fastest): linear
  inequalities on the design vector, handed to the optimizer as exact cheap constraints
  (:meth:`hypate.scaling.workflow.vocabulary.problem.ScalingProblem.cheap_constraints`); ``"free"``
  (default) leaves the points independent;
* ``material = ["ti6242", "inconel718", "al7075", "my_alloy"]`` -- the model material as
  a categorical variable (beyond the dissertation, which fixes Ti 6242): 2-8 distinct
  names, each a library material or a ``[materials.NAME]`` of the study. The design vector
  holds the level number ``0 .. k-1`` (bounds ``[0, k - 1]``) and the optimizer treats it
  as categorical (:mod:`hypate.scaling.engine.mixed`).

:func:`study_variables` turns the table into the problem's
:class:`~hypate.scaling.workflow.vocabulary.spec.Variable` tuple; every error is an
:class:`~hypate.solvers.errors.InputError` naming ``variables.NAME`` (or its sub-key).
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Annotated, Any, Literal

from hypate.scaling.workflow.vocabulary.spec import Variable
from hypate.scaling.workflow.vocabulary.tunnels import TunnelEnvelope
from hypate.scaling.workflow.vocabulary.variables import (
    CATEGORICAL,
    DESIGN_VARIABLES,
    HARD_LIMITS,
    SCHEDULABLE,
    SCHEDULE_POINTS,
    schedule_names,
)
from hypate.solvers.config import InputModel, Pair, pydantic_input_error
from hypate.solvers.errors import InputError
from pydantic import Field, ValidationError, model_validator

#: What a ``[variables]`` entry may be in the study schema (a schedule is checked by
#: :class:`ScheduleEntry` afterwards, so that its errors name its own keys).
VariableEntry = list[float] | list[str] | str | dict[str, Any]
#: Shapes of a schedule.
SHAPES = ("free", "increasing", "decreasing")
#: Fewest and most values of a categorical variable.
LEVELS: tuple[int, int] = (2, 8)


class ScheduleEntry(InputModel):
    """``{ schedule = n, range = [lo, hi], shape = "free" }`` of a scheduled variable."""

    schedule: Annotated[int, Field(ge=SCHEDULE_POINTS[0], le=SCHEDULE_POINTS[1])]
    range: Pair
    shape: Literal["free", "increasing", "decreasing"] = "free"

    @model_validator(mode="after")
    def _check(self) -> ScheduleEntry:
        lo, hi = self.range
        if not (math.isfinite(lo) and math.isfinite(hi) and 0.0 < lo < hi):
            raise ValueError(f"range: need finite [lower, upper] with 0 < lower < upper; got "
                             f"[{lo:g}, {hi:g}]")
        return self


def schedule_entry(name: str, value: Mapping[str, Any]) -> ScheduleEntry:
    """A ``[variables]`` table entry validated as a schedule of ``name``.

    Raises
    ------
    InputError
        ``variables.NAME`` (or ``variables.NAME.KEY``): ``name`` cannot be scheduled, or a
        key is missing, unknown or out of range (``schedule`` an integer in [2, 12],
        ``range`` finite with ``0 < lo < hi`` inside the variable's hard limits, ``shape``
        one of :data:`SHAPES`).
    """
    field = f"variables.{name}"
    if name not in SCHEDULABLE:
        raise InputError(field, f"only {', '.join(SCHEDULABLE)} can be scheduled "
                         "({ schedule = n, range = [lo, hi] }); give [lower, upper] bounds")
    try:
        entry = ScheduleEntry.model_validate(dict(value))
    except ValidationError as exc:
        raise pydantic_input_error(exc, prefix=field, model=ScheduleEntry) from None
    lo, hi = entry.range
    hard = HARD_LIMITS[name]
    if lo < hard[0] or hi > hard[1]:
        raise InputError(f"{field}.range", f"[{lo:g}, {hi:g}] leaves the allowed range "
                         f"[{hard[0]:g}, {hard[1]:g}]")
    return entry


def categorical_levels(name: str, value: Any) -> tuple[str, ...]:
    """The values of a categorical entry ``NAME = ["a", "b", ...]``, checked (2-8 distinct
    non-empty names, each one of the row's ``choices``; whether each names a material is
    the study's check).

    Raises
    ------
    InputError
        ``variables.NAME``: ``name`` is not categorical, or the list is not 2-8 distinct
        names its row allows.
    """
    field = f"variables.{name}"
    if name not in CATEGORICAL:
        raise InputError(field, "bounds must be numbers [lower, upper] (only "
                         f"{', '.join(CATEGORICAL)} takes a list of names)")
    lo, hi = LEVELS
    if not (isinstance(value, list) and all(isinstance(v, str) and v for v in value)):
        raise InputError(field, "needs a list of names, e.g. [\"ti6242\", \"inconel718\"]")
    if not lo <= len(value) <= hi:
        raise InputError(field, f"needs {lo} to {hi} names; got {len(value)}")
    if len(set(value)) != len(value):
        raise InputError(field, "a name is listed twice")
    allowed = DESIGN_VARIABLES[name].choices
    if allowed and (bad := [v for v in value if v not in allowed]):
        raise InputError(field, f"{bad[0]!r} is not one of {', '.join(allowed)}")
    return tuple(value)


def study_levels(entries: Mapping[str, VariableEntry]) -> dict[str, tuple[str, ...]]:
    """The categorical entries of a ``[variables]`` table: ``{NAME: (value, ...)}``."""
    return {name: categorical_levels(name, value) for name, value in entries.items()
            if name in CATEGORICAL}


def variable_bounds(name: str, value: list[float] | list[str] | str,
                    tunnel: TunnelEnvelope | None) -> tuple[float, float]:
    """Bounds of a ``NAME = [lower, upper]`` or ``NAME = "tunnel"`` entry (SI units)."""
    field = f"variables.{name}"
    if isinstance(value, list) and any(isinstance(v, str) for v in value):
        raise InputError(field, "bounds must be numbers [lower, upper]")
    if isinstance(value, str):
        if value != "tunnel":
            raise InputError(field, "bounds must be [lower, upper] or \"tunnel\"")
        if tunnel is None:
            raise InputError(field, "\"tunnel\" bounds need a [tunnel] table")
        b = tunnel.bounds()
        if name not in b:
            raise InputError(field, f"the tunnel {tunnel.name!r} gives no bounds for {name} "
                             f"(it bounds {', '.join(b)})")
        return b[name]
    if len(value) != 2:
        raise InputError(field, "bounds must be [lower, upper]")
    lo, hi = float(value[0]), float(value[1])
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise InputError(field, f"bounds must be finite with lower < upper; got [{lo:g}, {hi:g}]")
    hard = HARD_LIMITS[name]
    if lo < hard[0] or hi > hard[1]:
        raise InputError(field, f"bounds [{lo:g}, {hi:g}] leave the allowed range "
                         f"[{hard[0]:g}, {hard[1]:g}]")
    if tunnel is not None and name in tunnel.bounds():
        tlo, thi = tunnel.bounds()[name]
        if lo < tlo * (1 - 1e-9) or hi > thi * (1 + 1e-9):
            raise InputError(field, f"bounds [{lo:g}, {hi:g}] leave the tunnel envelope "
                             f"{tunnel.name} [{tlo:g}, {thi:g}]")
    return lo, hi


def study_variables(entries: Mapping[str, VariableEntry], tunnel: TunnelEnvelope | None
                    ) -> tuple[tuple[Variable, ...], tuple[str, ...], tuple[str, ...]]:
    """The design variables of a ``[variables]`` table, in its order, and the names of the
    schedules whose shape is ``"increasing"`` and ``"decreasing"``.

    A schedule of ``n`` points contributes ``NAME[0] .. NAME[n-1]``, each with the
    schedule's ``range`` as bounds; a categorical entry of ``k`` values one variable with
    bounds ``[0, k - 1]`` (its level number).
    """
    variables: list[Variable] = []
    increasing: list[str] = []
    decreasing: list[str] = []
    for name, value in entries.items():
        if name in CATEGORICAL:
            variables.append(Variable(name, 0.0, float(len(categorical_levels(name, value)) - 1)))
        elif isinstance(value, dict):
            entry = schedule_entry(name, value)
            variables += [Variable(n, *entry.range) for n in schedule_names(name,
                                                                            entry.schedule)]
            if entry.shape == "increasing":
                increasing.append(name)
            elif entry.shape == "decreasing":
                decreasing.append(name)
        else:
            variables.append(Variable(name, *variable_bounds(name, value, tunnel)))
    return tuple(variables), tuple(increasing), tuple(decreasing)


__all__ = ["LEVELS", "SHAPES", "ScheduleEntry", "VariableEntry", "categorical_levels",
           "schedule_entry", "study_levels", "study_variables", "variable_bounds"]
