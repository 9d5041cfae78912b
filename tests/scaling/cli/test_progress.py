"""Progress of step-wise commands (scaling/cli/progress.py): a bar in a terminal, lines
without one (per finished step and every 10 s), nothing when quiet."""
from __future__ import annotations

import io

from hypate.scaling.cli.progress import LOG_EVERY, StepProgress


class Clock:
    """A settable monotonic clock."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def test_lines_every_interval_and_when_a_step_finishes() -> None:
    out, clock = io.StringIO(), Clock()
    p = StepProgress("job", tty=False, file=out, clock=clock)
    for k in range(1, 31):  # 30 units of 1 s each: lines at 10 s and 20 s, and at the end
        clock.now = float(k)
        p("one", k, 30)
    clock.now += 2.0  # step two takes 2 s
    p("two", 1, 1)
    p.close()
    lines = out.getvalue().splitlines()
    # ETA from the rate since the step's first report (1 unit per second)
    assert lines == ["job: one 10/30 running, 10.0 s (total 10 s), ETA 20 s",
                     "job: one 20/30 running, 20.0 s (total 20 s), ETA 10 s",
                     "job: one 30/30 done, 30.0 s (total 30 s)",
                     "job: two 1/1 done, 2.0 s (total 32 s)"]
    assert LOG_EVERY == 10.0


def test_eta_leaves_out_the_work_reused_at_the_start() -> None:
    out, clock = io.StringIO(), Clock()
    p = StepProgress("job", tty=False, file=out, clock=clock)
    p("cfd", 50, 100)  # 50 reused from an earlier run, reported at once
    clock.now = 10.0
    p("cfd", 55, 100)  # then 5 in 10 s: 45 left take 90 s
    assert out.getvalue().splitlines()[-1].endswith("ETA 90 s")


def test_quiet_prints_nothing_and_a_terminal_gets_a_bar() -> None:
    out = io.StringIO()
    p = StepProgress("job", quiet=True, tty=False, file=out)
    p("one", 1, 2)
    p("one", 2, 2)
    p.close()
    assert out.getvalue() == ""
    p = StepProgress("job", tty=True, file=out)
    p("one", 1, 2)
    p("one", 2, 2)
    p("two", 3, 3)
    p.close()
    text = out.getvalue()
    assert "job: one" in text and "2/2" in text and "job: two" in text and "3/3" in text
    assert " done, " not in text  # the bar replaces the lines
