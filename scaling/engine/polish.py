"""The final local search of a run (``OptimizerSettings.polish``): Nelder-Mead, or
Gauss-Newton on the histories the objectives are composed from.

After the Bayesian iterations, a local search of the design-point score
(:func:`~hypate.scaling.engine.design_point.worst_objective`: the objective itself, or
``max_j J_j`` of two or more -- Sec. 9.2.3's min-max criterion) starts from the best
feasible design. Each new design it asks for is a real evaluation, stored as iteration
``n_iter + 1`` (batch index = its order); a design already evaluated (to 1e-9 of each
range) is not simulated again. A resumed run replays the stored evaluations in order, so it
ends where the uninterrupted run did. The search stops after ``settings.polish`` new
evaluations or when the evaluation budget is spent.

``polish_method = "nelder-mead"``: a derivative-free simplex search in the surrogates'
coordinates (``settings.coordinates``, or the unit box), with the cheap constraints
enforced by projection.

``polish_method = "gauss-newton"`` (a problem whose objectives are a
:class:`~hypate.scaling.engine.histories.Composition` of its histories,
``J_j^2 = sum_g w_jg ||h_g - t_g||^2``, Eqs. 6.4, 9.6): the objectives' structure used
directly. The residual histories ``r(x) = h(x) - t`` and the expensive constraints
``G(x)`` are linearized in the unit box (forward differences of one evaluation per
variable, then Broyden secant updates from every usable evaluation the search makes,
feasible or not), and each step solves the trust-region min-max problem

    min_d max_j sum_g w_jg ||r_g + A_g d||^2   s.t.  G + B d <= 0,  cheap constraints,
    0 <= u + d <= 1,  |d|_inf <= Delta

(a Gauss-Newton step of the min-max criterion, SLSQP on the small smooth problem). A valley
where the histories cross the prototype's is curved and narrow in the design box; the
linearized histories follow it where a simplex, which sees only ``max J``, needs many
evaluations per turn. The panel's other equilibrium branches lie close to the valley floor
(a design a fraction of a percent away can buckle the other way, J ~ 2): a step whose
score jumps to more than :data:`JUMP` times the current one, or that fails, is taken as
such a branch -- it shrinks the trust region and does not enter the secant model; a
difference that does leaves its variable out of the first model (the branch lies 0.1 % of
its range away: measured on the quick-start, retrying it backward moved the search onto
the other branches more often than it helped). The steps
keep :data:`BACKOFF` from the linearized constraints. When the trust region has shrunk
below :data:`MIN_RADIUS` the remaining evaluations go to the Nelder-Mead search from the
best design seen; a best design without usable histories goes to it at once, with a
warning.
"""
from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from hypate.scaling.engine.design_point import worst_objective
from hypate.scaling.engine.histories import HISTORIES, Composition
from hypate.scaling.engine.problem import project_unit, scipy_constraints
from hypate.scaling.engine.settings import OptimizerSettings, SettingError
from hypate.scaling.engine.store import Evaluation
from scipy.optimize import minimize

__all__ = ["BACKOFF", "FD_STEP", "JUMP", "MAX_RADIUS", "MIN_RADIUS", "RADIUS",
           "polish_best", "polish_composition"]

#: Forward-difference step of the Gauss-Newton linearization, a share of each range.
FD_STEP = 1e-3
#: Initial trust-region radius (max-norm in the unit box).
RADIUS = 0.02
#: Largest trust-region radius.
MAX_RADIUS = 0.2
#: Below this radius the Gauss-Newton search hands over to Nelder-Mead.
MIN_RADIUS = 1e-4
#: A score above this multiple of the current one is another branch, not a slope.
JUMP = 1.5
#: The radius grows by this factor after a step that did better than GOOD_RATIO of the
#: predicted gain, shrinks by it after a step that did not improve, and by its square
#: after a failure or a jump to another branch.
SHRINK, GOOD_RATIO = 2.0, 0.75
#: Margin the steps keep from the linearized expensive constraints (a step aimed at the
#: boundary would land on either side of it).
BACKOFF = 1e-6


class _PolishDone(Exception):
    """The polish budget is spent."""


def _feasible(ev: Evaluation) -> bool:
    return bool(ev.ok and np.all(np.asarray(ev.G) <= 0.0))


def _score(ev: Evaluation) -> float:
    """The design-point score of an evaluation: inf unless feasible (module docstring)."""
    if not _feasible(ev):
        return math.inf
    s = float(worst_objective(np.atleast_2d(np.asarray(ev.F, float)))[0])
    return s if np.isfinite(s) else math.inf


class _Search:
    """The polish's evaluations: new designs simulated (or replayed from the store) until
    the budget is spent, designs already evaluated looked up."""

    def __init__(self, settings: OptimizerSettings, bounds: np.ndarray,
                 records: Sequence[Evaluation], evaluate: Callable[[np.ndarray, int], Evaluation],
                 budget_left: Callable[[], int]) -> None:
        self.settings, self.evaluate, self.budget_left = settings, evaluate, budget_left
        self.lo, self.hi = bounds[:, 0], bounds[:, 1]
        self.span = self.hi - self.lo
        t = settings.n_iter + 1
        self.before = [r for r in records if r.iteration < t]
        self.stored = {r.batch_index: r for r in records if r.iteration == t}
        self.seen = {self.key(r.x): r for r in self.before}
        self.count = 0
        cheap = settings.cheap_constraints
        self.cons = scipy_constraints(cheap, self.lo, self.span) if cheap else []

    def key(self, x: np.ndarray) -> tuple[float, ...]:
        # a design's place in the unit box to 1e-9 of each range: the searches' arithmetic
        # revisits a design with float noise (5e-16 of p0), which is not simulated again
        return tuple(np.round((np.asarray(x, float) - self.lo) / self.span, 9))

    def start(self) -> Evaluation | None:
        """The best feasible evaluation before the polish (None: there is none)."""
        scores = [_score(r) for r in self.before]
        if not scores or not np.isfinite(min(scores)):
            return None
        return self.before[int(np.argmin(scores))]

    def design(self, x: np.ndarray) -> np.ndarray:
        """``x`` clipped to the bounds and projected onto the cheap constraints."""
        x = np.clip(x, self.lo, self.hi)
        if self.cons:
            x = self.lo + project_unit((x - self.lo) / self.span, self.cons) * self.span
        return x

    def __call__(self, x: np.ndarray) -> Evaluation:
        ev = self.seen.get(self.key(x))
        if ev is not None:
            return ev
        k = self.count
        if k >= self.settings.polish or self.budget_left() <= 0:
            raise _PolishDone
        if k in self.stored:
            ev = self.stored[k]
            if not np.allclose(ev.x, x, rtol=0, atol=1e-9):
                warnings.warn("polish: resumed point differs from the stored one",
                              RuntimeWarning, stacklevel=2)
        else:
            ev = self.evaluate(x, k)
        self.count += 1
        self.seen[self.key(x)] = ev
        return ev


def polish_composition(settings: OptimizerSettings, problem: Any,
                       composition: Composition | None) -> Composition | None:
    """The composition the polish linearizes: the surrogates' (``composition``), else the
    problem's ``composition()`` when ``polish_method = "gauss-newton"`` asks for one.

    Raises
    ------
    SettingError
        Gauss-Newton asked of a problem without a composition of its histories.
    """
    if composition is not None or not settings.polish or \
            settings.polish_method != "gauss-newton":
        return composition
    compose = getattr(problem, "composition", None)
    found = compose() if callable(compose) else None
    if found is None:
        raise SettingError("polish_method", "'nelder-mead' for a problem without a "
                           "composition() of its objectives from histories",
                           settings.polish_method)
    return found


def polish_best(settings: OptimizerSettings, bounds: np.ndarray, records: Sequence[Evaluation],
                evaluate: Callable[[np.ndarray, int], Evaluation],
                budget_left: Callable[[], int], composition: Composition | None = None
                ) -> None:
    """The final local search from the best feasible design of ``records`` (module
    docstring).

    Parameters
    ----------
    settings : OptimizerSettings
        ``polish`` (new evaluations), ``polish_method``, ``polish_step`` (the initial
        simplex's edge, a share of each coordinate's range), ``n_iter``, ``coordinates``,
        ``cheap_constraints``.
    bounds : ndarray of shape (d, 2)
    records : sequence of Evaluation
        The run's evaluations (a resumed polish's own among them, iteration ``n_iter + 1``).
    evaluate : callable
        ``evaluate(x, k)``: simulate design ``x`` as the polish's ``k``-th evaluation, commit
        it and return its record.
    budget_left : callable
        Evaluations the run may still make.
    composition : Composition, optional
        How the objectives follow from the evaluations' ``aux["histories"]``; required by
        ``polish_method = "gauss-newton"``.
    """
    if settings.polish <= 0:
        return
    search = _Search(settings, bounds, records, evaluate, budget_left)
    start = search.start()
    if start is None:
        return
    try:
        if settings.polish_method == "gauss-newton":
            if composition is None:
                raise SettingError("polish_method", "'nelder-mead' without a composition",
                                   settings.polish_method)
            start = _gauss_newton(search, start, composition)
        _nelder_mead(search, np.asarray(start.x, float))
    except _PolishDone:
        pass


# -- Nelder-Mead --------------------------------------------------------------------------
def _nelder_mead(search: _Search, x_best: np.ndarray) -> None:
    """Nelder-Mead on the score from ``x_best`` in the surrogates' coordinates, until the
    budget is spent (raises :class:`_PolishDone`)."""
    s, lo, hi, span = search.settings, search.lo, search.hi, search.span
    n_var = len(lo)
    coords = s.coordinates
    if coords is None:  # the unit box
        z0, z_span = (x_best - lo) / span, np.ones(n_var)
    else:
        box = coords.box(np.column_stack([lo, hi]))
        z0, z_span = coords(x_best)[0], box[:, 1] - box[:, 0]
        A_inv = np.linalg.inv(coords.matrix)

    def value(z: np.ndarray) -> float:
        return _score(search(search.design(lo + z * span if coords is None
                                           else np.exp(A_inv @ z))))

    step = s.polish_step * z_span
    simplex = z0 + np.vstack([np.zeros(n_var), np.diag(step)])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        minimize(value, z0, method="Nelder-Mead",
                 options={"initial_simplex": simplex, "maxfev": 100 * s.polish,
                          "xatol": 1e-9, "fatol": 0.0})


# -- Gauss-Newton on the histories --------------------------------------------------------
def _usable(ev: Evaluation, composition: Composition, f_ref: float) -> np.ndarray | None:
    """The residual histories ``h - t`` of ``ev`` if it can enter the linearization: a
    successful evaluation with finite histories of the composition's length and finite
    constraints, whose max J stays within :data:`JUMP` times ``f_ref`` (else another
    branch); None otherwise. Feasibility does not matter here (the model includes G)."""
    h = ev.aux.get(HISTORIES) if ev.ok else None
    if h is None:
        return None
    r = np.asarray(h, float).ravel()
    F, G = np.asarray(ev.F, float), np.asarray(ev.G, float)
    if (r.size != composition.targets.size or not np.all(np.isfinite(r))
            or not np.all(np.isfinite(G)) or not np.all(np.isfinite(F))
            or float(worst_objective(F[None])[0]) > JUMP * f_ref):
        return None
    return r - composition.targets


class _Linearization:
    """``r(u) ~ r0 + A (u - u0)`` and ``G(u) ~ G0 + B (u - u0)`` about the current design."""

    def __init__(self, r: np.ndarray, G: np.ndarray, u: np.ndarray,
                 composition: Composition) -> None:
        self.comp = composition
        self.move(r, G, u)
        self.A = np.zeros((r.size, u.size))
        self.B = np.zeros((G.size, u.size))

    def move(self, r: np.ndarray, G: np.ndarray, u: np.ndarray) -> None:
        self.r, self.G, self.u = r, np.asarray(G, float), u

    def secant(self, r: np.ndarray, G: np.ndarray, u: np.ndarray) -> None:
        """Broyden's rank-one update: the model reproduces ``(r, G)`` at ``u``."""
        d = u - self.u
        dd = float(d @ d)
        if dd <= 0.0:
            return
        self.A += np.outer(r - self.r - self.A @ d, d) / dd
        self.B += np.outer(np.asarray(G, float) - self.G - self.B @ d, d) / dd

    def squares(self, d: np.ndarray) -> np.ndarray:
        """Predicted ``J_j^2`` of step ``d``, (m,)."""
        res = self.r + self.A @ d
        S = np.array([res[g] @ res[g] for g in self.comp.groups])
        return np.asarray(self.comp.weights @ S)

    def squares_jac(self, d: np.ndarray) -> np.ndarray:
        """Derivative of :meth:`squares` with respect to ``d``, (m, n)."""
        res = self.r + self.A @ d
        rows = [2.0 * res[g] @ self.A[g] for g in self.comp.groups]  # (G, n)
        return np.asarray(self.comp.weights @ np.array(rows))

    def step(self, radius: float, cons: list[dict[str, Any]]) -> np.ndarray:
        """The trust-region min-max step (module docstring), SLSQP on ``(d, s)``; no step
        (zeros) when SLSQP returns a point that breaks the subproblem's constraints."""
        n = self.u.size
        lo = np.maximum(-radius, -self.u)
        hi = np.minimum(radius, 1.0 - self.u)
        sq0 = self.squares(np.zeros(n))
        cheap = [_unit_constraint(c, self.u) for c in cons]
        model = [
            {"type": "ineq", "fun": lambda z: z[n] - self.squares(z[:n]),
             "jac": lambda z: np.column_stack([-self.squares_jac(z[:n]), np.ones(sq0.size)])},
            {"type": "ineq", "fun": lambda z: -(self.G + self.B @ z[:n]) - BACKOFF,
             "jac": lambda z: np.column_stack([-self.B, np.zeros(self.G.size)])}]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            res = minimize(lambda z: (z[n], np.r_[np.zeros(n), 1.0]), np.r_[np.zeros(n),
                                                                             sq0.max()],
                           jac=True, method="SLSQP",
                           bounds=list(zip(np.r_[lo, 0.0], np.r_[hi, np.inf])),
                           constraints=model + cheap, options={"maxiter": 200, "ftol": 1e-14})
        z = np.asarray(res.x, float)
        ok = np.all(np.isfinite(z)) and all(
            np.all(np.asarray(c["fun"](z)) >= -1e-8 * max(1.0, float(sq0.max())))
            if c["type"] == "ineq" else np.all(np.abs(np.asarray(c["fun"](z))) <= 1e-8)
            for c in model + cheap)
        return np.clip(z[:n], lo, hi) if ok else np.zeros(n)


def _unit_constraint(c: dict[str, Any], u: np.ndarray) -> dict[str, Any]:
    """A cheap constraint of the unit box (:func:`scipy_constraints`) as one of the step
    ``z = (d, s)`` about ``u``."""
    k = np.atleast_1d(np.asarray(c["fun"](u))).size
    n = u.size
    return {"type": c["type"], "fun": lambda z: c["fun"](u + z[:n]),
            "jac": lambda z: np.column_stack([c["jac"](u + z[:n]), np.zeros(k)])}


def _gauss_newton(search: _Search, start: Evaluation, composition: Composition) -> Evaluation:
    """The trust-region Gauss-Newton search of the min-max score (module docstring); returns
    the best evaluation it has seen when the radius has shrunk below :data:`MIN_RADIUS` (the
    budget spent raises :class:`_PolishDone`)."""
    lo, span = search.lo, search.span
    best, f_best = start, _score(start)
    r0 = _usable(start, composition, f_best)
    if r0 is None:
        warnings.warn("polish: the best design holds no usable histories; Nelder-Mead "
                      "instead of Gauss-Newton", RuntimeWarning, stacklevel=3)
        return start
    u0 = (np.asarray(start.x, float) - lo) / span
    lin = _Linearization(r0, start.G, u0, composition)

    lin_score = f_best  # the score of the linearization's base design

    def visit(u: np.ndarray) -> tuple[Evaluation, np.ndarray, np.ndarray | None]:
        """Evaluate unit-box point ``u`` (clipped, projected): the evaluation, its actual
        unit-box point and its residual histories if usable."""
        nonlocal best, f_best
        x = search.design(lo + u * span)
        ev = search(x)
        if _score(ev) < f_best:
            best, f_best = ev, _score(ev)
        return ev, (x - lo) / span, _usable(ev, composition, lin_score)
    for i in range(u0.size):  # forward differences (backward on the upper bound)
        u = u0.copy()
        u[i] += FD_STEP if u0[i] + FD_STEP <= 1.0 else -FD_STEP
        ev, u, r = visit(u)
        if r is not None:  # a failure or a jump 0.1 % away: a knife edge, stay off it
            lin.secant(r, ev.G, u)
    radius = RADIUS
    while radius >= MIN_RADIUS:
        d = lin.step(radius, search.cons)
        if not np.any(d):
            radius /= SHRINK
            continue
        predicted = math.sqrt(max(float(lin.squares(d).max()), 0.0))
        ev, u, r = visit(lin.u + d)
        if r is None:  # failed, or another branch
            radius /= SHRINK**2
            continue
        lin.secant(r, ev.G, u)
        f = _score(ev)
        if f < lin_score:
            gain = lin_score - predicted
            ratio = (lin_score - f) / gain if gain > 0.0 else 0.0
            lin.move(r, ev.G, u)
            lin_score = f
            if ratio > GOOD_RATIO:  # an improvement keeps the radius otherwise: the
                radius = min(SHRINK * radius, MAX_RADIUS)  # valley's turns mislead the model
        else:  # worse, or infeasible on a smooth slope: a smaller step
            radius /= SHRINK
    return best
