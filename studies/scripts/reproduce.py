"""The dissertation reproductions as one run (issue 21): Ch. 7 tables, Ch. 8 trends, Ch. 9
studies, each a table ``quantity | dissertation | hypate | difference | matches``
(:mod:`.comparison`), and the page ``reproduction.html`` (:mod:`.reproduction_page`).

What runs (:func:`~.reproduction_plan.plan`, with the builders of the tables and their
tolerances and accepted findings in :mod:`.reproduction_plan`):

* the deterministic scripts once: ``ch7_table7_3_modes``, ``ch7_flutter``, ``ch7_benchmark``,
  ``ch7_time_accuracy``, ``ch8_effects``, ``ch9_table9_3`` (``quick``: their ``--coarse``
  configurations; full: their defaults, ``ch7_flutter`` with its time-domain rows);
* Sec. 9.1 (Table 9.3, Figs. 9.3-9.4): the Bayesian optimization of ``sec9_1_xi*`` per seed,
  and the optimum of J_u next to Eq. 9.2 by Nelder-Mead (:func:`~.ch9_runs.j_u_optimum`; the
  accepted Poisson's-ratio finding, :data:`~.reproduction_plan.FINDING_POISSON`);
* Sec. 9.2.2 (Table 9.8), Sec. 9.2.3 (Tables 9.9-9.10, Fig. 9.13: Case 2 against Case 1,
  the accepted WT5 finding :data:`~.reproduction_plan.FINDING_WT5`) per seed; Sec. 9.2.4
  (Table 9.11, the envelope sweep) per seed in the full run only. The full run also
  evaluates each published design point of Tables 9.8-9.10 in hypate and checks that the
  run's own design point beats it (:func:`~.ch9_tables.published_rows`), the premise of the
  accepted finding on the design-variable rows and Table 9.11
  (:data:`~.ch9_tables.FINDING_SEC9_2_MODEL`), and puts Table 9.8's xi = 4 design and the
  first seed's envelope designs through the CFD fluid ROM too (``sec9_2_2_fluids``,
  ``sec9_2_4_fluids``: the fluid model's share, measured), and optimizes on it: the xi = 4
  study per seed and the envelope sweep for the first seed, beside their ``pt-bl`` + Eckert
  runs (``sec9_2_2_cfd``, ``sec9_2_4_cfd``).

``quick`` runs the Ch. 9 studies as coarse variants (:data:`~.ch9_runs.COARSE_9_1`,
:data:`~.ch9_runs.COARSE_9_2`: 4 x 4 meshes, fewer steps, 36-50 evaluations) with their own stated
tolerances, or no verdict where such a budget cannot resolve the dissertation's number (the
row says so: :class:`~.comparison.NotCompared`). Optimizations run for the seeds
``0 .. seeds - 1``; their rows show the median and the min-max over seeds, the verdict is
on the median.

Nothing finished is lost: every optimization is a ``hypate run`` directory
``OUT/runs/{quick,full}/seed<k>/<study>`` (a finished one is read again, an interrupted one
resumed, by :func:`~.ch9_runs.run_directory`), and after each reproduction its table
(``OUT/tables/<key>.csv``, ``.md``), ``OUT/reproduction.json`` and the page are rewritten.
The slow Ch. 9 tests read their run directories through :func:`~.ch9_runs.run_directory` as well.

Side by side (``Config.jobs > 1``, ``hypate reproduce --jobs``): a local process pool runs
the optimizations and the deterministic scripts in the order of :func:`schedule`, while this
process writes the tables in page order as their inputs finish (the first failure in the
pool ends the run; Ctrl-C terminates the workers, and a re-run resumes their runs). Each
optimization stores the same evaluations in either mode (designs and objectives bit for
bit: tested), so the page does not depend on the number of jobs; the wall time does, and a
pooled table's seconds are its jobs' own.

Run ``python -m hypate.studies.scripts.reproduce [--coarse] [--seeds N] [--jobs N]
[--out DIR]`` (the command line is ``hypate reproduce``).
"""
from __future__ import annotations

import argparse
import json
import math
import time
import warnings
from collections.abc import Callable, Sequence
from concurrent.futures import Future
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

import pandas as pd
from hypate.scaling.engine.executors import ResilientProcessPool
from hypate.studies.scripts.ch9_runs import Optimization, budget, run_directory, runs_root
from hypate.studies.scripts.comparison import (
    accepted_findings,
    mismatches,
    summary,
    write_table,
)
from hypate.studies.scripts.reproduction_page import PAGE_NAME, write_page
from hypate.studies.scripts.reproduction_plan import Context, Item, Progress, plan

#: The JSON record of a reproduction run (every table's rows), next to the page.
RESULT_JSON = "reproduction.json"
#: Largest ``--seeds``: each seed repeats every Ch. 9 optimization.
MAX_SEEDS = 20
#: Largest ``--jobs`` (processes side by side).
MAX_JOBS = 64
# -- the run ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class Reproduction:
    """One finished reproduction: its table and what it took."""

    key: str
    chapter: str
    title: str
    table: pd.DataFrame
    seconds: float
    seeds: int
    warnings: tuple[str, ...] = ()

    def counts(self) -> dict[str, int]:
        """Rows, compared rows, matches, mismatches and accepted findings of the table."""
        compared = int(sum(m is not None and not (isinstance(m, float) and math.isnan(m))
                           for m in self.table["matches"]))
        bad = len(mismatches(self.table))
        return {"rows": len(self.table), "compared": compared, "match": compared - bad,
                "mismatch": bad, "accepted_findings": len(accepted_findings(self.table))}

    def record(self) -> dict[str, Any]:
        """JSON-ready record (NaN written as null)."""
        rows = json.loads(self.table.to_json(orient="records"))
        return {"key": self.key, "chapter": self.chapter, "title": self.title,
                "seconds": self.seconds, "seeds": self.seeds, "summary": summary(self.table),
                **self.counts(), "warnings": list(self.warnings), "rows": rows}


@dataclass(frozen=True)
class Config:
    """Settings of :func:`run`.

    Parameters
    ----------
    quick : bool
        The coarse variants (``hypate reproduce --quick``).
    seeds : int
        Optimizer seeds 0 .. seeds - 1 of every Ch. 9 optimization (1 <= seeds <=
        :data:`MAX_SEEDS`).
    out : path
        Output directory (``reproduction.html``, ``reproduction.json``, ``tables/``,
        ``runs/``).
    only : tuple of str
        Keys of the reproductions to run (empty: all of :func:`plan`).
    jobs : int
        Processes that run the optimizations and the deterministic scripts side by side
        (1: one after another in this process; :func:`schedule` says in which order). The
        results do not depend on it: each optimization is the same ``hypate run`` wherever
        it runs.
    """

    quick: bool = False
    seeds: int = 1
    out: str = "reproduction"
    only: tuple[str, ...] = ()
    jobs: int = 1

    @classmethod
    def coarse(cls) -> Config:
        """The ``--quick`` run (one seed)."""
        return cls(quick=True)


@dataclass
class Result:
    """The reproductions finished so far, and the files written."""

    config: Config
    reproductions: list[Reproduction] = field(default_factory=list)
    planned: int = 0
    seconds: float = 0.0
    page: Path | None = None
    json: Path | None = None

    @property
    def finished(self) -> bool:
        return len(self.reproductions) == self.planned

    def counts(self) -> dict[str, int]:
        """Totals of :meth:`Reproduction.counts` over the reproductions."""
        keys = ("rows", "compared", "match", "mismatch", "accepted_findings")
        return {k: sum(r.counts()[k] for r in self.reproductions) for k in keys}

    def record(self) -> dict[str, Any]:
        return {"quick": self.config.quick, "seeds": self.config.seeds,
                "finished": self.finished, "planned": self.planned,
                "seconds": self.seconds, **self.counts(),
                "page": str(self.page) if self.page else None,
                "reproductions": [r.record() for r in self.reproductions]}


def _write(result: Result, out: Path) -> None:
    """Rewrite ``reproduction.json`` and the page (atomically: never half-written)."""
    out.mkdir(parents=True, exist_ok=True)
    path = out / RESULT_JSON
    tmp = path.with_name(path.name + ".tmp")
    result.page = out / PAGE_NAME
    tmp.write_text(json.dumps(result.record(), indent=1, allow_nan=False), encoding="utf-8")
    tmp.replace(path)
    result.json = path
    write_page(result, result.page)


def check_config(config: Config) -> None:
    """Refuse settings out of range before anything runs (:class:`ValueError` naming the
    setting; the command line turns it into its flag)."""
    if not 1 <= int(config.seeds) <= MAX_SEEDS:
        raise ValueError(f"seeds must be an integer in [1, {MAX_SEEDS}]; got {config.seeds}")
    if not (isinstance(config.jobs, int) and 1 <= config.jobs <= MAX_JOBS):
        raise ValueError(f"jobs must be an integer in [1, {MAX_JOBS}]; got {config.jobs!r}")
    known = {item.key for item in plan()}
    unknown = sorted(set(config.only) - known)
    if unknown:
        raise ValueError(f"only: unknown reproduction(s) {', '.join(unknown)}; "
                         f"known: {', '.join(sorted(known))}")


# -- side by side: a process pool (``jobs > 1``) -------------------------------------------------
def schedule(items: Sequence[Item], ctx: Context) -> list[tuple[str, Any]]:
    """The pool's jobs in submission order: ``("run", (name, seed))`` per optimization and
    seed, ``("build", key)`` per deterministic item.

    The costliest optimization goes first, then the deterministic scripts, then the other
    optimizations costliest first (:func:`~.ch9_runs.budget`; among equal costs seed by
    seed, in page order, the order the tables read them): one process stays on the long
    pole (the full run's envelope sweep on the CFD ROM, some 5 h) while the others clear
    the scripts and fill in behind it, so no long job starts last.
    """
    runs = list(dict.fromkeys((name, seed) for seed in range(ctx.seeds) for item in items
                              if seed == 0 or not item.first_seed
                              for name in item.studies(ctx.quick)))  # once per study
    cost = {name: budget(Optimization(name, ctx.quick)) for name, _ in runs}
    runs.sort(key=lambda r: -cost[r[0]])  # stable: seed by seed, page order
    builds = [("build", item.key) for item in items if not item.in_main]
    jobs = [("run", r) for r in runs]
    return jobs[:1] + builds + jobs[1:]


def _caught(fn: Callable[[], Any]) -> tuple[Any, tuple[str, ...]]:
    """``fn()`` and the distinct warnings it raised (``"Category: message"``)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("default")  # each distinct warning once
        value = fn()
    return value, tuple(dict.fromkeys(f"{w.category.__name__}: {w.message}" for w in caught))


def _run_job(name: str, quick: bool, out: str, seed: int) -> tuple[tuple[str, ...], float]:
    """Pool job: one optimization's run directory (:func:`run_directory`); its warnings and
    seconds."""
    start = time.monotonic()
    seen = _caught(lambda: run_directory(Optimization(name, quick),
                                         runs_root(out, quick, seed), seed))[1]
    return seen, time.monotonic() - start


def _build_job(key: str, quick: bool, seeds: int, out: str
               ) -> tuple[pd.DataFrame, tuple[str, ...], float]:
    """Pool job: a deterministic item's table, its warnings and its seconds."""
    item = next(i for i in plan() if i.key == key)
    start = time.monotonic()
    table, seen = _caught(lambda: item.build(Context(quick, seeds, Path(out))))
    return table, seen, time.monotonic() - start


def _submit(pool: ResilientProcessPool, items: Sequence[Item], ctx: Context,
            config: Config) -> dict[str, Future]:
    """Submit :func:`schedule`'s jobs; the optimizations' futures go to ``ctx.pending``,
    the deterministic items' are returned by key."""
    built = {}
    for kind, what in schedule(items, ctx):
        if kind == "run":
            job = ctx.pending[what] = pool.submit(_run_job, what[0], ctx.quick, config.out,
                                                  what[1])
        else:
            job = built[what] = pool.submit(_build_job, what, ctx.quick, ctx.seeds, config.out)
        ctx.jobs.append(job)
    return built


def run(config: Config | None = None, progress: Progress | None = None) -> Result:
    """Run the reproductions of ``config`` into ``config.out``.

    After each one its table is written (``tables/<key>.csv``, ``.md``) and
    ``reproduction.json`` and ``reproduction.html`` are rewritten, so an interrupted run
    keeps what finished (and its optimizations resume: :func:`run_directory`).

    Parameters
    ----------
    config : Config, optional
    progress : callable, optional
        ``progress(step, done, total)`` (a :class:`hypate.scaling.cli.progress.StepProgress`).

    Returns
    -------
    Result
    """
    config = Config() if config is None else config
    check_config(config)
    out = Path(config.out)
    items = [i for i in plan() if not config.only or i.key in config.only]
    result = Result(config, planned=len(items))
    ctx = Context(config.quick, int(config.seeds), out, progress)
    t0 = time.monotonic()
    n_jobs = len(schedule(items, ctx)) if config.jobs > 1 else 0
    # workers ignore Ctrl-C: the parent ends them (terminate: their runs resume on a re-run)
    pool = (ResilientProcessPool(min(config.jobs, n_jobs), ignore_interrupt=True)
            if n_jobs > 1 else None)
    try:
        built = _submit(pool, items, ctx, config) if pool is not None else {}
        for item in items:
            start = time.monotonic()
            ctx.report(item.title, 0, 1)
            for carried in (ctx.carried, ctx.carried_seconds, ctx.waited_seconds):
                carried.clear()
            if item.key in built:  # solver warnings: counted, each distinct one once
                table, seen, seconds = ctx.wait_for(item.title, built[item.key])
            else:
                table, seen = _caught(partial(item.build, ctx))
                seen = tuple(dict.fromkeys(ctx.carried + list(seen)))
                # pooled optimizations: their own seconds, not the wait for them
                seconds = (time.monotonic() - start - sum(ctx.waited_seconds)
                           + sum(ctx.carried_seconds))
            rep = Reproduction(item.key, item.chapter, item.title, table, seconds,
                               ctx.seeds if item.seeded else 1, seen)
            result.reproductions.append(rep)
            result.seconds = time.monotonic() - t0
            write_table(table, out / "tables", item.key, item.title)
            _write(result, out)
            ctx.report(item.title, 1, 1)
    finally:
        if pool is not None:
            pool.terminate()
    return result


def main(argv: list[str] | None = None) -> None:
    """``python -m hypate.studies.scripts.reproduce [--coarse] [--seeds N] [--jobs N]
    [--out DIR]``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--coarse", action="store_true", help="the quick (coarse) variants")
    parser.add_argument("--seeds", type=int, default=1)
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--out", default="reproduction")
    args = parser.parse_args(argv)
    res = run(Config(quick=args.coarse, seeds=args.seeds, out=args.out, jobs=args.jobs))
    for r in res.reproductions:
        print(f"{r.title}: {summary(r.table)}")
    print(res.page)


if __name__ == "__main__":
    main()
