"""The vocabulary of failure: which exceptions of an executor are infrastructure faults,
the errors a run stops with, and the retry budget (:func:`hypate.scaling.engine.executors.run_batch`
applies it).

* A design that makes the simulator fail (an exception, NaN, its own time limit) is a
  result: :func:`hypate.scaling.engine.problem.evaluate_design` returns it as a status and
  the optimizer stores it.
* An infrastructure fault (:func:`fault_kind`: a worker or the scheduler lost, a broken
  pool, a cancelled future, a closed client or comm) is not. The evaluation is re-submitted:
  first with the other faulted evaluations of its batch (:data:`SHARED_RETRIES` times), then
  alone, after a pause (:func:`backoff`) that doubles with each fault of the same evaluation.
  When the pool or cluster is gone, :class:`InfrastructureError` ends the run.

A design that kills the process evaluating it must not be retried forever: once the process
evaluating it *alone* died :data:`SOLO_DEATHS` times, the design is a failure
(:class:`KilledItsWorker`).
"""
from __future__ import annotations

import asyncio
import sys
from concurrent.futures import BrokenExecutor, CancelledError
from typing import Literal

__all__ = ["BACKOFF_FIRST", "BACKOFF_MAX", "ExecutorError", "InfrastructureError",
           "KilledItsWorker", "MAX_FAULTS", "SHARED_RETRIES", "SOLO_DEATHS", "backoff",
           "fault_kind"]

#: Re-submissions of an evaluation together with the other faulted evaluations of its batch;
#: after that it is re-submitted alone, so that a worker death can be blamed on it.
SHARED_RETRIES = 1
#: Deaths of the process evaluating a design alone after which the design is a failure
#: (status ``"error"``). Two: one death may be a signal from outside, a second one in a row
#: is the design's.
SOLO_DEATHS = 2
#: Infrastructure faults of one evaluation after which the run stops with
#: :class:`InfrastructureError` even though the executor answers (a cluster that keeps
#: losing its work).
MAX_FAULTS = 6
#: Pause before the first re-submission of an evaluation (s); it doubles with each further
#: fault of the same evaluation, up to :data:`BACKOFF_MAX` (time for a restarted worker or
#: scheduler to come up).
BACKOFF_FIRST = 0.25
BACKOFF_MAX = 8.0

def backoff(faults: int) -> float:
    """Pause before re-submitting an evaluation that met ``faults`` faults (s)."""
    return min(BACKOFF_FIRST * 2.0 ** (max(faults, 1) - 1), BACKOFF_MAX)


# ------------------------------------------------------------------------ errors
class ExecutorError(ValueError):
    """An executor could not be made; ``field`` names the setting (``scheduler``)."""

    def __init__(self, field: str, message: str) -> None:
        super().__init__(f"{field}: {message}")
        self.field, self.message = field, message

    def __reduce__(self):
        # pickled by its fields (a pool worker's error reaches the parent as itself)
        return type(self), (self.field, self.message)


class InfrastructureError(RuntimeError):
    """The pool or cluster evaluating designs is gone; no row was stored for the designs
    it left unfinished (a resumed run evaluates them).

    Parameters
    ----------
    lost : str
        What was lost, one line (``"the Dask scheduler at tcp://10.0.0.5:8786 (no answer
        for 60 s)"``).
    unfinished : int
        Evaluations of the batch left without a result.
    """

    def __init__(self, lost: str, unfinished: int = 0) -> None:
        self.lost, self.unfinished = lost, int(unfinished)
        tail = (f"; {self.unfinished} unfinished evaluation(s) not stored, a resume "
                "evaluates them" if self.unfinished else "")
        super().__init__(f"lost {lost}{tail}")

    def __reduce__(self):  # by its fields, not by its message ("lost lost ...")
        return type(self), (self.lost, self.unfinished)


class KilledItsWorker(Exception):
    """The process evaluating a design alone died :data:`SOLO_DEATHS` times: a design
    failure, not an infrastructure fault."""

    def __init__(self, deaths: int, last: str) -> None:
        self.deaths, self.last = int(deaths), last
        super().__init__(f"worker died while evaluating this design alone ({self.deaths} "
                         f"times; last: {last})")

    def __reduce__(self):
        return type(self), (self.deaths, self.last)


def fault_kind(exc: BaseException) -> Literal["worker", "connection"] | None:
    """Whether an exception from an executor is an infrastructure fault, and which.

    Parameters
    ----------
    exc : BaseException
        Raised by ``submit`` or by a future's ``result()``.

    Returns
    -------
    {"worker", "connection"} or None
        ``"worker"``: a process evaluating designs died (a broken pool, distributed's
        ``KilledWorker``); it may be the design's doing. ``"connection"``: the work was lost
        on the way (a cancelled future, a closed client or comm, a lost scheduler); never
        the design's doing. ``None``: not an infrastructure fault.
    """
    worker, connection = _distributed_faults()
    if isinstance(exc, (BrokenExecutor, *worker)):
        return "worker"
    if isinstance(exc, (CancelledError, asyncio.CancelledError, OSError, EOFError,
                        *connection)):
        return "connection"  # OSError covers ConnectionError and distributed's CommClosedError
    return None


def _distributed_faults() -> tuple[tuple[type, ...], tuple[type, ...]]:
    """distributed's worker-death and connection exceptions (none while it is not loaded:
    then none of them can have been raised)."""
    if "distributed" not in sys.modules:
        return (), ()
    from distributed import KilledWorker
    from distributed.client import ClosedClientError
    return (KilledWorker,), (ClosedClientError,)
