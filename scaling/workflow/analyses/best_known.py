"""The best known design of a shipped study: a long multistart local search on the simulator,
and the record a benchmark measures every run against.

A study's optimum is unknown; what can be known is the best admissible design anyone found.
:func:`best_known_search` starts a bounded Nelder-Mead on ``max(J_u, J_T)`` (the design-point
criterion, Sec. 9.2.3) from each of the best admissible designs of earlier runs (their
``evaluations.csv``), in the design box scaled to the unit cube, with an extreme barrier:
a failed or inadmissible evaluation scores ``BARRIER + its summed relative violation``, so the
simplex is pushed back inside. Every evaluation is kept (``search.csv``), the best one is
the result.

The shipped records live in ``scaling/data/best_known.toml`` (``[STUDY]`` tables: ``value``,
``J_u``, ``J_T``, ``design``, ``evaluations``, ``command``, ``commit``), read by
:func:`best_known` (``hypate bench study`` reports each run's gap to it).
"""
from __future__ import annotations

import csv
import math
import tomllib
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from hypate.scaling.engine.problem import project_cheap
from hypate.scaling.workflow.campaigns.rundir import EVALUATIONS_CSV
from hypate.scaling.workflow.vocabulary.admissibility import admissible, violation
from hypate.scaling.workflow.vocabulary.objectives import ModelFailure
from hypate.scaling.workflow.vocabulary.problem import ScalingProblem
from hypate.scaling.workflow.vocabulary.study import Study
from hypate.solvers.errors import InputError
from scipy.optimize import minimize

__all__ = ["BARRIER", "BestKnown", "SearchResult", "best_known", "best_known_search",
           "candidate_designs"]

#: Score of a failed or inadmissible design (plus its summed relative violation).
BARRIER = 10.0
#: Initial simplex edge of each start, as a fraction of the design box.
SIMPLEX_EDGE = 0.05


@dataclass(frozen=True)
class BestKnown:
    """A shipped study's best known design (``scaling/data/best_known.toml``)."""

    study: str
    value: float
    J_u: float
    J_T: float
    design: dict[str, float]
    evaluations: int
    command: str
    commit: str


def best_known(study_name: str) -> BestKnown | None:
    """The shipped record of ``study_name`` (None: none recorded)."""
    text = resources.files("hypate.scaling").joinpath("data", "best_known.toml").read_text()
    rec = tomllib.loads(text).get(study_name)
    if rec is None:
        return None
    return BestKnown(study=study_name, value=float(rec["value"]), J_u=float(rec["J_u"]),
                     J_T=float(rec["J_T"]), design={k: float(v) for k, v in
                                                    rec["design"].items()},
                     evaluations=int(rec["evaluations"]), command=str(rec["command"]),
                     commit=str(rec["commit"]))


def candidate_designs(study: Study, runs: Sequence[str | Path], k: int) -> list[np.ndarray]:
    """The ``k`` best admissible designs of the runs' ``evaluations.csv`` (smallest
    max(J_u, J_T); duplicates closer than 1e-6 of the box dropped)."""
    names = study.spec.names
    objectives = list(study.spec.objectives)
    frames = []
    for run in runs:
        path = Path(run) / EVALUATIONS_CSV
        if not path.is_file():
            raise InputError("--runs", f"{run} holds no {EVALUATIONS_CSV}")
        df = pd.read_csv(path)
        missing = [n for n in names + objectives if n not in df.columns]
        if missing:
            raise InputError("--runs", f"{path} lacks {', '.join(missing)}: a run of "
                             "another study")
        ok = df["status"] == "ok"
        if "admissible" in df.columns:
            ok &= df["admissible"].astype(str).str.lower() == "true"
        frames.append(df[ok])
    df = pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()
    if df.empty:
        return []
    score = df[objectives].max(axis=1).to_numpy(float)
    X = df[names].to_numpy(float)[np.argsort(score, kind="stable")]
    span = np.array([v.upper - v.lower for v in study.spec.variables])
    out: list[np.ndarray] = []
    for x in X:
        if all(np.max(np.abs(x - y) / span) > 1e-6 for y in out):
            out.append(x)
        if len(out) == k:
            break
    return out


@dataclass
class SearchResult:
    """Every evaluation of a search and its best admissible one."""

    rows: list[dict[str, Any]] = field(default_factory=list)

    @property
    def best(self) -> dict[str, Any] | None:
        good = [r for r in self.rows if r["admissible"]]
        return min(good, key=lambda r: r["value"]) if good else None


def _score(problem: ScalingProblem, x: np.ndarray) -> dict[str, Any]:
    """One simulator evaluation: J, admissibility and the search's score."""
    config = problem.model_configuration(x)
    try:
        err, _, aux = problem.outputs(config)
    except (ModelFailure, ArithmeticError, RuntimeError, ValueError) as exc:
        rows = problem.admissibility_rows(config, None)
        return {"J_u": math.nan, "J_T": math.nan, "value": math.inf, "admissible": False,
                "score": BARRIER + 1.0 + violation(rows), "message": str(exc)[:200]}
    rows = problem.admissibility_rows(config, aux["extremes"])
    value = max(err[o] for o in problem.spec.objectives)
    ok = admissible(rows)
    return {"J_u": err.get("J_u"), "J_T": err.get("J_T"), "value": value, "admissible": ok,
            "score": value if ok else BARRIER + violation(rows), "message": ""}


def best_known_search(study: Study, starts: Sequence[np.ndarray], evaluations: int,
                      out: Path | None = None,
                      progress: Callable[[int, int, float], None] | None = None
                      ) -> SearchResult:
    """Bounded Nelder-Mead on max(J) from each start (module docstring).

    Parameters
    ----------
    study : Study
    starts : sequence of ndarray of shape (d,)
        Designs to start from (each clipped to the box and projected onto the cheap
        constraints).
    evaluations : int
        Simulator evaluations per start (the Nelder-Mead ``maxfev``).
    out : Path, optional
        Folder of ``search.csv`` (every evaluation, written as it goes).
    progress : callable, optional
        ``progress(done, total, best)`` after each evaluation.
    """
    problem = ScalingProblem(study.spec)
    problem.prototype_response  # noqa: B018 - simulated once, before the searches
    lo, hi = np.asarray(problem.xl, float), np.asarray(problem.xu, float)
    span = hi - lo
    result = SearchResult()
    total = evaluations * len(starts)
    writer = None
    handle = None
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        handle = (out / "search.csv").open("w", newline="")
        writer = csv.writer(handle)
        writer.writerow(["start", *study.spec.names, *study.spec.objectives, "max_J",
                         "admissible", "message"])
    try:
        for k, x0 in enumerate(starts):
            x0 = project_cheap(problem, np.asarray(x0, float))

            def f(u: np.ndarray, k: int = k) -> float:
                x = project_cheap(problem, lo + np.clip(u, 0.0, 1.0) * span)
                row = {"start": k, "x": x, **_score(problem, x)}
                result.rows.append(row)
                if writer is not None:
                    assert handle is not None  # opened with the writer
                    writer.writerow([k, *(repr(float(v)) for v in x), *(repr(row[o]) for o in
                                                        study.spec.objectives),
                                     repr(row["value"]), row["admissible"], row["message"]])
                    handle.flush()
                if progress is not None:
                    best = result.best
                    progress(len(result.rows), total, math.inf if best is None
                             else best["value"])
                return float(row["score"])

            u0 = (x0 - lo) / span
            simplex = np.vstack([u0] + [np.clip(u0 + SIMPLEX_EDGE * np.eye(len(u0))[i]
                                                * (1.0 if u0[i] < 0.5 else -1.0), 0.0, 1.0)
                                        for i in range(len(u0))])
            minimize(f, u0, method="Nelder-Mead", bounds=[(0.0, 1.0)] * len(u0),
                     options={"maxfev": evaluations, "initial_simplex": simplex,
                              "xatol": 1e-6, "fatol": 1e-7})
    finally:
        if handle is not None:
            handle.close()
    return result
