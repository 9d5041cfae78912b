"""The ``hypate`` console script: Ctrl-C and SIGTERM handled from the first instant.

Loading the command line takes seconds (numpy, scipy, pandas, matplotlib). A Ctrl-C or
SIGTERM during that time would end in Python's traceback of whichever import was running;
here it prints one line and exits 130 (143), nothing having been written yet. The handlers
are set before :mod:`hypate.scaling.cli.main` is imported (so this module imports it after
that statement), and :func:`main` hands SIGINT back to Python (``KeyboardInterrupt``) and
SIGTERM to :func:`hypate.scaling.cli.failures.sigterm_as_interrupt` before any command runs.
"""
from __future__ import annotations

import os
import signal
import sys
from types import FrameType


def _during_start_up(signum: int, frame: FrameType | None) -> None:
    word = "interrupted" if signum == signal.SIGINT else "terminated (SIGTERM)"
    os.write(2, f"hypate: {word} during start-up; nothing was written\n".encode())
    os._exit(128 + signum)


for _sig in (signal.SIGINT, signal.SIGTERM):
    signal.signal(_sig, _during_start_up)

from hypate.scaling.cli.commands import quick_answer  # noqa: E402 - after the handlers


def main() -> int:
    """Entry point of the ``hypate`` console script; returns the exit code. ``--version``
    and ``--help`` are answered before any command is loaded (a fraction of a second)."""
    quick = quick_answer(sys.argv[1:])
    if quick is not None:
        return quick
    from hypate.scaling.cli.main import main as _main  # seconds: numpy, scipy, pandas, ...

    signal.signal(signal.SIGINT, signal.default_int_handler)
    return _main()  # its SIGTERM handler replaces the start-up one


if __name__ == "__main__":  # pragma: no cover - python -m hypate.scaling.cli.entry
    sys.exit(main())
