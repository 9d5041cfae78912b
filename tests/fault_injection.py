"""Designs that sleep, raise, warn, return NaN or kill the process evaluating them, and the
process and campaign probes of tests/reliability/test_faults.py.

A module on the tests' ``sys.path`` (``pythonpath = ["tests"]``), not a test file, so that
process-pool and Dask workers can import the objectives they are sent.
"""
from __future__ import annotations

import os
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from hypate.scaling.engine.functional import FunctionProblem
from hypate.scaling.engine.store import EvaluationStore

#: The box of every faulty problem.
BOUNDS = [(0.0, 1.0), (0.0, 1.0)]
#: What a design above ``warn_above`` warns.
WARNING = "ti6242.conductivity: temperature below the table range [250, 950] K"


@dataclass(frozen=True)
class Faulty:
    """``fun(x)`` of a :class:`FunctionProblem`: a smooth bowl with misbehaving regions.

    Attributes
    ----------
    sleep : float
        Seconds every evaluation takes.
    slow_above, slow : float
        Designs with ``x0 > slow_above`` take ``slow`` seconds more (a time limit's prey).
    kill_above : float
        Designs with ``x0 > kill_above`` end the process evaluating them (``os._exit(3)``).
    raise_below : float
        Designs with ``x0 < raise_below`` raise ``RuntimeError("solver diverged")``.
    nan_above : float
        Designs with ``x1 > nan_above`` return NaN.
    warn_above : float
        Designs with ``x0 > warn_above`` warn ``WARNING`` three times (a clamped table).
    numpy_nan_above : float
        Designs with ``x1 > numpy_nan_above`` return ``sqrt(-1)`` (numpy's "invalid value
        encountered in sqrt" RuntimeWarning, then NaN).
    log : str
        File getting one line ``"pid x0 x1"`` when each evaluation starts ("" for none).
    """

    sleep: float = 0.0
    slow_above: float = np.inf
    slow: float = 60.0
    kill_above: float = np.inf
    raise_below: float = -np.inf
    nan_above: float = np.inf
    warn_above: float = np.inf
    numpy_nan_above: float = np.inf
    log: str = ""

    def __call__(self, x: np.ndarray) -> float:
        if self.log:
            with open(self.log, "a") as f:  # one short append: atomic between processes
                f.write(f"{os.getpid()} {float(x[0])!r} {float(x[1])!r}\n")
        if self.sleep:
            time.sleep(self.sleep)
        if x[0] > self.slow_above:
            time.sleep(self.slow)
        if x[0] > self.kill_above:
            os._exit(3)
        if x[0] < self.raise_below:
            raise RuntimeError("solver diverged")
        if x[1] > self.nan_above:
            return float("nan")
        if x[0] > self.warn_above:
            for _ in range(3):
                warnings.warn(WARNING, RuntimeWarning, stacklevel=1)
        if x[1] > self.numpy_nan_above:
            return float(np.sqrt(np.array(-1.0)))
        return float((x[0] - 0.3) ** 2 + (x[1] - 0.6) ** 2 + 0.1 * np.sin(9.0 * x[0]))


def problem(**faults: object) -> FunctionProblem:
    """A two-variable, one-objective :class:`FunctionProblem` of :class:`Faulty`."""
    return FunctionProblem(Faulty(**faults), BOUNDS)


def campaign(store: str | Path) -> list[tuple]:
    """A stored campaign: ``(iteration, batch_index, x, F, status)`` per row in store order,
    floats as ``float.hex`` (exact, and NaN equals NaN)."""
    with EvaluationStore(store) as s:
        return [(e.iteration, e.batch_index, tuple(float(v).hex() for v in e.x),
                 tuple(float(v).hex() for v in e.F), e.status) for e in s.load()]


def log_lines(log: str | Path) -> list[tuple[int, float, float]]:
    """``(pid, x0, x1)`` of each evaluation started, in order."""
    path = Path(log)
    if not path.exists():
        return []
    out = []
    for line in path.read_text().splitlines():
        parts = line.split()
        if len(parts) == 3:
            out.append((int(parts[0]), float(parts[1]), float(parts[2])))
    return out


def _stat(pid: int) -> tuple[str, int] | None:
    """(state, ppid) of a process from /proc, or None if it is gone."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    fields = text[text.rindex(")") + 2:].split()  # the name may hold blanks and brackets
    return fields[0], int(fields[1])


def alive(pid: int) -> bool:
    """Whether a process exists and is not a zombie."""
    st = _stat(pid)
    return st is not None and st[0] not in ("Z", "X")


def children(pid: int) -> set[int]:
    """Live processes whose parent is ``pid`` (from /proc)."""
    out = set()
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            st = _stat(int(entry.name))
            if st is not None and st[1] == pid and st[0] not in ("Z", "X"):
                out.add(int(entry.name))
    return out


def descendants(pid: int) -> set[int]:
    """Live children, grandchildren, ... of ``pid``."""
    found, todo = set(), [pid]
    while todo:
        for child in children(todo.pop()):
            if child not in found:
                found.add(child)
                todo.append(child)
    return found
