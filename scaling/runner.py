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
  responses (:class:`solvers.response.Response`).
"""
from __future__ import annotations

import json
import math
import time
import warnings
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from scaling.classical import classical_scaling
from scaling.optimizer import BayesianOptimizer, OptimizationResult, evaluate_design
from scaling.problem import ScalingProblem
from scaling.study import Study
from solvers.errors import InputError
from solvers.response import Response

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
        pool = ProcessPoolExecutor(max_workers=workers)
        return pool, lambda: pool.shutdown(cancel_futures=True)
    return None, lambda: None


def run_study(study: Study, out: str | Path, *, resume: bool = False, workers: int = 1,
              scheduler: str | None = None, seed: int | None = None,
              progress: Callable[[int, int, Any], None] | None = None
              ) -> RunOutcome:
    """Run (or resume) a study into ``out``.

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
        :class:`scaling.store.Evaluation` just stored).
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
    problem = ScalingProblem(study.spec)
    proto = problem.prototype_response  # simulated once, before any worker starts
    out.mkdir(parents=True, exist_ok=True)
    proto.save(out / "prototype.npz")
    classical = classical_baseline(study, problem)
    initial = None
    if classical and classical.get("x") is not None and opt.classical_seed and not resume:
        res = evaluate_design(problem, np.asarray(classical["x"]), timeout=opt.timeout)
        classical["objectives"] = {o: _finite(f) for o, f in zip(study.spec.objectives,
                                                                 res["F"])}
        classical["evaluation_status"] = res["status"]
        initial = (np.atleast_2d(classical["x"]), np.atleast_2d(res["F"]))
    _write_json(out / "classical.json", classical or {"status": "not available"})
    budget = opt.initial_samples + opt.iterations * opt.batch_size + (1 if initial else 0)
    executor, close = make_executor(workers, scheduler)
    count = [0]

    def callback(evaluation) -> None:
        count[0] += 1
        if progress is not None:
            progress(count[0], budget, evaluation)

    weights = opt.weights if opt.weights is not None else None
    optimizer = BayesianOptimizer(
        problem, acquisition=study.acquisition, n_init=opt.initial_samples,
        n_iter=opt.iterations, batch_size=opt.batch_size, v=opt.v, weights=weights,
        cheap_constraints=problem.cheap_constraints(), executor=executor,
        timeout=opt.timeout, store=store_path, initial_samples=initial,
        seed=opt.seed if seed is None else seed, callback=callback)
    t0 = time.perf_counter()
    try:
        result = optimizer.run()
    finally:
        close()
    wall = time.perf_counter() - t0
    point = write_outputs(study, problem, result, out, wall_seconds=wall)
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
    point: dict[str, Any] = {"study": study.name, "xi": study.spec.xi}
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


def load_response(path: Path) -> Response | None:
    return Response.load(path) if path.exists() else None


__all__ = ["RunOutcome", "run_study", "write_outputs", "classical_baseline", "make_executor",
           "evaluations_table", "choose_design_point", "STORE_NAME"]
