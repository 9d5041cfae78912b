"""Progress of a command that works through named steps (``hypate rom build``).

In a terminal a live tqdm bar per step; without one (a log file, CI, a pipe) a line when a
step finishes and every :data:`LOG_EVERY` seconds in between; nothing when quiet. Always on
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
        self.step_t0 = self.t0
        self.bar: tqdm | None = None

    def __call__(self, step: str, done: int, total: int) -> None:
        now = self.clock()
        if step != self.step:  # a step begins where the previous report ended
            self._close_bar()
            self.step, self.step_t0 = step, self.seen
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
            print(f"{self.label}: {step} {done}/{total} {state}, {now - self.step_t0:.1f} s "
                  f"(total {now - self.t0:.0f} s)", file=self.file, flush=True)
        self.seen = now

    def _close_bar(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None

    def close(self) -> None:
        """End the last bar (call once the command is done)."""
        self._close_bar()
