"""The self-contained page of a full-scale prediction (``prediction.html`` of
``hypate predict``): what was mapped, through which scales (Eqs. 9.3, 9.5-9.6 and the
nondimensionalization of Sec. 9.2.1.1), the band and its parts, the figure.

The page shares the run report's style (:data:`hypate.scaling.report.html.PAGE_CSS`) and
tables (:func:`hypate.scaling.report.sections.html_table`); the figure is embedded as a
``data:`` URI, so the page can be mailed as it is.
"""
from __future__ import annotations

import html

from hypate.scaling.report.figures import embed_png
from hypate.scaling.report.html import PAGE_CSS
from hypate.scaling.report.numbers import format_number, format_percent
from hypate.scaling.report.sections import html_table
from hypate.scaling.workflow.analyses.predict import COVERAGE, Prediction

__all__ = ["prediction_page"]


def _scales_table(pred: Prediction) -> str:
    sc = pred.basis.scaling
    rows = [("time step [s] (Eqs. 9.3, 9.5-9.6)", sc.model_time_step, sc.prototype_time_step,
             sc.time_ratio),
            ("thickness h [m] (w / h)", sc.model_thickness, sc.prototype_thickness,
             sc.prototype_thickness / sc.model_thickness),
            ("stagnation temperature T0 [K] (T / T0)", sc.model_stagnation_temperature,
             sc.prototype_stagnation_temperature,
             sc.prototype_stagnation_temperature / sc.model_stagnation_temperature)]
    return html_table(["reference", "model", "prototype", "prototype / model"], rows)


def _band_table(pred: Prediction) -> str:
    rows = []
    for name, h in pred.histories.items():
        p = h.parts
        ref = pred.basis.scaling.reference(name, "prototype")
        rows.append((f"{name} [{h.unit}]", format_percent(p.J), p.crest_factor,
                     p.residual * ref,
                     None if p.scatter is None else COVERAGE * p.scatter * ref,
                     COVERAGE * p.measurement * ref, h.half_width,
                     format_percent(h.in_band)))
    return html_table(["history", "J of the design point", "crest factor",
                       "residual B", "scatter z sigma_s", "measurement z sigma_m",
                       "half-width H", "simulated prototype in band"], rows)


def prediction_page(pred: Prediction, png: bytes) -> str:
    """The prediction page (HTML5, no external reference).

    Parameters
    ----------
    pred : Prediction
    png : bytes
        The figure (:func:`hypate.scaling.report.figures.prediction_figure`).
    """
    b = pred.basis
    design = ", ".join(f"{k} = {format_number(v)}" for k, v in b.design.items())
    title = f"hypate prediction: {b.run_dir.name or b.run_dir}"
    span = f"[0, {format_number(b.model_span)}]"
    body = [
        f"<h1>{html.escape(title)}</h1>",
        f"<p>Measured model test <code>{html.escape(str(pred.measured.path))}</code> "
        f"({pred.time.size} time points) mapped onto the prototype through the "
        f"{html.escape(b.source)} of <code>{html.escape(str(b.run_dir))}</code> "
        f"(xi = {format_number(b.xi)}; {html.escape(design)}). The model's test span is "
        f"{span} s, {b.steps - 1} steps.</p>",
        "<h2>Mapping</h2>",
        "<p>Model step k matches prototype step k (matched nondimensional time): "
        "t<sub>p</sub> = t<sub>m</sub> &Delta;t<sub>p</sub> / &Delta;t<sub>m</sub>, "
        "w<sub>p</sub> = (w<sub>m</sub> / h<sub>m</sub>) h<sub>p</sub>, "
        "T<sub>p</sub> = (T<sub>m</sub> / T0<sub>m</sub>) T0<sub>p</sub>, with the "
        "references J_u and J_T compared.</p>",
        _scales_table(pred),
        "<h2>Band</h2>",
        "<p>H = B + z &radic;(&sigma;<sub>s</sub>&sup2; + &sigma;<sub>m</sub>&sup2;), "
        f"z = {COVERAGE:.3f}: B the largest nondimensional residual of the design point "
        "over its matched steps (crest factor times J times the prototype history's RMS), "
        "&sigma;<sub>s</sub> the spread of that RMS under the study's scatter "
        f"({html.escape(b.scatter_source)}), &sigma;<sub>m</sub> the RMS deviation of the "
        "measured history from the design point's simulated model. Prototype units; the "
        "last column compares with the simulated prototype.</p>",
        _band_table(pred),
        f'<figure>{embed_png(png, "predicted prototype histories")}<figcaption>Predicted '
        "prototype histories with their band (shaded) and the simulated prototype "
        "(dashed).</figcaption></figure>",
    ]
    return "\n".join(["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
                      '<link rel="icon" href="data:,">',
                      f"<title>{html.escape(title)}</title><style>{PAGE_CSS}</style></head>"
                      "<body>", *body, "</body></html>"])
