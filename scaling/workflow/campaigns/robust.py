"""Robust design of a study with ``[uncertainty]`` and ``[robust]`` (Sec. 10.2; beyond the
dissertation): the model design whose robust statistic of J (``[robust] statistic``: the
mean, mean + 2 std or 90 % quantile of J_u and of J_T under the study's scatter) is least.

A robust run directory ``OUT`` holds two campaigns:

* ``OUT/nominal/`` -- the study's nominal optimization, exactly as without ``[robust]``
  (its design point propagated under the scatter: the baseline the robust design is
  compared with);
* ``OUT`` itself -- the robust search (:class:`~hypate.scaling.engine.robust.
  RobustBayesianOptimizer`): kriging over (design, uncertain inputs) jointly, fitted on the
  nominal campaign's evaluations (at the nominal inputs) and its own
  ``[robust] initial_samples`` + ``iterations`` (design, inputs) pairs, each stored with its
  inputs (``evaluations.csv`` columns ``input.NAME``), so kill -9 and ``--resume`` work as
  for a nominal run.

The robust design point is the design, among those simulated, whose surrogate robust
statistics are best by the study's design-point rule; it is then verified by propagation
on the simulator (:func:`~hypate.scaling.workflow.vocabulary.uncertainty.propagate_design`, the
``robust`` block of ``design_point.json``), and the nominal optimum's propagation is
reported beside it (``nominal``).
"""
from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from hypate.scaling.engine.coordinates import LogLinearCoordinates
from hypate.scaling.engine.design_point import design_point_index
from hypate.scaling.engine.executors import LOST_AFTER, make_executor
from hypate.scaling.engine.faults import ExecutorError
from hypate.scaling.engine.pareto import non_dominated_mask
from hypate.scaling.engine.propagation import collocation_nodes
from hypate.scaling.engine.robust import RobustBayesianOptimizer
from hypate.scaling.engine.store import Evaluation, EvaluationStore
from hypate.scaling.workflow.campaigns.campaign import preflight, record_campaign, run_lock
from hypate.scaling.workflow.campaigns.integrity import record_outputs
from hypate.scaling.workflow.campaigns.optimizer_settings import optimizer_settings
from hypate.scaling.workflow.campaigns.outputs import (
    design_fields,
    design_point_scatter,
    point_header,
    save_design_response,
)
from hypate.scaling.workflow.campaigns.run import RunOutcome, run_study, surrogate_coordinates
from hypate.scaling.workflow.campaigns.rundir import (
    DESIGN_POINT_JSON,
    EVALUATIONS_CSV,
    ID_COLUMN,
    PARETO_CSV,
    PROTOTYPE_NPZ,
    STORE,
    finite,
    finite_or_none,
    write_csv,
    write_json,
)
from hypate.scaling.workflow.vocabulary.objectives import response_errors
from hypate.scaling.workflow.vocabulary.problem import ScalingProblem, evaluate_rows
from hypate.scaling.workflow.vocabulary.study import Study
from hypate.scaling.workflow.vocabulary.uncertainty import Uncertainty, scattered_configuration
from hypate.solvers.errors import InputError
from pymoo.core.problem import Problem

#: The nominal campaign's folder inside a robust run directory.
NOMINAL_DIR = "nominal"
#: Samples of the uncertain inputs on which the surrogate's statistic is computed.
QUADRATURE_SAMPLES = 64
#: Candidate inputs of a proposal (the most uncertain one is simulated).
INPUT_CANDIDATES = 256
#: Column prefix of a stored evaluation's uncertain inputs.
INPUT_PREFIX = "input."


class JointProblem(Problem):
    """A study's design variables followed by its uncertain inputs (factors, bounded by the
    range of their samples): one evaluation simulates the scattered model
    (:func:`~hypate.scaling.workflow.vocabulary.uncertainty.scattered_configuration`) and compares
    it with the prototype."""

    def __init__(self, problem: ScalingProblem, unc: Uncertainty) -> None:
        self.scaling = problem
        self.unc = unc
        support = np.array([u.support() for u in unc.inputs])
        super().__init__(n_var=problem.n_var + len(unc.inputs), n_obj=problem.n_obj,
                         n_ieq_constr=0, xl=np.r_[problem.xl, support[:, 0]],
                         xu=np.r_[problem.xu, support[:, 1]])

    def composition(self) -> Any:
        """J as a composition of the histories (the scaled model's are compared with the
        nominal prototype's): the study's own (:meth:`ScalingProblem.composition`)."""
        return self.scaling.composition()

    def _evaluate(self, X: np.ndarray, out: dict[str, Any], *args: Any, **kwargs: Any) -> None:
        p, n = self.scaling, self.scaling.n_var
        # the robust statistic of a constraint is not modelled (the engine's robust search
        # takes none): the admissibility columns are dropped here, the nominal campaign
        # enforces them, and the chosen design's rows are reported (design_point.json)
        full: dict[str, Any] = {}
        evaluate_rows(p, [scattered_configuration(p, z[:n], self.unc.names, z[n:])
                          for z in np.atleast_2d(X)], full)
        out["F"], out["aux"] = full["F"], full["aux"]


def robust_inputs(study: Study) -> Uncertainty:
    """The study's ``[uncertainty]``: a robust run has one (refused otherwise)."""
    if study.uncertainty is None:
        raise InputError("robust", "a robust run needs [uncertainty] and [robust]")
    return study.uncertainty


def nominal_study(study: Study) -> Study:
    """The study as a nominal optimization (its scatter propagated at the design point)."""
    return dataclasses.replace(study, uncertainty=dataclasses.replace(robust_inputs(study),
                                                                      optimize=False))


def robust_budget(study: Study) -> int:
    """Evaluations of a robust run: the nominal campaign's and the robust search's."""
    unc = robust_inputs(study)
    iterations = study.iteration_cap if unc.iterations is None else unc.iterations
    return study.budget + unc.initial_samples + iterations


def joint_coordinates(study: Study, problem: ScalingProblem, n_inputs: int
                      ) -> LogLinearCoordinates | None:
    """The study's surrogate coordinates of the design, plain logs of the input factors."""
    coords = surrogate_coordinates(study, problem)
    if coords is None:
        return None
    n = problem.n_var
    A = np.eye(n + n_inputs)
    A[:n, :n] = coords.matrix
    return LogLinearCoordinates(A)


def _prior(nominal: RunOutcome, n_inputs: int) -> list[Evaluation]:
    """The nominal campaign's evaluations as (design, inputs = 1) evaluations."""
    data = nominal.result
    ones = np.ones(n_inputs)
    aux = data.data["aux"] if "aux" in data.data.columns else [{}] * len(data.data)
    return [Evaluation(x=np.r_[x, ones], F=np.asarray(F, float), G=np.zeros(0),
                       status="ok" if ok else "error", aux=a if isinstance(a, dict) else {})
            for x, F, ok, a in zip(data.X, data.F, data.ok, aux)]


def run_robust_study(study: Study, out: str | Path, *, resume: bool = False, workers: int = 1,
                     scheduler: str | None = None, seed: int | None = None,
                     progress: Callable[[int, int, Any], None] | None = None,
                     on_scatter: Callable[[str, int, int], None] | None = None,
                     on_written: Callable[[Path], object] | None = None,
                     lost_after: float = LOST_AFTER, force: bool = False) -> RunOutcome:
    """Run (or resume) a robust study into ``out`` (module docstring).

    ``progress(done, budget, evaluation)`` counts both campaigns' evaluations;
    ``on_scatter(which, done, total)`` the propagations (``which``: "nominal" or
    "robust"). Other parameters as :func:`~hypate.scaling.workflow.campaigns.run.run_study`.
    """
    out = Path(out)
    unc = robust_inputs(study)
    if not unc.optimize:
        raise InputError("robust", "a robust run needs [uncertainty] and [robust]")
    identity, run_seed = preflight(study, out, resume=resume, seed=seed, workers=workers,
                                   scheduler=scheduler, force=force)
    own = robust_budget(study) - study.budget  # the robust search's evaluations
    total, count = [study.budget + own], [0]

    def nominal_progress(done: int, budget: int, evaluation: Evaluation) -> None:
        total[0], count[0] = budget + own, done  # the nominal budget counts its seeds
        if progress is not None:
            progress(done, total[0], evaluation)

    def callback(evaluation: Evaluation) -> None:
        count[0] += 1
        if progress is not None:
            progress(count[0], total[0], evaluation)

    def scatter(which: str) -> Callable[[int, int], None] | None:
        if on_scatter is None:
            return None
        return lambda done, total: on_scatter(which, done, total)

    nominal_dir = out / NOMINAL_DIR
    # the robust store first: a run killed in its nominal campaign resumes
    with run_lock(out), EvaluationStore(out / STORE) as store:
        record_campaign(store, identity, study)
        nominal = run_study(nominal_study(study), nominal_dir, workers=workers,
                            scheduler=scheduler, seed=run_seed, lost_after=lost_after,
                            force=force,
                            resume=resume and (nominal_dir / STORE).is_file(),
                            progress=nominal_progress,
                            on_scatter=scatter("nominal"))
        problem = nominal.problem
        with EvaluationStore(nominal_dir / STORE, read_only=True) as nominal_store:
            nominal_done = len(nominal_store)  # finished: its seeds and budget, all stored
        # a resume counts what is stored (a nominal campaign found complete reported nothing)
        total[0], count[0] = nominal_done + own, nominal_done + len(store)
        problem.prototype_response.save(out / PROTOTYPE_NPZ)
        try:
            executor, close = make_executor(workers, scheduler, lost_after=lost_after)
        except ExecutorError as exc:
            raise InputError(exc.field, exc.message) from None
        ended = False  # an interrupt or error: the evaluations in flight are abandoned
        try:
            result, point = _robust_campaign(study, nominal, store, executor, run_seed,
                                             callback, scatter("robust"), out)
            ended = True
        finally:
            close(abandon=not ended)
        if on_written is not None:
            on_written(out)
        record_outputs(store, out)  # complete: every output written
    return RunOutcome(directory=out, result=result, design_point=point, problem=problem)


def _robust_campaign(study: Study, nominal: RunOutcome, store: EvaluationStore,
                     executor: Any, run_seed: int, callback: Callable[[Evaluation], None],
                     on_scatter: Callable[[int, int], None] | None, out: Path):
    """The robust search on the joint problem, then the outputs."""
    unc, problem = robust_inputs(study), nominal.problem
    joint = JointProblem(problem, unc)
    n_inputs = len(unc.inputs)
    settings, context = optimizer_settings(
        study, problem, executor=executor, store=store, seed=run_seed, callback=callback,
        robust=True, coordinates=joint_coordinates(study, problem, n_inputs))
    optimizer = RobustBayesianOptimizer(
        joint, settings, context, n_design=problem.n_var,
        samples=collocation_nodes(unc.inputs, QUADRATURE_SAMPLES, run_seed),
        candidates=collocation_nodes(unc.inputs, INPUT_CANDIDATES, run_seed + 1),
        statistic=unc.statistic, prior=_prior(nominal, n_inputs))
    t0 = time.perf_counter()
    result = optimizer.run()
    wall = time.perf_counter() - t0
    point = write_robust_outputs(study, problem, optimizer, store, nominal, out, wall,
                                 on_scatter)
    return result, point


def verified_statistic(block: dict[str, Any] | None) -> float:
    """The statistic of max(J_u, J_T) of a propagation block (infinite when it failed)."""
    if block is None:
        return float("inf")
    try:
        value = block["objectives"]["J_max"]["robust"]
    except (KeyError, TypeError):
        return float("inf")
    return float("inf") if value is None else float(value)


def _evaluations_frame(study: Study, optimizer: RobustBayesianOptimizer,
                       records: list[Evaluation]) -> pd.DataFrame:
    names = study.spec.names + [INPUT_PREFIX + n for n in robust_inputs(study).names]
    X = np.array([r.x for r in records], float).reshape(len(records), len(names))
    df = pd.DataFrame(X, columns=names)
    for j, o in enumerate(study.spec.objectives):
        df[o] = [float(r.F[j]) for r in records]
    df["status"] = [r.status for r in records]
    df["message"] = [r.message for r in records]
    df["iteration"] = [r.iteration for r in records]
    df["seconds"] = [r.seconds for r in records]
    df.insert(0, ID_COLUMN, np.arange(len(df)))
    return df


def _write_csv(df: pd.DataFrame, path: Path) -> None:
    write_csv(path, df)


def write_robust_outputs(study: Study, problem: ScalingProblem,
                         optimizer: RobustBayesianOptimizer, store: EvaluationStore,
                         nominal: RunOutcome, out: Path, wall_seconds: float,
                         on_scatter: Callable[[int, int], None] | None = None
                         ) -> dict[str, Any]:
    """evaluations.csv (the robust search's pairs), pareto.csv (the simulated designs with
    their surrogate robust statistics, the non-dominated ones), design_point.json (the
    robust design point, its ``robust`` propagation and the ``nominal`` optimum's beside it)
    and design_point.npz (the robust design's nominal response)."""
    unc = robust_inputs(study)
    records = store.load()
    _write_csv(_evaluations_frame(study, optimizer, records), out / EVALUATIONS_CSV)
    designs, R, S = optimizer.robust_estimates(records)
    objectives = study.spec.objectives
    stat_names = [f"{unc.statistic}({o})" for o in objectives]
    finite_rows = np.flatnonzero(np.all(np.isfinite(R), axis=1))
    k = int(finite_rows[design_point_index(R[finite_rows], study.optimizer.design_point,
                                           study.optimizer.weights)])
    front = pd.DataFrame(designs, columns=study.spec.names)
    for j, name in enumerate(stat_names):
        front[name] = R[:, j]
    front = front.iloc[finite_rows[non_dominated_mask(R[finite_rows])]]
    _write_csv(front.sort_values(stat_names[0], kind="stable"), out / PARETO_CSV)
    # the surrogate's robust optimum, verified on the simulator; the nominal optimum
    # (verified in its own campaign) is the fallback when it verifies better
    candidate = design_point_scatter(study, problem, designs[k], store, on_scatter)
    npoint = nominal.design_point
    x_nominal = (None if npoint.get("design") is None else
                 np.array([npoint["design"][n] for n in study.spec.names]))
    chosen = "robust search"
    x, block = designs[k], candidate
    if x_nominal is not None and verified_statistic(npoint.get("scatter")) < \
            verified_statistic(candidate):
        chosen = "nominal optimum (the robust search's best design verified worse)"
        x, block = x_nominal, npoint["scatter"]
    point = {**point_header(study), **design_fields(study, problem, x), "chosen": chosen}
    resp, saved = save_design_response(problem, x, out)
    point["objectives"] = None
    if resp is not None:
        err = response_errors(resp, problem.prototype_response, study.spec.projection)
        point["objectives"] = {o: float(err[o]) for o in objectives}
    point.update(saved)
    point["robust"] = block
    point["robust_search"] = {
        "design": problem.design(designs[k]), "robust": candidate,
        "surrogate": {"statistic": unc.statistic, "transform": study.optimizer.transform,
                      "objectives": {o: {"predicted": finite_or_none(float(R[k, j])),
                                         "std": finite_or_none(float(S[k, j]))}
                                     for j, o in enumerate(objectives)}}}
    point["nominal"] = {"directory": NOMINAL_DIR, "design": npoint.get("design"),
                        "objectives": npoint.get("objectives"),
                        "robust": npoint.get("scatter")}
    n = len(records)
    ok = sum(r.ok for r in records)
    n_nominal = int(npoint.get("statistics", {}).get("evaluations", 0))
    runs = [int(b.get("samples", 0)) for b in (candidate, point["nominal"]["robust"]) if b]
    point["statistics"] = {
        "evaluations": n, "successful": ok, "failed": n - ok,
        "nominal_evaluations": n_nominal, "propagation_runs": sum(runs),
        "simulator_runs": n + n_nominal + sum(runs),
        "wall_seconds": finite_or_none(wall_seconds),
        "median_seconds_per_evaluation":
            finite_or_none(float(np.median([r.seconds for r in records]))) if n else None,
        "pareto_size": len(front)}
    point = finite(point)
    write_json(out / DESIGN_POINT_JSON, point)
    return point


__all__ = [
    "INPUT_PREFIX",
    "NOMINAL_DIR",
    "JointProblem",
    "nominal_study",
    "robust_budget",
    "run_robust_study",
    "write_robust_outputs",
]
