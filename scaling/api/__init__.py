"""hypate: aerothermoelastically scaled wind-tunnel models of hypersonic skin panels.

This folder is installed as the top-level package ``hypate`` (``pyproject.toml``,
``[tool.setuptools] package-dir``); the repository's ``scaling/``, ``solvers/`` and
``studies/`` install beneath it as ``hypate.scaling``, ``hypate.solvers`` and
``hypate.studies``, so that no generic top-level name enters the user's environment.

The documented Python API:

- :func:`load_study` -- read and validate a study file (TOML) into a :class:`Study`;
- :func:`run_study` -- run it into a run directory (Bayesian optimization, crash-safe store,
  ``evaluations.csv``, ``design_point.json``, ``report.html``), as ``hypate run`` does;
- :class:`BayesianOptimizer` -- the engine on any pymoo ``Problem``.
"""
from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from hypate.scaling.engine.optimizer import BayesianOptimizer
from hypate.scaling.report.html import write_report_safely
from hypate.scaling.workflow import run as _run
from hypate.scaling.workflow.run import RunOutcome
from hypate.scaling.workflow.study import Study, load_study

__all__ = ["BayesianOptimizer", "RunOutcome", "Study", "load_study", "run_study"]


def run_study(study: Study, out: str | Path, *,
              on_written: Callable[[Path], object] | None = write_report_safely,
              **options: Any) -> RunOutcome:
    """Run (or, with ``resume=True``, continue) ``study`` into the directory ``out`` and
    write its report, exactly as ``hypate run STUDY --out OUT`` does.

    ``options`` are those of :func:`hypate.scaling.workflow.run.run_study` (``resume``,
    ``workers``, ``scheduler``, ``seed``, ``progress``, ``seed_runs``); ``on_written=None``
    skips the report.
    """
    return _run.run_study(study, out, on_written=on_written, **options)
