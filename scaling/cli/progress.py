"""Progress of a command: the evaluations of ``hypate run`` (:class:`Progress`) and the
named steps of e.g. ``hypate rom build`` (:class:`StepProgress`).

In a terminal a live tqdm bar per step; without one (a log file, CI, a pipe) a line when a
step finishes and every :data:`LOG_EVERY` seconds in between (with an ETA from the step's
rate since its first report, so that work reused from an earlier run does not count);
nothing when quiet. Always on
stderr, so that stdout stays the command's result (``--json``).
"""
from __future__ import annotations

import sys
import time
from collections.abc import Callable, Sequence
from typing import TextIO

import numpy as np
from hypate.scaling.engine.design_point import worst_objective
from hypate.scaling.engine.pareto import hypervolume
from tqdm import tqdm

#: Seconds between two progress lines without a terminal (a log file, CI, nohup).
LOG_EVERY = 10.0
#: Reference point of the progress-bar hypervolume (relative errors of 100 %).
PROGRESS_REF = np.array([1.0, 1.0])


class Progress:
    """Progress: evaluations / budget, best max(J), hypervolume, elapsed and ETA -- a live
    bar in a terminal, a line every :data:`LOG_EVERY` seconds (and at the end) otherwise,
    nothing when quiet.

    Called as the ``progress`` callback of :func:`hypate.scaling.workflow.campaigns.run.run_study`:
    ``progress(done, budget, evaluation)`` with the evaluation just stored (or None);
    ``done`` counts the campaign's stored evaluations, a resumed one's earlier sessions
    too, and the ETA this session's.

    Parameters
    ----------
    quiet : bool
        No progress output at all.
    tty : bool or None
        Whether stderr is a terminal (``None``: ask it).
    verbose : bool
        Print each evaluation's recorded warnings as it is stored
        (``"evaluation 12: RuntimeWarning: ... (3 times)"``, the id of ``evaluations.csv``;
        a robust run's search counts on from its nominal campaign's), even when quiet.
    history : sequence of ndarray
        Objectives of the successful evaluations stored before this session (a resume):
        the best and the hypervolume count them.
    """

    def __init__(self, quiet: bool = False, tty: bool | None = None, verbose: bool = False,
                 history: Sequence[np.ndarray] = ()) -> None:
        tty = sys.stderr.isatty() if tty is None else tty
        self.verbose = verbose
        self.lines = not quiet and not tty
        self.bar = tqdm(total=1, unit="eval", desc="evaluations", disable=quiet or not tty,
                        dynamic_ncols=True)
        self.F: list[np.ndarray] = [np.asarray(f, float) for f in history]
        self.t0 = self.last = time.monotonic()
        self.first: int | None = None

    def __call__(self, done: int, budget: int, evaluation) -> None:
        self.bar.total = budget
        if self.verbose and evaluation is not None:
            for entry in evaluation.warnings:  # above the bar, not through it
                self.bar.write(f"evaluation {done - 1}: {entry}",
                               file=sys.stderr)
        if evaluation is not None and evaluation.status == "ok":
            self.F.append(np.asarray(evaluation.F, float))
        post = {}
        if self.F:
            F = np.array(self.F)
            post["best"] = f"{worst_objective(F).min():.4g}"
            if F.shape[1] == 2:
                post["HV"] = f"{hypervolume(F[np.all(F < PROGRESS_REF, axis=1)], PROGRESS_REF):.4g}"
        self.bar.set_postfix(post, refresh=False)
        self.bar.update(done - self.bar.n)
        if self.first is None:
            self.first = done - 1 if evaluation is not None else done
        now = time.monotonic()
        if self.lines and (now - self.last >= LOG_EVERY or done >= budget):
            self.last = now
            rate = (now - self.t0) / max(done - self.first, 1)
            eta = f", ETA {rate * (budget - done):.0f} s" if done < budget else ""
            extra = "".join(f", {k} {v}" for k, v in post.items())
            print(f"evaluations {done}/{budget}{extra}, {now - self.t0:.0f} s{eta}",
                  file=sys.stderr, flush=True)

    def close(self) -> None:
        self.bar.close()


class StepProgress:
    """A ``progress(step, done, total)`` callback that shows a sequence of steps.

    Parameters
    ----------
    label : str
        Prefix of every line (the command, e.g. ``"rom build"``).
    quiet : bool
        No output at all.
    tty : bool or None
        Whether ``file`` is a terminal (``None``: ask it).
    file : text stream, optional
        Where to write (default ``sys.stderr``).
    clock : callable, optional
        Monotonic seconds (default :func:`time.monotonic`).
    """

    def __init__(self, label: str, quiet: bool = False, tty: bool | None = None,
                 file: TextIO | None = None, clock: Callable[[], float] | None = None
                 ) -> None:
        self.file = sys.stderr if file is None else file
        clock = time.monotonic if clock is None else clock
        tty = bool(getattr(self.file, "isatty", lambda: False)()) if tty is None else tty
        self.label = label
        self.bars = not quiet and tty
        self.lines = not quiet and not tty
        self.clock = clock
        self.t0 = self.last = self.seen = clock()
        self.step: str | None = None
        self.step_first = (self.t0, 0)
        self.step_t0 = self.t0
        self.bar: tqdm | None = None

    def __call__(self, step: str, done: int, total: int) -> None:
        now = self.clock()
        if step != self.step:  # a step begins where the previous report ended
            self._close_bar()
            self.step, self.step_t0 = step, self.seen
            self.step_first = (now, done)  # the rate (ETA) counts from the first report
            if self.bars:
                self.bar = tqdm(total=total, desc=f"{self.label}: {step}", file=self.file,
                                dynamic_ncols=True, leave=True)
        if self.bar is not None:
            self.bar.total = total
            self.bar.update(done - self.bar.n)
        finished = done >= total
        if self.lines and (finished or now - self.last >= LOG_EVERY):
            self.last = now
            state = "done" if finished else "running"
            t1, d1 = self.step_first
            eta = (f", ETA {(now - t1) / (done - d1) * (total - done):.0f} s"
                   if not finished and done > d1 and now > t1 else "")
            print(f"{self.label}: {step} {done}/{total} {state}, {now - self.step_t0:.1f} s "
                  f"(total {now - self.t0:.0f} s){eta}", file=self.file, flush=True)
        self.seen = now

    def _close_bar(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None

    def close(self) -> None:
        """End the last bar (call once the command is done)."""
        self._close_bar()
