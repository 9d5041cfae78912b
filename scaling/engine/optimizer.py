"""Bayesian optimization loop (Sec. 6.3.1, updating approach) for any pymoo Problem.

Direct approach: the weighted metric ``S_g`` (Eq. (6.11); ``g = 1`` weighted sum,
``g = inf`` Chebyshev) of the objectives' confidence bounds. Indirect approach: hypervolume
acquisitions (HVLCB, HVEI, HVPoI; Eqs. (6.25)-(6.28)) producing a Pareto set.
Single-objective problems use PoI, EI or LCB (Eqs. (6.14)-(6.22)).

Each iteration (Sec. 6.3.1 step 4):

1. fit kriging surrogates of the objectives on the successful evaluations, of the expensive
   constraints (``G <= 0``) and, if any evaluation failed, of the failure indicator;
2. maximize the acquisition by :func:`optimize_acquisition`: optimal-Latin-hypercube raw
   points, the best ``n_starts`` of them polished by SLSQP with analytic gradients, the
   cheap constraints enforced exactly and the surrogate constraints
   (:class:`hypate.scaling.engine.surrogate.ProbabilisticConstraint`: predicted probability of
   feasibility of each expensive constraint ``>= p_feasible``, predicted failure
   indicator ``<= 1/2``) as SLSQP inequalities;
3. for batches ``q > 1`` repeat 2 on a fantasized model (kriging believer: the predicted
   mean is appended as if observed; constant liar: the best value so far);
4. evaluate the batch through a ``concurrent.futures``-style executor (anything with
   ``submit(fn, *args)`` returning futures with ``.result(timeout)``: a
   ``ProcessPoolExecutor`` or a ``dask.distributed.Client``) or in-process, and commit
   each finished evaluation to the store before the next proposal.

Reproducibility: the random numbers of iteration ``t`` come from
``numpy.random.default_rng([seed, t])`` and a proposal depends only on the evaluations of
earlier iterations, so a resumed run proposes exactly what the uninterrupted run proposed.
"""
from __future__ import annotations

import math
import threading
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd
from hypate.scaling.engine.acquisition import (
    Acquisition,
    ExpectedImprovement,
    HypervolumeEI,
    HypervolumeLCB,
    HypervolumePoI,
    LowerConfidenceBound,
    ProbabilityOfImprovement,
    WeightedMetricLCB,
    weighted_metric,
)
from hypate.scaling.engine.pareto import hypervolume, non_dominated_mask, pareto_front
from hypate.scaling.engine.store import (
    STATUS_OK,
    Evaluation,
    EvaluationStore,
    evaluations_to_dataframe,
)
from hypate.scaling.engine.surrogate import ProbabilisticConstraint, fit_surrogate
from hypate.solvers.numerics.random import as_rng, latin_hypercube, raw_latin_hypercube
from hypate.solvers.numerics.threads import blas_threads
from scipy.optimize import Bounds, minimize

__all__ = [
    "CheapConstraint",
    "LogLinearCoordinates",
    "AcquisitionContext",
    "BayesianOptimizer",
    "OptimizationResult",
    "optimize_acquisition",
    "evaluate_design",
    "SINGLE_OBJECTIVE_ACQUISITIONS",
    "MULTI_OBJECTIVE_ACQUISITIONS",
]

SINGLE_OBJECTIVE_ACQUISITIONS: tuple[str, ...] = ("lcb", "ei", "poi")
MULTI_OBJECTIVE_ACQUISITIONS: tuple[str, ...] = ("hvlcb", "hvei", "hvpoi", "ws", "cheb", "wm")
#: Objective transforms the surrogates may model (:class:`BayesianOptimizer`).
OUTPUT_TRANSFORMS: tuple[str, ...] = ("none", "log")
#: Smallest objective value of the log transform (ln 1e-12 = -27.6).
LOG_FLOOR = 1e-12

#: Feasibility tolerance of the cheap constraints at every proposal.
CHEAP_TOL = 1e-8
#: Default HVLCB exploration weight ``v`` of Eq. (6.28): tuned on the issue's benchmarks
#: (v = 1 over-exploits BraninCurrin's x1 = 1 edge for one seed in five; v = 2 costs DTLZ2
#: about 4 % of hypervolume regret-wise); see the closing note of issue 3.
HVLCB_V = 1.5
#: Smoothing of the failure-indicator kriging (standardized nugget, unit-box length scales).
FAILURE_NUGGET = 0.05
FAILURE_LENGTH_SCALES = (0.15, 1e2)
#: Largest predicted failure indicator accepted for a proposal.
FAILURE_THRESHOLD = 0.15


# ----------------------------------------------------------------- cheap constraints
@dataclass(frozen=True)
class CheapConstraint:
    """An analytic constraint enforced exactly inside the inner optimization.

    Parameters
    ----------
    fun : callable
        ``fun(x) -> ndarray of shape (k,)`` (or a scalar) for one design ``x`` of shape (d,).
    jac : callable
        ``jac(x) -> ndarray of shape (k, d)`` (or (d,)).
    kind : {"ineq", "eq"}
        ``"ineq"``: ``fun(x) <= 0`` (pymoo's convention); ``"eq"``: ``fun(x) == 0``
        (Eqs. (6.10b)-(6.10c)).
    """

    fun: Callable[[np.ndarray], Any]
    jac: Callable[[np.ndarray], Any]
    kind: Literal["ineq", "eq"] = "ineq"

    def __post_init__(self) -> None:
        if self.kind not in ("ineq", "eq"):
            raise ValueError(f"kind must be 'ineq' or 'eq', got {self.kind!r}")

    def violation(self, x: np.ndarray) -> float:
        """Largest violation at ``x`` (0 if satisfied)."""
        c = np.atleast_1d(np.asarray(self.fun(x), dtype=float))
        v = np.abs(c) if self.kind == "eq" else np.maximum(c, 0.0)
        return float(v.max(initial=0.0))


def _cheap_violation(constraints: Sequence[CheapConstraint], x: np.ndarray) -> float:
    return max((c.violation(x) for c in constraints), default=0.0)


def _scipy_cheap(constraints: Sequence[CheapConstraint], lo: np.ndarray, span: np.ndarray):
    """Cheap constraints in unit coordinates ``x = lo + u span``, scipy's ``>= 0`` form."""
    out = []
    for c in constraints:
        sign = 1.0 if c.kind == "eq" else -1.0

        def fun(u, c=c, sign=sign):
            return sign * np.atleast_1d(np.asarray(c.fun(lo + u * span), dtype=float))

        def jac(u, c=c, sign=sign):
            J = np.atleast_2d(np.asarray(c.jac(lo + u * span), dtype=float))
            return sign * J * span

        out.append({"type": c.kind, "fun": fun, "jac": jac})
    return out


def _project(u0: np.ndarray, cons: list, tol: float = 1e-14) -> np.ndarray:
    """Closest point of the unit box satisfying the scipy-form constraints (SLSQP)."""
    d = len(u0)
    res = minimize(lambda u: (0.5 * np.sum((u - u0) ** 2), u - u0), u0, jac=True,
                   method="SLSQP", bounds=Bounds(np.zeros(d), np.ones(d)), constraints=cons,
                   options={"maxiter": 200, "ftol": tol})
    return np.clip(res.x, 0.0, 1.0)


def project_cheap(problem: Any, x: np.ndarray) -> np.ndarray:
    """Clip ``x`` to the bounds of ``problem`` (a pymoo problem with ``cheap_constraints()``)
    and project it onto its cheap constraints (e.g. the Eq. 9.7 equality), as the optimizer
    does for its initial design, so that seeds satisfy them exactly."""
    lo, hi = np.asarray(problem.xl, float), np.asarray(problem.xu, float)
    x = np.clip(np.asarray(x, float), lo, hi)
    cons = problem.cheap_constraints()
    if not cons:
        return x
    span = hi - lo
    u = _project((x - lo) / span, _scipy_cheap(cons, lo, span))
    return lo + u * span


# ------------------------------------------------------------ input coordinates
@dataclass(frozen=True)
class LogLinearCoordinates:
    """Surrogate input coordinates ``z = A ln x`` of positive design variables.

    Kriging with one length scale per input (Eq. (A.3)) resolves a landscape whose valleys
    are aligned with the inputs. The objective of a scaling problem depends mainly on the
    similarity parameters, monomials ``Pi_i = c_i prod_j x_j^(A_ij)`` of the design
    (Sec. 6.1), so its valleys (``Pi_i = Pi_i^p``) are hyperplanes of ``ln x`` that are
    oblique to the axes (Sec. 9.1: ``h``, ``p_inf ~ h^3``, ``Delta T ~ h^2``). Rows of
    ``A`` that are the exponents of those parameters make them the axes. Only the
    surrogates see ``z``: designs, bounds, cheap constraints and the acquisition search
    stay in ``x`` (gradients by the chain rule).

    Parameters
    ----------
    matrix : ndarray of shape (d, d)
        Invertible; ``A = I`` gives plain log coordinates.
    """

    matrix: np.ndarray

    def __post_init__(self) -> None:
        A = np.asarray(self.matrix, dtype=float)
        if A.ndim != 2 or A.shape[0] != A.shape[1] or not np.all(np.isfinite(A)):
            raise ValueError(f"coordinate matrix must be square and finite, got shape {A.shape}")
        if np.linalg.cond(A) > 1e10:
            raise ValueError("coordinate matrix is singular: the rows must be independent")
        object.__setattr__(self, "matrix", A)

    @classmethod
    def log(cls, d: int) -> "LogLinearCoordinates":
        return cls(np.eye(d))

    def __call__(self, X: np.ndarray) -> np.ndarray:
        """``z`` of designs ``X`` of shape (N, d) (all entries positive)."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        return np.log(X) @ self.matrix.T

    def jacobian(self, X: np.ndarray) -> np.ndarray:
        """``dz/dx = A diag(1/x)``, shape (N, d, d)."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        return self.matrix[None] / X[:, None, :]

    def box(self, bounds: np.ndarray) -> np.ndarray:
        """Bounding box (d, 2) of the image of the design box (the surrogates' unit box)."""
        b = np.log(np.asarray(bounds, dtype=float))
        lo = np.where(self.matrix > 0, self.matrix * b[:, 0], self.matrix * b[:, 1]).sum(axis=1)
        hi = np.where(self.matrix > 0, self.matrix * b[:, 1], self.matrix * b[:, 0]).sum(axis=1)
        return np.c_[lo, hi]


class _WarpedModel:
    """A surrogate fitted in ``z`` coordinates, queried (with gradients) in ``x``."""

    def __init__(self, model: Any, coords: LogLinearCoordinates) -> None:
        self.model = model
        self.coords = coords

    def predict_moments(self, X: np.ndarray):
        return self.model.predict_moments(self.coords(X))

    def predict_with_gradients(self, X: np.ndarray):
        mean, std, dmean, dstd = self.model.predict_with_gradients(self.coords(X))
        J = self.coords.jacobian(X)
        return (mean, std, np.einsum("nmk,nkd->nmd", dmean, J),
                np.einsum("nmk,nkd->nmd", dstd, J))

    def condition(self, X: np.ndarray, y: np.ndarray) -> "_WarpedModel":
        return _WarpedModel(self.model.condition(self.coords(X), y), self.coords)


# ----------------------------------------------------------- inner optimization
def optimize_acquisition(
    acquisition: Acquisition,
    bounds: np.ndarray,
    *,
    n_raw: int = 256,
    n_starts: int = 5,
    cheap_constraints: Sequence[CheapConstraint] = (),
    model_constraints: Sequence[ProbabilisticConstraint] = (),
    X_avoid: np.ndarray | None = None,
    min_distance: float = 1e-5,
    extra_starts: np.ndarray | None = None,
    rng: np.random.Generator | int | None = None,
    maxiter: int = 200,
    ftol: float = 1e-9,
) -> tuple[np.ndarray, float]:
    """Multistart SLSQP maximization (or minimization) of an acquisition (Sec. 6.3.3).

    Raw OLH points (plus ``extra_starts``) are scored by the acquisition; the best
    ``n_starts`` (those satisfying the model constraints first) start SLSQP with the
    analytic gradient, the cheap constraints (exact) and the model constraints. Results
    whose cheap constraints are violated by more than 1e-8 are polished by a projection and
    rejected if still infeasible; a result closer than ``min_distance`` (unit-box
    coordinates) to a row of ``X_avoid`` is rejected in favour of the next best.

    Parameters
    ----------
    acquisition : Acquisition
        ``maximize`` says the sense.
    bounds : ndarray of shape (d, 2)
    n_raw, n_starts : int
    cheap_constraints : sequence of CheapConstraint
    model_constraints : sequence of ProbabilisticConstraint
        Each ``c(x) <= 0``.
    X_avoid : ndarray of shape (n, d) or None
        Existing (and pending) samples.
    min_distance : float
    extra_starts : ndarray of shape (s, d) or None
        Additional candidate starts (e.g. the best designs so far).
    rng : numpy.random.Generator, int or None
    maxiter : int
        SLSQP iteration limit.
    ftol : float
        SLSQP tolerance on the scaled acquisition.

    Returns
    -------
    x : ndarray of shape (d,)
    value : float
        Acquisition value at ``x``.
    """
    rng = as_rng(rng)
    b = np.asarray(bounds, dtype=float)
    lo, span = b[:, 0], b[:, 1] - b[:, 0]
    d = len(lo)
    sign = -1.0 if acquisition.maximize else 1.0
    U = raw_latin_hypercube(n_raw, np.c_[np.zeros(d), np.ones(d)], rng)
    if extra_starts is not None and len(extra_starts):
        U = np.vstack([U, np.clip((np.atleast_2d(extra_starts) - lo) / span, 0.0, 1.0)])
    X = lo + U * span
    loss = sign * acquisition(X)
    viol = np.zeros(len(U))
    for mc in model_constraints:
        viol += np.maximum(mc(X), 0.0).sum(axis=1)
    loss = np.where(np.isfinite(loss), loss, np.inf)
    order = np.lexsort((loss, viol > 0))
    U_avoid = None if X_avoid is None or len(X_avoid) == 0 else (np.atleast_2d(X_avoid) - lo) / span

    def far(u: np.ndarray) -> bool:
        return U_avoid is None or float(np.min(np.linalg.norm(U_avoid - u, axis=1))) >= min_distance

    starts = U[order[:n_starts]]
    scale = max(float(np.max(np.abs(loss[order[:n_starts]]))), 1e-300)
    if not np.isfinite(scale):
        scale = 1.0
    cheap = _scipy_cheap(cheap_constraints, lo, span)
    model_cons = []
    for mc in model_constraints:
        model_cons.append({
            "type": "ineq",
            "fun": lambda u, mc=mc: -mc(lo + u * span)[0],
            "jac": lambda u, mc=mc: -mc.jacobian(lo + u * span)[0] * span,
        })

    def fun(u: np.ndarray):
        val, grad = acquisition.value_and_gradient((lo + u * span)[None])
        return sign * float(val[0]) / scale, sign * grad[0] * span / scale

    def model_violation(u: np.ndarray) -> float:
        x = (lo + u * span)[None]
        return float(sum(np.maximum(mc(x), 0.0).sum() for mc in model_constraints))

    def cheap_ok(u: np.ndarray) -> bool:
        return _cheap_violation(cheap_constraints, lo + u * span) <= CHEAP_TOL

    candidates: list[tuple[bool, float, np.ndarray]] = []
    box = Bounds(np.zeros(d), np.ones(d))
    for u0 in starts:  # loop over starts
        if cheap and not cheap_ok(u0):
            u0 = _project(u0, cheap)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            res = minimize(fun, u0, jac=True, method="SLSQP", bounds=box,
                           constraints=cheap + model_cons,
                           options={"maxiter": maxiter, "ftol": ftol})
        u = np.clip(res.x, 0.0, 1.0)
        # status 0: converged; 9: iteration limit (a valid improved iterate); others (e.g.
        # 4 "inequality constraints incompatible", 8 line search) keep the better of x, x0
        if res.status not in (0, 9) and not fun(u)[0] <= fun(u0)[0]:
            u = u0
        if cheap and not cheap_ok(u):
            u = _project(u, cheap)
            if not cheap_ok(u):
                continue
        candidates.append((model_violation(u) > 1e-6, fun(u)[0], u))
    candidates.sort(key=lambda c: (c[0], c[1]))
    for _, _, u in candidates:
        if far(u):
            x = lo + u * span
            return x, float(acquisition(x[None])[0])
    # every polished start is too close to a sample: best raw point that is far and feasible
    for i in order:
        u = U[i]
        if cheap and not cheap_ok(u):
            u = _project(u, cheap)
            if not cheap_ok(u):
                continue
        if far(u):
            x = lo + u * span
            return x, float(acquisition(x[None])[0])
    raise RuntimeError("no admissible candidate: every start is infeasible or already sampled")


# ------------------------------------------------------------------- evaluation
def evaluate_design(problem: Any, x: np.ndarray, timeout: float | None = None,
                    eq_tol: float = 1e-4) -> dict:
    """Evaluate one design with a pymoo Problem; never raises (module level: picklable).

    Parameters
    ----------
    problem : pymoo Problem
    x : ndarray of shape (d,)
    timeout : float or None
        Seconds; the evaluation runs in a daemon thread of the evaluating process and is
        abandoned (status ``"timeout"``) when it takes longer. The time limit thus counts
        from the start of the evaluation, not from its submission to a busy executor.
    eq_tol : float
        Tolerance turning equality constraints ``H = 0`` into ``|H| - eq_tol <= 0``.

    Returns
    -------
    dict
        ``F`` (m,), ``G`` (k,) (inequalities ``G <= 0``, then ``|H| - eq_tol`` for
        equalities), ``status`` (``"ok"``, ``"error"``, ``"invalid"``, ``"timeout"``),
        ``message``, ``seconds``.
    """
    m = int(problem.n_obj)
    k = int(problem.n_ieq_constr) + int(problem.n_eq_constr)
    t0 = time.perf_counter()
    box: dict[str, Any] = {}

    def work() -> None:
        try:
            box["out"] = problem.evaluate(np.asarray(x, dtype=float)[None, :],
                                          return_as_dictionary=True)
        except Exception as exc:  # any failure of the user's model is recorded, not raised
            box["error"] = f"{type(exc).__name__}: {exc}"

    if timeout is None:
        work()
    else:
        thread = threading.Thread(target=work, daemon=True)
        thread.start()
        thread.join(timeout)
        if thread.is_alive():
            return {"F": np.full(m, np.nan), "G": np.full(k, np.nan), "status": "timeout",
                    "message": f"exceeded {timeout} s", "seconds": time.perf_counter() - t0}
    seconds = time.perf_counter() - t0
    if "error" in box:
        return {"F": np.full(m, np.nan), "G": np.full(k, np.nan), "status": "error",
                "message": box["error"], "seconds": seconds}
    out = box["out"]
    try:
        F = np.asarray(out["F"], dtype=float).reshape(-1)
        parts = []
        if problem.n_ieq_constr:
            parts.append(np.asarray(out["G"], dtype=float).reshape(-1))
        if problem.n_eq_constr:
            parts.append(np.abs(np.asarray(out["H"], dtype=float).reshape(-1)) - eq_tol)
        G = np.concatenate(parts) if parts else np.zeros(0)
    except (KeyError, TypeError, ValueError) as exc:
        return {"F": np.full(m, np.nan), "G": np.full(k, np.nan), "status": "error",
                "message": f"{type(exc).__name__}: {exc}", "seconds": seconds}
    if F.shape != (m,) or G.shape != (k,):
        return {"F": np.full(m, np.nan), "G": np.full(k, np.nan), "status": "error",
                "message": f"expected {m} objectives and {k} constraints, got "
                           f"{F.size} and {G.size}", "seconds": seconds}
    if not (np.all(np.isfinite(F)) and np.all(np.isfinite(G))):
        return {"F": F, "G": G, "status": "invalid", "message": "non-finite objective or "
                "constraint", "seconds": seconds}
    return {"F": F, "G": G, "status": STATUS_OK, "message": "", "seconds": seconds}


# ---------------------------------------------------------------------- results
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

    @property
    def X(self) -> np.ndarray:
        return self.data[[f"x{i}" for i in range(self.n_var)]].to_numpy(float)

    @property
    def F(self) -> np.ndarray:
        return self.data[[f"f{i}" for i in range(self.n_obj)]].to_numpy(float)

    @property
    def G(self) -> np.ndarray:
        cols = [c for c in self.data.columns if c.startswith("g") and c[1:].isdigit()]
        return self.data[cols].to_numpy(float).reshape(len(self.data), len(cols))

    @property
    def ok(self) -> np.ndarray:
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

    def pareto_set(self) -> np.ndarray:
        """Designs of the Pareto set, shape (k, d)."""
        return self.X[self.pareto_mask()]

    def pareto_front(self) -> np.ndarray:
        """Objectives of the Pareto set, shape (k, m), sorted by the first objective."""
        return pareto_front(self.F[self.pareto_mask()])

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


# --------------------------------------------------------------------- optimizer
class _PolishDone(Exception):
    """The polish budget is spent."""


@dataclass
class AcquisitionContext:
    """What an acquisition factory may use besides the objective model."""

    best_f: float
    pareto_front: np.ndarray
    ref_point: np.ndarray | None
    ideal: np.ndarray
    scale: np.ndarray
    rng: np.random.Generator


AcquisitionFactory = Callable[[Any, AcquisitionContext], Acquisition]


class BayesianOptimizer:
    """Surrogate-based (Bayesian) optimization of a pymoo Problem, Sec. 6.3.

    Parameters
    ----------
    problem : pymoo.core.problem.Problem
        Objectives minimized, constraints ``G <= 0`` (equalities ``H`` become
        ``|H| - eq_tol <= 0``); finite bounds ``xl``, ``xu``.
    acquisition : str or callable
        ``"lcb"``, ``"ei"``, ``"poi"`` (one objective); ``"hvlcb"``, ``"hvei"``, ``"hvpoi"``
        (indirect), ``"ws"`` (``g = 1``), ``"cheb"`` (``g = inf``), ``"wm"`` (``g``)
        (direct); or ``factory(model, context) -> Acquisition``. ``None``: ``"lcb"`` or
        ``"hvlcb"``.
    n_init : int
        Initial OLH samples (iteration 0).
    n_iter : int
        BO iterations (each proposes ``batch_size`` designs).
    batch_size : int
        ``q`` designs per iteration.
    batch_strategy : {"believer", "liar"}
        Kriging believer or constant liar (best value so far) fantasies within a batch.
    v : float or None
        Exploration weight: LCB and direct approach 2.0, HVLCB :data:`HVLCB_V`, EI 0.
    ref_point : array-like of shape (m,) or None
        Hypervolume reference point; ``None``: nadir of the Pareto set + 10 % of its range.
    weights : array-like of shape (m,) or None
        ``c`` of Eq. (6.11) for the direct approach (default equal).
    g : float
        Exponent of the weighted metric for ``"wm"``.
    cheap_constraints : sequence of CheapConstraint
    p_feasible : float
        Required predicted probability of feasibility of each expensive constraint.
    kernel : {"matern52", "rbf"}
    n_restarts : int
        Restarts of each surrogate's likelihood optimization.
    n_raw, n_starts : int
        Raw OLH points and SLSQP starts of the inner optimization.
    min_distance : float
        Unit-box distance below which a candidate duplicates a sample.
    executor : object or None
        ``submit(fn, *args)`` -> future with ``.result(timeout)``; ``None`` evaluates
        in-process.
    timeout : float or None
        Seconds per evaluation, counted from its start in the evaluating process (see
        :func:`evaluate_design`: the late evaluation is abandoned, status ``"timeout"``).
    store : str, Path, EvaluationStore or None
        SQLite store; an existing one is resumed.
    initial_samples : tuple (X, F) or (X, F, G), or None
        Earlier evaluations to recycle (Sec. 9.2.4), stored as iteration -1.
    seed : int
    max_evaluations : int or None
        Stop after this many evaluations in the store (a budget).
    convergence_tol : float or None
        Stop when the best value (one objective) or hypervolume improved by less than this
        (relative) over the last ``convergence_window`` iterations.
    convergence_window : int
    callback : callable or None
        ``callback(evaluation)`` after each committed evaluation; an exception stops the run
        (the store keeps everything committed).
    blas_threads : int or None
        BLAS threads during proposals (surrogate matrices are small: threading only costs,
        and oversubscribes badly when evaluations run on the same cores); ``None`` leaves
        the setting alone.
    output_transform : {"none", "log"}
        ``"log"``: the surrogates model ``ln F`` (objectives must be positive, e.g. the
        relative errors J of Eq. 6.4) and the acquisition works in that space. An objective
        whose good values are orders of magnitude below its typical ones (a narrow valley of
        J ~ 1e-2 in a landscape of J ~ 1) is resolved far better; the transform is monotone,
        so best points and Pareto dominance are unchanged.
    coordinates : LogLinearCoordinates or None
        Input coordinates of the surrogates (all bounds must be positive); ``None``: the
        design variables themselves (scaled to the unit box).
    polish : int
        Evaluations of a final local search (one objective only): Nelder-Mead from the best
        feasible design, in :attr:`coordinates` (or the unit box), each point clipped to
        the bounds and projected onto the cheap constraints, failures ranked last. A
        stationary kriging model spends its budget exploring when the optimum is a valley
        far narrower than the landscape (Sec. 9.1: ``lambda_F`` must match to ~1 % in a
        box spanning a factor 800); the polish converges on the valley floor. Stored as
        iteration ``n_iter + 1`` and replayed on resume.
    polish_step : float
        Initial simplex edge, as a fraction of each coordinate's range.
    """

    def __init__(
        self,
        problem: Any,
        *,
        acquisition: str | AcquisitionFactory | None = None,
        n_init: int = 10,
        n_iter: int = 40,
        batch_size: int = 1,
        batch_strategy: Literal["believer", "liar"] = "believer",
        v: float | None = None,
        ref_point: Sequence[float] | None = None,
        weights: Sequence[float] | None = None,
        g: float = 2.0,
        cheap_constraints: Sequence[CheapConstraint] = (),
        p_feasible: float = 0.5,
        kernel: str = "matern52",
        n_restarts: int = 2,
        n_raw: int = 256,
        n_starts: int = 5,
        min_distance: float = 1e-5,
        executor: Any = None,
        timeout: float | None = None,
        store: str | Path | EvaluationStore | None = None,
        initial_samples: tuple[np.ndarray, ...] | None = None,
        seed: int = 0,
        max_evaluations: int | None = None,
        convergence_tol: float | None = None,
        convergence_window: int = 5,
        callback: Callable[[Evaluation], None] | None = None,
        blas_threads: int | None = 1,
        output_transform: Literal["none", "log"] = "none",
        coordinates: LogLinearCoordinates | None = None,
        polish: int = 0,
        polish_step: float = 0.01,
    ) -> None:
        if output_transform not in OUTPUT_TRANSFORMS:
            raise ValueError(f"output_transform must be one of {OUTPUT_TRANSFORMS}, "
                             f"got {output_transform!r}")
        self.output_transform = output_transform
        self.problem = problem
        self.n_var = int(problem.n_var)
        self.n_obj = int(problem.n_obj)
        self.n_constr = int(problem.n_ieq_constr) + int(problem.n_eq_constr)
        self.bounds = np.c_[np.asarray(problem.xl, float), np.asarray(problem.xu, float)]
        if self.bounds.shape != (self.n_var, 2) or not np.all(np.isfinite(self.bounds)):
            raise ValueError("problem needs finite bounds xl, xu of length n_var")
        if coordinates is not None:
            if coordinates.matrix.shape != (self.n_var, self.n_var):
                raise ValueError(f"coordinates need a {self.n_var} x {self.n_var} matrix, got "
                                 f"{coordinates.matrix.shape}")
            if not np.all(self.bounds > 0.0):
                raise ValueError("log-linear coordinates need positive bounds xl, xu")
        self.coordinates = coordinates
        if polish < 0 or not 0.0 < polish_step <= 0.5:
            raise ValueError("polish >= 0 and 0 < polish_step <= 0.5 required")
        if polish and self.n_obj != 1:
            raise ValueError("polish needs a single objective")
        self.polish = int(polish)
        self.polish_step = float(polish_step)
        if acquisition is None:
            acquisition = "lcb" if self.n_obj == 1 else "hvlcb"
        if isinstance(acquisition, str):
            valid = (SINGLE_OBJECTIVE_ACQUISITIONS if self.n_obj == 1
                     else MULTI_OBJECTIVE_ACQUISITIONS)
            if acquisition not in valid:
                raise ValueError(f"acquisition for {self.n_obj} objective(s) must be one of "
                                 f"{valid}, got {acquisition!r}")
        if batch_strategy not in ("believer", "liar"):
            raise ValueError(f"batch_strategy must be 'believer' or 'liar', got {batch_strategy!r}")
        if batch_size < 1 or n_init < 0 or n_iter < 0:
            raise ValueError("batch_size >= 1, n_init >= 0 and n_iter >= 0 required")
        self.acquisition = acquisition
        self.n_init = int(n_init)
        self.n_iter = int(n_iter)
        self.batch_size = int(batch_size)
        self.batch_strategy = batch_strategy
        self.v = v
        self.ref_point = None if ref_point is None else np.asarray(ref_point, dtype=float)
        self.weights = (np.full(self.n_obj, 1.0 / self.n_obj) if weights is None
                        else np.asarray(weights, dtype=float))
        self.g = float(g)
        self.cheap_constraints = tuple(cheap_constraints)
        self.p_feasible = float(p_feasible)
        self.kernel = kernel
        self.n_restarts = int(n_restarts)
        self.n_raw = int(n_raw)
        self.n_starts = int(n_starts)
        self.min_distance = float(min_distance)
        self.executor = executor
        self.timeout = timeout
        self.store = store
        self.initial_samples = initial_samples
        self.seed = int(seed)
        self.max_evaluations = max_evaluations
        self.convergence_tol = convergence_tol
        self.convergence_window = int(convergence_window)
        self.callback = callback
        self.blas_threads = blas_threads

    # -------------------------------------------------------------- helpers
    def _rng(self, iteration: int) -> np.random.Generator:
        """Random numbers of one iteration, from ``(seed, iteration)`` (resume-safe)."""
        return np.random.default_rng([self.seed, iteration + 1])

    def _arrays(self, records: list[Evaluation]):
        n = len(records)
        X = np.array([r.x for r in records], dtype=float).reshape(n, self.n_var)
        F = np.array([r.F for r in records], dtype=float).reshape(n, self.n_obj)
        G = np.array([r.G for r in records], dtype=float).reshape(n, self.n_constr)
        ok = np.array([r.ok for r in records], dtype=bool)
        feas = ok & np.all(G <= 0.0, axis=1)
        return X, F, G, ok, feas

    def initial_design(self) -> np.ndarray:
        """The iteration-0 OLH design (projected onto the cheap constraints)."""
        X = latin_hypercube(self.n_init, self.bounds, self._rng(0))
        if self.cheap_constraints and len(X):
            lo, span = self.bounds[:, 0], self.bounds[:, 1] - self.bounds[:, 0]
            cons = _scipy_cheap(self.cheap_constraints, lo, span)
            X = np.array([lo + _project((x - lo) / span, cons) * span for x in X])
        return X

    def _fit(self, X: np.ndarray, Y: np.ndarray, rng: np.random.Generator, **kw: Any):
        """A surrogate of ``Y(X)`` in the optimizer's input coordinates, queried in ``x``."""
        if self.coordinates is None:
            return fit_surrogate(X, Y, self.bounds, kernel=self.kernel,
                                 n_restarts=self.n_restarts, rng=rng, **kw)
        gp = fit_surrogate(self.coordinates(X), Y, self.coordinates.box(self.bounds),
                           kernel=self.kernel, n_restarts=self.n_restarts, rng=rng, **kw)
        return _WarpedModel(gp, self.coordinates)

    def _model_space(self, F: np.ndarray) -> np.ndarray:
        """Objective values as the surrogates see them (:attr:`output_transform`)."""
        if self.output_transform == "log":
            with np.errstate(invalid="ignore"):
                return np.log(np.maximum(F, LOG_FLOOR))
        return F

    def _reference_point(self, F_feas: np.ndarray) -> np.ndarray | None:
        if self.ref_point is not None:
            return self._model_space(self.ref_point)
        if len(F_feas) == 0:
            return None
        P = pareto_front(F_feas)
        ideal, nadir = P.min(axis=0), P.max(axis=0)
        return nadir + 0.1 * np.where(nadir > ideal, nadir - ideal, np.maximum(abs(nadir), 1.0))

    def _build_acquisition(self, model, F_obs: np.ndarray, feas: np.ndarray, F_ok: np.ndarray,
                           rng: np.random.Generator) -> Acquisition:
        F_feas = F_obs[feas]
        base = F_feas if len(F_feas) else F_ok
        best_f = float(base[:, 0].min()) if len(base) else 0.0
        ideal = base.min(axis=0) if len(base) else np.zeros(self.n_obj)
        nadir = base.max(axis=0) if len(base) else np.ones(self.n_obj)
        scale = np.where(nadir > ideal, nadir - ideal, 1.0)
        ref = self._reference_point(base)
        front = pareto_front(F_feas) if len(F_feas) else np.zeros((0, self.n_obj))
        if ref is None:
            ref = nadir + scale
        ctx = AcquisitionContext(best_f, front, ref, ideal, scale, rng)
        name = self.acquisition
        if callable(name):
            return name(model, ctx)
        v = self.v
        if name == "lcb":
            return LowerConfidenceBound(model, v=2.0 if v is None else v)
        if name == "ei":
            return ExpectedImprovement(model, best_f, v=0.0 if v is None else v)
        if name == "poi":
            return ProbabilityOfImprovement(model, best_f)
        if name == "hvlcb":
            return HypervolumeLCB(model, front, ref, v=HVLCB_V if v is None else v)
        if name == "hvei":
            return HypervolumeEI(model, front, ref, rng=rng)
        if name == "hvpoi":
            return HypervolumePoI(model, front, ref)
        g = {"ws": 1.0, "cheb": math.inf}.get(name, self.g)
        return WeightedMetricLCB(model, self.weights, g=g, v=2.0 if v is None else v,
                                 ideal=ideal, scale=scale)

    # ------------------------------------------------------------ proposal
    def propose(self, records: list[Evaluation], iteration: int) -> np.ndarray:
        """The ``batch_size`` designs of one iteration from the evaluations so far.

        Parameters
        ----------
        records : list of Evaluation
            Every evaluation of earlier iterations.
        iteration : int
            ``t >= 1`` (seeds the iteration's random numbers).

        Returns
        -------
        ndarray of shape (batch_size, d)
        """
        rng = self._rng(iteration)
        X, F, G, ok, feas = self._arrays(records)
        F = self._model_space(F)
        if ok.sum() < 2:
            # nothing to model: explore with an OLH point far from the samples
            U = latin_hypercube(self.batch_size, self.bounds, rng)
            return U
        model = self._fit(X[ok], F[ok], rng)
        model_constraints: list[ProbabilisticConstraint] = []
        if self.n_constr:
            gm = self._fit(X[ok], G[ok], rng)
            model_constraints.append(ProbabilisticConstraint(gm, p_min=self.p_feasible))
        if not np.all(ok):
            fm = self._fit(X, (~ok).astype(float)[:, None], rng, nugget=FAILURE_NUGGET,
                           length_scale_bounds=FAILURE_LENGTH_SCALES)
            model_constraints.append(
                ProbabilisticConstraint(fm, p_min=0.5, threshold=FAILURE_THRESHOLD))
        # exploitation starts: the best feasible designs (nudged off the data points)
        F_good = np.where(feas[:, None], F, np.inf)
        if self.n_obj == 1:
            best_idx = np.argsort(F_good[:, 0])[:3]
        else:
            idx = np.flatnonzero(feas)
            best_idx = idx[non_dominated_mask(F[idx])] if len(idx) else idx
            best_idx = best_idx[rng.permutation(len(best_idx))[:5]]
        span = self.bounds[:, 1] - self.bounds[:, 0]
        X_obs, F_obs, feas_obs = X[ok], F[ok], feas[ok]
        pending: list[np.ndarray] = []
        cur_model = model
        for b in range(self.batch_size):
            acq = self._build_acquisition(cur_model, F_obs, feas_obs, F[ok], rng)
            extra = X[best_idx] + 1e-3 * span * rng.standard_normal((len(best_idx), self.n_var))
            X_avoid = np.vstack([X] + [p[None] for p in pending])
            try:
                x, _ = optimize_acquisition(
                    acq, self.bounds, n_raw=self.n_raw, n_starts=self.n_starts,
                    cheap_constraints=self.cheap_constraints,
                    model_constraints=model_constraints, X_avoid=X_avoid,
                    min_distance=self.min_distance, extra_starts=extra, rng=rng)
            except RuntimeError as exc:
                # every start infeasible or already sampled: fall back to a fresh OLH point
                warnings.warn(f"iteration {iteration}: {exc}; proposing a space-filling point",
                              RuntimeWarning, stacklevel=2)
                x = self._fallback_point(X_avoid, rng)
            pending.append(x)
            if b + 1 < self.batch_size:
                if self.batch_strategy == "believer":
                    y_f = cur_model.predict_moments(x[None])[0][0]
                else:
                    base = F_obs[feas_obs] if feas_obs.any() else F_obs
                    y_f = base.min(axis=0)
                X_obs = np.vstack([X_obs, x])
                F_obs = np.vstack([F_obs, y_f])
                feas_obs = np.r_[feas_obs, True]
                cur_model = model.condition(X_obs, F_obs)
        return np.array(pending)

    def _fallback_point(self, X_avoid: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """The OLH point farthest from the samples, projected onto the cheap constraints."""
        lo, span = self.bounds[:, 0], self.bounds[:, 1] - self.bounds[:, 0]
        U = raw_latin_hypercube(self.n_raw, np.c_[np.zeros(self.n_var), np.ones(self.n_var)], rng)
        U_avoid = (X_avoid - lo) / span
        dist = np.min(np.linalg.norm(U[:, None] - U_avoid[None], axis=2), axis=1)
        u = U[int(np.argmax(dist))]
        if self.cheap_constraints:
            u = _project(u, _scipy_cheap(self.cheap_constraints, lo, span))
        return lo + u * span

    # ----------------------------------------------------------- evaluation
    def _evaluate(self, X: np.ndarray, iteration: int, indices: Sequence[int],
                  store: EvaluationStore, records: list[Evaluation]) -> None:
        """Evaluate designs, committing each result (in batch order) before going on."""
        if self.executor is None:
            for x, i in zip(X, indices):
                self._record(x, evaluate_design(self.problem, x, self.timeout), iteration, i,
                             store, records)
            return
        futures = [(x, i, time.perf_counter(),
                    self.executor.submit(evaluate_design, self.problem, x, self.timeout))
                   for x, i in zip(X, indices)]
        for x, i, t_submit, fut in futures:
            try:
                res = fut.result()
            except Exception as exc:  # worker died, result not picklable, cancelled, ...
                res = {"F": np.full(self.n_obj, np.nan), "G": np.full(self.n_constr, np.nan),
                       "status": "error", "message": f"{type(exc).__name__}: {exc}",
                       "seconds": time.perf_counter() - t_submit}
            self._record(x, res, iteration, i, store, records)

    def _record(self, x, res, iteration, index, store, records) -> None:
        ev = Evaluation(x=np.asarray(x, float), F=np.asarray(res["F"], float),
                        G=np.asarray(res["G"], float), status=res["status"],
                        message=res["message"], seconds=float(res["seconds"]),
                        iteration=iteration, batch_index=index, seed=self.seed)
        store.append(ev)
        records.append(ev)
        if self.callback is not None:
            self.callback(ev)

    # ------------------------------------------------------------------ run
    def _open_store(self) -> tuple[EvaluationStore, bool]:
        if isinstance(self.store, EvaluationStore):
            return self.store, False
        return EvaluationStore(":memory:" if self.store is None else self.store), True

    def _budget_left(self, records: list[Evaluation]) -> int:
        if self.max_evaluations is None:
            return 1 << 60
        return self.max_evaluations - sum(r.iteration >= 0 for r in records)

    def _converged(self, records: list[Evaluation], iteration: int) -> bool:
        if self.convergence_tol is None or iteration <= self.convergence_window:
            return False
        X, F, G, ok, feas = self._arrays(records)
        it = np.array([r.iteration for r in records])
        before = it < iteration - self.convergence_window
        if self.n_obj == 1:
            now = F[feas, 0].min(initial=np.inf)
            old = F[feas & before, 0].min(initial=np.inf)
            if not np.isfinite(old):
                return False
            return abs(old - now) <= self.convergence_tol * max(abs(old), 1e-12)
        ref = self._reference_point(F[feas])
        if ref is None:
            return False
        now, old = hypervolume(F[feas], ref), hypervolume(F[feas & before], ref)
        return old > 0 and (now - old) <= self.convergence_tol * old

    def _polish(self, store: EvaluationStore, records: list[Evaluation]) -> None:
        """Final Nelder-Mead search from the best feasible design (see ``polish``)."""
        if self.polish <= 0:
            return
        t = self.n_iter + 1
        X, F, G, ok, feas = self._arrays([r for r in records if r.iteration < t])
        if not feas.any():
            return
        lo, hi = self.bounds[:, 0], self.bounds[:, 1]
        span = hi - lo
        x_best = X[feas][int(np.argmin(F[feas, 0]))]
        coords = self.coordinates
        if coords is None:  # the unit box
            z0, z_span = (x_best - lo) / span, np.ones(self.n_var)
        else:
            box = coords.box(self.bounds)
            z0, z_span = coords(x_best)[0], box[:, 1] - box[:, 0]
            A_inv = np.linalg.inv(coords.matrix)
        cons = _scipy_cheap(self.cheap_constraints, lo, span) if self.cheap_constraints else []
        stored = {r.batch_index: r for r in records if r.iteration == t}
        seen = {tuple(np.round(r.x, 12)): r for r in records if r.iteration < t}
        count = [0]

        def design(z: np.ndarray) -> np.ndarray:
            x = lo + z * span if coords is None else np.exp(A_inv @ z)
            x = np.clip(x, lo, hi)
            if cons:
                x = lo + _project((x - lo) / span, cons) * span
            return x

        def value(z: np.ndarray) -> float:
            x = design(z)
            ev = seen.get(tuple(np.round(x, 12)))
            if ev is None:
                k = count[0]
                if k >= self.polish or self._budget_left(records) <= 0:
                    raise _PolishDone
                if k in stored:
                    ev = stored[k]
                    if not np.allclose(ev.x, x, rtol=0, atol=1e-9):
                        warnings.warn("polish: resumed point differs from the stored one",
                                      RuntimeWarning, stacklevel=2)
                else:
                    self._evaluate(x[None], t, [k], store, records)
                    ev = records[-1]
                count[0] += 1
                seen[tuple(np.round(x, 12))] = ev
            good = ev.ok and np.all(np.asarray(ev.G) <= 0.0) and np.isfinite(ev.F[0])
            return float(ev.F[0]) if good else math.inf

        simplex = z0 + np.vstack([np.zeros(self.n_var), np.diag(self.polish_step * z_span)])
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                minimize(value, z0, method="Nelder-Mead",
                         options={"initial_simplex": simplex, "maxfev": 100 * self.polish,
                                  "xatol": 1e-9, "fatol": 0.0})
        except _PolishDone:
            pass

    def run(self) -> OptimizationResult:
        """Run (or resume) the optimization.

        Returns
        -------
        OptimizationResult
        """
        store, owned = self._open_store()
        try:
            return self._run(store)
        finally:
            if owned and self.store is not None:
                store.close()

    def _run(self, store: EvaluationStore) -> OptimizationResult:
        for key, val in (("seed", self.seed), ("n_var", self.n_var), ("n_obj", self.n_obj),
                         ("n_constr", self.n_constr), ("n_init", self.n_init),
                         ("batch_size", self.batch_size)):
            store.set_meta(key, val)
        records = store.load()
        done = {(r.iteration, r.batch_index) for r in records}
        if self.initial_samples is not None and not any(r.iteration == -1 for r in records):
            Xr, Fr = (np.atleast_2d(np.asarray(a, float)) for a in self.initial_samples[:2])
            Gr = (np.atleast_2d(np.asarray(self.initial_samples[2], float))
                  if len(self.initial_samples) > 2 else np.zeros((len(Xr), 0)))
            Fr = Fr.reshape(len(Xr), self.n_obj)
            Gr = Gr.reshape(len(Xr), self.n_constr)
            for i, (x, f, gg) in enumerate(zip(Xr, Fr, Gr)):
                finite = np.all(np.isfinite(f)) and np.all(np.isfinite(gg))
                status = STATUS_OK if finite else "invalid"
                self._record(x, {"F": f, "G": gg, "status": status, "message": "recycled",
                                 "seconds": 0.0}, -1, i, store, records)
        overhead: list[float] = []
        # iteration 0: initial design
        X0 = self.initial_design()
        todo = [i for i in range(len(X0)) if (0, i) not in done]
        todo = todo[: max(0, self._budget_left(records))]
        if todo:
            self._evaluate(X0[todo], 0, todo, store, records)
        for t in range(1, self.n_iter + 1):
            if all((t, i) in done for i in range(self.batch_size)):
                continue  # replayed from the store
            if self._budget_left(records) <= 0 or self._converged(records, t):
                break
            t0 = time.perf_counter()
            prior = [r for r in records if r.iteration < t]
            if self.blas_threads is None:
                Xb = self.propose(prior, t)
            else:
                with blas_threads(self.blas_threads):
                    Xb = self.propose(prior, t)
            overhead.append(time.perf_counter() - t0)
            todo = [i for i in range(self.batch_size) if (t, i) not in done]
            stored = {r.batch_index: r.x for r in records if r.iteration == t}
            for i, x in stored.items():
                if not np.allclose(x, Xb[i], rtol=0, atol=1e-9):
                    warnings.warn(f"iteration {t}: resumed proposal differs from the stored one",
                                  RuntimeWarning, stacklevel=2)
            todo = todo[: max(0, self._budget_left(records))]
            self._evaluate(Xb[todo], t, todo, store, records)
        self._polish(store, records)
        data = evaluations_to_dataframe(records) if records else evaluations_to_dataframe([])
        X, F, G, ok, feas = self._arrays(records)
        ref = self._reference_point(F[feas]) if self.n_obj > 1 else None
        return OptimizationResult(data=data, n_var=self.n_var, n_obj=self.n_obj, ref_point=ref,
                                  seconds_per_iteration=np.array(overhead))
