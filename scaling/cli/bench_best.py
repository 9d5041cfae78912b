"""``hypate bench best STUDY [--seeds N | --runs DIR ...] [--starts K] [--evaluations M]``:
the best known admissible design of a study (:mod:`hypate.scaling.workflow.analyses.best_known`).

Runs the study for ``--seeds`` seeds (or reads finished ``--runs``), then a bounded
Nelder-Mead on max(J_u, J_T) from each of the ``--starts`` best admissible designs found,
``--evaluations`` simulator evaluations each. Prints the best admissible design with its
J, and writes every evaluation to ``OUT/search.csv`` and the record to ``OUT/best.json``
(``study``, ``value``, ``J_u``, ``J_T``, ``design``, ``evaluations`` -- the runs' and the
search's --, ``starts``): what ``scaling/data/best_known.toml`` holds for a shipped study.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np
from hypate.scaling.cli.jsonout import dumps
from hypate.scaling.cli.run import resolve_workers
from hypate.scaling.workflow.analyses.best_known import best_known_search, candidate_designs
from hypate.scaling.workflow.campaigns.execute import execute
from hypate.scaling.workflow.campaigns.run import RunOutcome
from hypate.scaling.workflow.campaigns.seeds import seed_directory, seed_list
from hypate.scaling.workflow.vocabulary.shipped import resolve
from hypate.scaling.workflow.vocabulary.study import load_study
from hypate.solvers.errors import InputError


def register_bench(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("best", help="best known admissible design: multistart local search",
                       description="Run a study for several seeds (or read finished runs), "
                       "then Nelder-Mead on max(J_u, J_T) from the best admissible designs "
                       "found; print and record the best admissible design.")
    p.add_argument("study", help="study TOML file or a shipped study's name")
    p.add_argument("--seeds", type=int, default=10, help="runs of the study, seeds S .. "
                   "S+N-1, whose best designs start the search (10; ignored with --runs)")
    p.add_argument("--seed", type=int, help="first seed (default: the study's)")
    p.add_argument("--runs", nargs="+", metavar="DIR", help="finished run directories to "
                   "start from instead of new runs")
    p.add_argument("--starts", type=int, default=4, help="local searches (4)")
    p.add_argument("--evaluations", type=int, default=120,
                   help="simulator evaluations per local search (120)")
    p.add_argument("--workers", default="auto", help="workers of the runs (default auto)")
    p.add_argument("--out", required=True, help="folder of the runs, search.csv, best.json")
    p.add_argument("--json", action="store_true", help="print the record as JSON")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if not 1 <= args.starts <= 100:
        raise InputError("--starts", f"must be in [1, 100]; got {args.starts}")
    if not 10 <= args.evaluations <= 100000:
        raise InputError("--evaluations", f"must be in [10, 100000]; got {args.evaluations}")
    if args.runs is None and not 1 <= args.seeds <= 100:
        raise InputError("--seeds", f"must be in [1, 100]; got {args.seeds}")
    study = load_study(resolve(args.study, "study"))
    if study.spec.choices or study.lower_levels or study.sweep is not None:
        raise InputError("study", "the local search runs over continuous variables of one "
                         "single-fidelity study: no categorical variable, [[fidelity]] or "
                         "[sweep]")
    out = Path(args.out)
    runs = [Path(r) for r in args.runs] if args.runs else []
    spent = 0
    if not runs:
        workers = resolve_workers(args.workers, study)
        for s in seed_list(study.optimizer.seed if args.seed is None else args.seed,
                           args.seeds):
            d = seed_directory(out / "runs", s)
            print(f"bench best: {study.name}, seed {s} ...", file=sys.stderr, flush=True)
            outcome = execute(study, d, workers=workers, seed=s,
                              resume=(d / "evaluations.sqlite").is_file())
            # one campaign (no sweep, no seeds, no on_complete: never None)
            assert isinstance(outcome, RunOutcome)
            spent += len(outcome.result.data)
            runs.append(d)
    starts = candidate_designs(study, runs, args.starts)
    if not starts:
        raise InputError("--runs", "no admissible successful evaluation to start from")

    def progress(done: int, total: int, best: float) -> None:
        if done % 20 == 0 or done == total:
            print(f"bench best: {done}/{total} search evaluations, best max(J) "
                  f"{100 * best:.3f} %", file=sys.stderr, flush=True)

    result = best_known_search(study, starts, args.evaluations, out, progress)
    best = result.best
    record: dict[str, Any] = {"study": study.name, "value": None if best is None
                              else float(best["value"]),
                              "evaluations": spent + len(result.rows),
                              "search_evaluations": len(result.rows),
                              "starts": [dict(zip(study.spec.names, map(float, x)))
                                         for x in starts]}
    if best is not None:
        record.update(J_u=float(best["J_u"]), J_T=float(best["J_T"]),
                      design=dict(zip(study.spec.names, map(float, np.asarray(best["x"])))))
    (out / "best.json").write_text(json.dumps(record, indent=2))
    if args.json:
        print(dumps(record, indent=2))
    elif best is None:
        print(f"{study.name}: no admissible design in {len(result.rows)} search evaluations")
    else:
        print(f"{study.name}: best known max(J_u, J_T) = {100 * best['value']:.3f} % "
              f"(J_u {100 * best['J_u']:.3f} %, J_T {100 * best['J_T']:.3f} %) after "
              f"{record['evaluations']} evaluations ({len(result.rows)} in the search)")
        for name, value in record["design"].items():
            print(f"  {name:>10s} = {value:.6g}")
    return 0
