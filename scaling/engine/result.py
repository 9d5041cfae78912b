"""The result of a run: every evaluation, with Pareto, hypervolume and best-design helpers."""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from hypate.scaling.engine.criteria import weighted_metric
from hypate.scaling.engine.design_point import DESIGN_POINT_RULES, design_point_index
from hypate.scaling.engine.pareto import (
    hypervolume,
    non_dominated_mask,
    pareto_front,
    pareto_order,
)
from hypate.scaling.engine.problem import STATUS_OK

__all__ = ["OptimizationResult"]


@dataclass
class OptimizationResult:
    """All evaluations of a run, with Pareto/hypervolume/best-design helpers.

    Attributes
    ----------
    data : pandas.DataFrame
        One row per evaluation (:func:`hypate.scaling.engine.store.evaluations_to_dataframe`).
    n_var, n_obj : int
    ref_point : ndarray of shape (m,) or None
        Reference point of the hypervolume (given, or the one used last).
    seconds_per_iteration : ndarray
        Overhead (surrogate fits + acquisition optimization) of each iteration proposed in
        this run (iterations replayed from a store are not timed).
    """

    data: pd.DataFrame
    n_var: int
    n_obj: int
    ref_point: np.ndarray | None = None
    seconds_per_iteration: np.ndarray = field(default_factory=lambda: np.zeros(0))
    #: Why the run ended (:class:`hypate.scaling.engine.stopping.Stopping` as a dict; None
    #: without a stopping rule).
    stopping: dict | None = None

    @property
    def X(self) -> np.ndarray:
        """Designs, shape (n, d)."""
        return self.data[[f"x{i}" for i in range(self.n_var)]].to_numpy(float)

    @property
    def F(self) -> np.ndarray:
        """Objectives, shape (n, m) (NaN where an evaluation failed)."""
        return self.data[[f"f{i}" for i in range(self.n_obj)]].to_numpy(float)

    @property
    def G(self) -> np.ndarray:
        """Expensive constraints, shape (n, k), feasible where ``G <= 0``."""
        cols = [c for c in self.data.columns if c.startswith("g") and c[1:].isdigit()]
        return self.data[cols].to_numpy(float).reshape(len(self.data), len(cols))

    @property
    def ok(self) -> np.ndarray:
        """Successful evaluations, shape (n,)."""
        return (self.data["status"] == STATUS_OK).to_numpy()

    @property
    def feasible(self) -> np.ndarray:
        """Successful and satisfying every expensive constraint."""
        return self.ok & np.all(self.G <= 0.0, axis=1)

    def pareto_mask(self) -> np.ndarray:
        """Rows in the Pareto set (feasible, non-dominated)."""
        mask = np.zeros(len(self.data), dtype=bool)
        idx = np.flatnonzero(self.feasible)
        mask[idx[non_dominated_mask(self.F[idx])]] = True
        return mask

    def pareto_indices(self) -> np.ndarray:
        """Rows of :attr:`data` in the Pareto set, in THE order of every Pareto table:
        by the first objective, ties by the next ones, then by evaluation order
        (:func:`~hypate.scaling.engine.pareto.pareto_order`).

        Returns
        -------
        ndarray of int, shape (k,)
            ``pareto_set()[i]`` is ``X[idx[i]]`` and ``pareto_front()[i]`` is ``F[idx[i]]``.
        """
        idx = np.flatnonzero(self.feasible)
        return idx[pareto_order(self.F[idx])]

    def pareto_set(self) -> np.ndarray:
        """Designs of the Pareto set, shape (k, d), row-aligned with :meth:`pareto_front`
        (row ``i`` has the objectives ``pareto_front()[i]``; :meth:`pareto_indices`)."""
        return self.X[self.pareto_indices()]

    def pareto_front(self) -> np.ndarray:
        """Objectives of the Pareto set, shape (k, m), sorted by the first objective and
        row-aligned with :meth:`pareto_set` (designs with equal objectives each keep their
        row)."""
        return self.F[self.pareto_indices()]

    def named_data(self, variables: Sequence[str] | None = None,
                   objectives: Sequence[str] | None = None,
                   constraints: Sequence[str] | None = None) -> pd.DataFrame:
        """:attr:`data` with the columns ``x0..``, ``f0..``, ``g0..`` renamed.

        Parameters
        ----------
        variables, objectives, constraints : sequence of str, optional
            One distinct name per column of the kind (``None``: keep ``x0..`` etc.).

        Returns
        -------
        pandas.DataFrame
            A copy; the other columns (status, message, iteration, ...) unchanged.

        Raises
        ------
        ValueError
            A name list of the wrong length, with a repeated name, or a name another
            column already has.
        """
        G_cols = [c for c in self.data.columns if c.startswith("g") and c[1:].isdigit()]
        rename: dict[str, str] = {}
        for arg, names, cols in (("variables", variables, [f"x{i}" for i in range(self.n_var)]),
                                 ("objectives", objectives,
                                  [f"f{i}" for i in range(self.n_obj)]),
                                 ("constraints", constraints, G_cols)):
            if names is None:
                continue
            names = [str(n) for n in names]
            if len(names) != len(cols) or len(set(names)) != len(names):
                raise ValueError(f"{arg}: need {len(cols)} distinct names; got {names!r}")
            rename.update(zip(cols, names))
        taken = set(self.data.columns) - set(rename)
        clash = sorted(set(rename.values()) & taken)
        if clash or len(set(rename.values())) != len(rename):
            raise ValueError(f"names: {clash or sorted(rename.values())} would repeat a "
                             "column name")
        return self.data.rename(columns=rename)

    def hypervolume_history(self, ref_point: np.ndarray | None = None) -> np.ndarray:
        """Hypervolume of the feasible archive after each evaluation, shape (n,)."""
        r = self.ref_point if ref_point is None else np.asarray(ref_point, float)
        if r is None:
            raise ValueError("no reference point")
        F, feas = self.F, self.feasible
        out = np.zeros(len(F))
        for i in range(len(F)):  # a history, not a hot path
            out[i] = hypervolume(F[: i + 1][feas[: i + 1]], r)
        return out

    def best_history(self) -> np.ndarray:
        """Best feasible first objective after each evaluation, shape (n,) (inf before one)."""
        f = np.where(self.feasible, self.F[:, 0], np.inf)
        return np.minimum.accumulate(f) if len(f) else f

    def design_point(self, rule: str = DESIGN_POINT_RULES[0],
                     weights: Sequence[float] | None = None) -> int | None:
        """Row of the design point among the feasible evaluations by ``rule``
        (:func:`~hypate.scaling.engine.design_point.design_point_index`; default "minmax":
        the smallest largest objective, Sec. 9.2.3), None without a feasible evaluation.
        THE recommendation of a run: :func:`hypate.minimize` and a study's run directory
        both take it from here (:meth:`best` is Eq. (6.11)'s scalarization, for studies
        of the metric itself)."""
        idx = np.flatnonzero(self.feasible)
        if idx.size == 0:
            return None
        return int(idx[design_point_index(self.F[idx], rule, weights)])

    def best(self, weights: np.ndarray | None = None, g: float = 1.0,
             normalize: bool = True) -> pd.Series:
        """The feasible evaluation minimizing ``S_g`` (Eq. (6.11)).

        Parameters
        ----------
        weights : ndarray of shape (m,) or None
            ``c`` (default equal weights).
        g : float
            ``1`` weighted sum, ``inf`` Chebyshev.
        normalize : bool
            Normalize the objectives by the Pareto front's ideal and nadir points first.

        Returns
        -------
        pandas.Series
            The row of :attr:`data`.
        """
        idx = np.flatnonzero(self.feasible)
        if len(idx) == 0:
            raise ValueError("no feasible evaluation")
        F = self.F[idx]
        if normalize and self.n_obj > 1:
            P = pareto_front(F)
            ideal, nadir = P.min(axis=0), P.max(axis=0)
            F = (F - ideal) / np.where(nadir > ideal, nadir - ideal, 1.0)
        c = np.full(self.n_obj, 1.0 / self.n_obj) if weights is None else np.asarray(weights)
        s, _ = weighted_metric(F, c, g)
        return self.data.iloc[idx[int(np.argmin(s))]]
