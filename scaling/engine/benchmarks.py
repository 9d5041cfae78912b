"""Benchmark problems for the optimizer, as pymoo Problems with known optima.

* single objective: Branin (``f* = 0.397887``), Hartmann-6 (``f* = -3.32237``);
* two objectives: ZDT1/2/3 and DTLZ2 from pymoo, BraninCurrin (BoTorch's definition).

:func:`get_benchmark` returns a :class:`Benchmark` with the problem, the reference point of
the issue's acceptance criteria and the optimum (``f*`` or the true front's hypervolume).
Baselines on the same budget: :func:`run_nsga2` (pymoo NSGA-II) and :func:`run_random`
(optimal Latin hypercube).
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from hypate.scaling.engine.pareto import hypervolume
from hypate.solvers.numerics.random import latin_hypercube
from pymoo.algorithms.moo.nsga2 import NSGA2
from pymoo.core.problem import Problem
from pymoo.optimize import minimize
from pymoo.problems import get_problem

__all__ = [
    "Branin",
    "Hartmann6",
    "BraninCurrin",
    "SlowProblem",
    "FailingProblem",
    "Benchmark",
    "get_benchmark",
    "BENCHMARKS",
    "run_nsga2",
    "run_random",
]


def _branin(x1: np.ndarray, x2: np.ndarray) -> np.ndarray:
    a, b, c = 1.0, 5.1 / (4 * np.pi**2), 5.0 / np.pi
    r, s, t = 6.0, 10.0, 1.0 / (8 * np.pi)
    return a * (x2 - b * x1**2 + c * x1 - r) ** 2 + s * (1 - t) * np.cos(x1) + s


class Branin(Problem):
    """Branin-Hoo on ``[-5, 10] x [0, 15]``; three global minima with ``f* = 5 / (4 pi)``."""

    optimum = 0.397887357729738

    def __init__(self) -> None:
        super().__init__(n_var=2, n_obj=1, xl=np.array([-5.0, 0.0]), xu=np.array([10.0, 15.0]))

    def _evaluate(self, X, out, *args, **kwargs):
        out["F"] = _branin(X[:, 0], X[:, 1])[:, None]


class Hartmann6(Problem):
    """Hartmann-6 on ``[0, 1]^6``; ``f* = -3.32237``."""

    optimum = -3.32236801141551
    _alpha = np.array([1.0, 1.2, 3.0, 3.2])
    _A = np.array([[10, 3, 17, 3.5, 1.7, 8], [0.05, 10, 17, 0.1, 8, 14],
                   [3, 3.5, 1.7, 10, 17, 8], [17, 8, 0.05, 10, 0.1, 14]], dtype=float)
    _P = 1e-4 * np.array([[1312, 1696, 5569, 124, 8283, 5886],
                          [2329, 4135, 8307, 3736, 1004, 9991],
                          [2348, 1451, 3522, 2883, 3047, 6650],
                          [4047, 8828, 8732, 5743, 1091, 381]])

    def __init__(self) -> None:
        super().__init__(n_var=6, n_obj=1, xl=np.zeros(6), xu=np.ones(6))

    def _evaluate(self, X, out, *args, **kwargs):
        inner = np.einsum("kd,nkd->nk", self._A, (X[:, None, :] - self._P[None]) ** 2)
        out["F"] = (-np.exp(-inner) @ self._alpha)[:, None]


class BraninCurrin(Problem):
    """BraninCurrin on ``[0, 1]^2`` (two objectives, minimized; BoTorch's definition)."""

    def __init__(self) -> None:
        super().__init__(n_var=2, n_obj=2, xl=np.zeros(2), xu=np.ones(2))

    def _evaluate(self, X, out, *args, **kwargs):
        f1 = _branin(15.0 * X[:, 0] - 5.0, 15.0 * X[:, 1])
        x0, x1 = X[:, 0], X[:, 1]
        with np.errstate(divide="ignore"):
            factor = 1.0 - np.exp(-1.0 / (2.0 * x1))
        f2 = factor * (2300 * x0**3 + 1900 * x0**2 + 2092 * x0 + 60) / (
            100 * x0**3 + 500 * x0**2 + 4 * x0 + 20)
        out["F"] = np.c_[f1, f2]


class SlowProblem(Problem):
    """Wrap a problem so that each evaluated design costs ``delay`` seconds (batch tests)."""

    def __init__(self, problem: Problem, delay: float = 1.0) -> None:
        super().__init__(n_var=problem.n_var, n_obj=problem.n_obj,
                         n_ieq_constr=problem.n_ieq_constr, xl=problem.xl, xu=problem.xu)
        self.inner = problem
        self.delay = float(delay)

    def _evaluate(self, X, out, *args, **kwargs):
        time.sleep(self.delay * len(X))
        res = self.inner.evaluate(X, return_as_dictionary=True)
        out.update({k: v for k, v in res.items() if k in ("F", "G")})


class FailingProblem(Problem):
    """Wrap a problem: designs with ``x[0]`` above ``threshold`` (in the unit box) raise;
    optionally designs with ``x[1]`` above ``nan_threshold`` return NaN (failure tests)."""

    def __init__(self, problem: Problem, threshold: float = 0.7,
                 nan_threshold: float | None = None) -> None:
        super().__init__(n_var=problem.n_var, n_obj=problem.n_obj,
                         n_ieq_constr=problem.n_ieq_constr, xl=problem.xl, xu=problem.xu)
        self.inner = problem
        self.threshold = threshold
        self.nan_threshold = nan_threshold

    def _evaluate(self, X, out, *args, **kwargs):
        U = (X - self.xl) / (self.xu - self.xl)
        if np.any(U[:, 0] > self.threshold):
            raise RuntimeError("solver diverged")
        res = self.inner.evaluate(X, return_as_dictionary=True)
        F = np.array(res["F"], dtype=float)
        if self.nan_threshold is not None:
            F[U[:, 1] > self.nan_threshold] = np.nan
        out["F"] = F


@dataclass(frozen=True)
class Benchmark:
    """A test problem with its acceptance data.

    Attributes
    ----------
    name : str
    problem : pymoo Problem
    ref_point : ndarray or None
        Hypervolume reference point (multi-objective).
    optimum : float
        ``f*`` (single objective) or the true Pareto front's hypervolume.
    target : float or None
        Acceptance target (hypervolume) of the issue, if any.
    n_init, n_iter : int
        Default budget of the acceptance runs.
    """

    name: str
    problem: Problem
    ref_point: np.ndarray | None
    optimum: float
    target: float | None
    n_init: int
    n_iter: int

    @property
    def multi_objective(self) -> bool:
        return self.problem.n_obj > 1


#: Names accepted by :func:`get_benchmark`.
BENCHMARKS: tuple[str, ...] = ("zdt1", "zdt2", "zdt3", "dtlz2", "branincurrin", "branin",
                               "hartmann6")


def get_benchmark(name: str, n_var: int | None = None) -> Benchmark:
    """A benchmark by name (``BENCHMARKS``); ``n_var`` for the scalable ZDT/DTLZ problems.

    Reference points and optima follow the issue: ZDT ``[11, 11]`` (ZDT1 front HV
    ``121 - 1/3``, ZDT2 ``121 - 2/3``), DTLZ2 ``[1.1, 1.1]`` (``1.21 - pi/4``),
    BraninCurrin ``[18, 6]`` (59.4065, dense sampling).
    """

    key = name.lower()
    if key in ("zdt1", "zdt2", "zdt3"):
        d = 6 if n_var is None else n_var
        opt = {"zdt1": 121 - 1 / 3, "zdt2": 121 - 2 / 3, "zdt3": float("nan")}[key]
        tgt = {"zdt1": 120.48, "zdt2": 119.91, "zdt3": None}[key]
        return Benchmark(key, get_problem(key, n_var=d), np.array([11.0, 11.0]), opt, tgt, 20, 50)
    if key == "dtlz2":
        d = 6 if n_var is None else n_var
        return Benchmark(key, get_problem("dtlz2", n_var=d, n_obj=2), np.array([1.1, 1.1]),
                         1.21 - np.pi / 4, 0.361, 20, 50)
    if key == "branincurrin":
        return Benchmark(key, BraninCurrin(), np.array([18.0, 6.0]), 59.4065, 57.87, 6, 64)
    if key == "branin":
        return Benchmark(key, Branin(), None, Branin.optimum, None, 10, 30)
    if key == "hartmann6":
        return Benchmark(key, Hartmann6(), None, Hartmann6.optimum, None, 10, 90)
    raise ValueError(f"unknown benchmark {name!r}; choose from {BENCHMARKS}")


class _Recorder(Problem):
    """Forward to a problem and keep every evaluated objective vector (the archive)."""

    def __init__(self, problem: Problem) -> None:
        super().__init__(n_var=problem.n_var, n_obj=problem.n_obj, xl=problem.xl, xu=problem.xu)
        self.inner = problem
        self.archive: list[np.ndarray] = []

    def _evaluate(self, X, out, *args, **kwargs):
        F = self.inner.evaluate(X, return_as_dictionary=True)["F"]
        self.archive.append(np.asarray(F, dtype=float))
        out["F"] = F


def _history(F: np.ndarray, ref_point: np.ndarray | None) -> np.ndarray:
    if ref_point is None:
        return np.minimum.accumulate(F[:, 0])
    return np.array([hypervolume(F[: i + 1], ref_point) for i in range(len(F))])


def run_nsga2(bench: Benchmark, n_evaluations: int, seed: int, pop_size: int = 10) -> np.ndarray:
    """pymoo NSGA-II with ``pop_size`` on ``n_evaluations``; history of the archive's
    hypervolume (or best value) per evaluation."""

    rec = _Recorder(bench.problem)
    minimize(rec, NSGA2(pop_size=pop_size), ("n_evals", n_evaluations), seed=seed, verbose=False)
    F = np.vstack(rec.archive)[:n_evaluations]
    return _history(F, bench.ref_point)


def run_random(bench: Benchmark, n_evaluations: int, seed: int) -> np.ndarray:
    """Optimal-Latin-hypercube random search on the same budget; history as above."""
    p = bench.problem
    X = latin_hypercube(n_evaluations, np.c_[p.xl, p.xu], seed)
    F = p.evaluate(X, return_as_dictionary=True)["F"]
    return _history(np.asarray(F, float), bench.ref_point)
