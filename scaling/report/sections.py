"""The report's sections: :class:`Section`, :func:`html_table` and the built-in builders.

Each builder takes a :class:`~hypate.scaling.report.rundata.RunData` and returns a
:class:`Section` (or ``None`` to leave it out). :data:`BUILTIN_SECTIONS` lists them in page
order: *Study*, *Design point* (Table 9.8 style, with the rule that chose it, the active
constraints, the surrogates' leave-one-out prediction and the definitions of J),
*Admissibility* (the design point's checks against its material's limits, its tunnel's
test section and run time, with the margins; the model's and the prototype's temperatures in
K, deflection and stress; the prototype's own validity), *Across seeds* (one seed of a
``--seeds`` run: the spread of the design point; left out otherwise), *Similarity
parameters* (prototype / model / relative difference; > 10 % highlighted), *Glossary*
(symbol, formula, equation and meaning of each parameter),
*Robustness* (a study with ``[uncertainty]``: the design point under its scatter),
*Figures* (with a heater schedule: the optimized ``T_rad(t)`` next to the wall temperatures),
*Pareto set* (the design point's row marked), *Run statistics* (evaluations, failures grouped by
reason, wall time), *Warnings* (the distinct solver warnings, where they occurred and how often;
left out without any) and *Scaling laws* (a sweep's refined laws, Fig. 9.12). :mod:`.html` renders
them into the page.

Every evaluation number printed is the evaluation id (``RunData.evaluations``' index, the
``id`` column of ``evaluations.csv``); every number goes through :mod:`.numbers`.

The building blocks (:class:`Section`, :func:`html_table`) are :mod:`.blocks`; the run-health
sections (statistics, seeds, warnings) :mod:`.run_sections`.
"""
from __future__ import annotations

import html
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from hypate.scaling.engine.design_point import describe_rule
from hypate.scaling.engine.pareto import non_dominated_mask
from hypate.scaling.report.blocks import Raw, Section, dl, fmt, html_table, pct
from hypate.scaling.report.figures import (
    MISMATCH_THRESHOLD,
    close_figures,
    distribution_figure,
    figure_html,
    history_figure,
    pareto_figure,
    response_figure,
    schedule_figure,
    sobol_figure,
    variable_unit,
)
from hypate.scaling.report.glossary import glossary_rows
from hypate.scaling.report.laws import laws_figure, laws_table
from hypate.scaling.report.material import choice_row, choices_note
from hypate.scaling.report.numbers import (
    format_difference,
)
from hypate.scaling.report.run_sections import (
    seeds_section,
    statistics_section,
    warnings_section,
)
from hypate.scaling.report.rundata import RunData
from hypate.scaling.workflow.campaigns.laws import (
    SWEEP_JSON,
    laws_of_run,
    load_sweep,
    materials_by_scale,
)
from hypate.scaling.workflow.campaigns.rundir import (
    PREDICTION_DIR,
    PREDICTION_HTML,
    PREDICTION_JSON,
)
from hypate.scaling.workflow.vocabulary.variables import CATEGORICAL

__all__ = ["BUILTIN_SECTIONS", "Section", "html_table"]


def _study_section(run: RunData) -> Section:
    point = run.point or {}
    study = run.study
    if study is None:
        items = [("study", fmt(point.get("study", "unknown"))),
                 ("xi (geometric scale)", fmt(point.get("xi"))),
                 ("design variables", html.escape(", ".join(run.variables)) or "&ndash;"),
                 ("objectives", html.escape(", ".join(run.objectives)) or "&ndash;"),
                 ("evaluations stored", fmt(len(run.evaluations)))]
        return Section("Study", dl(items) + "<p class='note'>The study file is unknown: "
                       "regenerate with <code>hypate report DIR --study STUDY.toml</code> "
                       "for the full summary.</p>")
    spec = study.spec
    proto = spec.prototype
    pp, pf = proto.panel, proto.flow
    layers = ", ".join(f"{layer.material.name} {1e3 * layer.thickness:.3g} mm"
                       for layer in pp.layers)
    alt = f", H = {pf.altitude / 1e3:.4g} km" if pf.altitude is not None else ""
    prototype = (f"{pp.length:.4g} m x {pp.width:.4g} m {pp.boundary.replace('_', ' ')} "
                 f"panel ({html.escape(layers)}), L_le = {pp.leading_edge_length:.4g} m; "
                 f"M = {pf.mach:.4g}{alt}, p = {pf.pressure:.4g} Pa, "
                 f"T = {pf.temperature:.4g} K, T0 = {pf.stagnation_temperature:.4g} K")
    mp = spec.model.panel
    made_of = (" or ".join(spec.material_names) + " (a design variable)" if spec.materials
               else mp.layers[0].material.name)
    model = (f"{html.escape(made_of)} panel, {mp.length:.4g} m x "
             f"{mp.width:.4g} m (scale xi = {spec.xi:g})")
    tun = study.tunnel
    if tun is None:
        tunnel = "free flight (no tunnel envelope)"
    else:
        mach = (f"M = {', '.join(f'{m:g}' for m in tun.mach_values)}" if tun.mach_values
                else f"M in [{tun.mach[0]:g}, {tun.mach[1]:g}]")
        tunnel = (f"{html.escape(tun.name)}: {mach}, p0 in [{tun.p0[0] / 1e6:.4g}, "
                  f"{tun.p0[1] / 1e6:.4g}] MPa, T0 in [{tun.T0[0]:.4g}, {tun.T0[1]:.4g}] K"
                  + (f" &mdash; {html.escape(tun.description)}" if tun.description else ""))
    sim = spec.simulation
    opt = study.optimizer
    its = (f"up to {opt.max_iterations} (auto: stopped when converged)"
           if opt.iterations == "auto" else f"{opt.iterations}")
    budget = (f"{opt.initial_samples} initial samples + {its} iterations x "
              f"batch {opt.batch_size}"
              + (f" + {opt.polish} polish evaluations" if opt.polish else "")
              + f" ({study.acquisition.upper()}, {opt.approach} approach, seed "
              f"{opt.seed if run.seed is None else run.seed}"
              + (f", {opt.coordinates} coordinates" if opt.coordinates != "design" else "")
              + (f", {opt.transform} transform" if opt.transform != "none" else "") + ")")
    items = [("study", html.escape(study.name)),
             ("description", html.escape(study.description or "")),
             ("study file", f"<code>{html.escape(Path(str(run.study_path)).name)}</code>"),
             ("prototype", prototype), ("model", model), ("tunnel", tunnel),
             ("simulation", html.escape(
                 f"{spec.kind}, {sim.n_steps} steps of {sim.time_step:g} s (prototype), "
                 f"aero {sim.aero}, heating {sim.heating}; time scaling {spec.time_scaling}, "
                 f"projection {spec.projection}")),
             ("objectives", html.escape(", ".join(spec.objectives))),
             ("budget", html.escape(budget))]
    if spec.equalities:
        items.append(("equality constraints", html.escape(", ".join(spec.equalities))))
    var_rows = [(v.name, "-", "one of: " + ", ".join(spec.level_names(v.name)), "")
                if v.name in spec.levels else (v.name, variable_unit(v.name), v.lower, v.upper)
                for v in spec.variables]
    body = dl(items) + "<h3>Design variables</h3>" + html_table(
        ["variable", "unit", "lower bound", "upper bound"], var_rows)
    if spec.fixed:
        body += "<h3>Fixed values</h3>" + html_table(
            ["name", "unit", "value"], [(k, variable_unit(k), v) for k, v in spec.fixed.items()])
    return Section("Study", body)


def _bounds_of(run: RunData) -> dict[str, tuple[float, float]]:
    if run.study is None:
        return {}
    return {v.name: (v.lower, v.upper) for v in run.study.spec.variables}


def _rule_paragraph(run: RunData) -> str:
    """The sentence that defends the design point: which rule chose it, from what."""
    rule = describe_rule(run.rule, len(run.objectives), run.weights)
    which = f"evaluation {run.point_id}" if run.point_id is not None else "the design point"
    source = ("rebuilt from the evaluation store (the run did not finish)"
              if run.point_rebuilt else "chosen by the run")
    key = (f" Rule <code>[optimizer] design_point = \"{html.escape(run.rule)}\"</code>."
           if len(run.objectives) > 1 else "")
    return (f"<p class='rule'><strong>Selection rule.</strong> The design point "
            f"({html.escape(which)}, {source}) is {html.escape(rule)}.{key}</p>")


#: What the leave-one-out column means (under the objectives table).
_SURROGATE_NOTE = (
    "<p class='note'>How sure the search is: the kriging surrogate fitted to every other "
    "evaluation (hyperparameters of the final fit) predicts the design point's objective "
    "as shown, with its one-standard-deviation band; <i>z</i> is the observed value's "
    "distance from the prediction in standard deviations (of ln J for a log-transformed "
    "study). |z| &lt; 2: the surrogate had learned this neighbourhood. z &lt; -3: the design "
    "point is much better than the surrogate expected (a narrow valley, sampled "
    "sparsely): a search with another seed may land elsewhere.</p>")


def _surrogate_cell(check: dict[str, Any] | None) -> str:
    """``predicted (lower - upper), z = ...`` in percent, or ``-`` without a check."""
    if not check or check.get("predicted") is None:
        return "-"
    band = f"{pct(check.get('lower'))} &ndash; {pct(check.get('upper'))}"
    z = check.get("z")
    zs = f", <i>z</i> = {z:+.2g}" if isinstance(z, (int, float)) else ""
    return f"{pct(check['predicted'])} ({band}){zs}"


def _design_section(run: RunData) -> Section:
    point = run.point
    if not point or not point.get("design"):
        msg = (point or {}).get("message") or "no successful evaluation"
        return Section("Design point", f"<p class='warn'>No design point: {html.escape(msg)}."
                       " See the run statistics for the failure reasons.</p>")
    bounds = _bounds_of(run)
    active = [str(a) for a in point.get("active_constraints") or []]
    active_vars = {a.split("=")[0]: a.split("=")[1] for a in active if "=" in a}
    classical = (run.classical or {}).get("design") or {}
    rows, classes = [], []
    for name, value in point["design"].items():
        lo, hi = bounds.get(name, (None, None))
        state = active_vars.get(name, "")
        rows.append(choice_row(point, name, run.classical) if name in CATEGORICAL else
                    (name, variable_unit(name), value, lo, hi, state or "",
                     classical.get(name)))
        classes.append("active" if state else "")
    intro = _rule_paragraph(run)
    objs = point.get("objectives") or {}
    checks = ((point.get("surrogate") or {}).get("objectives")) or {}
    obj_rows = [(k, Raw(pct(v)), Raw(_surrogate_cell(checks.get(k))),
                 Raw(pct(((run.classical or {}).get("objectives") or {}).get(k))))
                for k, v in objs.items()]
    body = intro + html_table(["variable", "unit", "value", "lower bound", "upper bound",
                               "bound hit", "classical baseline"], rows, classes)
    body += choices_note(point, [n for n in point["design"] if n in CATEGORICAL])
    body += "<h3>Objectives</h3>" + html_table(
        ["objective", "design point", "surrogate prediction (leave-one-out)",
         "classical baseline"], obj_rows)
    body += _objectives_definition(run)
    if checks:
        body += _SURROGATE_NOTE
    body += "<h3>Active constraints</h3>" + (
        "<ul>" + "".join(f"<li>{html.escape(a)}</li>" for a in active) + "</ul>"
        if active else "<p>none</p>")
    extra = []
    if isinstance(point.get("evaluation"), int):
        extra.append(("evaluation", fmt(point["evaluation"])))
    if run.model_time_step is not None:
        extra.append(("model time step", f"{run.model_time_step:.4g} s"))
    if run.study is not None and run.model_time_step is not None:
        sim = run.study.spec.simulation
        extra.append(("model test duration",
                      f"{run.model_time_step * sim.n_steps:.4g} s (prototype "
                      f"{sim.time_step * sim.n_steps:.4g} s)"))
    return Section("Design point", body + (dl(extra) if extra else ""))


#: What J_u compares, per projection (the study's ``projection``).
_J_U = {"center": "the centre deflection over the thickness, w_c / h",
        "modal": "the sinusoidal modal coordinates of the deflection over the thickness",
        "fields": "the nodal displacement fields nondimensionalized by Eq. (3.17b) (in-plane, "
                  "transverse and rotation groups weighted equally)"}


def _objectives_definition(run: RunData) -> str:
    """The definitions of J_u and J_T (Eqs. 6.4, 9.6; Sec. 9.2.1.1)."""
    projection = run.study.spec.projection if run.study is not None else "center"
    return ("<p class='note'><strong>Definitions.</strong> Each J is a relative RMS error "
            "over the time samples matched in nondimensional time (Eq. 6.4; model steps "
            "mapped by the Fourier number, Eqs. 9.5-9.6): J = ||model - prototype|| / "
            "||prototype||, so 0.1 reads 10 %. <i>J_u</i> compares "
            f"{html.escape(_J_U.get(projection, _J_U['center']))}; <i>J_T</i> compares the "
            "volume-mean temperature over the stagnation temperature, T_mean / T0 "
            "(Sec. 9.2.1.1). The temperatures in kelvin are in the admissibility "
            "section.</p>")


#: Row labels of the responses table (key of ``responses.*``, label, unit, scale).
_RESPONSE_ROWS = (("max_wall_temperature", "max wall temperature", "K", 1.0),
                  ("max_wall_temperature_over_T0", "max wall temperature / T0", "-", 1.0),
                  ("mean_wall_temperature", "max mean wall temperature", "K", 1.0),
                  ("mean_temperature", "max volume-mean temperature", "K", 1.0),
                  ("mean_temperature_over_T0", "max volume-mean temperature / T0", "-", 1.0),
                  ("stagnation_temperature", "stagnation temperature T0", "K", 1.0),
                  ("max_deflection_ratio", "max |w| / h", "-", 1.0),
                  ("max_von_mises", "max von Mises stress", "MPa", 1e-6),
                  ("max_stress_ratio", "max von Mises / yield(T)", "-", 1.0))


def _check_state(row: dict[str, Any]) -> str:
    if row.get("ok") is None:
        return "limit not stated"
    if row.get("ok") is False:
        return "VIOLATED"
    return "binding" if row.get("binding") else "ok"


def _admissibility_section(run: RunData) -> Section | None:
    """What the design point's model goes through against its limits: the admissibility
    table (check, value, limit, margin, binding), the model's and the prototype's
    temperatures (K and over T0), deflection and stress, the prototype's own validity and
    the materials' limits with their sources."""
    point = run.point or {}
    rows_in = point.get("admissibility")
    if not rows_in:
        return None
    verdict = ("<p class='rule'><strong>Admissible.</strong> The model holds every enforced "
               "limit (<i>constraint</i> mode) with the margins below.</p>"
               if point.get("admissible") else
               f"<p class='warn'><strong>Not admissible.</strong> "
               f"{html.escape(point.get('message') or 'An enforced limit is violated.')} "
               "The violated checks are highlighted.</p>")
    rows, classes = [], []
    for r in rows_in:
        unit = r.get("unit")
        scale = 1e-6 if unit == "Pa" else 1.0
        shown = "MPa" if unit == "Pa" else unit
        rows.append((r.get("check"), r.get("mode"),
                     None if r.get("value") is None else r["value"] * scale,
                     None if r.get("limit") is None else r["limit"] * scale,
                     None if r.get("margin") is None else r["margin"] * scale, shown,
                     _check_state(r), r.get("where") or ""))
        classes.append("mismatch" if r.get("ok") is False else
                       "active" if r.get("binding") else "")
    body = verdict + html_table(["check", "mode", "value", "limit", "margin = limit - value",
                                 "unit", "state", "where"], rows, classes)
    body += ("<p class='note'>Limits already hold the study's margins. <i>constraint</i>: "
             "enforced by the optimizer and the design-point choice; <i>report</i>: shown, "
             "not enforced. Temperature: each layer's highest temperature against its "
             "material's service temperature; data: the temperatures its property tables "
             "cover; stress: plane-stress von Mises at the load-bearing surfaces (face "
             "sheets of a sandwich) against yield(T) / safety factor at the point of highest "
             "utilization; size: L_le + panel length inside the free jet's uniform core; "
             "duration: the scaled test plus the injection time against the tunnel's run "
             "time at the setting.</p>")
    responses = point.get("responses") or {}
    if any(responses.values()):
        resp_rows = []
        for key, label, unit, scale in _RESPONSE_ROWS:
            vals = [(responses.get(w) or {}).get(key) for w in ("model", "prototype")]
            resp_rows.append((label, unit) + tuple(None if v is None else v * scale
                                                  for v in vals))
        body += "<h3>What the model and the prototype go through</h3>" + html_table(
            ["quantity", "unit", "model", "prototype"], resp_rows)
    proto_rows = point.get("prototype_admissibility") or []
    stress = next((r for r in proto_rows if r.get("check") == "stress"), None)
    if point.get("prototype_yields") and stress is not None:
        body += (f"<p class='warn'><strong>The prototype itself would yield.</strong> Its "
                 f"elastic von Mises stress reaches {stress['value'] / 1e6:.0f} MPa against "
                 f"a yield strength of {stress['limit'] / 1e6:.0f} MPa there "
                 f"({html.escape(stress.get('where') or '')}): the similarity computed here "
                 "is that of the elastic idealization, and the study's stress check only "
                 "reports (a model need not be held to a stricter standard than its "
                 "prototype).</p>")
    limits = point.get("limits") or {}
    lim_rows = []
    for who in ("model", "prototype"):
        for m in limits.get(who) or []:
            lo, hi = m.get("data_range") or (None, None)
            lim_rows.append((who, m.get("material"), m.get("service_temperature"),
                             f"{lo:g}-{hi:g}" if lo is not None and hi is not None else "-",
                             "-" if not m.get("trusted_range") else
                             "-".join(f"{v:g}" for v in m["trusted_range"]),
                             None if m.get("yield_strength_300K") is None
                             else m["yield_strength_300K"] / 1e6, m.get("sources") or ""))
    if lim_rows:
        body += "<h3>Material limits</h3>" + html_table(
            ["article", "material", "service temperature (K)", "property data (K)",
             "trusted range (K)", "yield at 300 K (MPa)", "sources"], lim_rows)
    return Section("Admissibility", body)


def _similarity_section(run: RunData) -> Section:
    rows_in = (run.point or {}).get("similarity") or []
    if not rows_in:
        return Section("Similarity parameters", "<p class='note'>Not available (needs the "
                       "study file to rebuild it for an interrupted run).</p>")
    rows, classes = [], []
    for rec in rows_in:
        rd = rec.get("relative_difference")
        bad = rd is not None and np.isfinite(float(rd)) and abs(float(rd)) > MISMATCH_THRESHOLD
        rows.append((rec.get("name"), rec.get("prototype"), rec.get("model"),
                     Raw(format_difference(rd, rec.get("prototype"), rec.get("model")))))
        classes.append("mismatch" if bad else "")
    n_bad = classes.count("mismatch")
    return Section("Similarity parameters",
                   f"<p>{n_bad} of {len(rows)} parameters differ by more than "
                   f"{100 * MISMATCH_THRESHOLD:.0f} % (highlighted). Relative difference = "
                   "|model - prototype| / |prototype|; far from 1 the model/prototype ratio "
                   "is given instead (x13.2 = 13.2 times the prototype's value). Symbols "
                   "are explained in the glossary.</p>"
                   + html_table(["parameter", "prototype", "model", "relative difference"],
                                rows, classes, css_class="similarity"))


def _glossary_section(run: RunData) -> Section | None:
    """Symbol, formula, equation and meaning of every parameter of the similarity table."""
    names = [str(rec.get("name")) for rec in (run.point or {}).get("similarity") or []]
    if not names:
        return None
    return Section("Glossary", "<p>The similarity parameters of the table above, as computed "
                   "by hypate (equation numbers refer to the dissertation).</p>"
                   + html_table(["symbol", "formula", "equation", "physical meaning"],
                                glossary_rows(names), css_class="glossary"))


def _figures_section(run: RunData) -> Section:
    parts = []
    for make in (pareto_figure, history_figure, response_figure, schedule_figure):
        try:
            parts.append(make(run))
        except (ValueError, RuntimeError, KeyError, IndexError, TypeError) as exc:
            close_figures()
            parts.append(f"<p class='warn'>Figure {make.__name__.strip('_')} failed: "
                         f"{html.escape(str(exc))}</p>")
    body = "".join(p for p in parts if p)
    return Section("Figures", body or "<p class='note'>No figure: no successful evaluation "
                   "and no response file.</p>")


def _pareto_section(run: RunData) -> Section | None:
    ok = run.ok
    if ok.empty or not run.objectives:
        return None
    F = ok[run.objectives].to_numpy(float)
    if len(run.objectives) == 2:
        sel = ok[non_dominated_mask(F)].sort_values(run.objectives[0], kind="stable")
        title = f"Pareto set ({len(sel)} design{'s' if len(sel) != 1 else ''})"
    else:
        sel = ok.nsmallest(10, run.objectives[0])
        title = f"Best designs ({len(sel)})"
    header = ["evaluation"] + [f"{v} ({variable_unit(v)})" for v in run.variables] + \
        [f"{o} (%)" for o in run.objectives]
    rows = [[int(i)] + [r[v] for v in run.variables] + [Raw(pct(r[o])) for o in run.objectives]
            for i, r in sel.iterrows()]
    marked = ["design" if int(i) == run.point_id else "" for i in sel.index]
    note = ("<p>The design point's row is marked (&#9733;).</p>" if "design" in marked
            else "")
    return Section(title, note + html_table(header, rows, marked))


def _scatter_how(block: dict[str, Any]) -> str:
    """How a propagation's statistics were obtained (one sentence part)."""
    if block["method"] == "chaos":
        return (f"a polynomial chaos (degree {block['order']}) of the response histories, "
                f"leave-one-out error {pct(block['chaos_error'])} of the std")
    return ("the simulator samples themselves (the chaos does not hold here: a scattered "
            f"model failed or the leave-one-out error is {pct(block['chaos_error'])} of the "
            "std), a failed model counting as J = infinity (shown as -)")


def _statistics_rows(label: str | None, block: dict[str, Any]) -> list[tuple[Any, ...]]:
    lead = () if label is None else (label,)
    return [(*lead, name, *(Raw(pct(st[q])) for q in ("mean", "std", "q10", "q50", "q90")))
            for name, st in block["objectives"].items()]


def _robustness_section(run: RunData) -> Section | None:
    """A study with ``[uncertainty]``: the design point under the study's scatter
    (``design_point.json`` ``scatter``, or for a robust study ``robust`` beside
    ``nominal.robust``): statistics of J, their distributions and the Sobol indices."""
    point = run.point or {}
    nominal = point.get("nominal")
    scatter = point.get("robust") if nominal else point.get("scatter")
    if not scatter:
        return None
    if "objectives" not in scatter:
        return Section("Robustness", f"<p>The scatter could not be propagated at the design "
                       f"point: {html.escape(str(scatter.get('status')))}</p>")
    inputs = ", ".join(f"{n}: {d}" for n, d in scatter["inputs"].items())
    body = (f"<p>The design point as the tunnel would test it, under the study's scatter "
            f"({html.escape(inputs)}): {scatter['samples']} simulator runs at scrambled-"
            f"Sobol samples ({scatter['failed']} failed), on the nominal design's time "
            f"mapping; statistics from {html.escape(_scatter_how(scatter))}.")
    if not nominal:
        body += " The optimization itself is nominal.</p>"
        body += html_table(["objective", "mean", "std", "q10", "q50", "q90"],
                           _statistics_rows(None, scatter))
    else:
        stat = scatter["statistic"]
        search = point.get("robust_search") or {}
        candidate = search.get("robust") or {}
        other = nominal.get("robust") or {}
        body += (f" The robust search minimizes the {html.escape(stat)} of J_u and J_T under "
                 "that scatter on its surrogate; its best design and the nominal optimum of "
                 "the same study (its own campaign, "
                 f"{html.escape(Path(nominal['directory']).name)}/) "
                 "are both verified on the simulator, and the design point is the better "
                 f"of the two: the {html.escape(point.get('chosen', 'robust search'))}.</p>")
        blocks = {name: block for name, block in (("robust search's design", candidate),
                                                  ("nominal optimum", other))
                  if "objectives" in block}
        rows = [row for name, block in blocks.items() for row in _statistics_rows(name, block)]
        body += html_table(["design", "objective", "mean", "std", "q10", "q50", "q90"], rows)
        predicted = (search.get("surrogate") or {}).get("objectives") or {}
        if predicted:
            body += ("<p>The surrogate's " + html.escape(stat) + " at the robust search's "
                     "design: " + ", ".join(
                         f"{html.escape(o)} {pct(v['predicted'])} (std {pct(v['std'])})"
                         for o, v in predicted.items()) + ".</p>")
        blocks = {k: b for k, b in blocks.items() if "distribution" in b}
        if blocks:
            body += figure_html(distribution_figure(blocks), run, "distribution",
                                "Distributions of J under the study's scatter: the robust "
                                "search's design and the nominal optimum")
    for msg in dict.fromkeys(scatter.get("failures") or []):
        body += f"<p class='note'>failed: {html.escape(msg)}</p>"
    caveat = ("" if scatter.get("sobol_valid") else
              " (from the chaos, which does not hold here: indicative only)")
    body += figure_html(sobol_figure(scatter["sobol"]), run, "sobol",
                        "First-order Sobol indices at the design point: the share of each "
                        f"input's scatter in the variance of J{caveat}")
    return Section("Robustness", body)


def _laws_section(run: RunData) -> Section | None:
    """The "Scaling laws" section: shown for a sweep directory or a sweep point's
    sub-directory (``sweep.json`` in it or in its parent) with finished points at two or more
    scales; left out otherwise."""
    directory = Path(run.directory)
    for cand in (directory, directory.parent):
        if (cand / SWEEP_JSON).is_file():
            sweep = load_sweep(cand)
            break
    else:
        return None
    if len({p.xi for p in sweep.points}) < 2:
        return None
    laws = laws_of_run(sweep)
    img = figure_html(laws_figure(laws), run, "laws",
                      "Design variables against xi: numerical points (hollow: at a "
                      "bound, not fitted), fitted law, analytical law (Fig. 9.12)")
    rows = laws_table(laws)
    cols = list(rows[0]) if rows else []
    table = html_table(cols, [[r[c] for c in cols] for r in rows])
    chosen = materials_by_scale(sweep.points)
    if chosen:  # categorical: no power law
        table += "<p>Model material chosen at each scale (not fitted): " + ", ".join(
            f"&xi; = {c['xi']:g}: {html.escape(c['material'])}" for c in chosen) + ".</p>"
    return Section("Scaling laws", img + table)


def _prediction_section(run: RunData) -> Section | None:
    """``hypate predict RUN_DIR``'s result (``RUN_DIR/prediction/prediction.json``): the
    measured file, the time mapping, each predicted history's band and in-band fraction,
    and the page with the figure; left out before a prediction."""
    try:
        summary = json.loads((run.directory / PREDICTION_DIR / PREDICTION_JSON).read_text())
        histories = summary["histories"].items()
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return None
    rows = [(f"{name} [{h.get('unit', '')}]", Raw(pct(h.get("J"))), h.get("half_width"),
             Raw(pct(h.get("in_band")))) for name, h in histories]
    page = run.directory / PREDICTION_DIR / PREDICTION_HTML
    intro = (f"<p>Measured model test <code>{html.escape(str(summary.get('measured')))}</code>"
             f" ({fmt(summary.get('points'))} points) mapped onto the prototype through the "
             f"{html.escape(str(summary.get('source')))}: prototype time = "
             f"{fmt(summary.get('time_ratio'))} x model time.</p>")
    link = (f"<p>Figure and band parts: <a href='{PREDICTION_DIR}/{PREDICTION_HTML}'>"
            f"{PREDICTION_DIR}/{PREDICTION_HTML}</a>.</p>" if page.is_file() else "")
    return Section("Prediction", intro + html_table(
        ["history", "J of the design point", "band half-width", "simulated prototype in band"],
        rows) + link)


#: The built-in section builders, in page order (registered plug-ins follow them).
BUILTIN_SECTIONS: tuple[Callable[[RunData], Section | None], ...] = (
    _study_section, _design_section, _admissibility_section, seeds_section,
    _similarity_section, _glossary_section,
    _robustness_section, _figures_section, _pareto_section, statistics_section,
    warnings_section, _laws_section, _prediction_section)
