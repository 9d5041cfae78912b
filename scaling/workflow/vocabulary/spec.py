"""What defines one scaling problem (Secs. 6.2, 9.1.2.2, 9.2.1): the prototype, the model
template, the design variables with their bounds, the fixed values, the objectives, time
scaling and projection, the cheap constraints, the categorical variables' values, the
tunnel and the admissibility checks -- a :class:`ScalingSpec`, which a study file builds
(:mod:`.study`) and :class:`~hypate.scaling.workflow.vocabulary.problem.ScalingProblem`
turns into a pymoo problem.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

from hypate.scaling.workflow.vocabulary.admissibility import Admissibility
from hypate.scaling.workflow.vocabulary.configuration import Configuration
from hypate.scaling.workflow.vocabulary.objectives import PROJECTIONS
from hypate.scaling.workflow.vocabulary.similarity import TIME_SCALINGS
from hypate.scaling.workflow.vocabulary.tunnels import TunnelEnvelope
from hypate.scaling.workflow.vocabulary.variables import CATEGORICAL, base_name, schedule_point
from hypate.solvers.errors import InputError
from hypate.solvers.settings import SimulationSettings

#: Objective names.
OBJECTIVES = ("J_u", "J_T", "J_s")
#: Cheap equality constraints available (Eq. 9.7).
EQUALITY_CONSTRAINTS = ("T_inf",)
#: The categorical model material (one of
#: :data:`~hypate.scaling.workflow.vocabulary.variables.CATEGORICAL`).
MATERIAL = "material"
#: The levels of one categorical variable: ``((value name, value), ...)``.
Levels = tuple[tuple[str, Any], ...]


@dataclass(frozen=True)
class Variable:
    """A continuous design variable with its bounds (SI units)."""

    name: str
    lower: float
    upper: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.lower) and math.isfinite(self.upper)
                and self.lower < self.upper):
            raise InputError(f"variables.{self.name}", f"bounds must be finite with lower < "
                             f"upper; got [{self.lower:g}, {self.upper:g}]")


@dataclass(frozen=True)
class ScalingSpec:
    """Everything that defines one scaling problem.

    Attributes
    ----------
    prototype : Configuration
        Full-scale panel in flight (``delta_T`` for a uniformly heated panel).
    model : Configuration
        Model template in the tunnel (material, layup, mesh, Mach, fixed values).
    variables : tuple of Variable
    fixed : dict
        Design values applied to every model (names of ``apply_design``), e.g. ``L`` from
        the geometric scale.
    objectives : tuple of str
    time_scaling : {"fourier", "fourier_thickness", "structural"}
        :data:`hypate.scaling.workflow.vocabulary.similarity.TIME_SCALINGS`: Eqs. 9.5-9.6, Eq. 6.5
        or Eq. 9.3.
    projection : {"center", "modal", "fields"}
    equalities : tuple of str
        Cheap equality constraints (:data:`EQUALITY_CONSTRAINTS`).
    xi : float
        Geometric scale L_p / L_m (for reports and laws).
    increasing : tuple of str
        Scheduled variables (``"T_rad"``) whose control points ``NAME[k]`` may not
        decrease with k (``shape = "increasing"``): cheap linear inequalities.
    decreasing : tuple of str
        Likewise, control points that may not increase with k (``shape = "decreasing"``).
    choices : tuple of (str, Levels)
        The categorical design variables' values: ``(NAME, ((value name, value), ...))``
        per variable; level ``k`` of ``NAME`` in a design vector sets the ``k``-th value
        into the model (:func:`~hypate.scaling.workflow.vocabulary.configuration.with_choice`:
        a ``material``'s values are :class:`~hypate.solvers.materials.Material` objects, the
        model made of one; others are the names themselves).
    tunnel : TunnelEnvelope or None
        The tunnel the model is tested in (its test section and run time bound the size
        and duration checks).
    admissibility : Admissibility
        The study's admissibility checks (``[admissibility]``).
    simulator : str or None
        The user's own simulator by name (:mod:`~hypate.scaling.workflow.vocabulary.external`);
        None: hypate's.
    """

    prototype: Configuration
    model: Configuration
    variables: tuple[Variable, ...]
    fixed: dict[str, float] = field(default_factory=dict)
    objectives: tuple[str, ...] = ("J_u", "J_T")
    time_scaling: str = "fourier"
    projection: str = "center"
    equalities: tuple[str, ...] = ()
    xi: float = 1.0
    increasing: tuple[str, ...] = ()
    decreasing: tuple[str, ...] = ()
    choices: tuple[tuple[str, Levels], ...] = ()
    tunnel: TunnelEnvelope | None = None
    admissibility: Admissibility = Admissibility()
    simulator: str | None = None

    def __post_init__(self) -> None:
        if not self.variables:
            raise InputError("variables", "at least one design variable is needed")
        bad = [o for o in self.objectives if o not in OBJECTIVES]
        if bad or not self.objectives:
            raise InputError("study.objectives", f"must be a non-empty subset of "
                             f"{', '.join(OBJECTIVES)}; got {list(self.objectives)}")
        if self.time_scaling not in TIME_SCALINGS:
            raise InputError("study.time_scaling", f"must be one of {', '.join(TIME_SCALINGS)}")
        if self.projection not in PROJECTIONS:
            raise InputError("study.projection", f"must be one of {', '.join(PROJECTIONS)}")
        for eq in self.equalities:
            if eq not in EQUALITY_CONSTRAINTS:
                raise InputError("constraints.equality", f"unknown constraint {eq!r}; "
                                 f"available: {', '.join(EQUALITY_CONSTRAINTS)}")
        names = [v.name for v in self.variables]
        if len(set(names)) != len(names):
            raise InputError("variables", "a design variable is listed twice")
        both = set(map(base_name, names)) & set(map(base_name, self.fixed))
        if both:
            raise InputError(f"fixed.{sorted(both)[0]}", "is also a design variable")
        levels = self.levels
        for v in self.variables:
            if (v.name in CATEGORICAL) != (v.name in levels) or (
                    v.name in levels and (v.lower, v.upper) != (0.0, len(levels[v.name]) - 1)):
                raise InputError(f"variables.{v.name}", f"a categorical variable needs its "
                                 f"values and bounds [0, k - 1] for its "
                                 f"{len(levels.get(v.name, ()))} values")
        if set(levels) - set(names):
            raise InputError(f"variables.{sorted(set(levels) - set(names))[0]}",
                             "values given for a name that is not a design variable")
        for name, sign in self.monotone:
            if len(self.schedule_indices(name)) < 2:
                shape = "an increasing" if sign > 0 else "a decreasing"
                raise InputError(f"variables.{name}", f"{shape} shape needs a schedule of at "
                                 "least 2 control points")

    @property
    def monotone(self) -> list[tuple[str, int]]:
        """The monotone schedules as ``(name, +1 increasing | -1 decreasing)``."""
        return [(n, 1) for n in self.increasing] + [(n, -1) for n in self.decreasing]

    def schedule_indices(self, name: str) -> list[int]:
        """Positions of the control points ``NAME[0], NAME[1], ...`` in the design vector,
        in the order of k (empty when ``name`` is not scheduled)."""
        found = {p[1]: i for i, v in enumerate(self.variables)
                 if (p := schedule_point(v.name)) is not None and p[0] == name}
        return [found[k] for k in sorted(found)]

    @property
    def levels(self) -> dict[str, Levels]:
        """Each categorical design variable's values by its name (:attr:`choices`)."""
        return dict(self.choices)

    @property
    def categorical_names(self) -> list[str]:
        """The categorical design variables in design-vector order."""
        return [n for n in self.names if n in self.levels]

    @property
    def categorical_indices(self) -> list[int]:
        """Their positions in the design vector (empty: none)."""
        return [self.names.index(n) for n in self.categorical_names]

    def level_names(self, name: str) -> tuple[str, ...]:
        """The value names of categorical variable ``name`` (empty: not a variable)."""
        return tuple(level for level, _ in self.levels.get(name, ()))

    @property
    def materials(self) -> Levels:
        """A categorical material's levels, ``((name, Material), ...)`` (empty: fixed)."""
        return self.levels.get(MATERIAL, ())

    @property
    def material_index(self) -> int | None:
        """Position of the categorical ``material`` in the design vector (None: fixed)."""
        return self.names.index(MATERIAL) if self.materials else None

    @property
    def material_names(self) -> tuple[str, ...]:
        return self.level_names(MATERIAL)

    @property
    def simulation(self) -> SimulationSettings:
        """The prototype's simulation settings (the model template carries the same ones;
        each model runs them with its own time step)."""
        return self.prototype.simulation

    @property
    def kind(self) -> str:
        """``"quasi_steady"`` (TC + LSA) or ``"aeroelastic"`` (S2): the study kind."""
        return "quasi_steady" if self.simulation.scheme == "tc" else "aeroelastic"

    def with_steps(self, steps: int) -> ScalingSpec:
        """The same problem simulated for ``steps`` prototype time steps."""
        def resized(config: Configuration) -> Configuration:
            sim = config.simulation
            return dataclasses.replace(config, simulation=dataclasses.replace(
                sim, duration=sim.time_step * int(steps)))
        return dataclasses.replace(self, prototype=resized(self.prototype),
                                   model=resized(self.model))

    @property
    def names(self) -> list[str]:
        return [v.name for v in self.variables]


__all__ = ["EQUALITY_CONSTRAINTS", "MATERIAL", "OBJECTIVES", "Levels", "ScalingSpec",
           "Variable"]
