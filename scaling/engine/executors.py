"""Where expensive evaluations run: in-process, in a local process pool
(:class:`ResilientProcessPool`) or on a ``dask.distributed`` cluster (:class:`DaskExecutor`);
:func:`make_executor` builds them from the ``--workers`` / ``--scheduler`` settings. The
optimizer sees ``concurrent.futures``-style executors only (DESIGN.md, "Contracts between
parts: Executor") and hands each batch to :func:`run_batch`, which tells a design's failure
from an infrastructure fault (:mod:`hypate.scaling.engine.faults`): the evaluations a fault
cost are re-submitted, and when the pool or cluster is gone :class:`InfrastructureError`
ends the run -- the evaluations already finished are committed, the unfinished ones are not
stored, and a resume evaluates exactly those.

Size: about 640 lines: three executors sharing one contract (submit, lost workers,
timeouts, signals); kept together so that contract is read in one place.
"""
from __future__ import annotations

import contextlib
import logging
import os
import signal
import socket
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Executor, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from typing import Any, TypeVar
from urllib.parse import urlsplit

from hypate.scaling.engine.child import die_with_parent
from hypate.scaling.engine.faults import (
    BACKOFF_MAX,
    MAX_FAULTS,
    SHARED_RETRIES,
    SOLO_DEATHS,
    ExecutorError,
    InfrastructureError,
    KilledItsWorker,
    backoff,
    fault_kind,
)

__all__ = ["CLOSE_TIMEOUT", "DASHBOARD_PORT", "DaskExecutor", "HEALTH_INTERVAL", "LOST_AFTER",
           "REACH_TIMEOUT", "ResilientProcessPool", "check_scheduler_address", "fault_tolerant",
           "make_executor", "run_batch"]

T = TypeVar("T")

#: Default of ``lost_after``: a cluster whose scheduler is unreachable, or which has no
#: worker, for this many seconds is lost (s).
LOST_AFTER = 60.0
#: Interval of the cluster health checks while results are awaited (s).
HEALTH_INTERVAL = 1.0
#: Seconds a scheduler's port must answer within (the preflight probe of :func:`make_executor`).
REACH_TIMEOUT = 10.0
#: Seconds a closer waits for a client or cluster to close.
CLOSE_TIMEOUT = 10.0
#: The Dask dashboard's default port, used by ``local:N`` when it is free.
DASHBOARD_PORT = 8787

# ----------------------------------------------------------------- process pool
class ResilientProcessPool(Executor):
    """A local process pool that is restarted when a worker dies, whose workers die with
    the parent.

    ``concurrent.futures.ProcessPoolExecutor`` breaks as a whole when one worker dies:
    every pending future fails with ``BrokenProcessPool`` and later submissions are
    refused. Here a submission to a broken pool restarts it; :func:`run_batch` re-submits
    the evaluations the break cost. Each worker runs :func:`die_with_parent` first, so no
    worker outlives the process that made the pool (SIGKILL included; Linux).

    Parameters
    ----------
    workers : int
        Number of worker processes.
    ignore_interrupt : bool, keyword-only
        Workers ignore SIGINT and SIGTERM (a Ctrl-C in the terminal, or a ``kill`` of the
        process group, reaches every process of the group): the parent alone handles them
        and ends the workers (:meth:`terminate`, SIGKILL), so a Ctrl-C prints the parent's
        one line and no worker's traceback. The workers are forked with both signals
        blocked, so that one arriving before they ignore it is discarded, not delivered.
    """

    def __init__(self, workers: int, *, ignore_interrupt: bool = False) -> None:
        self.workers = int(workers)
        self.restarts = 0
        self.ignore_interrupt = bool(ignore_interrupt)
        self._pool = self._new_pool()

    def _new_pool(self) -> ProcessPoolExecutor:
        start = _worker_ignoring_interrupt if self.ignore_interrupt else die_with_parent
        return ProcessPoolExecutor(max_workers=self.workers, initializer=start,
                                   initargs=(os.getpid(),))

    def submit(self, fn: Callable[..., T], /, *args: Any, **kwargs: Any) -> Any:
        """Schedule ``fn(*args, **kwargs)``; a broken pool is replaced by a new one first.

        Raises
        ------
        InfrastructureError
            No new pool could be started (no processes can be made).
        """
        try:
            with self._forking():
                return self._pool.submit(fn, *args, **kwargs)
        except BrokenProcessPool:
            self._pool.shutdown(wait=False, cancel_futures=True)
            try:
                self._pool = self._new_pool()
                self.restarts += 1
                with self._forking():
                    return self._pool.submit(fn, *args, **kwargs)
            except (OSError, BrokenProcessPool) as exc:
                raise InfrastructureError(f"the process pool: cannot restart it ({exc})"
                                          ) from None

    @contextlib.contextmanager
    def _forking(self) -> Iterator[None]:
        """SIGINT and SIGTERM blocked in this thread while a submission may fork the
        workers (the first one: ``concurrent.futures`` forks them all then): a worker
        inherits the mask and ignores both before it unblocks them. A signal that arrives
        meanwhile waits here and is delivered when the block ends."""
        if not self.ignore_interrupt or not hasattr(signal, "pthread_sigmask"):
            yield
            return
        old = signal.pthread_sigmask(signal.SIG_BLOCK, _GROUP_SIGNALS)
        try:
            yield
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, old)

    def wait_result(self, future: Any) -> Any:
        """The result of a future of this pool (the protocol of :func:`run_batch`)."""
        return future.result()

    def check_alive(self) -> None:
        """A broken pool is restarted at the next submission: nothing to wait for."""

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        self._pool.shutdown(wait=wait, cancel_futures=cancel_futures)

    def terminate(self) -> None:
        """End the pool now: queued work is cancelled, the workers are terminated mid-job
        (SIGKILL when they ignore SIGTERM, else SIGTERM) -- for jobs whose results are
        committed as they finish (evaluations, whole optimizations): what was in flight
        is evaluated again by a resume."""
        # concurrent.futures has no public handle on its workers; shutdown(wait=False)
        # alone would let a running job go on until it ends, and the interpreter's exit
        # would wait for it
        procs = list((getattr(self._pool, "_processes", None) or {}).values())
        self._pool.shutdown(wait=False, cancel_futures=True)
        for proc in procs:
            if proc.is_alive():
                proc.kill() if self.ignore_interrupt else proc.terminate()
        for proc in procs:
            proc.join(timeout=5.0)


#: The signals a terminal or ``kill -- -PGID`` sends to a whole process group.
_GROUP_SIGNALS = {signal.SIGINT, signal.SIGTERM}


def _worker_ignoring_interrupt(parent: int) -> None:
    """Pool initializer: :func:`die_with_parent`, SIGINT and SIGTERM ignored, then unblocked
    (the parent forked with them blocked: one sent meanwhile is discarded)."""
    for sig in _GROUP_SIGNALS:
        signal.signal(sig, signal.SIG_IGN)
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, _GROUP_SIGNALS)
    die_with_parent(parent)


# ------------------------------------------------------------------------- dask
class DaskExecutor(Executor):
    """A ``dask.distributed`` client as an executor whose losses are noticed.

    Results are awaited in slices of :data:`HEALTH_INTERVAL` seconds; between them the
    cluster is checked. A scheduler that cannot be reached, or a cluster without a worker,
    for ``lost_after`` seconds is lost: :class:`InfrastructureError` (never a wait for
    ever). A worker that dies mid-task is distributed's business (it re-runs the task
    elsewhere); a scheduler that comes back within ``lost_after`` is reconnected to by the
    client, and :func:`run_batch` re-submits what was cancelled meanwhile.

    Parameters
    ----------
    client : distributed.Client
    lost_after : float
        Seconds (see above).
    address : str, optional
        Scheduler address for messages (default: the client's).
    """

    def __init__(self, client: Any, *, lost_after: float = LOST_AFTER,
                 address: str | None = None) -> None:
        if not lost_after > 0:
            raise ValueError(f"lost_after must be > 0 s; got {lost_after}")
        self.client, self.lost_after = client, float(lost_after)
        self.address = address or str(getattr(client.scheduler, "address", "?"))

    def submit(self, fn: Callable[..., T], /, *args: Any, **kwargs: Any) -> Any:
        # pure=False: a re-submitted evaluation gets a new key, not the lost one's
        return self.client.submit(fn, *args, pure=False, **kwargs)

    def lost(self) -> tuple[str, bool] | None:
        """What of the cluster is lost now: ``(description, recoverable)``, or None."""
        status = str(getattr(self.client, "status", "closed"))
        if status in ("closing", "closed"):
            return f"the Dask scheduler at {self.address} (the client is closed)", False
        if status != "running":
            return f"the Dask scheduler at {self.address} (no connection)", True
        try:
            try:
                info = self.client.scheduler_info(n_workers=0)  # totals only
            except TypeError:  # distributed < 2025 has no n_workers
                info = self.client.scheduler_info()
        except (OSError, RuntimeError):
            return f"the Dask scheduler at {self.address} (no answer)", True
        n = int(info.get("n_workers", len(info.get("workers", {}))))
        if n == 0:
            return f"every worker of the Dask cluster at {self.address}", True
        return None

    def wait_result(self, future: Any) -> Any:
        """The result of ``future``, watching the cluster while it is awaited.

        Raises
        ------
        InfrastructureError
            The cluster was lost for ``lost_after`` seconds (or the client closed).
        """
        lost_since: float | None = None
        while True:
            try:
                return future.result(timeout=HEALTH_INTERVAL)
            except TimeoutError:
                if future.done():
                    raise  # the evaluation itself raised TimeoutError: not a wait slice
            wrong = self.lost()
            if wrong is None:
                lost_since = None
                continue
            now = time.monotonic()
            lost_since = now if lost_since is None else lost_since
            if not wrong[1] or now - lost_since >= self.lost_after:
                raise InfrastructureError(self._for(wrong[0], now - lost_since))

    def check_alive(self) -> None:
        """Return once the cluster works (a scheduler and a worker), waiting up to
        ``lost_after`` seconds for it to come back.

        Raises
        ------
        InfrastructureError
            It did not (or the client is closed).
        """
        t0 = time.monotonic()
        while (wrong := self.lost()) is not None:
            if not wrong[1] or time.monotonic() - t0 >= self.lost_after:
                raise InfrastructureError(self._for(wrong[0], time.monotonic() - t0))
            time.sleep(min(HEALTH_INTERVAL, self.lost_after / 10))

    @staticmethod
    def _for(what: str, seconds: float) -> str:
        return f"{what} for {seconds:.0f} s" if seconds >= 1 else what

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        """Close the client quietly (see :func:`make_executor`'s closer)."""
        _close_quietly(self.client)


@contextlib.contextmanager
def _quiet_distributed() -> Iterator[None]:
    """Mute distributed's loggers: closing a client whose scheduler died logs the
    cancelled reconnection as an error with a traceback, which says nothing to the user."""
    # the parent logger and the children that dask's logging config gives their own level
    loggers = [logging.getLogger(name) for name in (
        "distributed", "distributed.client", "distributed.gc", "tornado",
        "tornado.application")]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        for lg, level in zip(loggers, levels):
            lg.setLevel(level)


def _close_quietly(*closables: Any) -> None:
    """Close clients/clusters, whatever state their scheduler is in: no raise, no log."""
    with _quiet_distributed():
        for obj in closables:
            try:
                obj.close(timeout=CLOSE_TIMEOUT)
            except Exception:  # noqa: BLE001 - a dead scheduler fails in many ways; all moot
                pass


def check_scheduler_address(text: str) -> str:
    """Check the form of a scheduler address before anything connects to it.

    Parameters
    ----------
    text : str
        ``tcp://HOST:PORT``, ``tls://HOST:PORT`` or ``local:N`` (a local cluster of ``N >= 1``
        single-threaded worker processes).

    Returns
    -------
    str
        ``text`` without surrounding blanks.

    Raises
    ------
    ExecutorError
        ``field == "scheduler"``: any other form.
    """
    address = str(text).strip()
    expected = "expected tcp://HOST:PORT or local:N"
    if address.startswith("local:"):
        n = address[len("local:"):]
        if not (n.isdigit() and int(n) >= 1):
            raise ExecutorError("scheduler", f"{text!r}: local:N needs a whole number N >= 1 "
                                f"of workers; {expected}")
        return address
    try:
        parts = urlsplit(address)
        port = parts.port
    except ValueError:
        port, parts = None, None
    if parts is None or parts.scheme not in ("tcp", "tls") or not parts.hostname \
            or port is None or not 0 < port < 65536 or parts.path or parts.query \
            or parts.fragment or parts.username or parts.password:
        raise ExecutorError("scheduler", f"{text!r} is not a scheduler address; {expected} "
                            "(tls://HOST:PORT with TLS)")
    return address


def _dashboard_address() -> str:
    """The dashboard's default port on loopback if it is free, else any free port (a
    taken default port makes distributed warn on the terminal)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        try:
            s.bind(("127.0.0.1", DASHBOARD_PORT))
        except OSError:
            return "127.0.0.1:0"
    return f"127.0.0.1:{DASHBOARD_PORT}"


def _probe(address: str, seconds: float) -> None:
    """Fail fast on a scheduler nobody listens at (the client itself would keep trying for
    ``lost_after`` seconds): one TCP connection, closed at once."""
    parts = urlsplit(address)
    try:
        with socket.create_connection((parts.hostname, parts.port), timeout=seconds):
            pass
    except OSError as exc:
        raise ExecutorError("scheduler", f"cannot reach {address}: {exc}") from None


def usable_cores() -> int:
    """The cores this process may run on (its CPU affinity; ``os.cpu_count`` where the
    platform has none)."""
    try:
        return max(len(os.sched_getaffinity(0)), 1)
    except AttributeError:  # not on every platform
        return max(os.cpu_count() or 1, 1)


def auto_workers(batch_size: int) -> int:
    """``--workers auto``: the usable cores, capped by the proposals per iteration (more
    workers than designs to evaluate at once would idle)."""
    return max(1, min(usable_cores(), int(batch_size)))


def make_executor(workers: int, scheduler: str | None, *, lost_after: float = LOST_AFTER
                  ) -> tuple[Any, Callable[..., None]]:
    """The executor of a run and its closer.

    Parameters
    ----------
    workers : int
        Local process-pool size when there is no ``scheduler`` (1: in-process).
    scheduler : str or None
        ``tcp://HOST:PORT`` / ``tls://HOST:PORT`` of a running Dask scheduler, or
        ``local:N``: a ``distributed.LocalCluster`` on loopback (127.0.0.1) with ``N``
        single-threaded worker processes, silent logs, and its dashboard on the default
        port 8787 if that is free (on a free port otherwise).
    lost_after : float, keyword-only
        Seconds after which a cluster whose scheduler is unreachable, or which has no
        worker, is lost (:class:`InfrastructureError`). The client tries to connect, and
        to reconnect, a little longer (:data:`BACKOFF_MAX` more), so that the run declares
        the loss. Default :data:`LOST_AFTER` (60 s).

    Returns
    -------
    executor : ResilientProcessPool, DaskExecutor or None
        ``None``: evaluate in-process.
    close : callable
        ``close(abandon=False)`` releases the pool or cluster. It never raises and prints
        nothing, also after the scheduler died. ``abandon=True`` (the run ends on an
        interrupt or an error) ends local workers mid-evaluation instead of waiting for
        them: their evaluations were not stored and a resume runs them again.

    Raises
    ------
    ExecutorError
        A malformed address, the cluster extra missing, or an unreachable scheduler.
    """
    if not scheduler:
        if workers > 1:
            # the workers ignore the terminal's Ctrl-C and a kill of the process group:
            # the run handles them, and its closer ends the workers
            pool = ResilientProcessPool(workers, ignore_interrupt=True)

            def close_pool(abandon: bool = False) -> None:
                if abandon:
                    pool.terminate()
                else:
                    pool.shutdown(cancel_futures=True)

            return pool, close_pool
        return None, lambda abandon=False: None
    address = check_scheduler_address(scheduler)
    if not lost_after > 0:
        raise ExecutorError("lost_after", f"must be > 0 s; got {lost_after}")
    try:
        from distributed import (  # optional dependency (cluster extra)
            Client,
            LocalCluster,
        )
    except ImportError:
        raise ExecutorError("scheduler", "needs the cluster extra: pip install -e "
                            "\".[cluster]\"") from None
    if address.startswith("local:"):
        try:
            cluster = LocalCluster(n_workers=int(address[len("local:"):]),
                                   threads_per_worker=1, processes=True, host="127.0.0.1",
                                   dashboard_address=_dashboard_address(),
                                   silence_logs=logging.CRITICAL)
        except (OSError, RuntimeError) as exc:  # e.g. no worker process could start
            raise ExecutorError("scheduler", f"cannot start {address}: {exc}") from None
        client = Client(cluster)
        executor = DaskExecutor(client, lost_after=lost_after,
                                address=cluster.scheduler_address)
        return executor, lambda abandon=False: _close_quietly(client, cluster)
    _probe(address, min(REACH_TIMEOUT, lost_after))
    try:
        # the client's own reconnection window is a little longer than lost_after, so that
        # the run, not the client, declares the loss (and closes the client quietly)
        client = Client(address, timeout=lost_after + BACKOFF_MAX)
    except (OSError, TimeoutError) as exc:
        raise ExecutorError("scheduler", f"cannot reach {address}: {exc}") from None
    except TypeError:  # distributed's way of saying that TLS has no certificates
        if not address.startswith("tls://"):
            raise
        raise ExecutorError("scheduler", f"cannot connect to {address}: no TLS certificates "
                            "configured for the client (set distributed.comm.tls.ca-file and "
                            "distributed.comm.tls.client.cert/key in Dask's configuration)"
                            ) from None
    executor = DaskExecutor(client, lost_after=lost_after, address=address)
    return executor, lambda abandon=False: _close_quietly(client)


# ------------------------------------------------------------------------ batches
class _Plain:
    """Any other ``concurrent.futures``-style executor: no restart, no health check."""

    def __init__(self, executor: Any) -> None:
        self.executor = executor

    def submit(self, fn: Callable[..., Any], *args: Any) -> Any:
        return self.executor.submit(fn, *args)

    @staticmethod
    def wait_result(future: Any) -> Any:
        return future.result()

    def check_alive(self) -> None:
        pass


def fault_tolerant(executor: Any) -> Any:
    """``executor`` with the protocol of :func:`run_batch` (``submit``, ``wait_result``,
    ``check_alive``): ours as they are, a bare ``distributed.Client`` watched by a
    :class:`DaskExecutor`, anything else as it is."""
    if callable(getattr(executor, "wait_result", None)) and \
            callable(getattr(executor, "check_alive", None)):
        return executor
    if "distributed" in sys.modules:
        from distributed import Client
        if isinstance(executor, Client):
            return DaskExecutor(executor)
    return _Plain(executor)


@dataclass
class _Slot:
    """One evaluation of a batch and what befell it."""

    index: int
    args: tuple
    future: Any = None
    started: float = 0.0
    faults: int = 0
    worker_faults: int = 0
    solo_deaths: int = 0
    done: bool = False
    value: Any = None


def run_batch(executor: Any, fn: Callable[..., T], calls: Sequence[tuple], *,
              on_failure: Callable[[str, float], T]) -> Iterator[tuple[int, T]]:
    """Evaluate ``fn(*args)`` for each ``args`` of ``calls``; yield ``(position, value)``
    in batch order, each as soon as it and all before it are finished.

    Infrastructure faults (:func:`fault_kind`) are not results. The faulted evaluations
    are re-submitted together (:data:`SHARED_RETRIES` times after a worker death), then
    one at a time, alone, so that a death can be blamed: a design whose process died while
    evaluating it alone :data:`SOLO_DEATHS` times gets ``on_failure(message, seconds)``.
    Each re-submission waits :data:`BACKOFF_FIRST` seconds, doubled per fault of that
    evaluation (at most :data:`BACKOFF_MAX`), and the executor's ``check_alive()`` first.

    Parameters
    ----------
    executor : executor or None
        ``None``: in-process, in order. :class:`ResilientProcessPool` and
        :class:`DaskExecutor` restart or watch their machinery; a bare
        ``distributed.Client`` is watched as a :class:`DaskExecutor` with the default
        ``lost_after``; any other ``submit(fn, *args)`` executor is used as it is (a broken
        one ends the run).
    fn : callable
        Module-level (picklable) function.
    calls : sequence of tuple
        Positional arguments of each evaluation.
    on_failure : callable
        ``on_failure(message, seconds) -> value`` for an evaluation that is a failure for
        a reason the executor reported rather than ``fn`` (it killed its worker, or the
        executor raised an exception that is not an infrastructure fault).

    Yields
    ------
    (int, value)
        Position in ``calls`` and ``fn``'s value (or ``on_failure``'s).

    Raises
    ------
    InfrastructureError
        The pool or cluster is gone (or one evaluation met :data:`MAX_FAULTS` faults).
        Everything finished before is yielded first, in batch order; nothing is yielded for
        the unfinished evaluations.
    """
    if executor is None:
        for k, args in enumerate(calls):
            yield k, fn(*args)
        return
    ex = fault_tolerant(executor)
    slots = [_Slot(k, tuple(args)) for k, args in enumerate(calls)]
    pending = list(slots)
    emitted = 0
    try:
        while pending:
            # a slot that lost its worker more than SHARED_RETRIES times goes alone
            solo = [s for s in pending if s.worker_faults > SHARED_RETRIES]
            group = solo[:1] if solo else pending
            alone = len(group) == 1
            pause = max((backoff(s.faults) for s in group if s.faults), default=0.0)
            if pause:
                ex.check_alive()
                time.sleep(pause)
            for s in group:
                s.started = s.started or time.perf_counter()
                try:
                    s.future = ex.submit(fn, *s.args)
                except InfrastructureError:
                    raise
                except Exception as exc:  # noqa: BLE001 - classified right here
                    if fault_kind(exc) is None:
                        raise
                    raise InfrastructureError(f"the executor {type(executor).__name__} "
                                              f"({type(exc).__name__}: {exc})") from None
            for s in group:
                _settle(ex, s, alone, on_failure)
                if not s.done:
                    continue
                while emitted < len(slots) and slots[emitted].done:
                    yield emitted, slots[emitted].value
                    emitted += 1
            pending = [s for s in pending if not s.done]
    except InfrastructureError as exc:
        finished = _harvest(slots[emitted:])
        for s in finished:
            yield s.index, s.value
        unfinished = len(slots) - emitted - len(finished)
        raise InfrastructureError(exc.lost, unfinished) from None
    finally:
        for s in slots:
            if not s.done and s.future is not None:
                with contextlib.suppress(Exception):
                    s.future.cancel()


def _settle(ex: Any, s: _Slot, alone: bool, on_failure: Callable[[str, float], Any]) -> None:
    """Wait for one slot's future; record its value, its failure, or the fault it met."""
    try:
        s.value, s.done = ex.wait_result(s.future), True
        return
    except InfrastructureError:
        raise
    except Exception as exc:  # noqa: BLE001 - classified right here
        kind = fault_kind(exc)
        text = f"{type(exc).__name__}: {exc}".strip().rstrip(":")
        if kind is None:  # e.g. an unpicklable result: the evaluation's failure
            s.value, s.done = on_failure(text, time.perf_counter() - s.started), True
            return
    s.faults += 1
    if kind == "worker":
        s.worker_faults += 1
        if alone:
            s.solo_deaths += 1
            if s.solo_deaths >= SOLO_DEATHS:
                s.value = on_failure(str(KilledItsWorker(s.solo_deaths, text)),
                                     time.perf_counter() - s.started)
                s.done = True
                return
    if s.faults >= MAX_FAULTS:
        raise InfrastructureError(f"the work of the executor: one evaluation was lost "
                                  f"{s.faults} times (last: {text})")


def _harvest(slots: Sequence[_Slot]) -> list[_Slot]:
    """The slots whose evaluation finished, in batch order (their futures may hold a value
    that was not awaited yet)."""
    out = []
    for s in slots:
        if not s.done and s.future is not None:
            try:
                if s.future.done() and s.future.exception(timeout=0) is None:
                    s.value, s.done = s.future.result(timeout=0), True
            except Exception:  # noqa: BLE001 - a lost future has no value: leave it unfinished
                pass
        if s.done:
            out.append(s)
    return out
