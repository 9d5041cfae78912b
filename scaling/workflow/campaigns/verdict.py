"""A run's admissibility verdict: which evaluations a test engineer could build, the design
point among them, and what the model and the prototype went through.

Every successful evaluation stores what its model went through (its auxiliary outputs,
``aux["extremes"]``: :meth:`Response.extremes`); with the analytic checks recomputed from its
design, that gives its admissibility rows (:mod:`hypate.scaling.workflow.vocabulary.admissibility`).
The design point is chosen by the study's rule among the admissible evaluations; when none
is admissible, it is the least-violating successful one, and the run says so.

Public ``design_point.json`` (and ``hypate whatif --json``) fields written from here:
``admissible``, ``admissibility`` (rows ``{"check", "value", "limit", "margin", "unit",
"binding", "ok"}`` plus ``mode``, ``where``), ``responses`` = ``{"model": {...},
"prototype": {...}}`` (each with ``max_wall_temperature`` K, ``mean_temperature`` K,
``max_deflection_ratio`` (max ``|w| / h``), ``max_von_mises`` Pa and the details of
:func:`responses_record`), ``prototype_admissibility`` (the prototype's own temperature,
data and stress rows) and ``limits`` (the materials' limits and their sources).
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from hypate.scaling.engine.design_point import design_point_index
from hypate.scaling.engine.result import OptimizationResult
from hypate.scaling.workflow.campaigns.rundir import finite
from hypate.scaling.workflow.vocabulary.admissibility import (
    admissible,
    material_limits,
    violation,
)
from hypate.scaling.workflow.vocabulary.problem import ScalingProblem
from hypate.solvers.panel import PanelSpec

__all__ = ["admissibility_lines", "binding_limits", "choose_admissible_point",
           "evaluation_admissibility", "prototype_note", "prototype_yields",
           "responses_record", "verdict_fields"]

#: The response summary's keys, SI units (public: ``responses.model`` / ``.prototype``).
RESPONSE_KEYS = ("max_wall_temperature", "mean_wall_temperature", "mean_temperature",
                 "max_deflection_ratio", "max_von_mises", "von_mises_location",
                 "von_mises_time", "max_stress_ratio", "stress_ratio_location",
                 "layer_temperature", "layer_materials")


def responses_record(extremes: Mapping[str, Any] | None, stagnation_temperature: float
                     ) -> dict[str, Any] | None:
    """One response summary of ``design_point.json``'s ``responses``: the run's
    :meth:`Response.extremes` (K, Pa, m, s) plus the stagnation temperature ``T0`` (K) and
    the temperatures over it (``max_wall_temperature_over_T0``, ``mean_temperature_over_T0``)
    that J_T compares."""
    if extremes is None:
        return None
    rec = {k: extremes.get(k) for k in RESPONSE_KEYS}
    T0 = float(stagnation_temperature)
    rec["stagnation_temperature"] = T0
    for key in ("max_wall_temperature", "mean_temperature"):
        value = rec.get(key)
        rec[f"{key}_over_T0"] = None if value is None else float(value) / T0
    return finite(rec)


def evaluation_admissibility(problem: ScalingProblem, result: OptimizationResult
                             ) -> tuple[np.ndarray, np.ndarray]:
    """Each evaluation's admissibility and summed relative violation.

    A failed evaluation is not admissible (violation inf); a successful one is when every
    enforced check holds: its constraint columns (``G <= 0``) and the rows rebuilt from its
    stored extremes and its design (an evaluation stored before the extremes were recorded
    is judged on the analytic rows and its columns).

    Returns
    -------
    admissible : ndarray of bool, shape (n,)
    violation : ndarray of shape (n,)
    """
    n = len(result.data)
    ok = result.ok
    G = result.G
    adm = np.zeros(n, bool)
    vio = np.full(n, np.inf)
    aux = result.data["aux"] if "aux" in result.data.columns else [{}] * n
    for i in np.flatnonzero(ok):
        extra = aux.iloc[i] if hasattr(aux, "iloc") else aux[i]
        extremes = extra.get("extremes") if isinstance(extra, dict) else None
        rows = problem.admissibility_rows(problem.model_configuration(result.X[i]), extremes)
        cols_ok = bool(np.all(G[i] <= 0.0)) if G.shape[1] else True
        adm[i] = admissible(rows) and cols_ok
        vio[i] = violation(rows) + float(np.sum(np.maximum(G[i], 0.0))) if G.shape[1] else \
            violation(rows)
    return adm, vio


def choose_admissible_point(result: OptimizationResult, admissible_rows: np.ndarray,
                            violations: np.ndarray, rule: str,
                            weights: Sequence[float] | None) -> tuple[int | None, bool]:
    """The design point's row and whether it is admissible.

    Among the admissible evaluations by the study's design-point ``rule``
    (:func:`~hypate.scaling.engine.design_point.design_point_index`); with none admissible the
    successful evaluation with the smallest summed relative violation (ties: the rule's
    score, then the earlier evaluation); None without a successful evaluation.
    """
    ok = result.ok
    idx = np.flatnonzero(ok & admissible_rows)
    F = result.F
    if idx.size:
        return int(idx[design_point_index(F[idx], rule, weights)]), True
    idx = np.flatnonzero(ok)
    if idx.size == 0:
        return None, False
    order = np.lexsort((idx, F[idx].max(axis=1), violations[idx]))
    return int(idx[order[0]]), False


def prototype_yields(rows: Sequence[Mapping[str, Any]]) -> bool:
    """Whether the prototype's elastic stress exceeds its yield strength (its stress row)."""
    return any(r["check"] == "stress" and r["ok"] is False for r in rows)


def binding_limits(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """The checks a design sits on or violates, in words (``"temperature 971.2 <= 977.6 K
    (binding)"``), enforced ones first."""
    out = []
    for r in sorted(rows, key=lambda r: r["mode"] != "constraint"):
        if not (r["binding"] or r["ok"] is False):
            continue
        state = "binding" if r["ok"] else "VIOLATED"
        value, limit = _cell(r["value"], r["unit"]), _cell(r["limit"], r["unit"])
        sign = "<=" if r["ok"] else ">"
        low = r["check"] == "data" and "below" in r.get("where", "")
        if low:
            sign = ">=" if r["ok"] else "<"
        extra = "" if r["mode"] == "constraint" else f", {r['mode']} only"
        unit = "MPa" if r["unit"] == "Pa" else r["unit"]
        out.append(f"{r['check']} {value} {sign} {limit} {unit} ({state}{extra}"
                   + (f"; {r['where']}" if r.get("where") else "") + ")")
    return out


def _layers_limits(panel: PanelSpec) -> list[dict[str, Any]]:
    seen: dict[str, dict[str, Any]] = {}
    for layer in panel.layers:
        seen.setdefault(layer.material.name, material_limits(layer.material))
    return list(seen.values())


def verdict_fields(problem: ScalingProblem, x: np.ndarray,
                   extremes: Mapping[str, Any] | None) -> dict[str, Any]:
    """The admissibility fields of one design's record (module docstring): the rows of
    design ``x`` with its run's ``extremes`` (None: the model failed, analytic rows
    only), the model's and the prototype's responses, the prototype's own rows and the
    materials' limits."""
    config = problem.model_configuration(x)
    rows = problem.admissibility_rows(config, extremes)
    proto = problem.prototype_response
    proto_rows = problem.prototype_rows()
    return finite({
        "admissible": admissible(rows) if extremes is not None else False,
        "admissibility": rows,
        "binding": binding_limits(rows),
        "responses": {
            "model": responses_record(extremes, config.flow.stagnation_temperature),
            "prototype": responses_record(proto.extremes(),
                                          problem.spec.prototype.flow.stagnation_temperature)},
        "prototype_admissibility": proto_rows,
        "prototype_yields": prototype_yields(proto_rows),
        "limits": {"model": _layers_limits(config.panel),
                   "prototype": _layers_limits(problem.spec.prototype.panel)}})


def prototype_note(rows: Sequence[Mapping[str, Any]]) -> str | None:
    """The one plain sentence a run prints when the prototype itself exceeds its yield
    strength (None otherwise)."""
    stress = next((r for r in rows if r["check"] == "stress" and r["ok"] is False), None)
    if stress is None:
        return None
    return (f"note: the prototype's own elastic stress reaches {stress['value'] / 1e6:.0f} MPa "
            f"against a yield strength of {stress['limit'] / 1e6:.0f} MPa ({stress['where']}): "
            "it would yield, so the similarity is that of the elastic idealization and the "
            "stress check only reports")


def admissibility_lines(record: Mapping[str, Any]) -> list[str]:
    """The admissibility table of a design record (``design_point.json`` or a what-if) as
    terminal lines: check, value, limit, margin, unit, mode and state, then the model's and
    the prototype's temperatures in K beside T / T0."""
    rows = record.get("admissibility") or []
    if not rows:
        return []
    verdict = "ADMISSIBLE" if record.get("admissible") else "NOT ADMISSIBLE"
    out = [f"admissibility: {verdict} (enforced checks; margin = limit - value)",
           f"  {'check':<12s} {'value':>11s} {'limit':>11s} {'margin':>11s} {'unit':<4s} "
           f"{'mode':<10s} state"]
    for r in rows:
        state = ("not stated" if r["ok"] is None else "BINDING" if r["binding"]
                 else "ok" if r["ok"] else "VIOLATED")
        unit = "MPa" if r["unit"] == "Pa" else r["unit"]
        out.append(f"  {r['check']:<12s} {_cell(r['value'], r['unit']):>11s} "
                   f"{_cell(r['limit'], r['unit']):>11s} {_cell(r['margin'], r['unit']):>11s} "
                   f"{unit:<4s} {r['mode']:<10s} {state}"
                   + (f"  ({r['where']})" if r.get("where") else ""))
    responses = record.get("responses") or {}
    for who in ("model", "prototype"):
        rec = responses.get(who)
        if not rec:
            continue
        out.append(f"  {who:<9s} max wall T {_cell(rec['max_wall_temperature'], 'K')} K "
                   f"(T/T0 {_cell(rec['max_wall_temperature_over_T0'], '-')}), mean T "
                   f"{_cell(rec['mean_temperature'], 'K')} K (T/T0 "
                   f"{_cell(rec['mean_temperature_over_T0'], '-')}), max |w|/h "
                   f"{_cell(rec['max_deflection_ratio'], '-')}, max von Mises "
                   f"{_cell(rec['max_von_mises'], 'Pa')} MPa")
    return out


def _cell(value: float | None, unit: str) -> str:
    """A value for the terminal: MPa for Pa, 0.1 K for kelvin, 4 digits otherwise."""
    if value is None or not math.isfinite(value):
        return "-"
    if unit == "Pa":
        return f"{value / 1e6:.4g}"
    if unit == "K":
        return f"{value:.1f}"
    return f"{value:.4g}"
