"""A run's processes: the wall time of a campaign that was interrupted and resumed.

Every process that evaluates into a run directory is a *session*, recorded in the store's
``meta`` key ``sessions`` as ``{"started", "ended"}`` (wall-clock seconds since the epoch):
``started`` before its first evaluation, ``ended`` after its last one. A session that was
killed (SIGKILL, a lost machine) has no ``ended``; it counts until the last evaluation it
committed (the rows' ``created`` times), the work in flight being lost anyway.
``design_point.json``'s ``statistics.wall_seconds`` is the sum over the sessions.
"""
from __future__ import annotations

import time
from typing import Any

from hypate.scaling.engine.store import EvaluationStore

__all__ = ["SESSIONS_META", "begin_session", "end_session", "sessions_wall_seconds"]

#: Store ``meta`` key of the sessions.
SESSIONS_META = "sessions"


def _sessions(store: EvaluationStore) -> list[dict[str, Any]]:
    stored = store.get_meta(SESSIONS_META)
    return [s for s in stored if isinstance(s, dict)] if isinstance(stored, list) else []


def begin_session(store: EvaluationStore) -> int:
    """Record that this process starts evaluating; returns its index (for
    :func:`end_session`)."""
    sessions = _sessions(store)
    sessions.append({"started": time.time(), "ended": None})
    store.set_meta(SESSIONS_META, sessions, replace=True)
    return len(sessions) - 1


def end_session(store: EvaluationStore, index: int) -> None:
    """Record that session ``index`` evaluated its last design."""
    sessions = _sessions(store)
    if 0 <= index < len(sessions):
        sessions[index]["ended"] = time.time()
        store.set_meta(SESSIONS_META, sessions, replace=True)


def sessions_wall_seconds(store: EvaluationStore) -> float:
    """The wall time of the run's evaluations, summed over its sessions (s); NaN for a
    store without a session record (a run of a hypate before it)."""
    sessions = _sessions(store)
    if not sessions:
        return float("nan")
    created = sorted(r.created for r in store.load())
    total = 0.0
    for k, s in enumerate(sessions):
        start = float(s.get("started") or 0.0)
        end = s.get("ended")
        if not isinstance(end, int | float):  # killed: until its last committed row
            stop = float(sessions[k + 1]["started"]) if k + 1 < len(sessions) else float("inf")
            mine = [t for t in created if start <= t < stop]
            end = mine[-1] if mine else start
        total += max(0.0, float(end) - start)
    return total
