"""How well a run's final surrogates know one of its evaluations: the leave-one-out check
shown beside the design point in the report (the model refitted without the evaluation,
hyperparameters kept, predicts it from the rest of the data)."""
from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import numpy as np
from hypate.scaling.engine.result import OptimizationResult

__all__ = ["SurrogateCheck", "leave_one_out_check"]


@dataclasses.dataclass(frozen=True)
class SurrogateCheck:
    """How well the final surrogates know one evaluation: their leave-one-out prediction.

    The kriging model fitted to every successful evaluation interpolates them (its std at
    a sample is ~0, which says nothing); the model without that sample, hyperparameters
    kept, predicts it from the rest of the data. A prediction within a few std of the
    observed value says the surrogate has learned the neighbourhood; an observed value far
    below it marks a point the surrogate did not expect (a narrow valley, or a spike).

    Attributes (arrays of shape (m,), one entry per objective)
    ----------
    observed : the evaluated objective values.
    mean : predicted objective (with the ``"log"`` transform: ``exp`` of the predicted
        ``ln J``, the median of the log-normal prediction).
    std : standard deviation of the prediction in the surrogate's output space (objective
        units, or of ``ln J`` with the ``"log"`` transform).
    lower, upper : the one-std band in objective units.
    z : ``(observed - predicted) / std`` in the surrogate's output space.
    transform : the output transform (``"none"`` or ``"log"``).
    """

    observed: np.ndarray
    mean: np.ndarray
    std: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    z: np.ndarray
    transform: str


def leave_one_out_check(result: OptimizationResult, row: int,
                        fit: Callable[[np.ndarray, np.ndarray], Any],
                        model_space: Callable[[np.ndarray], np.ndarray],
                        transform: str) -> SurrogateCheck:
    """The final surrogates' leave-one-out prediction of evaluation ``row``.

    Parameters
    ----------
    result : OptimizationResult
        The run's evaluations.
    row : int
        A successful evaluation (row of ``result.data``), e.g. the design point.
    fit : callable
        ``fit(X, F)``: the surrogate of the objectives (with ``leave_one_out()``) as the
        optimizer fits it, ``F`` in its output space.
    model_space : callable
        Objective values as the surrogates see them (the output transform).
    transform : {"none", "log"}
        The output transform.

    Returns
    -------
    SurrogateCheck

    Raises
    ------
    ValueError
        If ``row`` is not a successful evaluation, or fewer than 3 evaluations succeeded.
    """
    ok = result.ok
    if not 0 <= row < len(ok) or not ok[row]:
        raise ValueError(f"evaluation {row} is not a successful evaluation")
    if ok.sum() < 3:
        raise ValueError("a leave-one-out check needs at least 3 successful evaluations")
    F = model_space(result.F[ok])
    mean, std = fit(result.X[ok], F).leave_one_out()
    k = int(np.count_nonzero(ok[:row]))
    m, s, y = mean[k], std[k], F[k]
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(s > 0, (y - m) / s, np.nan)
    back = np.exp if transform == "log" else (lambda v: v)
    return SurrogateCheck(observed=result.F[row].copy(), mean=back(m), std=s,
                          lower=back(m - s), upper=back(m + s), z=z, transform=transform)
