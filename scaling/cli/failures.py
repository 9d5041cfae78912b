"""How a command ends when it cannot finish: its exit codes, SIGTERM, a full disk.

=====  ===================================================================================
code   meaning
=====  ===================================================================================
0      done (or already complete)
1      the campaign finished without one successful evaluation
2      bad input or a refused resume (one line ``hypate: error: KEY: ...``, nothing written)
3      the cluster or worker pool was lost
4      the machine ran out of room or an output could not be written (a full disk, a
       file-size limit, an I/O error, memory, or the report failed): the finished
       evaluations are stored, a resume continues
130    Ctrl-C (128 + SIGINT)
143    SIGTERM (128 + SIGTERM), handled as Ctrl-C
=====  ===================================================================================

SIGTERM is turned into :class:`Terminated`, a :class:`KeyboardInterrupt`, in the main thread:
every clean-up that runs for Ctrl-C (the store's open transaction rolled back, the workers
ended, the resume line printed) runs for it too.
"""
from __future__ import annotations

import errno
import signal
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType

__all__ = ["EXIT_INFRASTRUCTURE", "EXIT_INTERRUPTED", "EXIT_NO_RESULT", "EXIT_OUTPUT",
           "EXIT_TERMINATED", "EXIT_USAGE", "Terminated", "interrupt_code",
           "interrupt_word", "is_write_failure", "sigterm_as_interrupt", "write_failure"]

EXIT_NO_RESULT = 1
EXIT_USAGE = 2
EXIT_INFRASTRUCTURE = 3
EXIT_OUTPUT = 4
EXIT_INTERRUPTED = 128 + signal.SIGINT
EXIT_TERMINATED = 128 + signal.SIGTERM
#: errno values that mean "no room to write": a full disk or quota, a file-size limit.
NO_ROOM = {errno.ENOSPC, errno.EDQUOT, errno.EFBIG}


class Terminated(KeyboardInterrupt):
    """SIGTERM received (raised in the main thread by :func:`sigterm_as_interrupt`)."""


def _raise_terminated(signum: int, frame: FrameType | None) -> None:
    raise Terminated()


@contextmanager
def sigterm_as_interrupt() -> Iterator[None]:
    """Within the block, SIGTERM raises :class:`Terminated` in the main thread (outside the
    main thread, or where signals cannot be set, nothing changes); the previous handler is
    restored afterwards."""
    try:
        old = signal.signal(signal.SIGTERM, _raise_terminated)
    except ValueError:  # not the main thread
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)


def interrupt_code(exc: BaseException) -> int:
    """The exit code of an interrupt: 143 for SIGTERM, 130 for Ctrl-C."""
    return EXIT_TERMINATED if isinstance(exc, Terminated) else EXIT_INTERRUPTED


def interrupt_word(exc: BaseException) -> str:
    """``"terminated (SIGTERM)"`` or ``"interrupted"``, for the one line."""
    return "terminated (SIGTERM)" if isinstance(exc, Terminated) else "interrupted"


def write_failure(exc: OSError) -> tuple[str, str]:
    """What a failed write says: ``(what happened, what to do)``.

    ``("disk full writing runs/x/evaluations.sqlite", "free space")`` for ``ENOSPC`` /
    ``EDQUOT``; a file-size limit (``EFBIG``: ``ulimit -f``) and an I/O error (the store's
    SQLite ``disk I/O error``, which SQLite also reports for a file-size limit) say so.
    Anything else is ``"cannot write PATH (reason)"``.
    """
    where = exc.filename if exc.filename is not None else "the run directory"
    reason = exc.strerror or str(exc)
    if exc.errno in (errno.ENOSPC, errno.EDQUOT):
        return f"disk full writing {where}", "free space"
    if exc.errno == errno.EFBIG:
        return (f"file-size limit reached writing {where} ({reason})",
                "raise the limit (ulimit -f) or free space")
    if exc.errno == errno.EIO:
        return (f"I/O error writing {where} ({reason}: a full disk, a file-size limit or a "
                "failing disk)", "free space")
    return f"cannot write {where} ({reason})", "fix that"


def is_write_failure(exc: BaseException) -> bool:
    """Whether ``exc`` is a failed write :func:`write_failure` describes as such (no room,
    or an I/O error)."""
    return isinstance(exc, OSError) and exc.errno in NO_ROOM | {errno.EIO}
