"""``hypate run [STUDY.toml]``: run a scaling study (the main job)."""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np
from hypate.scaling.engine.pareto import hypervolume
from hypate.scaling.report.html import write_report_safely
from hypate.scaling.workflow.run import run_study
from hypate.scaling.workflow.shipped import default_study, resolve
from hypate.scaling.workflow.study import load_study
from hypate.scaling.workflow.sweep import run_sweep
from hypate.solvers.errors import InputError
from tqdm import tqdm

#: Reference point of the progress-bar hypervolume (relative errors of 100 %).
PROGRESS_REF = np.array([1.0, 1.0])


def default_run_dir(name: str, resume: bool, root: Path = Path("runs")) -> Path:
    """``runs/NAME``, or ``runs/NAME-2``, ``-3``... when earlier runs exist (a repeated
    ``hypate run`` starts a new run instead of refusing); with ``--resume`` the latest."""
    candidates = [root / name] + [root / f"{name}-{k}" for k in range(2, 1000)]
    existing = [c for c in candidates if c.exists()]
    if resume:
        return existing[-1] if existing else candidates[0]
    return next(c for c in candidates if not c.exists())


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("run", help="run a scaling study (default: the quick-start study)",
                       description="Optimize a wind-tunnel model whose nondimensional "
                       "aerothermoelastic response matches the prototype's. Writes "
                       "evaluations.sqlite/.csv, pareto.csv and design_point.json to --out; "
                       "a study with a [sweep] table runs one optimization per sweep point "
                       "into --out/<point> and writes --out/sweep.json and sweep.csv.")
    p.add_argument("study", nargs="?", help="study TOML file or a shipped study's name (default: the quick-start)")
    p.add_argument("--out", help="run directory (default: runs/<study name>, numbered -2, "
                   "-3 ... when it exists)")
    p.add_argument("--resume", action="store_true", help="continue the run in --out")
    p.add_argument("--workers", type=int, default=1, help="local worker processes (default 1)")
    p.add_argument("--scheduler", help="Dask scheduler address tcp://HOST:PORT")
    p.add_argument("--seed", type=int, help="override the study's optimizer seed")
    p.add_argument("--seed-from", action="append", default=[], metavar="RUN_DIR",
                   help="seed the initial sample with the 10 best designs of an earlier run "
                   "(repeatable; e.g. Case 1 for the Case 2 strategy); variables it lacks "
                   "take the model template's values")
    p.set_defaults(func=run, field_flags={"out": "--out", "resume": "--resume",
                                          "workers": "--workers", "scheduler": "--scheduler",
                                          "seed_runs": "--seed-from"})


class _Progress:
    """Progress bar: evaluations / budget, best max(J), hypervolume, elapsed and ETA."""

    def __init__(self, enabled: bool) -> None:
        self.bar = tqdm(total=1, unit="eval", desc="evaluations", disable=not enabled,
                        dynamic_ncols=True)
        self.F: list[np.ndarray] = []

    def __call__(self, done: int, budget: int, evaluation) -> None:
        self.bar.total = budget
        if evaluation is not None and evaluation.status == "ok":
            self.F.append(np.asarray(evaluation.F, float))
        post = {}
        if self.F:
            F = np.array(self.F)
            post["best"] = f"{F.max(axis=1).min():.4g}"
            if F.shape[1] == 2:
                post["HV"] = f"{hypervolume(F[np.all(F < PROGRESS_REF, axis=1)], PROGRESS_REF):.4g}"
        self.bar.set_postfix(post, refresh=False)
        self.bar.update(done - self.bar.n)

    def close(self) -> None:
        self.bar.close()


def run(args: argparse.Namespace) -> int:
    path = resolve(args.study, "study") if args.study else default_study()
    study = load_study(path)
    out = Path(args.out) if args.out else default_run_dir(study.name, args.resume)
    if args.seed is not None and args.seed < 0:
        raise InputError("--seed", "must be >= 0")
    t0 = time.perf_counter()
    print(f"study {study.name}: {study.description or path}", file=sys.stderr)
    if study.sweep is not None:
        if args.seed_from:
            raise InputError("--seed-from", "not available for sweep studies (their points "
                             "are seeded by recycling, [sweep] recycle)")
        return _run_sweep(args, study, out, t0)
    print("simulating the prototype ...", file=sys.stderr)
    bar = _Progress(enabled=sys.stderr.isatty())
    try:
        outcome = run_study(study, out, resume=args.resume, workers=args.workers,
                            scheduler=args.scheduler, seed=args.seed, progress=bar,
                            seed_runs=args.seed_from, on_written=write_report_safely)
    finally:
        bar.close()
    point = outcome.design_point
    print(f"{out}: {point['statistics']['evaluations']} evaluations in "
          f"{time.perf_counter() - t0:.1f} s")
    if point.get("design"):
        objs = ", ".join(f"{k} = {v:.4g}" for k, v in point["objectives"].items())
        print(f"design point: {objs}")
        for name, value in point["design"].items():
            print(f"  {name:>10s} = {value:.6g}")
        if point["active_constraints"]:
            print(f"  active: {', '.join(point['active_constraints'])}")
    else:
        print("no successful evaluation: see evaluations.csv for the reasons")
    if not math.isfinite(point["statistics"].get("wall_seconds") or 0.0):
        return 1
    return 0


def _run_sweep(args: argparse.Namespace, study, out: Path, t0: float) -> int:
    """``hypate run`` of a sweep study: one optimization per point, then the summary."""
    bars: list[_Progress] = []

    def on_point(i: int, n: int, point) -> None:
        if bars:
            bars.pop().close()
        print(f"[{i + 1}/{n}] {point.label}", file=sys.stderr)
        bars.append(_Progress(enabled=sys.stderr.isatty()))

    def progress(done: int, budget: int, evaluation) -> None:
        if bars:
            bars[-1](done, budget, evaluation)

    try:
        outcome = run_sweep(study, out, resume=args.resume, workers=args.workers,
                            scheduler=args.scheduler, seed=args.seed, progress=progress,
                            on_point=on_point, on_written=write_report_safely)
    finally:
        for bar in bars:
            bar.close()
    print(f"{out}: {len(outcome.points)} sweep points in {time.perf_counter() - t0:.1f} s "
          f"(summary: {out / 'sweep.csv'})")
    failed = 0
    for rec in outcome.points:
        objs = ", ".join(f"{k} = {v:.4g}" for k, v in (rec.get("objectives") or {}).items())
        active = ", ".join(rec.get("active_constraints") or [])
        print(f"  {rec['label']:>16s}  {rec['status']:>7s}  {objs}"
              + (f"  [active: {active}]" if active else ""))
        failed += rec["status"] != "done"
    return 1 if failed else 0
