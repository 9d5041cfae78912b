"""Tunnel scatter, fabrication tolerances and material uncertainty of a model design
(``[uncertainty]`` / ``[robust]`` of a study; Sec. 10.2's robust design, beyond the
dissertation).

Public keys::

    [uncertainty]
    p0 = { normal = 0.03 }            # relative standard deviation about the design value
    T0 = { uniform = 0.02 }           # relative half-width
    h = { normal = 0.02 }             # fabrication tolerance on the model thickness
    "model.youngs_modulus" = { normal = 0.03 }   # scale factor on the model material
    "model.conductivity" = { lognormal = 0.05 }  # standard deviation of the log
    emissivity = { uniform = 0.05 }
    [robust]
    statistic = "q90"    # per objective: "mean", "mean+2std", "q90"
    order = 2            # polynomial chaos degree
    samples = 64         # simulator runs per propagation (default: 2x the chaos terms)

Every entry is a factor on a nominal value (:mod:`hypate.scaling.engine.propagation`): a
design value of the study (a variable or a ``[fixed]`` value), a model/tunnel value the
template sets (read back through its design-variable row,
:func:`~hypate.scaling.workflow.vocabulary.configuration.nominal_values`), or a material property of
every model layer (:data:`MATERIAL_FACTORS`). ``T_rad`` of a study with a heater schedule
is one factor on every control point ``T_rad[k]`` (a heater bank's calibration scatters the
whole programme); a categorical ``material`` has no scatter (its properties do: ``model.NAME``).

The test is planned on the nominal design: the model time step (the time mapping, Eq. 9.6)
is the nominal design's, and the scatter acts on the article and the tunnel only -- a model
made 2 % thick runs on the nominal design's clock, as it would in the tunnel.

Propagation (:func:`propagate_design`) runs the simulator at scrambled-Sobol collocation
nodes and expands the *response histories* (centre deflection, mean temperature; POD of the
samples, then polynomial chaos of the POD coefficients), not J itself: J is a norm of the
history misfit and has a kink where the misfit vanishes, the histories are smooth in the
inputs. J_u, J_T and max(J_u, J_T) are then evaluated exactly from 8192 chaos samples; their
first-order Sobol indices come from a degree-4 chaos of those samples.
"""
from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Annotated, Any, Literal

import numpy as np
from hypate.scaling.engine.propagation import (
    DISTRIBUTIONS,
    ROBUST_STATISTICS,
    Expansion,
    Uncertain,
    collocation_nodes,
    default_samples,
    expansion_terms,
    robust_value,
    summary,
)
from hypate.scaling.workflow.vocabulary.configuration import Configuration, nominal_values
from hypate.scaling.workflow.vocabulary.objectives import (
    ModelFailure,
    relative_rms,
    response_series,
)
from hypate.scaling.workflow.vocabulary.problem import ScalingProblem
from hypate.scaling.workflow.vocabulary.variables import CATEGORICAL, schedule_point
from hypate.solvers import materials as mat
from hypate.solvers.config import InputModel
from hypate.solvers.errors import InputError
from pydantic import Field, model_validator

#: ``model.NAME`` factors: the material properties (lamina fields) each one scales.
MATERIAL_FACTORS = {
    "youngs_modulus": ("E1", "E2", "G12", "G13", "G23"),
    "conductivity": ("k1", "k2", "k3"),
    "density": ("density",),
    "specific_heat": ("specific_heat",),
    "expansion": ("alpha1", "alpha2"),
}
MODEL_PREFIX = "model."
#: Chaos samples on which J is evaluated (quantiles, Sobol indices): cheap, the surrogate.
SURROGATE_SAMPLES = 8192
#: Probabilities of the quantiles kept as the distribution of J (the report's CDF).
DISTRIBUTION_PROBABILITIES = np.linspace(0.01, 0.99, 50)
#: Degree of the chaos of J fitted for its Sobol indices.
SOBOL_ORDER = 4
#: Most uncertain inputs of a study (C(12 + 4, 4) = 1820 terms in the chaos of J).
MAX_INPUTS = 12
#: What a scattered model may raise instead of a response: counted as a failed node (a
#: scattered value outside its valid range -- emissivity above 1 -- or a solver failure).
NODE_FAILURES = (ModelFailure, InputError, ArithmeticError, RuntimeError)
#: Objective statistics reported: J_u, J_T and their maximum (the design-point rule).
REPORTED = ("J_u", "J_T", "J_max")
#: Largest leave-one-out error of the chaos's J at the nodes (RMS, relative to the nodes'
#: standard deviation of J) for its statistics to stand; above it -- or when a scattered
#: model failed (a divergence boundary inside the scatter: J jumps) -- the statistics are
#: the simulator samples' own (scrambled-Sobol quasi Monte Carlo), failures counted as
#: J = infinity.
CHAOS_TOLERANCE = 0.2


# -- study keys -------------------------------------------------------------------------
Width = Annotated[float, Field(gt=0.0)]


class UncertainEntry(InputModel):
    """One ``[uncertainty]`` entry: exactly one of the distribution keys."""

    normal: Width | None = None
    uniform: Width | None = None
    lognormal: Width | None = None

    @model_validator(mode="after")
    def _one(self) -> UncertainEntry:
        given = [k for k in DISTRIBUTIONS if getattr(self, k) is not None]
        if len(given) != 1:
            raise ValueError(f"give exactly one distribution of {', '.join(DISTRIBUTIONS)} "
                             "(a width: "
                             f"{'; '.join(f'{k}: {v}' for k, v in DISTRIBUTIONS.items())})")
        return self

    def uncertain(self, name: str) -> Uncertain:
        kind = next(k for k in DISTRIBUTIONS if getattr(self, k) is not None)
        try:
            return Uncertain(name, kind, float(getattr(self, kind)))
        except ValueError as exc:
            raise InputError(f"uncertainty.{name}", str(exc).split(": ", 1)[-1]) from None


class RobustSection(InputModel):
    statistic: Literal["mean", "mean+2std", "q90"] = "q90"
    order: Annotated[int, Field(ge=1, le=4)] = 2
    samples: Annotated[int, Field(ge=2, le=4096)] | None = None
    # robust optimization (scaling.workflow.campaigns.robust); a study without [robust] is nominal
    optimize: bool = True
    initial_samples: Annotated[int, Field(ge=0, le=1000)] = 10
    iterations: Annotated[int, Field(ge=0, le=10000)] | None = None


@dataclass(frozen=True)
class Uncertainty:
    """A study's uncertain inputs and robust settings."""

    inputs: tuple[Uncertain, ...]
    statistic: str = "q90"
    order: int = 2
    samples: int | None = None
    optimize: bool = False          # [robust] given: the design minimizes the statistic
    initial_samples: int = 10       # joint (design, inputs) samples of the robust search
    iterations: int | None = None   # its BO iterations (None: the study's)

    def __post_init__(self) -> None:
        if self.statistic not in ROBUST_STATISTICS:
            raise InputError("robust.statistic", f"must be one of {', '.join(ROBUST_STATISTICS)}")

    @property
    def names(self) -> list[str]:
        return [u.name for u in self.inputs]

    @property
    def n_samples(self) -> int:
        return self.samples or default_samples(len(self.inputs), self.order)


def parse_uncertainty(entries: dict[str, UncertainEntry], robust: RobustSection,
                      problem: ScalingProblem) -> Uncertainty | None:
    """Validate the ``[uncertainty]`` names against the study and build one scattered
    configuration (so that nothing fails later); ``None`` without entries."""
    if not entries:
        return None
    if len(entries) > MAX_INPUTS:
        raise InputError("uncertainty", f"at most {MAX_INPUTS} uncertain inputs (the chaos of "
                         f"J grows as C(d + 4, 4) terms); got {len(entries)}")
    x0 = np.array([0.5 * (v.lower + v.upper) for v in problem.spec.variables])
    design = problem.design(x0)
    nominal = nominal_values(problem.spec.model)
    inputs = []
    for name, entry in entries.items():
        if name.startswith(MODEL_PREFIX):
            if name[len(MODEL_PREFIX):] not in MATERIAL_FACTORS:
                raise InputError(f"uncertainty.{name}", "unknown material property; known: "
                                 + ", ".join(MODEL_PREFIX + k for k in MATERIAL_FACTORS))
        elif name in CATEGORICAL:
            raise InputError(f"uncertainty.{name}", "a categorical value has no scatter; "
                             "give its properties' (model.NAME)")
        elif name not in design and name not in nominal and not schedule_points(name, design):
            raise InputError(f"uncertainty.{name}", "not a design value of the study; known: "
                             + ", ".join(dict.fromkeys([*design, *nominal]))
                             + ", " + ", ".join(MODEL_PREFIX + k for k in MATERIAL_FACTORS))
        elif name not in design and nominal.get(name) == 0.0:  # e.g. no external pressure
            raise InputError(f"uncertainty.{name}", "the model's value is 0: a factor on it "
                             "scatters nothing; give it a value ([fixed]) or leave it out")
        inputs.append(entry.uncertain(name))
    unc = Uncertainty(tuple(inputs), robust.statistic, robust.order, robust.samples,
                      robust.optimize, robust.initial_samples, robust.iterations)
    terms = expansion_terms(len(inputs), robust.order)
    if robust.samples is not None and robust.samples < terms:
        raise InputError("robust.samples", f"must be at least {terms}, the number of terms of "
                         f"an order-{robust.order} chaos in {len(inputs)} inputs; got "
                         f"{robust.samples}")
    try:
        scattered_configuration(problem, x0, unc.names, np.ones(len(inputs)))
    except InputError as exc:
        raise InputError(f"uncertainty ({exc.field})", exc.message) from None
    return unc


# -- one scattered model ------------------------------------------------------------------
def schedule_points(name: str, design: Mapping[str, float]) -> list[str]:
    """The control points ``NAME[k]`` of a scheduled ``name`` in ``design`` (empty: none)."""
    return [n for n in design if (p := schedule_point(n)) is not None and p[0] == name]


def scaled_material(m: mat.Material, factors: dict[str, float]) -> mat.Material:
    """``m`` with the properties of :data:`MATERIAL_FACTORS` multiplied by ``factors``."""
    changes = {}
    for key, f in factors.items():
        for prop in MATERIAL_FACTORS[key]:
            value = getattr(m, prop)
            if value is not None:
                changes[prop] = value.scaled(f)
    return dataclasses.replace(m, **changes) if changes else m


def scattered_configuration(problem: ScalingProblem, x: np.ndarray | Sequence[float],
                            names: Sequence[str], factors: np.ndarray | Sequence[float]
                            ) -> Configuration:
    """The model of design ``x`` as built and tested with the inputs ``names`` multiplied
    by ``factors``, run on the nominal design's time step (the planned time mapping)."""
    nominal = problem.model_configuration(x)
    design = problem.design(x)
    template = nominal_values(nominal)  # read back once, not per scattered input
    changed: dict[str, float] = {}
    props: dict[str, float] = {}
    for name, f in zip(names, map(float, factors)):
        if name.startswith(MODEL_PREFIX):
            props[name[len(MODEL_PREFIX):]] = f
        elif name not in design and (points := schedule_points(name, design)):
            changed.update({p: design[p] * f for p in points})  # the whole schedule
        else:
            changed[name] = (design[name] if name in design else template[name]) * f
    config = problem.configure({**design, **changed})
    config = config.with_time_step(nominal.simulation.time_step)
    if props:
        panel = config.panel
        layers = tuple(dataclasses.replace(layer, material=scaled_material(layer.material, props))
                       for layer in panel.layers)
        config = dataclasses.replace(config, panel=dataclasses.replace(panel, layers=layers))
    return config


# -- propagation ----------------------------------------------------------------------------
@dataclass
class Samples:
    """Simulated histories at the collocation nodes (failed nodes left out)."""

    nodes: np.ndarray                    # (n_ok, d)
    series: dict[str, np.ndarray]        # name -> (n_ok, m) histories over steps 1 .. n-1
    prototype: dict[str, np.ndarray]     # name -> (m,)
    failed: list[str]                    # failure messages
    seconds: float


def simulate_scatter(problem: ScalingProblem, x: np.ndarray | Sequence[float], unc: Uncertainty,
                     nodes: np.ndarray, progress: Callable[[int, int], None] | None = None
                     ) -> Samples:
    """Simulate the scattered models at ``nodes`` (one simulator run each)."""
    t0 = time.perf_counter()
    proto = problem.prototype_response
    n = len(proto.times)
    projection = problem.spec.projection
    sp = {k: v[1:n].reshape(-1) for k, v in response_series(proto, projection).items()}
    rows: dict[str, list[np.ndarray]] = {k: [] for k in sp}
    ok, failed = [], []
    for i, f in enumerate(nodes):
        try:
            resp = problem.checked_response(scattered_configuration(problem, x, unc.names, f))
        except NODE_FAILURES as exc:
            failed.append(str(exc))
        else:
            for k, v in response_series(resp, projection).items():
                rows[k].append(v[1:n].reshape(-1))
            ok.append(i)
        if progress is not None:
            progress(i + 1, len(nodes))
    series = {k: np.array(v, float).reshape(len(ok), sp[k].size) for k, v in rows.items()}
    return Samples(nodes[ok], series, sp, failed, time.perf_counter() - t0)


def sample_errors(series: dict[str, np.ndarray], prototype: dict[str, np.ndarray]
                  ) -> dict[str, np.ndarray]:
    """J_u, J_T, J_max per sample row of simulated histories (as :func:`series_errors`)."""
    J = {k: np.array([relative_rms(row, prototype[k]) for row in v]) for k, v in series.items()}
    return _combine(J)


def _combine(J: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    if "u" in J:
        J_u = J["u"]
    else:  # the "fields" projection: RMS over the field groups
        J_u = np.sqrt(np.mean(np.square([J[k] for k in J if k != "T"]), axis=0))
    return {"J_u": J_u, "J_T": J["T"], "J_max": np.maximum(J_u, J["T"])}


class HistoryChaos:
    """Polynomial chaos of the response histories: per history, the POD of the samples
    (mean + orthonormal modes, all with energy) and a chaos of the modal coefficients.

    J of a chaos sample is exact in the modes: with ``y = mu + V a`` and the prototype
    history ``p``, ``|y - p|^2 = |mu - p|^2 + 2 a.(V^T (mu - p)) + |a|^2``.
    """

    def __init__(self, samples: Samples, unc: Uncertainty) -> None:
        self.unc = unc
        self.n_nodes = len(samples.nodes)
        self.parts = {}
        for k, Y in samples.series.items():
            mu = Y.mean(axis=0)
            _, s, Vt = np.linalg.svd(Y - mu, full_matrices=False)
            keep = s > 1e-12 * max(s[0], 1e-300) if s.size else np.zeros(0, bool)
            V = Vt[keep].T
            d = mu - samples.prototype[k]
            self.parts[k] = (V, float(d @ d), V.T @ d, float(np.linalg.norm(samples.prototype[k])),
                             Expansion(unc.inputs, samples.nodes, (Y - mu) @ V, unc.order)
                             if V.shape[1] else None)

    def errors(self, factors: np.ndarray) -> dict[str, np.ndarray]:
        """J_u, J_T, J_max at factor samples (n, d) -> arrays (n,)."""
        return self._errors({k: None if part[4] is None else part[4](factors)
                             for k, part in self.parts.items()}, len(factors))

    def leave_one_out(self) -> dict[str, np.ndarray]:
        """J at each node from the chaos fitted without that node."""
        return self._errors({k: None if part[4] is None else part[4].leave_one_out()
                             for k, part in self.parts.items()}, self.n_nodes)

    def _errors(self, coefficients: dict[str, np.ndarray | None], n: int
                ) -> dict[str, np.ndarray]:
        J = {}
        for k, (_, c0, b, norm_p, _) in self.parts.items():
            a = coefficients[k]
            sq = np.full(n, c0) if a is None else c0 + 2.0 * a @ b + np.sum(a * a, axis=1)
            num = np.sqrt(np.maximum(sq, 0.0))
            J[k] = num / norm_p if norm_p > 0.0 else num
        return _combine(J)


def propagate_design(problem: ScalingProblem, x: np.ndarray | Sequence[float], unc: Uncertainty,
                     samples: int | None = None, seed: int = 0,
                     progress: Callable[[int, int], None] | None = None) -> dict[str, Any]:
    """Propagate the study's uncertainty at design ``x`` on the simulator.

    Returns
    -------
    dict
        The public ``robust`` block: ``statistic``, ``samples`` (simulator runs),
        ``objectives`` (``J_u``, ``J_T``, ``J_max`` = max(J_u, J_T): each ``mean``, ``std``,
        ``q10``, ``q50``, ``q90`` and ``robust``, the statistic's value), ``sobol``
        (objective -> input -> first-order index, from the chaos), plus ``inputs`` (name ->
        distribution), ``order``, ``failed`` (count), ``failures`` (first messages),
        ``chaos_error`` (leave-one-out, :data:`CHAOS_TOLERANCE`), ``method`` (``"chaos"``,
        or ``"samples"`` when the chaos does not stand), ``sobol_valid`` (the Sobol indices
        come from the chaos: False with ``"samples"``), ``seconds``, ``distribution``
        (``probabilities`` and per objective its quantiles there: the CDF).
    """
    n = int(samples or unc.n_samples)
    nodes = collocation_nodes(unc.inputs, n, seed)
    sim = simulate_scatter(problem, x, unc, nodes, progress)
    out: dict[str, Any] = {"statistic": unc.statistic, "samples": n,
                           "inputs": {u.name: u.describe() for u in unc.inputs},
                           "order": unc.order, "failed": len(sim.failed),
                           "failures": sim.failed[:3], "seconds": sim.seconds}
    if len(sim.nodes) < expansion_terms(len(unc.inputs), unc.order):
        raise ModelFailure(f"{len(sim.failed)} of {n} scattered models failed ("
                           f"{sim.failed[0] if sim.failed else ''}): too few for an order-"
                           f"{unc.order} chaos")
    chaos = HistoryChaos(sim, unc)
    J_nodes = sample_errors(sim.series, sim.prototype)
    J_loo = chaos.leave_one_out()
    # relative to J's spread at the nodes (floored: an objective the scatter does not move
    # must not fail the check on rounding)
    error = max(float(np.sqrt(np.mean((J_loo[k] - J_nodes[k]) ** 2)))
                / max(float(np.std(J_nodes[k])), 1e-9 * abs(float(np.mean(J_nodes[k]))), 1e-300)
                for k in REPORTED)
    out["chaos_error"] = error
    out["method"] = "chaos" if error <= CHAOS_TOLERANCE and not sim.failed else "samples"
    F = collocation_nodes(unc.inputs, SURROGATE_SAMPLES, seed + 1)
    J = chaos.errors(F)
    objectives, distribution = {}, {"probabilities": DISTRIBUTION_PROBABILITIES.tolist()}
    for k in REPORTED:
        if out["method"] == "chaos":
            values = J[k]
        else:  # the simulator samples; a failed model is J = infinity
            values = np.r_[J_nodes[k], np.full(len(sim.failed), np.inf)]
        stats = summary(values)
        stats["robust"] = robust_value(stats, unc.statistic)
        objectives[k] = stats
        distribution[k] = np.quantile(values, DISTRIBUTION_PROBABILITIES,
                                      method="inverted_cdf").tolist()
    out["objectives"] = objectives
    out["distribution"] = distribution
    sobol = Expansion(unc.inputs, F, np.column_stack([J[k] for k in REPORTED]),
                      SOBOL_ORDER).first_order_sobol()
    out["sobol"] = {k: {u.name: float(max(sobol[i, j], 0.0)) for i, u in enumerate(unc.inputs)}
                    for j, k in enumerate(REPORTED)}
    # from the chaos: indicative only where the chaos does not hold
    out["sobol_valid"] = out["method"] == "chaos"
    return out


def propagate_or_failure(problem: ScalingProblem, x: np.ndarray | Sequence[float], unc: Uncertainty,
                         samples: int | None = None, seed: int = 0,
                         progress: Callable[[int, int], None] | None = None) -> dict[str, Any]:
    """:func:`propagate_design`, or ``{"status": "failed: ...", "samples", "statistic"}``
    when too many scattered models fail for a chaos: a design on a stability boundary is
    an answer, not a crash."""
    try:
        return {"status": "ok", **propagate_design(problem, x, unc, samples, seed, progress)}
    except ModelFailure as exc:
        return {"status": f"failed: {exc}", "statistic": unc.statistic,
                "samples": int(samples or unc.n_samples)}


def monte_carlo_design(problem: ScalingProblem, x: np.ndarray | Sequence[float], unc: Uncertainty,
                       samples: int = 256, seed: int = 0,
                       progress: Callable[[int, int], None] | None = None) -> dict[str, Any]:
    """The reference of :func:`propagate_design`: J statistics of ``samples`` scrambled-Sobol
    simulator runs directly (no chaos). Returns ``samples``, ``failed``, ``objectives``."""
    sim = simulate_scatter(problem, x, unc, collocation_nodes(unc.inputs, samples, seed),
                           progress)
    J = sample_errors(sim.series, sim.prototype)
    return {"samples": samples, "failed": len(sim.failed), "seconds": sim.seconds,
            "objectives": {k: summary(J[k]) for k in REPORTED}}


__all__ = ["MATERIAL_FACTORS", "RobustSection", "UncertainEntry", "Uncertainty",
           "monte_carlo_design", "parse_uncertainty", "propagate_design",
           "propagate_or_failure", "scattered_configuration"]
