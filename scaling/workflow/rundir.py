"""The run-directory contract: every file a run directory holds, who writes and who reads it.

==========================  ==========================================  ======================
file                        content                                     written by / read by
==========================  ==========================================  ======================
``evaluations.sqlite``      crash-safe store, one row per finished      engine store / resume,
                            evaluation (WAL, synchronous=FULL)          report, sweeps, laws
``evaluations.csv``         ``id`` (0-based row in the store order),    :func:`run.write_outputs`
                            designs by name, objectives, status,        / ``--seed-from``, report
                            message, warnings, wall time
``pareto.csv``              the Pareto set (best designs of one         ``write_outputs`` / users
                            objective)
``design_point.json``       public fields ``design``, ``objectives``,   ``write_outputs`` / report,
                            ``similarity``, ``active_constraints``,     laws, what-if ``--base``,
                            ``rule`` (:data:`DESIGN_POINT_RULES`),      predict
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
:func:`design_point_index` picks it from the feasible evaluations by one of
:data:`DESIGN_POINT_RULES` (the study's ``[optimizer] design_point``; :func:`describe_rule`
states the rule in words for the report). With one objective every rule is its minimum.
"""
from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from hypate.scaling.engine.pareto import non_dominated_mask
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
#: The design-point rules (``[optimizer] design_point``); the first is the default.
DESIGN_POINT_RULES = ("minmax", "weighted", "knee")
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


def worst_objective(F: np.ndarray) -> np.ndarray:
    """The design-point score of each row of ``F`` (n, m): its largest objective,
    ``max(J_u, J_T)`` (Sec. 9.2.3's min-max criterion; the objective itself for one)."""
    return np.asarray(F, dtype=float).max(axis=1)


def rank_designs(F: np.ndarray) -> np.ndarray:
    """Row indices of ``F`` from the best design to the worst by :func:`worst_objective`
    (stable: of equal scores the earlier evaluation comes first). THE "best design" order:
    the sweep recycling and ``--seed-from`` take their designs in this order, and it is the
    default ("minmax") design-point rule of :func:`design_point_index`."""
    return np.argsort(worst_objective(F), kind="stable")


def normalized_front(F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``F`` scaled by the range of its Pareto set, and that Pareto mask.

    Parameters
    ----------
    F : ndarray of shape (n, m)
        Finite objectives of the candidate designs.

    Returns
    -------
    Fn : ndarray of shape (n, m)
        ``(F - min_P) / (max_P - min_P)`` per objective, min/max over the Pareto set P
        (an objective constant on P keeps the range 1, so it adds nothing to a choice).
    mask : ndarray of bool, shape (n,)
        The Pareto set of ``F``.
    """
    F = np.asarray(F, dtype=float)
    mask = non_dominated_mask(F)
    lo, hi = F[mask].min(axis=0), F[mask].max(axis=0)
    span = np.where(hi > lo, hi - lo, 1.0)
    return (F - lo) / span, mask


def weighted_scores(F: np.ndarray, weights: Sequence[float] | None = None) -> np.ndarray:
    """The "weighted" score of each row: ``sum_k w_k Fn_k`` with ``Fn`` of
    :func:`normalized_front` and weights normalized to sum 1 (equal when None)."""
    Fn, _ = normalized_front(F)
    w = np.ones(Fn.shape[1]) if weights is None else np.asarray(weights, dtype=float)
    if w.shape != (Fn.shape[1],) or not np.all(w >= 0) or w.sum() <= 0:
        raise ValueError(f"weights must be {Fn.shape[1]} non-negative values, not all zero")
    return Fn @ (w / w.sum())


def knee_distances(F: np.ndarray) -> np.ndarray:
    """The "knee" score of each row: its distance to the straight line through the two
    extreme points of the normalized Pareto front (largest = knee); NaN off the front.

    In the normalized objectives of :func:`normalized_front` the extreme points of a
    two-objective front are (0, 1) and (1, 0), so the distance of a front point is
    ``(1 - Fn_1 - Fn_2) / sqrt(2)``; with more objectives the line becomes the hyperplane
    ``sum_k Fn_k = 1`` through the per-objective extremes, distance
    ``(1 - sum_k Fn_k) / sqrt(m)``. Signed: points beyond the line (a concave front) come
    out negative, and the largest value is still the most "bulging" compromise.
    """
    Fn, mask = normalized_front(F)
    m = Fn.shape[1]
    d = (1.0 - Fn.sum(axis=1)) / np.sqrt(m)
    return np.where(mask, d, np.nan)


def design_point_index(F: np.ndarray, rule: str = DESIGN_POINT_RULES[0],
                       weights: Sequence[float] | None = None) -> int:
    """Row of ``F`` chosen as the design point by ``rule``.

    Parameters
    ----------
    F : ndarray of shape (n, m), n >= 1
        Finite objectives of the feasible evaluations, in store order.
    rule : {"minmax", "weighted", "knee"}
        ``minmax``: the smallest ``max_k J_k`` (Sec. 9.2.3; :func:`rank_designs`);
        ``weighted``: the Pareto point with the smallest :func:`weighted_scores` (study
        weights, equal if None; the minimum over all designs is on the front anyway);
        ``knee``: the Pareto point farthest from the line through the two extreme points of
        the normalized front (:func:`knee_distances`). With one objective every rule is the
        minimum. Ties go to the earlier evaluation.
    weights : sequence of float, optional
        Objective weights of ``weighted``.

    Raises
    ------
    ValueError
        Unknown ``rule`` or empty ``F``.
    """
    F = np.atleast_2d(np.asarray(F, dtype=float))
    if rule not in DESIGN_POINT_RULES:
        raise ValueError(f"design-point rule {rule!r}: must be one of "
                         f"{', '.join(DESIGN_POINT_RULES)}")
    if F.shape[0] == 0:
        raise ValueError("no design to choose from")
    if rule == "minmax" or F.shape[1] == 1:
        return int(rank_designs(F)[0])
    if rule == "weighted":
        # over the Pareto set only: with a zero weight a dominated design could tie
        _, mask = normalized_front(F)
        return int(np.argmin(np.where(mask, weighted_scores(F, weights), np.inf)))
    d = knee_distances(F)
    return int(np.nanargmax(d))


def describe_rule(rule: str, n_objectives: int,
                  weights: Sequence[float] | None = None) -> str:
    """One sentence stating how ``rule`` chose the design point (for the report)."""
    if n_objectives <= 1:
        return "the feasible evaluation with the smallest objective"
    if rule == "weighted":
        w = "equal weights" if weights is None else \
            "weights " + ", ".join(f"{x:g}" for x in weights)
        return ("the feasible evaluation with the smallest weighted sum of the objectives "
                f"({w}), each normalized by its range over the Pareto set ('weighted')")
    if rule == "knee":
        return ("the knee of the Pareto front: the Pareto point farthest from the straight "
                "line through the two extreme points of the front, objectives normalized by "
                "their range over the Pareto set ('knee')")
    return ("the feasible evaluation with the smallest max(J_u, J_T), the larger of its "
            "two errors (Sec. 9.2.3 min-max criterion, 'minmax')")


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
