"""One study, several optimizer seeds: how far the design point depends on the seed.

``hypate run STUDY --seeds N`` runs the study once per seed (``S, S + 1, ..., S + N - 1``,
``S`` the study's seed or ``--seed``) into ``OUT/seed-<s>/``, ordinary run directories, and
after each one rewrites ``OUT/seeds.json`` and ``OUT/seeds.csv`` (:mod:`.rundir`): every
seed's design point and the spread over the finished ones (median, min, max of each design
variable, objective and similarity-parameter difference). A seed's report shows the spread
next to its own design point, so one seed's answer is never read as the study's.
"""
from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from hypate.scaling.workflow.campaigns.campaign import MAX_SEED
from hypate.scaling.workflow.campaigns.rundir import (
    DESIGN_POINT_JSON,
    SEEDS_CSV,
    SEEDS_JSON,
    write_csv,
    write_json,
)
from hypate.scaling.workflow.vocabulary.study import Study
from hypate.solvers.errors import InputError

__all__ = ["MAX_SEEDS", "SEED_DIR", "seed_directory", "seed_list", "seed_spread",
           "load_seeds", "write_seeds_summary"]

#: Largest ``--seeds``: each seed is a whole optimization.
MAX_SEEDS = 100
#: Sub-directory of one seed's run.
SEED_DIR = "seed-{seed}"


def seed_list(first: int, n: int) -> list[int]:
    """The seeds ``first, first + 1, ..., first + n - 1``.

    Raises
    ------
    InputError
        ``n`` outside ``1..MAX_SEEDS`` or a seed above the store's limit.
    """
    if not 1 <= n <= MAX_SEEDS:
        raise InputError("--seeds", f"a number of seeds in 1..{MAX_SEEDS}, got {n}")
    if first < 0 or first + n - 1 > MAX_SEED:
        raise InputError("--seed", f"seeds in 0..{MAX_SEED}, got {first}..{first + n - 1}")
    return [first + k for k in range(n)]


def seed_directory(out: Path, seed: int) -> Path:
    """``OUT/seed-<seed>``."""
    return Path(out) / SEED_DIR.format(seed=seed)


def _record(seed: int, directory: Path) -> dict[str, Any]:
    """One seed's row: its design point, or its status when it has none yet."""
    path = directory / DESIGN_POINT_JSON
    if not path.is_file():
        return {"seed": seed, "directory": directory.name, "status": "not finished"}
    point = json.loads(path.read_text())
    if not point.get("design"):
        return {"seed": seed, "directory": directory.name, "status": "no design point"}
    stats = point.get("statistics") or {}
    return {"seed": seed, "directory": directory.name, "status": "done",
            "design": point["design"], "objectives": point["objectives"],
            "similarity": {r["name"]: r["relative_difference"]
                           for r in point.get("similarity") or []},
            "evaluations": stats.get("evaluations"), "wall_seconds": stats.get("wall_seconds")}


def _stats(values: Sequence[float]) -> dict[str, float | None]:
    v = np.asarray([x for x in values if x is not None], dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return {"median": None, "min": None, "max": None}
    return {"median": float(np.median(v)), "min": float(v.min()), "max": float(v.max())}


def seed_spread(records: Sequence[dict[str, Any]]) -> dict[str, dict[str, dict[str, Any]]]:
    """Median, min and max over the finished seeds of every design variable, objective and
    similarity-parameter relative difference: ``{"design"|"objectives"|"similarity":
    {name: {"median", "min", "max"}}}``."""
    done = [r for r in records if r.get("status") == "done"]
    out: dict[str, dict[str, dict[str, Any]]] = {}
    for group in ("design", "objectives", "similarity"):
        names = list(dict.fromkeys(k for r in done for k in r[group]))
        out[group] = {k: _stats([r[group].get(k) for r in done]) for k in names}
    return out


def write_seeds_summary(study: Study, out: Path, seeds: Sequence[int]) -> dict[str, Any]:
    """Rewrite ``seeds.json`` and ``seeds.csv`` from the seed directories as they are.

    Returns
    -------
    dict
        The content of ``seeds.json``: ``study``, ``seeds`` (one record per seed, in
        order), ``finished`` and ``spread`` (:func:`seed_spread`).
    """
    out = Path(out)
    records = [_record(s, seed_directory(out, s)) for s in seeds]
    data = {"study": study.name, "seeds": records,
            "finished": sum(r["status"] == "done" for r in records),
            "spread": seed_spread(records)}
    write_json(out / SEEDS_JSON, data)
    rows = []
    for r in records:
        row: dict[str, Any] = {"seed": r["seed"], "status": r["status"],
                               "directory": r["directory"]}
        for group, prefix in (("design", ""), ("objectives", ""), ("similarity", "d ")):
            row.update({f"{prefix}{k}": v for k, v in (r.get(group) or {}).items()})
        row.update({"evaluations": r.get("evaluations"), "wall_seconds": r.get("wall_seconds")})
        rows.append(row)
    write_csv(out / SEEDS_CSV, pd.DataFrame(rows))
    return data


def load_seeds(run_dir: Path) -> dict[str, Any] | None:
    """The ``seeds.json`` of the ``--seeds`` run that ``run_dir`` is one seed of, with
    ``"this"``: that seed's record; None for a run that is not part of one."""
    path = Path(run_dir).resolve().parent / SEEDS_JSON
    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    mine = [r for r in data.get("seeds", []) if r.get("directory") == Path(run_dir).resolve().name]
    return {**data, "this": mine[0]} if mine else None
