"""When a run has converged: the documented stopping rule of ``iterations = "auto"``.

The run optimizes for a design point (the min-max criterion ``c = max_j F_j`` of the best
feasible evaluation, Sec. 9.2.3). Before proposing iteration ``t`` (from ``min_iterations``
on) the optimizer asks :func:`check` with the surrogates it has just fitted; the run stops
when all three hold:

1. **stalled** -- the best ``c`` improved by at most ``tolerance`` (relative) over the last
   ``patience`` iterations;
2. **the surrogate knows the design point** -- its leave-one-out prediction of the best
   evaluation (hyperparameters kept, the evaluation left out) lies within ``z_max``
   standard deviations of what was observed, for every objective;
3. **no promise left** -- the largest expected improvement of ``c``
   (:class:`~hypate.scaling.engine.acquisition.MinMaxEI`) over the inner optimization's raw
   candidates and the best designs is at most ``gain`` times the best ``c`` (in the
   surrogates' output space: with the log transform, a relative improvement directly).

Otherwise the run goes on to the hard cap (``n_iter``). The decision depends only on the
evaluations of earlier iterations and the iteration's random numbers, so a resumed run
stops where the uninterrupted one did. :class:`Stopping` is the record of why a run ended
(``design_point.json`` field ``stopping``).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

__all__ = ["StoppingRule", "Stopping", "check", "criterion"]


@dataclass(frozen=True)
class StoppingRule:
    """The settings of the rule (module docstring)."""

    min_iterations: int = 8
    patience: int = 3
    tolerance: float = 0.005
    z_max: float = 2.0
    gain: float = 0.005

    def __post_init__(self) -> None:
        if self.min_iterations < 1 or self.patience < 1:
            raise ValueError("min_iterations and patience must be >= 1")
        if not (self.tolerance >= 0.0 and self.z_max > 0.0 and self.gain >= 0.0):
            raise ValueError("tolerance and gain must be >= 0, z_max > 0")


@dataclass
class Stopping:
    """Why a run ended: ``reason`` is ``"converged"`` (the rule held at ``iteration``,
    before proposing it) or ``"cap"`` (the hard cap of iterations was spent); ``evidence``
    holds the three tests of the last check (``improvement`` relative, ``z`` per
    objective, ``predicted_gain`` relative)."""

    reason: str = "cap"
    iteration: int | None = None
    evidence: dict[str, Any] = field(default_factory=dict)
    rule: dict[str, Any] | None = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def criterion(F: np.ndarray) -> np.ndarray:
    """The design-point criterion of each row of ``F`` (n, m): ``max_j F_j``."""
    return np.max(np.atleast_2d(np.asarray(F, float)), axis=1)


def check(rule: StoppingRule, iteration: int, F: np.ndarray, feasible: np.ndarray,
          iterations: np.ndarray, loo: tuple[np.ndarray, np.ndarray] | None,
          best_row: int | None, predicted_gain: float) -> tuple[bool, dict[str, Any]]:
    """Whether the run has converged before iteration ``iteration`` (module docstring).

    Parameters
    ----------
    F : ndarray of shape (n, m)
        The successful evaluations' objectives in the surrogates' output space.
    feasible : ndarray of bool, shape (n,)
    iterations : ndarray of int, shape (n,)
        Each evaluation's iteration.
    loo : (mean, std) of shape (n, m) or None
        The surrogates' leave-one-out moments at the successful evaluations.
    best_row : int or None
        The row of the best feasible evaluation.
    predicted_gain : float
        The largest expected improvement of the criterion found, in output units.

    Returns
    -------
    stop : bool
    evidence : dict
        ``improvement`` (relative improvement of the best criterion over the patience
        window), ``z`` (per objective), ``predicted_gain`` (relative), and each test's
        outcome.
    """
    c = np.where(feasible, criterion(F), np.inf)
    now = float(c.min(initial=np.inf))
    old = float(c[iterations < iteration - rule.patience].min(initial=np.inf))
    scale = max(abs(now), 1e-12)
    improvement = (old - now) / scale if np.isfinite(old) and np.isfinite(now) else np.inf
    z = None
    if loo is not None and best_row is not None:
        mean, std = loo
        z = ((F[best_row] - mean[best_row]) / np.maximum(std[best_row], 1e-12)).tolist()
    gain = predicted_gain / scale if np.isfinite(now) else np.inf
    tests = {"stalled": bool(improvement <= rule.tolerance),
             "surrogate_knows_it": bool(z is not None and np.all(np.abs(z) <= rule.z_max)),
             "no_promise_left": bool(gain <= rule.gain)}
    evidence = {"improvement": None if not np.isfinite(improvement) else float(improvement),
                "z": z, "predicted_gain": None if not np.isfinite(gain) else float(gain),
                **tests}
    return iteration > rule.min_iterations and all(tests.values()), evidence
