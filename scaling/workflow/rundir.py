"""The run-directory contract: every file a run directory holds, who writes and who reads it.

==========================  ==========================================  ======================
file                        content                                     written by / read by
==========================  ==========================================  ======================
``evaluations.sqlite``      crash-safe store, one row per finished      engine store / resume,
                            evaluation (WAL, synchronous=FULL)          report, sweeps, laws
``evaluations.csv``         designs by name, objectives, status,        :func:`run.write_outputs`
                            message, wall time                          / ``--seed-from``, report
``pareto.csv``              the Pareto set (best designs of one         ``write_outputs`` / users
                            objective)
``design_point.json``       public fields ``design``, ``objectives``,   ``write_outputs`` / report,
                            ``similarity``, ``active_constraints``      laws, what-if ``--base``
``classical.json``          the classical GP baseline                   ``run_study`` / report
``prototype.npz``           the prototype's response                    ``run_study`` / report
``design_point.npz``        the design point's response                 ``write_outputs`` / report
``report.html``,            the self-contained report and its figures   the report
``figures/``
``sweep.json``,             a sweep's points and their records          :mod:`.sweep` / laws,
``sweep.csv``                                                           report, scripts
==========================  ==========================================  ======================

Writers replace files atomically (write ``NAME.tmp``, then rename), so a killed run never
leaves a half-written file behind.
"""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

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
#: The store's name under its historical public alias.
STORE_NAME = STORE


def json_default(obj: Any) -> Any:
    """JSON form of numpy scalars and arrays (``json.dumps(default=...)``)."""
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    raise TypeError(f"not JSON serializable: {type(obj).__name__}")


def write_json(path: Path, data: dict[str, Any]) -> None:
    """Write ``data`` to ``path`` atomically (no NaN: non-finite values must be None)."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(data, indent=2, default=json_default, allow_nan=False))
    tmp.replace(path)


def finite_or_none(x: float) -> float | None:
    """``x`` as a float, or None when it is not finite (JSON has no NaN)."""
    return float(x) if math.isfinite(x) else None


def worst_objective(F: np.ndarray) -> np.ndarray:
    """The design-point score of each row of ``F`` (n, m): its largest objective,
    ``max(J_u, J_T)`` (Sec. 9.2.3's min-max criterion; the objective itself for one)."""
    return np.asarray(F, dtype=float).max(axis=1)


def rank_designs(F: np.ndarray) -> np.ndarray:
    """Row indices of ``F`` from the best design to the worst by :func:`worst_objective`
    (stable: of equal scores the earlier evaluation comes first). THE "best design" rule:
    the design point, the sweep recycling and ``--seed-from`` all take their designs in
    this order."""
    return np.argsort(worst_objective(F), kind="stable")
