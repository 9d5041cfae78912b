"""The scaling problem (Sec. 6.2, 9.1.2.2, 9.2.1): prototype vs wind-tunnel model.

A :class:`ScalingProblem` is a pymoo problem whose design vector sets the model and the
tunnel (names of :func:`hypate.scaling.workflow.vocabulary.configuration.apply_design`:
``p0``, ``T0``, ``M``, ``L``, ``L_le``, ``h``, ``emissivity``, ``T_rad``, ``p_ext``,
``p_inf``, ``delta_T``...). One evaluation simulates the model with the compact
aerothermoelastic simulator and compares its nondimensional response with the prototype's
(simulated once and cached) at matched nondimensional times: the model's time step follows
from the prototype's by the Fourier number (Eqs. 9.5-9.6 with the length scale, or Eq. 6.5
with the thickness; quasi-steady problems) or by the structural time (Eq. 9.3, transient
aeroelastic problems), and both runs take the same number of steps.

The objectives J_u, J_T, J_s and the histories they compare are :mod:`.objectives`.

Cheap equality constraints (Eq. 9.7), e.g. ``"T_inf"``: the model's free-stream temperature
ratio ``T_w / T_inf`` equals the prototype's, are analytic functions of the design vector
and are handed to the optimizer as :class:`~scaling.optimizer.CheapConstraint` with exact
gradients (log space). A heater schedule of shape ``"increasing"`` (``"decreasing"``)
(:mod:`hypate.scaling.workflow.vocabulary.design_space`) adds the linear inequalities
``T_rad[k] - T_rad[k+1] <= 0`` (``>= 0``) the same way.

A failed model simulation (no equilibrium, instability before the prototype's end, solver
divergence) raises :class:`ModelFailure`; the optimizer records it as a failed evaluation
with the reason and steers away from it (never a crash).

Admissibility (:mod:`hypate.scaling.workflow.vocabulary.admissibility`): the simulated checks in
``"constraint"`` mode (service temperature, property data, stress) are the problem's
expensive constraint columns ``G <= 0`` (relative violations), the analytic ones (size in
the free jet's core, test duration against the run time) further cheap inequalities; every
evaluation also returns, as its auxiliary outputs (``aux``), what the model went through
(:meth:`Response.extremes`), from which its admissibility rows are rebuilt.

What defines a problem (:class:`~hypate.scaling.workflow.vocabulary.spec.ScalingSpec`) is
:mod:`.spec`; the objectives, configuration, simulation and user's simulator have their own
modules.
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from hypate.scaling.engine.histories import HISTORIES, Composition
from hypate.scaling.engine.mixed import Categorical
from hypate.scaling.engine.problem import CheapConstraint
from hypate.scaling.workflow.vocabulary.admissibility import (
    Admissibility,
    analytic_rows,
    simulated_columns,
    size_value,
    stress_row,
    temperature_rows,
)
from hypate.scaling.workflow.vocabulary.configuration import (
    Configuration,
    apply_design,
    simulate_configuration,
    with_choice,
)
from hypate.scaling.workflow.vocabulary.external import (
    check_checks,
    external_response,
    load_simulator,
)
from hypate.scaling.workflow.vocabulary.objectives import (
    ModelFailure,
    history_vector,
    response_errors,
    response_series,
)
from hypate.scaling.workflow.vocabulary.similarity import (
    compare,
    comparison_records,
    reference_quantities,
    time_scale,
)
from hypate.scaling.workflow.vocabulary.spec import MATERIAL, ScalingSpec
from hypate.solvers.coupling.response import Response
from hypate.solvers.errors import InputError
from pymoo.core.problem import Problem

#: A design vector: the values of the problem's variables in order.
DesignVector = Sequence[float] | np.ndarray
#: Largest |deflection| / thickness of a meaningful response: beyond it the von Karman
#: (moderate rotation) shell model no longer holds and the run counts as diverged.
MAX_DEFLECTION = 50.0


class AnalyticCheck:
    """An analytic admissibility check of a scaling problem as a cheap inequality
    ``fun(x) <= 0`` (relative violation), with a forward-difference Jacobian (step
    :attr:`REL_STEP` of each bound's span, backward on the upper bound; the value at ``x`` is
    cached, as SLSQP asks for
    it and its Jacobian at the same point). Picklable: the inner SLSQP starts run on the
    run's workers.

    ``"size"``: ``(plate - (core - margin)) / core``, the model plate in the free jet's core;
    ``"duration"``: ``(test + injection - (run time - margin)) / run time``. The run time is
    a closed form of the setting; the test duration needs the model's matched time step
    (its reference quantities, the costly part), which depends on few variables (the
    panel's length and material for Eq. 9.6, not the tunnel setting): it is cached by the
    values of the variables it depends on, found once by moving each variable alone
    between two interior points of the box (a categorical variable always counts).
    """

    REL_STEP = 1e-6

    def __init__(self, problem: ScalingProblem, check: str) -> None:
        self.problem, self.check = problem, check
        self._cache: dict[bytes, float] = {}
        self._steps: dict[bytes, float] = {}
        self._step_inputs: list[int] | None = None

    def __getstate__(self) -> dict[str, Any]:
        return {"problem": self.problem, "check": self.check, "_cache": {}, "_steps": {},
                "_step_inputs": self._step_inputs}

    def _duration_inputs(self) -> list[int]:
        """The variables the test duration depends on (class docstring)."""
        if self._step_inputs is None:
            p = self.problem
            lo, hi = np.asarray(p.xl, float), np.asarray(p.xu, float)
            a, b = lo + 0.3 * (hi - lo), lo + 0.7 * (hi - lo)
            base = p.model_configuration(a).simulation.duration
            found = []
            for i in range(p.n_var):
                if i in p.spec.categorical_indices:
                    found.append(i)
                    continue
                moved = a.copy()
                moved[i] = b[i]
                if p.model_configuration(moved).simulation.duration != base:
                    found.append(i)
            self._step_inputs = found
        return self._step_inputs

    def test_duration(self, x: np.ndarray) -> float:
        """The scaled test's duration (s) of design ``x``, cached (class docstring)."""
        key = np.asarray(x, float)[self._duration_inputs()].tobytes()
        if key not in self._steps:
            if len(self._steps) > 256:
                self._steps.clear()
            self._steps[key] = self.problem.model_configuration(x).simulation.duration
        return self._steps[key]

    def margin(self, x: np.ndarray) -> float:
        """The relative violation at design ``x`` (<= 0: the check holds)."""
        p = self.problem
        rule = p.spec.admissibility.rule(self.check)
        tunnel = p.spec.tunnel
        assert tunnel is not None
        config = p.configure(p.design(x))
        if self.check == "size":
            plate, core = size_value(config.panel, tunnel, float(config.flow.mach))
            assert core is not None  # the check is made only for a tunnel's test section
            return (plate - (float(core) - rule.margin)) / max(float(core), 1e-12)
        run = tunnel.run_time_at(*p.setting(config))
        assert run is not None  # the check is made only for a tunnel's run time
        return (self.test_duration(x) + rule.injection_time - (run - rule.margin)) / run

    def _value(self, x: np.ndarray) -> float:
        key = np.asarray(x, float).tobytes()
        if key not in self._cache:
            if len(self._cache) > 64:
                self._cache.clear()
            self._cache[key] = float(self.margin(np.asarray(x, float)))
        return self._cache[key]

    def fun(self, x: np.ndarray) -> np.ndarray:
        return np.array([self._value(x)])

    def jac(self, x: np.ndarray) -> np.ndarray:
        p = self.problem
        x = np.asarray(x, float)
        f0 = self._value(x)
        span = np.asarray(p.xu, float) - np.asarray(p.xl, float)
        J = np.zeros((1, p.n_var))
        for i in range(p.n_var):
            if i in p.spec.categorical_indices:  # a level: no derivative
                continue
            # forward, or backward on the upper bound: a design past a bound may not exist
            # (an emissivity above 1 is refused)
            step = self.REL_STEP * span[i]
            if x[i] + step > p.xu[i]:
                step = -step
            xp = x.copy()
            xp[i] += step
            J[0, i] = (self._value(xp) - f0) / step
        return J

    def constraint(self) -> CheapConstraint:
        return CheapConstraint(fun=self.fun, jac=self.jac, kind="ineq")


def evaluate_rows(problem: ScalingProblem, configs: Sequence[Configuration],
                  out: dict[str, Any]) -> None:
    """Fill a pymoo output dictionary from one model simulation per configuration
    (:meth:`ScalingProblem.outputs`): ``F``, ``G`` (when the problem has constraint
    columns) and ``aux`` (one dict per row)."""
    F = np.empty((len(configs), problem.n_obj))
    G = np.empty((len(configs), problem.n_ieq_constr))
    aux = []
    for i, config in enumerate(configs):  # each one expensive simulation
        err, g, extra = problem.outputs(config)
        F[i] = [err[o] for o in problem.spec.objectives]
        G[i] = g
        aux.append(extra)
    out["F"] = F
    if problem.n_ieq_constr:
        out["G"] = G
    out["aux"] = aux


# -- the pymoo problem ----------------------------------------------------------------------
class ScalingProblem(Problem):
    """Prototype vs model as a pymoo problem (objectives minimized; the admissibility checks
    in ``"constraint"`` mode as expensive constraints ``G <= 0``, module docstring).

    Parameters
    ----------
    spec : ScalingSpec
    prototype_response : Response, optional
        A cached prototype response (computed on first use otherwise).
    """

    def __init__(self, spec: ScalingSpec, prototype_response: Response | None = None) -> None:
        self.spec = spec
        xl = np.array([v.lower for v in spec.variables])
        xu = np.array([v.upper for v in spec.variables])
        self._rules: Admissibility | None = None
        super().__init__(n_var=len(spec.variables), n_obj=len(spec.objectives),
                         n_ieq_constr=0, xl=xl, xu=xu)
        self._prototype_response = prototype_response
        if spec.admissibility.mode("stress") != "auto":
            self._settle(spec.admissibility)
        elif prototype_response is not None:
            self._settle(spec.admissibility.resolved(
                prototype_response.extremes()["max_stress_ratio"]))
        else:  # provisional until the prototype says whether the stress check applies
            self.n_ieq_constr = len([n for n in spec.admissibility.simulated_constraints
                                     if n != "stress"])
        self._ref_p = reference_quantities(spec.prototype)
        cats = spec.categorical_names
        #: The categorical variables for the optimizer (None: none).
        self.categorical = None if not cats else Categorical(
            tuple(spec.categorical_indices), tuple(len(spec.levels[n]) for n in cats))

    def _settle(self, rules: Admissibility) -> None:
        """Fix the admissibility rules and the constraint columns they make."""
        self._rules = rules
        self.n_ieq_constr = len(rules.simulated_constraints)

    @property
    def admissibility(self) -> Admissibility:
        """The study's checks with the stress check's ``"auto"`` decided by the prototype's
        own stress (the prototype is simulated if it was not yet)."""
        if self._rules is None:
            self.prototype_response  # noqa: B018 - settles the rules
        assert self._rules is not None
        return self._rules

    @property
    def constraint_names(self) -> tuple[str, ...]:
        """The checks behind the expensive constraint columns, in order."""
        return self.admissibility.simulated_constraints

    # -- prototype --------------------------------------------------------------------------
    @property
    def prototype_response(self) -> Response:
        """The prototype's response (simulated once, then cached)."""
        if self._prototype_response is None:
            resp = self.simulate(self.spec.prototype,
                                 keep_fields=self.spec.projection == "fields")
            if resp.status == "failed":
                raise InputError("prototype", f"the prototype simulation failed: {resp.message}")
            self._prototype_response = resp
        if self._rules is None:
            self._settle(self.spec.admissibility.resolved(
                self._prototype_response.extremes()["max_stress_ratio"]))
        return self._prototype_response

    # -- model --------------------------------------------------------------------------------
    def design(self, x: DesignVector) -> dict[str, float]:
        """Design dict (variables then fixed values) of a design vector; a categorical
        variable is its level number (:meth:`choice_names` names it)."""
        x = np.asarray(x, dtype=float).reshape(-1)
        if x.size != self.n_var:
            raise InputError("design", f"expected {self.n_var} values, got {x.size}")
        if self.categorical is not None:
            x = self.categorical.snap(x)[0]
        return {**self.spec.fixed, **dict(zip(self.spec.names, map(float, x)))}

    def choice_names(self, x: DesignVector) -> dict[str, str]:
        """Each categorical variable's value of design ``x`` by its study name."""
        if self.categorical is None:
            return {}
        levels = self.categorical.variable_levels(np.asarray(x, float))[0]
        return {name: self.spec.levels[name][int(k)][0]
                for name, k in zip(self.spec.categorical_names, levels)}

    def material_name(self, x: DesignVector) -> str | None:
        """The material of design ``x`` by its study name (None: not a design variable)."""
        return self.choice_names(x).get(MATERIAL)

    def configure(self, design: Mapping[str, float]) -> Configuration:
        """The model of a design dict (:meth:`design` form): the template with each
        categorical variable's chosen value (:func:`with_choice`: a material level makes
        the model of it), then :func:`apply_design` with the other values."""
        design = dict(design)
        template = self.spec.model
        for name, levels in self.spec.choices:
            level = round(design.pop(name))
            if not 0 <= level < len(levels):
                raise InputError(f"design.{name}", f"level must be in [0, "
                                 f"{len(levels) - 1}]; got {level}")
            template = with_choice(template, name, levels[level][1])
        return apply_design(template, design)

    def model_configuration(self, x: DesignVector) -> Configuration:
        """The model configuration of design vector ``x`` (DESIGN.md data flow), simulated
        with its matched time step (:meth:`model_time_step`), which is also the reference
        time of its similarity parameters."""
        config = self.configure(self.design(x))
        return config.with_time_step(self.model_time_step(config))

    def model_time_step(self, config: Configuration) -> float:
        """Model time step at matched nondimensional time (Eqs. 9.6, 6.5 or 9.3)."""
        return self.spec.simulation.time_step * time_scale(
            self._ref_p, reference_quantities(config), self.spec.time_scaling)

    def simulate_model(self, x: DesignVector, keep_fields: bool = False
                       ) -> tuple[Configuration, Response]:
        config = self.model_configuration(x)
        return config, self.simulate(config, keep_fields=keep_fields)

    def simulate(self, config: Configuration, keep_fields: bool = False) -> Response:
        """One configuration's response: hypate's simulator or the user's (``spec.simulator``,
        :mod:`~hypate.scaling.workflow.vocabulary.external`: checked to feed the checks that are
        on)."""
        if self.spec.simulator is None:
            return simulate_configuration(config, keep_fields=keep_fields)
        histories = load_simulator(self.spec.simulator)(config)
        resp = external_response(histories, config)  # refuses what is not the protocol's
        check_checks(histories, {r.name: r.mode for r in self.spec.admissibility.rules})
        return resp

    def errors(self, x: DesignVector) -> dict[str, float]:
        """J_u, J_T, J_s of one design; raises :class:`ModelFailure` when not comparable."""
        return self.outputs(self.model_configuration(x))[0]

    def outputs(self, config: Configuration) -> tuple[dict[str, float], np.ndarray,
                                                        dict[str, Any]]:
        """One model simulation's J (as :meth:`errors`), its expensive constraint columns
        (:func:`~hypate.scaling.workflow.vocabulary.admissibility.simulated_columns`) and its
        auxiliary outputs: ``{"extremes": Response.extremes()}``.

        Raises
        ------
        ModelFailure
            The response is not comparable with the prototype's.
        """
        proto = self.prototype_response
        resp = self.checked_response(config)
        err = response_errors(resp, proto, self.spec.projection)
        ext = resp.extremes()
        aux: dict[str, Any] = {"extremes": ext}
        if self.spec.projection != "fields":  # a fields projection's histories are fields
            aux[HISTORIES] = history_vector(response_series(resp, self.spec.projection),
                                            len(proto.times)).tolist()
        return err, simulated_columns(self.admissibility, config.panel, ext), aux

    def composition(self) -> Composition | None:
        """J as a composition of the model's nondimensional histories (the engine's
        histories surrogate, :mod:`hypate.scaling.engine.histories`): the histories vector
        of :func:`history_vector` (the ``"u"`` series, then ``"T"``, steps 1 .. n - 1, as
        J compares them), the prototype's as the targets, and each objective's weights
        over the two groups (Eqs. 6.4, 9.8: ``J_u^2 = ||u - u_p||^2 / ||u_p||^2``, ``J_T``
        alike, ``J_s^2`` their sum). None for the ``"fields"`` projection."""
        if self.spec.projection == "fields":
            return None
        proto = response_series(self.prototype_response, self.spec.projection)
        n = len(self.prototype_response.times)
        u, T = proto["u"][1:n].ravel(), proto["T"][1:n].ravel()
        groups = (np.arange(u.size), u.size + np.arange(T.size))
        inv = np.array([1.0 / max(float(u @ u), 1e-300), 1.0 / max(float(T @ T), 1e-300)])
        rows = {"J_u": [inv[0], 0.0], "J_T": [0.0, inv[1]], "J_s": [inv[0], inv[1]]}
        return Composition(targets=np.r_[u, T], groups=groups,
                           weights=np.array([rows[o] for o in self.spec.objectives]))

    def checked_response(self, config: Configuration) -> Response:
        """Simulate a model configuration; :class:`ModelFailure` unless its response is
        comparable with the prototype's (as long, stable while the prototype is, within
        the moderate-rotation model)."""
        proto = self.prototype_response
        resp = self.simulate(config, keep_fields=self.spec.projection == "fields")
        n_p = len(proto.times)
        if resp.status == "failed" or len(resp.times) < 2:
            raise ModelFailure(f"model simulation failed: {resp.message}")
        if len(resp.times) < n_p:
            raise ModelFailure(
                f"model {resp.instability_type or 'instability'} at step "
                f"{len(resp.times) - 1} of {n_p - 1} (the prototype "
                f"{'stays stable' if proto.status == 'completed' else 'lasts longer'}):"
                f" {resp.message}")
        w = np.abs(np.asarray(resp.center_deflection)) / resp.thickness
        modal = np.abs(np.asarray(resp.modal)) if resp.modal else np.zeros(1)
        if not (np.all(np.isfinite(w)) and w.max() <= MAX_DEFLECTION
                and np.all(np.isfinite(modal)) and modal.max() <= MAX_DEFLECTION):
            raise ModelFailure(f"model response diverged (deflection beyond {MAX_DEFLECTION:g} "
                               "thicknesses: outside the moderate-rotation shell model)")
        return resp

    def _evaluate(self, X: np.ndarray, out: dict[str, Any], *args: Any, **kwargs: Any) -> None:
        evaluate_rows(self, [self.model_configuration(x) for x in np.atleast_2d(X)], out)

    # -- admissibility ------------------------------------------------------------------------
    def setting(self, config: Configuration) -> tuple[float, float, float]:
        """The tunnel setting ``(M, p0, T0)`` (Pa, K) of a model configuration."""
        f = config.flow
        return float(f.mach), float(f.stagnation_pressure), float(f.stagnation_temperature)

    def admissibility_rows(self, config: Configuration, extremes: Mapping[str, Any] | None
                           ) -> list[dict[str, Any]]:
        """Every admissibility row of a model
        (:mod:`~hypate.scaling.workflow.vocabulary.admissibility`; the simulated ones only with the
        run's ``extremes``), in report order."""
        rules, panel = self.admissibility, config.panel
        rows: list[dict[str, Any]] = []
        if extremes is not None:
            rows += temperature_rows(rules, panel, extremes)
            srow = stress_row(rules, panel, extremes)
            rows += [] if srow is None else [srow]
        envelope = any(v.name in ("M", "p0", "T0") for v in self.spec.variables) or \
            any(n in ("M", "p0", "T0") for n in self.spec.fixed)
        rows += analytic_rows(rules, panel, self.spec.tunnel, self.setting(config),
                              config.simulation.duration, envelope=envelope)
        return rows

    def prototype_rows(self) -> list[dict[str, Any]]:
        """The prototype's own temperature, data and stress rows (its validity: a prototype
        beyond its yield strength makes the similarity one of the elastic idealization)."""
        proto = self.prototype_response
        panel = self.spec.prototype.panel
        ext = proto.extremes()
        rules = dataclasses.replace(self.admissibility, rules=tuple(
            dataclasses.replace(r, mode="report", margin=0.0) for r in self.admissibility.rules))
        srow = stress_row(rules, panel, ext)
        return temperature_rows(rules, panel, ext) + ([] if srow is None else [srow])

    # -- cheap constraints ------------------------------------------------------------------
    def cheap_constraints(self) -> list[CheapConstraint]:
        """Eq. (9.7) equalities as exact analytic constraints on the design vector, in the
        order of ``spec.equalities``, then one monotonicity constraint per increasing,
        then per decreasing schedule (:meth:`_monotone_constraint`), then the analytic
        admissibility checks in ``"constraint"`` mode (:meth:`_size_constraint`,
        :meth:`_duration_constraint`) where the tunnel states their limit."""
        out = []
        for name in self.spec.equalities:
            if name == "T_inf":
                out.append(self._t_inf_constraint())
        out += [self._monotone_constraint(name, sign) for name, sign in self.spec.monotone]
        rules, tunnel = self.spec.admissibility, self.spec.tunnel
        if tunnel is not None and tunnel.test_section is not None \
                and rules.mode("size") == "constraint":
            out.append(AnalyticCheck(self, "size").constraint())
        if tunnel is not None and tunnel.run_time is not None \
                and rules.mode("duration") == "constraint":
            out.append(AnalyticCheck(self, "duration").constraint())
        return out


    def _monotone_constraint(self, name: str, sign: int) -> CheapConstraint:
        """``sign (x[k] - x[k+1]) / span <= 0`` for the control points of schedule ``name``:
        ``T_rad`` does not decrease (``sign = 1``) or increase (``-1``) from one control
        point to the next. Linear, so the Jacobian is a constant matrix (rows scaled by the
        bounds' span, violations comparable to the unit-box tolerance of the optimizer)."""
        idx = self.spec.schedule_indices(name)
        D = np.zeros((len(idx) - 1, self.n_var))
        rows = np.arange(len(idx) - 1)
        span = np.asarray(self.xu, float)[idx] - np.asarray(self.xl, float)[idx]
        D[rows, idx[:-1]] = sign / span[:-1]
        D[rows, idx[1:]] = -sign / span[:-1]
        D.flags.writeable = False

        def fun(x: np.ndarray) -> np.ndarray:
            return D @ np.asarray(x, float)

        def jac(x: np.ndarray) -> np.ndarray:
            return D

        return CheapConstraint(fun=fun, jac=jac, kind="ineq")

    def _t_inf_constraint(self) -> CheapConstraint:
        """``ln(T_inf^m / T_w^m) - ln(T_inf^p / T_w^p) = 0`` with
        ``T_inf = T0 / (1 + (gamma - 1)/2 M^2)`` (isentropic nozzle)."""
        names = self.spec.names
        if "T0" not in names and "M" not in names:
            raise InputError("constraints.equality", "'T_inf' needs T0 or M as a design "
                             "variable")
        p = self.spec.prototype
        target = math.log(p.flow.temperature / p.panel.initial_temperature)
        tw_m = self.spec.model.panel.initial_temperature
        g = self.spec.model.flow.gamma
        i_T0 = names.index("T0") if "T0" in names else None
        i_M = names.index("M") if "M" in names else None
        base = self.spec.model.flow

        def parts(x: np.ndarray) -> tuple[float, float]:
            d = self.design(x)
            T0 = float(d.get("T0", base.stagnation_temperature))
            M = float(d.get("M", base.mach))
            return T0, M

        def fun(x: np.ndarray) -> np.ndarray:
            T0, M = parts(x)
            ratio = 1.0 + 0.5 * (g - 1.0) * M * M
            return np.array([math.log(T0 / ratio / tw_m) - target])

        def jac(x: np.ndarray) -> np.ndarray:
            T0, M = parts(x)
            J = np.zeros((1, len(names)))
            if i_T0 is not None:
                J[0, i_T0] = 1.0 / T0
            if i_M is not None:
                J[0, i_M] = -(g - 1.0) * M / (1.0 + 0.5 * (g - 1.0) * M * M)
            return J

        return CheapConstraint(fun=fun, jac=jac, kind="eq")

    # -- reporting ------------------------------------------------------------------------------
    def similarity(self, x: DesignVector) -> list[dict[str, Any]]:
        """Similarity-parameter table of a design, public ``design_point.json`` form."""
        proto = self.spec.prototype
        table = compare(proto.with_time_step(proto.simulation.time_step),
                        self.model_configuration(x))
        return comparison_records(table)

    def active_bounds(self, x: DesignVector, rtol: float = 1e-3) -> list[str]:
        """Names of the bounds a design sits on (Table 9.8 style), e.g. ``"h=upper"``."""
        out = []
        for v, value in zip(self.spec.variables, np.asarray(x, float)):
            if v.name == MATERIAL:  # a level, not a bound
                continue
            span = v.upper - v.lower
            if value <= v.lower + rtol * span:
                out.append(f"{v.name}=lower")
            elif value >= v.upper - rtol * span:
                out.append(f"{v.name}=upper")
        return out
