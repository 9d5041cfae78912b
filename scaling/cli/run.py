"""``hypate run [STUDY.toml]``: run a scaling study (the main job).

How a study runs (single, seeds, sweep, robust) is decided by the runner,
:func:`hypate.scaling.workflow.campaigns.execute.execute`; this module shows it on the terminal
(:class:`Terminal`: the runner's hooks) and turns its end into one line and an exit code.
Size: about 640 lines, the terminal output of every way a study runs and of every way it
can stop.
"""
from __future__ import annotations

import argparse
import contextlib
import json
import math
import shlex
import sys
import time
import warnings
from collections import Counter
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from hypate.scaling.cli import jsonout
from hypate.scaling.cli.commands import HELP
from hypate.scaling.cli.failures import (
    EXIT_INFRASTRUCTURE,
    EXIT_NO_RESULT,
    EXIT_OUTPUT,
    interrupt_code,
    interrupt_word,
    is_write_failure,
    write_failure,
)
from hypate.scaling.cli.progress import Progress, StepProgress
from hypate.scaling.engine.executors import LOST_AFTER, auto_workers, usable_cores
from hypate.scaling.engine.faults import InfrastructureError
from hypate.scaling.engine.problem import summarize_warnings, tally_warnings
from hypate.scaling.engine.store import EvaluationStore, StoreError
from hypate.scaling.report.html import write_report, write_report_safely
from hypate.scaling.workflow.campaigns.execute import (
    RunStart,
    SeedsOutcome,
    check_request,
    default_run_dir,
    execute,
)
from hypate.scaling.workflow.campaigns.integrity import missing_outputs
from hypate.scaling.workflow.campaigns.resources import local_workers, study_estimate
from hypate.scaling.workflow.campaigns.robust import NOMINAL_DIR, robust_budget
from hypate.scaling.workflow.campaigns.run import RunOutcome
from hypate.scaling.workflow.campaigns.rundir import (
    DESIGN_POINT_JSON,
    REPORT_HTML,
    SEEDS_CSV,
    STORE,
    SWEEP_CSV,
    SWEEP_JSON,
    describe_occurrences,
)
from hypate.scaling.workflow.campaigns.sweep import SweepOutcome
from hypate.scaling.workflow.campaigns.verdict import prototype_note
from hypate.scaling.workflow.vocabulary.shipped import default_study, resolve
from hypate.scaling.workflow.vocabulary.study import Study, load_study
from hypate.scaling.workflow.vocabulary.variables import CATEGORICAL
from hypate.solvers.errors import InputError


class ReportFailed(Exception):
    """The report of a finished campaign could not be written (its cause chained)."""


def write_run_report(run_dir: Path) -> Path:
    """``report.html`` and ``figures/`` of a run that just wrote its outputs; a failure
    (other than a failed write, handled as such) raises :class:`ReportFailed`, so that the
    run ends with one line and a resume writes the report (the run is not complete
    without it)."""
    try:
        return write_report(run_dir)
    except OSError:
        raise
    except (ValueError, KeyError, RuntimeError, InputError) as exc:
        raise ReportFailed(f"{run_dir / REPORT_HTML} not written: {exc}") from exc


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("run", help=HELP["run"],
                       description="Optimize a wind-tunnel model whose nondimensional "
                       "aerothermoelastic response matches the prototype's. Writes "
                       "evaluations.sqlite/.csv, pareto.csv and design_point.json to --out; "
                       "a study with a [sweep] table runs one optimization per sweep point "
                       "into --out/<point> and writes --out/sweep.json and sweep.csv.")
    p.add_argument("study", nargs="?",
                   help="study TOML file or a shipped study's name (default: the quick-start)")
    p.add_argument("--out", help="run directory (default: runs/<study name>, numbered -2, "
                   "-3 ... when it exists)")
    p.add_argument("--resume", action="store_true", help="continue the run in --out")
    p.add_argument("--workers", default="auto", help="local worker processes: a number, or "
                   "auto (default): the usable cores, capped by the study's [optimizer] "
                   "batch_size (the designs proposed per iteration; the results depend on "
                   "the batch, not on the workers)")
    p.add_argument("--scheduler", help="Dask scheduler address tcp://HOST:PORT (tls://HOST:PORT "
                   "for a secured cluster), or local:N to start a cluster of N workers on "
                   "this machine (with Dask's dashboard)")
    p.add_argument("--cluster-timeout", type=float, default=LOST_AFTER, metavar="SECONDS",
                   help="a cluster whose scheduler is unreachable, or which has no worker, "
                   "for this long is lost: the run stops with exit code 3")
    p.add_argument("--seed", type=int, help="override the study's optimizer seed")
    p.add_argument("--seeds", type=int, metavar="N",
                   help="run the study once per seed S, S+1, ..., S+N-1 (S: --seed or the "
                   "study's) into --out/seed-<s>/ and write --out/seeds.json and seeds.csv: "
                   "each seed's design point and the spread; each report shows the spread "
                   "(default: one run)")
    p.add_argument("--json", action="store_true", help="print one JSON object at the end "
                   '{"directory", "report", "evaluations", "new_evaluations", "seconds", '
                   '"design_point"} (progress still goes to stderr)')
    p.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    p.add_argument("-v", "--verbose", action="store_true", help="show every solver warning "
                   "as it is recorded, with its evaluation (otherwise: one summary line per "
                   "kind at the end, with the evaluations it occurred in)")
    p.add_argument("--seed-from", action="append", default=[], metavar="RUN_DIR",
                   help="seed the initial sample with the 10 best designs of an earlier run "
                   "(repeatable; e.g. Case 1 for the Case 2 strategy); variables it lacks "
                   "take the model template's values")
    p.add_argument("--force", action="store_true", help="run even when the estimated memory "
                   "of the simulations exceeds what this machine has available (the estimate "
                   "and the refusal happen before the first simulation)")
    p.set_defaults(func=run, field_flags={"out": "--out", "resume": "--resume",
                                          "workers": "--workers", "scheduler": "--scheduler",
                                          "seed": "--seed", "seed_runs": "--seed-from",
                                          "lost_after": "--cluster-timeout", "seeds": "--seeds"})


@contextlib.contextmanager
def collected_warnings(verbose: bool) -> Iterator[list[warnings.WarningMessage]]:
    """Collect the Python warnings the CLI process raises outside the evaluations (which
    record their own) instead of printing them into the progress bar (``verbose``: print
    them as they come, collect nothing)."""
    if verbose:
        yield []
        return
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")  # count every occurrence
        yield caught


def print_warnings(place: str, entries: Sequence[str]) -> None:
    """``-v``: the warnings recorded at ``place`` (``"prototype"``), one line each."""
    for entry in entries:
        print(f"{place}: {entry}", file=sys.stderr)


def run_warnings(run_dir: Path, first: int = 0) -> list[tuple[int, tuple[str, ...]]]:
    """``(evaluation id, warnings)`` of the evaluations of a run directory's store from id
    ``first`` on (those of this run after a resume) that recorded any, read-only."""
    if not (run_dir / STORE).is_file():
        return []
    with EvaluationStore(run_dir / STORE, read_only=True) as store:
        rows = store.load()
    return [(i, r.warnings) for i, r in enumerate(rows) if i >= first and r.warnings]


def warning_summary(caught: Iterable[warnings.WarningMessage],
                    evaluations: Iterable[tuple[Any, Sequence[str]]] = (),
                    prototype: Sequence[str] = ()) -> list[str]:
    """One line per distinct warning, most frequent first, saying where it occurred:
    ``"  RuntimeWarning: ...: prototype, evaluations 3, 7-9 (5 times)"``.

    Parameters
    ----------
    caught : iterable of warnings.WarningMessage
        Raised in the CLI process outside the prototype and the evaluations (the
        optimizer, the design point's re-simulation, the report): attributed to "run".
    evaluations : iterable of (id, entries)
        Each evaluation's recorded warnings (:func:`run_warnings`).
    prototype : sequence of str
        The prototype simulation's recorded warnings.

    Returns
    -------
    list of str
        A heading and the lines; empty without warnings.
    """
    tally = tally_warnings([("prototype", prototype), *evaluations,
                            ("run", summarize_warnings(caught))])
    if not tally:
        return []
    total = sum(n for _, _, n in tally)
    head = (f"{total} solver warnings of {len(tally)} kinds during the run "
            "(-v shows each as it is recorded; evaluation ids as in evaluations.csv):")
    return [head, *(f"  {text}: {describe_occurrences(labels)} ({n} time"
                    f"{'' if n == 1 else 's'})" for text, labels, n in tally)]


def stored_evaluations(run_dir: Path) -> int:
    """Evaluations already in a run directory's store (0 without one), read-only."""
    if not (run_dir / STORE).is_file():
        return 0
    try:
        with EvaluationStore(run_dir / STORE, read_only=True) as store:
            return len(store)
    except StoreError as exc:
        raise InputError("resume", str(exc)) from None


def stored_objectives(run_dir: Path) -> list[np.ndarray]:
    """Objectives of the successful evaluations in a run directory's store (none without
    one), read-only: a resumed run's progress starts from them."""
    if not (run_dir / STORE).is_file():
        return []
    with EvaluationStore(run_dir / STORE, read_only=True) as store:
        return [np.asarray(r.F, float) for r in store.load() if r.ok]


def failure_reasons(run_dir: Path, limit: int = 5) -> list[str]:
    """The most frequent failure messages of a run's evaluations: ``"12 x error: ..."``."""
    with EvaluationStore(run_dir / STORE, read_only=True) as store:
        counts = Counter(f"{r.status}: {r.message[:120]}" for r in store.load() if not r.ok)
    return [f"  {n} x {text}" for text, n in counts.most_common(limit)]


def resume_command(args: argparse.Namespace, out: Path) -> str:
    """The command that continues an interrupted run (of every seed, for ``--seeds``),
    quoted for a POSIX shell; without ``--resume`` when nothing was stored yet (a run
    stopped before its store existed starts again)."""
    study = [args.study] if args.study else []
    seeds = getattr(args, "seeds_run", None)
    if seeds is not None:  # one seed of a --seeds run: continue them all
        first, n, parent = seeds
        words = ["hypate", "run", *study, "--seeds", str(n), "--seed", str(first),
                 "--out", str(parent)]
        started = Path(parent).is_dir()
    else:
        words = ["hypate", "run", *study, "--out", str(out)]
        started = (out / STORE).is_file() or (out / SWEEP_JSON).is_file()
    return shlex.join(words + ["--resume"] * started)


def _summary(out: Path, point: dict[str, Any], before: int, seconds: float) -> dict[str, Any]:
    n = int(point["statistics"]["evaluations"])
    report = out / REPORT_HTML
    stats = point["statistics"]
    return {"directory": str(out), "report": str(report) if report.is_file() else None,
            "evaluations": n, "new_evaluations": n - before, "seconds": seconds,
            "failed": int(stats.get("failed", 0)), "admissible_evaluations":
                stats.get("admissible"),
            "failed_iterations": stats.get("failed_iterations"),
            "iteration_evaluations": stats.get("iteration_evaluations"),
            "design_point": {k: point.get(k) for k in ("design", "objectives",
                                                       "active_constraints", "scatter",
                                                       "robust", "robust_search",
                                                       "nominal", "chosen", "admissible",
                                                       "binding", "message",
                                                       "prototype_admissibility", "stopping")
                             if k in ("design", "objectives", "active_constraints")
                             or k in point}}


def _print_summary(summary: dict[str, Any], before: int) -> None:
    n, new, t = summary["evaluations"], summary["new_evaluations"], summary["seconds"]
    done = (f"resumed: {before} earlier + {new} new evaluations" if before
            else f"{n} evaluations")
    print(f"{summary['directory']}: {done}, {t:.1f} s in this run")
    point = summary["design_point"]
    if point.get("design"):
        objs = ", ".join(f"{k} = {v:.4g}" for k, v in point["objectives"].items())
        print(f"design point: {objs}")
        for name, value in point["design"].items():  # a categorical value by its name
            shown = (point[name]["name"] if name in CATEGORICAL and name in point
                     else f"{value:.6g}")
            print(f"  {name:>10s} = {shown}")
        if point["active_constraints"]:
            print(f"  active: {', '.join(point['active_constraints'])}")
        if "admissible" in point:
            state = "admissible" if point["admissible"] else "NOT admissible"
            binding = point.get("binding") or []
            enforced = [b for b in binding if " only" not in b]
            print(f"  {state}; binding limits: " + ("; ".join(enforced) or "none"))
            for line in (b for b in binding if " only" in b):
                print(f"  beyond its limit (not enforced): {line}")
        nominal = point.get("nominal")
        if nominal:
            _print_scatter("robust search's design",
                           (point.get("robust_search") or {}).get("robust"))
            _print_scatter(f"nominal optimum ({nominal['directory']}/)", nominal.get("robust"))
            print(f"  the design point is the {point.get('chosen')}")
        else:
            _print_scatter("design point", point.get("scatter"))
    else:
        print("no successful evaluation: see evaluations.csv for the reasons")
    note = prototype_note(point.get("prototype_admissibility") or [])
    if note:
        print(note)
    for line in point.get("binding") or []:
        if line.startswith("data ") and "VIOLATED" in line:  # clamped property tables
            print(f"hypate: error: the design point's model leaves its material's property "
                  f"data ({line}); its results rest on clamped tables", file=sys.stderr)
    if point.get("design") and point.get("admissible") is False:
        print(f"hypate: error: {point.get('message') or 'the design point is not admissible'}"
              "; see the report's admissibility table", file=sys.stderr)
    print(f"failed evaluations: {summary['failed']} of {n}"
          + (f" ({summary['failed_iterations']} of the {summary['iteration_evaluations']} "
             "after the initial design)" if summary.get("iteration_evaluations") else "")
          + (f"; admissible: {summary['admissible_evaluations']}"
             if summary.get("admissible_evaluations") is not None else ""))
    stopping = point.get("stopping")
    if stopping:
        why = ("converged before iteration " + str(stopping["iteration"])
               if stopping["reason"] == "converged" else "spent its iteration cap")
        print(f"the run {why} (stopping rule of iterations = \"auto\")")
    if summary["report"]:
        print(f"report: {summary['report']}")


def _print_scatter(what: str, scatter: dict[str, Any] | None) -> None:
    """One line: max(J_u, J_T) under the study's scatter at a design."""
    if scatter and "objectives" in scatter:
        st = scatter["objectives"]["J_max"]
        def pct(v: float | None) -> str:
            return "inf" if v is None else f"{100 * v:.3g} %"
        print(f"  {what} under the study's scatter ({scatter['samples']} simulator runs, "
              f"{scatter['failed']} failed): max(J_u, J_T) mean {pct(st['mean'])}, "
              f"q90 {pct(st['q90'])}")
    elif scatter:
        print(f"  {what} under the study's scatter: {scatter.get('status')}")


def resolve_workers(value: str | int, study: Study) -> int:
    """The ``--workers`` count: a number >= 1, or ``auto``
    (:func:`~hypate.scaling.engine.executors.auto_workers` of the study's batch); a number
    above the usable cores is capped to them, with one line saying so."""
    if value == "auto":
        return auto_workers(study.optimizer.batch_size)
    try:
        workers = int(value)
    except (TypeError, ValueError):
        workers = 0
    if workers < 1:
        raise InputError("--workers", f"must be >= 1 (a number, or auto); got {value!r}")
    cores = usable_cores()
    if workers > cores:  # more processes than cores only share them: said once
        print(f"--workers {workers}: this machine gives the run {cores} core"
              f"{'s' * (cores > 1)}; using {cores} workers", file=sys.stderr)
        return cores
    return workers


def run(args: argparse.Namespace) -> int:
    path = resolve(args.study, "study") if args.study else default_study()
    study = load_study(path)
    args.workers = resolve_workers(args.workers, study)
    kind = check_request(study, args.seeds, args.seed_from)
    if kind == "seeds" and args.json:
        raise InputError("--json", "not available with --seeds (seeds.json holds the result)")
    out = Path(args.out) if args.out else default_run_dir(study.name, args.resume)
    say = (lambda *a: None) if args.quiet else (lambda *a: print(*a, file=sys.stderr))
    say(f"study {study.name}: {study.description or path}")
    if args.out is None and out.name != study.name and not args.resume:
        say(f"runs/{study.name} exists: this run writes {out} "
            f"(hypate run --resume continues the latest)")
    if kind == "seeds":  # an interrupted seed: continue them all
        first = study.optimizer.seed if args.seed is None else args.seed
        args.seeds_run = (first, args.seeds, out)
    terminal = Terminal(args, study, kind, say, out)
    try:
        with collected_warnings(args.verbose) as caught:
            terminal.caught = caught
            outcome = execute(
                study, out, resume=args.resume, workers=args.workers,
                scheduler=args.scheduler, seed=args.seed, seeds=args.seeds,
                seed_runs=args.seed_from, progress=terminal.progress,
                on_run=terminal.start, on_done=terminal.done, on_complete=terminal.complete,
                on_written=write_run_report, on_seeds_written=write_report_safely,
                on_warnings=print_warnings if args.verbose else None,
                on_scatter=terminal.scatter, lost_after=args.cluster_timeout,
                force=args.force)
    except KeyboardInterrupt as exc:  # Ctrl-C or SIGTERM
        terminal.close()
        return interrupted(args, out, exc)
    except InfrastructureError as exc:
        terminal.close()
        return infrastructure_lost(args, out, exc)
    except ReportFailed as exc:
        terminal.close()
        return output_failed(args, out, str(exc), "fix that")
    except MemoryError:
        terminal.close()
        return output_failed(args, out, "out of memory in a simulation (--force ran a "
                             "study beyond the estimate, or other work took the memory)",
                             "use a coarser [simulation] mesh or fewer --workers")
    except OSError as exc:
        if not is_write_failure(exc):
            raise
        terminal.close()
        return output_failed(args, out, *write_failure(exc))
    finally:
        terminal.close()
    if isinstance(outcome, SweepOutcome):
        return _sweep_summary(args, out, outcome, terminal, caught)
    if isinstance(outcome, SeedsOutcome):
        return _seeds_summary(out, outcome, terminal)
    return terminal.code


class Terminal:
    """What ``hypate run`` shows of a run: the hooks of
    :func:`~hypate.scaling.workflow.campaigns.execute.execute` (a progress bar per campaign, the
    scatter's step lines, each campaign's summary) and the exit code they imply."""

    def __init__(self, args: argparse.Namespace, study: Study, kind: str, say,
                 out: Path) -> None:
        self.args, self.study, self.kind, self.say = args, study, kind, say
        self.bars: list[Progress] = []
        self.steps: list[StepProgress] = []  # made when a scatter starts: its clock too
        self.caught: list[warnings.WarningMessage] = []
        self.mark = 0  # warnings caught before the campaign now running
        self.before = 0  # evaluations its store held before this run
        self.t0 = time.perf_counter()
        self.code = 0  # the single run's exit code
        self.failed = 0  # seeds without a result
        #: evaluations each sweep point's store held before this run (its warnings are
        #: those of the later ones)
        self.stored = {store.parent.name: stored_evaluations(store.parent)
                       for store in (out.glob(f"*/{STORE}")
                                     if args.resume and kind == "sweep" else ())}

    def announce(self, start: RunStart) -> None:
        if start.kind == "seeds":
            self.say(f"[seed {start.index + 1}/{start.total}] seed {start.seed}: "
                     f"{start.directory}")
        elif start.kind == "sweep" and not self.args.quiet:
            print(f"[{start.index + 1}/{start.total}] {start.label}", file=sys.stderr)

    def start(self, start: RunStart) -> None:
        """A campaign starts: the estimate, what a resume still has to do, a new bar."""
        self.close()
        self.announce(start)
        args = self.args
        if start.kind == "sweep":
            self.bars.append(Progress(quiet=args.quiet, verbose=args.verbose,
                                      history=self._history(start)))
            return
        self.t0, self.mark = time.perf_counter(), len(self.caught)
        if local_workers(args.workers, args.scheduler) is not None:
            self.say(study_estimate(self.study, args.workers).summary())
        self.before = stored_evaluations(start.directory) if start.resume else 0
        if start.resume:
            budget = (robust_budget(self.study) - self.study.budget if start.kind == "robust"
                      else self.study.budget)
            if self.before >= budget:  # the evaluations are done: only outputs are left
                self.say(f"{start.directory}: the {self.before} evaluations are stored; "
                         f"writing what is missing: "
                         f"{', '.join(missing_outputs(start.directory))}")
        self.say("simulating the prototype ...")
        self.bars.append(Progress(quiet=args.quiet, verbose=args.verbose,
                                  history=self._history(start)))

    def _history(self, start: RunStart) -> list[np.ndarray]:
        """The stored objectives a resumed campaign's progress starts from (a robust run's
        nominal campaign's too: its bar shows both)."""
        if not self.args.resume:
            return []
        nominal = stored_objectives(start.directory / NOMINAL_DIR) if start.kind == "robust" else []
        return nominal + stored_objectives(start.directory)

    def progress(self, done: int, budget: int, evaluation: Any) -> None:
        if self.bars:
            self.bars[-1](done, budget, evaluation)

    def scatter(self, done: int, total: int, which: str = "the design point") -> None:
        """The scatter's own step line (a robust run's nominal one runs before the robust
        search's evaluations, so only the last one closes the bar)."""
        if not self.steps or self.steps[-1].step != f"scatter at {which}":
            if which != "the nominal design":
                for bar in self.bars:  # the evaluations are over: the scatter's own line
                    bar.close()
            self.steps.append(StepProgress("run", quiet=self.args.quiet))
        self.steps[-1](f"scatter at {which}", done, total)

    def complete(self, start: RunStart) -> None:
        """A campaign found complete on resume: its summary, nothing run."""
        self.announce(start)
        before = stored_evaluations(start.directory)
        point = json.loads((start.directory / DESIGN_POINT_JSON).read_text())
        summary = _summary(start.directory, point, before, 0.0)
        if self.args.json:
            print(jsonout.dumps(summary, indent=2))
        else:
            print(f"{start.directory}: already complete ({before} evaluations); nothing to do")
            if summary["report"]:
                print(f"report: {summary['report']}")

    def done(self, start: RunStart, outcome: RunOutcome) -> None:
        """A campaign finished: its warnings, its summary, its exit code."""
        self.close()
        args, out = self.args, start.directory
        if not args.quiet and not args.verbose:
            for line in warning_summary(self.caught[self.mark:],
                                        run_warnings(out, self.before),
                                        outcome.prototype_warnings):
                self.say(line)
        point = outcome.design_point
        summary = _summary(out, point, self.before, time.perf_counter() - self.t0)
        if args.json:
            print(jsonout.dumps(summary, indent=2))
        else:
            _print_summary(summary, self.before)
        code = 0
        if not point["statistics"]["successful"]:
            print(f"hypate: error: no evaluation succeeded "
                  f"({point['statistics']['evaluations']} failed); the reasons:",
                  file=sys.stderr)
            for line in failure_reasons(out):
                print(line, file=sys.stderr)
            code = EXIT_NO_RESULT
        elif not math.isfinite(point["statistics"].get("wall_seconds") or 0.0):
            code = EXIT_NO_RESULT
        self.code = code
        self.failed += code != 0

    def close(self) -> None:
        for bar in self.bars:
            bar.close()
        self.bars.clear()
        for step in self.steps:
            step.close()
        self.steps.clear()


def _seeds_summary(out: Path, outcome: SeedsOutcome, terminal: Terminal) -> int:
    """``--seeds N``: the spread over the seeds."""
    data = outcome.summary
    print(f"{out}: {data['finished']} of {len(outcome.seeds)} seeds finished "
          f"(summary: {out / SEEDS_CSV})")
    for group in ("objectives", "design"):
        for name, st in data["spread"][group].items():
            if st["median"] is not None:
                print(f"  {name:>10s}: median {st['median']:.6g}, min {st['min']:.6g}, "
                      f"max {st['max']:.6g}")
    return EXIT_NO_RESULT if terminal.failed else 0


def infrastructure_lost(args: argparse.Namespace, out: Path, exc: InfrastructureError) -> int:
    """The pool or cluster is gone: one line with what was lost and how to continue; exit 3
    (the finished evaluations are stored, the unfinished ones are not)."""
    print(f"hypate: error: {exc}; continue with `{resume_command(args, out)}` once the "
          "cluster is back", file=sys.stderr)
    return EXIT_INFRASTRUCTURE


def output_failed(args: argparse.Namespace, out: Path, what: str, todo: str) -> int:
    """The machine ran out of room or an output could not be written (a full disk, memory,
    the report): one line with what and how to continue; exit 4 (the evaluations are
    stored, the store is consistent)."""
    print(f"hypate: error: {what}; {todo} and continue with `{resume_command(args, out)}`",
          file=sys.stderr)
    return EXIT_OUTPUT


def interrupted(args: argparse.Namespace, out: Path, exc: BaseException) -> int:
    """Ctrl-C or SIGTERM: one line with what is stored and how to continue; exit 130 or
    143."""
    stores = [out / STORE, *out.glob(f"*/{STORE}")] if out.is_dir() else []
    n = sum(stored_evaluations(s.parent) for s in stores)
    print(f"hypate: {interrupt_word(exc)} after {n} evaluations; continue with "
          f"`{resume_command(args, out)}`", file=sys.stderr)
    return interrupt_code(exc)


def _sweep_summary(args: argparse.Namespace, out: Path, outcome: SweepOutcome,
                   terminal: Terminal, caught: list[warnings.WarningMessage]) -> int:
    """``hypate run`` of a sweep study: the warnings of every point, then one line each."""
    seconds = time.perf_counter() - terminal.t0
    if not args.quiet and not args.verbose:
        attributed = [((rec["label"], i), w) for rec in outcome.points
                      for i, w in run_warnings(out / rec["label"],
                                               terminal.stored.get(rec["label"], 0))]
        for line in warning_summary(caught, attributed):
            print(line, file=sys.stderr)
    if args.json:
        print(jsonout.dumps({"directory": str(out), "summary": str(out / SWEEP_CSV),
                             "seconds": seconds, "points": outcome.points},
                            indent=2, default=str))
        return 1 if any(rec["status"] != "done" for rec in outcome.points) else 0
    print(f"{out}: {len(outcome.points)} sweep points in {seconds:.1f} s "
          f"(summary: {out / SWEEP_CSV})")
    failed = 0
    for rec in outcome.points:
        objs = ", ".join(f"{k} = {v:.4g}" for k, v in (rec.get("objectives") or {}).items())
        active = ", ".join(rec.get("active_constraints") or [])
        print(f"  {rec['label']:>16s}  {rec['status']:>7s}  {objs}"
              + (f"  [active: {active}]" if active else ""))
        failed += rec["status"] != "done"
    return 1 if failed else 0
