"""hypate: aerothermoelastically scaled wind-tunnel models of hypersonic skin panels.

This folder is installed as the top-level package ``hypate`` (``pyproject.toml``,
``[tool.setuptools] package-dir``); the repository's ``scaling/``, ``solvers/`` and
``studies/`` install beneath it as ``hypate.scaling``, ``hypate.solvers`` and
``hypate.studies``, so that no generic top-level name enters the user's environment.

The documented Python API:

- :func:`load_study` -- read and validate a study file (TOML) into a :class:`Study`;
- :func:`run_study` -- run it (Bayesian optimization, crash-safe store, report inputs);
- :class:`BayesianOptimizer` -- the engine on any pymoo ``Problem``.
"""
from hypate.scaling.engine.optimizer import BayesianOptimizer
from hypate.scaling.workflow.run import run_study
from hypate.scaling.workflow.study import Study, load_study

__all__ = ["BayesianOptimizer", "Study", "load_study", "run_study"]
