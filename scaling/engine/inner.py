"""The inner optimization: multistart SLSQP on an acquisition (Sec. 6.3.3).

Raw optimal-Latin-hypercube points are scored by the acquisition; the best few start SLSQP
with the analytic gradient, the cheap constraints (exact) and the surrogate constraints
(:class:`hypate.scaling.engine.surrogate.ProbabilisticConstraint`). Everything happens in
unit-box coordinates ``u`` (``x = lo + u span``) so that SLSQP sees a well-scaled problem.
"""
from __future__ import annotations

import dataclasses
import itertools
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol, cast

import numpy as np
from hypate.scaling.engine.acquisition import Acquisition
from hypate.scaling.engine.coordinates import LogLinearCoordinates, WarpedModel
from hypate.scaling.engine.histories import HistoriesModel
from hypate.scaling.engine.problem import (
    CHEAP_TOL,
    CheapConstraint,
    cheap_violation,
    project_unit,
    scipy_constraints,
)
from hypate.solvers.numerics.kriging import Mapper
from hypate.solvers.numerics.random import as_rng, raw_latin_hypercube
from scipy.optimize import Bounds, minimize

__all__ = ["Resolution", "optimize_acquisition"]

#: Predicted violation of the surrogate constraints above which a candidate ranks last.
MODEL_VIOLATION_TOL = 1e-6
#: Random directions tried per design variable for an inward probe.
PROBE_DIRECTIONS_PER_VARIABLE = 16
#: Smallest cosine between an inward probe's direction and the bound's inward normal
#: (26 degrees): a probe, and a neighbour that counts as one, moves off the bound along
#: the normal, not along the face (an off-valley neighbour 7 % inward in h but 10 % off in
#: the thermal load, at cosine 0.86, does not say how J_u falls along the valley).
PROBE_MIN_COSINE = 0.9


class ModelConstraint(Protocol):
    """A surrogate constraint ``c(X) <= 0`` of designs (N, d): values (N, k) and their
    Jacobian (N, k, d): a :class:`hypate.scaling.engine.surrogate.ProbabilisticConstraint`,
    the success classifier, or one of them on one level
    (:class:`hypate.scaling.engine.mixed.LevelConstraint`)."""

    def __call__(self, X: np.ndarray, /) -> np.ndarray: ...

    def jacobian(self, X: np.ndarray, /) -> np.ndarray: ...


@dataclass(frozen=True)
class Resolution:
    """The surrogate's own metric: ``w = to_metric(x)`` with Euclidean distances in units
    of the surrogate's length scales, its inverse ``from_metric``, and ``normals[i]``: the
    unit direction in ``w`` along which design variable ``i`` grows.

    A candidate closer than ``radius`` to a sample (in ``w``) is nearly perfectly
    correlated with it (Matern 5/2: correlation 0.997 at 0.05 length scales): the
    surrogate's value there is the sample's, extrapolated.
    """

    to_metric: Callable[[np.ndarray], np.ndarray]
    from_metric: Callable[[np.ndarray], np.ndarray]
    radius: float
    normals: np.ndarray

    def inward_sphere(self, w_center: np.ndarray, inward: np.ndarray,
                      rng: np.random.Generator) -> np.ndarray:
        """Designs (k, d) on the sphere of ``radius`` (slightly outside) around a sample,
        in directions within the cone ``cos >= PROBE_MIN_COSINE`` around the unit inward
        normal ``inward``: the normal first, then random directions of that cone."""
        d = len(w_center)
        random = rng.standard_normal((PROBE_DIRECTIONS_PER_VARIABLE * d, d))
        random /= np.linalg.norm(random, axis=1, keepdims=True)
        # tilt each random direction into the cone: normal + t * (its part across it)
        across = random - np.outer(random @ inward, inward)
        size = np.linalg.norm(across, axis=1, keepdims=True)
        tan = np.sqrt(1.0 - PROBE_MIN_COSINE**2) / PROBE_MIN_COSINE
        tilt = rng.uniform(0.0, tan, (len(random), 1))
        cone = inward + tilt * across / np.where(size > 0, size, 1.0)
        dirs = np.vstack([inward, cone / np.linalg.norm(cone, axis=1, keepdims=True)])
        return self.from_metric(w_center + (1.0 + 1e-6) * self.radius * dirs)

#: Largest length scale (unit box) of the surrogates' metric for the inward probe.
MAX_METRIC_LENGTH = 1.0


def surrogate_metric(model: Any, radius: float, n_var: int) -> Resolution:
    """The objective surrogates' metric: input coordinates (the model's warp, or the design
    box) scaled to the surrogates' unit box and divided by their shortest length scale per
    input (over the objectives, at most :data:`MAX_METRIC_LENGTH`), with the probe
    ``radius``; a histories model's is that of its coefficients' kriging."""
    if isinstance(model, HistoriesModel):  # the metric of its coefficients' kriging
        model = model.coefficients
    coords = model.coords if isinstance(model, WarpedModel) else None
    gp = model.model if isinstance(model, WarpedModel) else model
    # a length scale beyond the box (an input the fit calls irrelevant, up to the
    # bound 1e2) would make the whole box one point: the metric caps it at the box
    lower = gp.lower_
    unit = gp.scale_ * np.minimum(gp.length_scale_.min(axis=0), MAX_METRIC_LENGTH)
    if coords is None:
        return Resolution(lambda X: (np.atleast_2d(X) - lower) / unit,
                          lambda W: lower + np.atleast_2d(W) * unit, radius,
                          np.eye(n_var))
    # log-linear: a categorical variable's mixed coordinates have no metric (no inward side)
    A_inv = np.linalg.inv(cast(LogLinearCoordinates, coords).matrix)
    # x_i grows along the gradient of ln x_i = (A^-1 z)_i, i.e. of A^-1 (lower + w unit)
    normals = A_inv * unit[None, :]
    return Resolution(lambda X: (coords(X) - lower) / unit,
                      lambda W: np.exp((lower + np.atleast_2d(W) * unit) @ A_inv.T),
                      radius, normals / np.linalg.norm(normals, axis=1, keepdims=True))



@dataclass(frozen=True)
class _UnitSearch:
    """The acquisition and its constraints seen in unit-box coordinates ``u``."""

    acquisition: Acquisition
    lo: np.ndarray
    span: np.ndarray
    sign: float                  # -1 for a maximized acquisition: SLSQP minimizes
    scale: float                 # loss scale: SLSQP's ftol is relative to O(1) values
    cheap_constraints: Sequence[CheapConstraint]
    cheap: list[dict[str, Any]]  # the cheap constraints in scipy form, in u
    model_constraints: Sequence[ModelConstraint]
    U_avoid: np.ndarray | None
    min_distance: float

    def loss(self, u: np.ndarray) -> tuple[float, np.ndarray]:
        """Scaled, sign-flipped acquisition and its u-gradient (SLSQP's objective)."""
        val, grad = self.acquisition.value_and_gradient((self.lo + u * self.span)[None])
        return (self.sign * float(val[0]) / self.scale,
                self.sign * grad[0] * self.span / self.scale)

    def model_violation(self, u: np.ndarray) -> float:
        x = (self.lo + u * self.span)[None]
        return float(sum(np.maximum(mc(x), 0.0).sum() for mc in self.model_constraints))

    def cheap_ok(self, u: np.ndarray) -> bool:
        return cheap_violation(self.cheap_constraints, self.lo + u * self.span) <= CHEAP_TOL

    def far(self, u: np.ndarray) -> bool:
        """At least ``min_distance`` from every sample (unit-box distance)."""
        return self.U_avoid is None or \
            float(np.min(np.linalg.norm(self.U_avoid - u, axis=1))) >= self.min_distance

    def feasible(self, u: np.ndarray) -> np.ndarray | None:
        """``u``, projected onto the cheap constraints if needed; None if that fails."""
        if self.cheap and not self.cheap_ok(u):
            u = project_unit(u, self.cheap)
            if not self.cheap_ok(u):
                return None
        return u

    def scipy_model_constraints(self) -> list[dict[str, Any]]:
        """The surrogate constraints ``c(x) <= 0`` as scipy inequalities ``-c >= 0`` in u."""
        lo, span = self.lo, self.span
        return [{"type": "ineq",
                 "fun": lambda u, mc=mc: -mc(lo + u * span)[0],
                 "jac": lambda u, mc=mc: -mc.jacobian(lo + u * span)[0] * span}
                for mc in self.model_constraints]


def _raw_points(acquisition: Acquisition, lo: np.ndarray, span: np.ndarray, n_raw: int,
                extra_starts: np.ndarray | None,
                model_constraints: Sequence[ModelConstraint], sign: float,
                rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Raw OLH points (+ extra starts) in u, their losses, and their ranking: points that
    satisfy the surrogate constraints first, then by loss (non-finite losses last)."""
    d = len(lo)
    U = raw_latin_hypercube(n_raw, np.c_[np.zeros(d), np.ones(d)], rng)
    if extra_starts is not None and len(extra_starts):
        U = np.vstack([U, np.clip((np.atleast_2d(extra_starts) - lo) / span, 0.0, 1.0)])
    X = lo + U * span
    loss = sign * acquisition(X)
    viol = np.zeros(len(U))
    for mc in model_constraints:
        viol += np.maximum(mc(X), 0.0).sum(axis=1)
    loss = np.where(np.isfinite(loss), loss, np.inf)
    return U, loss, np.lexsort((loss, viol > 0))


def _slsqp(search: _UnitSearch, u0: np.ndarray, model_cons: list[dict[str, Any]],
           maxiter: int, ftol: float) -> np.ndarray | None:
    """One SLSQP run from ``u0``; the polished point, or None if no feasible point results."""
    if search.cheap and not search.cheap_ok(u0):
        u0 = project_unit(u0, search.cheap)
    box = Bounds(np.zeros(len(u0)), np.ones(len(u0)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        res = minimize(search.loss, u0, jac=True, method="SLSQP", bounds=box,
                       constraints=search.cheap + model_cons,
                       options={"maxiter": maxiter, "ftol": ftol})
    u = np.clip(res.x, 0.0, 1.0)
    # status 0: converged; 9: iteration limit (a valid improved iterate); others (e.g.
    # 4 "inequality constraints incompatible", 8 line search) keep the better of x, x0
    if res.status not in (0, 9) and not search.loss(u)[0] <= search.loss(u0)[0]:
        u = u0
    return search.feasible(u)


@dataclass(frozen=True)
class _PolishStart:
    """One SLSQP start as a picklable call: ``start -> (violates, loss, u)`` or None. The
    search travels without its scipy-form constraints (closures do not pickle); they are
    rebuilt from the cheap constraints where the start runs."""

    search: _UnitSearch
    maxiter: int
    ftol: float

    def _here(self) -> tuple[_UnitSearch, list[dict[str, Any]]]:
        s = self.search
        if s.cheap_constraints and not s.cheap:
            s = dataclasses.replace(s, cheap=scipy_constraints(s.cheap_constraints, s.lo,
                                                               s.span))
        return s, s.scipy_model_constraints()

    @staticmethod
    def _candidate(search: _UnitSearch, u: np.ndarray | None):
        if u is None:
            return None
        return search.model_violation(u) > MODEL_VIOLATION_TOL, search.loss(u)[0], u

    def __call__(self, u0: np.ndarray) -> tuple[bool, float, np.ndarray] | None:
        search, model_cons = self._here()
        return self._candidate(search, _slsqp(search, u0, model_cons, self.maxiter, self.ftol))

    def serial(self, starts: Sequence[np.ndarray]) -> list:
        search, model_cons = self._here()
        return [self._candidate(search, _slsqp(search, u0, model_cons, self.maxiter, self.ftol))
                for u0 in starts]


#: A coordinate within this of 0 or 1 (unit box) sits on its bound.
ON_BOUND = 1e-9


def _bound_probe(search: _UnitSearch, candidates: list[tuple[bool, float, np.ndarray]],
                 resolution: Resolution, X_samples: np.ndarray,
                 rng: np.random.Generator) -> list[tuple[bool, float, np.ndarray]]:
    """The candidates, led by an inward probe when the best one refines a sample on a bound.

    A sample on a bound (a face or corner of the box) with no other sample within twice
    the resolution radius off that bound along its inward normal has data on one side only: whether
    the objective falls inward is the surrogate's extrapolation, and a search that trusts it refines
    the bound point forever (Sec. 9.1: h pinned at its upper bound while J_u falls inward along
    the similarity valley). When the best candidate lies within the radius of such a
    sample, the acquisition's best point of the resolution sphere around the sample within
    26 degrees of the inward normal of such a bound (the first, if several) goes first:
    one evaluation that measures the inward trend.
    """
    lo, span = search.lo, search.span
    W = resolution.to_metric(X_samples)
    w0 = resolution.to_metric((lo + candidates[0][2] * span)[None])[0]
    dist = np.linalg.norm(W - w0, axis=1)
    k = int(np.argmin(dist))
    if dist[k] >= resolution.radius:
        return candidates
    U_s = (X_samples - lo) / span
    u_s = U_s[k]
    at_lo, at_hi = u_s <= ON_BOUND, u_s >= 1.0 - ON_BOUND
    if not (at_lo | at_hi).any():
        return candidates
    D = W - W[k]
    dist_k = np.linalg.norm(D, axis=1)
    near = (dist_k <= 2.0 * resolution.radius) & (dist_k > 0.0)
    inward = np.where(at_lo, 1.0, -1.0)[:, None] * resolution.normals  # (d, d), row per bound
    # a neighbour probes a bound when it lies off it along the inward normal (the cone)
    along = (D[near] @ inward.T) >= PROBE_MIN_COSINE * dist_k[near][:, None]
    unprobed = np.flatnonzero((at_lo | at_hi) & ~along.any(axis=0))
    if unprobed.size == 0:
        return candidates
    U_p = (resolution.inward_sphere(W[k], inward[unprobed[0]], rng) - lo) / span
    inside = np.all(np.isfinite(U_p) & (U_p >= 0.0) & (U_p <= 1.0), axis=1)
    probes = [u for u in (search.feasible(u) for u in U_p[inside]) if u is not None]
    if not probes:
        return candidates
    ranked = sorted(((search.model_violation(u) > MODEL_VIOLATION_TOL, search.loss(u)[0], u)
                     for u in probes), key=lambda c: (c[0], c[1]))
    return [ranked[0], *candidates]


def optimize_acquisition(
    acquisition: Acquisition,
    bounds: np.ndarray,
    *,
    n_raw: int = 256,
    n_starts: int = 5,
    cheap_constraints: Sequence[CheapConstraint] = (),
    model_constraints: Sequence[ModelConstraint] = (),
    X_avoid: np.ndarray | None = None,
    min_distance: float = 1e-5,
    extra_starts: np.ndarray | None = None,
    rng: np.random.Generator | int | None = None,
    maxiter: int = 200,
    ftol: float = 1e-9,
    resolution: Resolution | None = None,
    mapper: Mapper | None = None,
) -> tuple[np.ndarray, float]:
    """Multistart SLSQP maximization (or minimization) of an acquisition (Sec. 6.3.3).

    Raw OLH points (plus ``extra_starts``) are scored by the acquisition; the best
    ``n_starts`` (those satisfying the model constraints first) start SLSQP with the
    analytic gradient, the cheap constraints (exact) and the model constraints. Results
    whose cheap constraints are violated by more than ``CHEAP_TOL`` are polished by a
    projection and rejected if still infeasible; a result closer than ``min_distance``
    (unit-box coordinates) to a row of ``X_avoid`` is rejected in favour of the next best.

    Parameters
    ----------
    acquisition : Acquisition
        ``maximize`` says the sense.
    bounds : ndarray of shape (d, 2)
    n_raw, n_starts : int
    cheap_constraints : sequence of CheapConstraint
    model_constraints : sequence of ModelConstraint
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
    resolution : Resolution or None
        The surrogate's metric: when the best candidate lies within ``resolution.radius``
        of a row of ``X_avoid`` that sits on a bound with no row near it off that bound,
        the proposal is the best point of the inward half of the sphere of that radius
        around the row (:func:`_bound_probe`).
    mapper : callable or None
        ``mapper(fn, starts)``: how the SLSQP starts are spread (e.g. over the run's
        workers, :class:`hypate.scaling.engine.sharing.WorkerMap`); None: one after another.
        The candidates do not depend on it.

    Returns
    -------
    x : ndarray of shape (d,)
    value : float
        Acquisition value at ``x``.

    Raises
    ------
    RuntimeError
        If every start is infeasible or already sampled.
    """
    rng = as_rng(rng)
    b = np.asarray(bounds, dtype=float)
    lo, span = b[:, 0], b[:, 1] - b[:, 0]
    sign = -1.0 if acquisition.maximize else 1.0
    U, loss, order = _raw_points(acquisition, lo, span, n_raw, extra_starts,
                                 model_constraints, sign, rng)
    scale = max(float(np.max(np.abs(loss[order[:n_starts]]))), 1e-300)
    if not np.isfinite(scale):
        scale = 1.0
    U_avoid = None if X_avoid is None or len(X_avoid) == 0 else (np.atleast_2d(X_avoid) - lo) / span
    search = _UnitSearch(acquisition, lo, span, sign, scale, cheap_constraints,
                         scipy_constraints(cheap_constraints, lo, span), model_constraints,
                         U_avoid, min_distance)
    starts = list(U[order[:n_starts]])
    polish = _PolishStart(dataclasses.replace(search, cheap=[]), maxiter, ftol)
    polished = polish.serial(starts) if mapper is None else mapper(polish, starts)
    candidates = [c for c in polished if c is not None]
    candidates.sort(key=lambda c: (c[0], c[1]))
    if resolution is not None and U_avoid is not None and candidates:
        assert X_avoid is not None  # U_avoid is None when X_avoid is
        candidates = _bound_probe(search, candidates, resolution, np.atleast_2d(X_avoid), rng)
    # after the polished starts, if all are too close to a sample: the raw points in rank
    # order (projected lazily: usually the first polished start is taken)
    raw = (search.feasible(U[i]) for i in order)
    for u in itertools.chain((c[2] for c in candidates), raw):
        if u is not None and search.far(u):
            x = lo + u * span
            return x, float(acquisition(x[None])[0])
    raise RuntimeError("no admissible candidate: every start is infeasible or already sampled")
