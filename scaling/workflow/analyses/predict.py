"""Full-scale prediction from a wind-tunnel test (``hypate predict``): measured model
histories mapped onto the prototype through the design point's nondimensionalization, with
an error band from the design point's residual mismatch, its propagated scatter and the
measurement's own deviation.

The measured file's contract and its reading are :mod:`.measured`. Size: about 650 lines,
most of them this docstring (the mapping and the band) and the sweep's basis; the basis,
the band and the outputs share one set of run-directory facts.

The mapping (Sec. 9.2.1.1, Eqs. 6.4, 9.3, 9.5-9.6)
-----------------------------------------------------
The run compared the model's nondimensional response with the prototype's step by step:
step ``k`` of the model (time ``k dt_m``) matches step ``k`` of the prototype (time
``k dt_p``), ``dt_m`` following from ``dt_p`` by the Fourier number (Eq. 9.6, the time form
of Eq. 9.5), Eq. (6.5) or the structural time (Eq. 9.3) -- ``design_point.json``
``model_time_step``; the deflection was compared as ``w / h`` and the temperature as
``T / T0`` (J_u, J_T of Eq. 6.4, Sec. 9.2.1.1) with the thickness ``h`` and stagnation
temperature ``T0`` of each run's own response. The prediction inverts exactly that:

.. math::

    t^p = t^m \\, \\Delta t^p / \\Delta t^m, \\qquad
    w^p = (w^m / h^m) \\, h^p, \\qquad
    T^p = (T^m / T_0^m) \\, T_0^p,

with ``h`` and ``T0`` read from the responses the objective compared (``design_point.npz``
and ``prototype.npz``), ``dt_m`` from ``design_point.json`` and ``dt_p`` from the study the
run ran (its store's campaign record, else its study file), checked against the prototype
response's own clock.

The band (:func:`band_parts`)
----------------------------
The prediction error splits, in nondimensional units, as

.. math::

    \\hat u_{pred} - \\hat u^p = (\\hat u_{meas} - \\hat u^m_{sim})
                              + (\\hat u^m_{sim} - \\hat u^p_{sim}),

the measurement's deviation from the design point's simulated model, plus the design
point's residual mismatch ``r_k`` -- the history whose relative RMS over steps
``1 .. n-1`` *is* J (Eq. 6.4; ``RMS(r) = J RMS(u^p)``). The residual at the nominal design
is deterministic: a drift with one sign over long stretches of the history, not noise. Its
bound is its largest value over the matched steps, ``B = max_k |r_k| = c J RMS(u^p)`` (``c``
the residual's crest factor; step 0 included: the band covers the whole test). The random
parts -- the article's and the tunnel's scatter and the measurement's deviation -- are
independent and are combined root-sum-square, each at the two-sided 95 % normal quantile
``z = 1.96``; they add *linearly* to the bias bound:

.. math:: H = B + z \\sqrt{\\sigma_s^2 + \\sigma_m^2}

(a root-sum-square of the bias with the random parts would leave points where noise and
bias add up outside the band -- about half of those near the largest residual). The parts:

* ``sigma_s`` (propagated scatter): ``std(J) RMS(u^p)``, the standard deviation of the
  residual's RMS under the study's ``[uncertainty]`` -- ``design_point.json`` ``robust``
  (a robust run) or ``scatter`` block, ``objectives.J_u.std`` / ``J_T.std``; when that std
  is infinite (failed scattered models) the interdecile estimate ``(q90 - q10) / 2.563``;
  left out (and said so) without a usable block;
* ``sigma_m`` (measurement): the RMS of the measured nondimensional history minus the design
  point's simulated model interpolated at the measured times -- the noise, and whatever the
  simulator misses of the real test (the scatter of the built article shows here too, so
  with both parts the band is on the safe side).

By the triangle inequality ``|u_pred - u^p| <= |dev| + B``, so a point leaves the band only
where the deviation exceeds its 95 % range *and* the residual is near its largest value. The
band is constant in time; in prototype units ``H h_p`` (m) and ``H T0_p`` (K).

Another size (``--xi``, :func:`sweep_basis`)
--------------------------------------------
A sweep run's refined laws (Sec. 6.1.3, :mod:`.laws`) give the model design at a new scale
``xi``; :func:`sweep_basis` simulates that design once against the sweep's prototype and the
prediction proceeds as above with it in place of the design point: the measured file is a
test of the model the laws give at ``xi`` (``hypate laws SWEEP --predict XI``), and the
prototype is the sweep's.
"""
from __future__ import annotations

import contextlib
import io
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from statistics import NormalDist
from typing import Any

import numpy as np
import pandas as pd
from hypate.scaling.engine.store import EvaluationStore, StoreError
from hypate.scaling.workflow.campaigns.integrity import verify_run
from hypate.scaling.workflow.campaigns.laws import load_sweep
from hypate.scaling.workflow.campaigns.laws import predict as law_design
from hypate.scaling.workflow.campaigns.rundir import (
    DESIGN_POINT_JSON,
    DESIGN_POINT_NPZ,
    PREDICTION_CSV,
    PREDICTION_JSON,
    PROTOTYPE_NPZ,
    STORE,
    SWEEP_JSON,
    finite,
    json_default,
)
from hypate.scaling.workflow.vocabulary.measured import COLUMNS, Measured, column_error
from hypate.scaling.workflow.vocabulary.objectives import ModelFailure, relative_rms
from hypate.scaling.workflow.vocabulary.problem import ScalingProblem
from hypate.scaling.workflow.vocabulary.study import load_study
from hypate.solvers.coupling.response import Response
from hypate.solvers.errors import InputError
from hypate.solvers.numerics.files import (
    atomic_file,
    ensure_directory,
    refuse_link,
    same_content,
)

__all__ = ["COVERAGE", "BandParts", "Basis", "PredictedHistory", "Prediction", "Scaling",
           "band_parts", "check_clock", "check_span", "design_point_basis", "predict",
           "prediction_summary", "prediction_table", "scatter_sigma", "study_time_step",
           "sweep_basis", "sweep_root", "write_prediction"]

#: Two-sided 95 % quantile of the standard normal distribution (the random parts' factor).
COVERAGE = NormalDist().inv_cdf(0.975)
#: ``q90 - q10`` of a normal distribution in standard deviations (interdecile estimate).
INTERDECILE = 2.0 * NormalDist().inv_cdf(0.9)
#: Relative slack of the test-span check (clock rounding, ms -> s).
SPAN_RTOL = 1e-9
#: Relative slack of the band's edge in the in-band count (rounding of the unit conversions).
EDGE_RTOL = 1e-9
#: Relative agreement asked of the prototype response's clock with ``k dt_p``.
CLOCK_RTOL = 1e-9


# -- what the prediction maps through ----------------------------------------------------
@dataclass(frozen=True)
class Scaling:
    """The design point's nondimensionalization (SI units; module docstring).

    Attributes
    ----------
    model_thickness, prototype_thickness : float
        ``h_m``, ``h_p`` (m): the deflection reference of J_u.
    model_stagnation_temperature, prototype_stagnation_temperature : float
        ``T0_m``, ``T0_p`` (K): the temperature reference of J_T.
    model_time_step, prototype_time_step : float
        ``dt_m`` (Eq. 9.6, 6.5 or 9.3 of the run) and ``dt_p`` (the study's), s.
    """

    model_thickness: float
    prototype_thickness: float
    model_stagnation_temperature: float
    prototype_stagnation_temperature: float
    model_time_step: float
    prototype_time_step: float

    @property
    def time_ratio(self) -> float:
        """``dt_p / dt_m``: prototype seconds per model second at matched nondimensional
        time (the inverse of Eq. 9.6's factor)."""
        return self.prototype_time_step / self.model_time_step

    def reference(self, name: str, side: str) -> float:
        """The reference quantity of a history (``"center_deflection"``: h,
        ``"mean_temperature"``: T0) on ``side`` ``"model"`` or ``"prototype"``."""
        key = "thickness" if name == "center_deflection" else "stagnation_temperature"
        return float(getattr(self, f"{side}_{key}"))

    def prototype_time(self, model_time: np.ndarray) -> np.ndarray:
        """``t_p = t_m dt_p / dt_m`` (Eqs. 9.5-9.6 inverted; step k to step k)."""
        return np.asarray(model_time, float) * self.time_ratio

    def nondimensional(self, name: str, values: np.ndarray, side: str = "model") -> np.ndarray:
        """``w / h`` or ``T / T0`` (Sec. 9.2.1.1) of a history on one side."""
        return np.asarray(values, float) / self.reference(name, side)

    def to_prototype(self, name: str, model_values: np.ndarray) -> np.ndarray:
        """``w_p = (w_m / h_m) h_p`` or ``T_p = (T_m / T0_m) T0_p``."""
        return self.nondimensional(name, model_values) * self.reference(name, "prototype")


@dataclass(frozen=True)
class Basis:
    """A design and what a prediction through it needs.

    Attributes
    ----------
    source : str
        ``"design point"`` or ``"refined laws at xi = X"``.
    run_dir : Path
    xi : float
        Geometric scale of the design.
    design : dict
    scaling : Scaling
    model, prototype : Response
        The design's simulated model and the prototype (matched step by step).
    scatter : dict or None
        A propagation block (``objectives.J_u/J_T``: mean, std, q10 ... q90) or None.
    scatter_source : str
        Where ``scatter`` comes from (or why there is none).
    """

    source: str
    run_dir: Path
    xi: float
    design: dict[str, float]
    scaling: Scaling
    model: Response
    prototype: Response
    scatter: dict[str, Any] | None = None
    scatter_source: str = "none"

    @property
    def steps(self) -> int:
        """Matched time points (step 0 included)."""
        return min(len(self.model.times), len(self.prototype.times))

    @property
    def model_span(self) -> float:
        """End of the model's test (s): the last matched model time."""
        return float(self.model.times[self.steps - 1])

    def history(self, name: str, side: str) -> np.ndarray:
        """A simulated history over the matched steps (SI units)."""
        resp = self.model if side == "model" else self.prototype
        return np.asarray(getattr(resp, name), float)[:self.steps]

    def times(self, side: str) -> np.ndarray:
        resp = self.model if side == "model" else self.prototype
        return np.asarray(resp.times, float)[:self.steps]


def _read_json(path: Path) -> dict[str, Any]:
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise InputError("RUN_DIR", f"{path}: not readable as JSON ({exc})") from None
    if not isinstance(data, dict):
        raise InputError("RUN_DIR", f"{path}: not a design-point record")
    return data


def _load_response(path: Path, what: str) -> Response:
    if not path.is_file():
        raise InputError("RUN_DIR", f"{path.parent} has no {path.name} ({what}); a finished "
                         "`hypate run` writes it")
    return Response.load(path)


def study_time_step(run_dir: Path, point: Mapping[str, Any]) -> float:
    """The prototype time step the run used: the study's ``[simulation] time_step`` as the
    run's store recorded it (``meta`` ``campaign``), else from the study file at
    ``design_point.json`` ``study_path``."""
    store = run_dir / STORE
    if store.is_file():
        try:
            with EvaluationStore(store, read_only=True) as st:
                record = st.get_meta("campaign")
        except StoreError:
            record = None
        sim = record.get("simulation") if isinstance(record, dict) else None
        step = sim.get("time_step") if isinstance(sim, dict) else None
        if isinstance(step, int | float) and math.isfinite(step) and step > 0:
            return float(step)
    path = point.get("study_path")
    if isinstance(path, str) and Path(path).is_file():
        return float(load_study(path).spec.simulation.time_step)
    raise InputError("RUN_DIR", f"{run_dir}: the prototype's time step is unknown (no "
                     "campaign record in the store and the study file is not found)")


def check_clock(resp: Response, time_step: float, what: str) -> None:
    """A response's times must be ``k * time_step`` (the step the mapping assumes)."""
    t = np.asarray(resp.times, float)
    k = np.arange(t.size)
    if t.size < 2 or not np.allclose(t, k * time_step, rtol=CLOCK_RTOL, atol=0.0):
        raise InputError("RUN_DIR", f"{what} was not simulated with the time step "
                         f"{time_step:.9g} s the mapping uses")


def _scatter_block(point: Mapping[str, Any]) -> tuple[dict[str, Any] | None, str]:
    for key in ("robust", "scatter"):
        block = point.get(key)
        if isinstance(block, dict):
            if block.get("status", "ok") == "ok" and isinstance(block.get("objectives"), dict):
                return block, f"design_point.json {key}"
            return None, f"design_point.json {key}: {block.get('status', 'no objectives')}"
    return None, "none (the study has no [uncertainty])"


def design_point_basis(run_dir: str | Path) -> Basis:
    """The run's design point as a :class:`Basis` (files of :mod:`.rundir`).

    Raises
    ------
    InputError
        Field ``RUN_DIR``: no finished design point (``design_point.json`` with a design
        and ``model_time_step``, ``design_point.npz``, ``prototype.npz``), a sweep directory,
        responses whose clocks do not match the recorded time steps, or a store or output
        changed after the run wrote it (:func:`~.integrity.verify_run`).
    """
    run_dir = Path(run_dir)
    verify_run(run_dir)  # its store matches its digests, its outputs the store
    path = run_dir / DESIGN_POINT_JSON
    if not path.is_file():
        hint = (" (a sweep: give one point's directory, or --xi X)"
                if (run_dir / SWEEP_JSON).is_file() else "")
        raise InputError("RUN_DIR", f"{run_dir} holds no design point ({DESIGN_POINT_JSON})"
                         + hint)
    point = _read_json(path)
    dt_m = point.get("model_time_step")
    if not point.get("design") or not isinstance(dt_m, int | float) or not dt_m > 0:
        raise InputError("RUN_DIR", f"{path}: no simulated design point (design and "
                         "model_time_step); the run found no successful design or its "
                         f"response was not saved ({point.get('design_point_response', '')})")
    model = _load_response(run_dir / DESIGN_POINT_NPZ, "the design point's response")
    proto = _load_response(run_dir / PROTOTYPE_NPZ, "the prototype's response")
    dt_p = study_time_step(run_dir, point)
    check_clock(model, float(dt_m), f"{run_dir / DESIGN_POINT_NPZ}")
    check_clock(proto, dt_p, f"{run_dir / PROTOTYPE_NPZ}")
    scatter, where = _scatter_block(point)
    return Basis(source="design point", run_dir=run_dir, xi=float(point.get("xi") or 1.0),
                 design={k: float(v) for k, v in point["design"].items()},
                 scaling=_scaling(model, proto, float(dt_m), dt_p), model=model,
                 prototype=proto, scatter=scatter, scatter_source=where)


def _scaling(model: Response, proto: Response, dt_m: float, dt_p: float) -> Scaling:
    return Scaling(model_thickness=model.thickness, prototype_thickness=proto.thickness,
                   model_stagnation_temperature=model.stagnation_temperature,
                   prototype_stagnation_temperature=proto.stagnation_temperature,
                   model_time_step=dt_m, prototype_time_step=dt_p)


def sweep_root(run_dir: str | Path) -> Path:
    """The sweep directory of ``run_dir`` (itself, or the sweep whose point it is).

    Raises
    ------
    InputError
        Field ``xi``: neither ``run_dir`` nor its parent holds ``sweep.json``.
    """
    run_dir = Path(run_dir)
    for d in (run_dir, run_dir.parent):
        if (d / SWEEP_JSON).is_file():
            return d
    raise InputError("xi", f"{run_dir} is not a sweep run (no {SWEEP_JSON}): another size "
                     "needs the refined scaling laws of a study with a [sweep] table")


def sweep_basis(run_dir: str | Path, xi: float) -> Basis:
    """The design the refined laws of a sweep give at scale ``xi``, simulated once against
    the sweep's prototype (Sec. 6.1.3; :func:`hypate.scaling.workflow.campaigns.laws.predict`).

    The design is clipped to the study's bounds at ``xi`` and projected on its cheap
    equalities; its model runs on the time step of the study's time mapping (Eq. 9.6 or
    9.3) for that design. The scatter is the nearest sweep point's (in ``log xi``), if any.

    Raises
    ------
    InputError
        Field ``xi``: not a sweep run, ``xi`` below 1, a sweep over flight conditions, no
        finished point, or the laws' design fails to simulate.
    """
    if not (math.isfinite(xi) and xi >= 1.0):
        raise InputError("xi", f"must be a geometric scale >= 1; got {xi:g}")
    root = sweep_root(run_dir)
    run = load_sweep(root)
    if not run.points:
        raise InputError("xi", f"{root}: no finished sweep point to fit laws on")
    if len({(r.get("mach"), r.get("altitude")) for r in run.records}) > 1:
        raise InputError("xi", f"{root} sweeps flight conditions: its laws are not laws of "
                         "the geometric scale alone")
    done = [r for r in run.records if r.get("status") == "done"]
    nearest = min(done, key=lambda r: abs(math.log(float(r["xi"]) / xi)))
    point_dir = root / str(nearest["directory"])
    proto = _load_response(point_dir / PROTOTYPE_NPZ, "the sweep's prototype response")
    study = run.study(xi)
    dt_p = float(study.spec.simulation.time_step)
    check_clock(proto, dt_p, f"{point_dir / PROTOTYPE_NPZ}")
    predicted = law_design(run, xi)
    problem = ScalingProblem(study.spec, prototype_response=proto)
    x = np.array([predicted["design"][n] for n in study.spec.names])
    config = problem.model_configuration(x)
    try:
        model = problem.checked_response(config)
    except (ModelFailure, ArithmeticError, RuntimeError) as exc:
        raise InputError("xi", f"the refined laws' design at xi = {xi:g} does not simulate "
                         f"to a comparable response: {exc}") from None
    point = _read_json(point_dir / DESIGN_POINT_JSON) \
        if (point_dir / DESIGN_POINT_JSON).is_file() else {}
    scatter, where = _scatter_block(point)
    if scatter is not None:
        where = f"the nearest sweep point {nearest['label']} ({where})"
    return Basis(source=f"refined laws at xi = {xi:g}", run_dir=root, xi=float(xi),
                 design=dict(predicted["design"]),
                 scaling=_scaling(model, proto, float(config.simulation.time_step), dt_p),
                 model=model, prototype=proto, scatter=scatter, scatter_source=where)


# -- the band ----------------------------------------------------------------------------
@dataclass(frozen=True)
class BandParts:
    """The parts of one history's band, nondimensional (module docstring).

    Attributes
    ----------
    J : float
        Relative RMS residual of the design point over steps 1 .. n-1 (Eq. 6.4 as J_u with
        the centre projection, J_T).
    rms_prototype : float
        RMS of the prototype's nondimensional history over those steps.
    residual : float
        ``B = max_k |r_k|`` over the matched steps.
    scatter : float or None
        ``sigma_s``; None without a usable scatter block.
    scatter_statistic : str
        ``"std"``, ``"interdecile"`` or ``"none"``.
    measurement : float
        ``sigma_m``.
    """

    J: float
    rms_prototype: float
    residual: float
    scatter: float | None
    scatter_statistic: str
    measurement: float

    @property
    def crest_factor(self) -> float:
        """``B / RMS(r)``: how far the largest residual is above its RMS."""
        rms = self.J * self.rms_prototype
        return self.residual / rms if rms > 0.0 else math.nan

    @property
    def random(self) -> float:
        """``z sqrt(sigma_s^2 + sigma_m^2)``: the random parts at 95 %."""
        return COVERAGE * math.hypot(self.scatter or 0.0, self.measurement)

    @property
    def half_width(self) -> float:
        """``H = B + z sqrt(sigma_s^2 + sigma_m^2)``."""
        return self.residual + self.random


#: design_point.json objective of each history.
OBJECTIVE = {"center_deflection": "J_u", "mean_temperature": "J_T"}


def scatter_sigma(block: Mapping[str, Any] | None, objective: str) -> tuple[float | None, str]:
    """The spread of J under the scatter: its std, else the interdecile estimate
    ``(q90 - q10) / 2.563``; ``(None, "none")`` when neither is finite."""
    stats = ((block or {}).get("objectives") or {}).get(objective) or {}
    std = stats.get("std")
    if isinstance(std, int | float) and math.isfinite(std):
        return float(std), "std"
    q10, q90 = stats.get("q10"), stats.get("q90")
    if isinstance(q10, int | float) and isinstance(q90, int | float) \
            and math.isfinite(q10) and math.isfinite(q90):
        return (float(q90) - float(q10)) / INTERDECILE, "interdecile"
    return None, "none"


def band_parts(basis: Basis, name: str, measured_time: np.ndarray,
               measured_values: np.ndarray) -> BandParts:
    """The band of history ``name`` (``"center_deflection"`` or ``"mean_temperature"``)
    for measured model values (SI) at model times ``measured_time``."""
    sc = basis.scaling
    um = sc.nondimensional(name, basis.history(name, "model"), "model")
    up = sc.nondimensional(name, basis.history(name, "prototype"), "prototype")
    J = relative_rms(um[1:], up[1:])                                    # Eq. (6.4)
    rms_p = float(np.sqrt(np.mean(up[1:] ** 2))) if up.size > 1 else 0.0
    residual = float(np.max(np.abs(um - up)))
    std, statistic = scatter_sigma(basis.scatter, OBJECTIVE[name])
    sim = np.interp(measured_time, basis.times("model"), um)
    dev = sc.nondimensional(name, measured_values, "model") - sim
    return BandParts(J=J, rms_prototype=rms_p, residual=residual,
                     scatter=None if std is None else std * rms_p,
                     scatter_statistic=statistic,
                     measurement=float(np.sqrt(np.mean(dev ** 2))))


# -- the prediction ----------------------------------------------------------------------
@dataclass(frozen=True)
class PredictedHistory:
    """One predicted prototype history (SI units).

    Attributes
    ----------
    name : str
    unit : str
    predicted : ndarray of shape (n,)
    half_width : float
        ``H`` times the prototype reference (m or K).
    parts : BandParts
    simulated : ndarray of shape (n,)
        The simulated prototype interpolated at the predicted times.
    """

    name: str
    unit: str
    predicted: np.ndarray
    half_width: float
    parts: BandParts
    simulated: np.ndarray

    @property
    def lower(self) -> np.ndarray:
        return self.predicted - self.half_width

    @property
    def upper(self) -> np.ndarray:
        return self.predicted + self.half_width

    @property
    def inside(self) -> np.ndarray:
        """Boolean (n,): the simulated prototype lies within the band (its edge included,
        up to :data:`EDGE_RTOL`: the step of the largest residual sits on the edge of a
        noise-free prediction)."""
        return np.abs(self.simulated - self.predicted) <= self.half_width * (1.0 + EDGE_RTOL)

    @property
    def in_band(self) -> float:
        """Fraction of the time points where the simulated prototype is inside the band."""
        return float(np.mean(self.inside))


@dataclass(frozen=True)
class Prediction:
    """A full-scale prediction from a measured model test.

    Attributes
    ----------
    basis : Basis
    measured : Measured
    model_time, time : ndarray of shape (n,)
        Measured model time and the matched prototype time (s).
    histories : dict
        Name -> :class:`PredictedHistory` (the measured ones).
    """

    basis: Basis
    measured: Measured
    model_time: np.ndarray
    time: np.ndarray
    histories: dict[str, PredictedHistory] = field(default_factory=dict)


def check_span(measured: Measured, basis: Basis) -> None:
    """The measured time must lie within the model's test ``[0, t_end]``."""
    end = basis.model_span
    tol = SPAN_RTOL * end
    t = measured.time
    if t[0] < -tol or t[-1] > end + tol:
        raise column_error(measured.path, measured.headers["time"],
                            f"the measured span [{t[0]:.6g}, {t[-1]:.6g}] s is outside the "
                            f"model's test span [0, {end:.6g}] s ({basis.steps - 1} steps of "
                            f"{basis.scaling.model_time_step:.6g} s at the {basis.source})")


def predict(basis: Basis, measured: Measured) -> Prediction:
    """Map a measured model test onto the prototype (module docstring).

    Raises
    ------
    InputError
        Field ``measured``: the measured time leaves the model's test span.
    """
    check_span(measured, basis)
    sc = basis.scaling
    time = sc.prototype_time(measured.time)
    out: dict[str, PredictedHistory] = {}
    for name, values in measured.histories.items():
        parts = band_parts(basis, name, measured.time, values)
        ref = sc.reference(name, "prototype")
        simulated = np.interp(time, basis.times("prototype"), basis.history(name, "prototype"))
        out[name] = PredictedHistory(name=name, unit=COLUMNS[name],
                                     predicted=sc.to_prototype(name, values),
                                     half_width=parts.half_width * ref, parts=parts,
                                     simulated=simulated)
    return Prediction(basis=basis, measured=measured, model_time=measured.time, time=time,
                      histories=out)


def prediction_table(pred: Prediction) -> pd.DataFrame:
    """``prediction.csv``: ``time [s]`` (prototype), ``model_time [s]``, and per measured
    history ``NAME [U]``, ``NAME_lower [U]``, ``NAME_upper [U]``, ``simulated_NAME [U]``
    (U = m or K)."""
    cols: dict[str, np.ndarray] = {"time [s]": pred.time, "model_time [s]": pred.model_time}
    for name, h in pred.histories.items():
        cols[f"{name} [{h.unit}]"] = h.predicted
        cols[f"{name}_lower [{h.unit}]"] = h.lower
        cols[f"{name}_upper [{h.unit}]"] = h.upper
        cols[f"simulated_{name} [{h.unit}]"] = h.simulated
    return pd.DataFrame(cols)


def prediction_summary(pred: Prediction, files: Mapping[str, str | Path] | None = None
                       ) -> dict[str, Any]:
    """The JSON summary (``prediction.json``, ``hypate predict --json``)."""
    b, sc = pred.basis, pred.basis.scaling
    hist = {}
    for name, h in pred.histories.items():
        p, ref = h.parts, sc.reference(name, "prototype")
        hist[name] = {
            "unit": h.unit, "half_width": h.half_width,
            "residual": p.residual * ref, "scatter": None if p.scatter is None
            else COVERAGE * p.scatter * ref, "measurement": COVERAGE * p.measurement * ref,
            "scatter_statistic": p.scatter_statistic, "J": p.J,
            "crest_factor": p.crest_factor, "in_band": h.in_band,
            "model_reference": sc.reference(name, "model"), "prototype_reference": ref}
    return finite({
        "run_dir": str(b.run_dir), "measured": str(pred.measured.path), "source": b.source,
        "xi": b.xi, "design": b.design, "points": int(pred.time.size),
        "model_time_step": sc.model_time_step, "prototype_time_step": sc.prototype_time_step,
        "time_ratio": sc.time_ratio, "model_span": [0.0, b.model_span],
        "prototype_span": [float(pred.time[0]), float(pred.time[-1])],
        "coverage": COVERAGE, "scatter_source": b.scatter_source,
        "histories": hist, "files": {k: str(v) for k, v in (files or {}).items()}})


def write_prediction(pred: Prediction, out: str | Path,
                     files: Mapping[str, bytes] | None = None) -> dict[str, Any]:
    """Write ``prediction.csv``, ``prediction.json`` and ``files`` (name -> bytes, e.g. the
    figure and the page) into ``out``: every file goes to a temporary beside it first (never
    through a link, :func:`~hypate.solvers.numerics.files.atomic_file`) and all are
    renamed once all are written, so an error leaves no half-written file. Returns the
    summary."""
    out = Path(out)
    names = [PREDICTION_CSV, PREDICTION_JSON, *(files or {})]
    summary = prediction_summary(pred, {n.rsplit(".", 1)[-1]: out / n for n in names})
    buf = io.StringIO()
    prediction_table(pred).to_csv(buf, index=False)
    payload = {PREDICTION_CSV: buf.getvalue().encode(),
               PREDICTION_JSON: json.dumps(summary, indent=2, default=json_default,
                                           allow_nan=False).encode(), **(files or {})}
    for name in payload:
        refuse_link(out / name)
        if (out / name).is_dir():
            raise InputError("out", f"{out / name} is a directory")
    ensure_directory(out)
    # every changed file to its temporary first; the renames follow once all are written
    with contextlib.ExitStack() as stack:
        for name, data in payload.items():
            if not same_content(out / name, data):
                stack.enter_context(atomic_file(out / name)).write(data)
    return summary
