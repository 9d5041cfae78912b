"""Categorical design variables (e.g. the model material, the model's edge support) next to
continuous ones.

A categorical variable sits in the design vector as its level number ``0 .. k-1``
(bounds ``[0, k - 1]``), so stores, executors and pymoo problems see plain float vectors.
Three pieces make the Bayesian optimization mixed-variable (Garrido-Merchan and
Hernandez-Lobato's one-hot treatment, with the inner search enumerating the levels as the
dissertation's SLSQP multistart cannot step between them):

* :class:`Categorical` -- which entries are categorical and how many levels each has;
* :class:`MixedCoordinates` -- the surrogates' inputs ``z = [c(x_cont), onehot(levels)]``
  (one indicator block per variable):
  the kriging kernel (Eq. (A.3)) gets one length scale per level indicator, i.e. a learned
  correlation ``exp(-(1/l_a^2 + 1/l_b^2) / 2)`` (Gaussian) between levels ``a`` and ``b``,
  and the continuous part keeps its own coordinates (design or log-linear similarity axes);
* :class:`LevelSlice` -- a fitted model restricted to one combination of levels and
  queried, with exact gradients, on the continuous variables alone: the inner SLSQP
  multistart runs once per combination on it and the best one's optimum is the proposal.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from hypate.scaling.engine.acquisition import Acquisition
from hypate.scaling.engine.coordinates import LogLinearCoordinates
from hypate.scaling.engine.inner import optimize_acquisition
from hypate.scaling.engine.problem import CheapConstraint
from hypate.scaling.engine.surrogate import ProbabilisticConstraint

__all__ = ["Categorical", "LevelSlice", "MixedCoordinates", "propose_by_level",
           "sliced_constraints"]


#: Most combinations of the categorical variables' values (one inner search each).
MAX_COMBINATIONS = 64


def _entries(value: int | tuple[int, ...]) -> tuple[int, ...]:
    """One entry per variable: a plain integer is one variable."""
    return tuple(value) if isinstance(value, (tuple, list)) else (value,)


@dataclass(frozen=True)
class Categorical:
    """Entries ``index`` of the design vector are categorical, entry ``index[j]`` with
    ``levels[j]`` values ``0 .. levels[j] - 1`` (its bounds must be ``[0, levels[j] - 1]``);
    one variable may be given as plain integers (``Categorical(index=1, levels=3)``).

    The engine enumerates the *combinations* of the variables' values
    (:attr:`count` of them, at most :data:`MAX_COMBINATIONS`): a combination number
    ``0 .. count - 1`` (:meth:`level`) is the mixed-radix number of the variables' levels,
    the first variable's the most significant digit, so one variable's combination is its
    level.
    """

    index: int | tuple[int, ...]
    levels: int | tuple[int, ...]

    def __post_init__(self) -> None:
        index, levels = _entries(self.index), _entries(self.levels)
        if not index or len(index) != len(levels):
            raise ValueError(f"categorical index and levels need one entry per variable, got "
                             f"{self.index} and {self.levels}")
        for i in index:
            if int(i) != i or i < 0:
                raise ValueError(f"categorical index must be a non-negative integer, got {i}")
        if len(set(index)) != len(index):
            raise ValueError(f"categorical index lists an entry twice: {self.index}")
        for k in levels:
            if int(k) != k or k < 2:
                raise ValueError(f"a categorical variable needs at least 2 levels, got {k}")
        if math.prod(levels) > MAX_COMBINATIONS:
            raise ValueError(f"categorical variables with {' x '.join(map(str, levels))} = "
                             f"{math.prod(levels)} combinations: at most {MAX_COMBINATIONS} "
                             "(each one is an inner search per proposal)")
        object.__setattr__(self, "indices", tuple(int(i) for i in index))
        object.__setattr__(self, "sizes", tuple(int(k) for k in levels))

    indices: tuple[int, ...] = field(init=False, repr=False, compare=False)
    sizes: tuple[int, ...] = field(init=False, repr=False, compare=False)

    @property
    def count(self) -> int:
        """Number of combinations of the variables' values."""
        return math.prod(self.sizes)

    def problem_mismatch(self, bounds: np.ndarray) -> tuple[str, Any] | None:
        """(allowed, value) when the design box ``bounds`` (d, 2) does not fit these
        variables (indices inside the vector, bounds ``[0, levels - 1]``); None when it fits."""
        n_var = len(bounds)
        for i, k in zip(self.indices, self.sizes):
            if not i < n_var:
                return f"an index in [0, {n_var - 1}]", i
            if tuple(bounds[i]) != (0.0, float(k - 1)):
                return f"bounds [0, {k - 1}] of variable {i}", tuple(bounds[i])
        return None

    def variable_levels(self, X: np.ndarray) -> np.ndarray:
        """Each variable's level (N, n_cat) of designs ``X`` (N, d): the nearest, clipped."""
        cols = np.atleast_2d(np.asarray(X, dtype=float))[:, list(self.indices)]
        return np.clip(np.rint(cols), 0, np.asarray(self.sizes) - 1).astype(int)

    def _radix(self) -> np.ndarray:
        """Place values of the mixed-radix combination number."""
        return np.r_[np.cumprod(self.sizes[:0:-1])[::-1], 1].astype(int)

    def level(self, X: np.ndarray) -> np.ndarray:
        """Combination numbers (N,) of designs ``X`` (N, d)."""
        return self.variable_levels(X) @ self._radix()

    def levels_of(self, level: int) -> np.ndarray:
        """Each variable's level (n_cat,) in combination ``level``."""
        return (int(level) // self._radix()) % np.asarray(self.sizes)

    def snap(self, X: np.ndarray) -> np.ndarray:
        """``X`` with each categorical entry set to its nearest level."""
        X = np.array(np.atleast_2d(X), dtype=float)
        X[:, list(self.indices)] = self.variable_levels(X)
        return X

    def continuous(self, X: np.ndarray) -> np.ndarray:
        """The continuous entries (N, d - n_cat) of designs ``X`` (N, d)."""
        return np.delete(np.atleast_2d(np.asarray(X, dtype=float)), list(self.indices), axis=1)

    def insert(self, Xc: np.ndarray, level: int) -> np.ndarray:
        """Full designs (N, d) from continuous entries ``Xc`` (N, d - n_cat) at combination
        ``level``."""
        Xc = np.atleast_2d(np.asarray(Xc, dtype=float))
        X = np.empty((len(Xc), Xc.shape[1] + len(self.indices)))
        cat = list(self.indices)
        X[:, np.setdiff1d(np.arange(X.shape[1]), cat)] = Xc
        X[:, cat] = self.levels_of(level).astype(float)
        return X

    def stratified(self, X: np.ndarray) -> np.ndarray:
        """``X`` (N, d) of a Latin hypercube with each categorical column's strata made
        levels: a column ``c`` in ``[0, k - 1]`` becomes ``floor(k u)``, ``u = c / (k - 1)``,
        so an LHS of ``n`` points takes each level ``n / k`` times (within one)."""
        X = np.array(X, dtype=float)
        for i, k in zip(self.indices, self.sizes):
            u = X[:, i] / (k - 1) * (1.0 - 1e-12)
            X[:, i] = np.minimum(np.floor(u * k), k - 1)
        return X


class MixedCoordinates:
    """Surrogate inputs ``z = [c(x_cont), onehot(levels)]`` of mixed designs: each
    categorical variable's ``k_j`` indicators, in the order of ``categorical.indices``.

    Parameters
    ----------
    categorical : Categorical
    n_var : int
        Length ``d`` of the design vector (the categorical entries included).
    continuous : LogLinearCoordinates or None
        Coordinates of the ``d - n_cat`` continuous entries (None: the entries themselves).
    """

    def __init__(self, categorical: Categorical, n_var: int,
                 continuous: LogLinearCoordinates | None = None) -> None:
        if not all(0 <= i < n_var for i in categorical.indices):
            raise ValueError(f"categorical index {categorical.index} outside a design of "
                             f"{n_var} variables")
        n_cont = n_var - len(categorical.indices)
        if continuous is not None and continuous.matrix.shape != (n_cont, n_cont):
            raise ValueError(f"continuous coordinates need a {n_cont} x {n_cont} matrix")
        self.categorical = categorical
        self.n_var = int(n_var)
        self.n_cont = n_cont
        self.continuous = continuous

    @property
    def n_z(self) -> int:
        return self.n_cont + sum(self.categorical.sizes)

    def __call__(self, X: np.ndarray) -> np.ndarray:
        """``z`` (N, d - n_cat + sum k_j) of designs ``X`` (N, d)."""
        cat = self.categorical
        Xc = cat.continuous(X)
        zc = Xc if self.continuous is None else self.continuous(Xc)
        digits = cat.variable_levels(X)
        onehot = [(digits[:, j, None] == np.arange(k)[None]).astype(float)
                  for j, k in enumerate(cat.sizes)]
        return np.hstack([zc, *onehot])

    def jacobian(self, X: np.ndarray) -> np.ndarray:
        """``dz/dx`` (N, n_z, d): the continuous block, zero for the levels (piecewise-
        constant indicators) and for the indicators' rows."""
        cat = self.categorical
        X = np.atleast_2d(np.asarray(X, dtype=float))
        n, d = X.shape
        Xc = cat.continuous(X)
        nc = self.n_cont
        Jc = (np.broadcast_to(np.eye(nc), (n, nc, nc)) if self.continuous is None
              else self.continuous.jacobian(Xc))
        J = np.zeros((n, self.n_z, d))
        keep = [j for j in range(d) if j not in cat.indices]
        J[:, :nc, keep] = Jc
        return J

    def box(self, bounds: np.ndarray) -> np.ndarray:
        """Bounding box (n_z, 2) of the image of the design box."""
        b = np.delete(np.asarray(bounds, dtype=float), list(self.categorical.indices), axis=0)
        bc = b if self.continuous is None else self.continuous.box(b)
        return np.vstack([bc, np.tile([0.0, 1.0], (sum(self.categorical.sizes), 1))])


class LevelSlice:
    """A fitted model (``predict_moments``, ``predict_with_gradients`` on full designs)
    restricted to one combination of levels, queried on the continuous entries
    (N, d - n_cat)."""

    def __init__(self, model: Any, categorical: Categorical, level: int) -> None:
        self.model = model
        self.categorical = categorical
        self.level = int(level)

    def predict_moments(self, Xc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.model.predict_moments(self.categorical.insert(Xc, self.level))

    def predict_with_gradients(
        self, Xc: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Moments (N, m) and their gradients (N, m, d - n_cat) in the continuous entries."""
        mean, std, dmean, dstd = self.model.predict_with_gradients(
            self.categorical.insert(Xc, self.level))
        i = list(self.categorical.indices)
        return mean, std, np.delete(dmean, i, axis=2), np.delete(dstd, i, axis=2)

    @property
    def sample_with_gradients(self) -> Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]:
        """The model's joint samples at one level (an AttributeError when it draws none,
        as ``getattr(model, "sample_with_gradients", None)`` expects)."""
        inner = self.model.sample_with_gradients

        def sample(Xc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            Y, dY = inner(self.categorical.insert(Xc, self.level))
            return Y, np.delete(dY, list(self.categorical.indices), axis=3)

        return sample


class LevelConstraint:
    """A model constraint of full designs (``c(X) -> (N, k)``, ``c.jacobian(X) -> (N, k,
    d)``: a :class:`ProbabilisticConstraint` or the success classifier) at one combination of
    levels, on the continuous entries (N, d - n_cat)."""

    def __init__(self, constraint: Any, categorical: Categorical, level: int) -> None:
        self.constraint = constraint
        self.categorical = categorical
        self.level = int(level)

    def __call__(self, Xc: np.ndarray) -> np.ndarray:
        return self.constraint(self.categorical.insert(Xc, self.level))

    def jacobian(self, Xc: np.ndarray) -> np.ndarray:
        J = self.constraint.jacobian(self.categorical.insert(Xc, self.level))
        return np.delete(J, list(self.categorical.indices), axis=2)


def sliced_constraints(constraints: Sequence[CheapConstraint], categorical: Categorical,
                       level: int) -> list[CheapConstraint]:
    """Cheap constraints of full designs as constraints of the continuous entries at one
    combination of levels (values unchanged, the levels' Jacobian columns dropped)."""
    out = []
    for c in constraints:
        def fun(xc: np.ndarray, c: CheapConstraint = c) -> np.ndarray:
            return np.asarray(c.fun(categorical.insert(xc, level)[0]), dtype=float)

        def jac(xc: np.ndarray, c: CheapConstraint = c) -> np.ndarray:
            J = np.atleast_2d(np.asarray(c.jac(categorical.insert(xc, level)[0]), dtype=float))
            return np.delete(J, list(categorical.indices), axis=1)

        out.append(CheapConstraint(fun=fun, jac=jac, kind=c.kind))
    return out


def propose_by_level(categorical: Categorical, model: Any,
                     model_constraints: Sequence[ProbabilisticConstraint], bounds: np.ndarray,
                     acquisition_of: Callable[[Any], Acquisition], X_avoid: np.ndarray,
                     extra: np.ndarray, rng: np.random.Generator, *, n_raw: int, n_starts: int,
                     cheap_constraints: Sequence[CheapConstraint] = (),
                     min_distance: float = 1e-5) -> np.ndarray:
    """The proposal of a mixed problem: the acquisition (``acquisition_of(model)``)
    maximized over the continuous variables at each combination of levels
    (:class:`LevelSlice`), the best combination's optimum (values of one acquisition, so
    comparable across combinations).

    Raises
    ------
    RuntimeError
        If no level has an admissible candidate.
    """
    cat = categorical
    box = np.delete(np.asarray(bounds, float), list(cat.indices), axis=0)
    avoid_level, extra_level = cat.level(X_avoid), cat.level(extra)
    best: tuple[float, np.ndarray] | None = None
    for level in range(cat.count):  # a handful of combinations: one multistart each
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
