"""Running a study: prototype, classical baseline, Bayesian optimization, outputs.

Outputs in the run directory (public names):

* ``evaluations.sqlite`` -- the crash-safe store (every finished evaluation committed before
  the next proposal; ``--resume`` continues from it);
* ``evaluations.csv`` -- every design with its variables by name, objectives, status,
  message and wall time;
* ``pareto.csv`` -- the Pareto set (or the best designs of a single-objective study);
* ``design_point.json`` -- ``design`` (name -> value), ``objectives`` (name -> value),
  ``similarity`` (list of ``{"name", "prototype", "model", "relative_difference"}``),
  ``active_constraints`` (list of names), plus the classical baseline and run statistics;
* ``prototype.npz`` / ``design_point.npz`` -- the prototype's and the design point's
  responses (:class:`hypate.solvers.coupling.response.Response`).
"""
from __future__ import annotations

import dataclasses
import json
import math
import time
import warnings
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from hypate.scaling.engine.coordinates import LogLinearCoordinates
from hypate.scaling.engine.optimizer import BayesianOptimizer
from hypate.scaling.engine.problem import evaluate_design, project_cheap
from hypate.scaling.engine.result import OptimizationResult
from hypate.scaling.engine.settings import OptimizerSettings
from hypate.scaling.engine.store import Evaluation, EvaluationStore
from hypate.scaling.workflow.classical import (
    classical_scaling,
    design_vector,
    similarity_basis,
    similarity_exponents,
)
from hypate.scaling.workflow.laws import (
    ANALYTICAL_EXPONENTS,
    analytical_laws,
    fit_laws,
    point_from_record,
    predicted_design,
)
from hypate.scaling.workflow.problem import ScalingProblem
from hypate.scaling.workflow.study import Study, study_at, study_data, sweep_points
from hypate.solvers.coupling.response import Response
from hypate.solvers.errors import InputError

#: Parameters matched by the classical baseline (Eqs. 9.1, 6.3), per study kind.
CLASSICAL_MATCH = {"aeroelastic": ["h/L", "lambda_F", "DeltaT_NTx_L2/Dxx"],
                   "quasi_steady": ["h/L", "lambda_F", "Re_0", "Bi_F"]}
STORE_NAME = "evaluations.sqlite"


@dataclass
class RunOutcome:
    """What a finished (or resumed) run produced."""

    directory: Path
    result: OptimizationResult
    design_point: dict[str, Any]
    problem: ScalingProblem


def _json_default(obj: Any) -> Any:
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    raise TypeError(f"not JSON serializable: {type(obj).__name__}")


def _write_json(path: Path, data: dict[str, Any]) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(data, indent=2, default=_json_default, allow_nan=False))
    tmp.replace(path)


def _finite(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def classical_baseline(study: Study, problem: ScalingProblem) -> dict[str, Any] | None:
    """The left prong: best classical (GP) design within the study's bounds, or None."""
    spec = study.spec
    bounds = {v.name: (v.lower, v.upper) for v in spec.variables}
    bounds.update({k: (v, v) for k, v in spec.fixed.items() if v > 0})
    match = CLASSICAL_MATCH[spec.simulation.kind]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = classical_scaling(spec.prototype, spec.model, bounds, match, objective="max")
    except (InputError, ValueError, ArithmeticError) as exc:
        return {"status": f"failed: {exc}", "design": None}
    x = res.point(spec.names, defaults=spec.fixed,
                  bounds=np.c_[problem.xl, problem.xu])
    out = res.to_dict()
    out["x"] = x.tolist()
    return out


def surrogate_coordinates(study: Study, problem: ScalingProblem
                          ) -> LogLinearCoordinates | None:
    """The surrogates' input coordinates of ``[optimizer] coordinates``.

    ``"similarity"``: the logs of the classically matched parameters (:data:`CLASSICAL_MATCH`,
    exponents at the centre of the log box), completed by their null space, so that the
    valleys ``Pi_i = Pi_i^p`` of the objective are aligned with the kriging axes.
    """
    kind = study.optimizer.coordinates
    if kind == "design":
        return None
    lo, hi = np.asarray(problem.xl, float), np.asarray(problem.xu, float)
    if not np.all(lo > 0.0):
        bad = [n for n, v in zip(problem.spec.names, lo) if not v > 0.0]
        raise InputError("optimizer.coordinates", f"{kind!r} needs positive lower bounds; "
                         f"not so for {', '.join(bad)}")
    if kind == "log":
        return LogLinearCoordinates.log(len(lo))
    spec = study.spec
    names = list(spec.names)
    centre = dict(zip(names, np.sqrt(lo * hi).tolist()))
    design = {**{k: v for k, v in spec.fixed.items() if v > 0}, **centre}
    try:
        E = similarity_exponents(spec.model, design, names, CLASSICAL_MATCH[spec.simulation.kind])
    except (ValueError, ArithmeticError) as exc:
        raise InputError("optimizer.coordinates", f"similarity exponents: {exc}") from None
    return LogLinearCoordinates(similarity_basis(E))


def make_executor(workers: int, scheduler: str | None) -> tuple[Any, Callable[[], None]]:
    """A concurrent.futures-style executor and its closer (None: in-process)."""
    if scheduler:
        try:
            from distributed import Client
        except ImportError:
            raise InputError("--scheduler", "needs the cluster extra: pip install -e "
                             "\".[cluster]\"") from None
        try:
            client = Client(scheduler, timeout=20)
        except (OSError, TimeoutError) as exc:
            raise InputError("--scheduler", f"cannot reach {scheduler}: {exc}") from None
        return client, client.close
    if workers > 1:
        pool = ResilientProcessPool(workers)
        return pool, pool.shutdown
    return None, lambda: None


class ResilientProcessPool:
    """A process pool in which a worker that dies costs only its own evaluation.

    ``concurrent.futures.ProcessPoolExecutor`` breaks as a whole when one worker dies: every
    pending future fails with ``BrokenProcessPool`` and later submissions are refused. Here
    the pool is restarted, and each future whose pool broke is re-submitted once, alone,
    when its result is asked for (the optimizer asks in batch order): an innocent evaluation
    then finishes normally, while the evaluation that kills its worker breaks the pool a
    second time and is recorded as failed.
    """

    def __init__(self, workers: int) -> None:
        self.workers = int(workers)
        self._pool = ProcessPoolExecutor(max_workers=self.workers)

    def _restart(self) -> None:
        self._pool.shutdown(wait=False, cancel_futures=True)
        self._pool = ProcessPoolExecutor(max_workers=self.workers)

    def _submit(self, fn: Callable[..., Any], args: tuple) -> Any:
        try:
            return self._pool.submit(fn, *args)
        except BrokenProcessPool:
            self._restart()
            return self._pool.submit(fn, *args)

    def submit(self, fn: Callable[..., Any], *args: Any) -> _RetryFuture:
        return _RetryFuture(self, fn, args)

    def shutdown(self) -> None:
        self._pool.shutdown(cancel_futures=True)


class _RetryFuture:
    """Future of :class:`ResilientProcessPool`: one re-submission after a broken pool."""

    def __init__(self, owner: ResilientProcessPool, fn: Callable[..., Any], args: tuple) -> None:
        self._owner, self._fn, self._args = owner, fn, args
        self._future = owner._submit(fn, args)
        self._retried = False

    def result(self, timeout: float | None = None) -> Any:
        try:
            return self._future.result(timeout)
        except BrokenProcessPool:
            if self._retried:
                raise
            self._retried = True
            self._future = self._owner._submit(self._fn, self._args)
            return self._future.result(timeout)


#: Seeds taken from each earlier run given to :func:`seeds_from_runs`.
SEEDS_PER_RUN = 10


def _template_values(study: Study) -> dict[str, float]:
    """Values the model template implies for variables a study may not optimize."""
    m = study.spec.model
    vals = {"L": m.panel.length, "L_le": m.panel.leading_edge_length,
            "h": m.panel.thickness, "emissivity": m.panel.emissivity,
            "T_rad": m.radiation_temperature or 0.0,  # no heater: nearest bound
            "p_ext": m.external_pressure}
    if m.delta_T is not None:
        vals["delta_T"] = m.delta_T
    vals.update(study.spec.fixed)
    return vals


def seeds_from_runs(study: Study, problem: ScalingProblem, run_dirs: Sequence[str | Path],
                    k: int = SEEDS_PER_RUN) -> list[tuple[np.ndarray, str]]:
    """The ``k`` best designs of earlier runs as seeds (``hypate run --seed-from``).

    A richer strategy starts where a simpler one ended (Sec. 9.2.3: Case 2 adds the radiant
    heater to Case 1's variables): each design keeps the values of the variables the runs
    share; a variable the earlier run did not optimize takes the model template's value
    (emissivity, no heater, no external pressure, template size), and every point is
    clipped to the bounds and projected onto the cheap equalities. "Best" is the
    design-point criterion: the smallest max over objectives of successful evaluations.
    """
    names = list(problem.spec.names)
    bounds = np.c_[problem.xl, problem.xu]
    defaults = _template_values(study)
    out: list[tuple[np.ndarray, str]] = []
    for run_dir in run_dirs:
        csv = Path(run_dir) / "evaluations.csv"
        if not csv.exists():
            raise InputError("--seed-from", f"{run_dir} holds no evaluations.csv")
        df = pd.read_csv(csv)
        objectives = [c for c in df.columns if c.startswith("J_")]
        if not objectives:
            raise InputError("--seed-from", f"{csv} has no objective columns (J_...)")
        missing = [n for n in names if n not in df.columns and n not in defaults]
        if missing:
            raise InputError("--seed-from", f"{run_dir} does not set {', '.join(missing)} "
                             "and the model template has no value for it")
        df = df[(df["status"] == "ok") & np.isfinite(df[objectives]).all(axis=1)]
        df = df.assign(_worst=df[objectives].max(axis=1)).sort_values("_worst", kind="stable")
        for idx, row in df.head(k).iterrows():
            design = {n: float(row[n]) for n in names if n in df.columns}
            x = design_vector(design, names, defaults=defaults, bounds=bounds)
            out.append((project_cheap(problem, x),
                        f"seed: {Path(run_dir).name} evaluation {idx}"))
    return out


def _seed_designs(study: Study, problem: ScalingProblem, classical: dict[str, Any] | None,
                  seeds: Sequence[tuple[Sequence[float], str]] | None
                  ) -> list[tuple[np.ndarray, str]]:
    """Classical baseline first (if enabled), then the caller's seeds (duplicates dropped)."""
    out: list[tuple[np.ndarray, str]] = []
    if classical and classical.get("x") is not None and study.optimizer.classical_seed:
        # the GP design matches monomial similarity parameters, not the Eq. (9.7) equality
        out.append((project_cheap(problem, classical["x"]), "seed: classical baseline"))
    span = np.asarray(problem.xu, float) - np.asarray(problem.xl, float)
    for x, why in seeds or ():
        x = project_cheap(problem, x)
        if any(np.max(np.abs(x - y) / span) < 1e-9 for y, _ in out):
            continue
        out.append((x, why))
    return out


def run_study(study: Study, out: str | Path, *, resume: bool = False, workers: int = 1,
              scheduler: str | None = None, seed: int | None = None,
              progress: Callable[[int, int, Any], None] | None = None,
              seeds: Sequence[tuple[Sequence[float], str]] | None = None,
              prototype_response: Response | None = None,
              seed_runs: Sequence[str | Path] = (),
              on_written: Callable[[Path], object] | None = None) -> RunOutcome:
    """Run (or resume) a study into ``out``.

    ``on_written(out)`` is called once the outputs are written: the CLI and ``hypate.run_study``
    write the report there (the workflow does not know the report).

    Parameters
    ----------
    study : Study
    out : path
        Run directory (created). Without ``resume`` it must not hold a run already.
    resume : bool
        Continue from ``out/evaluations.sqlite`` (nothing finished is re-evaluated).
    workers : int
        Local process pool size (1 = in-process).
    scheduler : str, optional
        Address of a Dask scheduler (``tcp://host:port``).
    seed : int, optional
        Overrides the study's optimizer seed.
    progress : callable, optional
        ``progress(done, budget, evaluation)`` after each committed evaluation (the
        :class:`hypate.scaling.engine.store.Evaluation` just stored).
    seeds : sequence of (x, reason), optional
        Extra designs evaluated before the initial sample and stored with it as
        iteration -1 (recycled samples of Sec. 9.2.4, a refined law's prediction); the
        classical baseline comes first. Each seed is committed as soon as it is
        evaluated, so an interrupted run resumes without evaluating it again.
    prototype_response : Response, optional
        The prototype's response if already simulated.
    seed_runs : sequence of paths
        Earlier run directories whose best designs seed this run
        (:func:`seeds_from_runs`), after ``seeds``.
    """
    out = Path(out)
    store_path = out / STORE_NAME
    if store_path.exists() and not resume:
        raise InputError("--out", f"{out} already holds a run; use --resume to continue it "
                         "or choose another directory")
    if resume and not store_path.exists():
        raise InputError("--resume", f"{out} holds no run to resume")
    opt = study.optimizer
    if workers < 1:
        raise InputError("--workers", "must be >= 1")
    problem = ScalingProblem(study.spec, prototype_response=prototype_response)
    coordinates = surrogate_coordinates(study, problem)  # bad settings fail before any work
    if seed_runs:
        seeds = list(seeds or ()) + seeds_from_runs(study, problem, seed_runs)
    proto = problem.prototype_response  # simulated once, before any worker starts
    out.mkdir(parents=True, exist_ok=True)
    proto.save(out / "prototype.npz")
    classical = classical_baseline(study, problem)
    seed_list = _seed_designs(study, problem, classical, seeds)
    budget = (opt.initial_samples + opt.iterations * opt.batch_size + opt.polish
              + len(seed_list))
    count = [0]

    def callback(evaluation) -> None:
        count[0] += 1
        if progress is not None:
            progress(count[0], budget, evaluation)

    run_seed = opt.seed if seed is None else seed
    # seeds: iteration -1, committed one by one (crash-safe; skipped when already stored)
    with EvaluationStore(store_path) as store:
        stored = {r.batch_index: r for r in store.load() if r.iteration == -1}
        for i, (x, why) in enumerate(seed_list):
            if i in stored:
                ev = stored[i]
            else:
                res = evaluate_design(problem, x, timeout=opt.timeout)
                ev = Evaluation(x=np.asarray(x, float), F=np.asarray(res["F"], float),
                                G=np.asarray(res["G"], float), status=res["status"],
                                message=f"{why}; {res['message']}" if res["message"] else why,
                                seconds=float(res["seconds"]), iteration=-1, batch_index=i,
                                seed=run_seed)
                store.append(ev)
                callback(ev)
            if i == 0 and why == "seed: classical baseline" and classical is not None:
                classical["objectives"] = {o: _finite(f) for o, f in
                                           zip(study.spec.objectives, ev.F)}
                classical["evaluation_status"] = ev.status
    _write_json(out / "classical.json", classical or {"status": "not available"})
    executor, close = make_executor(workers, scheduler)
    settings = OptimizerSettings(
        acquisition=study.acquisition, n_init=opt.initial_samples, n_iter=opt.iterations,
        batch_size=opt.batch_size, v=opt.v, weights=opt.weights,
        cheap_constraints=problem.cheap_constraints(), executor=executor,
        timeout=opt.timeout, store=store_path, seed=run_seed, callback=callback,
        output_transform=opt.transform, coordinates=coordinates, polish=opt.polish)
    optimizer = BayesianOptimizer(problem, settings)
    t0 = time.perf_counter()
    try:
        result = optimizer.run()
    finally:
        close()
    wall = time.perf_counter() - t0
    point = write_outputs(study, problem, result, out, wall_seconds=wall)
    if on_written is not None:
        on_written(out)
    return RunOutcome(directory=out, result=result, design_point=point, problem=problem)


def evaluations_table(study: Study, result: OptimizationResult) -> pd.DataFrame:
    """Evaluations with variables and objectives by name."""
    df = result.data.copy()
    names = study.spec.names
    rename = {f"x{i}": n for i, n in enumerate(names)}
    rename.update({f"f{i}": o for i, o in enumerate(study.spec.objectives)})
    return df.rename(columns=rename)


def choose_design_point(study: Study, result: OptimizationResult) -> int | None:
    """Row of the design point: the feasible evaluation with the smallest max(J_u, J_T)
    (Sec. 9.2.3's min max criterion; the objective itself for one objective)."""
    idx = np.flatnonzero(result.feasible)
    if idx.size == 0:
        return None
    F = result.F[idx]
    score = F.max(axis=1)
    return int(idx[int(np.argmin(score))])


def write_outputs(study: Study, problem: ScalingProblem, result: OptimizationResult,
                  out: Path, wall_seconds: float = float("nan")) -> dict[str, Any]:
    """evaluations.csv, pareto.csv, design_point.json (+ design_point.npz)."""
    table = evaluations_table(study, result)
    tmp = out / "evaluations.csv.tmp"
    table.to_csv(tmp, index=False)
    tmp.replace(out / "evaluations.csv")
    mask = result.pareto_mask() if len(table) else np.zeros(0, bool)
    pareto = table[mask] if study.spec.objectives and len(study.spec.objectives) > 1 else \
        table[result.feasible].nsmallest(10, study.spec.objectives[0])
    tmp = out / "pareto.csv.tmp"
    pareto.to_csv(tmp, index=False)
    tmp.replace(out / "pareto.csv")
    row = choose_design_point(study, result)
    point: dict[str, Any] = {"study": study.name, "xi": study.spec.xi,
                             "study_path": str(Path(study.path).resolve())
                             if study.path != "<memory>" else None}
    if row is None:
        point.update(design=None, objectives=None, similarity=[], active_constraints=[],
                     message="no successful evaluation")
    else:
        x = result.X[row]
        design = problem.design(x)
        point["design"] = design
        point["objectives"] = {o: float(f) for o, f in zip(study.spec.objectives, result.F[row])}
        point["similarity"] = problem.similarity(x)
        point["active_constraints"] = problem.active_bounds(x) + [
            f"{name} (equality)" for name in study.spec.equalities]
        point["evaluation"] = int(row)
        point["bounds"] = {v.name: [v.lower, v.upper] for v in study.spec.variables}
        try:
            config, resp = problem.simulate_model(x, keep_fields=False)
            resp.save(out / "design_point.npz")
            point["model_time_step"] = problem.model_time_step(config)
        except (InputError, ArithmeticError, RuntimeError) as exc:
            point["design_point_response"] = f"not saved: {exc}"
    n = len(table)
    ok = int(result.ok.sum()) if n else 0
    point["statistics"] = {"evaluations": n, "successful": ok, "failed": n - ok,
                           "wall_seconds": _finite(wall_seconds),
                           "median_seconds_per_evaluation":
                               _finite(float(np.median(table["seconds"]))) if n else None,
                           "pareto_size": int(mask.sum()) if n else 0}
    classical = out / "classical.json"
    if classical.exists():
        point["classical"] = json.loads(classical.read_text())
    _write_json(out / "design_point.json", point)
    return point


# -- sweeps (issue 10, Sec. 9.2.4) -----------------------------------------------------------
SWEEP_JSON = "sweep.json"
SWEEP_CSV = "sweep.csv"


@dataclass
class SweepOutcome:
    """A finished (or resumed) sweep: one record per sweep point, in run order."""

    directory: Path
    points: list[dict[str, Any]]


def _best_designs(store_path: Path, k: int) -> np.ndarray:
    """The ``k`` best successful, feasible designs of a finished sub-run (smallest
    max over objectives, the design-point criterion)."""
    if k <= 0 or not store_path.exists():
        return np.zeros((0, 0))
    with EvaluationStore(store_path) as store:
        recs = [r for r in store.load() if r.ok and np.all(np.asarray(r.G) <= 0.0)
                and np.all(np.isfinite(r.F))]
    recs.sort(key=lambda r: float(np.max(r.F)))
    if not recs:
        return np.zeros((0, 0))
    return np.array([r.x for r in recs[:k]], dtype=float)


def sweep_seeds(study: Study, sub: Study, problem: ScalingProblem, index: int,
                records: Sequence[dict[str, Any]], out: Path
                ) -> list[tuple[np.ndarray, str]]:
    """Seeds of sweep point ``index`` from the points already finished (Sec. 9.2.4).

    * **Recycling**: the ``sweep.recycle`` best designs of the previous point (its
      neighbour: scales in order, conditions in serpentine order) are re-evaluated in the
      new problem as part of its initial sample. When the scale changes they are first
      moved along the scaling laws, ``d * (xi_new / xi_old)**k``, with the refined
      exponent ``k`` where two or more scales are finished and the analytical one
      otherwise (:mod:`hypate.scaling.workflow.laws`), so that e.g. the thickness keeps ``h/L``.
    * **Prediction**: for a scale not solved yet, with ``sweep.predict`` and two or more
      finished scales, the refined laws' prediction (:func:`hypate.scaling.workflow.laws.predicted_design`)
      comes first.

    Every seed is clipped to the new bounds and projected onto the cheap equalities
    (Eq. 9.7). The result depends only on finished points, so a resumed sweep recomputes
    the same seeds.
    """

    sw = study.sweep
    if sw is None or index == 0:
        return []
    names = sub.spec.names
    xi_new = sub.spec.xi
    done = [r for r in records[:index] if r.get("status") == "done"]
    points = [p for r in done if (p := point_from_record(r)) is not None]
    laws = []
    if len({p.xi for p in points}) >= 2:
        laws = fit_laws(points, variables=names, analytical=analytical_laws(sub),
                        exponent_bounds={k: tuple(v) for k, v in
                                         sub.raw.laws.exponent_bounds.items()},
                        monotone=dict(sub.raw.laws.monotone))
    fitted = {law.variable: law.fit.exponent for law in laws if law.fit.exponent is not None}
    seeds: list[tuple[np.ndarray, str]] = []
    if sw.predict and laws and all(abs(p.xi - xi_new) > 1e-12 for p in points):
        d = predicted_design(laws, points, xi_new, names)
        seeds.append((project_cheap(problem, np.array([d[n] for n in names])),
                      f"seed: refined-law prediction at xi = {xi_new:g}"))
    prev = records[index - 1]
    if prev.get("status") == "done" and sw.recycle > 0:
        X = _best_designs(out / prev["label"] / STORE_NAME, sw.recycle)
        xi_old = float(prev.get("xi") or xi_new)
        ratio = xi_new / xi_old
        k = np.array([fitted.get(n, ANALYTICAL_EXPONENTS.get(n, 0.0)) for n in names])
        for j, x in enumerate(X):
            if x.size != len(names):
                continue
            x_new = x * ratio ** k if ratio != 1.0 else x
            seeds.append((project_cheap(problem, x_new),
                          f"seed: recycled #{j + 1} of {prev['label']}"))
    return seeds


def _point_record(point: Any, sub: Study, directory: Path, status: str,
                  design_point: dict[str, Any] | None) -> dict[str, Any]:
    rec: dict[str, Any] = {"label": point.label, "xi": sub.spec.xi,
                           "mach": sub.spec.prototype.flow.mach,
                           "altitude": sub.spec.prototype.flow.altitude,
                           "directory": directory.name, "status": status,
                           "bounds": {v.name: [v.lower, v.upper] for v in sub.spec.variables}}
    if design_point is not None:
        rec.update(design=design_point.get("design"), objectives=design_point.get("objectives"),
                   active_constraints=design_point.get("active_constraints", []),
                   model_time_step=design_point.get("model_time_step"),
                   evaluations=(design_point.get("statistics") or {}).get("evaluations"))
        if not design_point.get("design"):
            rec["status"] = "failed"
    return rec


def write_sweep_summary(study: Study, out: Path, records: Sequence[dict[str, Any]]) -> None:
    """``sweep.json`` (study data + one record per point) and ``sweep.csv`` (one row per
    point: label, xi, mach, altitude, status, design variables, objectives)."""

    _write_json(out / SWEEP_JSON, {"study": study.name, "study_path": study.path,
                                   "study_data": study_data(study), "points": list(records)})
    rows = []
    for r in records:
        row = {k: r.get(k) for k in ("label", "xi", "mach", "altitude", "status")}
        row.update(r.get("design") or {})
        row.update(r.get("objectives") or {})
        row["evaluations"] = r.get("evaluations")
        row["active_constraints"] = ";".join(r.get("active_constraints") or [])
        rows.append(row)
    tmp = out / (SWEEP_CSV + ".tmp")
    pd.DataFrame(rows).to_csv(tmp, index=False)
    tmp.replace(out / SWEEP_CSV)


def run_sweep(study: Study, out: str | Path, *, resume: bool = False, workers: int = 1,
              scheduler: str | None = None, seed: int | None = None,
              progress: Callable[[int, int, Any], None] | None = None,
              on_point: Callable[[int, int, Any], None] | None = None,
              on_written: Callable[[Path], object] | None = None) -> SweepOutcome:
    """Run (or resume) a sweep study: one optimization per sweep point (``on_written`` as in
    :func:`run_study`, called for each point and again for all once the sweep is done).

    Each point (:func:`hypate.scaling.workflow.study.sweep_points`) runs :func:`run_study` into
    ``out/<label>`` (its own store), sequentially, with the executor of ``workers`` /
    ``scheduler`` inside each point; seeds from its finished neighbours
    (:func:`sweep_seeds`). After every point ``out/sweep.json`` and ``out/sweep.csv`` are
    rewritten. With ``resume``, finished points (``design_point.json`` written) are
    skipped, an interrupted one continues from its store and the rest run normally.

    Parameters
    ----------
    study : Study
        A study with a ``[sweep]`` table.
    out : path
    resume, workers, scheduler, seed, progress
        As :func:`run_study` (``progress`` restarts with each point).
    on_point : callable, optional
        ``on_point(index, n_points, point)`` before each point starts or is skipped.
    """

    points = sweep_points(study)
    if not points:
        raise InputError("sweep", "the study has no [sweep] table")
    out = Path(out)
    if (out / SWEEP_JSON).exists() and not resume:
        raise InputError("--out", f"{out} already holds a sweep; use --resume to continue it "
                         "or choose another directory")
    if resume and not (out / SWEEP_JSON).exists():
        raise InputError("--resume", f"{out} holds no sweep to resume")
    out.mkdir(parents=True, exist_ok=True)
    subs = [study_at(study, p, first=(i == 0)) for i, p in enumerate(points)]
    records = [_point_record(p, sub, out / p.label, "pending", None)
               for p, sub in zip(points, subs)]
    if not resume:
        write_sweep_summary(study, out, records)
    prototypes: dict[tuple[float, float, float], Response] = {}
    for i, (point, sub) in enumerate(zip(points, subs)):
        if on_point is not None:
            on_point(i, len(points), point)
        sub_dir = out / point.label
        finished = sub_dir / "design_point.json"
        if resume and finished.exists() and (sub_dir / STORE_NAME).exists():
            records[i] = _point_record(point, sub, sub_dir, "done",
                                       json.loads(finished.read_text()))
            write_sweep_summary(study, out, records)  # the summary says so at once
            continue
        flow = sub.spec.prototype.flow
        key = (flow.mach, flow.pressure, flow.temperature)
        problem = ScalingProblem(sub.spec, prototype_response=prototypes.get(key))
        seeds = sweep_seeds(study, sub, problem, i, records, out)
        if sub.optimizer.initial_samples + len(seeds) < 2:
            n0 = max(2, study.optimizer.initial_samples)
            warnings.warn(f"sweep point {point.label}: only {len(seeds)} recycled design(s); "
                          f"drawing {n0} initial samples instead", RuntimeWarning, stacklevel=2)
            sub = dataclasses.replace(sub, optimizer=sub.optimizer.model_copy(
                update={"initial_samples": n0}))
        outcome = run_study(sub, sub_dir, resume=resume and (sub_dir / STORE_NAME).exists(),
                            workers=workers, scheduler=scheduler, seed=seed,
                            progress=progress, seeds=seeds,
                            prototype_response=problem.prototype_response,
                            on_written=on_written)
        prototypes[key] = outcome.problem.prototype_response
        records[i] = _point_record(point, sub, sub_dir, "done", outcome.design_point)
        write_sweep_summary(study, out, records)
    write_sweep_summary(study, out, records)
    for record_dir in (out / p.label for p in points):
        if on_written is not None and (record_dir / "design_point.json").exists():
            on_written(record_dir)  # again: the report's laws section now sees every point
    return SweepOutcome(directory=out, points=records)




__all__ = ["RunOutcome", "SweepOutcome", "run_study", "run_sweep", "sweep_seeds",
           "write_sweep_summary", "surrogate_coordinates", "seeds_from_runs",
           "write_outputs", "classical_baseline", "make_executor", "evaluations_table",
           "choose_design_point", "STORE_NAME"]
