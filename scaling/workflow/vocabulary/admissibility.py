"""Admissibility: whether a scaled model can be built and tested, with its margins.

A design point is only useful if the model survives its test and the tunnel can run it.
Six checks, each declared once here (``[admissibility]`` of a study file; every check on by
default):

==============  =========================================================  ====  ==========
check           value <= limit                                              unit  kind
==============  =========================================================  ====  ==========
``temperature`` each layer's highest temperature <= its material's service  K     simulated
                temperature - margin
``data``        each layer's temperatures inside its material's property    K     simulated
                data (or declared trusted range), by the margin
``stress``      von Mises stress at the load-bearing surfaces <= yield(T) /  Pa    simulated
                safety factor (at the point of the highest utilization)
``size``        the model plate (L_le + panel length) inside the free jet's  m     analytic
                uniform core (:meth:`TunnelEnvelope.core_length`) - margin
``duration``    scaled test duration + injection time <= the tunnel's run   s     analytic
                time at the setting (:meth:`TunnelEnvelope.run_time_at`)
``envelope``    the tunnel setting (M, p0, T0) inside the envelope          -     bounds
==============  =========================================================  ====  ==========

Modes: ``"constraint"`` (the optimizer respects it and the design point is chosen among
admissible evaluations), ``"report"`` (computed and shown, never enforced), ``"off"``.
Simulated checks become expensive constraint columns ``G <= 0`` of the scaling problem
(kriging surrogates, probability of feasibility in the acquisition); the analytic ones are
exact cheap constraints of the inner SLSQP, like the Eq. (9.7) equality; the envelope is the
tunnel variables' bounds (as before). The stress check defaults to ``"auto"``: a constraint,
unless the prototype's own elastic stress exceeds its yield strength (the similarity is then
of the elastic idealization, and no model can be held to a stricter standard than its
prototype): then ``"report"``.

Syntax::

    [admissibility]
    temperature = { mode = "constraint", margin = 20.0 }   # K below the service limit
    stress = { mode = "report", safety_factor = 1.5 }
    duration = { injection_time = 1.0 }                    # s to inject the model
    size = "off"

A check's row (public ``design_point.json`` / ``whatif --json`` field ``admissibility``):
``{"check", "value", "limit", "margin", "unit", "binding", "ok"}`` plus ``mode`` and
``where``; ``margin = limit - value`` (negative: violated), ``limit`` already holds the
study's margin, ``ok`` None when the limit is not stated (a material without a service
temperature, a tunnel without a test section), ``binding`` when it holds within
:data:`BINDING_FRACTION` of the limit.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Annotated, Any, Literal

import numpy as np
from hypate.scaling.workflow.vocabulary.tunnels import TunnelEnvelope
from hypate.solvers.config import InputModel
from hypate.solvers.materials import Material
from hypate.solvers.panel import PanelSpec
from pydantic import Field, model_validator

#: Every check, in report order.
CHECKS = ("temperature", "data", "stress", "size", "duration", "envelope")
#: Checks computed from a simulation (expensive constraint columns).
SIMULATED = ("temperature", "data", "stress")
#: Checks that are analytic functions of the design (cheap constraints).
ANALYTIC = ("size", "duration")
#: Modes of a check (``"auto"``: the stress check's default, see the module docstring).
MODES = ("constraint", "report", "off")
#: Units of the checks' values.
UNITS = {"temperature": "K", "data": "K", "stress": "Pa", "size": "m", "duration": "s",
         "envelope": "-"}
#: A check that holds with a margin below this fraction of its limit is binding.
BINDING_FRACTION = 0.02
#: Relative tolerance of a check that holds (an analytic check is enforced to about 1e-8).
HOLD_TOL = 1e-6
#: Seconds to inject a model into a started tunnel flow (issue estimate: 0.5-1 s).
DEFAULT_INJECTION_TIME = 1.0

Mode = Literal["constraint", "report", "off"]


class CheckEntry(InputModel):
    """One check of ``[admissibility]``: its mode and margin (and its own parameters); a
    bare string is the mode (``temperature = "report"``)."""

    mode: Literal["constraint", "report", "off", "auto"] | None = None
    margin: Annotated[float, Field(ge=0.0, le=1e4)] = 0.0
    safety_factor: Annotated[float, Field(ge=1.0, le=10.0)] = 1.0
    injection_time: Annotated[float, Field(ge=0.0, le=1e4)] = DEFAULT_INJECTION_TIME

    @model_validator(mode="before")
    @classmethod
    def _mode_alone(cls, value: Any) -> Any:
        return {"mode": value} if isinstance(value, str) else value


class AdmissibilitySection(InputModel):
    """``[admissibility]`` of a study file (module docstring)."""

    temperature: CheckEntry = CheckEntry()
    data: CheckEntry = CheckEntry()
    stress: CheckEntry = CheckEntry()
    size: CheckEntry = CheckEntry()
    duration: CheckEntry = CheckEntry()
    envelope: CheckEntry = CheckEntry()

    def rules(self) -> Admissibility:
        """The validated rules (``"auto"`` only for ``stress``)."""
        out = []
        for name in CHECKS:
            entry = getattr(self, name)
            mode = entry.mode or ("auto" if name == "stress" else "constraint")
            if mode == "auto" and name != "stress":
                raise ValueError(f"{name}: mode 'auto' is the stress check's only; use one of "
                                 f"{', '.join(MODES)}")
            out.append(Rule(name, mode, entry.margin, entry.safety_factor,
                            entry.injection_time))
        return Admissibility(tuple(out))


@dataclass(frozen=True)
class Rule:
    """A check's settings (SI units; ``margin`` in the check's unit)."""

    name: str
    mode: str
    margin: float = 0.0
    safety_factor: float = 1.0
    injection_time: float = DEFAULT_INJECTION_TIME


@dataclass(frozen=True)
class Admissibility:
    """The checks of one study (module docstring); the default has every check on."""

    rules: tuple[Rule, ...] = tuple(Rule(n, "auto" if n == "stress" else "constraint")
                                    for n in CHECKS)

    def rule(self, name: str) -> Rule:
        return next(r for r in self.rules if r.name == name)

    def mode(self, name: str) -> str:
        return self.rule(name).mode

    def resolved(self, prototype_stress_ratio: float) -> Admissibility:
        """The stress check's ``"auto"`` decided by the prototype's largest von Mises /
        yield ratio: ``"report"`` above 1 (the prototype itself yields), else
        ``"constraint"``; a NaN ratio (no yield data) gives ``"report"``."""
        if self.mode("stress") != "auto":
            return self
        ok = math.isfinite(prototype_stress_ratio) and prototype_stress_ratio <= 1.0
        return replace(self, rules=tuple(
            replace(r, mode="constraint" if ok else "report") if r.name == "stress" else r
            for r in self.rules))

    @property
    def simulated_constraints(self) -> tuple[str, ...]:
        """The simulated checks enforced as expensive constraint columns, in order."""
        return tuple(n for n in SIMULATED if self.mode(n) == "constraint")

    @property
    def analytic_constraints(self) -> tuple[str, ...]:
        """The analytic checks enforced as cheap constraints, in order."""
        return tuple(n for n in ANALYTIC if self.mode(n) == "constraint")


# -- rows ------------------------------------------------------------------------------------
def _row(check: str, rules: Admissibility, value: float | None, limit: float | None,
         where: str = "") -> dict[str, Any]:
    """One public row; ``limit`` already holds the study's margin."""
    if value is None or limit is None or not (math.isfinite(value) and math.isfinite(limit)):
        margin, ok, binding = None, None, False
    else:
        margin = float(limit - value)
        # the cheap constraints hold to the inner optimizer's tolerance, not to the last bit
        ok = bool(margin >= -HOLD_TOL * max(abs(limit), 1.0))
        binding = bool(ok and margin <= BINDING_FRACTION * abs(limit))
    return {"check": check, "value": None if value is None or not math.isfinite(value)
            else float(value), "limit": None if limit is None or not math.isfinite(limit)
            else float(limit), "margin": margin, "unit": UNITS[check], "binding": binding,
            "ok": ok, "mode": rules.mode(check), "where": where}


def _layer_label(panel: PanelSpec, k: int) -> str:
    return f"layer {k} ({panel.layers[k].material.name})"


def temperature_rows(rules: Admissibility, panel: PanelSpec, extremes: Mapping[str, Any]
                     ) -> list[dict[str, Any]]:
    """The ``temperature`` and ``data`` rows of one simulated run: the layer with the least
    margin of each (``extremes`` of :meth:`Response.extremes`)."""
    layers = extremes.get("layer_temperature") or []
    out = []
    if rules.mode("temperature") != "off":
        best: tuple[float, float | None, float | None, str] | None = None
        for k, (_, t_max) in enumerate(layers):
            limit = panel.layers[k].material.limits.service_temperature
            if limit is None:
                continue
            lim = limit - rules.rule("temperature").margin
            key = lim - t_max
            if best is None or key < best[0]:
                best = (key, t_max, lim, _layer_label(panel, k))
        if best is None:
            t_max = max((t for _, t in layers), default=float("nan"))
            out.append(_row("temperature", rules, t_max, None, "no service temperature stated"))
        else:
            out.append(_row("temperature", rules, best[1], best[2], best[3]))
    if rules.mode("data") != "off":
        margin = rules.rule("data").margin
        best = None
        for k, (t_min, t_max) in enumerate(layers):
            lo, hi = panel.layers[k].material.valid_range
            for value, limit, key, side in ((t_max, hi - margin, hi - margin - t_max, "above"),
                                            (-t_min, -(lo + margin), t_min - lo - margin,
                                             "below")):
                if math.isfinite(limit) and (best is None or key < best[0]):
                    best = (key, value, limit, f"{_layer_label(panel, k)}, {side} its data")
        if best is None:
            out.append(_row("data", rules, float("nan"), None, "every property constant"))
        else:
            row = _row("data", rules, best[1], best[2], best[3])
            if row["value"] is not None and row["value"] < 0:  # the low side, written in K
                row["value"], row["limit"] = -row["value"], -row["limit"]
            out.append(row)
    return out


def stress_row(rules: Admissibility, panel: PanelSpec, extremes: Mapping[str, Any]
               ) -> dict[str, Any] | None:
    """The ``stress`` row: at the point of the highest von Mises / yield ratio, the von
    Mises stress against yield / safety factor (None when the check is off)."""
    if rules.mode("stress") == "off":
        return None
    ratio = extremes.get("max_stress_ratio", float("nan"))
    sigma = extremes.get("stress_at_ratio", float("nan"))
    sf = rules.rule("stress").safety_factor
    loc = extremes.get("stress_ratio_location")
    where = "" if loc is None else f"x = {loc[0]:.3g} m, y = {loc[1]:.3g} m, z = {loc[2]:.3g} m"
    if not (math.isfinite(ratio) and ratio > 0.0 and math.isfinite(sigma)):
        return _row("stress", rules, extremes.get("max_von_mises", float("nan")), None,
                    "no yield strength stated")
    return _row("stress", rules, sigma, sigma / ratio / sf, where)


def size_value(panel: PanelSpec, tunnel: TunnelEnvelope | None, mach: float
               ) -> tuple[float, float | None]:
    """The model plate's length (L_le + panel length, m) and the core length it must fit."""
    plate = panel.leading_edge_length + panel.length
    width = panel.width if panel.kind == "3d" else 0.0
    return plate, None if tunnel is None else tunnel.core_length(mach, width)


def analytic_rows(rules: Admissibility, panel: PanelSpec, tunnel: TunnelEnvelope | None,
                  setting: tuple[float, float, float], test_duration: float,
                  envelope: bool = True) -> list[dict[str, Any]]:
    """The ``size``, ``duration`` and ``envelope`` rows of a model.

    Parameters
    ----------
    setting : (M, p0, T0)
        The tunnel setting (Pa, K).
    test_duration : float
        The scaled test duration (s): the prototype's duration times the time scale.
    envelope : bool
        Whether the study has a tunnel envelope to check against.
    """
    mach, p0, T0 = setting
    out = []
    if rules.mode("size") != "off":
        plate, core = size_value(panel, tunnel, mach)
        out.append(_row("size", rules, plate, None if core is None
                        else core - rules.rule("size").margin,
                        "test section not stated" if core is None else
                        f"L_le + L in the free jet's core at M {mach:.3g}"))
    if rules.mode("duration") != "off":
        inj = rules.rule("duration").injection_time
        run = None if tunnel is None else tunnel.run_time_at(mach, p0, T0)
        out.append(_row("duration", rules, test_duration + inj,
                        None if run is None else run - rules.rule("duration").margin,
                        "run time not stated" if run is None else
                        f"test {test_duration:.3g} s + injection {inj:g} s"))
    if rules.mode("envelope") != "off" and envelope and tunnel is not None:
        for name, value in (("M", mach), ("p0", p0), ("T0", T0)):
            bounds = tunnel.bounds().get(name)
            if bounds is None:  # a discrete Mach number: one of the nozzles
                nozzle = min(tunnel.mach_values, key=lambda m: abs(m - value))
                bounds = (nozzle, nozzle)
            lo, hi = bounds
            inside = min(value - lo, hi - value)
            row = _row("envelope", rules, value, hi if hi - value <= value - lo else lo,
                       f"{name} in [{lo:g}, {hi:g}]")
            span = max(hi - lo, abs(hi) * 1e-9)
            row["margin"] = float(inside)
            row["ok"] = bool(inside >= -1e-9 * max(abs(lo), abs(hi)))
            row["binding"] = bool(row["ok"] and inside <= BINDING_FRACTION * span)
            row["unit"] = {"M": "-", "p0": "Pa", "T0": "K"}[name]
            out.append(row)
    return out


def admissible(rows: Sequence[Mapping[str, Any]]) -> bool:
    """Whether every check in ``"constraint"`` mode holds (an undecided one, ``ok`` None,
    does not count against the design; the report says it is not stated)."""
    return all(r["ok"] is not False for r in rows if r["mode"] == "constraint")


def violation(rows: Sequence[Mapping[str, Any]]) -> float:
    """Sum of the enforced checks' relative violations (0 for an admissible design): the
    order of the least-violating design when none is admissible."""
    total = 0.0
    for r in rows:
        if r["mode"] == "constraint" and r["ok"] is False and r["limit"] is not None:
            total += -float(r["margin"]) / max(abs(float(r["limit"])), 1e-12)
    return total


def simulated_columns(rules: Admissibility, panel: PanelSpec,
                      extremes: Mapping[str, Any]) -> np.ndarray:
    """The expensive constraint columns ``G <= 0`` of one run, in the order of
    :attr:`Admissibility.simulated_constraints`: ``-margin / |limit|`` (the relative
    violation; 0 where a limit is not stated: the design fails nothing there)."""
    rows = {r["check"]: r for r in temperature_rows(rules, panel, extremes)}
    srow = stress_row(rules, panel, extremes)
    if srow is not None:
        rows["stress"] = srow
    out = []
    for name in rules.simulated_constraints:
        r = rows[name]
        if r["limit"] is None or r["margin"] is None:
            out.append(0.0)
        else:
            out.append(-r["margin"] / max(abs(r["limit"]), 1e-12))
    return np.array(out, dtype=float)


def material_limits(material: Material) -> dict[str, Any]:
    """A material's limits for reports: service temperature (K), data range (K), the
    trusted range if declared, yield strength at 300 K (Pa) and the sources."""
    lim = material.limits
    lo, hi = material.data_range
    return {"material": material.name, "service_temperature": lim.service_temperature,
            "data_range": [lo, hi], "trusted_range": None if lim.trusted_range is None
            else list(lim.trusted_range),
            "yield_strength_300K": None if lim.yield_strength is None
            else float(lim.yield_strength(300.0)), "sources": lim.sources}
