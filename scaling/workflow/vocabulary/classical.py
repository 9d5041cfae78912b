"""Left prong: classical scaling as a geometric program (cvxpy, ``gp=True``).

Classical similarity (Sec. 6.1) asks the model to reproduce a chosen subset of the
prototype's similarity parameters (Eqs. 6.1-6.3, 9.1). With the material properties frozen
at the reference temperatures, almost every parameter is a *monomial* of the positive
design variables (e.g. ``lambda_F = gamma p_inf M L^3 / D_xx`` with ``D_xx ~ h^3``), so

    minimize    prod_i t_i^{w_i}            (or max_i t_i)
    subject to  r_i(x) <= t_i,  1 / r_i(x) <= t_i,   r_i = Pi_i(x) / Pi_i^prototype
                lower_j <= x_j <= upper_j

is a geometric program: in log space a linear program whose optimum minimizes the weighted
sum (or the maximum) of ``|log r_i|``. When every requested parameter can be matched inside
the bounds the optimum has all ``t_i = 1`` and reproduces the analytical laws (Eq. 9.2);
otherwise it is the best compromise, with the residual mismatch of each parameter and the
active bounds reported (the analysis Table 9.8 shows for the refined designs).

The monomial of each parameter is not written by hand: it is the exact local power law of
:func:`hypate.scaling.workflow.vocabulary.similarity.similarity_parameters` around the current point
(exponents from central differences in log space, exact for monomials up to round-off). Parameters
that are not monomials of the chosen variables -- ``Re_0`` through Sutherland's viscosity, anything
through temperature-dependent properties or the isentropic relations in M -- are handled by
sequential geometric programming: re-fit the local monomials at the new point and solve
again, inside a log-space trust region that shrinks when the true mismatch does not
decrease. For pure monomials the first GP is already the exact answer.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import reduce
from typing import Any, Literal

import cvxpy as cp
import numpy as np
import pandas as pd
from hypate.scaling.workflow.vocabulary.configuration import Configuration, apply_design
from hypate.scaling.workflow.vocabulary.similarity import (
    compare,
    comparison_records,
    parameter_names,
    similarity_parameters,
)
from hypate.solvers.errors import InputError

__all__ = [
    "ActiveBound",
    "ClassicalResult",
    "classical_scaling",
    "classical_records",
    "design_vector",
    "similarity_exponents",
    "similarity_basis",
]

Bounds = tuple[float, float]

#: Log-space step of the central differences that fit the local monomials.
_LOG_STEP = 1e-4


@dataclass(frozen=True)
class ActiveBound:
    """A design variable at one of its bounds."""

    name: str
    side: Literal["lower", "upper"]
    value: float

    def describe(self) -> str:
        return f"{self.name} at {self.side} bound {self.value:g}"

    def as_record(self) -> dict[str, Any]:
        return {"name": self.name, "bound": self.side, "value": self.value}


@dataclass(frozen=True)
class ClassicalResult:
    """Best classical design (the left prong).

    Attributes
    ----------
    design : dict
        ``{variable: value}`` (SI), in the order of the bounds given.
    targets : dict
        Prototype values of the matched parameters.
    achieved : dict
        Model values of the matched parameters at ``design``.
    residuals : dict
        Relative mismatch ``achieved / target - 1`` of each matched parameter (for a
        parameter that is zero for the prototype, e.g. ``lambda_ext`` without external
        pressure, the model's absolute value; such parameters stay out of the GP).
    active_bounds : tuple of ActiveBound
        Variables at a bound (within the active tolerance, relative).
    objective : float
        ``sum_i w_i |log r_i|`` (``"product"``) or ``max_i |log r_i|`` (``"max"``).
    status : str
        ``"optimal"`` (converged), ``"max_iterations"``, or the cvxpy status of a failed
        subproblem.
    iterations : int
        Geometric programs solved.
    model : Configuration
        The model configuration at ``design``.
    bounds : dict
        The bounds used, ``{variable: (lower, upper)}``.
    """

    design: dict[str, float]
    targets: dict[str, float]
    achieved: dict[str, float]
    residuals: dict[str, float]
    active_bounds: tuple[ActiveBound, ...]
    objective: float
    status: str
    iterations: int
    model: Configuration = field(repr=False)
    bounds: dict[str, Bounds] = field(default_factory=dict)

    @property
    def matched(self) -> bool:
        """All requested parameters reproduced within 1e-6 (relative)."""
        return all(abs(r) <= 1e-6 for r in self.residuals.values())

    def active_constraints(self) -> list[str]:
        """Active bounds as strings (``"p_inf at upper bound 8000"``)."""
        return [b.describe() for b in self.active_bounds]

    def point(self, names: Sequence[str], *, defaults: Mapping[str, float] | None = None,
              bounds: Mapping[str, Bounds] | np.ndarray | None = None) -> np.ndarray:
        """The design as a point in an optimizer's variable order; see :func:`design_vector`."""
        return design_vector(self.design, names, defaults=defaults, bounds=bounds)

    def similarity_table(self, prototype: Configuration,
                         names: Sequence[str] | None = None) -> pd.DataFrame:
        """:func:`hypate.scaling.workflow.vocabulary.similarity.compare` of the prototype and this
        design."""
        return compare(prototype, self.model, names)

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe summary (design, residuals, active bounds, status)."""
        return {"design": dict(self.design), "targets": dict(self.targets),
                "achieved": dict(self.achieved), "residuals": dict(self.residuals),
                "active_constraints": [b.as_record() for b in self.active_bounds],
                "objective": self.objective, "status": self.status,
                "iterations": self.iterations}


def design_vector(design: Mapping[str, float], names: Sequence[str], *,
                  defaults: Mapping[str, float] | None = None,
                  bounds: Mapping[str, Bounds] | np.ndarray | None = None) -> np.ndarray:
    """A design ``{name: value}`` as a point in a given variable order (e.g. to seed the
    Bayesian optimization's initial sample).

    Parameters
    ----------
    design : mapping
    names : sequence of str
        The optimizer's variable order.
    defaults : mapping, optional
        Values for names the design does not set.
    bounds : mapping or ndarray of shape (n, 2), optional
        Optimizer bounds; the point is clipped into them.

    Returns
    -------
    ndarray of shape (len(names),)

    Raises
    ------
    InputError
        A name neither in ``design`` nor in ``defaults``.
    """
    defaults = defaults or {}
    x = np.empty(len(names))
    for i, name in enumerate(names):
        if name in design:
            x[i] = design[name]
        elif name in defaults:
            x[i] = defaults[name]
        else:
            raise InputError(f"design.{name}", "not set by the classical design; give a "
                             "default value for it")
    if bounds is not None:
        if isinstance(bounds, Mapping):
            lo = np.array([bounds[n][0] if n in bounds else -np.inf for n in names])
            hi = np.array([bounds[n][1] if n in bounds else np.inf for n in names])
        else:
            b = np.asarray(bounds, dtype=float)
            lo, hi = b[:, 0], b[:, 1]
        x = np.clip(x, lo, hi)
    return x


def _check_bounds(bounds: Mapping[str, Bounds]) -> dict[str, Bounds]:
    out: dict[str, Bounds] = {}
    if not bounds:
        raise InputError("bounds", "give at least one design variable with bounds")
    for name, pair in bounds.items():
        try:
            lo, hi = (float(v) for v in pair)
        except (TypeError, ValueError):
            raise InputError(f"bounds.{name}", f"must be a pair [lower, upper]; got {pair!r}") \
                from None
        if not (math.isfinite(lo) and math.isfinite(hi) and lo > 0.0):
            raise InputError(f"bounds.{name}", "a geometric program needs finite, positive "
                             f"bounds; got [{lo:g}, {hi:g}]")
        if lo > hi:
            raise InputError(f"bounds.{name}", f"reversed bounds: lower {lo:g} exceeds upper "
                             f"{hi:g}")
        out[name] = (lo, hi)
    return out


def _weights(match: Sequence[str] | Mapping[str, float]) -> dict[str, float]:
    if isinstance(match, Mapping):
        w = {str(k): float(v) for k, v in match.items()}
    else:
        w = {str(k): 1.0 for k in match}
    if not w:
        raise InputError("match", "give at least one similarity parameter to match")
    parameter_names(list(w))
    for k, v in w.items():
        if not (math.isfinite(v) and v > 0.0):
            raise InputError(f"match.{k}", f"weight must be > 0; got {v:g}")
    return w


class _Evaluator:
    """log of the matched parameters as a function of log design variables."""

    def __init__(self, template: Configuration, variables: list[str], names: list[str]):
        self.template = template
        self.variables = variables
        self.names = names

    def config(self, u: np.ndarray) -> Configuration:
        return apply_design(self.template, dict(zip(self.variables, np.exp(u).tolist())))

    def values(self, u: np.ndarray) -> dict[str, float]:
        return similarity_parameters(self.config(u), names=self.names)

    def log_values(self, u: np.ndarray) -> np.ndarray:
        vals = self.values(u)
        out = np.empty(len(self.names))
        for i, name in enumerate(self.names):
            v = vals[name]
            if not v > 0.0:
                raise InputError(f"match.{name}", f"value {v:g} of the model is not positive; "
                                 "a geometric program can only match positive parameters")
            out[i] = math.log(v)
        return out

    def linearize(self, u: np.ndarray, free: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """log values at ``u`` and the exponents d log(Pi)/d log(x) of the free variables."""
        f0 = self.log_values(u)
        J = np.zeros((len(self.names), u.size))
        for j in np.flatnonzero(free):
            e = np.zeros(u.size)
            e[j] = _LOG_STEP
            J[:, j] = (self.log_values(u + e) - self.log_values(u - e)) / (2.0 * _LOG_STEP)
        return f0, J


def _mismatch(e: np.ndarray, w: np.ndarray, objective: str) -> float:
    return float(np.sum(w * np.abs(e))) if objective == "product" else float(np.max(np.abs(e)))


def _solve_gp(e0: np.ndarray, J: np.ndarray, w: np.ndarray, free: np.ndarray,
              log_lo: np.ndarray, log_hi: np.ndarray, radius: float, objective: str,
              solver: str | None) -> tuple[np.ndarray | None, str]:
    """One geometric program in the normalized variables ``y = x / x_k``.

    ``r_i(y) = exp(e0_i) prod_j y_j^J_ij`` is the local monomial of the ratio model/target.
    Returns the optimal log step (zeros for fixed variables) and the cvxpy status.
    """
    idx = np.flatnonzero(free)
    y = cp.Variable(idx.size, pos=True)
    t = cp.Variable(e0.size, pos=True)
    cons = []
    for i in range(e0.size):
        terms = [y[k] ** float(J[i, j]) for k, j in enumerate(idx) if J[i, j] != 0.0]
        mono = reduce(lambda a, b: a * b, terms, math.exp(float(e0[i])))
        if isinstance(mono, float):
            # Constant ratio: t_i >= max(r, 1/r) directly.
            cons.append(t[i] >= math.exp(abs(float(e0[i]))))
        else:
            cons += [mono <= t[i], 1.0 / mono <= t[i]]
    lo = np.maximum(log_lo[idx], -radius)
    hi = np.minimum(log_hi[idx], radius)
    cons += [y >= np.exp(lo), y <= np.exp(hi)]
    if objective == "product":
        obj = reduce(lambda a, b: a * b, [t[i] ** float(w[i]) for i in range(e0.size)])
    else:
        obj = cp.maximum(*[t[i] for i in range(e0.size)]) if e0.size > 1 else t[0]
    prob = cp.Problem(cp.Minimize(obj), cons)
    try:
        prob.solve(gp=True, solver=solver)
        if objective == "max" and prob.status in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
            # Minimax optima are not unique: among them take the one with the least weighted
            # sum of log mismatches (lexicographic second stage).
            cap = float(prob.value) * (1.0 + 1e-9)
            second = reduce(lambda a, b: a * b, [t[i] ** float(w[i]) for i in range(e0.size)])
            prob = cp.Problem(cp.Minimize(second), cons + [t <= cap])
            prob.solve(gp=True, solver=solver)
    except cp.SolverError as exc:
        return None, f"solver_error: {exc}"
    if prob.status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE) or y.value is None:
        return None, str(prob.status)
    step = np.zeros(free.size)
    step[idx] = np.clip(np.log(np.asarray(y.value, dtype=float)), lo, hi)
    return step, str(prob.status)


def _snap_to_bounds(u: np.ndarray, log_lo: np.ndarray, log_hi: np.ndarray, tol: float,
                    mismatch: Any) -> np.ndarray:
    """Move variables within ``tol`` (log) of a bound onto it when that does not increase
    the true mismatch by more than the solver accuracy (the GP solution is only accurate
    to the solver tolerance, so a variable meant to sit on a bound ends a hair inside)."""
    near_lo = np.abs(u - log_lo) <= tol
    near_hi = np.abs(u - log_hi) <= tol
    if not np.any(near_lo | near_hi):
        return u
    snapped = np.where(near_lo, log_lo, np.where(near_hi, log_hi, u))
    before = mismatch(u)
    # Accept a change of the order of the GP solver's accuracy (1e-8 in log units).
    return snapped if mismatch(snapped) <= before + 1e-8 * max(1.0, before) else u


def classical_scaling(prototype: Configuration, model_template: Configuration,
                      bounds: Mapping[str, Bounds],
                      match: Sequence[str] | Mapping[str, float], *,
                      objective: Literal["product", "max"] = "product",
                      initial: Mapping[str, float] | None = None,
                      max_iterations: int = 30, tolerance: float = 1e-10,
                      active_tolerance: float = 1e-6,
                      solver: str | None = None) -> ClassicalResult:
    """Classical scaling as a geometric program: match a subset of similarity parameters as
    closely as possible within bounds.

    Parameters
    ----------
    prototype : Configuration
        Full-scale article; its parameters are the targets.
    model_template : Configuration
        Model layup, aspect ratio, Mach number and every value that is not a design
        variable (see :func:`hypate.scaling.workflow.vocabulary.configuration.apply_design`).
    bounds : mapping
        ``{variable: (lower, upper)}``, positive, SI units; ``lower == upper`` fixes a
        variable. Names as in :data:`hypate.scaling.workflow.vocabulary.variables.DESIGN_VARIABLES`.
    match : sequence of str or mapping
        Parameters to match (names of
        :data:`hypate.scaling.workflow.vocabulary.similarity.PARAMETERS`), or ``{name: weight}``.
    objective : {"product", "max"}
        Minimize ``prod t_i^{w_i}`` (weighted sum of ``|log r_i|``) or ``max t_i``.
    initial : mapping, optional
        Starting point (default: the geometric mean of each bound pair). It matters only
        for non-monomial parameters (sequential GP) and for ties.
    max_iterations : int
        Geometric programs solved at most.
    tolerance : float
        Stop when the local GP cannot lower the log-mismatch by more than
        ``tolerance * max(1, current)``.
    active_tolerance : float
        A variable is at a bound when ``|log(x / bound)| <= active_tolerance``.
    solver : str, optional
        cvxpy solver name (default: cvxpy's choice).

    Returns
    -------
    ClassicalResult

    Raises
    ------
    InputError
        Bad bounds, unknown variables or parameters, or a target that is not positive.
    """
    if objective not in ("product", "max"):
        raise InputError("objective", f"must be 'product' or 'max'; got {objective!r}")
    box = _check_bounds(bounds)
    weights = _weights(match)
    variables = list(box)
    apply_design(model_template, {n: math.sqrt(lo * hi) for n, (lo, hi) in box.items()})

    targets_all = similarity_parameters(prototype, names=list(weights))
    # Parameters that are zero for the prototype can only be matched by being zero: they are
    # kept out of the GP and reported with their residual.
    names = [n for n in weights if targets_all[n] != 0.0]
    for n in names:
        if targets_all[n] < 0.0:
            raise InputError(f"match.{n}", f"prototype value {targets_all[n]:g} is negative; a "
                             "geometric program can only match positive parameters")
    w = np.array([weights[n] for n in names])
    log_target = np.log([targets_all[n] for n in names])
    log_lo = np.log([box[n][0] for n in variables])
    log_hi = np.log([box[n][1] for n in variables])
    free = log_hi > log_lo
    u = 0.5 * (log_lo + log_hi)
    for i, n in enumerate(variables):
        if initial is not None and n in initial:
            u[i] = float(np.clip(math.log(float(initial[n])), log_lo[i], log_hi[i]))

    ev = _Evaluator(model_template, variables, names)
    status = "optimal"
    iterations = 0
    if names and np.any(free):
        radius = math.inf
        status = "max_iterations"
        for _ in range(max_iterations):
            f0, J = ev.linearize(u, free)
            e0 = f0 - log_target
            current = _mismatch(e0, w, objective)
            step, gp_status = _solve_gp(e0, J, w, free, log_lo - u, log_hi - u, radius,
                                        objective, solver)
            iterations += 1
            if step is None:
                status = gp_status
                break
            predicted = _mismatch(e0 + J @ step, w, objective)
            if current - predicted <= tolerance * max(1.0, current):
                status = "optimal"
                break
            u_new = np.clip(u + step, log_lo, log_hi)
            new = _mismatch(ev.log_values(u_new) - log_target, w, objective)
            if new < current:
                u = u_new
                if math.isfinite(radius):
                    radius = min(4.0 * radius, 50.0)
            else:
                radius = 0.25 * float(np.max(np.abs(step)))
                if radius < 1e-12:
                    status = "optimal"
                    break

    if names and np.any(free):
        u = _snap_to_bounds(u, log_lo, log_hi, active_tolerance,
                            lambda v: _mismatch(ev.log_values(v) - log_target, w, objective))
    x = np.exp(u)
    design = {n: (box[n][0] if u[i] == log_lo[i] else box[n][1] if u[i] == log_hi[i]
                  else float(x[i])) for i, n in enumerate(variables)}
    model = apply_design(model_template, design)
    achieved = similarity_parameters(model, names=list(weights))
    residuals = {}
    for n in weights:
        tgt = targets_all[n]
        residuals[n] = (achieved[n] / tgt - 1.0) if tgt != 0.0 else achieved[n]
    logs = np.array([math.log(achieved[n] / targets_all[n]) for n in names])
    final = _mismatch(logs, w, objective) if names else 0.0
    active = []
    for i, n in enumerate(variables):
        if not free[i]:
            continue
        if abs(u[i] - log_lo[i]) <= active_tolerance:
            active.append(ActiveBound(n, "lower", box[n][0]))
        elif abs(u[i] - log_hi[i]) <= active_tolerance:
            active.append(ActiveBound(n, "upper", box[n][1]))
    return ClassicalResult(design=design, targets={n: targets_all[n] for n in weights},
                           achieved=achieved, residuals=residuals,
                           active_bounds=tuple(active), objective=final, status=status,
                           iterations=iterations, model=model, bounds=box)


def similarity_exponents(model_template: Configuration, design: Mapping[str, float],
                         variables: Sequence[str], names: Sequence[str]) -> np.ndarray:
    """Local power-law exponents ``d ln Pi_i / d ln x_j`` of similarity parameters.

    Exact for monomials (Eqs. 6.1-6.3, 9.1a: e.g. ``lambda_F ~ p_inf h^-3``), a local fit
    otherwise (central differences in log space, as the geometric program uses).

    Parameters
    ----------
    model_template : Configuration
    design : mapping
        Every design value at which to linearize (variables and fixed values), positive.
    variables : sequence of str
        The columns (a subset of ``design``).
    names : sequence of str
        The rows (parameter names); each must be positive at ``design``.

    Returns
    -------
    ndarray of shape (len(names), len(variables))
    """
    keys = list(design)
    missing = [v for v in variables if v not in design]
    if missing:
        raise InputError("variables", f"no value for {', '.join(missing)}")
    u = np.log([float(design[k]) for k in keys])
    free = np.array([k in variables for k in keys])
    _, J = _Evaluator(model_template, keys, list(names)).linearize(u, free)
    return J[:, [keys.index(v) for v in variables]]


def similarity_basis(exponents: np.ndarray, tol: float = 1e-8) -> np.ndarray:
    """An invertible ``d x d`` matrix whose leading rows are independent parameter exponents.

    Rows of ``exponents`` that add a new direction are kept in order; the rest of the
    space (directions no matched parameter sees, e.g. along which the analytical laws
    leave the design free) is completed by an orthonormal basis of their null space.
    """
    E = np.atleast_2d(np.asarray(exponents, dtype=float))
    d = E.shape[1]
    if not np.any(E):
        return np.eye(d)
    rows: list[np.ndarray] = []
    for r in E:
        trial = np.array(rows + [r])
        if np.linalg.matrix_rank(trial, tol=tol * max(1.0, np.abs(E).max())) == len(trial):
            rows.append(r)
        if len(rows) == d:
            break
    if len(rows) < d:
        _, _, Vt = np.linalg.svd(np.array(rows).reshape(len(rows), d))
        rows += list(Vt[len(rows):])
    return np.array(rows)


def classical_records(result: ClassicalResult, prototype: Configuration,
                      names: Sequence[str] | None = None) -> list[dict[str, Any]]:
    """The public ``similarity`` list (``[{"name", "prototype", "model",
    "relative_difference"}]``) of a classical design."""
    return comparison_records(result.similarity_table(prototype, names))
