"""Progress of a command that works through named steps (``hypate rom build``).

In a terminal a live tqdm bar per step; without one (a log file, CI, a pipe) a line when a
step finishes and every :data:`LOG_EVERY` seconds in between (with an ETA from the step's
rate since its first report, so that work reused from an earlier run does not count);
nothing when quiet. Always on
stderr, so that stdout stays the command's result (``--json``).
"""
from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import TextIO

from tqdm import tqdm

#: Seconds between two progress lines without a terminal (the interval of ``hypate run``).
LOG_EVERY = 10.0


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
