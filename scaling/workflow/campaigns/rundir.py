"""The run-directory contract: every file a run directory holds, who writes and who reads it.

==========================  ==========================================  ======================
file                        content                                     written by / read by
==========================  ==========================================  ======================
``evaluations.sqlite``      crash-safe store, one row per finished      engine store / resume,
                            evaluation (WAL, synchronous=FULL)          report, sweeps, laws
``evaluations.csv``         ``id`` (0-based row in the store order),    ``outputs.write_outputs``
                            designs by name, objectives, status,        / ``--seed-from``, report
                            message, warnings, wall time
``pareto.csv``              the Pareto set (best designs of one         ``write_outputs`` / users
                            objective)
``design_point.json``       public fields ``design``, ``objectives``,   ``write_outputs`` / report,
                            ``similarity``, ``active_constraints``,     laws, what-if ``--base``,
                            ``rule`` (``DESIGN_POINT_RULES``),      predict
                            ``model_time_step``, ``study_path``
``classical.json``          the classical GP baseline                   ``run_study`` / report
``prototype.npz``           the prototype's response                    ``run_study`` / report,
                                                                        predict
``design_point.npz``        the design point's response                 ``write_outputs`` / report,
                                                                        predict
``report.html``,            the self-contained report and its figures   the report
``figures/``
``sweep.json``,             a sweep's points and their records          :mod:`.sweep` / laws,
``sweep.csv``                                                           report, scripts
``seeds.json``,             one run per seed (``hypate run --seeds N``):  :mod:`.seeds` / report
``seeds.csv``               each seed's design point and the spread
``run.lock``                the pid of the run holding the directory    :mod:`.campaign`
                            (an exclusive POSIX record lock)
``prediction/``             ``hypate predict``: ``prediction.csv``      :mod:`.predict` and
                            (prototype histories with their band),      the CLI / users
                            ``prediction.json`` (summary),
                            ``prediction.png``, ``prediction.html``
==========================  ==========================================  ======================

Writers replace files atomically and never through a link
(:func:`hypate.solvers.numerics.files.atomic_file`: a fresh ``.NAME.*.tmp`` beside the file,
then a rename), so a killed run never leaves a half-written file behind and a link planted in
a received directory redirects nothing.

The design point
----------------
:func:`hypate.scaling.engine.design_point.design_point_index` picks it from the feasible
evaluations by one of its rules (the study's ``[optimizer] design_point``; ``describe_rule``
states the rule in words for the report). With one objective every rule is its minimum.
"""
from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from hypate.solvers.numerics.files import write_text

STORE = "evaluations.sqlite"
EVALUATIONS_CSV = "evaluations.csv"
PARETO_CSV = "pareto.csv"
DESIGN_POINT_JSON = "design_point.json"
CLASSICAL_JSON = "classical.json"
PROTOTYPE_NPZ = "prototype.npz"
DESIGN_POINT_NPZ = "design_point.npz"
REPORT_HTML = "report.html"
FIGURES_DIR = "figures"
SWEEP_JSON = "sweep.json"
SWEEP_CSV = "sweep.csv"
SEEDS_JSON = "seeds.json"
SEEDS_CSV = "seeds.csv"
LOCK_FILE = "run.lock"
PREDICTION_DIR = "prediction"
PREDICTION_CSV = "prediction.csv"
PREDICTION_JSON = "prediction.json"
PREDICTION_PNG = "prediction.png"
PREDICTION_HTML = "prediction.html"
#: The id column of ``evaluations.csv``: the 0-based row number in the store order, the
#: number every report cites ("evaluation 37").
ID_COLUMN = "id"
#: Store metadata key of the prototype simulation's warnings (a JSON list of
#: :func:`hypate.scaling.engine.problem.summarize_warnings` entries).
PROTOTYPE_WARNINGS = "prototype_warnings"
#: Evaluation ids listed by :func:`describe_occurrences` before the rest are only counted.
LISTED_IDS = 8
#: The store's name under its historical public alias.
STORE_NAME = STORE


def json_default(obj: Any) -> Any:
    """JSON form of numpy scalars and arrays (``json.dumps(default=...)``)."""
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    raise TypeError(f"not JSON serializable: {type(obj).__name__}")


def finite(obj: Any) -> Any:
    """A copy of ``obj`` (dicts, lists, tuples, numpy values) with every non-finite float
    replaced by None (JSON has no NaN or Infinity: a missing value is ``null``)."""
    if isinstance(obj, dict):
        return {str(k): finite(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [finite(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return finite(obj.tolist())
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def write_json(path: Path, data: dict[str, Any]) -> None:
    """Write ``data`` to ``path`` atomically (no NaN: non-finite values must be None)."""
    write_text(path, json.dumps(data, indent=2, default=json_default, allow_nan=False))


def write_csv(path: Path, table: Any) -> None:
    """Write a pandas DataFrame to ``path`` atomically, without its index (an unchanged
    file is left alone, :func:`~hypate.solvers.numerics.files.write_bytes`)."""
    write_text(path, table.to_csv(index=False, lineterminator="\n"))


def finite_or_none(x: float) -> float | None:
    """``x`` as a float, or None when it is not finite (JSON has no NaN)."""
    return float(x) if math.isfinite(x) else None


def describe_occurrences(labels: Sequence[Any], limit: int = LISTED_IDS) -> str:
    """Where a warning occurred, in words: ``"prototype, evaluations 3, 7-9, 12"``.

    Parameters
    ----------
    labels : sequence of int, str or (str, int)
        Evaluation ids (ints), other places (``"prototype"``, ``"run"``; strings, listed
        first as given) and ids within a group (a sweep point's label and its id:
        ``"p1 evaluations 3, 4; p2 evaluation 0"``).
    limit : int
        Runs of consecutive ids listed (per group); beyond them ``"... (N in all)"``.

    Returns
    -------
    str
    """
    groups: dict[str, list[Any]] = {}
    for v in labels:
        if isinstance(v, tuple):
            groups.setdefault(str(v[0]), []).append(v[1])
    if groups:
        rest = describe_occurrences([v for v in labels if not isinstance(v, tuple)], limit)
        return "; ".join([rest] * bool(rest) + [f"{g} {describe_occurrences(ids, limit)}"
                                                 for g, ids in groups.items()])
    names = [str(v) for v in labels if isinstance(v, str)]
    ids = sorted({int(v) for v in labels if not isinstance(v, str)})
    runs: list[list[int]] = []
    for i in ids:
        if runs and i == runs[-1][1] + 1:
            runs[-1][1] = i
        else:
            runs.append([i, i])
    parts = [f"{a}" if a == b else f"{a}-{b}" for a, b in runs[:limit]]
    if len(runs) > limit:
        parts.append(f"... ({len(ids)} in all)")
    if ids:
        names.append(("evaluation " if len(ids) == 1 else "evaluations ") + ", ".join(parts))
    return ", ".join(names)
