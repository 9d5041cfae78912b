"""One categorical design variable (e.g. the model material) next to continuous ones.

The categorical variable sits in the design vector as its level number ``0 .. k-1``
(bounds ``[0, k - 1]``), so stores, executors and pymoo problems see plain float vectors.
Three pieces make the Bayesian optimization mixed-variable (Garrido-Merchan and
Hernandez-Lobato's one-hot treatment, with the inner search enumerating the levels as the
dissertation's SLSQP multistart cannot step between them):

* :class:`Categorical` -- which entry is categorical and how many levels it has;
* :class:`MixedCoordinates` -- the surrogates' inputs ``z = [c(x_cont), onehot(level)]``:
  the kriging kernel (Eq. (A.3)) gets one length scale per level indicator, i.e. a learned
  correlation ``exp(-(1/l_a^2 + 1/l_b^2) / 2)`` (Gaussian) between levels ``a`` and ``b``,
  and the continuous part keeps its own coordinates (design or log-linear similarity axes);
* :class:`LevelSlice` -- a fitted model restricted to one level and queried, with exact
  gradients, on the continuous variables alone: the inner SLSQP multistart runs once per
  level on it and the best level's optimum is the proposal.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from hypate.scaling.engine.acquisition import Acquisition
from hypate.scaling.engine.coordinates import LogLinearCoordinates
from hypate.scaling.engine.inner import optimize_acquisition
from hypate.scaling.engine.problem import CheapConstraint
from hypate.scaling.engine.surrogate import ProbabilisticConstraint

__all__ = ["Categorical", "LevelSlice", "MixedCoordinates", "propose_by_level",
           "sliced_constraints"]


@dataclass(frozen=True)
class Categorical:
    """Entry ``index`` of the design vector is categorical with ``levels`` values
    ``0 .. levels - 1`` (its bounds must be ``[0, levels - 1]``)."""

    index: int
    levels: int

    def __post_init__(self) -> None:
        if int(self.index) != self.index or self.index < 0:
            raise ValueError(f"categorical index must be a non-negative integer, got {self.index}")
        if int(self.levels) != self.levels or self.levels < 2:
            raise ValueError(f"a categorical variable needs at least 2 levels, got {self.levels}")

    def problem_mismatch(self, bounds: np.ndarray) -> tuple[str, Any] | None:
        """(allowed, value) when the design box ``bounds`` (d, 2) does not fit this
        variable (index inside the vector, bounds ``[0, levels - 1]``); None when it fits."""
        n_var = len(bounds)
        if not self.index < n_var:
            return f"an index in [0, {n_var - 1}]", self.index
        if tuple(bounds[self.index]) != (0.0, float(self.levels - 1)):
            return (f"bounds [0, {self.levels - 1}] of variable {self.index}",
                    tuple(bounds[self.index]))
        return None

    def level(self, X: np.ndarray) -> np.ndarray:
        """Level numbers (N,) of designs ``X`` (N, d): the nearest level, clipped."""
        col = np.atleast_2d(np.asarray(X, dtype=float))[:, self.index]
        return np.clip(np.rint(col), 0, self.levels - 1).astype(int)

    def snap(self, X: np.ndarray) -> np.ndarray:
        """``X`` with the categorical entry set to its nearest level."""
        X = np.array(np.atleast_2d(X), dtype=float)
        X[:, self.index] = self.level(X)
        return X

    def continuous(self, X: np.ndarray) -> np.ndarray:
        """The continuous entries (N, d - 1) of designs ``X`` (N, d)."""
        return np.delete(np.atleast_2d(np.asarray(X, dtype=float)), self.index, axis=1)

    def insert(self, Xc: np.ndarray, level: int) -> np.ndarray:
        """Full designs (N, d) from continuous entries ``Xc`` (N, d - 1) at ``level``."""
        Xc = np.atleast_2d(np.asarray(Xc, dtype=float))
        return np.insert(Xc, self.index, float(level), axis=1)

    def stratified(self, u: np.ndarray) -> np.ndarray:
        """Levels of a Latin-hypercube column ``u`` in [0, 1): ``floor(k u)``, so an LHS of
        ``n`` points takes each level ``n / k`` times (within one)."""
        return np.minimum(np.floor(np.asarray(u, float) * self.levels), self.levels - 1)


class MixedCoordinates:
    """Surrogate inputs ``z = [c(x_cont), onehot(level)]`` of mixed designs.

    Parameters
    ----------
    categorical : Categorical
    n_var : int
        Length ``d`` of the design vector (the categorical entry included).
    continuous : LogLinearCoordinates or None
        Coordinates of the ``d - 1`` continuous entries (None: the entries themselves).
    """

    def __init__(self, categorical: Categorical, n_var: int,
                 continuous: LogLinearCoordinates | None = None) -> None:
        if not 0 <= categorical.index < n_var:
            raise ValueError(f"categorical index {categorical.index} outside a design of "
                             f"{n_var} variables")
        if continuous is not None and continuous.matrix.shape != (n_var - 1, n_var - 1):
            raise ValueError(f"continuous coordinates need a {n_var - 1} x {n_var - 1} matrix")
        self.categorical = categorical
        self.n_var = int(n_var)
        self.continuous = continuous

    @property
    def n_z(self) -> int:
        return self.n_var - 1 + self.categorical.levels

    def __call__(self, X: np.ndarray) -> np.ndarray:
        """``z`` (N, d - 1 + k) of designs ``X`` (N, d)."""
        cat = self.categorical
        Xc = cat.continuous(X)
        zc = Xc if self.continuous is None else self.continuous(Xc)
        onehot = (cat.level(X)[:, None] == np.arange(cat.levels)[None]).astype(float)
        return np.hstack([zc, onehot])

    def jacobian(self, X: np.ndarray) -> np.ndarray:
        """``dz/dx`` (N, d - 1 + k, d): the continuous block, zero for the level (a
        piecewise-constant indicator) and for the indicators' rows."""
        cat = self.categorical
        X = np.atleast_2d(np.asarray(X, dtype=float))
        n, d = X.shape
        Xc = cat.continuous(X)
        Jc = (np.broadcast_to(np.eye(d - 1), (n, d - 1, d - 1)) if self.continuous is None
              else self.continuous.jacobian(Xc))
        J = np.zeros((n, self.n_z, d))
        keep = [j for j in range(d) if j != cat.index]
        J[:, : d - 1, keep] = Jc
        return J

    def box(self, bounds: np.ndarray) -> np.ndarray:
        """Bounding box (d - 1 + k, 2) of the image of the design box."""
        b = np.delete(np.asarray(bounds, dtype=float), self.categorical.index, axis=0)
        bc = b if self.continuous is None else self.continuous.box(b)
        return np.vstack([bc, np.tile([0.0, 1.0], (self.categorical.levels, 1))])


class LevelSlice:
    """A fitted model (``predict_moments``, ``predict_with_gradients`` on full designs)
    restricted to one level, queried on the continuous entries (N, d - 1)."""

    def __init__(self, model: Any, categorical: Categorical, level: int) -> None:
        self.model = model
        self.categorical = categorical
        self.level = int(level)

    def predict_moments(self, Xc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.model.predict_moments(self.categorical.insert(Xc, self.level))

    def predict_with_gradients(
        self, Xc: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Moments (N, m) and their gradients (N, m, d - 1) in the continuous entries."""
        mean, std, dmean, dstd = self.model.predict_with_gradients(
            self.categorical.insert(Xc, self.level))
        i = self.categorical.index
        return mean, std, np.delete(dmean, i, axis=2), np.delete(dstd, i, axis=2)

    @property
    def sample_with_gradients(self) -> Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]:
        """The model's joint samples at one level (an AttributeError when it draws none,
        as ``getattr(model, "sample_with_gradients", None)`` expects)."""
        inner = self.model.sample_with_gradients

        def sample(Xc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            Y, dY = inner(self.categorical.insert(Xc, self.level))
            return Y, np.delete(dY, self.categorical.index, axis=3)

        return sample


class LevelConstraint:
    """A model constraint of full designs (``c(X) -> (N, k)``, ``c.jacobian(X) -> (N, k,
    d)``: a :class:`ProbabilisticConstraint` or the success classifier) at one level, on the
    continuous entries (N, d - 1)."""

    def __init__(self, constraint: Any, categorical: Categorical, level: int) -> None:
        self.constraint = constraint
        self.categorical = categorical
        self.level = int(level)

    def __call__(self, Xc: np.ndarray) -> np.ndarray:
        return self.constraint(self.categorical.insert(Xc, self.level))

    def jacobian(self, Xc: np.ndarray) -> np.ndarray:
        J = self.constraint.jacobian(self.categorical.insert(Xc, self.level))
        return np.delete(J, self.categorical.index, axis=2)


def sliced_constraints(constraints: Sequence[CheapConstraint], categorical: Categorical,
                       level: int) -> list[CheapConstraint]:
    """Cheap constraints of full designs as constraints of the continuous entries at one
    level (values unchanged, the level's Jacobian column dropped)."""
    out = []
    for c in constraints:
        def fun(xc: np.ndarray, c: CheapConstraint = c) -> np.ndarray:
            return np.asarray(c.fun(categorical.insert(xc, level)[0]), dtype=float)

        def jac(xc: np.ndarray, c: CheapConstraint = c) -> np.ndarray:
            J = np.atleast_2d(np.asarray(c.jac(categorical.insert(xc, level)[0]), dtype=float))
            return np.delete(J, categorical.index, axis=1)

        out.append(CheapConstraint(fun=fun, jac=jac, kind=c.kind))
    return out


def propose_by_level(categorical: Categorical, model: Any,
                     model_constraints: Sequence[ProbabilisticConstraint], bounds: np.ndarray,
                     acquisition_of: Callable[[Any], Acquisition], X_avoid: np.ndarray,
                     extra: np.ndarray, rng: np.random.Generator, *, n_raw: int, n_starts: int,
                     cheap_constraints: Sequence[CheapConstraint] = (),
                     min_distance: float = 1e-5) -> np.ndarray:
    """The proposal of a mixed problem: the acquisition (``acquisition_of(model)``)
    maximized over the continuous variables at each level (:class:`LevelSlice`), the best
    level's optimum (values of one acquisition, so comparable across levels).

    Raises
    ------
    RuntimeError
        If no level has an admissible candidate.
    """
    cat = categorical
    box = np.delete(np.asarray(bounds, float), cat.index, axis=0)
    avoid_level, extra_level = cat.level(X_avoid), cat.level(extra)
    best: tuple[float, np.ndarray] | None = None
    for level in range(cat.levels):  # a handful of levels: one multistart each
        acq = acquisition_of(LevelSlice(model, cat, level))
        cons = [LevelConstraint(c, cat, level) for c in model_constraints]
        avoid = cat.continuous(X_avoid[avoid_level == level])
        starts = cat.continuous(extra[extra_level == level])
        try:
            xc, value = optimize_acquisition(
                acq, box, n_raw=n_raw, n_starts=n_starts,
                cheap_constraints=sliced_constraints(cheap_constraints, cat, level),
                model_constraints=cons, X_avoid=avoid if len(avoid) else None,
                min_distance=min_distance,
                extra_starts=np.clip(starts, box[:, 0], box[:, 1]) if len(starts) else None,
                rng=rng)
        except RuntimeError:
            continue
        score = value if acq.maximize else -value
        if best is None or score > best[0]:
            best = (score, cat.insert(xc, level)[0])
    if best is None:
        raise RuntimeError("no admissible candidate at any level of the categorical variable")
    return best[1]
