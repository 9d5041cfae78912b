"""Refined scaling laws from a sweep of scaled designs (Sec. 6.1.3, Fig. 9.4, Fig. 9.12).

A sweep study (``[sweep] xi = [...]``, see :mod:`hypate.scaling.workflow.vocabulary.study`) yields
one optimized design point per geometric scale ``xi = L_p / L_m``. For every continuous design
variable ``d`` the points are fitted by a power law

.. math:: d(\\xi) = c\\,\\xi^{k}

by least squares on ``ln d = ln c + k ln xi`` (with :mod:`cvxpy` when the study bounds ``k``
or asks for monotonicity: ``[laws] exponent_bounds`` / ``monotone``). The 95 % interval of
``k`` is ``k +- t_{0.975, n-2} s / sqrt(S_xx)`` from the residuals (Student t); two points
determine the law exactly and give no interval. Points where the variable sits on one of its
bounds (within 1e-3 of the span, as :meth:`ScalingProblem.active_bounds`) are *pinned*: the
law is flagged ``at_bound`` and fitted on the free points only (no fit with fewer than two).

Analytical exponents (dimensional analysis; the fitted ``k`` is reported next to them):

==============  =====  ===================================================================
variable        k      origin
==============  =====  ===================================================================
h               -1     h/L matched (Eq. 9.2a)
L, L_le         -1     geometric similarity
p_inf           0      Eq. 9.2b, ``xi^3 D_m/D_p`` with ``D ~ h^3`` at ``h_p/xi`` (fixed
                       model material)
delta_T         0      Eq. 9.2c, ``xi^2 (D_m/D_p)(N_Tp/N_Tm)`` with ``N_T ~ h``
M, p0, T0,      0      flow similarity at every scale (tunnel / radiant-heater settings are
T_inf, T_rad,          intensive), unless ``[laws] analytical.NAME`` says otherwise
emissivity,
p_ext,                 (``T_rad[k]``, the control points of a heater schedule: each is
T_rad[k]               T_rad at a matched nondimensional time, its own law with k = 0)
time_step       -2     model time step, Fourier number (Eq. 9.5/9.6, ``t ~ L^2 rho c/k``);
                -1     with structural time scaling (Eq. 9.3: ``L^2 sqrt(I/D) ~ L^2/h``)
==============  =====  ===================================================================

The analytical *coefficients* (the analytical line of Fig. 9.4/9.12) are the prototype's
values (``h_p``, ``L_p``, ``L_le^p``, M, p0, T0, T_inf, emissivity) and Eq. 9.2b/9.2c/9.3 at
``xi = 1`` for ``p_inf``, ``delta_T`` and the structural time step.

:func:`predict` turns the laws into the design at a new scale, its similarity table and
(optionally) its simulated ``J_u``, ``J_T``; the sweep runner seeds a new scale's initial
sample with the same prediction (:func:`hypate.scaling.workflow.campaigns.sweep.run_sweep`).

Their exponent table, the Fig. 9.4/9.12-style figure and the report section are in
:mod:`hypate.scaling.report.laws`.
"""
from __future__ import annotations

import json
import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cvxpy as cp
import numpy as np
from hypate.scaling.engine.problem import project_cheap
from hypate.scaling.workflow.campaigns.integrity import verify_run
from hypate.scaling.workflow.campaigns.rundir import DESIGN_POINT_JSON, SWEEP_JSON
from hypate.scaling.workflow.vocabulary.configuration import nominal_values
from hypate.scaling.workflow.vocabulary.derived import study_at, study_data
from hypate.scaling.workflow.vocabulary.objectives import ModelFailure
from hypate.scaling.workflow.vocabulary.problem import ScalingProblem
from hypate.scaling.workflow.vocabulary.similarity import (
    analytical_scaling,
    reference_quantities,
    time_scale,
)
from hypate.scaling.workflow.vocabulary.study import load_study
from hypate.scaling.workflow.vocabulary.variables import CATEGORICAL, DESIGN_VARIABLES, base_name
from hypate.solvers.errors import InputError
from scipy import stats

#: Analytical exponents of the design variables (table in the module docstring): their
#: rows' ``exponent`` (scaling.workflow.vocabulary.variables).
ANALYTICAL_EXPONENTS: dict[str, float] = {n: v.exponent for n, v in DESIGN_VARIABLES.items()
                                          if v.exponent is not None}
#: Analytical exponent of the model time step by time scaling (Eqs. 9.3, 9.5/9.6).
TIME_EXPONENTS: dict[str, float] = {"fourier": -2.0, "fourier_thickness": -2.0,
                                    "structural": -1.0}
#: Name of the derived time-step law.
TIME_STEP = "time_step"
#: Relative distance to a bound (of the span) below which a value is pinned.
PIN_RTOL = 1e-3


@dataclass(frozen=True)
class PowerLawFit:
    """``c * xi**k`` fitted on ``n`` points, with the 95 % interval of ``k``.

    ``exponent_low``/``exponent_high`` are None for two points (exact fit, no residual
    degrees of freedom) or for no fit at all (``coefficient`` None).
    """

    coefficient: float | None
    exponent: float | None
    exponent_low: float | None
    exponent_high: float | None
    n: int
    method: str = "lstsq"
    note: str = ""

    def __call__(self, xi: float | np.ndarray) -> float | np.ndarray:
        if self.coefficient is None or self.exponent is None:
            raise ValueError("no law was fitted")
        return self.coefficient * np.asarray(xi, float) ** self.exponent


@dataclass(frozen=True)
class ScalingLaw:
    """The refined law of one variable next to its analytical law.

    Attributes
    ----------
    variable : str
    fit : PowerLawFit
    analytical_exponent : float or None
    analytical_coefficient : float or None
        Value at ``xi = 1`` of the analytical law (None: no analytical line).
    at_bound : bool
        Some design point sits on a bound of this variable (pinned, not fitted).
    xi, values, pinned : tuple
        The design points used (all of them; ``pinned[i]`` marks the bound-pinned ones).
    """

    variable: str
    fit: PowerLawFit
    analytical_exponent: float | None
    analytical_coefficient: float | None = None
    at_bound: bool = False
    xi: tuple[float, ...] = ()
    values: tuple[float, ...] = ()
    pinned: tuple[bool, ...] = ()

    def to_json(self) -> dict[str, Any]:
        """The public ``hypate laws --json`` record."""
        f = self.fit
        return {"variable": self.variable, "coefficient": f.coefficient,
                "exponent": f.exponent, "exponent_low": f.exponent_low,
                "exponent_high": f.exponent_high,
                "analytical_exponent": self.analytical_exponent,
                "at_bound": bool(self.at_bound)}

    def analytical(self, xi: float | np.ndarray) -> float | np.ndarray | None:
        """The analytical law at ``xi`` (None without a coefficient)."""
        if self.analytical_coefficient is None or self.analytical_exponent is None:
            return None
        return self.analytical_coefficient * np.asarray(xi, float) ** self.analytical_exponent


@dataclass(frozen=True)
class DesignPoint:
    """One finished sweep point: scale, design, bounds and objectives."""

    xi: float
    design: Mapping[str, float]
    bounds: Mapping[str, tuple[float, float]] = field(default_factory=dict)
    objectives: Mapping[str, float] = field(default_factory=dict)
    label: str = ""
    time_step: float | None = None
    #: The chosen model material of a study with a categorical one (None: fixed).
    material: str | None = None


def materials_by_scale(points: Sequence[DesignPoint]) -> list[dict[str, Any]]:
    """``[{"xi", "material"}]`` of the points whose study chose the model material: a
    categorical value has no power law, the laws report the choice per scale."""
    return [{"xi": float(p.xi), "material": p.material} for p in points
            if p.material is not None]


# -- fitting --------------------------------------------------------------------------------
def fit_power_law(xi: Sequence[float], values: Sequence[float], *,
                  exponent_bounds: tuple[float, float] | None = None,
                  confidence: float = 0.95) -> PowerLawFit:
    """Fit ``values = c * xi**k`` by log-linear least squares.

    Parameters
    ----------
    xi, values : sequence of float
        Positive scales and values (same length).
    exponent_bounds : (float, float), optional
        Bounds on ``k`` (monotonicity is ``(0, inf)`` or ``(-inf, 0)``); solved with cvxpy
        as a constrained least-squares problem, the interval is intersected with them.
    confidence : float
        Level of the interval of ``k`` (Student t on the residuals, ``n - 2`` dof).

    Returns
    -------
    PowerLawFit
    """
    x = np.asarray(xi, float)
    y = np.asarray(values, float)
    if x.shape != y.shape:
        raise ValueError("xi and values need the same length")
    if np.any(x <= 0) or np.any(y <= 0) or not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        raise ValueError("a power law needs positive finite xi and values")
    n = len(x)
    if n < 2 or np.ptp(x) == 0.0:
        return PowerLawFit(None, None, None, None, n, "none",
                           f"{n} point(s) at distinct scales: no law")
    lx, ly = np.log(x), np.log(y)
    method = "lstsq"
    if exponent_bounds is None:
        k, a = np.polyfit(lx, ly, 1)
    else:
        k, a = _constrained_fit(lx, ly, exponent_bounds)
        method = "cvxpy"
    if n == 2:
        return PowerLawFit(float(math.exp(a)), float(k), None, None, n, method,
                           "2 points: exact fit, no confidence interval")
    resid = ly - (a + k * lx)
    dof = n - 2
    s2 = float(resid @ resid) / dof
    sxx = float(np.sum((lx - lx.mean()) ** 2))
    half = float(stats.t.ppf(0.5 + 0.5 * confidence, dof)) * math.sqrt(s2 / sxx)
    lo, hi = k - half, k + half
    if exponent_bounds is not None:
        lo, hi = max(lo, exponent_bounds[0]), min(hi, exponent_bounds[1])
    return PowerLawFit(float(math.exp(a)), float(k), float(lo), float(hi), n, method)


def _constrained_fit(lx: np.ndarray, ly: np.ndarray, bounds: tuple[float, float]
                     ) -> tuple[float, float]:
    """Least squares on ``ly = a + k lx`` with ``lo <= k <= hi`` (cvxpy)."""

    a, k = cp.Variable(), cp.Variable()
    cons = []
    if math.isfinite(bounds[0]):
        cons.append(k >= bounds[0])
    if math.isfinite(bounds[1]):
        cons.append(k <= bounds[1])
    prob = cp.Problem(cp.Minimize(cp.sum_squares(a + k * lx - ly)), cons)
    prob.solve()
    if prob.status not in ("optimal", "optimal_inaccurate") or k.value is None:
        raise ArithmeticError(f"constrained power-law fit failed: {prob.status}")
    assert a.value is not None  # solved (optimal): a's value is set with k's
    return float(k.value), float(a.value)


def is_pinned(value: float, bounds: tuple[float, float] | None, rtol: float = PIN_RTOL) -> bool:
    """True when ``value`` sits on a bound (within ``rtol`` of the span)."""
    if bounds is None:
        return False
    lo, hi = bounds
    span = hi - lo
    return bool(value <= lo + rtol * span or value >= hi - rtol * span)


def fit_laws(points: Sequence[DesignPoint], *, variables: Sequence[str] | None = None,
             analytical: Mapping[str, tuple[float | None, float | None]] | None = None,
             exponent_bounds: Mapping[str, Sequence[float]] | None = None,
             monotone: Mapping[str, str] | None = None,
             confidence: float = 0.95) -> list[ScalingLaw]:
    """Refined scaling laws of a sweep's design points.

    Parameters
    ----------
    points : sequence of DesignPoint
        Finished points (one per scale; several per scale are allowed).
    variables : sequence of str, optional
        Variables to fit (default: the design variables of the first point, in order, plus
        :data:`TIME_STEP` when every point has a model time step).
    analytical : mapping name -> (coefficient, exponent), optional
        Analytical laws (default: :data:`ANALYTICAL_EXPONENTS`, no coefficients).
    exponent_bounds : mapping name -> (lo, hi), optional
    monotone : mapping name -> "increasing" | "decreasing", optional
        Constrained fits (cvxpy).
    confidence : float

    Returns
    -------
    list of ScalingLaw
    """
    points = list(points)
    if variables is None:
        variables = list(points[0].bounds or points[0].design) if points else []
        if points and all(p.time_step is not None for p in points):
            variables.append(TIME_STEP)
    variables = [n for n in variables if n not in CATEGORICAL]  # see materials_by_scale
    exponent_bounds = dict(exponent_bounds or {})
    for name, direction in (monotone or {}).items():
        lo, hi = exponent_bounds.get(name, (-math.inf, math.inf))
        exponent_bounds[name] = ((max(lo, 0.0), hi) if direction == "increasing"
                                 else (lo, min(hi, 0.0)))
    laws = []
    for name in variables:
        xs, ys, pins = [], [], []
        for p in points:
            value = p.time_step if name == TIME_STEP else p.design.get(name)
            if value is None or not math.isfinite(float(value)):
                continue
            xs.append(float(p.xi))
            ys.append(float(value))
            pins.append(is_pinned(float(value), p.bounds.get(name)) if name in p.bounds
                        else False)
        free = [i for i, pin in enumerate(pins) if not pin]
        bnd = exponent_bounds.get(name)
        if any(y <= 0 for y in ys):
            fit = PowerLawFit(None, None, None, None, len(ys), "none",
                              "non-positive values: no power law")
        else:
            fit = fit_power_law([xs[i] for i in free], [ys[i] for i in free],
                                exponent_bounds=None if bnd is None else (float(bnd[0]),
                                                                          float(bnd[1])),
                                confidence=confidence)
            if any(pins):
                fit = PowerLawFit(fit.coefficient, fit.exponent, fit.exponent_low,
                                  fit.exponent_high, fit.n, fit.method,
                                  (f"{sum(pins)} bound-pinned point(s) not fitted; "
                                   + fit.note).rstrip("; "))
        key = base_name(name)  # a schedule's T_rad[k] has T_rad's analytical law
        if analytical is not None and key in analytical:
            a_coef, a_exp = analytical[key]
        else:
            a_coef, a_exp = None, (ANALYTICAL_EXPONENTS.get(key))
        laws.append(ScalingLaw(variable=name, fit=fit, analytical_exponent=a_exp,
                               analytical_coefficient=a_coef, at_bound=any(pins),
                               xi=tuple(xs), values=tuple(ys), pinned=tuple(pins)))
    return laws


# -- analytical laws of a study -------------------------------------------------------------
def analytical_laws(study: Any) -> dict[str, tuple[float | None, float | None]]:
    """Analytical ``(coefficient, exponent)`` of every law of a study (module table).

    Parameters
    ----------
    study : scaling.study.Study
        Any point of the sweep (the prototype and the model template do not depend on xi).
    """

    spec = study.spec
    proto = spec.prototype
    values = nominal_values(proto)  # the prototype's own values, read through the rows
    coef: dict[str, float | None] = {
        n: values.get(n) if DESIGN_VARIABLES[n].coefficient == "prototype" else None
        for n in ANALYTICAL_EXPONENTS}
    coef[TIME_STEP] = None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            an = analytical_scaling(proto, spec.model, 1.0, time_step=spec.simulation.time_step)
            coef["p_inf"] = an.pressure                                     # Eq. (9.2b)
            coef["delta_T"] = an.delta_T                                    # Eq. (9.2c)
            if spec.time_scaling == "structural":
                coef[TIME_STEP] = an.time_step                              # Eq. (9.3)
            else:
                coef[TIME_STEP] = spec.simulation.time_step * time_scale(   # (9.6)/(6.5)
                    reference_quantities(proto), reference_quantities(an.model),
                    spec.time_scaling)
        except (ValueError, ArithmeticError, TypeError) as exc:
            warnings.warn(f"analytical laws unavailable: {exc}", RuntimeWarning, stacklevel=2)
    overrides = dict(study.raw.laws.analytical) if study.raw is not None else {}
    out: dict[str, tuple[float | None, float | None]] = {}
    names = list(ANALYTICAL_EXPONENTS) + [TIME_STEP]
    for name in names:
        k = TIME_EXPONENTS[spec.time_scaling] if name == TIME_STEP else ANALYTICAL_EXPONENTS[name]
        c = coef.get(name)
        if name in overrides:
            k, c = float(overrides[name]), (c if float(overrides[name]) == k else None)
        out[name] = (None if c is None else float(c), k)
    return out


# -- sweep run directories ------------------------------------------------------------------
@dataclass
class SweepRun:
    """A sweep run directory read back: study data, finished points and the laws' options."""

    directory: Path
    study_data: dict[str, Any]
    points: list[DesignPoint]
    records: list[dict[str, Any]]

    def study(self, xi: float | None = None) -> Any:
        """The single study at scale ``xi`` (default: the first point's)."""

        return study_at(self.study_data, xi=xi if xi is not None else
                        (self.points[0].xi if self.points else None))


def point_from_record(rec: Mapping[str, Any], default_xi: float | None = None
                       ) -> DesignPoint | None:
    design = rec.get("design")
    if not design:
        return None
    xi = rec.get("xi", default_xi)
    if xi is None:
        return None
    bounds = {k: (float(v[0]), float(v[1])) for k, v in (rec.get("bounds") or {}).items()}
    return DesignPoint(xi=float(xi), design={k: float(v) for k, v in design.items()},
                       bounds=bounds, objectives=dict(rec.get("objectives") or {}),
                       label=str(rec.get("label", "")), time_step=rec.get("model_time_step"),
                       material=(rec.get("material") or {}).get("name"))


def load_sweep(run_dir: str | Path) -> SweepRun:
    """Read a sweep run directory (``sweep.json`` written by ``hypate run``).

    Raises
    ------
    InputError
        No ``sweep.json`` in ``run_dir``, or a finished point whose store or outputs were
        changed after the run wrote them (:func:`~.integrity.verify_run`).
    """

    run_dir = Path(run_dir)
    path = run_dir / SWEEP_JSON
    if not path.is_file():
        raise InputError("RUN_DIR", f"{run_dir} holds no sweep (no {SWEEP_JSON}); run a study "
                         "with a [sweep] table first")
    data = json.loads(path.read_text())
    records = list(data.get("points", []))
    for rec in records:  # each finished point's store and outputs, before they are read
        if rec.get("status") == "done" and isinstance(rec.get("directory"), str):
            verify_run(run_dir / rec["directory"])
    points = [p for rec in records if rec.get("status") == "done"
              and (p := point_from_record(rec)) is not None]
    return SweepRun(directory=run_dir, study_data=data["study_data"], points=points,
                    records=records)


def load_runs(run_dirs: Sequence[str | Path]) -> SweepRun:
    """Several single-study run directories (``design_point.json`` each, e.g. the Sec. 9.2.2
    studies ``sec9_2_2_xi{2..5}``) read back as one sweep; a single sweep directory is read
    with :func:`load_sweep`.

    The runs must share the prototype, the model template and the design variables (their
    studies may differ only in ``xi``, name, description and optimizer settings); the laws'
    options and the analytical table come from the first run's study file.

    Raises
    ------
    InputError
        A directory without ``design_point.json``, a missing study file, or runs of
        different scaling problems.
    """

    dirs = [Path(d) for d in run_dirs]
    if len(dirs) == 1 and (dirs[0] / SWEEP_JSON).is_file():
        return load_sweep(dirs[0])
    points: list[DesignPoint] = []
    records: list[dict[str, Any]] = []
    reference: dict[str, Any] | None = None
    for d in dirs:
        verify_run(d)  # its store matches its digests, its outputs the store
        path = d / DESIGN_POINT_JSON
        if not path.is_file():
            raise InputError("RUN_DIR", f"{d} holds neither a sweep ({SWEEP_JSON}) nor a "
                             "finished run (design_point.json)")
        rec = json.loads(path.read_text())
        try:
            data = study_data(load_study(rec["study_path"]))
        except (KeyError, OSError) as exc:
            raise InputError("RUN_DIR", f"{d}: the run's study file is unavailable: {exc}") \
                from exc
        problem = {k: data.get(k) for k in ("prototype", "model", "tunnel", "variables",
                                             "simulation", "constraints")}
        problem["kind"] = data["study"].get("kind")
        if reference is None:
            reference, first = problem, data
        elif problem != reference:
            raise InputError("RUN_DIR", f"{d} is a different scaling problem from {dirs[0]} "
                             "(prototype, model, tunnel, variables or simulation differ)")
        rec = {**rec, "label": rec.get("study", d.name), "status": "done"}
        records.append(rec)
        if (point := point_from_record(rec)) is not None:
            points.append(point)
    if len({p.xi for p in points}) != len(points):
        raise InputError("RUN_DIR", "two runs at the same geometric scale xi")
    points.sort(key=lambda p: p.xi)
    first = dict(first)
    first.pop("sweep", None)
    return SweepRun(directory=dirs[0], study_data=first, points=points, records=records)


def laws_of_run(run: SweepRun) -> list[ScalingLaw]:
    """The refined laws of a sweep run, with the study's ``[laws]`` options and its
    analytical table."""
    study = run.study()
    opts = study.raw.laws
    return fit_laws(run.points, analytical=analytical_laws(study),
                    exponent_bounds={k: tuple(v) for k, v in opts.exponent_bounds.items()},
                    monotone=dict(opts.monotone))


def predicted_design(laws: Sequence[ScalingLaw], points: Sequence[DesignPoint], xi: float,
                     names: Sequence[str]) -> dict[str, float]:
    """Design the laws predict at ``xi``.

    A fitted variable follows its law; one without a fit (pinned or fewer than two free
    points) takes the value of the point nearest in ``log xi``, moved along the analytical
    exponent; a categorical material is the nearest point's.
    """
    by_name = {law.variable: law for law in laws}
    nearest = min(points, key=lambda p: abs(math.log(p.xi / xi)))
    out = {}
    for name in names:
        law = by_name.get(name)
        if name in CATEGORICAL:
            out[name] = float(nearest.design[name])
        elif law is not None and law.fit.coefficient is not None:
            out[name] = float(law.fit(xi))
        else:
            k = (law.analytical_exponent if law is not None else None)
            k = ANALYTICAL_EXPONENTS.get(name, 0.0) if k is None else k
            out[name] = float(nearest.design[name]) * (xi / nearest.xi) ** k
    return out


def predict(run: SweepRun, xi: float, *, evaluate: bool = False,
            laws: Sequence[ScalingLaw] | None = None) -> dict[str, Any]:
    """The design the refined laws predict at a new scale, its similarity table and,
    with ``evaluate``, its simulated objectives (no optimization).

    Returns
    -------
    dict
        ``xi``, ``design`` (name -> value, clipped to the study's bounds at ``xi`` and
        projected on its cheap equalities), ``clipped`` (names moved onto a bound),
        ``active_constraints``, ``similarity`` (records of
        :meth:`ScalingProblem.similarity`) and, with
        ``evaluate``, ``objectives`` (J_u, J_T, J_s) or ``evaluation_error``.
    """

    if not run.points:
        raise InputError("RUN_DIR", f"{run.directory}: no finished sweep point to predict from")
    laws = laws_of_run(run) if laws is None else laws
    study = run.study(xi)
    problem = ScalingProblem(study.spec)
    names = study.spec.names
    raw = predicted_design(laws, run.points, xi, names)
    x0 = np.array([raw[n] for n in names])
    x = project_cheap(problem, x0)
    span = problem.xu - problem.xl
    clipped = [n for n, a, b in zip(names, x0, x) if abs(a - b) > 1e-9 * span[names.index(n)]]
    material = problem.material_name(x)
    out: dict[str, Any] = {"xi": float(xi), "design": problem.design(x),
                           **({} if material is None else {"material": material}),
                           "clipped": clipped,
                           "active_constraints": problem.active_bounds(x),
                           "similarity": problem.similarity(x)}
    if evaluate:
        try:
            out["objectives"] = problem.errors(x)
        except (ModelFailure, ArithmeticError, RuntimeError) as exc:
            out["objectives"] = None
            out["evaluation_error"] = str(exc)
    return out


def laws_json(laws: Sequence[ScalingLaw], prediction: Mapping[str, Any] | None,
              points: Sequence[DesignPoint] = ()) -> dict[str, Any]:
    """The public ``hypate laws --json`` document (``materials``: the chosen model
    material per scale, :func:`materials_by_scale`, when the study chose it)."""
    out = {"laws": [law.to_json() for law in laws],
           "prediction": None if prediction is None else dict(prediction)}
    if chosen := materials_by_scale(points):
        out["materials"] = chosen
    return out


__all__ = ["ANALYTICAL_EXPONENTS", "TIME_EXPONENTS", "TIME_STEP", "DesignPoint", "PowerLawFit",
           "ScalingLaw", "SweepRun", "analytical_laws", "fit_laws", "fit_power_law",
           "is_pinned", "laws_json", "laws_of_run", "load_sweep", "materials_by_scale",
           "predict", "predicted_design"]
