"""``hypate reproduce [--quick] [--seeds N] [--jobs N|auto] [--out DIR] [--json]``: run the
dissertation reproductions (Ch. 7 tables, Ch. 8 trends, Ch. 9 studies) and write
``reproduction.html`` (:mod:`hypate.studies.scripts.reproduce`)."""
from __future__ import annotations

import argparse

from hypate.scaling.cli.arguments import integer_in, output_directory
from hypate.scaling.cli.commands import HELP
from hypate.scaling.cli.jsonout import dumps
from hypate.scaling.cli.progress import StepProgress
from hypate.scaling.engine.executors import usable_cores
from hypate.solvers.errors import InputError
from hypate.studies.scripts.reproduce import MAX_JOBS, MAX_SEEDS, Config
from hypate.studies.scripts.reproduce import run as run_reproductions


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("reproduce", help=HELP["reproduce"],
                       description="Run the dissertation reproductions (Ch. 7 tables, Ch. 8 "
                       "trends, Ch. 9 studies) and write DIR/reproduction.html: every table "
                       "as quantity | dissertation | hypate (median and min-max over seeds) "
                       "| difference, with a verdict per row against its tolerance and the "
                       "accepted findings explained next to their rows. Finished "
                       "optimizations are kept in DIR/runs and reused by a re-run.")
    p.add_argument("--quick", action="store_true", help="the coarse variants (4 x 4 meshes, "
                   "small optimization budgets; measured on 2 cores with --jobs 1: 2.2 min "
                   "with one seed, 5.1 min with three)")
    p.add_argument("--seeds", type=int, default=1, metavar="N",
                   help=f"run every Ch. 9 optimization for seeds 0 .. N-1 (1-{MAX_SEEDS}); "
                   "the page shows the median and the min-max (default 1)")
    p.add_argument("--jobs", default="auto", metavar="N",
                   help="processes that run the optimizations and scripts side by side: a "
                   f"number (1-{MAX_JOBS}; 1: one after another), or auto, the usable cores "
                   "(default). The results do not depend on it")
    p.add_argument("--out", default="reproduction", metavar="DIR",
                   help="output directory (created)")
    p.add_argument("--json", action="store_true", help="print one JSON object at the end: "
                   '{"page", "json", "quick", "seeds", "seconds", counts, "reproductions": '
                   '[{"key", "title", "summary", counts}]}')
    p.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")
    p.set_defaults(func=run)


def jobs_count(value: str) -> int:
    """The ``--jobs`` count: a number in [1, MAX_JOBS], or ``auto`` (the usable cores)."""
    if value == "auto":
        return min(usable_cores(), MAX_JOBS)
    try:
        jobs = int(value)
    except ValueError:
        jobs = 0
    if not 1 <= jobs <= MAX_JOBS:
        raise InputError("--jobs", f"must be an integer in [1, {MAX_JOBS}] or auto; "
                         f"got {value!r}")
    return jobs


def run(args: argparse.Namespace) -> int:
    seeds = integer_in(args.seeds, "--seeds", 1, MAX_SEEDS)
    jobs = jobs_count(args.jobs)
    out = output_directory(args.out, "--out")
    progress = StepProgress("reproduce", quiet=args.quiet)
    try:
        result = run_reproductions(Config(quick=args.quick, seeds=seeds, out=str(out),
                                          jobs=jobs), progress=progress)
    finally:
        progress.close()
    if args.json:
        record = result.record()
        record.pop("reproductions")
        record["json"] = str(result.json)
        # the rows and the warnings' texts are in the JSON file; here their counts
        record["reproductions"] = [
            {**{k: v for k, v in r.record().items() if k not in ("rows", "warnings")},
             "warnings": len(r.warnings)} for r in result.reproductions]
        print(dumps(record, indent=1))
        return 0
    for r in result.reproductions:
        c = r.counts()
        print(f"{r.title}: {c['match']} of {c['compared']} match"
              + (f", {c['mismatch']} NO ({c['accepted_findings']} accepted findings)"
                 if c["mismatch"] else ""))
    total = result.counts()
    print(f"{total['match']} of {total['compared']} compared rows match; "
          f"{result.seconds / 60.0:.1f} min")
    print(result.page)
    return 0
