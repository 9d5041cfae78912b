"""A finished campaign's outputs: ``evaluations.csv``, ``pareto.csv``, ``design_point.json``
and ``design_point.npz`` (the public names of :mod:`hypate.scaling.workflow.campaigns.run`'s
docstring), with the design point chosen by the study's rule, its admissibility, its surrogate
record and the scatter it takes under ``[uncertainty]``.
"""
from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from hypate.scaling.engine.design_point import design_point_index
from hypate.scaling.engine.optimizer import BayesianOptimizer
from hypate.scaling.engine.result import OptimizationResult
from hypate.scaling.engine.store import EvaluationStore
from hypate.scaling.workflow.campaigns.rundir import (
    CLASSICAL_JSON,
    DESIGN_POINT_JSON,
    DESIGN_POINT_NPZ,
    EVALUATIONS_CSV,
    ID_COLUMN,
    PARETO_CSV,
    finite,
    finite_or_none,
    write_csv,
    write_json,
)
from hypate.scaling.workflow.campaigns.verdict import (
    choose_admissible_point,
    evaluation_admissibility,
    verdict_fields,
)
from hypate.scaling.workflow.vocabulary.fidelity import (
    FIDELITY,
    FIDELITY_NAME,
    cost_summary,
    top_level,
)
from hypate.scaling.workflow.vocabulary.problem import ScalingProblem
from hypate.scaling.workflow.vocabulary.study import Study
from hypate.scaling.workflow.vocabulary.uncertainty import propagate_or_failure
from hypate.solvers.coupling.response import Response
from hypate.solvers.errors import InputError

#: Store metadata key of the design point's propagated scatter (:func:`design_point_scatter`).
SCATTER_META = "design_point_scatter"
#: evaluations.csv columns read from each evaluation's extremes (K, -, Pa).
EXTREME_COLUMNS = ("max_wall_temperature", "max_deflection_ratio", "max_von_mises")
#: evaluations.csv column: whether the evaluation is admissible (empty: failed, or a lower
#: fidelity level).
ADMISSIBLE_COLUMN = "admissible"
#: evaluations.csv prefix of an admissibility constraint column (its relative violation).
CONSTRAINT_PREFIX = "G_"


def evaluations_table(study: Study, result: OptimizationResult,
                      admissible: tuple[np.ndarray, np.ndarray] | None = None,
                      constraint_names: Sequence[str] = ()) -> pd.DataFrame:
    """Evaluations with variables and objectives by name, after an ``id`` column (the
    0-based row number in the store order: the evaluation number the report prints);
    the admissibility constraint columns ``G_<check>`` (``constraint_names``, the problem's
    :attr:`~ScalingProblem.constraint_names`; relative violation, <= 0 holds),
    what each model went through (:data:`EXTREME_COLUMNS`) and, given ``admissible`` as
    ``(rows, flags)``, an ``admissible`` column (True / False on those rows)."""
    df = result.data.copy()
    names = study.spec.names
    rename = {f"x{i}": n for i, n in enumerate(names)}
    rename.update({f"f{i}": o for i, o in enumerate(study.spec.objectives)})
    gcols = [c for c in df.columns if c.startswith("g") and c[1:].isdigit()]
    if len(gcols) == len(constraint_names):
        rename.update({g: CONSTRAINT_PREFIX + n for g, n in zip(gcols, constraint_names)})
    df = df.rename(columns=rename)
    aux = df.pop("aux") if "aux" in df.columns else pd.Series([{}] * len(df))
    for key in EXTREME_COLUMNS:
        df[key] = [((a or {}).get("extremes") or {}).get(key, np.nan) if isinstance(a, dict)
                   else np.nan for a in aux]
    if admissible is not None:
        flags = pd.Series([None] * len(df), dtype=object)
        flags.iloc[admissible[0]] = [bool(v) for v in admissible[1]]
        df[ADMISSIBLE_COLUMN] = flags.to_numpy()
    df.insert(0, ID_COLUMN, np.arange(len(df)))
    if study.lower_levels:  # the level after the design, then its name
        df = df.rename(columns={f"x{len(names)}": FIDELITY})
        levels = np.clip(np.rint(df[FIDELITY].to_numpy(float)), 0, len(study.level_names) - 1)
        df.insert(df.columns.get_loc(FIDELITY) + 1, FIDELITY_NAME,
                  [study.level_names[int(k)] for k in levels])
    for name in study.spec.categorical_names:  # each level's name next to its number
        values = study.spec.level_names(name)
        levels = np.clip(np.rint(df[name].to_numpy(float)), 0, len(values) - 1)
        df.insert(df.columns.get_loc(name) + 1, level_column(name),
                  [values[int(k)] for k in levels])
    return df


def level_column(name: str) -> str:
    """The evaluations table's column naming categorical ``name``'s value, after its level
    number (``material_name``)."""
    return f"{name}_name"


def choose_design_point(study: Study, result: OptimizationResult) -> int | None:
    """Row of the design point among the feasible evaluations, by the study's
    ``[optimizer] design_point`` rule (:meth:`OptimizationResult.design_point`;
    default "minmax": the smallest max(J_u, J_T), Sec. 9.2.3); None without a feasible one."""
    return result.design_point(study.optimizer.design_point, study.optimizer.weights)


def surrogate_record(optimizer: BayesianOptimizer, result: OptimizationResult, row: int,
                     objectives: Sequence[str]) -> dict[str, Any]:
    """The public ``surrogate`` field of design_point.json: the final surrogates'
    leave-one-out prediction of the design point
    (:meth:`~hypate.scaling.engine.optimizer.BayesianOptimizer.leave_one_out`), per objective
    ``{"observed", "predicted", "std", "lower", "upper", "z"}``; ``std`` and ``z`` are in
    the surrogate's output space (``transform``: ``"log"`` means of ``ln J``)."""
    check = optimizer.leave_one_out(result, row)
    per = {name: {"observed": finite_or_none(float(check.observed[j])),
                  "predicted": finite_or_none(float(check.mean[j])),
                  "std": finite_or_none(float(check.std[j])),
                  "lower": finite_or_none(float(check.lower[j])),
                  "upper": finite_or_none(float(check.upper[j])),
                  "z": finite_or_none(float(check.z[j]))}
           for j, name in enumerate(objectives)}
    return {"method": "leave-one-out kriging (hyperparameters of the final fit)",
            "transform": check.transform, "objectives": per}


def best_by_level(study: Study, result: OptimizationResult, variable: str) -> dict[str, Any]:
    """design_point.json's ``NAME.best`` of categorical ``variable`` (``material.best``):
    per value, its best feasible evaluation by the design-point rule (``evaluation``,
    ``objectives``; None when none succeeded), so the report can say how far the other
    values stayed."""
    cat_col = result.X[:, study.spec.names.index(variable)]
    out: dict[str, Any] = {}
    for level, name in enumerate(study.spec.level_names(variable)):
        idx = np.flatnonzero(result.feasible & (np.rint(cat_col) == level))
        if idx.size == 0:
            out[name] = None
            continue
        opt = study.optimizer
        row = int(idx[design_point_index(result.F[idx], opt.design_point, opt.weights)])
        out[name] = {"evaluation": row, "objectives": {
            o: float(f) for o, f in zip(study.spec.objectives, result.F[row])}}
    return out


def design_point_scatter(study: Study, problem: ScalingProblem, x: np.ndarray,
                         store: EvaluationStore | None = None,
                         progress: Callable[[int, int], None] | None = None) -> dict[str, Any]:
    """The study's ``[uncertainty]`` propagated at the design point
    (:func:`~hypate.scaling.workflow.vocabulary.uncertainty.propagate_or_failure`; its seed is the
    study file's ``[optimizer] seed``, so ``--seed`` runs of one study see the same scatter
    samples): once per design point, kept in the store's metadata so that a resumed run does
    not simulate it again. Too many failed scattered models give ``{"status": "failed: ..."}``.
    """
    key = [float(v) for v in x]
    cached = store.get_meta(SCATTER_META) if store is not None else None
    if isinstance(cached, dict) and cached.get("x") == key:
        return cached["block"]
    assert study.uncertainty is not None  # a scatter only with [uncertainty]
    block = finite(propagate_or_failure(problem, x, study.uncertainty,
                                        seed=study.optimizer.seed, progress=progress))
    if store is not None:
        store.set_meta(SCATTER_META, {"x": key, "block": block}, replace=True)
    return block


def point_header(study: Study) -> dict[str, Any]:
    """The first fields of design_point.json: study, xi, the design-point rule, its file."""
    return {"study": study.name, "xi": study.spec.xi, "rule": study.optimizer.design_point,
            "study_path": str(Path(study.path).resolve()) if study.path != "<memory>" else None}


def design_fields(study: Study, problem: ScalingProblem, x: np.ndarray) -> dict[str, Any]:
    """design_point.json's description of design ``x``: ``design``, ``similarity``,
    ``active_constraints`` (bounds hit, then the equalities) and the variables' ``bounds``;
    with a categorical variable also one block of its name (``material``: ``name``,
    ``level``, ``levels``)."""
    design = problem.design(x)
    named = {name: {"name": value, "level": int(design[name]),
                    "levels": list(study.spec.level_names(name))}
             for name, value in problem.choice_names(x).items()}
    return {"design": problem.design(x), **named, "similarity": problem.similarity(x),
            "active_constraints": problem.active_bounds(x) + [
                f"{name} (equality)" for name in study.spec.equalities],
            "bounds": {v.name: [v.lower, v.upper] for v in study.spec.variables}}


def save_design_response(problem: ScalingProblem, x: np.ndarray, out: Path
                         ) -> tuple[Response | None, dict[str, Any]]:
    """Simulate design ``x`` at the nominal inputs into ``out/design_point.npz``; its
    response (None if the simulation failed) and the fields saying so (``model_time_step``,
    or ``design_point_response``: why nothing was saved)."""
    try:
        config, resp = problem.simulate_model(x, keep_fields=False)
        resp.save(out / DESIGN_POINT_NPZ)
    except (InputError, ArithmeticError, RuntimeError) as exc:
        return None, {"design_point_response": f"not saved: {exc}"}
    return resp, {"model_time_step": problem.model_time_step(config)}


def write_outputs(study: Study, problem: ScalingProblem, result: OptimizationResult,
                  out: Path, wall_seconds: float = float("nan"),
                  optimizer: BayesianOptimizer | None = None,
                  store: EvaluationStore | None = None,
                  on_scatter: Callable[[int, int], None] | None = None) -> dict[str, Any]:
    """evaluations.csv, pareto.csv, design_point.json (+ design_point.npz); with the run's
    ``optimizer``, the surrogates' leave-one-out prediction of the design point
    (:func:`surrogate_record`); for a study with ``[uncertainty]``, the design point's
    ``scatter`` (:func:`design_point_scatter`). The design point is chosen among the
    admissible evaluations (:mod:`hypate.scaling.workflow.campaigns.verdict`)."""
    full = result
    if study.lower_levels:  # the front and the design point are the top level's
        result, rows = top_level(full, len(study.level_names))
    else:
        rows = np.arange(len(full.data))
    adm, vio = evaluation_admissibility(problem, result)
    table = evaluations_table(study, full, admissible=(rows, adm),
                              constraint_names=problem.constraint_names)
    write_csv(out / EVALUATIONS_CSV, table)
    mask = result.pareto_mask() if len(rows) else np.zeros(0, bool)
    top_table = table.iloc[rows]
    # one order for every Pareto table: by the first objective (result.pareto_indices)
    front = result.pareto_indices() if len(rows) else np.zeros(0, int)
    pareto = top_table.iloc[front] if len(study.spec.objectives) > 1 else \
        top_table[result.feasible].nsmallest(10, study.spec.objectives[0])
    write_csv(out / PARETO_CSV, pareto)
    opt = study.optimizer
    row, is_admissible = choose_admissible_point(result, adm, vio, opt.design_point,
                                                 opt.weights)
    point = point_header(study)
    if row is None:
        point.update(design=None, objectives=None, similarity=[], active_constraints=[],
                     admissible=False, admissibility=[],
                     message="no successful evaluation")
    else:
        x = result.X[row]
        point.update(design_fields(study, problem, x))
        point["objectives"] = {o: float(f) for o, f in zip(study.spec.objectives, result.F[row])}
        point["evaluation"] = int(rows[row])
        if optimizer is not None and not study.lower_levels and int(result.ok.sum()) >= 3:
            point["surrogate"] = surrogate_record(optimizer, result, row,
                                                  study.spec.objectives)
        for name in study.spec.categorical_names:
            point[name]["best"] = best_by_level(study, result, name)
        if study.uncertainty is not None:
            point["scatter"] = design_point_scatter(study, problem, x, store, on_scatter)
        resp, saved = save_design_response(problem, x, out)
        point.update(saved)
        extremes = (resp.extremes() if resp is not None
                    else result.data["aux"].iloc[row].get("extremes"))
        point.update(verdict_fields(problem, x, extremes))
        if not is_admissible:
            point["message"] = (f"no admissible evaluation: the design point is the "
                                f"least-violating of the {int(result.ok.sum())} successful ones")
    n = len(table)
    ok = int(full.ok.sum()) if n else 0
    if full.stopping is not None:
        point["stopping"] = finite(full.stopping)
    it = table["iteration"].to_numpy() if n else np.zeros(0, int)
    failed = (table["status"] != "ok").to_numpy() if n else np.zeros(0, bool)
    point["statistics"] = {"evaluations": n, "successful": ok, "failed": n - ok,
                           # the classifier of failures acts after the initial design
                           "failed_initial": int(np.sum(failed & (it <= 0))),
                           "failed_iterations": int(np.sum(failed & (it >= 1))),
                           "iteration_evaluations": int(np.sum(it >= 1)),
                           "admissible": int(adm.sum()),
                           "wall_seconds": finite_or_none(wall_seconds),
                           "median_seconds_per_evaluation":
                               finite_or_none(float(np.median(table["seconds"]))) if n else None,
                           "pareto_size": int(mask.sum()) if n else 0}
    if study.lower_levels:
        point["fidelity"] = {"levels": study.level_names, "design_point_level":
                             study.level_names[-1], "by_level": cost_summary(
                                 table[FIDELITY].to_numpy(int), table["seconds"].to_numpy(float),
                                 study.level_names)}
    classical = out / CLASSICAL_JSON
    if classical.exists():
        point["classical"] = json.loads(classical.read_text())
    write_json(out / DESIGN_POINT_JSON, point)
    return point
