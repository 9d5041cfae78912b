"""An ask/tell loop on Branin with a store, as an external driver would run it: the
subprocess of tests/scaling/engine/test_asktell.py's kill-and-resume test, and (imported)
its uninterrupted reference.

``python tests/asktell_loop.py STORE N Q [DIE_AT]``: ask ``Q`` designs at a time and tell
them one by one until ``N`` are told; with ``DIE_AT``, the process SIGKILLs itself when
``DIE_AT`` evaluations are told, between two tells of one batch (a kill can come anywhere:
this one leaves a batch half told, the hardest place to resume from).
"""
from __future__ import annotations

import os
import signal
import sys

import numpy as np
from hypate import Optimizer

BOUNDS = [(-5.0, 10.0), (0.0, 15.0)]


def branin(x: np.ndarray) -> float:
    b, c = 5.1 / (4 * np.pi**2), 5 / np.pi
    return float((x[1] - b * x[0]**2 + c * x[0] - 6)**2
                 + 10 * (1 - 1 / (8 * np.pi)) * np.cos(x[0]) + 10)


def loop(store: str, n: int, q: int, die_at: int | None = None) -> None:
    """Drive the optimizer until ``n`` evaluations are told (module docstring)."""
    with Optimizer(BOUNDS, seed=1, n_evaluations=n, store=store) as opt:
        while opt.n_told < n:
            for x in opt.ask(min(q, n - opt.n_told)):
                if die_at is not None and opt.n_told == die_at:
                    os.kill(os.getpid(), signal.SIGKILL)
                opt.tell(x, branin(x))


if __name__ == "__main__":
    loop(sys.argv[1], int(sys.argv[2]), int(sys.argv[3]),
         int(sys.argv[4]) if len(sys.argv) > 4 else None)
