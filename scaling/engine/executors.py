"""Where expensive evaluations run: in-process, a local process pool that survives a dying
worker, or a ``dask.distributed`` cluster. The optimizer sees a ``concurrent.futures``-style
executor only (DESIGN.md, "Contracts between parts: Executor")."""
from __future__ import annotations

import re
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Any


class ExecutorError(ValueError):
    """An executor could not be made; ``field`` names the setting (``scheduler``)."""

    def __init__(self, field: str, message: str) -> None:
        super().__init__(f"{field}: {message}")
        self.field, self.message = field, message


def check_scheduler_address(text: str) -> None:
    """An executor address of a known form: ``tcp://HOST:PORT`` or ``tls://HOST:PORT``."""
    if not re.fullmatch(r"(tcp|tls)://[\w.\-\[\]:]+:\d+", text):
        raise ExecutorError("scheduler", f"{text!r} is not an address; expected "
                            "tcp://HOST:PORT")


def make_executor(workers: int, scheduler: str | None) -> tuple[Any, Callable[[], None]]:
    """A concurrent.futures-style executor and its closer (None: in-process)."""
    if scheduler:
        try:
            from distributed import Client  # optional dependency (the cluster extra)
        except ImportError:
            raise ExecutorError("scheduler", "needs the cluster extra: pip install -e "
                                "\".[cluster]\"") from None
        try:
            client = Client(scheduler, timeout=20)
        except (OSError, TimeoutError) as exc:
            raise ExecutorError("scheduler", f"cannot reach {scheduler}: {exc}") from None
        return client, client.close
    if workers > 1:
        pool = ResilientProcessPool(workers)
        return pool, pool.shutdown
    return None, lambda: None


class ResilientProcessPool:
    """A process pool in which a worker that dies costs only its own evaluation.

    ``concurrent.futures.ProcessPoolExecutor`` breaks as a whole when one worker dies: every
    pending future fails with ``BrokenProcessPool`` and later submissions are refused. Here
    the pool is restarted, and each future whose pool broke is re-submitted once, alone,
    when its result is asked for (the optimizer asks in batch order): an innocent evaluation
    then finishes normally, while the evaluation that kills its worker breaks the pool a
    second time and is recorded as failed.
    """

    def __init__(self, workers: int) -> None:
        self.workers = int(workers)
        self._pool = ProcessPoolExecutor(max_workers=self.workers)

    def _restart(self) -> None:
        self._pool.shutdown(wait=False, cancel_futures=True)
        self._pool = ProcessPoolExecutor(max_workers=self.workers)

    def _submit(self, fn: Callable[..., Any], args: tuple) -> Any:
        try:
            return self._pool.submit(fn, *args)
        except BrokenProcessPool:
            self._restart()
            return self._pool.submit(fn, *args)

    def submit(self, fn: Callable[..., Any], *args: Any) -> _RetryFuture:
        return _RetryFuture(self, fn, args)

    def shutdown(self) -> None:
        self._pool.shutdown(cancel_futures=True)


class _RetryFuture:
    """Future of :class:`ResilientProcessPool`: one re-submission after a broken pool."""

    def __init__(self, owner: ResilientProcessPool, fn: Callable[..., Any], args: tuple) -> None:
        self._owner, self._fn, self._args = owner, fn, args
        self._future = owner._submit(fn, args)
        self._retried = False

    def result(self, timeout: float | None = None) -> Any:
        try:
            return self._future.result(timeout)
        except BrokenProcessPool:
            if self._retried:
                raise
            self._retried = True
            self._future = self._owner._submit(self._fn, self._args)
            return self._future.result(timeout)


__all__ = ["ExecutorError", "ResilientProcessPool", "make_executor"]
