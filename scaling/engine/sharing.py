"""The run's workers lend a hand to the proposal (Sec. 6.3.1, step 4 on every core).

While the main process fits the surrogates and polishes the acquisition's starts, the
worker processes of a run would idle: with two cores and evaluations of a fraction of a
second, the proposal is the serial part that caps ``--workers 2`` (Amdahl). A
:class:`WorkerMap` spreads the independent pieces of a proposal -- one kriging column's
likelihood optimization, one SLSQP start -- over this process and the executor's workers:
the first share runs here, the others on the executor.

Each piece is a deterministic function of plain data and the pieces come back in order,
so a proposal is the serial one, bit for bit on one machine: a seed's campaign does not
depend on the worker count. A share the executor cannot take (it does not pickle, the pool
broke, the cluster is gone) is computed here; the evaluations that follow see the fault
and handle it (:func:`hypate.scaling.engine.executors.run_batch`).
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from hypate.scaling.engine.executors import fault_tolerant
from hypate.solvers.numerics.threads import blas_threads

__all__ = ["WorkerMap"]


def _run_share(fn: Callable[[Any], Any], items: Sequence[Any], blas: int | None = None) -> list:
    # the BLAS thread count of the main process: a different one may round differently
    with blas_threads(blas):
        return [fn(item) for item in items]


class WorkerMap:
    """``map(fn, items)`` -> ``[fn(item) for item in items]``, spread over this process
    and an executor's workers.

    Parameters
    ----------
    executor : ResilientProcessPool, DaskExecutor, or any ``concurrent.futures``-style
        executor (``submit(fn, *args)``).
    width : int or None
        Shares per call (this process's included); ``None``: the executor's ``workers``
        (a process pool's size), 2 when it does not say.
    blas : int or None
        BLAS threads of the shares (the optimizer's ``blas_threads``; None: no limit).
    """

    def __init__(self, executor: Any, width: int | None = None,
                 blas: int | None = None) -> None:
        self.executor, self.blas = executor, blas
        self.width = max(int(width if width is not None
                             else getattr(executor, "workers", 2)), 1)

    def __call__(self, fn: Callable[[Any], Any], items: Sequence[Any]) -> list:
        items = list(items)
        k = min(self.width, len(items))
        if k < 2:
            return _run_share(fn, items, self.blas)
        shares = [items[g::k] for g in range(k)]  # round robin: a slow tail is shared too
        ex = fault_tolerant(self.executor)
        futures: dict[int, Any] = {}
        for g in range(1, k):
            try:
                futures[g] = ex.submit(_run_share, fn, shares[g], self.blas)
            except Exception:  # noqa: BLE001 - a share the executor refuses is done here
                pass
        done = {0: _run_share(fn, shares[0], self.blas)}
        for g in range(1, k):
            try:
                done[g] = ex.wait_result(futures[g])
            except Exception:  # noqa: BLE001 - lost or unpicklable: compute it here
                done[g] = _run_share(fn, shares[g], self.blas)
        out: list = [None] * len(items)
        for g in range(k):
            out[g::k] = done[g]
        return out
