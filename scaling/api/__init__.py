"""hypate: aerothermoelastically scaled wind-tunnel models of hypersonic skin panels.

This folder is installed as the top-level package ``hypate`` (``pyproject.toml``,
``[tool.setuptools] package-dir``); the repository's ``scaling/``, ``solvers/`` and
``studies/`` install beneath it as ``hypate.scaling``, ``hypate.solvers`` and
``hypate.studies``, so that no generic top-level name enters the user's environment.

The documented Python API:

- :func:`load_study` -- read and validate a study file (TOML) into a :class:`Study`;
- :func:`run_study` -- run it into a run directory (Bayesian optimization, crash-safe store,
  ``evaluations.csv``, ``design_point.json``, ``report.html``), as ``hypate run`` does;
- :class:`BayesianOptimizer` -- the engine on any pymoo ``Problem``, with its
  :class:`OptimizerSettings` (the algorithm) and :class:`RunContext` (executor, store,
  callback, time limit);
- :func:`minimize` -- the engine on a plain Python function (or a pymoo problem), with
  expensive and cheap constraints and a scipy-style result;
- :class:`Optimizer` -- the engine driven from outside: ``ask`` for designs, ``tell`` their
  results (an external code, an experiment), crash-safe and resumable;
- :class:`CheapConstraint` -- an analytic constraint with its Jacobian, enforced exactly;
- :class:`SimulatedHistories`, :class:`ModelFailure` -- what a scaling study's own
  simulator (``[simulation] simulator``, :mod:`hypate.scaling.workflow.vocabulary.external`)
  returns, and what it raises on a design it cannot simulate.

The names load on first use (PEP 562 ``__getattr__``): ``import hypate`` itself is instant,
and the ``hypate`` command can answer a Ctrl-C at once instead of after numpy, scipy, pandas
and pymoo have loaded (:mod:`hypate.scaling.cli.entry`).
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # what the names are, for type checkers and readers
    from hypate._api import (
        BayesianOptimizer,
        CheapConstraint,
        ModelFailure,
        Optimizer,
        OptimizerSettings,
        RunContext,
        RunOutcome,
        SimulatedHistories,
        Study,
        load_study,
        minimize,
        run_study,
    )

__all__ = ["BayesianOptimizer", "CheapConstraint", "ModelFailure", "Optimizer",
           "OptimizerSettings", "RunContext", "RunOutcome", "SimulatedHistories", "Study",
           "load_study", "minimize", "run_study"]


def __getattr__(name: str) -> Any:
    """A name of the API, imported from :mod:`hypate._api` on first use."""
    if name not in __all__:
        raise AttributeError(f"module 'hypate' has no attribute {name!r}")
    import hypate._api as api  # the lazy import (tests/test_layers.py allows this one)

    value = getattr(api, name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
