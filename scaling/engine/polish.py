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
variable, then Broyden secant updates from every evaluation the search makes), and each
step solves the trust-region min-max problem

    min_d max_j sum_g w_jg ||r_g + A_g d||^2   s.t.  G + B d <= 0,  cheap constraints,
    0 <= u + d <= 1,  |d|_inf <= Delta

(a Gauss-Newton step of the min-max criterion, SLSQP on the small smooth problem). A valley
where the histories cross the prototype's is curved and narrow in the design box; the
linearized histories follow it where a simplex, which sees only ``max J``, needs many
evaluations per turn. The panel's other equilibrium branches lie close to the valley floor
(a design a fraction of a percent away can buckle the other way, J ~ 2): a step whose
score jumps to more than :data:`JUMP` times the current one, or that fails, is taken as
such a branch -- it shrinks the trust region and does not enter the secant model. When the
trust region has shrunk below :data:`MIN_RADIUS` the remaining evaluations go to the
Nelder-Mead search from the best design.
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

__all__ = ["FD_STEP", "JUMP", "MIN_RADIUS", "RADIUS", "polish_best", "polish_composition"]

#: Forward-difference step of the Gauss-Newton linearization, a share of each range.
FD_STEP = 1e-3
#: Initial trust-region radius (max-norm in the unit box) and its cap.
RADIUS, MAX_RADIUS = 0.02, 0.2
#: Below this radius the Gauss-Newton search hands over to Nelder-Mead.
MIN_RADIUS = 1e-4
#: A score above this multiple of the current one is another branch, not a slope.
JUMP = 1.5


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
class _Linearization:
    """``r(u) ~ r0 + A (u - u0)`` and ``G(u) ~ G0 + B (u - u0)`` about the current design."""

    def __init__(self, ev: Evaluation, u: np.ndarray, composition: Composition) -> None:
        self.comp = composition
        self.move(ev, u)
        self.A = np.zeros((self.r.size, u.size))
        self.B = np.zeros((self.G.size, u.size))

    def move(self, ev: Evaluation, u: np.ndarray) -> None:
        self.ev, self.u = ev, u
        self.r = np.asarray(ev.aux[HISTORIES], float) - self.comp.targets
        self.G = np.asarray(ev.G, float)

    def secant(self, ev: Evaluation, u: np.ndarray) -> None:
        """Broyden's rank-one update: the model reproduces ``ev`` at ``u``."""
        d = u - self.u
        dd = float(d @ d)
        if dd <= 0.0:
            return
        r = np.asarray(ev.aux[HISTORIES], float) - self.comp.targets
        self.A += np.outer(r - self.r - self.A @ d, d) / dd
        self.B += np.outer(np.asarray(ev.G, float) - self.G - self.B @ d, d) / dd

    def squares(self, d: np.ndarray) -> np.ndarray:
        """Predicted ``J_j^2`` of step ``d``."""
        res = self.r + self.A @ d
        S = np.array([res[g] @ res[g] for g in self.comp.groups])
        return np.asarray(self.comp.weights @ S)

    def squares_jac(self, d: np.ndarray) -> np.ndarray:
        res = self.r + self.A @ d
        rows = [2.0 * res[g] @ self.A[g] for g in self.comp.groups]  # (G, n)
        return np.asarray(self.comp.weights @ np.array(rows))

    def step(self, radius: float, cons: list[dict[str, Any]]) -> np.ndarray:
        """The trust-region min-max step (module docstring), SLSQP on ``(d, s)``."""
        n = self.u.size
        lo = np.maximum(-radius, -self.u)
        hi = np.minimum(radius, 1.0 - self.u)
        sq0 = self.squares(np.zeros(n))
        z0 = np.r_[np.zeros(n), sq0.max()]
        unit = [{"type": c["type"], "fun": (lambda z, c=c: c["fun"](self.u + z[:n])),
                 "jac": (lambda z, c=c: np.column_stack([c["jac"](self.u + z[:n]),
                                                         np.zeros(len(c["fun"](self.u)))]))}
                for c in cons]
        m = len(sq0)
        model = [
            {"type": "ineq", "fun": lambda z: z[n] - self.squares(z[:n]),
             "jac": lambda z: np.column_stack([-self.squares_jac(z[:n]), np.ones(m)])},
            {"type": "ineq", "fun": lambda z: -(self.G + self.B @ z[:n]),
             "jac": lambda z: np.column_stack([-self.B, np.zeros(self.G.size)])}]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            res = minimize(lambda z: (z[n], np.r_[np.zeros(n), 1.0]), z0, jac=True,
                           method="SLSQP", bounds=list(zip(np.r_[lo, 0.0], np.r_[hi, np.inf])),
                           constraints=model + unit, options={"maxiter": 200, "ftol": 1e-14})
        return np.clip(res.x[:n], lo, hi)


def _gauss_newton(search: _Search, start: Evaluation, composition: Composition) -> Evaluation:
    """The trust-region Gauss-Newton search of the min-max score (module docstring); returns
    the best evaluation when the radius has shrunk below :data:`MIN_RADIUS` (the budget
    spent raises :class:`_PolishDone`)."""
    lo, span = search.lo, search.span
    u0 = (np.asarray(start.x, float) - lo) / span
    lin = _Linearization(start, u0, composition)
    best, f_best = start, _score(start)
    for i in range(u0.size):  # forward differences (backward on the upper bound)
        u = u0.copy()
        u[i] += FD_STEP if u0[i] + FD_STEP <= 1.0 else -FD_STEP
        x = search.design(lo + u * span)
        ev = search(x)
        if _score(ev) <= JUMP * f_best:  # a failure or another branch leaves the column 0
            lin.secant(ev, (x - lo) / span)
    radius = RADIUS
    while radius >= MIN_RADIUS:
        d = lin.step(radius, search.cons)
        x = search.design(lo + (lin.u + d) * span)
        ev = search(x)
        f = _score(ev)
        if not f <= JUMP * f_best:  # failed, inadmissible or another branch
            radius /= 4.0
            continue
        u = (x - lo) / span
        predicted = math.sqrt(max(float(lin.squares(u - lin.u).max()), 0.0))
        lin.secant(ev, u)
        if f < f_best:
            ratio = (f_best - f) / max(f_best - predicted, 1e-300)
            lin.move(ev, u)
            best, f_best = ev, f
            if ratio > 0.75:
                radius = min(2.0 * radius, MAX_RADIUS)
        else:
            radius /= 2.0
    return best
