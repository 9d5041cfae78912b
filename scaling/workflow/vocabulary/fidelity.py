"""Fidelity levels of a study: cheaper versions of its own simulation (issue 19; beyond the
dissertation's single-fidelity Sec. 6.3).

Public keys (a study's ``[[fidelity]]`` array of tables, cheapest first)::

    [[fidelity]]
    name = "coarse"
    mesh = [4, 4]               # shell elements of prototype and model at this level
    time_step_factor = 4.0      # 4x the time step, 1/4 of the steps (same duration)
    initial_samples = 20        # this level's own initial designs (default 2x [optimizer]'s)
    [[fidelity]]
    name = "full"               # the study's own [simulation]; always last, no overrides

Each lower level is the study re-read with its ``[simulation] mesh`` and ``time_step``
changed (:func:`level_data`): its own prototype, simulated at its resolution, and its own
J_u, J_T -- the same nondimensional comparison at fewer nodes and fewer matched times. The
optimizer sees one problem, :class:`FidelityProblem`, whose last variable is the level
(:class:`~hypate.scaling.engine.fidelity.MultiFidelityOptimizer`); the design point, the
Pareto front and the report are the top level's evaluations only.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Annotated, Any

import numpy as np
from hypate.scaling.engine.fidelity import MultiFidelityOptimizer
from hypate.scaling.engine.result import OptimizationResult
from hypate.scaling.engine.settings import OptimizerSettings, RunContext
from hypate.scaling.workflow.vocabulary.problem import ScalingProblem, evaluate_rows
from hypate.solvers.config import InputModel
from hypate.solvers.settings import DEFAULTS
from pydantic import Field
from pymoo.core.problem import Problem

#: The evaluations.csv column of an evaluation's level (0 = cheapest), and of its name.
FIDELITY = "fidelity"
FIDELITY_NAME = "fidelity_name"
#: Most levels a study may declare (the top one included).
MAX_LEVELS = 4


class FidelitySection(InputModel):
    """One ``[[fidelity]]`` table (module docstring)."""

    name: Annotated[str, Field(min_length=1, max_length=40, pattern=r"^[A-Za-z0-9_.-]+$")]
    mesh: Annotated[list[Annotated[int, Field(ge=1, le=100)]],
                    Field(min_length=2, max_length=2)] | None = None
    time_step_factor: Annotated[float, Field(ge=1.0, le=100.0)] = 1.0
    initial_samples: Annotated[int, Field(ge=0, le=10000)] | None = None


def check_fidelity(levels: Sequence[FidelitySection], *, steps: int, categorical: bool,
                   robust: bool, sweep: bool, polish: int,
                   coordinates: str) -> None:
    """Cross-key checks of ``[[fidelity]]`` (ValueError naming the key; nothing runs)."""
    if not levels:
        return
    if not 2 <= len(levels) <= MAX_LEVELS:
        raise ValueError(f"fidelity: give 2 to {MAX_LEVELS} levels, cheapest first, the "
                         f"study's own [simulation] last; got {len(levels)}")
    names = [f.name for f in levels]
    if len(set(names)) != len(names):
        raise ValueError(f"fidelity: level names must differ; got {names}")
    top = levels[-1]
    if top.mesh is not None or top.time_step_factor != 1.0 or top.initial_samples is not None:
        raise ValueError(f"fidelity[{len(levels) - 1}] ({top.name}): the last level is the "
                         "study's own [simulation]; give it only a name")
    for k, f in enumerate(levels[:-1]):
        if f.mesh is None and f.time_step_factor == 1.0:
            raise ValueError(f"fidelity[{k}] ({f.name}): a cheaper level needs mesh or "
                             "time_step_factor > 1")
        n = steps / f.time_step_factor
        if abs(n - round(n)) > 1e-9 * steps or round(n) < 2:
            raise ValueError(f"fidelity[{k}].time_step_factor: must divide simulation.steps "
                             f"= {steps} into at least 2 steps; got {f.time_step_factor:g}")
    clashes = {"variables.material (a categorical variable)": categorical,
               "[robust]": robust, "[sweep]": sweep, f"optimizer.polish = {polish}": polish > 0,
               f"optimizer.coordinates = {coordinates!r}": coordinates != "design"}
    bad = [k for k, v in clashes.items() if v]
    if bad:
        raise ValueError(f"fidelity: the multi-fidelity search runs over the design "
                         f"coordinates, without {', '.join(bad)}; remove one or the other")


def level_data(data: dict[str, Any], level: FidelitySection) -> dict[str, Any]:
    """The study's raw dict at a lower ``level``: no ``fidelity`` array, ``[simulation]``
    with the level's mesh and ``time_step_factor`` x the time step over as many fewer
    steps (the same simulated duration)."""
    out = {k: v for k, v in data.items() if k != "fidelity"}
    sim = dict(out.get("simulation") or {})
    factor = float(level.time_step_factor)
    if factor != 1.0:
        dt = float(sim.get("time_step", _default("time_step")))
        steps = int(sim.get("steps", _default("steps")))
        sim["time_step"] = dt * factor
        sim["steps"] = int(round(steps / factor))
    if level.mesh is not None:
        sim["mesh"] = list(level.mesh)
    out["simulation"] = sim
    return out


def _default(key: str) -> float:
    """A ``[simulation]`` default (the study schema's)."""
    return float(getattr(DEFAULTS, {"time_step": "time_step", "steps": "n_steps"}[key]))


def default_low_samples(level: FidelitySection, initial_samples: int) -> int:
    """A lower level's own initial designs: its key, else twice the top level's."""
    return 2 * initial_samples if level.initial_samples is None else level.initial_samples


#: Per-step work that does not grow with the mesh (aerodynamics, thermal layers, the
#: coupling's bookkeeping), in shell-element equivalents: a coarse 4 x 4 / 40-step Sec. 9.2.2
#: simulation took 1/7 of the full 8 x 8 / 160-step one's seconds on 12 designs (2 busy
#: cores), (16 + c) / (64 + c) = 4 / 7 per step gives c = 48. On the quiet machine the
#: ratio was 0.54 s / 4.7 s = 1/8.7 (c = 25): the model overstates the coarse level's cost
#: by about 1.5x there, which leans the level choice slightly towards the top level.
STEP_OVERHEAD_ELEMENTS = 48.0


def prior_cost(spec: Any) -> float:
    """Relative cost of one simulation of a level, time steps x (shell elements +
    :data:`STEP_OVERHEAD_ELEMENTS`): deterministic, so that the level choice (and the run)
    does not depend on the machine's timing noise."""
    nx, ny = spec.model.panel.mesh
    sim = spec.simulation
    return float((nx * ny + STEP_OVERHEAD_ELEMENTS)
                 * max(1, round(sim.duration / sim.time_step)))


class FidelityProblem(Problem):
    """The levels' scaling problems as one pymoo problem ``(x, level)``.

    Parameters
    ----------
    levels : sequence of ScalingProblem
        Cheapest first, the study's own problem last; the same variables.
    names : sequence of str
        The levels' names.
    """

    def __init__(self, levels: Sequence[Any], names: Sequence[str]) -> None:
        top = levels[-1]
        if any(p.n_var != top.n_var or p.n_obj != top.n_obj for p in levels):
            raise ValueError("fidelity levels must share the variables and objectives")
        self.levels = list(levels)
        self.names = list(names)
        # the multi-fidelity search models no expensive constraint (its co-kriging is of the
        # objectives): the admissibility columns are dropped here, every evaluation keeps
        # what its model went through (aux), and the design point is chosen among the
        # admissible top-level evaluations (scaling.workflow.campaigns.verdict)
        super().__init__(n_var=top.n_var + 1, n_obj=top.n_obj, n_ieq_constr=0,
                         xl=np.r_[np.asarray(top.xl, float), 0.0],
                         xu=np.r_[np.asarray(top.xu, float), float(len(levels) - 1)])

    @property
    def top(self) -> Any:
        """The study's own problem (the highest level)."""
        return self.levels[-1]

    def level(self, x: Sequence[float]) -> int:
        """The level of a design vector ``(x, level)`` (rounded, clipped)."""
        return int(min(max(round(float(np.asarray(x, float)[-1])), 0), len(self.levels) - 1))

    def _evaluate(self, X: np.ndarray, out: dict[str, Any], *args: Any, **kwargs: Any) -> None:
        X = np.atleast_2d(X)
        if len(X) != 1:  # the engine evaluates one design at a time
            raise ValueError("a fidelity problem evaluates one design per call")
        level = self.levels[self.level(X[0])]
        full: dict[str, Any] = {}
        evaluate_rows(level, [level.model_configuration(X[0, :-1])], full)
        out["F"], out["aux"] = full["F"], full["aux"]


def fidelity_problem(study: Any, problem: Any) -> FidelityProblem | None:
    """The study's levels around its own ``problem`` (None: a single-fidelity study)."""
    if not study.lower_levels:
        return None
    # every level enforces the top level's checks (the stress check's "auto" decided once,
    # by the study's own prototype), so that the constraint columns mean one thing
    rules = problem.admissibility
    return FidelityProblem([ScalingProblem(dataclasses.replace(spec, admissibility=rules))
                            for _, spec, _ in study.lower_levels] + [problem],
                           study.level_names)


def fidelity_optimizer(study: Any, problem: FidelityProblem, settings: OptimizerSettings,
                       context: RunContext) -> MultiFidelityOptimizer:
    """The multi-fidelity optimizer of a study: the levels' costs from :func:`prior_cost`
    (relative and deterministic; the measured seconds are reported, not used) and each lower
    level's own initial designs (:func:`default_low_samples`)."""
    n_init = study.optimizer.initial_samples
    return MultiFidelityOptimizer(
        problem, settings, context, costs=[prior_cost(p.spec) for p in problem.levels],
        low_samples=[default_low_samples(f, n_init) for _, _, f in study.lower_levels])


def top_level(result: OptimizationResult, n_levels: int
              ) -> tuple[OptimizationResult, np.ndarray]:
    """The top level's evaluations of a multi-fidelity run as a result over the design
    alone, with their rows in the full result (evaluation ids)."""
    rows = np.flatnonzero(is_top(result.X, n_levels))
    data = result.data.iloc[rows].drop(columns=[f"x{result.n_var - 1}"]).reset_index(drop=True)
    return (OptimizationResult(data=data, n_var=result.n_var - 1, n_obj=result.n_obj,
                               ref_point=result.ref_point,
                               seconds_per_iteration=result.seconds_per_iteration), rows)


def is_top(X: np.ndarray, n_levels: int) -> np.ndarray:
    """Mask of the rows of ``(x, level)`` designs at the top level."""
    X = np.atleast_2d(np.asarray(X, float))
    return np.rint(X[:, -1]) == n_levels - 1 if len(X) else np.zeros(0, bool)


def cost_summary(levels: np.ndarray, seconds: np.ndarray, names: Sequence[str]
                 ) -> dict[str, dict[str, Any]]:
    """design_point.json's ``fidelity``: per level name, evaluations and simulator seconds."""
    return {name: {"evaluations": int(np.sum(levels == k)),
                   "simulator_seconds": float(np.sum(seconds[levels == k]))
                   if np.any(levels == k) else 0.0,
                   "median_seconds": float(np.median(seconds[levels == k]))
                   if np.any(levels == k) else None}
            for k, name in enumerate(names)}


__all__ = ["FIDELITY", "FIDELITY_NAME", "FidelityProblem", "FidelitySection",
           "check_fidelity", "cost_summary", "default_low_samples", "fidelity_optimizer",
           "fidelity_problem", "is_top", "level_data", "prior_cost", "top_level"]
