"""``hypate bench study STUDY [--target 0.10] [--seeds 3] [--compare single] [--json]``: how
fast a study's design point gets good (issue 19's benchmark; medians over seeds, never
pass/fail).

Each seed runs the study (``hypate run``'s workflow, in ``--out/seed-<s>`` or a temporary
folder) and records, at every committed evaluation, the wall time since the run started
(prototype simulation included), the simulator seconds spent and the evaluations made. The
time to target is when the best design so far -- the smallest max(J_u, J_T) over the
successful evaluations, the design-point rule -- first reaches ``--target``; ``null`` if it
never does (a median over seeds counts such a seed as infinitely slow). ``--compare single``
runs the one-worker configuration of the same study side by side in the same invocation
(without the study's ``[[fidelity]]`` levels) and prints the ratio; a multi-fidelity
run's target and final values count its top-level evaluations only.

Each seed's design point is reported too (issue 41): ``design_points`` (max(J_u, J_T) of each
seed's design point), ``median_design_point``, ``worst_design_point``; with a record in
``scaling/data/best_known.toml`` (:mod:`hypate.scaling.workflow.analyses.best_known`),
``best_known`` and each seed's ``gap`` to it (``median_gap``, ``worst_gap``, in the same fractions);
and the failed evaluations after the initial design, ``failed_after_initial`` (per seed
``[failed, evaluated]``) and ``failed_share`` (their sum over seeds, as a fraction).

JSON (public): ``{"study", "target", "seeds", "seconds_to_target": [...],
"median_seconds_to_target", "final": {"J_u", "J_T", "hypervolume", "evaluations",
"simulator_seconds"}, "compare": {the same fields} or null, "speedup": median ratio or
null}``, plus ``workers``, ``evaluations_to_target``, ``simulator_seconds_to_target``,
``evaluations_per_second`` (per seed: the evaluations committed after the first one over
the wall time from the first to the last; the prototype simulation and the report are not
in it) with its ``median_evaluations_per_second``, and ``throughput`` (the median
evaluations per second against the compared configuration's, or null).
"""
from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
from hypate.scaling.cli.jsonout import dumps
from hypate.scaling.cli.run import resolve_workers
from hypate.scaling.engine.pareto import hypervolume
from hypate.scaling.workflow.analyses.best_known import best_known
from hypate.scaling.workflow.campaigns.execute import execute
from hypate.scaling.workflow.campaigns.run import RunOutcome
from hypate.scaling.workflow.campaigns.seeds import seed_directory, seed_list
from hypate.scaling.workflow.vocabulary.derived import study_data
from hypate.scaling.workflow.vocabulary.fidelity import is_top
from hypate.scaling.workflow.vocabulary.shipped import resolve
from hypate.scaling.workflow.vocabulary.study import Study, load_study, parse_study
from hypate.solvers.errors import InputError

#: Hypervolume reference point of the final front (J_u, J_T as fractions).
REFERENCE = np.array([1.0, 1.0])


def register_bench(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("study", help="time to a design point with max(J_u, J_T) <= target",
                       description="Run a study for several seeds; report the wall time, "
                       "simulator seconds and evaluations until the design point first "
                       "reaches max(J_u, J_T) <= --target, and the final values (medians).")
    p.add_argument("study", help="study TOML file or a shipped study's name")
    p.add_argument("--target", type=float, default=0.10, help="max(J_u, J_T) to reach (0.10)")
    p.add_argument("--seeds", type=int, default=3, help="seeds S .. S+N-1 (3)")
    p.add_argument("--seed", type=int, help="first seed (default: the study's)")
    p.add_argument("--workers", default="auto", help="as for hypate run (default auto)")
    p.add_argument("--compare", choices=["single"], help="also run the one-worker, "
                   "single-fidelity configuration and print the speed-up")
    p.add_argument("--out", help="keep the run directories here (default: a temporary folder)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=run)


def _trace(study: Study, out: Path, workers: int, seed: int) -> dict[str, Any]:
    """One run of the study: per committed evaluation (wall s, simulator s, max J)."""
    rows: list[tuple[float, float, float]] = []
    spent = [0.0]
    t0 = time.perf_counter()

    n_levels = len(study.level_names)

    def top(evaluation: Any) -> bool:  # a multi-fidelity run's design point is top-level
        return not n_levels or round(float(evaluation.x[-1])) == n_levels - 1

    def progress(done: int, budget: int, evaluation: Any) -> None:
        spent[0] += float(evaluation.seconds)
        admissible = evaluation.ok and top(evaluation) and bool(np.all(evaluation.G <= 0.0))
        worst = float(np.max(evaluation.F)) if admissible else math.inf
        rows.append((time.perf_counter() - t0, spent[0], worst))

    outcome = execute(study, out, workers=workers, seed=seed, progress=progress)
    # one single campaign (run() rejects sweeps and robust studies; no seeds, no on_complete)
    assert isinstance(outcome, RunOutcome)
    point = outcome.design_point
    result = outcome.result
    keep = result.ok & (is_top(result.X, n_levels) if n_levels else True)
    F = result.F[keep]
    F = F[np.all(np.isfinite(F), axis=1)]
    hv = (float(hypervolume(F[np.all(F < REFERENCE, axis=1)], REFERENCE))
          if F.shape[1:] == (2,) else None)
    objectives = point.get("objectives") or {}
    it = result.data["iteration"].to_numpy()
    after = (it >= 1) & (is_top(result.X, n_levels) if n_levels else True)
    return {"rows": rows, "J_u": objectives.get("J_u"), "J_T": objectives.get("J_T"),
            "design_point": max(objectives.values()) if objectives else None,
            "admissible": point.get("admissible"),
            "hypervolume": hv, "evaluations": len(outcome.result.F),
            "failed_after_initial": [int((after & ~result.ok).sum()), int(after.sum())],
            "simulator_seconds": float(np.sum(outcome.result.data["seconds"]))}


def _text(value: float | None) -> str:
    return "-" if value is None else f"{value:.2f}"


def single_fidelity(study: Study) -> Study:
    """The study without its ``[[fidelity]]`` levels (itself when it has none)."""
    if not study.lower_levels:
        return study
    data = {k: v for k, v in study_data(study).items() if k != "fidelity"}
    return parse_study(data, study.path)


def _to_target(rows: list[tuple[float, float, float]], target: float
               ) -> tuple[float | None, float | None, int | None]:
    """Wall s, simulator s and evaluations at which the running best first is <= target."""
    best = math.inf
    for k, (wall, spent, worst) in enumerate(rows):
        best = min(best, worst)
        if best <= target:
            return wall, spent, k + 1
    return None, None, None


def _median(values: list[float | None]) -> float | None:
    """Median with None as infinitely slow; None when the median is such a seed."""
    m = float(np.median([math.inf if v is None else v for v in values]))
    return m if math.isfinite(m) else None


def measure(study: Study, seeds: list[int], target: float, workers: int, root: Path,
            label: str) -> dict[str, Any]:
    """The benchmark block of one configuration (module docstring)."""
    runs = []
    for s in seeds:
        print(f"bench study: {label}, seed {s} ...", file=sys.stderr, flush=True)
        runs.append(_trace(study, seed_directory(root / label, s), workers, s))
    hits = [_to_target(r["rows"], target) for r in runs]
    rates = [_rate(r["rows"]) for r in runs]
    final = {key: _median([r[key] for r in runs]) for key in
             ("J_u", "J_T", "hypervolume", "simulator_seconds")}
    final["evaluations"] = int(np.median([r["evaluations"] for r in runs]))
    points = [r["design_point"] for r in runs]
    known = best_known(study.name)
    gaps = [None if p is None or known is None else p - known.value for p in points]
    failed = [r["failed_after_initial"] for r in runs]
    evaluated = sum(f[1] for f in failed)
    return {"study": study.name, "target": target, "seeds": seeds, "workers": workers,
            "design_points": points, "median_design_point": _median(points),
            "worst_design_point": _worst(points),
            "best_known": None if known is None else known.value,
            "gap": gaps, "median_gap": None if known is None else _median(gaps),
            "worst_gap": None if known is None else _worst(gaps),
            "inadmissible_design_points": sum(r["admissible"] is False for r in runs),
            "failed_after_initial": failed,
            "failed_share": sum(f[0] for f in failed) / evaluated if evaluated else None,
            "seconds_to_target": [h[0] for h in hits],
            "median_seconds_to_target": _median([h[0] for h in hits]),
            "simulator_seconds_to_target": [h[1] for h in hits],
            "evaluations_to_target": [h[2] for h in hits],
            "evaluations_per_second": rates, "median_evaluations_per_second": _median(rates),
            "final": final}


def _worst(values: list[float | None]) -> float | None:
    """The largest value, a missing one (no design point) counting as infinitely bad."""
    m = max((math.inf if v is None else v for v in values), default=math.inf)
    return m if math.isfinite(m) else None


def _rate(rows: list[tuple[float, float, float]]) -> float | None:
    """Evaluations committed per wall second, from the first commit to the last."""
    if len(rows) < 2 or rows[-1][0] <= rows[0][0]:
        return None
    return (len(rows) - 1) / (rows[-1][0] - rows[0][0])


def run(args: argparse.Namespace) -> int:
    if not (0.0 < args.target < math.inf):
        raise InputError("--target", f"must be a positive number; got {args.target}")
    if not 1 <= args.seeds <= 100:
        raise InputError("--seeds", f"must be in [1, 100]; got {args.seeds}")
    study = load_study(resolve(args.study, "study"))
    if study.sweep is not None or (study.uncertainty is not None and study.uncertainty.optimize):
        raise InputError("study", "bench study times one optimization: not a sweep or a "
                         "robust study")
    workers = resolve_workers(args.workers, study)
    seeds = seed_list(study.optimizer.seed if args.seed is None else args.seed, args.seeds)
    with tempfile.TemporaryDirectory(prefix="hypate-bench-") as tmp:
        root = Path(args.out) if args.out else Path(tmp)
        main = measure(study, seeds, args.target, workers, root, "main")
        compare = (measure(single_fidelity(study), seeds, args.target, 1, root, "single")
                   if args.compare else None)
    speedup = None
    if compare is not None and main["median_seconds_to_target"] and \
            compare["median_seconds_to_target"] is not None:
        speedup = compare["median_seconds_to_target"] / main["median_seconds_to_target"]
    throughput = None
    if compare is not None and main["median_evaluations_per_second"] and \
            compare["median_evaluations_per_second"]:
        throughput = (main["median_evaluations_per_second"]
                      / compare["median_evaluations_per_second"])
    out = {**main, "compare": compare, "speedup": speedup, "throughput": throughput}
    if args.json:
        print(dumps(out, indent=2))
        return 0
    for block, name in ((main, f"{workers} worker(s)"), (compare, "single (1 worker)")):
        if block is None:
            continue
        f = block["final"]
        med = block["median_seconds_to_target"]
        print(f"{study.name} [{name}]: max(J_u, J_T) <= {args.target:g} after "
              + ", ".join("-" if v is None else f"{v:.1f} s" for v in block["seconds_to_target"])
              + f" (median {'not reached' if med is None else f'{med:.1f} s'}); final J_u "
              f"{f['J_u']:.4g}, J_T {f['J_T']:.4g}, HV {f['hypervolume']}, "
              f"{f['evaluations']:.0f} evaluations, {f['simulator_seconds']:.1f} simulator s, "
              f"{_text(block['median_evaluations_per_second'])} evaluations/s (median)")
    for block, name in ((main, f"{workers} worker(s)"), (compare, "single (1 worker)")):
        if block is None:
            continue
        pct = (lambda v: "-" if v is None else f"{100 * v:.2f} %")  # noqa: E731
        print(f"{study.name} [{name}]: design point max(J_u, J_T) per seed "
              + ", ".join(pct(v) for v in block["design_points"])
              + f"; median {pct(block['median_design_point'])}, worst "
              f"{pct(block['worst_design_point'])}"
              + ("" if block["best_known"] is None else
                 f"; best known {pct(block['best_known'])}, gap median "
                 f"{pct(block['median_gap'])}, worst {pct(block['worst_gap'])}")
              + f"; failed after the initial design {pct(block['failed_share'])} ("
              + ", ".join(f"{a}/{b}" for a, b in block["failed_after_initial"]) + ")"
              + (f"; {block['inadmissible_design_points']} inadmissible design point(s)"
                 if block["inadmissible_design_points"] else ""))
    if speedup is not None:
        print(f"speed-up (single / {workers} worker(s), median time to target): {speedup:.2f}x")
    if throughput is not None:
        print(f"throughput ({workers} worker(s) / single, median evaluations per second): "
              f"{throughput:.2f}x")
    return 0
