"""Running a study: prototype, classical baseline, Bayesian optimization, outputs.

Outputs in the run directory (public names):

* ``evaluations.sqlite`` -- the crash-safe store (every finished evaluation committed before
  the next proposal; ``--resume`` continues from it);
* ``evaluations.csv`` -- ``id`` (the 0-based row number in the store order, the number the
  report cites), every design with its variables by name, objectives, status, message,
  warnings (empty, or a JSON list of ``"Category: message (N times)"`` raised during the
  evaluation) and wall time;
* ``pareto.csv`` -- the Pareto set (or the best designs of a single-objective study);
* ``design_point.json`` -- ``design`` (name -> value), ``objectives`` (name -> value),
  ``similarity`` (list of ``{"name", "prototype", "model", "relative_difference"}``),
  ``active_constraints`` (list of names), ``rule`` (the study's ``[optimizer] design_point``
  rule that chose it), plus the classical baseline and run statistics;
* ``prototype.npz`` / ``design_point.npz`` -- the prototype's and the design point's
  responses (:class:`hypate.solvers.coupling.response.Response`).

A multi-fidelity study (``[[fidelity]]``, :mod:`hypate.scaling.workflow.vocabulary.fidelity`) adds
the ``fidelity`` / ``fidelity_name`` columns; its front and design point are the top level's.

One run's sequence (baseline, seeds, optimizer) reads top to bottom here; the outputs it ends
with are written by :mod:`hypate.scaling.workflow.campaigns.outputs`.
"""
from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from hypate.scaling.engine.coordinates import LogLinearCoordinates
from hypate.scaling.engine.design_point import rank_designs
from hypate.scaling.engine.executors import LOST_AFTER, make_executor, run_batch
from hypate.scaling.engine.faults import ExecutorError
from hypate.scaling.engine.optimizer import BayesianOptimizer
from hypate.scaling.engine.problem import (
    Outcome,
    evaluate_design,
    project_cheap,
    recorded_warnings,
    summarize_warnings,
)
from hypate.scaling.engine.result import OptimizationResult
from hypate.scaling.engine.store import Evaluation, EvaluationStore
from hypate.scaling.workflow.campaigns.campaign import preflight, record_campaign, run_lock
from hypate.scaling.workflow.campaigns.integrity import record_outputs
from hypate.scaling.workflow.campaigns.optimizer_settings import optimizer_settings
from hypate.scaling.workflow.campaigns.outputs import write_outputs
from hypate.scaling.workflow.campaigns.rundir import (
    CLASSICAL_JSON,
    EVALUATIONS_CSV,
    PARETO_CSV,
    PROTOTYPE_NPZ,
    PROTOTYPE_WARNINGS,
    STORE,
    finite_or_none,
    write_json,
)
from hypate.scaling.workflow.campaigns.sessions import (
    begin_session,
    end_session,
    sessions_wall_seconds,
)
from hypate.scaling.workflow.vocabulary.classical import (
    classical_scaling,
    design_vector,
    similarity_basis,
    similarity_exponents,
)
from hypate.scaling.workflow.vocabulary.configuration import (
    Configuration,
    nominal_values,
    with_choice,
)
from hypate.scaling.workflow.vocabulary.fidelity import (
    FidelityProblem,
    fidelity_optimizer,
    fidelity_problem,
)
from hypate.scaling.workflow.vocabulary.problem import DesignVector, ScalingProblem
from hypate.scaling.workflow.vocabulary.study import Study
from hypate.scaling.workflow.vocabulary.variables import schedule_point, variable_unit
from hypate.solvers.coupling.response import Response
from hypate.solvers.errors import InputError

#: Text columns of evaluations.csv (an empty cell reads back as "").
TEXT_COLUMNS = ("status", "message", "warnings")
#: Parameters matched by the classical baseline (Eqs. 9.1, 6.3), per study kind.
CLASSICAL_MATCH = {"aeroelastic": ["h/L", "lambda_F", "DeltaT_NTx_L2/Dxx"],
                   "quasi_steady": ["h/L", "lambda_F", "Re_0", "Bi_F"]}


@dataclass
class RunOutcome:
    """What a finished (or resumed) run produced.

    ``prototype_warnings``: the warnings of this run's prototype simulation
    (:func:`hypate.scaling.engine.problem.summarize_warnings`; empty when the prototype's
    response was given); each evaluation's are on its row (``result.data["warnings"]``).
    """

    directory: Path
    result: OptimizationResult
    design_point: dict[str, Any]
    problem: ScalingProblem
    prototype_warnings: tuple[str, ...] = ()

    @property
    def evaluations(self) -> pd.DataFrame:
        """Every evaluation of the run, as ``evaluations.csv`` holds it.

        Returns
        -------
        pandas.DataFrame
            One row per evaluation in the store order: ``id`` (the evaluation number the
            report cites), the design variables by name (``M``, ``p0``, ``T0``, ``L_le``,
            ``h``, ...), the objectives by name (``J_u``, ``J_T``), then ``status``,
            ``message``, ``warnings``, ``seconds``, ``iteration`` and the admissibility
            columns. ``attrs["units"]`` maps each variable and objective column to its SI
            unit (``"-"``: dimensionless).
        """
        return run_table(self.directory / EVALUATIONS_CSV, self.problem.spec.names,
                         self.problem.spec.objectives)

    @property
    def pareto(self) -> pd.DataFrame:
        """The run's Pareto set, as ``pareto.csv`` holds it.

        Returns
        -------
        pandas.DataFrame
            The feasible non-dominated evaluations sorted by the first objective (for one
            objective: the ten best), with the columns of :attr:`evaluations`; each row is
            its evaluation's row there (the same ``id``, design and objectives).
        """
        return run_table(self.directory / PARETO_CSV, self.problem.spec.names,
                         self.problem.spec.objectives)


def run_table(path: Path, variables: Sequence[str], objectives: Sequence[str]
              ) -> pd.DataFrame:
    """``evaluations.csv`` or ``pareto.csv`` of a run directory as a DataFrame: empty text
    cells (``message``, ``warnings``) as ``""``; ``attrs["units"]`` the unit of each of the
    ``variables`` (:func:`~hypate.scaling.workflow.vocabulary.variables.variable_unit`) and
    ``objectives`` (``"-"``: the similarity errors are nondimensional)."""
    df = pd.read_csv(path)
    for col in TEXT_COLUMNS:
        if col in df.columns:
            df[col] = ["" if pd.isna(v) else str(v) for v in df[col]]
    df.attrs["units"] = {**{n: variable_unit(n) for n in variables},
                         **{o: "-" for o in objectives}}
    return df


def classical_design(study: Study, template: Configuration, names: Sequence[str],
                     box: np.ndarray) -> dict[str, Any]:
    """The best classical (GP) design of one model template over the variables ``names``
    (bounds ``box`` (n, 2)): :meth:`ClassicalResult.to_dict` plus its point ``x`` in the
    order of ``names``, or ``{"status": "failed: ...", "design": None}``."""
    spec = study.spec
    bounds = {n: (float(lo), float(hi)) for n, (lo, hi) in zip(names, box)}
    bounds.update({k: (v, v) for k, v in spec.fixed.items() if v > 0})
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = classical_scaling(spec.prototype, template, bounds, CLASSICAL_MATCH[spec.kind],
                                    objective="max")
    except (InputError, ValueError, ArithmeticError) as exc:
        return {"status": f"failed: {exc}", "design": None}
    out = res.to_dict()
    out["x"] = res.point(names, defaults=spec.fixed, bounds=box).tolist()
    return out


def classical_baseline(study: Study, problem: ScalingProblem) -> dict[str, Any] | None:
    """The left prong: best classical (GP) design within the study's bounds.

    With categorical variables, one classical design per combination of their values (the
    matched parameters hold material constants): ``by_material`` maps each combination's
    names (the material's name; several joined by ", ") to its record (``x`` the full
    design vector, ``design`` with the levels, each variable's value name under its own
    name), and the top level is the first combination's until the seeds' objectives pick
    the best (:func:`_evaluate_seeds`).
    """
    spec = study.spec
    box = np.c_[problem.xl, problem.xu]
    cat = problem.categorical
    if cat is None:
        return classical_design(study, spec.model, spec.names, box)
    names = [n for n in spec.names if n not in spec.levels]
    by_material: dict[str, dict[str, Any]] = {}
    for level in range(cat.count):
        template, picked = spec.model, {}
        for name, k in zip(spec.categorical_names, cat.levels_of(level)):
            value_name, value = spec.levels[name][int(k)]
            template, picked[name] = with_choice(template, name, value), value_name
        rec = classical_design(study, template, names,
                               np.delete(box, list(cat.indices), axis=0))
        if rec.get("x") is not None:
            rec["x"] = cat.insert(rec["x"], level)[0].tolist()
            rec["design"].update(zip(spec.categorical_names, map(float, cat.levels_of(level))))
        by_material[", ".join(picked.values())] = {**rec, **picked}
    return {**next(iter(by_material.values())), "by_material": by_material}


def surrogate_coordinates(study: Study, problem: ScalingProblem
                          ) -> LogLinearCoordinates | None:
    """The surrogates' input coordinates of ``[optimizer] coordinates``.

    ``"similarity"``: the logs of the classically matched parameters (:data:`CLASSICAL_MATCH`,
    exponents at the centre of the log box), completed by their null space, so that the
    valleys ``Pi_i = Pi_i^p`` of the objective are aligned with the kriging axes.

    Categorical variables are left out: these are the coordinates of the continuous
    variables (the engine's one-hot coordinates add the levels, engine.mixed).
    """
    kind = study.optimizer.coordinates
    if kind == "design":
        return None
    spec = study.spec
    keep = [i for i, n in enumerate(spec.names) if n not in spec.levels]
    names = [spec.names[i] for i in keep]
    lo, hi = np.asarray(problem.xl, float)[keep], np.asarray(problem.xu, float)[keep]
    if not np.all(lo > 0.0):
        bad = [n for n, v in zip(names, lo) if not v > 0.0]
        raise InputError("optimizer.coordinates", f"{kind!r} needs positive lower bounds; "
                         f"not so for {', '.join(bad)}")
    if kind == "log":
        return LogLinearCoordinates.log(len(lo))
    centre = dict(zip(names, np.sqrt(lo * hi).tolist()))
    design = {**{k: v for k, v in spec.fixed.items() if v > 0}, **centre}
    try:
        E = similarity_exponents(spec.model, design, names, CLASSICAL_MATCH[spec.kind])
    except (ValueError, ArithmeticError) as exc:
        raise InputError("optimizer.coordinates", f"similarity exponents: {exc}") from None
    return LogLinearCoordinates(similarity_basis(E))


#: Seeds taken from each earlier run given to :func:`seeds_from_runs`.
SEEDS_PER_RUN = 10


def _template_values(study: Study) -> dict[str, float]:
    """Values the model template implies for variables a study may not optimize (its rows'
    read-back, :func:`nominal_values`; no heater: ``T_rad`` 0, the nearest bound)."""
    vals = {"T_rad": 0.0, **nominal_values(study.spec.model)}
    vals.update(study.spec.fixed)
    for name in study.spec.names:  # a heater schedule's points: the constant heater's value
        if (point := schedule_point(name)) is not None and point[0] in vals:
            vals[name] = vals[point[0]]
    return vals


def seeds_from_runs(study: Study, problem: ScalingProblem, run_dirs: Sequence[str | Path],
                    k: int = SEEDS_PER_RUN) -> list[tuple[np.ndarray, str]]:
    """The ``k`` best designs of earlier runs as seeds (``hypate run --seed-from``).

    A richer strategy starts where a simpler one ended (Sec. 9.2.3: Case 2 adds the radiant
    heater to Case 1's variables): each design keeps the values of the variables the runs
    share; a variable the earlier run did not optimize takes the model template's value
    (emissivity, no heater, no external pressure, template size), and every point is
    clipped to the bounds and projected onto the cheap constraints. A heater schedule's
    control points ``T_rad[k]`` missing from a run that optimized a constant ``T_rad`` all
    take its value (the constant heater as a flat schedule). "Best" is the design-point
    criterion: the smallest max over objectives of successful evaluations.
    """
    names = list(problem.spec.names)
    bounds = np.c_[problem.xl, problem.xu]
    defaults = _template_values(study)
    out: list[tuple[np.ndarray, str]] = []
    for run_dir in run_dirs:
        csv = Path(run_dir) / EVALUATIONS_CSV
        if not csv.exists():
            raise InputError("seed_runs", f"{run_dir} holds no evaluations.csv")
        df = pd.read_csv(csv)
        objectives = [c for c in df.columns if c.startswith("J_")]
        if not objectives:
            raise InputError("seed_runs", f"{csv} has no objective columns (J_...)")
        missing = [n for n in names if n not in df.columns and n not in defaults]
        if missing:
            raise InputError("seed_runs", f"{run_dir} does not set {', '.join(missing)} "
                             "and the model template has no value for it")
        df = df[(df["status"] == "ok") & np.isfinite(df[objectives]).all(axis=1)]
        df = df.iloc[rank_designs(df[objectives].to_numpy(float))]
        for idx, row in df.head(k).iterrows():
            design = {n: float(row[n]) for n in names if n in df.columns}
            design.update({n: float(row[p[0]]) for n in names if n not in design
                           and (p := schedule_point(n)) is not None and p[0] in df.columns})
            x = design_vector(design, names, defaults=defaults, bounds=bounds)
            out.append((project_cheap(problem, x),
                        f"seed: {Path(run_dir).name} evaluation {idx}"))
    return out


#: Reason of the classical baseline's seed (a material's name follows for a categorical one).
CLASSICAL_SEED = "seed: classical baseline"


def _classical_records(classical: dict[str, Any] | None) -> list[tuple[str, dict[str, Any]]]:
    """(seed reason, record) of each classical design: one, or one per material."""
    if not classical:
        return []
    by = classical.get("by_material")
    if by is None:
        return [(CLASSICAL_SEED, classical)]
    return [(f"{CLASSICAL_SEED} ({name})", rec) for name, rec in by.items()]


def _seed_designs(study: Study, problem: ScalingProblem, classical: dict[str, Any] | None,
                  seeds: Sequence[tuple[DesignVector, str]] | None
                  ) -> list[tuple[np.ndarray, str]]:
    """Classical baseline first (if enabled; one per material of a categorical one), then
    the caller's seeds (duplicates dropped)."""
    out: list[tuple[np.ndarray, str]] = []
    if study.optimizer.classical_seed:
        # the GP design matches monomial similarity parameters, not the Eq. (9.7) equality
        out += [(project_cheap(problem, rec["x"]), why)
                for why, rec in _classical_records(classical) if rec.get("x") is not None]
    span = np.asarray(problem.xu, float) - np.asarray(problem.xl, float)
    for given, why in seeds or ():
        x = project_cheap(problem, np.asarray(given, float))
        if any(np.max(np.abs(x - y) / span) < 1e-9 for y, _ in out):
            continue
        out.append((x, why))
    return out


def _evaluate_seeds(problem: ScalingProblem | FidelityProblem, study: Study, store: EvaluationStore,
                    seed_list: Sequence[tuple[np.ndarray, str]],
                    classical: dict[str, Any] | None, run_seed: int,
                    callback: Callable[[Evaluation], None], executor: Any = None) -> None:
    """The seeds as iteration -1 (those not stored yet), on the run's ``executor`` like the
    optimizer's batches (:func:`~hypate.scaling.engine.executors.run_batch`: a sweep
    point's recycled designs take all the workers) and committed in seed order as each
    finishes (crash-safe: a resume evaluates the missing ones); the classical baseline's
    objectives are noted in ``classical`` (per material, the best material's record then
    heading it)."""
    stored = {r.batch_index: r for r in store.load() if r.iteration == -1}
    todo = [i for i in range(len(seed_list)) if i not in stored]
    n_obj, n_constr = int(problem.n_obj), int(problem.n_ieq_constr) + int(problem.n_eq_constr)

    def failure(message: str, seconds: float) -> Outcome:
        return Outcome.failure(n_obj, n_constr, "error", message, seconds)

    calls = [(problem, seed_list[i][0], study.optimizer.timeout) for i in todo]
    for j, res in run_batch(executor, evaluate_design, calls, on_failure=failure):
        i = todo[j]
        x, why = seed_list[i]
        ev = Evaluation.from_outcome(x, res, iteration=-1, batch_index=i, seed=run_seed)
        ev = dataclasses.replace(ev, message=f"{why}; {res.message}" if res.message else why)
        store.append(ev)
        callback(ev)
        stored[i] = ev
    records = dict(_classical_records(classical))
    for i, (_, why) in enumerate(seed_list):
        if why in records:
            ev = stored[i]
            records[why]["objectives"] = {o: finite_or_none(f) for o, f in
                                          zip(study.spec.objectives, ev.F)}
            records[why]["evaluation_status"] = ev.status
    by = (classical or {}).get("by_material")
    scored = [r for r in (by or {}).values() if r.get("evaluation_status") == "ok"]
    if scored:  # the material whose classical design is best (the design-point rule)
        assert classical is not None  # its by_material records were scored
        best = scored[int(rank_designs(np.array([list(r["objectives"].values())
                                                 for r in scored], float))[0])]
        classical.update({**best, "by_material": by})


def run_study(study: Study, out: str | Path, *, resume: bool = False, workers: int = 1,
              scheduler: str | None = None, seed: int | None = None,
              progress: Callable[[int, int, Any], None] | None = None,
              seeds: Sequence[tuple[DesignVector, str]] | None = None,
              prototype_response: Response | None = None,
              seed_runs: Sequence[str | Path] = (),
              on_written: Callable[[Path], object] | None = None,
              lost_after: float = LOST_AFTER,
              on_warnings: Callable[[str, tuple[str, ...]], None] | None = None,
              on_scatter: Callable[[int, int], None] | None = None,
              force: bool = False) -> RunOutcome:
    """Run (or resume) a study into ``out``.

    ``on_written(out)`` is called once the outputs are written: the CLI and ``hypate.run_study``
    write the report there (the workflow does not know the report).

    Parameters
    ----------
    study : Study
    out : path
        Run directory (created). Without ``resume`` it must not hold a run already.
    resume : bool
        Continue from ``out/evaluations.sqlite`` (nothing finished is re-evaluated). Only
        the same campaign resumes (:mod:`hypate.scaling.workflow.campaigns.campaign`): another
        study, case file, seed or package version is refused before anything is touched.
    workers : int
        Local process pool size (1 = in-process).
    scheduler : str, optional
        Address of a Dask scheduler (``tcp://host:port``, ``tls://host:port``), or
        ``local:N`` for a cluster of N workers on this machine.
    seed : int, optional
        Overrides the study's optimizer seed (on resume: the stored seed when omitted).
    progress : callable, optional
        ``progress(done, budget, evaluation)`` after each committed evaluation (the
        :class:`hypate.scaling.engine.store.Evaluation` just stored); ``done`` counts the
        store's evaluations, a resumed run's earlier ones too.
    seeds : sequence of (x, reason), optional
        Extra designs evaluated before the initial sample and stored with it as
        iteration -1 (recycled samples of Sec. 9.2.4, a refined law's prediction); the
        classical baseline comes first. They are evaluated on the run's workers and each
        is committed once it and the seeds before it are finished, so an interrupted run
        resumes without evaluating them again.
    prototype_response : Response, optional
        The prototype's response if already simulated.
    seed_runs : sequence of paths
        Earlier run directories whose best designs seed this run
        (:func:`seeds_from_runs`), after ``seeds``.
    lost_after : float
        Seconds after which a cluster without a reachable scheduler or without a worker is
        lost (:class:`~hypate.scaling.engine.faults.InfrastructureError`; the finished
        evaluations are stored and a resume evaluates the rest).
    on_warnings : callable, optional
        ``on_warnings("prototype", entries)`` once the prototype's simulation recorded
        warnings (they are not printed; also stored in the store's metadata and on the
        :class:`RunOutcome`). Each evaluation records its own (``Evaluation.warnings``,
        the ``warnings`` column), handed to ``progress`` with it.
    on_scatter : callable, optional
        ``on_scatter(done, total)`` while a study with ``[uncertainty]`` propagates its
        scatter at the design point (:func:`design_point_scatter`).
    force : bool
        Run even when the simulations' estimated memory exceeds what this machine has
        available (:func:`~hypate.scaling.workflow.campaigns.resources.check_resources`).
    """
    out = Path(out)
    store_path = out / STORE
    # every check that needs no simulation, before anything is written
    identity, run_seed = preflight(study, out, resume=resume, seed=seed, workers=workers,
                                   scheduler=scheduler, force=force)
    problem = ScalingProblem(study.spec, prototype_response=prototype_response)
    levels = fidelity_problem(study, problem)  # None: a single-fidelity study
    coordinates = surrogate_coordinates(study, problem)
    if seed_runs:
        seeds = [*(seeds or ()), *seeds_from_runs(study, problem, seed_runs)]
    try:
        # connected (and its scheduler reachable) before any work
        executor, close = make_executor(workers, scheduler, lost_after=lost_after)
    except ExecutorError as exc:
        raise InputError(exc.field, exc.message) from None
    ended = False  # an interrupt or error: the workers' evaluations in flight are abandoned
    try:
        with recorded_warnings() as caught:  # attributed to the prototype, not printed
            proto = problem.prototype_response  # simulated once, before any worker starts
            for low in (levels.levels[:-1] if levels is not None else ()):
                low.prototype_response  # noqa: B018 - each level's own prototype, cached
        prototype_warnings = summarize_warnings(caught)
        if prototype_warnings and on_warnings is not None:
            on_warnings("prototype", prototype_warnings)
        with run_lock(out), EvaluationStore(store_path) as store:
            record_campaign(store, identity, study)
            session = begin_session(store)
            if prototype_response is None:  # this run simulated it
                store.set_meta(PROTOTYPE_WARNINGS, list(prototype_warnings), replace=True)
            proto.save(out / PROTOTYPE_NPZ)
            classical = classical_baseline(study, problem)
            seed_list = _seed_designs(study, problem, classical, seeds)
            budget = study.budget + len(seed_list)
            count = [len(store)]  # a resume counts the earlier sessions' evaluations

            def callback(evaluation: Evaluation) -> None:
                count[0] += 1
                if progress is not None:
                    progress(count[0], budget, evaluation)

            if levels is not None:  # seeds are full-fidelity evaluations
                top = float(len(levels.levels) - 1)
                seed_list = [(np.r_[x, top], why) for x, why in seed_list]
            _evaluate_seeds(levels or problem, study, store, seed_list, classical, run_seed,
                            callback, executor)
            write_json(out / CLASSICAL_JSON, classical or {"status": "not available"})
            settings, context = optimizer_settings(study, problem, executor=executor,
                                                   store=store, seed=run_seed,
                                                   callback=callback, coordinates=coordinates)
            optimizer = (BayesianOptimizer(problem, settings, context) if levels is None
                         else fidelity_optimizer(study, levels, settings, context))
            result = optimizer.run()
            end_session(store, session)
            point = write_outputs(study, problem, result, out,
                                  wall_seconds=sessions_wall_seconds(store),
                                  optimizer=optimizer, store=store, on_scatter=on_scatter)
            if on_written is not None:
                on_written(out)
            record_outputs(store, out)  # complete: every output written
        ended = True
    finally:
        close(abandon=not ended)
    return RunOutcome(directory=out, result=result, design_point=point, problem=problem,
                      prototype_warnings=prototype_warnings)
