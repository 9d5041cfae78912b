"""Self-contained HTML report of a scaling run (what a test engineer mails around).

:func:`write_report` reads a run directory written by ``hypate run``
(:mod:`hypate.scaling.workflow.run`) -- also an *interrupted* one, where only ``evaluations.sqlite``
(and perhaps ``prototype.npz`` / ``classical.json``) exist -- and writes

* ``figures/*.png`` -- Pareto front with the classical baseline (Fig. 9.9 / 9.13 style),
  hypervolume history (two objectives) or best-J history (one objective), and the
  nondimensional response of the prototype vs the design-point model (Figs. 9.10, 9.11,
  9.14, 9.15 style: deflection / thickness and mean temperature / stagnation temperature
  over nondimensional time, with the LSA status of each step);
* ``report.html`` -- ONE page with every image embedded as a base64 ``data:`` URI, inline
  CSS, no JavaScript and no external reference, so that it can be sent by mail.

Sections (in order): *Study*, *Design point* (Table 9.8 style, with active constraints),
*Similarity parameters* (prototype / model / relative difference; > 10 % highlighted),
*Figures*, *Pareto set*, *Run statistics* (evaluations, failures grouped by reason, wall
time), then the extra sections.

Extending the report
--------------------
Two ways to add sections (e.g. the "Scaling laws" section of the laws helper):

* static: ``write_report(run_dir, extra_sections=[("Scaling laws", "<p>...</p>")])``;
* dynamic: a provider registered once at import time of the providing module::

      from hypate.scaling.report import html as report

      def laws_section(run: report.RunData) -> report.Section | None:
          if run.study is None:
              return None                      # nothing to say: section left out
          fig = ...                            # a matplotlib Figure
          img = report.figure_html(fig, run, "laws", "Design variables against xi")
          return report.Section("Scaling laws", img + report.html_table(...))

      report.register_section("scaling_laws", laws_section)

  List the providing module in :data:`SECTION_MODULES` so that :func:`write_report`
  imports it (and thereby registers it). Providers get the :class:`RunData` (study, evaluations, design point, responses) and
  return a :class:`Section` (or ``None``); they run after the built-in sections in
  registration order. A provider that raises is reported in the page (a short note), never
  breaks the report. HTML returned by providers is inserted verbatim: escape user text with
  :func:`html.escape` and embed images with :func:`figure_html` / :func:`embed_png`.
"""
from __future__ import annotations

import base64
import html
import io
import json
import math
import re
import warnings
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from hypate.scaling.engine.pareto import hypervolume, non_dominated_mask  # noqa: E402
from hypate.scaling.engine.store import EvaluationStore
from hypate.scaling.workflow.laws import (  # noqa: E402
    SWEEP_JSON,
    laws_figure,
    laws_of_run,
    laws_table,
    load_sweep,
)
from hypate.scaling.workflow.problem import ScalingProblem
from hypate.scaling.workflow.study import load_study
from hypate.scaling.workflow.tunnels import DESIGN_VARIABLES
from hypate.solvers.coupling.response import Response  # noqa: E402
from hypate.solvers.errors import InputError  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

__all__ = ["RunData", "Section", "SectionProvider", "load_run", "write_report",
           "register_section", "unregister_section", "figure_html", "embed_png",
           "html_table", "plot_sweep", "render_html", "variable_unit", "MISMATCH_THRESHOLD",
           "REPORT_NAME", "FIGURES_DIR"]

#: Relative difference above which a similarity parameter is highlighted (10 %).
MISMATCH_THRESHOLD = 0.10
#: Name of the report file in the run directory.
REPORT_NAME = "report.html"
#: Figure folder in the run directory.
FIGURES_DIR = "figures"
#: Reference point of the hypervolume history when the front dominates it (100 % errors).
HV_REFERENCE = np.array([1.0, 1.0])
_STORE = "evaluations.sqlite"
_RESERVED = {"iteration", "batch_index", "status", "message", "seconds", "seed"}


@dataclass(frozen=True)
class Section:
    """One report section: a title and its HTML body (inserted verbatim)."""

    title: str
    html: str


#: A dynamic section: ``provider(run) -> Section | None``.
SectionProvider = Callable[["RunData"], "Section | None"]
_PROVIDERS: dict[str, SectionProvider] = {}


def register_section(name: str, provider: SectionProvider) -> None:
    """Register a dynamic report section (appended after the built-in ones).

    Parameters
    ----------
    name : str
        Key of the provider; registering the same name again replaces it (idempotent
        module reloads).
    provider : callable
        ``provider(run: RunData) -> Section | None``; ``None`` leaves the section out.
    """
    _PROVIDERS[str(name)] = provider


def unregister_section(name: str) -> None:
    """Remove a registered provider (no error when absent)."""
    _PROVIDERS.pop(str(name), None)


@dataclass
class RunData:
    """Everything the report knows about one run directory.

    Attributes
    ----------
    directory : Path
    study : scaling.study.Study or None
        The study, when its file is known and still loads (see :func:`load_run`).
    study_path : str or None
    evaluations : pandas.DataFrame
        One row per evaluation in evaluation order: ``iteration, batch_index``, one column
        per design variable, one per objective, ``status, message, seconds, seed``.
    variables, objectives : list of str
        Column names of the design variables and objectives (``x0..``/``f0..`` when the
        study is unknown).
    point : dict or None
        ``design_point.json`` (public fields ``design``, ``objectives``, ``similarity``,
        ``active_constraints``), or rebuilt from the store for an interrupted run.
    point_rebuilt : bool
        True when ``point`` was rebuilt (``design_point.json`` missing).
    classical : dict or None
        ``classical.json`` (the left prong's baseline design).
    prototype, model : Response or None
        Prototype and design-point model responses.
    model_time_step : float or None
        Time step of the design-point model (s), for the nondimensional time axis.
    notes : list of str
        What could not be rebuilt, and why (shown at the top of the report).
    """

    directory: Path
    study: Any = None
    study_path: str | None = None
    evaluations: pd.DataFrame = field(default_factory=pd.DataFrame)
    variables: list[str] = field(default_factory=list)
    objectives: list[str] = field(default_factory=list)
    point: dict[str, Any] | None = None
    point_rebuilt: bool = False
    classical: dict[str, Any] | None = None
    prototype: Response | None = None
    model: Response | None = None
    model_time_step: float | None = None
    notes: list[str] = field(default_factory=list)

    @property
    def interrupted(self) -> bool:
        """True when the run has no ``design_point.json`` (killed or still running)."""
        return not (self.directory / "design_point.json").is_file()

    @property
    def ok(self) -> pd.DataFrame:
        """Successful evaluations with finite objectives."""
        df = self.evaluations
        if df.empty or not self.objectives:
            return df.iloc[0:0]
        F = df[self.objectives].to_numpy(float)
        return df[(df["status"] == "ok").to_numpy() & np.all(np.isfinite(F), axis=1)]

    def figure_path(self, name: str) -> Path:
        """``figures/<name>.png`` in the run directory (folder created)."""
        folder = self.directory / FIGURES_DIR
        folder.mkdir(parents=True, exist_ok=True)
        return folder / f"{name}.png"


# -- small HTML helpers ---------------------------------------------------------------------
def _fmt(value: Any, digits: int = 4) -> str:
    """Numbers to short text (``-`` for missing/NaN)."""
    if value is None:
        return "&ndash;"
    if isinstance(value, (bool, np.bool_)):
        return "yes" if value else "no"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        v = float(value)
        if not math.isfinite(v):
            return "&ndash;"
        return f"{v:.{digits}g}"
    return html.escape(str(value))


def _pct(value: Any) -> str:
    if value is None or not isinstance(value, (int, float, np.number)) \
            or not math.isfinite(float(value)):
        return "&ndash;"
    return f"{100.0 * float(value):.3g} %"


def html_table(header: Sequence[str], rows: Iterable[Sequence[Any]],
               row_classes: Sequence[str] | None = None, css_class: str = "") -> str:
    """An HTML table; header cells are escaped, numbers formatted to 4 significant digits.

    Parameters
    ----------
    header : sequence of str
    rows : iterable of sequences
        Cell values: numbers are formatted; strings are escaped, except instances of
        :class:`_Raw` (HTML kept verbatim).
    row_classes : sequence of str, optional
        A CSS class per row (``""`` for none), e.g. ``"mismatch"``.
    css_class : str
        CSS class of the table.
    """
    out = [f'<table class="{html.escape(css_class)}"><thead><tr>']
    out += [f"<th>{html.escape(str(h))}</th>" for h in header]
    out.append("</tr></thead><tbody>")
    for i, row in enumerate(rows):
        cls = row_classes[i] if row_classes is not None and i < len(row_classes) else ""
        out.append(f'<tr class="{cls}">' if cls else "<tr>")
        for cell in row:
            text = str(cell) if isinstance(cell, _Raw) else _fmt(cell)
            out.append(f"<td>{text}</td>")
        out.append("</tr>")
    out.append("</tbody></table>")
    return "".join(out)


class _Raw(str):
    """A string inserted into :func:`html_table` without escaping."""


def embed_png(path_or_bytes: str | Path | bytes, alt: str) -> str:
    """An ``<img>`` whose ``src`` is a base64 ``data:image/png`` URI (self-contained)."""
    data = path_or_bytes if isinstance(path_or_bytes, bytes) else Path(path_or_bytes).read_bytes()
    b64 = base64.b64encode(data).decode("ascii")
    return f'<img src="data:image/png;base64,{b64}" alt="{html.escape(alt)}">'


def figure_html(fig: Figure, run: RunData, name: str, caption: str) -> str:
    """Save ``fig`` as ``figures/<name>.png`` and return it embedded with a caption.

    The figure is closed afterwards.
    """
    path = run.figure_path(name)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    data = buf.getvalue()
    path.write_bytes(data)
    return (f'<figure>{embed_png(data, caption)}<figcaption>{html.escape(caption)}'
            f"</figcaption></figure>")


def variable_unit(name: str) -> str:
    """SI unit of a design variable (``"-"`` when dimensionless or unknown)."""

    base = re.sub(r"\[\d+\]$", "", name)
    var = DESIGN_VARIABLES.get(base)
    return var.unit if var is not None else "-"


# -- loading a run directory ----------------------------------------------------------------
def _read_json(path: Path, notes: list[str]) -> dict[str, Any] | None:
    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        notes.append(f"{path.name} unreadable ({exc}); ignored")
        return None
    return data if isinstance(data, dict) else None


def _read_response(path: Path, notes: list[str]) -> Response | None:
    if not path.is_file():
        return None
    try:
        return Response.load(path)
    except InputError as exc:
        notes.append(f"{path.name} unreadable ({exc.message}); ignored")
        return None


def _store_frame(path: Path) -> tuple[pd.DataFrame, dict[str, Any]]:

    with EvaluationStore(path) as store:
        df = store.to_dataframe()
        meta = {k: store.get_meta(k) for k in ("n_var", "n_obj", "study_path", "study")}
    return df, meta


def _study_candidates(run_dir: Path, explicit: str | Path | None, point: dict[str, Any] | None,
                      meta: dict[str, Any]) -> list[tuple[Path, bool]]:
    """Candidate study files: (path, certain). Uncertain ones must match the store."""
    out: list[tuple[Path, bool]] = []
    if explicit is not None:
        out.append((Path(explicit), True))
    for src in (point or {}, meta):
        for key in ("study_path", "study_file"):
            val = src.get(key)
            if isinstance(val, str) and val:
                p = Path(val)
                out.append((p if p.is_absolute() else run_dir / p, True))
                out.append((p, True))
    for name in ("study.toml",):
        if (run_dir / name).is_file():
            out.append((run_dir / name, True))
    name = (point or {}).get("study") or meta.get("study")
    if isinstance(name, str) and re.fullmatch(r"[\w.-]+", name):
        shipped = Path(__file__).resolve().parents[1] / "studies" / f"{name}.toml"
        out.append((shipped, False))
    return out


def _rename(df: pd.DataFrame, variables: list[str], objectives: list[str]) -> pd.DataFrame:
    mapping = {f"x{i}": n for i, n in enumerate(variables)}
    mapping.update({f"f{i}": n for i, n in enumerate(objectives)})
    return df.rename(columns=mapping)


def _names_from_csv(csv: Path, n_var: int, n_obj: int) -> tuple[list[str], list[str]] | None:
    try:
        cols = list(pd.read_csv(csv, nrows=0).columns)
    except (OSError, ValueError, pd.errors.EmptyDataError):
        return None
    middle = [c for c in cols if c not in _RESERVED and not re.fullmatch(r"g\d+", c)]
    if len(middle) != n_var + n_obj:
        return None
    return middle[:n_var], middle[n_var:]


def load_run(run_dir: str | Path, study_path: str | Path | None = None,
             simulate: bool = False) -> RunData:
    """Read a run directory (finished or interrupted) into a :class:`RunData`.

    Parameters
    ----------
    run_dir : path
        Directory written by ``hypate run``.
    study_path : path, optional
        The study file. Without it the study is looked up in ``design_point.json``
        (``study_path``), the store's metadata, ``run_dir/study.toml`` and finally the
        shipped ``studies/<study name>.toml`` (used only when its variable and objective
        counts match the store). When none is found the report shows what the store/CSV
        holds (variables ``x0..``, objectives ``f0..`` unless the CSV names them).
    simulate : bool
        For an interrupted run with a known study: simulate the rebuilt design point to
        plot its response (one model simulation). Off by default.

    Raises
    ------
    InputError
        ``run_dir`` is not a run directory (no ``evaluations.sqlite`` nor
        ``evaluations.csv``).
    """

    run_dir = Path(run_dir)
    store, csv = run_dir / _STORE, run_dir / "evaluations.csv"
    if not run_dir.is_dir():
        raise InputError("DIR", f"{run_dir} is not a directory")
    if not store.is_file() and not csv.is_file():
        raise InputError("DIR", f"{run_dir} is not a run directory (no {_STORE} or "
                         "evaluations.csv); run `hypate run STUDY.toml --out DIR` first")
    run = RunData(directory=run_dir)
    notes = run.notes
    point = _read_json(run_dir / "design_point.json", notes)
    run.classical = _read_json(run_dir / "classical.json", notes)
    if run.classical is None and point is not None and isinstance(point.get("classical"), dict):
        run.classical = point["classical"]

    meta: dict[str, Any] = {}
    if store.is_file():
        try:
            df, meta = _store_frame(store)
        except Exception as exc:  # noqa: BLE001 - sqlite3.DatabaseError and friends
            if not csv.is_file():
                raise InputError("DIR", f"{store} is not a readable evaluation store "
                                 f"({exc})") from None
            notes.append(f"{_STORE} unreadable ({exc}); using evaluations.csv")
            df = pd.read_csv(csv)
        else:
            df = df.drop(columns=[c for c in df.columns if re.fullmatch(r"g\d+", c)])
    else:
        df = pd.read_csv(csv)
        notes.append(f"no {_STORE}: evaluations from evaluations.csv")
    x_cols = [c for c in df.columns if re.fullmatch(r"x\d+", c)]
    f_cols = [c for c in df.columns if re.fullmatch(r"f\d+", c)]
    n_var = int(meta.get("n_var") or len(x_cols))
    n_obj = int(meta.get("n_obj") or len(f_cols))

    # -- the study ----------------------------------------------------------------------
    tried: list[str] = []
    for path, certain in _study_candidates(run_dir, study_path, point, meta):
        if not path.is_file():
            if certain and study_path is not None and path == Path(study_path):
                raise InputError("--study", f"file not found: {path}")
            continue
        try:
            study = load_study(path)
        except InputError as exc:
            if study_path is not None and path == Path(study_path):
                raise
            tried.append(f"{path}: {exc}")
            continue
        fits = len(study.spec.names) == n_var and len(study.spec.objectives) == n_obj
        if not fits and (x_cols or f_cols):
            msg = (f"study {path} has {len(study.spec.names)} variables / "
                   f"{len(study.spec.objectives)} objectives, the run {n_var} / {n_obj}")
            if study_path is not None and path == Path(study_path):
                raise InputError("--study", msg)
            tried.append(msg)
            continue
        run.study, run.study_path = study, str(path)
        if not certain:
            notes.append(f"study file not recorded in the run; assumed the shipped {path.name}")
        break
    if run.study is None:
        notes.append("study file unknown (pass --study STUDY.toml): the study summary and "
                     "similarity table are limited to what the run directory holds"
                     + (f" ({'; '.join(tried)})" if tried else ""))

    if run.study is not None:
        run.variables = list(run.study.spec.names)
        run.objectives = list(run.study.spec.objectives)
    elif x_cols or f_cols:
        names = _names_from_csv(csv, n_var, n_obj) if csv.is_file() else None
        run.variables, run.objectives = names if names else (x_cols, f_cols)
    else:  # the CSV already names its columns; take them from design_point.json if possible
        if point and isinstance(point.get("design"), dict):
            run.variables = [c for c in point["design"] if c in df.columns]
        if point and isinstance(point.get("objectives"), dict):
            run.objectives = [c for c in point["objectives"] if c in df.columns]
        if not run.objectives:
            run.objectives = [c for c in df.columns if c in ("J_u", "J_T", "J_s")]
        if not run.variables:
            run.variables = [c for c in df.columns if c not in _RESERVED
                             and c not in run.objectives]
    if x_cols or f_cols:
        df = _rename(df, run.variables, run.objectives)
    run.evaluations = df.reset_index(drop=True)

    # -- design point -------------------------------------------------------------------
    run.prototype = _read_response(run_dir / "prototype.npz", notes)
    if point is not None:
        run.point = point
        run.model = _read_response(run_dir / "design_point.npz", notes)
        mts = point.get("model_time_step")
        run.model_time_step = float(mts) if isinstance(mts, (int, float)) else None
        stats = point.get("statistics") or {}
        if isinstance(stats.get("evaluations"), int) and stats["evaluations"] < len(df):
            notes.append(f"the store holds {len(df)} evaluations, design_point.json "
                         f"{stats['evaluations']}: the run was resumed and not finished; the "
                         "design point may be outdated")
    else:
        notes.append("design_point.json missing (interrupted run): the design point was "
                     "rebuilt from the evaluations")
        run.point = _rebuild_point(run, simulate)
        run.point_rebuilt = True
    return run


def _rebuild_point(run: RunData, simulate: bool) -> dict[str, Any] | None:
    """Design point of an interrupted run: the successful evaluation with the smallest
    max(J) (the runner's criterion, Sec. 9.2.3)."""
    ok = run.ok
    if ok.empty:
        return None
    score = ok[run.objectives].to_numpy(float).max(axis=1)
    row = ok.index[int(np.argmin(score))]
    rec = run.evaluations.loc[row]
    design = {n: float(rec[n]) for n in run.variables}
    point: dict[str, Any] = {
        "design": design, "objectives": {o: float(rec[o]) for o in run.objectives},
        "similarity": [], "active_constraints": [], "evaluation": int(row)}
    if run.study is None:
        return point

    try:
        problem = ScalingProblem(run.study.spec, prototype_response=run.prototype)
        x = np.array([design[n] for n in run.variables])
        point["design"] = problem.design(x)
        point["similarity"] = problem.similarity(x)
        point["active_constraints"] = problem.active_bounds(x) + [
            f"{name} (equality)" for name in run.study.spec.equalities]
        config = problem.model_configuration(x)
        run.model_time_step = problem.model_time_step(config)
        point["model_time_step"] = run.model_time_step
        if simulate:
            _, run.model = problem.simulate_model(x)
    except (InputError, ArithmeticError, RuntimeError, ValueError) as exc:
        run.notes.append(f"could not rebuild the design point's similarity/response: {exc}")
    return point


# -- figures --------------------------------------------------------------------------------
def _pareto_figure(run: RunData) -> str:
    ok = run.ok
    objs = run.objectives
    if len(objs) != 2 or ok.empty:
        return ""
    F = ok[objs].to_numpy(float)
    fig, ax = plt.subplots(figsize=(6.0, 4.6))
    it = ok["iteration"].to_numpy() if "iteration" in ok else np.zeros(len(ok))
    init = it <= 0
    ax.scatter(F[init, 0], F[init, 1], s=18, c="0.65", label="initial samples")
    if (~init).any():
        sc = ax.scatter(F[~init, 0], F[~init, 1], s=18, c=it[~init], cmap="viridis",
                        label="BO iterations")
        fig.colorbar(sc, ax=ax, label="iteration")
    mask = non_dominated_mask(F)
    P = F[mask][np.argsort(F[mask][:, 0])]
    ax.step(P[:, 0], P[:, 1], where="post", color="tab:red", lw=1.2)
    ax.scatter(P[:, 0], P[:, 1], s=36, facecolors="none", edgecolors="tab:red",
               label="Pareto set")
    pobj = (run.point or {}).get("objectives") or {}
    if all(isinstance(pobj.get(o), (int, float)) for o in objs):
        ax.scatter([pobj[objs[0]]], [pobj[objs[1]]], marker="*", s=220, c="gold",
                   edgecolors="k", zorder=5, label="design point")
    cobj = (run.classical or {}).get("objectives") or {}
    if all(isinstance(cobj.get(o), (int, float)) for o in objs):
        ax.scatter([cobj[objs[0]]], [cobj[objs[1]]], marker="s", s=70, c="tab:blue",
                   edgecolors="k", zorder=5, label="classical baseline")
    ax.axvline(MISMATCH_THRESHOLD, color="0.5", ls=":", lw=0.8)
    ax.axhline(MISMATCH_THRESHOLD, color="0.5", ls=":", lw=0.8)
    ax.set_xlabel(objs[0])
    ax.set_ylabel(objs[1])
    if np.nanmax(F) / max(np.nanmin(F[F > 0]) if (F > 0).any() else 1.0, 1e-300) > 100:
        ax.set_xscale("log")
        ax.set_yscale("log")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title("Pareto front (dotted: 10 % error)")
    return figure_html(fig, run, "pareto_front",
                       f"Pareto front: {objs[0]} vs {objs[1]} of all successful evaluations, "
                       "the Pareto set, the design point and the classical baseline.")


def _history_figure(run: RunData) -> str:
    df = run.evaluations
    objs = run.objectives
    if df.empty or not objs:
        return ""
    F = df[objs].to_numpy(float)
    good = (df["status"] == "ok").to_numpy() & np.all(np.isfinite(F), axis=1)
    if not good.any():
        return ""
    n = np.arange(1, len(df) + 1)
    fig, ax = plt.subplots(figsize=(6.0, 3.8))
    it = df["iteration"].to_numpy() if "iteration" in df else np.zeros(len(df))
    first_bo = np.flatnonzero(it >= 1)
    if len(objs) == 2:
        feasible = F[good]
        ref = HV_REFERENCE if np.any(np.all(feasible < HV_REFERENCE, axis=1)) else \
            feasible.max(axis=0) * (1.0 + 1e-9) + 1e-12
        hv = np.empty(len(df))
        for i in range(len(df)):
            sel = good[: i + 1]
            hv[i] = hypervolume(F[: i + 1][sel], ref) if sel.any() else 0.0
        ax.plot(n, hv, drawstyle="steps-post", color="tab:blue")
        ax.set_ylabel("hypervolume")
        ref_text = "[1, 1]" if ref is HV_REFERENCE else \
            f"the nadir [{ref[0]:.3g}, {ref[1]:.3g}]"
        title = f"Hypervolume history (reference point {ref_text})"
        name = "hypervolume_history"
    else:
        f = np.where(good, F[:, 0], np.nan)
        best = np.fmin.accumulate(np.where(np.isnan(f), np.inf, f))
        best[~np.isfinite(best)] = np.nan
        ax.scatter(n, f, s=12, c="0.6", label=f"{objs[0]} per evaluation")
        ax.plot(n, best, drawstyle="steps-post", color="tab:blue", label=f"best {objs[0]}")
        ax.set_ylabel(objs[0])
        ax.legend(fontsize=8)
        title = f"Best-{objs[0]} history"
        name = "best_objective_history"
    bad = ~good
    if bad.any():
        ax.scatter(n[bad], np.full(bad.sum(), ax.get_ylim()[0]), marker="x", c="tab:red",
                   s=20, label="failed", clip_on=False)
        ax.legend(fontsize=8)
    if first_bo.size:
        ax.axvline(n[first_bo[0]] - 0.5, color="0.5", ls="--", lw=0.8)
    ax.set_xlabel("evaluation")
    ax.grid(alpha=0.3)
    ax.set_title(title)
    return figure_html(fig, run, name, title + "; dashed: start of the Bayesian iterations; "
                       "crosses: failed evaluations.")


def _nondimensional_time(resp: Response, dt: float | None, steps: int | None) -> np.ndarray:
    """t / t_end of the matched run: the model's time divided by its own duration
    ``dt * steps`` (Fourier- or structural-time matched, Eqs. 9.3 / 9.6)."""
    t = np.asarray(resp.times, float)
    if dt is not None and steps:
        return t / (dt * steps)
    if len(t) > 1 and t[-1] > 0:
        return t / t[-1]
    return t


def _lsa_markers(ax: Any, tau: np.ndarray, y: np.ndarray, resp: Response, color: str,
                 label_prefix: str, seen: set[str]) -> None:
    status = list(resp.lsa_status)[: len(tau)]
    for kind, marker in (("flutter", "v"), ("divergence", "^")):
        idx = [i for i, s in enumerate(status) if s == kind]
        if idx:
            label = f"{label_prefix} LSA: {kind}"
            ax.scatter(tau[idx], y[idx], marker=marker, s=60, c=color, edgecolors="k",
                       zorder=6, label=label if label not in seen else None)
            seen.add(label)


def _response_figure(run: RunData) -> str:
    proto, model = run.prototype, run.model
    if proto is None and model is None:
        return ""
    steps = None
    dt_p = None
    if run.study is not None:
        steps = run.study.spec.simulation.steps
        dt_p = run.study.spec.simulation.time_step
    elif proto is not None and len(proto.times) > 1:
        steps = len(proto.times) - 1
        dt_p = proto.times[1] - proto.times[0]
    fig, axes = plt.subplots(1, 2, figsize=(10.0, 3.9))
    seen: set[str] = set()
    for resp, label, color, style in ((proto, "prototype", "k", "-"),
                                      (model, "model (design point)", "tab:red", "--")):
        if resp is None or not resp.times:
            continue
        dt = dt_p if resp is proto else run.model_time_step
        tau = _nondimensional_time(resp, dt, steps)
        u, T = resp.deflection_over_thickness, resp.temperature_over_stagnation
        axes[0].plot(tau, u, style, color=color, marker="o", ms=3, label=label)
        axes[1].plot(tau, T, style, color=color, marker="o", ms=3, label=label)
        short = "prototype" if resp is proto else "model"
        _lsa_markers(axes[0], tau, u, resp, color, short, seen)
        _lsa_markers(axes[1], tau, T, resp, color, short, seen)
        if resp.instability_time is not None and dt is not None and steps:
            for ax in axes:
                ax.axvline(resp.instability_time / (dt * steps), color=color, ls=":", lw=1)
    axes[0].set_ylabel("center deflection / thickness  w/h")
    axes[1].set_ylabel("mean temperature / stagnation temperature  T/T0")
    for ax in axes:
        ax.set_xlabel("nondimensional time  t / t_end")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    axes[0].set_title("structural response")
    axes[1].set_title("thermal response")
    fig.tight_layout()
    note = "" if model is not None else " (no design-point response in the run directory)"
    return figure_html(fig, run, "response",
                       "Nondimensional response of the prototype and the design-point model "
                       "at matched nondimensional time (Figs. 9.10, 9.11); triangles mark "
                       "steps where the linearized stability analysis reports flutter or "
                       f"divergence{note}.")


def plot_sweep(rows: Sequence[dict[str, Any]], name: str, path: str | Path,
               bounds: tuple[float, float] | None = None,
               objectives: Sequence[str] = ("J_u", "J_T", "J_s"), title: str = "") -> Path:
    """Plot a one-variable what-if sweep (``hypate whatif --sweep``) to a PNG.

    Parameters
    ----------
    rows : sequence of dict
        ``{"value": float, "status": str, <objective>: float or None, ...}`` per design.
    name : str
        Swept variable (axis label, with its unit).
    path : path
        PNG to write.
    bounds : (float, float), optional
        The study's bounds of the variable (shaded outside).
    objectives : sequence of str
    title : str

    Returns
    -------
    Path
    """
    path = Path(path)
    v = np.array([float(r["value"]) for r in rows])
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    for obj, color in zip(objectives, ("tab:blue", "tab:orange", "tab:green", "tab:purple")):
        y = np.array([r.get(obj) if r.get(obj) is not None else np.nan for r in rows], float)
        if np.isfinite(y).any():
            ax.plot(v, 100.0 * y, "o-", color=color, ms=4, label=obj)
    failed = np.array([r.get("status") != "ok" for r in rows])
    if failed.any():
        lo = ax.get_ylim()[0]
        ax.scatter(v[failed], np.full(failed.sum(), lo), marker="x", c="tab:red", s=40,
                   clip_on=False, label="model failed")
    ax.axhline(100.0 * MISMATCH_THRESHOLD, color="0.5", ls=":", lw=0.8)
    if bounds is not None:
        lo_b, hi_b = bounds
        xmin, xmax = min(v.min(), lo_b), max(v.max(), hi_b)
        if v.min() < lo_b:
            ax.axvspan(xmin, lo_b, color="tab:red", alpha=0.08, label="outside bounds")
        if v.max() > hi_b:
            ax.axvspan(hi_b, xmax, color="tab:red", alpha=0.08,
                       label=None if v.min() < lo_b else "outside bounds")
    unit = variable_unit(name)
    ax.set_xlabel(f"{name} ({unit})" if unit != "-" else name)
    ax.set_ylabel("error (%)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(title or f"What-if sweep of {name}")
    fig.tight_layout()
    fig.savefig(path, format="png", dpi=110)
    plt.close(fig)
    return path


# -- sections -------------------------------------------------------------------------------
def _dl(items: Sequence[tuple[str, str]]) -> str:
    return "<dl>" + "".join(f"<dt>{html.escape(k)}</dt><dd>{v}</dd>" for k, v in items) + "</dl>"


def _study_section(run: RunData) -> Section:
    point = run.point or {}
    study = run.study
    if study is None:
        items = [("study", _fmt(point.get("study", "unknown"))),
                 ("xi (geometric scale)", _fmt(point.get("xi"))),
                 ("design variables", html.escape(", ".join(run.variables)) or "&ndash;"),
                 ("objectives", html.escape(", ".join(run.objectives)) or "&ndash;"),
                 ("evaluations stored", _fmt(len(run.evaluations)))]
        return Section("Study", _dl(items) + "<p class='note'>The study file is unknown: "
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
    model = (f"{html.escape(mp.layers[0].material.name)} panel, {mp.length:.4g} m x "
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
    budget = (f"{opt.initial_samples} initial samples + {opt.iterations} iterations x "
              f"batch {opt.batch_size}"
              + (f" + {opt.polish} polish evaluations" if opt.polish else "")
              + f" ({study.acquisition.upper()}, {opt.approach} approach, seed {opt.seed}"
              + (f", {opt.coordinates} coordinates" if opt.coordinates != "design" else "")
              + (f", {opt.transform} transform" if opt.transform != "none" else "") + ")")
    items = [("study", html.escape(study.name)),
             ("description", html.escape(study.description or "")),
             ("study file", f"<code>{html.escape(str(run.study_path))}</code>"),
             ("prototype", prototype), ("model", model), ("tunnel", tunnel),
             ("simulation", html.escape(
                 f"{sim.kind}, {sim.steps} steps of {sim.time_step:g} s (prototype), "
                 f"aero {sim.aero}, heating {sim.heating}; time scaling {spec.time_scaling}, "
                 f"projection {spec.projection}")),
             ("objectives", html.escape(", ".join(spec.objectives))),
             ("budget", html.escape(budget))]
    if spec.equalities:
        items.append(("equality constraints", html.escape(", ".join(spec.equalities))))
    var_rows = [(v.name, variable_unit(v.name), v.lower, v.upper) for v in spec.variables]
    body = _dl(items) + "<h3>Design variables</h3>" + html_table(
        ["variable", "unit", "lower bound", "upper bound"], var_rows)
    if spec.fixed:
        body += "<h3>Fixed values</h3>" + html_table(
            ["name", "unit", "value"], [(k, variable_unit(k), v) for k, v in spec.fixed.items()])
    return Section("Study", body)


def _bounds_of(run: RunData) -> dict[str, tuple[float, float]]:
    if run.study is None:
        return {}
    return {v.name: (v.lower, v.upper) for v in run.study.spec.variables}


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
        rows.append((name, variable_unit(name), value, lo, hi, state or "",
                     classical.get(name)))
        classes.append("active" if state else "")
    intro = ""
    if run.point_rebuilt:
        intro = ("<p class='note'>Rebuilt from the evaluation store (the run did not finish): "
                 "the successful evaluation with the smallest max(J).</p>")
    objs = point.get("objectives") or {}
    obj_rows = [(k, _Raw(_pct(v)), _Raw(_pct(((run.classical or {}).get("objectives")
                                               or {}).get(k))))
                for k, v in objs.items()]
    body = intro + html_table(["variable", "unit", "value", "lower bound", "upper bound",
                               "bound hit", "classical baseline"], rows, classes)
    body += "<h3>Objectives</h3>" + html_table(["objective", "design point",
                                                "classical baseline"], obj_rows)
    body += "<h3>Active constraints</h3>" + (
        "<ul>" + "".join(f"<li>{html.escape(a)}</li>" for a in active) + "</ul>"
        if active else "<p>none</p>")
    extra = []
    if isinstance(point.get("evaluation"), int):
        extra.append(("evaluation", _fmt(point["evaluation"])))
    if run.model_time_step is not None:
        extra.append(("model time step", f"{run.model_time_step:.4g} s"))
    if run.study is not None and run.model_time_step is not None:
        sim = run.study.spec.simulation
        extra.append(("model test duration",
                      f"{run.model_time_step * sim.steps:.4g} s (prototype "
                      f"{sim.time_step * sim.steps:.4g} s)"))
    return Section("Design point", body + (_dl(extra) if extra else ""))


def _similarity_section(run: RunData) -> Section:
    rows_in = (run.point or {}).get("similarity") or []
    if not rows_in:
        return Section("Similarity parameters", "<p class='note'>Not available (needs the "
                       "study file to rebuild it for an interrupted run).</p>")
    rows, classes = [], []
    for rec in rows_in:
        rd = rec.get("relative_difference")
        bad = rd is not None and math.isfinite(float(rd)) and abs(float(rd)) > MISMATCH_THRESHOLD
        rows.append((rec.get("name"), rec.get("prototype"), rec.get("model"), _Raw(_pct(rd))))
        classes.append("mismatch" if bad else "")
    n_bad = classes.count("mismatch")
    return Section("Similarity parameters",
                   f"<p>{n_bad} of {len(rows)} parameters differ by more than "
                   f"{100 * MISMATCH_THRESHOLD:.0f} % (highlighted). Relative difference = "
                   "|model - prototype| / |prototype|.</p>"
                   + html_table(["parameter", "prototype", "model", "relative difference"],
                                rows, classes, css_class="similarity"))


def _figures_section(run: RunData) -> Section:
    parts = []
    for make in (_pareto_figure, _history_figure, _response_figure):
        try:
            parts.append(make(run))
        except (ValueError, RuntimeError, KeyError, IndexError, TypeError) as exc:
            plt.close("all")
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
        sel = ok[non_dominated_mask(F)].sort_values(run.objectives[0])
        title = f"Pareto set ({len(sel)} designs)"
    else:
        sel = ok.nsmallest(10, run.objectives[0])
        title = f"Best designs ({len(sel)})"
    header = ["evaluation"] + [f"{v} ({variable_unit(v)})" for v in run.variables] + \
        list(run.objectives)
    rows = [[int(i)] + [r[v] for v in run.variables] + [_Raw(_pct(r[o])) for o in run.objectives]
            for i, r in sel.iterrows()]
    return Section(title, html_table(header, rows))


_NUM = re.compile(r"[-+]?\d+(\.\d+)?([eE][-+]?\d+)?")


def _statistics_section(run: RunData) -> Section:
    df = run.evaluations
    n = len(df)
    stats = (run.point or {}).get("statistics") or {}
    failed = df[df["status"] != "ok"] if n else df
    items = [("evaluations", _fmt(n)), ("successful", _fmt(n - len(failed))),
             ("failed", _fmt(len(failed)))]
    if n:
        sec = df["seconds"].to_numpy(float)
        items.append(("median time per evaluation", f"{np.median(sec):.3g} s"))
        items.append(("total evaluation time", f"{np.sum(sec):.4g} s"))
    if stats.get("wall_seconds") is not None:
        items.append(("wall time", f"{float(stats['wall_seconds']):.4g} s"))
    elif run.interrupted:
        items.append(("wall time", "not recorded (interrupted run)"))
    if stats.get("pareto_size") is not None:
        items.append(("Pareto-set size", _fmt(stats["pareto_size"])))
    if n and "iteration" in df:
        it = df["iteration"].to_numpy()
        opt = run.study.optimizer if run.study is not None else None
        if opt is not None and opt.polish:
            polish = it > opt.iterations
            items.append(("classical seed / initial / BO / polish evaluations",
                          f"{int((it < 0).sum())} / {int((it == 0).sum())} / "
                          f"{int(((it > 0) & ~polish).sum())} / {int(polish.sum())}"))
        else:
            items.append(("classical seed / initial / BO evaluations",
                          f"{int((it < 0).sum())} / {int((it == 0).sum())} / "
                          f"{int((it > 0).sum())}"))
    body = _dl(items)
    if len(failed):
        groups: dict[tuple[str, str], list[int]] = {}
        examples: dict[tuple[str, str], str] = {}
        for i, r in failed.iterrows():
            msg = str(r.get("message", "") or "")
            key = (str(r["status"]), _NUM.sub("#", msg)[:160])
            groups.setdefault(key, []).append(int(i))
            examples.setdefault(key, msg)
        rows = [(st, len(idx), ", ".join(map(str, idx[:12])) + (" ..." if len(idx) > 12 else ""),
                 examples[(st, k)][:300])
                for (st, k), idx in sorted(groups.items(), key=lambda kv: -len(kv[1]))]
        body += "<h3>Failures by reason</h3>" + html_table(
            ["status", "count", "evaluations", "example message"], rows)
    return Section("Run statistics", body)


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
    return Section("Scaling laws", img + table)


_BUILTIN: tuple[Callable[[RunData], Section | None], ...] = (
    _study_section, _design_section, _similarity_section, _figures_section, _pareto_section,
    _statistics_section, _laws_section)

_CSS = """
body{font-family:-apple-system,Segoe UI,Helvetica,Arial,sans-serif;max-width:1100px;
margin:2em auto;padding:0 1em;color:#222;line-height:1.4}
h1{border-bottom:2px solid #345;padding-bottom:.2em}h2{color:#345;margin-top:1.8em;
border-bottom:1px solid #ccd}h3{margin-bottom:.3em}
table{border-collapse:collapse;margin:.5em 0 1em;font-size:.92em}
th,td{border:1px solid #ccd;padding:.25em .6em;text-align:right}
th{background:#eef1f6}td:first-child,th:first-child{text-align:left}
tr.mismatch td{background:#fde2e1}tr.active td{background:#fff4d6}
dl{display:grid;grid-template-columns:max-content auto;gap:.2em 1em}dt{font-weight:600}dd{margin:0}
figure{margin:1em 0}figure img{max-width:100%;height:auto;border:1px solid #ddd}
figcaption{font-size:.9em;color:#555}.note{color:#555;font-style:italic}
.warn{color:#a40}.notes{background:#fff8e5;border:1px solid #eb5;padding:.5em 1em}
nav ul{columns:2}code{background:#f3f3f3;padding:0 .2em}
"""


def _slug(title: str, used: set[str]) -> str:
    base = re.sub(r"[^a-z0-9]+", "-", title.lower()).strip("-") or "section"
    slug, k = base, 2
    while slug in used:
        slug, k = f"{base}-{k}", k + 1
    used.add(slug)
    return slug


def render_html(run: RunData, sections: Sequence[Section]) -> str:
    """The report page of ``sections`` (self-contained HTML5)."""
    name = run.study.name if run.study is not None else str((run.point or {}).get("study")
                                                            or run.directory.name)
    title = f"hypate scaling report: {name}"
    used: set[str] = set()
    slugs = [_slug(s.title, used) for s in sections]
    stamp = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    state = "interrupted run (partial results)" if run.interrupted else "finished run"
    out = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
           '<meta name="viewport" content="width=device-width, initial-scale=1">',
           '<link rel="icon" href="data:,">',
           f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>",
           f"<h1>{html.escape(title)}</h1>",
           f"<p>Run directory <code>{html.escape(str(run.directory))}</code> &mdash; "
           f"{state} &mdash; generated {stamp}.</p>"]
    if run.notes:
        out.append("<div class='notes'><strong>Notes</strong><ul>"
                   + "".join(f"<li>{html.escape(n)}</li>" for n in run.notes) + "</ul></div>")
    out.append("<nav><ul>" + "".join(f'<li><a href="#{s}">{html.escape(sec.title)}</a></li>'
                                     for s, sec in zip(slugs, sections)) + "</ul></nav>")
    for slug, sec in zip(slugs, sections):
        out.append(f'<section id="{slug}"><h2>{html.escape(sec.title)}</h2>{sec.html}</section>')
    out.append("<footer><p class='note'>Generated by hypate (scaling.report). Equations and "
               "tables refer to the dissertation (Ch. 6, 9).</p></footer></body></html>")
    return "\n".join(out)


def write_report(run_dir: str | Path, *, study_path: str | Path | None = None,
                 extra_sections: Sequence[tuple[str, str]] | None = None,
                 simulate: bool = False) -> Path:
    """Build ``run_dir/figures/*.png`` and the self-contained ``run_dir/report.html``.

    Parameters
    ----------
    run_dir : path
        A run directory of ``hypate run`` (finished or interrupted).
    study_path : path, optional
        The study file when the run directory does not record it (see :func:`load_run`).
    extra_sections : sequence of (title, html), optional
        Static sections appended after the built-in and registered ones (HTML verbatim).
    simulate : bool
        Interrupted run: simulate the rebuilt design point for the response figure.

    Returns
    -------
    Path
        ``run_dir/report.html``.

    Raises
    ------
    InputError
        ``run_dir`` is not a run directory, or ``study_path`` does not fit the run.
    """
    run = load_run(run_dir, study_path=study_path, simulate=simulate)
    sections: list[Section] = []
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", category=RuntimeWarning)
        for build in _BUILTIN:
            sec = build(run)
            if sec is not None:
                sections.append(sec)
    for key, provider in list(_PROVIDERS.items()):
        try:
            sec = provider(run)
        except Exception as exc:  # noqa: BLE001 - a plug-in must never break the report
            plt.close("all")
            warnings.warn(f"report section {key!r} failed: {exc}", RuntimeWarning,
                          stacklevel=2)
            sec = Section(key, f"<p class='warn'>This section failed: "
                          f"{html.escape(f'{type(exc).__name__}: {exc}')}</p>")
        if sec is not None:
            sections.append(sec if isinstance(sec, Section) else Section(*sec))
    for title, body in extra_sections or ():
        sections.append(Section(str(title), str(body)))
    page = render_html(run, sections)
    path = run.directory / REPORT_NAME
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(page, encoding="utf-8")
    tmp.replace(path)
    return path


def write_report_safely(run_dir: Path) -> Path | None:
    """``report.html`` + ``figures/`` of a run; a failing report never costs the run."""
    try:
        return write_report(run_dir)
    except (OSError, ValueError, KeyError, RuntimeError, InputError) as exc:
        warnings.warn(f"report of {run_dir} not written: {exc}", RuntimeWarning, stacklevel=2)
        return None
