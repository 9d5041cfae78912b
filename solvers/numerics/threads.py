"""The one BLAS-thread limiter.

Measured on the 2-core machines: under load, OpenBLAS threads spin, and a 13 us banded
factorization can take 0.7 s and a 7 ms sparse one a second; one BLAS thread avoids that.
The threadpoolctl controller is built once (about 10 ms), so entering the context later
costs about 0.1 ms.
"""
from __future__ import annotations

import contextlib
from contextlib import AbstractContextManager

from threadpoolctl import ThreadpoolController

_CONTROLLER: list[ThreadpoolController] = []


def blas_threads(n: int | None) -> AbstractContextManager[object]:
    """Context limiting BLAS to ``n`` threads (``None``: no limit, a no-op context)."""
    if n is None:
        return contextlib.nullcontext()
    if not _CONTROLLER:
        _CONTROLLER.append(ThreadpoolController())
    return _CONTROLLER[0].limit(limits=n, user_api="blas")


def single_threaded_blas() -> AbstractContextManager[object]:
    """``blas_threads(1)``: the setting of every factorization in the simulator."""
    return blas_threads(1)
