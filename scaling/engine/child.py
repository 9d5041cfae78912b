"""Evaluations in forked children that die when their time limit passes or their parent
dies (:func:`call_in_child`, :func:`die_with_parent`).

Time limits end the work: the child is killed when its limit passes (SIGTERM, SIGKILL after
:data:`TERMINATE_GRACE`). Pool workers and these children die with their parent, even on
SIGKILL of the parent.
"""
from __future__ import annotations

import contextlib
import ctypes
import os
import pickle
import select
import signal
import struct
import sys
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TypeVar

from hypate.scaling.engine.faults import SOLO_DEATHS, KilledItsWorker, backoff

__all__ = ["CHILD_POLL", "TERMINATE_GRACE", "call_in_child", "die_with_parent"]

T = TypeVar("T")

#: Seconds between SIGTERM and SIGKILL of a timed-out evaluation's process.
TERMINATE_GRACE = 1.0
#: Interval at which a parent looks whether its evaluating child died without a result (s);
#: a result itself is read as soon as it arrives.
CHILD_POLL = 0.05
#: Exit code of a forked evaluation child that could not deliver its result.
_CHILD_FAILED = 70

_PR_SET_PDEATHSIG = 1  # <linux/prctl.h>


# ------------------------------------------------------------ processes and parents
def die_with_parent(parent: int) -> None:
    """Make the calling process die when its parent dies, even on SIGKILL of the parent.

    Linux: ``prctl(PR_SET_PDEATHSIG, SIGKILL)``. The kernel counts the *thread* that
    created the process as its parent, so a process must be started by a thread that
    outlives it (the optimizer's thread for pool workers, the waiting thread for evaluation
    children). Elsewhere nothing is armed (degrades to the platform's behaviour).

    Parameters
    ----------
    parent : int
        Process id of the parent that started this process: if it is not the parent any
        more, it died before the death signal was armed, and this process exits at once.
    """
    if sys.platform.startswith("linux"):
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
        except (OSError, AttributeError):  # no libc prctl: nothing to arm
            pass
    if os.getppid() != parent:
        os._exit(1)


def _describe_death(status: int) -> str:
    code = os.waitstatus_to_exitcode(status)
    if code < 0:
        try:
            name = signal.Signals(-code).name
        except ValueError:
            name = str(-code)
        return f"killed by signal {name}"
    return f"exited with code {code}"


def _flush_std_streams() -> None:
    for stream in (sys.stdout, sys.stderr):
        try:
            if stream is not None:
                stream.flush()
        except (OSError, ValueError):  # closed or detached stream
            pass


@dataclass(frozen=True)
class _Warning:
    """A warning raised in an evaluation child, re-issued in its parent."""

    message: str
    category: type[Warning]
    filename: str
    lineno: int


#: Registry of re-issued warnings: "default" filters show each one once, as in-process.
_REISSUED: dict[Any, Any] = {}


def _child(fn: Callable[[], Any], write_end: int, parent: int) -> None:
    """Body of an evaluation child: evaluate, send ``(value, warnings)``, exit. Never
    returns into the parent's code, whatever happens."""
    code = _CHILD_FAILED
    try:
        die_with_parent(parent)
        with warnings.catch_warnings(record=True) as caught:  # the inherited filters apply
            value = fn()
        records = [_Warning(str(w.message), w.category if _picklable(w.category)
                            else UserWarning, w.filename, w.lineno) for w in caught]
        data = pickle.dumps((value, records), protocol=pickle.HIGHEST_PROTOCOL)
        with os.fdopen(write_end, "wb") as out:
            out.write(struct.pack("!Q", len(data)) + data)
        code = 0
    except BaseException:  # noqa: BLE001 - the parent reads a missing result as a death
        pass
    finally:
        _flush_std_streams()
        os._exit(code)


def _picklable(obj: Any) -> bool:
    try:
        pickle.dumps(obj)
    except (pickle.PicklingError, TypeError, AttributeError):
        return False
    return True


def _terminate(pid: int) -> None:
    """SIGTERM a child, SIGKILL it after :data:`TERMINATE_GRACE`, and reap it."""
    with contextlib.suppress(ProcessLookupError):
        os.kill(pid, signal.SIGTERM)
    deadline = time.monotonic() + TERMINATE_GRACE
    while time.monotonic() < deadline:
        if os.waitpid(pid, os.WNOHANG)[0]:
            return
        time.sleep(0.01)
    with contextlib.suppress(ProcessLookupError):
        os.kill(pid, signal.SIGKILL)
    with contextlib.suppress(ChildProcessError):
        os.waitpid(pid, 0)


def _run_child_once(fn: Callable[[], T], limit: float) -> tuple[bool, Any]:
    """One forked evaluation: ``(True, value)``, or ``(False, why it died)``; raises
    TimeoutError (the child killed) when ``limit`` seconds pass first."""
    deadline = time.monotonic() + limit
    parent = os.getpid()
    _flush_std_streams()  # or the child would write the parent's buffered output again
    read_end, write_end = os.pipe()
    # Forked with SIGINT and SIGTERM blocked: until the child has set its own dispositions,
    # the parent's Python handlers (Ctrl-C, the CLI's SIGTERM) would raise in the child's
    # copy of the parent's stack and run the parent's code on in the child.
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, _GROUP_SIGNALS)
    try:
        pid = os.fork()
    except BaseException:
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        raise
    if pid == 0:  # the child
        _child_dispositions()
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        os.close(read_end)
        _child(fn, write_end, parent)
    signal.pthread_sigmask(signal.SIG_SETMASK, mask)
    os.close(write_end)
    buf, status, eof = bytearray(), None, False
    try:
        # Read until the framed message is complete or the child is gone. A sibling child
        # forked by another thread may hold a copy of the write end, so end-of-file is not
        # a reliable sign of death: the child's exit status is looked at too.
        while not _complete(buf):
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise TimeoutError
            if eof:
                time.sleep(min(remaining, CHILD_POLL))
            elif select.select([read_end], [], [], min(remaining, CHILD_POLL))[0]:
                chunk = os.read(read_end, 1 << 16)
                buf += chunk
                eof = not chunk
                continue
            reaped, st = os.waitpid(pid, os.WNOHANG)
            if reaped:
                status = st
                if not eof:
                    os.set_blocking(read_end, False)
                    with contextlib.suppress(BlockingIOError):
                        while chunk := os.read(read_end, 1 << 16):
                            buf += chunk
                break
    except BaseException:
        if status is None:
            _terminate(pid)  # the limit passed, or the waiting thread was interrupted
        raise
    finally:
        os.close(read_end)
    if status is None:
        _reap(pid)  # the message is complete: the child is exiting
    if _complete(buf):
        value, records = pickle.loads(bytes(buf[8:]))
        for w in records:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno,
                                   registry=_REISSUED)
        return True, value
    # incomplete: the read loop ended by its break, after the child was reaped
    assert status is not None
    return False, _describe_death(status)


#: The signals a terminal or ``kill -- -PGID`` sends to a whole process group.
_GROUP_SIGNALS = {signal.SIGINT, signal.SIGTERM}


def _child_dispositions() -> None:
    """In a fresh evaluation child: SIGTERM ends it (its time limit, its parent's clean-up),
    SIGINT is ignored (a Ctrl-C reaches the whole group; the parent handles it and ends
    the child)."""
    for sig, action in ((signal.SIGTERM, signal.SIG_DFL), (signal.SIGINT, signal.SIG_IGN)):
        with contextlib.suppress(ValueError, OSError):
            signal.signal(sig, action)


def _reap(pid: int) -> None:
    """Reap a child that is exiting; terminate it if it does not within the grace."""
    deadline = time.monotonic() + TERMINATE_GRACE
    while time.monotonic() < deadline:
        if os.waitpid(pid, os.WNOHANG)[0]:
            return
        time.sleep(0.001)
    _terminate(pid)


def _complete(buf: bytearray) -> bool:
    return len(buf) >= 8 and len(buf) - 8 >= struct.unpack("!Q", buf[:8])[0]


def call_in_child(fn: Callable[[], T], limit: float) -> T:
    """``fn()`` evaluated in a forked child process that is killed after ``limit`` seconds.

    A fork, not a ``multiprocessing`` process: it works in-process, inside the (daemonic)
    workers of a process pool and inside Dask workers alike, and ``fn`` need not be
    picklable (only its value is sent back). The child dies with its parent
    (:func:`die_with_parent`); its warnings are re-issued in the parent. A child that dies
    without a value (a signal from outside, or the work itself) is forked again after a
    pause, up to :data:`SOLO_DEATHS` deaths.

    Without ``os.fork`` (not POSIX) ``fn`` runs in-process and its value is discarded if it
    took longer than ``limit``: the limit is reported, the work is not interrupted.

    Parameters
    ----------
    fn : callable
        ``fn() -> value`` (the value must be picklable).
    limit : float
        Seconds, counted from the start of each attempt.

    Returns
    -------
    value
        What ``fn()`` returned in the child.

    Raises
    ------
    TimeoutError
        ``limit`` passed; the child was terminated and reaped.
    KilledItsWorker
        The child died without a value :data:`SOLO_DEATHS` times.
    """
    if not hasattr(os, "fork"):
        t0 = time.monotonic()
        value = fn()
        if time.monotonic() - t0 > limit:
            raise TimeoutError
        return value
    why = ""
    for death in range(SOLO_DEATHS):
        if death:
            time.sleep(backoff(death))
        ok, value = _run_child_once(fn, limit)
        if ok:
            return value
        why = value
    raise KilledItsWorker(SOLO_DEATHS, why)
