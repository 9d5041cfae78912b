"""Sweeps: one optimization per sweep point (geometric scales and/or flight conditions,
Sec. 9.2.4), each seeded by recycling the best designs of the previous point and, with
``[laws] predict``, by the refined scaling laws fitted so far (Sec. 9.1.3); ``sweep.json``
and ``sweep.csv`` record the points (:mod:`.rundir`)."""
from __future__ import annotations

import dataclasses
import json
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from hypate.scaling.engine.design_point import rank_designs
from hypate.scaling.engine.executors import LOST_AFTER
from hypate.scaling.engine.problem import project_cheap
from hypate.scaling.engine.store import EvaluationStore
from hypate.scaling.workflow.campaigns.campaign import (
    check_run_settings,
    refuse_changes,
    sweep_changes,
    sweep_identity,
)
from hypate.scaling.workflow.campaigns.laws import (
    ANALYTICAL_EXPONENTS,
    analytical_laws,
    fit_laws,
    point_from_record,
    predicted_design,
)
from hypate.scaling.workflow.campaigns.outputs import level_column
from hypate.scaling.workflow.campaigns.resources import check_resources, local_workers
from hypate.scaling.workflow.campaigns.run import run_study
from hypate.scaling.workflow.campaigns.rundir import (
    DESIGN_POINT_JSON,
    STORE,
    SWEEP_CSV,
    SWEEP_JSON,
    write_csv,
    write_json,
)
from hypate.scaling.workflow.vocabulary.derived import study_at, sweep_points
from hypate.scaling.workflow.vocabulary.problem import ScalingProblem
from hypate.scaling.workflow.vocabulary.study import Study
from hypate.scaling.workflow.vocabulary.variables import CATEGORICAL
from hypate.solvers.coupling.response import Response
from hypate.solvers.errors import InputError

# -- sweeps (issue 10, Sec. 9.2.4) -----------------------------------------------------------




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
    with EvaluationStore(store_path, read_only=True) as store:  # a reader
        recs = [r for r in store.load() if r.ok and np.all(np.asarray(r.G) <= 0.0)
                and np.all(np.isfinite(r.F))]
    if not recs:
        return np.zeros((0, 0))
    order = rank_designs(np.array([r.F for r in recs], dtype=float))
    return np.array([recs[i].x for i in order[:k]], dtype=float)


def sweep_seeds(study: Study, sub: Study, problem: ScalingProblem, index: int,
                records: Sequence[dict[str, Any]], out: Path
                ) -> list[tuple[np.ndarray, str]]:
    """Seeds of sweep point ``index`` from the points already finished (Sec. 9.2.4).

    * **Recycling**: the ``sweep.recycle`` best designs of the previous point (its
      neighbour: scales in order, conditions in serpentine order) are re-evaluated in the
      new problem as part of its initial sample. When the scale changes they are first
      moved along the scaling laws, ``d * (xi_new / xi_old)**k``, with the refined
      exponent ``k`` where two or more scales are finished and the analytical one
      otherwise (:mod:`hypate.scaling.workflow.campaigns.laws`), so that e.g. the thickness keeps
      ``h/L``.
    * **Prediction**: for a scale not solved yet, with ``sweep.predict`` and two or more
      finished scales, the refined laws' prediction
      (:func:`hypate.scaling.workflow.campaigns.laws.predicted_design`) comes first.

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
        X = _best_designs(out / prev["label"] / STORE, sw.recycle)
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
        for name in CATEGORICAL:  # a categorical value: the laws report it (material)
            if design_point.get(name):
                rec[name] = design_point[name]
        if not design_point.get("design"):
            rec["status"] = "failed"
    return rec


def write_sweep_summary(study: Study, out: Path, records: Sequence[dict[str, Any]]) -> None:
    """``sweep.json`` (study data + one record per point) and ``sweep.csv`` (one row per
    point: label, xi, mach, altitude, status, design variables, objectives)."""

    identity = sweep_identity(study)
    write_json(out / SWEEP_JSON, {"study": study.name, "study_path": study.path,
                                   "study_data": identity["study"], "case": identity["case"],
                                   "points": list(records)})
    rows = []
    for r in records:
        row = {k: r.get(k) for k in ("label", "xi", "mach", "altitude", "status")}
        row.update(r.get("design") or {})
        for name in CATEGORICAL:
            if r.get(name):
                row[level_column(name)] = r[name]["name"]
        row.update(r.get("objectives") or {})
        row["evaluations"] = r.get("evaluations")
        row["active_constraints"] = ";".join(r.get("active_constraints") or [])
        rows.append(row)
    write_csv(out / SWEEP_CSV, pd.DataFrame(rows))


def run_sweep(study: Study, out: str | Path, *, resume: bool = False, workers: int = 1,
              scheduler: str | None = None, seed: int | None = None,
              progress: Callable[[int, int, Any], None] | None = None,
              on_point: Callable[[int, int, Any], None] | None = None,
              on_written: Callable[[Path], object] | None = None,
              lost_after: float = LOST_AFTER, force: bool = False) -> SweepOutcome:
    """Run (or resume) a sweep study: one optimization per sweep point (``on_written`` as in
    :func:`run_study`, called for each point and again for all once the sweep is done).

    Each point (:func:`hypate.scaling.workflow.vocabulary.derived.sweep_points`) runs
    :func:`run_study` into ``out/<label>`` (its own store), sequentially, with the executor of
    ``workers`` / ``scheduler`` inside each point; seeds from its finished neighbours
    (:func:`sweep_seeds`). After every point ``out/sweep.json`` and ``out/sweep.csv`` are
    rewritten. With ``resume``, finished points (``design_point.json`` written) are
    skipped, an interrupted one continues from its store and the rest run normally.

    Parameters
    ----------
    study : Study
        A study with a ``[sweep]`` table.
    out : path
    resume, workers, scheduler, seed, progress, lost_after, force
        As :func:`run_study` (``progress`` restarts with each point).
    on_point : callable, optional
        ``on_point(index, n_points, point)`` before each point starts or is skipped.
    """

    points = sweep_points(study)
    if not points:
        raise InputError("sweep", "the study has no [sweep] table")
    out = Path(out)
    check_run_settings(out, seed=seed, workers=workers, scheduler=scheduler)
    here = local_workers(workers, scheduler)
    if here is not None:  # before the first point writes anything (each point's own size)
        for i, p in enumerate(points):
            check_resources(study_at(study, p, first=(i == 0)), here, force=force)
    if (out / SWEEP_JSON).exists() and not resume:
        raise InputError("out", f"{out} already holds a sweep; use --resume to continue it "
                         "or choose another directory")
    if resume and not (out / SWEEP_JSON).exists():
        raise InputError("resume", f"{out} holds no sweep to resume")
    if resume:  # the same sweep, or nothing in the directory is touched
        stored = json.loads((out / SWEEP_JSON).read_text())
        refuse_changes(out, sweep_changes(stored, study))
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
        finished = sub_dir / DESIGN_POINT_JSON
        if resume and finished.exists() and (sub_dir / STORE).exists():
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
        outcome = run_study(sub, sub_dir, resume=resume and (sub_dir / STORE).exists(),
                            workers=workers, scheduler=scheduler, seed=seed,
                            progress=progress, seeds=seeds,
                            prototype_response=problem.prototype_response,
                            on_written=on_written, lost_after=lost_after, force=force)
        prototypes[key] = outcome.problem.prototype_response
        records[i] = _point_record(point, sub, sub_dir, "done", outcome.design_point)
        write_sweep_summary(study, out, records)
    write_sweep_summary(study, out, records)
    for record_dir in (out / p.label for p in points):
        if on_written is not None and (record_dir / DESIGN_POINT_JSON).exists():
            on_written(record_dir)  # again: the report's laws section now sees every point
    return SweepOutcome(directory=out, points=records)


__all__ = ["SweepOutcome", "run_sweep", "sweep_seeds", "write_sweep_summary"]
