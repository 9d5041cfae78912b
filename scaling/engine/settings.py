"""The optimizer's settings, in two frozen, validated objects: the algorithm
(:class:`OptimizerSettings`: what it proposes, from what) and the run's context
(:class:`RunContext`: where the evaluations run and go -- executor, time limit, store,
callback, BLAS threads; of these only the time limit can change a result: a design it cuts
off is stored as failed).

Every option of :class:`hypate.scaling.engine.optimizer.BayesianOptimizer` is a field of one
of them, with its default and its allowed range; a bad value fails at construction with a
:class:`SettingError` naming the field and the range. What depends on the problem (the
acquisition fitting the number of objectives, lengths of ``weights`` and ``ref_point``,
positive bounds for log coordinates) is checked by the optimizer.
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from numbers import Integral, Real
from pathlib import Path
from typing import Any, Literal

from hypate.scaling.engine.acquisition import ACQUISITIONS, AcquisitionFactory
from hypate.scaling.engine.coordinates import LogLinearCoordinates
from hypate.scaling.engine.mixed import Categorical
from hypate.scaling.engine.problem import CheapConstraint
from hypate.scaling.engine.stopping import StoppingRule
from hypate.scaling.engine.store import Evaluation, EvaluationStore
from hypate.solvers.numerics.kriging import KERNELS

__all__ = ["OptimizerSettings", "RunContext", "SettingError", "BATCH_STRATEGIES",
           "OUTPUT_TRANSFORMS", "POLISH_METHODS", "SURROGATES"]

#: Fantasies within a batch: kriging believer or constant liar.
BATCH_STRATEGIES: tuple[str, ...] = ("believer", "liar")
#: Objective transforms the surrogates may model.
OUTPUT_TRANSFORMS: tuple[str, ...] = ("none", "log")
#: What the surrogates model: the objectives, or the histories they are composed from.
SURROGATES: tuple[str, ...] = ("objectives", "histories")
#: The final local searches (:mod:`hypate.scaling.engine.polish`).
POLISH_METHODS: tuple[str, ...] = ("nelder-mead", "gauss-newton")

#: Integer fields: smallest allowed value (``None`` allowed where the field is optional).
_INT_MIN = {"n_init": 0, "n_iter": 0, "batch_size": 1, "n_restarts": 0, "n_raw": 1,
            "n_starts": 1, "seed": 0, "max_evaluations": 0, "convergence_window": 0,
            "blas_threads": 1, "polish": 0, "exploit_last": 0}
#: Real fields: (low, high, low inclusive, high inclusive).
_REAL_RANGE = {"v": (0.0, math.inf, True, False), "v_final": (0.0, math.inf, True, False),
               "g": (1.0, math.inf, True, True),
               "p_feasible": (0.0, 1.0, False, False),
               "p_success": (0.0, 1.0, False, False),
               "p_exploit": (0.0, 1.0, False, False),
               "min_distance": (0.0, math.inf, True, False),
               "resolution": (0.0, 1.0, True, False),
               "timeout": (0.0, math.inf, False, False),
               "convergence_tol": (0.0, math.inf, True, False),
               "polish_step": (0.0, 0.5, False, True)}
#: Fields that may be ``None``.
_OPTIONAL = {"acquisition", "v", "v_final", "ref_point", "weights", "executor", "timeout", "store",
             "max_evaluations", "convergence_tol", "callback", "blas_threads", "coordinates",
             "categorical", "stopping"}
#: Fields of a fixed set of names.
_CHOICES = {"batch_strategy": BATCH_STRATEGIES, "kernel": KERNELS,
            "output_transform": OUTPUT_TRANSFORMS, "surrogate": SURROGATES,
            "polish_method": POLISH_METHODS}


class SettingError(ValueError):
    """A setting outside its allowed range; ``field`` names it."""

    def __init__(self, field: str, allowed: str, value: Any) -> None:
        super().__init__(f"{field} must be {allowed}, got {value!r}")
        self.field, self.allowed, self.value = field, allowed, value

    def __reduce__(self):
        # pickled by its fields (a pool worker's error reaches the parent as itself)
        return type(self), (self.field, self.allowed, self.value)


def _interval(lo: float, hi: float, lo_closed: bool, hi_closed: bool) -> str:
    return f"a number in {'[' if lo_closed else '('}{lo:g}, {hi:g}{']' if hi_closed else ')'}"


def _check_int(name: str, value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, Integral) or value < _INT_MIN[name]:
        raise SettingError(name, f"an integer >= {_INT_MIN[name]}", value)
    return int(value)


def _check_real(name: str, value: Any) -> Any:
    lo, hi, lo_closed, hi_closed = _REAL_RANGE[name]
    # the type test apart from the comparisons: typeshed's numbers.Real has no order
    # operators (a Real value here is a float, an int or a numpy number)
    real = isinstance(value, Real) and not isinstance(value, bool)
    ok = real and \
        (lo <= value if lo_closed else lo < value) and (value <= hi if hi_closed else value < hi)
    if not ok:
        raise SettingError(name, _interval(lo, hi, lo_closed, hi_closed), value)
    return value


def _check_vector(name: str, value: Any, minimum: float) -> tuple[float, ...]:
    try:
        vec = tuple(float(v) for v in value)
    except (TypeError, ValueError):
        raise SettingError(name, "a sequence of numbers", value) from None
    if not vec or not all(math.isfinite(v) and v >= minimum for v in vec):
        raise SettingError(name, f"a non-empty sequence of finite numbers >= {minimum:g}", value)
    return vec


def _check_fields(obj: Any) -> Callable[[str, Any], None]:
    """Check every field of a frozen settings dataclass against the tables above (integers
    normalized in place); returns the setter of normalized values."""
    def put(name: str, value: Any) -> None:
        object.__setattr__(obj, name, value)  # normalized values of a frozen instance

    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if value is None and f.name in _OPTIONAL:
            continue
        if f.name == "v_final" and isinstance(value, str):
            if value != "auto":
                raise SettingError(f.name, "a float in [0, inf), 'auto' or None", value)
            continue
        if f.name in _INT_MIN:
            put(f.name, _check_int(f.name, value))
        elif f.name in _REAL_RANGE:
            _check_real(f.name, value)
        elif f.name in _CHOICES and value not in _CHOICES[f.name]:
            raise SettingError(f.name, f"one of {_CHOICES[f.name]}", value)
    return put


def _check_acquisition(value: Any) -> None:
    if isinstance(value, str):
        if value not in ACQUISITIONS:
            raise SettingError("acquisition", f"one of {tuple(ACQUISITIONS)} or a factory", value)
    elif not callable(value):
        raise SettingError("acquisition", "a name, a factory(model, context) or None", value)


@dataclass(frozen=True)
class OptimizerSettings:
    """Every option of the Bayesian optimizer, with its default (Sec. 6.3).

    Parameters
    ----------
    acquisition : str, callable or None
        A name of :data:`hypate.scaling.engine.acquisition.ACQUISITIONS`: ``"lcb"``,
        ``"ei"``, ``"poi"`` (one objective); ``"hvlcb"``, ``"hvei"``, ``"hvpoi"`` (indirect),
        ``"ws"`` (``g = 1``), ``"cheb"`` (``g = inf``), ``"wm"`` (``g``) (direct); or
        ``factory(model, context) -> Acquisition``. ``None``: THE default rule,
        :func:`~hypate.scaling.engine.acquisition.default_acquisition` (``"ei"`` for one
        objective, ``"hvlcb"`` for several).
    n_init : int >= 0
        Initial OLH samples (iteration 0).
    n_iter : int >= 0
        BO iterations (each proposes ``batch_size`` designs).
    batch_size : int >= 1
        ``q`` designs per iteration.
    batch_strategy : {"believer", "liar"}
        Kriging believer or constant liar (best value so far) fantasies within a batch.
    v : float >= 0 or None
        Exploration weight; ``None``: each acquisition's ``default_v`` (LCB and the direct
        approach 2.0, HVLCB 1.5, EI 0).
    v_final : float >= 0, "auto" or None
        Exploration weight of the last iteration: ``v`` (or the acquisition's default)
        at iteration 1 falls linearly to ``v_final`` at iteration ``n_iter``, exploration
        first and exploitation of the front last; ``"auto"``: the acquisition's
        ``default_v_final`` (HVLCB 0.5; the others none, i.e. constant); ``None``: ``v``
        throughout (the studies' default: their Ch. 9 figures were measured so).
    ref_point : sequence of m floats or None
        Hypervolume reference point; ``None``: nadir of the Pareto set + 10 % of its range.
    weights : sequence of m floats >= 0 or None
        ``c`` of Eq. (6.11) for the direct approach (default equal).
    g : float >= 1
        Exponent of the weighted metric for ``"wm"``.
    cheap_constraints : sequence of CheapConstraint
        Enforced exactly at every proposal.
    p_feasible : float in (0, 1)
        Required predicted probability of feasibility of each expensive constraint.
    p_success : float in (0, 1)
        Required predicted probability that a proposal's evaluation succeeds, by the
        classifier of the failed evaluations (:mod:`hypate.scaling.engine.failures`).
        Measured on a Branin whose half-box fails (the optimum near its edge; 10 + 20
        evaluations, seeds 0-2): failures after the initial design 40-60 % at 0.5, 15-20 %
        at 0.7, 5-10 % at 0.85 with the optimum found to 1e-5.
    kernel : {"matern52", "rbf"}
    n_restarts : int >= 0
        Restarts of each surrogate's likelihood optimization.
    n_raw, n_starts : int >= 1
        Raw OLH points and SLSQP starts of the inner optimization.
    min_distance : float >= 0
        Unit-box distance below which a candidate duplicates a sample.
    resolution : float in [0, 1)
        Radius, in length scales of the objective surrogates (their own input metric), of
        the inward probe at a bound: when the acquisition's best candidate lies that close
        to a sample on a bound of the box that has no sample near it off the bound, the
        proposal is the acquisition's best point of the inward half of the sphere of this
        radius around the sample (:func:`hypate.scaling.engine.inner.optimize_acquisition`)
        -- one evaluation that measures whether the objective falls inward, instead of a
        search that refines a bound point forever (Sec. 9.1). ``0`` disables the probe.
    seed : int >= 0
    max_evaluations : int >= 0 or None
        Stop after this many evaluations in the store (a budget).
    convergence_tol : float >= 0 or None
        Stop when the best value (one objective) or hypervolume improved by less than this
        (relative) over the last ``convergence_window`` iterations.
    convergence_window : int >= 0
    output_transform : {"none", "log"}
        ``"log"``: the surrogates model ``ln F`` (objectives must be positive, e.g. the
        relative errors J of Eq. 6.4) and the acquisition works in that space. An objective
        whose good values are orders of magnitude below its typical ones (a narrow valley of
        J ~ 1e-2 in a landscape of J ~ 1) is resolved far better; the transform is monotone,
        so best points and Pareto dominance are unchanged.
    coordinates : LogLinearCoordinates or None
        Input coordinates of the surrogates (all bounds must be positive); ``None``: the
        design variables themselves (scaled to the unit box).
    polish : int >= 0
        Evaluations of a final local search of the design-point score (the objective, or
        ``max_j J_j``; ``polish_method``) from the best feasible design (Nelder-Mead in
        ``coordinates``, or the unit box), each point clipped to the
        bounds and projected onto the cheap constraints, failures ranked last. A stationary
        kriging model spends its budget exploring when the optimum is a valley far narrower
        than the landscape (Sec. 9.1: ``lambda_F`` must match to ~1 % in a box spanning a
        factor 800); the polish converges on the valley floor. Stored as iteration
        ``n_iter + 1`` and replayed on resume.
    polish_method : {"nelder-mead", "gauss-newton"}
        The local search of the polish (:mod:`hypate.scaling.engine.polish`): a simplex
        search of ``max J``, or trust-region Gauss-Newton steps on the linearized histories
        the objectives are composed from (a problem with a ``composition()``; the simplex
        takes over when the trust region has collapsed).
    polish_step : float in (0, 0.5]
        Initial simplex edge, as a fraction of each coordinate's range.
    exploit_last : int >= 0
        The last iterations that propose the surrogates' best design point (the mean of
        ``max_j J_j`` over the objectives' samples, two or more objectives) instead of the
        acquisition's, each enforced constraint and the simulation's success required with
        probability ``p_exploit``.
    p_exploit : float in (0, 1)
    stopping : StoppingRule or None
        The stopping rule of ``iterations = "auto"`` (:mod:`hypate.scaling.engine.stopping`):
        ``n_iter`` is then the hard cap, and the run stops before an iteration when its
        design point has stalled, the surrogates predict it and nothing promises more
        (two or more objectives).
    surrogate : {"objectives", "histories"}
        What the objective surrogates model: the objectives themselves, or the histories
        they are composed from (:mod:`hypate.scaling.engine.histories`: POD + kriging of
        the problem's ``aux["histories"]``, J composed with its uncertainty sampled), for a
        problem whose ``composition()`` says how; a problem without one keeps
        ``"objectives"``.
    categorical : Categorical or None
        The categorical design variables (each one's level number ``0 .. k-1`` in the
        design vector, bounds ``[0, k - 1]``; :mod:`hypate.scaling.engine.mixed`): the
        surrogates see their one-hot indicators, the initial design stratifies them, every
        proposal enumerates their combinations. ``coordinates`` then describe the
        ``d - n_cat`` continuous variables; no polish.

    Raises
    ------
    SettingError
        A ``ValueError`` naming the field and its allowed range.
    """

    acquisition: str | AcquisitionFactory | None = None
    n_init: int = 10
    n_iter: int = 40
    batch_size: int = 1
    batch_strategy: Literal["believer", "liar"] = "believer"
    v: float | None = None
    v_final: float | Literal["auto"] | None = "auto"
    ref_point: Sequence[float] | None = None
    weights: Sequence[float] | None = None
    g: float = 2.0
    cheap_constraints: Sequence[CheapConstraint] = ()
    p_feasible: float = 0.5
    p_success: float = 0.85
    kernel: Literal["matern52", "rbf"] = "matern52"
    n_restarts: int = 2
    n_raw: int = 256
    n_starts: int = 5
    min_distance: float = 1e-5
    resolution: float = 0.05
    seed: int = 0
    max_evaluations: int | None = None
    convergence_tol: float | None = None
    convergence_window: int = 5
    output_transform: Literal["none", "log"] = "none"
    coordinates: LogLinearCoordinates | None = None
    polish: int = 0
    polish_method: Literal["nelder-mead", "gauss-newton"] = "nelder-mead"
    polish_step: float = 0.01
    categorical: Categorical | None = None
    surrogate: Literal["objectives", "histories"] = "objectives"
    stopping: StoppingRule | None = None
    exploit_last: int = 0
    p_exploit: float = 0.95

    def __post_init__(self) -> None:
        put = _check_fields(self)
        if self.acquisition is not None:
            _check_acquisition(self.acquisition)
        if self.ref_point is not None:
            put("ref_point", _check_vector("ref_point", self.ref_point, -math.inf))
        if self.weights is not None:
            put("weights", _check_vector("weights", self.weights, 0.0))
        cheap = tuple(self.cheap_constraints)
        if not all(isinstance(c, CheapConstraint) for c in cheap):
            raise SettingError("cheap_constraints", "a sequence of CheapConstraint",
                               self.cheap_constraints)
        put("cheap_constraints", cheap)
        if self.coordinates is not None and not isinstance(self.coordinates,
                                                           LogLinearCoordinates):
            raise SettingError("coordinates", "LogLinearCoordinates or None", self.coordinates)
        if self.categorical is not None and not isinstance(self.categorical, Categorical):
            raise SettingError("categorical", "Categorical or None", self.categorical)
        if self.stopping is not None and not isinstance(self.stopping, StoppingRule):
            raise SettingError("stopping", "StoppingRule or None", self.stopping)

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """The field names (the keyword overrides :class:`BayesianOptimizer` accepts)."""
        return tuple(f.name for f in dataclasses.fields(cls))


@dataclass(frozen=True)
class RunContext:
    """Where a run's evaluations run and go. A run's designs are the same with any
    executor, store, callback or BLAS threads (tested); a time limit can change them (a
    design it cuts off is stored as failed, and the failure is data for the proposals).

    Parameters
    ----------
    executor : object or None
        ``submit(fn, *args)`` -> future with ``.result(timeout)``; ``None`` evaluates
        in-process.
    timeout : float > 0 or None
        Seconds per evaluation, counted from its start in the evaluating process; the
        evaluation runs in a forked child that is killed at the limit (status
        ``"timeout"``; :func:`hypate.scaling.engine.problem.evaluate_design`).
    store : str, Path, EvaluationStore or None
        SQLite store; an existing one is resumed. ``None``: in memory.
    callback : callable or None
        ``callback(evaluation)`` after each committed evaluation; an exception stops the run
        (the store keeps everything committed).
    blas_threads : int >= 1 or None
        BLAS threads during proposals (surrogate matrices are small: threading only costs,
        and oversubscribes badly when evaluations run on the same cores); ``None`` leaves
        the setting alone.

    Raises
    ------
    SettingError
        A ``ValueError`` naming the field and its allowed range.
    """

    executor: Any = None
    timeout: float | None = None
    store: str | Path | EvaluationStore | None = None
    callback: Callable[[Evaluation], None] | None = None
    blas_threads: int | None = 1

    def __post_init__(self) -> None:
        _check_fields(self)
        if self.executor is not None and not callable(getattr(self.executor, "submit", None)):
            raise SettingError("executor", "None or an object with submit(fn, *args)",
                               self.executor)
        if self.store is not None and not isinstance(self.store, (str, Path, EvaluationStore)):
            raise SettingError("store", "a path, an EvaluationStore or None", self.store)
        if self.callback is not None and not callable(self.callback):
            raise SettingError("callback", "a callable or None", self.callback)

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """The field names (keyword overrides :class:`BayesianOptimizer` also accepts)."""
        return tuple(f.name for f in dataclasses.fields(cls))
