"""What-ifs: evaluate one model design of a study, no optimization (``hypate whatif``).

The tunnel engineer's question "what if we only get 6 MPa stagnation pressure?" is::

    hypate whatif quickstart --set p0=6e6

Rules (documented in ``--help`` and the README):

* ``--set NAME=VALUE`` (repeatable) sets a design value in SI units. ``NAME`` is one of the
  study's design variables, one of its ``[fixed]`` values (overridden), or any other design
  variable of :data:`hypate.scaling.workflow.vocabulary.variables.DESIGN_VARIABLES` (applied as an
  extra fixed value and flagged). Unknown names exit 2 naming ``--set``.
* ``--set material=NAME`` picks the model material: one of the study's categorical
  ``[variables] material`` values, or, for a study with a fixed ``[model] material``, any
  library material or ``[materials.NAME]`` of the study (an extra, flagged).
* Variables not set take the **midpoint of their bounds** (arithmetic mean; a categorical
  material its first listed value), so no value is required; the output says which values were set
  and which are midpoints. With ``--base RUN_DIR`` (or a ``design_point.json``) they take the run's
  design point instead: "the optimized model, but with only 6 MPa".
* A value outside its bounds (or outside the tunnel envelope / manufacturing limits) is
  evaluated anyway -- that is the point of a what-if -- and flagged in the output.
* A study with a ``[sweep]`` (scales, flight conditions) is evaluated at one of its points:
  ``--point LABEL`` (``M7_H20km``, ``xi_3``: the sub-directory names of its run), or the
  point whose run directory ``--base`` is (``--base runs/envelope/M7_H20km``:
  :func:`base_point`), else at the study's own scale and condition, with a note
  (:func:`at_sweep_point`). The result's ``point`` field names the point (None).
* ``--sweep NAME=LOW:HIGH:N`` evaluates N designs with ``NAME`` linearly spaced from LOW to
  HIGH (other values as above) and writes ``whatif_<NAME>.png`` and ``whatif_<NAME>.csv`` to
  ``--out`` (default: the current directory).

Printed: J_u, J_T, J_s (relative RMS errors, Eq. 6.4 / 9.8), the admissibility table (what
the model goes through against its material's limits, its tunnel's test section and run
time, :mod:`hypate.scaling.workflow.vocabulary.admissibility`) and the prototype's own stress, the
similarity-parameter table
(prototype / model / relative difference, ``*`` above 10 %), and the constraint activity:
bounds hit or left, the residuals of the study's cheap equality constraints (Eq. 9.7) and,
for a heater schedule of shape ``"increasing"`` (``"decreasing"``), whether its control
points (``--set T_rad[1]=900``) still increase (decrease); a design against the shape is
evaluated and flagged.
``--json`` prints one JSON object instead (fields in :func:`evaluate_whatif`).
``--scatter [--samples N]`` propagates the study's ``[uncertainty]`` at the design instead
(:func:`scatter_whatif`; JSON: the ``robust`` block's fields). A model that
fails (e.g. flutters before the prototype's end) is a valid answer: status ``"failed"``
with the reason, exit code 0.
"""
from __future__ import annotations

import csv
import dataclasses
import json
import math
import re
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
from hypate.scaling.engine.propagation import expansion_terms
from hypate.scaling.workflow.campaigns.rundir import DESIGN_POINT_JSON, SWEEP_JSON
from hypate.scaling.workflow.campaigns.verdict import verdict_fields
from hypate.scaling.workflow.vocabulary.admissibility import admissible
from hypate.scaling.workflow.vocabulary.configuration import with_choice
from hypate.scaling.workflow.vocabulary.derived import study_at, sweep_points
from hypate.scaling.workflow.vocabulary.problem import ScalingProblem
from hypate.scaling.workflow.vocabulary.spec import MATERIAL
from hypate.scaling.workflow.vocabulary.study import Study, constant_material
from hypate.scaling.workflow.vocabulary.uncertainty import propagate_or_failure
from hypate.scaling.workflow.vocabulary.variables import CATEGORICAL, DESIGN_VARIABLES, HARD_LIMITS
from hypate.solvers.config import resolve_material
from hypate.solvers.errors import InputError
from hypate.solvers.numerics.files import atomic_file, ensure_directory

#: ``plot(rows, name, path, bounds=..., title=...) -> Path`` draws a sweep's figure.
SweepPlot = Callable[..., Path]


#: Relative tolerance of "at a bound" (as :meth:`ScalingProblem.active_bounds`).
BOUND_RTOL = 1e-3


#: Tolerance of a satisfied cheap equality constraint (log-space residual).
EQUALITY_TOL = 1e-8


#: Relative difference above which a similarity parameter is flagged (10 %).
MISMATCH = 0.10


# -- the what-if problem --------------------------------------------------------------------
class WhatIf:
    """A study's scaling problem with user-set design values (midpoints elsewhere).

    Parameters
    ----------
    study : scaling.study.Study
    values : mapping
        ``{name: value}`` set by the user (SI units).
    option : str
        The input named in errors (``set``, ``sweep``; the CLI shows its flag).
    """

    def __init__(self, study: Any, values: Mapping[str, float | str], option: str = "set",
                 base: Mapping[str, float] | None = None) -> None:


        self.study = study
        spec, values = study.spec, dict(values)
        #: ``--set NAME=VALUE`` of a categorical variable, by name: a study value's level,
        #: or for a study that fixes it the template with the value (an extra)
        self.chosen: dict[str, str] = {}
        self.extra: list[str] = []
        for name in [n for n in values if n in CATEGORICAL]:
            spec, level = self._choice(study, spec, name, values[name], option)
            if level is None:
                del values[name]
            else:
                values[name] = level
        known = list(spec.names) + [n for n in spec.fixed if n not in spec.names]
        others = [n for n in DESIGN_VARIABLES if n not in known]
        fixed = dict(spec.fixed)
        for name, value in values.items():
            if name in spec.names:
                continue
            if name in spec.fixed:
                fixed[name] = float(value)
            elif name in DESIGN_VARIABLES:
                fixed[name] = float(value)
                self.extra.append(name)
            else:
                raise InputError(option, f"unknown design variable {name!r}; the study's "
                                 f"variables are {', '.join(spec.names)}"
                                 + (f" (fixed: {', '.join(spec.fixed)})" if spec.fixed else "")
                                 + f"; other design variables: {', '.join(others)}")
        self.spec = dataclasses.replace(spec, fixed=fixed) if fixed != spec.fixed else spec
        self.problem = ScalingProblem(self.spec)
        self.values = dict(values)
        self.option = option
        self.base = {k: float(v) for k, v in (base or {}).items() if k in spec.names}

    def _choice(self, study: Any, spec: Any, name: str, value: str | float, option: str
                ) -> tuple[Any, float | None]:
        """(spec, level) of ``--set NAME=VALUE`` of a categorical variable: a name (or level
        number) of the study's values, or for a study that fixes it any value the row
        allows (a material: of the library or the study's ``[materials.NAME]``), the
        template made with it (level None)."""
        if name in spec.levels:
            names = spec.level_names(name)
            if isinstance(value, str) and value not in names:
                raise InputError(option, f"{name}: {value!r} is not one of the study's "
                                 f"values ({', '.join(names)})")
            level = names.index(value) if isinstance(value, str) else float(value)
            if level not in range(len(names)):
                raise InputError(option, f"{name}: a level in [0, {len(names) - 1}] "
                                 f"({', '.join(names)}); got {value}")
            self.chosen[name] = names[int(level)]
            return spec, float(level)
        allowed = DESIGN_VARIABLES[name].choices
        if not isinstance(value, str) or (allowed and value not in allowed):
            raise InputError(option, f"{name}: give one of "
                             + (", ".join(allowed) if allowed else "the material names, "
                                "e.g. material=inconel718"))
        chosen: Any = value
        if name == MATERIAL:
            raw = study.raw
            chosen = resolve_material(value, {}, raw.materials, field=option)
            if raw.model.temperature_independent:
                chosen = constant_material(chosen, raw.model.initial_temperature)
        self.chosen[name] = value
        self.extra.append(name)
        return dataclasses.replace(spec, model=with_choice(spec.model, name, chosen)), None

    def design_vector(self, overrides: Mapping[str, float] | None = None) -> np.ndarray:
        """Design vector: set values, then ``overrides``, midpoints elsewhere (a
        categorical variable: its first listed value)."""
        vals = {**self.base, **self.values, **(overrides or {})}
        return np.array([float(vals.get(v.name, v.lower if v.name in self.spec.levels
                                        else 0.5 * (v.lower + v.upper)))
                         for v in self.spec.variables])

    def sources(self, overrides: Mapping[str, float] | None = None) -> dict[str, str]:
        """Where each design value comes from: set / sweep / midpoint / fixed / extra."""
        out = {}
        for v in self.spec.variables:
            out[v.name] = ("sweep" if overrides and v.name in overrides else
                           "set" if v.name in self.values else
                           "design point" if v.name in self.base else
                           "first listed" if v.name in self.spec.levels else "midpoint")
        for name in self.chosen:
            if name in self.extra:
                out[name] = f"extra (set; the study fixes another {name})"
        for name in self.spec.fixed:
            if name not in out:
                out[name] = ("extra (not a study variable)" if name in self.extra else
                             "fixed (set)" if name in self.values else "fixed")
        return out

    def check(self, x: np.ndarray) -> None:
        """Raise InputError (naming the option) when the design cannot be built at all."""
        try:
            self.problem.model_configuration(x)
        except InputError as exc:
            name = exc.field.split(".", 1)[-1]
            raise InputError(f"{self.option} {name}", exc.message) from None

    def constraints(self, x: np.ndarray) -> dict[str, Any]:
        """Bounds hit/left, tunnel envelope and manufacturing limits, equality residuals."""

        design = self.problem.design(x)
        bounds: list[dict[str, Any]] = []
        limits = {v.name: (v.lower, v.upper, "bounds") for v in self.spec.variables
                  if v.name not in self.spec.levels}  # a level, no bound to hit
        tunnel = self.study.tunnel
        if tunnel is not None:
            for name, (lo, hi) in tunnel.bounds().items():
                if name in design and name not in limits:
                    limits[name] = (lo, hi, f"tunnel {tunnel.name}")
        for name, (lo, hi) in HARD_LIMITS.items():
            if name in design and name not in limits:
                limits[name] = (lo, hi, "allowed range")
        active, outside = [], []
        for name, (lo, hi, kind) in limits.items():
            value = float(design[name])
            span = hi - lo
            if value < lo - 1e-12 * max(1.0, abs(lo)):
                state = "below lower"
            elif value > hi + 1e-12 * max(1.0, abs(hi)):
                state = "above upper"
            elif value <= lo + BOUND_RTOL * span:
                state = "at lower"
            elif value >= hi - BOUND_RTOL * span:
                state = "at upper"
            else:
                state = "inside"
            if state.startswith("at"):
                active.append(f"{name}={state[3:]}")
            elif state != "inside":
                outside.append(f"{name} {state} ({kind} [{lo:g}, {hi:g}])")
            bounds.append({"name": name, "value": value, "lower": lo, "upper": hi,
                           "kind": kind, "state": state})
        equalities = []
        for name, con in zip(self.spec.equalities, self.problem.cheap_constraints()):
            r = float(np.max(np.abs(np.atleast_1d(con.fun(np.asarray(x, float))))))
            equalities.append({"name": name, "residual": r, "satisfied": r <= EQUALITY_TOL})
        inequalities = []
        for name, sign in self.spec.monotone:
            T = np.asarray(x, float)[self.spec.schedule_indices(name)]
            # the largest step against the shape between control points
            drop = float(np.max(sign * (T[:-1] - T[1:])))
            shape, against = ("increasing", "decrease") if sign > 0 else ("decreasing",
                                                                          "increase")
            inequalities.append({"name": f"{name} {shape}", against: max(drop, 0.0),
                                 "satisfied": drop <= 0.0})
            if drop > 0.0:
                outside.append(f"{name} schedule {against}s by {drop:g} K between control "
                               f"points (shape \"{shape}\")")
        return {"bounds": bounds, "active": active, "outside": outside,
                "equalities": equalities, "inequalities": inequalities}

    def evaluate(self, x: np.ndarray) -> dict[str, Any]:
        """J_u, J_T, J_s of one design; a failing model gives status ``"failed"``. The
        model's run extremes (:meth:`Response.extremes`) are kept in ``extremes`` (None
        when it failed) for its admissibility."""
        t0 = time.perf_counter()
        out: dict[str, Any] = {"status": "ok", "message": "",
                               "objectives": {"J_u": None, "J_T": None, "J_s": None},
                               "extremes": None}
        try:
            err, _, aux = self.problem.outputs(self.problem.model_configuration(x))
        except InputError:
            raise
        except Exception as exc:  # noqa: BLE001 - any model failure is an answer, not a crash
            out["status"], out["message"] = "failed", f"{type(exc).__name__}: {exc}"
        else:
            out["objectives"] = {k: (float(v) if math.isfinite(v) else None)
                                 for k, v in err.items()}
            out["extremes"] = aux["extremes"]
        out["seconds"] = time.perf_counter() - t0
        return out


def evaluate_whatif(study: Any, values: Mapping[str, float | str],
                    base: Mapping[str, float] | None = None) -> dict[str, Any]:
    """Evaluate one what-if design of ``study``.

    Parameters
    ----------
    study : scaling.study.Study
    values : mapping
        ``{name: value}`` (SI); others take ``base`` values or their midpoints.
    base : mapping, optional
        Values of the unset variables (e.g. a run's design point).

    Returns
    -------
    dict
        ``study``, ``design`` (name -> value, fixed values included), ``sources`` (name ->
        ``"set"``/``"midpoint"``/``"fixed"``...), each categorical variable's value by its
        name (``material``: when the study chooses it or ``--set material=NAME`` sets it),
        ``objectives`` (``J_u``, ``J_T``, ``J_s``; ``None`` when the model failed),
        ``status`` (``"ok"``/``"failed"``), ``message``, ``similarity`` (list of
        ``{"name", "prototype", "model", "relative_difference"}``),
        ``constraints`` (``bounds`` list, ``active`` names, ``outside`` flags,
        ``equalities`` residuals, ``inequalities``: a monotone schedule's ``name``,
        ``decrease`` (K; ``increase`` for a decreasing one) and ``satisfied``),
        ``model_time_step`` (s), ``seconds``, and the admissibility fields of
        :func:`~hypate.scaling.workflow.campaigns.verdict.verdict_fields`: ``admissible``,
        ``admissibility`` (rows), ``binding``, ``responses`` (``model``, ``prototype``),
        ``prototype_admissibility``, ``prototype_yields``, ``limits``.
    """
    w = WhatIf(study, values, base=base)
    x = w.design_vector()
    w.check(x)
    result = {"study": study.name, "design": w.problem.design(x), "sources": w.sources()}
    result.update({**w.chosen, **w.problem.choice_names(x)})  # categorical values by name
    result.update(w.evaluate(x))
    result.update(verdict_fields(w.problem, x, result.pop("extremes")))
    result["similarity"] = w.problem.similarity(x)
    result["constraints"] = w.constraints(x)
    result["model_time_step"] = w.problem.model_time_step(w.problem.model_configuration(x))
    return result


def scatter_whatif(study: Any, values: Mapping[str, float | str],
                   base: Mapping[str, float] | None = None, samples: int | None = None,
                   progress: Callable[[int, int], None] | None = None) -> dict[str, Any]:
    """Propagate the study's ``[uncertainty]`` at one what-if design (``--scatter``).

    Returns
    -------
    dict
        The ``robust`` block of
        :func:`hypate.scaling.workflow.vocabulary.uncertainty.propagate_design` (``statistic``,
        ``samples``, ``objectives``, ``sobol`` ...) for the design of
        :func:`evaluate_whatif` (same ``values`` / ``base`` rules), with ``status`` ``"ok"``,
        or ``"failed: ..."`` when too many scattered models fail; seed: the study's.
    """
    if study.uncertainty is None:
        raise InputError("scatter", f"study {study.name} has no [uncertainty] table")
    if samples is not None:
        terms = expansion_terms(len(study.uncertainty.inputs), study.uncertainty.order)
        if not terms <= samples <= 4096:
            raise InputError("samples", f"must be in [{terms}, 4096] (the order-"
                             f"{study.uncertainty.order} chaos has {terms} terms); got {samples}")
    w = WhatIf(study, values, base=base)
    x = w.design_vector()
    w.check(x)
    return propagate_or_failure(w.problem, x, study.uncertainty, samples=samples,
                                seed=study.optimizer.seed, progress=progress)


def sweep_whatif(study: Any, values: Mapping[str, float | str], name: str, low: float,
                 high: float, n: int, out_dir: str | Path = ".",
                 base: Mapping[str, float] | None = None, plot: SweepPlot | None = None
                 ) -> dict[str, Any]:
    """Evaluate ``n`` designs with ``name`` in ``linspace(low, high, n)``; write the CSV and,
    with ``plot`` (the report's ``plot_sweep``: the workflow draws no figures), the PNG.

    Returns
    -------
    dict
        ``name``, ``values``, ``rows`` (per design: ``value``, ``J_u``, ``J_T``, ``J_s``,
        ``status``, ``message``, ``outside`` flags, ``seconds``), ``csv``, ``png`` paths.
    """

    if name in values:
        raise InputError("sweep", f"{name} is also given with set")
    w = WhatIf(study, values, base=base)
    if name not in w.spec.names:
        WhatIf(study, {**values, name: low}, option="sweep")  # validates the name
    grid = np.linspace(low, high, n)
    out_dir = Path(out_dir)
    ensure_directory(out_dir)
    rows = []
    for value in grid:
        if name in w.spec.names:
            x = w.design_vector({name: float(value)})
            ww = w
        else:
            ww = WhatIf(study, {**values, name: float(value)}, option="sweep", base=base)
            x = ww.design_vector()
        ww.check(x)
        ev = ww.evaluate(x)
        rows_adm = ww.problem.admissibility_rows(ww.problem.model_configuration(x),
                                                 ev["extremes"])
        row = {"value": float(value), **ev["objectives"], "status": ev["status"],
               "message": ev["message"], "outside": ww.constraints(x)["outside"],
               "admissible": ev["extremes"] is not None and admissible(rows_adm),
               "violated": [r["check"] for r in rows_adm if r["ok"] is False
                            and r["mode"] == "constraint"],
               "seconds": ev["seconds"], "design": ww.problem.design(x)}
        rows.append(row)
    safe = re.sub(r"[^\w.-]+", "_", name)
    csv_path = out_dir / f"whatif_{safe}.csv"
    design_names = list(rows[0]["design"])
    with atomic_file(csv_path, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(design_names + ["J_u", "J_T", "J_s", "status", "message", "outside",
                                        "admissible", "violated", "seconds"])
        for r in rows:
            writer.writerow([repr(float(r["design"][k])) for k in design_names]
                            + ["" if r[o] is None else repr(r[o]) for o in ("J_u", "J_T", "J_s")]
                            + [r["status"], r["message"], "; ".join(r["outside"]),
                               str(r["admissible"]).lower(), "; ".join(r["violated"]),
                               f"{r['seconds']:.3f}"])
    bounds = next(((v.lower, v.upper) for v in w.spec.variables if v.name == name), None)
    png = None if plot is None else plot(rows, name, out_dir / f"whatif_{safe}.png",
                                         bounds=bounds,
                                         title=f"{study.name}: what if {name} varies")
    for r in rows:
        r.pop("design")
    return {"name": name, "values": grid.tolist(), "rows": rows, "csv": str(csv_path),
            "png": None if png is None else str(png),
            "base_design": w.problem.design(w.design_vector()),
            "sources": w.sources({name: low})}


def base_point(study: Study, base: str | Path) -> str | None:
    """The label of the ``[sweep]`` point whose run directory ``base`` is (or whose
    ``design_point.json``): the point its design point records (``"study": "NAME
    [LABEL]"``), else the directory's name inside a sweep run (beside ``sweep.json``); None
    when it is no point of ``study``'s sweep."""
    if study.sweep is None:
        return None
    labels = {p.label for p in sweep_points(study)}
    folder = Path(base).resolve()
    folder = folder.parent if folder.is_file() else folder
    try:
        recorded = json.loads((folder / DESIGN_POINT_JSON).read_text()).get("study", "")
    except (OSError, ValueError, AttributeError):
        recorded = ""
    found = re.search(r"\[([^\[\]]+)\]\s*$", str(recorded))
    if found and found.group(1) in labels:
        return found.group(1)
    if folder.name in labels and (folder.parent / SWEEP_JSON).is_file():
        return folder.name
    return None


def at_sweep_point(study: Study, label: str) -> Study:
    """The single study of the point ``label`` of ``study``'s ``[sweep]`` (its scale and
    flight condition); InputError on ``--point`` for an unknown label or a study without a
    sweep."""
    if study.sweep is None:
        raise InputError("--point", f"study {study.name} has no [sweep]")
    points = {p.label: p for p in sweep_points(study)}
    if label not in points:
        raise InputError("--point", f"{label!r} is not a point of the sweep; one of "
                         f"{', '.join(points)}")
    return study_at(study, points[label], first=False)


def load_base(path: str | Path) -> dict[str, float]:
    """The ``design`` of a run directory's ``design_point.json`` (InputError on ``--base``)."""
    path = Path(path)
    if path.is_dir():
        path = path / DESIGN_POINT_JSON
    try:
        design = json.loads(path.read_text()).get("design")
    except (OSError, ValueError, AttributeError) as exc:
        raise InputError("base", f"cannot read a design point from {path}: {exc}") from None
    if not isinstance(design, dict) or not design:
        raise InputError("base", f"{path} holds no design point")
    return {str(k): float(v) for k, v in design.items()}


__all__ = ["WhatIf", "at_sweep_point", "base_point", "evaluate_whatif", "load_base",
           "scatter_whatif", "sweep_whatif"]
