"""The run data of the report: :class:`RunData` and :func:`load_run`.

:func:`load_run` reads a run directory written by ``hypate run``
(:mod:`hypate.scaling.workflow.campaigns.run`) -- also an *interrupted* one, where only
``evaluations.sqlite`` (and perhaps ``prototype.npz`` / ``classical.json``) exist -- finds
its study file, names the store's columns and, when ``design_point.json`` is missing,
rebuilds the design point from the evaluations (Sec. 9.2.3 criterion). Nothing here draws
or writes HTML: :mod:`.figures` and :mod:`.sections` read a :class:`RunData`.
"""
from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from hypate.scaling.engine.design_point import DESIGN_POINT_RULES, design_point_index
from hypate.scaling.engine.problem import tally_warnings
from hypate.scaling.engine.store import EvaluationStore, StoreTampered, warnings_from_text
from hypate.scaling.workflow.campaigns.campaign import ENVIRONMENTS
from hypate.scaling.workflow.campaigns.rundir import (
    CLASSICAL_JSON,
    DESIGN_POINT_JSON,
    DESIGN_POINT_NPZ,
    EVALUATIONS_CSV,
    FIGURES_DIR,
    ID_COLUMN,
    PROTOTYPE_NPZ,
    PROTOTYPE_WARNINGS,
    STORE,
)
from hypate.scaling.workflow.campaigns.seeds import load_seeds
from hypate.scaling.workflow.vocabulary.fidelity import FIDELITY, FIDELITY_NAME
from hypate.scaling.workflow.vocabulary.problem import ScalingProblem
from hypate.scaling.workflow.vocabulary.shipped import shipped
from hypate.scaling.workflow.vocabulary.study import load_study
from hypate.solvers.coupling.response import Response
from hypate.solvers.errors import InputError
from hypate.solvers.numerics.files import ensure_directory

__all__ = ["RunData", "load_run", "FIGURES_DIR"]

#: Figure folder in the run directory.
_RESERVED = {ID_COLUMN, "iteration", "batch_index", "status", "message", "warnings", "seconds",
             "seed", "aux", "admissible", "max_wall_temperature", "max_deflection_ratio",
             "max_von_mises"}

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
        per design variable, one per objective, ``status, message, warnings, seconds,
        seed`` (``warnings``: empty or a JSON list, as in ``evaluations.csv``). The
        index is the evaluation id (0-based row in the store order, the ``id`` column of
        ``evaluations.csv``): every evaluation number the report prints is this index.
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
    prototype_warnings : list of str
        The warnings of the prototype's simulation (the store's metadata; empty for runs
        older than it).
    seeds : dict or None
        For one seed of a ``hypate run --seeds N`` run: the parent's ``seeds.json``
        (:func:`hypate.scaling.workflow.campaigns.seeds.load_seeds`, with ``"this"``).
    seed : int or None
        The optimizer seed the run used (the store's; ``--seed`` may override the study's).
    environments : list of dict
        The numerical environments the run ran in
        (:func:`hypate.scaling.workflow.campaigns.campaign.runtime_environment`).
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
    prototype_warnings: list[str] = field(default_factory=list)
    seeds: dict[str, Any] | None = None
    seed: int | None = None
    environments: list[dict[str, Any]] = field(default_factory=list)
    #: A multi-fidelity run's lower-level evaluations (``evaluations`` holds the top
    #: level's, with their evaluation ids); empty otherwise.
    lower_fidelity: pd.DataFrame = field(default_factory=pd.DataFrame)

    @property
    def warnings(self) -> list[tuple[str, list[Any], int]]:
        """Distinct warnings of the run: ``(text, where, count)``, most frequent first;
        ``where`` lists ``"prototype"`` and evaluation ids
        (:func:`hypate.scaling.engine.problem.tally_warnings`)."""
        df = self.evaluations
        cells = df["warnings"] if "warnings" in df else pd.Series([], dtype=object)
        return tally_warnings([("prototype", self.prototype_warnings),
                               *((int(i), warnings_from_text(c)) for i, c in cells.items())])

    @property
    def interrupted(self) -> bool:
        """True when the run has no ``design_point.json`` (killed or still running)."""
        return not (self.directory / DESIGN_POINT_JSON).is_file()

    @property
    def rule(self) -> str:
        """The design-point rule: ``design_point.json``'s ``rule``, else the study's
        ``[optimizer] design_point``, else the default "minmax" (runs older than the key)."""
        recorded = (self.point or {}).get("rule")
        if isinstance(recorded, str) and recorded in DESIGN_POINT_RULES:
            return recorded
        if self.study is not None:
            return str(self.study.optimizer.design_point)
        return DESIGN_POINT_RULES[0]

    @property
    def weights(self) -> list[float] | None:
        """The study's ``[optimizer] weights`` (the "weighted" rule), None when unknown."""
        if self.study is None or self.study.optimizer.weights is None:
            return None
        return [float(w) for w in self.study.optimizer.weights]

    @property
    def point_id(self) -> int | None:
        """Evaluation id of the design point (None when there is none)."""
        ev = (self.point or {}).get("evaluation")
        return int(ev) if isinstance(ev, int) and not isinstance(ev, bool) else None

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
        return ensure_directory(self.directory / FIGURES_DIR) / f"{name}.png"


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


#: RunData.evaluations column: the evaluation is admissible (the report marks it so).
ADMISSIBLE = "admissible"


def _store_frame(path: Path) -> tuple[pd.DataFrame, dict[str, Any]]:
    """The store's evaluations and metadata, read from a snapshot (the run directory is
    not touched; its digest chain verified)."""
    with EvaluationStore(path, read_only=True) as store:
        df = store.to_dataframe()
        meta = {k: store.get_meta(k) for k in ("n_var", "n_obj", "study_path", "study",
                                               "seed", ENVIRONMENTS, PROTOTYPE_WARNINGS)}
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
    for fname in ("study.toml",):
        if (run_dir / fname).is_file():
            out.append((run_dir / fname, True))
    name = (point or {}).get("study") or meta.get("study")
    if isinstance(name, str) and re.fullmatch(r"[\w.-]+", name):
        match = shipped("study").get(name)
        if match is not None:
            out.append((match, False))
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
    middle = [c for c in cols if c not in _RESERVED and not re.fullmatch(r"g\d+|G_\w+", c)]
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
        shipped study of that name (:mod:`hypate.scaling.workflow.vocabulary.shipped`) (used only
        when its variable and objective counts match the store). When none is found the report shows
        what the store/CSV holds (variables ``x0..``, objectives ``f0..`` unless the CSV names
        them).
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
    store, csv = run_dir / STORE, run_dir / EVALUATIONS_CSV
    if not run_dir.is_dir():
        raise InputError("DIR", f"{run_dir} is not a directory")
    if not store.is_file() and not csv.is_file():
        raise InputError("DIR", f"{run_dir} is not a run directory (no {STORE} or "
                         "evaluations.csv); run `hypate run STUDY.toml --out DIR` first")
    run = RunData(directory=run_dir)
    point = _read_json(run_dir / DESIGN_POINT_JSON, run.notes)
    run.classical = _read_json(run_dir / CLASSICAL_JSON, run.notes)
    if run.classical is None and point is not None and isinstance(point.get("classical"), dict):
        run.classical = point["classical"]
    df, meta = _read_evaluations(store, csv, run.notes)
    x_cols = [c for c in df.columns if re.fullmatch(r"x\d+", c)]
    f_cols = [c for c in df.columns if re.fullmatch(r"f\d+", c)]
    counts = (int(meta.get("n_var") or len(x_cols)), int(meta.get("n_obj") or len(f_cols)))
    _find_study(run, study_path, point, meta, counts, numbered=bool(x_cols or f_cols))
    _name_columns(run, df, point, csv, counts, (x_cols, f_cols))
    if x_cols or f_cols:
        df = _rename(df, run.variables, run.objectives)
    # the id column of evaluations.csv is the row number itself: the index carries it
    run.evaluations = df.drop(columns=[ID_COLUMN], errors="ignore").reset_index(drop=True)
    if FIDELITY in run.variables:  # the report is the top level's; the rest is shown apart
        df, top = run.evaluations, len(run.study.level_names) - 1
        is_top = np.rint(df[FIDELITY].to_numpy(float)) == top
        names = run.study.level_names
        run.lower_fidelity = df[~is_top].assign(**{FIDELITY_NAME: [
            names[int(round(v))] for v in df.loc[~is_top, FIDELITY]]})
        run.evaluations = df[is_top].drop(columns=[FIDELITY, FIDELITY_NAME], errors="ignore")
        run.variables.remove(FIDELITY)
    proto = meta.get(PROTOTYPE_WARNINGS)
    run.prototype_warnings = [str(w) for w in proto] if isinstance(proto, list) else []
    _attach_point(run, point, simulate)
    run.seeds = load_seeds(run_dir)
    run.seed = meta.get("seed") if isinstance(meta.get("seed"), int) else None
    envs = meta.get(ENVIRONMENTS)
    run.environments = [e for e in envs if isinstance(e, dict)] if isinstance(envs, list) else []
    return run


def _read_evaluations(store: Path, csv: Path, notes: list[str]
                      ) -> tuple[pd.DataFrame, dict[str, Any]]:
    """The evaluations and the store's metadata; ``evaluations.csv`` (and no metadata) when
    the store is missing or unreadable."""
    meta: dict[str, Any] = {}
    if store.is_file():
        try:
            df, meta = _store_frame(store)
        except StoreTampered as exc:  # never fall back to a file beside an edited store
            raise InputError("DIR", str(exc)) from None
        except Exception as exc:  # noqa: BLE001 - sqlite3.DatabaseError and friends
            if not csv.is_file():
                raise InputError("DIR", f"{store} is not a readable evaluation store "
                                 f"({exc})") from None
            notes.append(f"{STORE} unreadable ({exc}); using evaluations.csv")
            df = pd.read_csv(csv)
        else:
            # admissible: a success that holds every enforced simulated check (G <= 0); the
            # analytic checks are enforced on every proposal (cheap constraints)
            gcols = [c for c in df.columns if re.fullmatch(r"g\d+", c)]
            ok = (df["status"] == "ok").to_numpy()
            G = df[gcols].to_numpy(float) if gcols else np.zeros((len(df), 0))
            df[ADMISSIBLE] = ok & np.all(G <= 0.0, axis=1)
            df = df.drop(columns=gcols)
    else:
        df = pd.read_csv(csv)
        notes.append(f"no {STORE}: evaluations from evaluations.csv")
    return df, meta


def _find_study(run: RunData, study_path: str | Path | None, point: dict[str, Any] | None,
                meta: dict[str, Any], counts: tuple[int, int], numbered: bool) -> None:
    """Set ``run.study`` / ``run.study_path`` from the first candidate that loads and fits.

    ``counts`` are the run's (variables, objectives); a study that does not match them is
    skipped when the columns are ``numbered`` (``x0..``/``f0..``). An explicit
    ``study_path`` that is missing, invalid or does not fit raises :class:`InputError`.
    """
    n_var, n_obj = counts
    tried: list[str] = []
    for path, certain in _study_candidates(run.directory, study_path, point, meta):
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
        fits = (len(study.spec.names) + bool(study.lower_levels) == n_var  # + the level
                and len(study.spec.objectives) == n_obj)
        if not fits and numbered:
            msg = (f"study {path} has {len(study.spec.names)} variables / "
                   f"{len(study.spec.objectives)} objectives, the run {n_var} / {n_obj}")
            if study_path is not None and path == Path(study_path):
                raise InputError("--study", msg)
            tried.append(msg)
            continue
        run.study, run.study_path = study, str(path)
        if not certain:
            run.notes.append(f"study file not recorded in the run; assumed the shipped "
                             f"{path.name}")
        break
    if run.study is None:
        run.notes.append("study file unknown (pass --study STUDY.toml): the study summary and "
                         "similarity table are limited to what the run directory holds"
                         + (f" ({'; '.join(tried)})" if tried else ""))


def _name_columns(run: RunData, df: pd.DataFrame, point: dict[str, Any] | None, csv: Path,
                  counts: tuple[int, int], numbered: tuple[list[str], list[str]]) -> None:
    """Set ``run.variables`` / ``run.objectives``: from the study, else from the CSV header
    (numbered store columns ``numbered = (x_cols, f_cols)``), else from the named columns."""
    x_cols, f_cols = numbered
    if run.study is not None:
        run.variables = list(run.study.spec.names) + ([FIDELITY] if run.study.lower_levels
                                                      else [])
        run.objectives = list(run.study.spec.objectives)
    elif x_cols or f_cols:
        names = _names_from_csv(csv, *counts) if csv.is_file() else None
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
                             and c not in run.objectives and not c.startswith("G_")]


def _attach_point(run: RunData, point: dict[str, Any] | None, simulate: bool) -> None:
    """The responses and the design point: ``design_point.json``, or rebuilt from the
    evaluations of an interrupted run (needs ``run.evaluations`` set)."""
    notes = run.notes
    run.prototype = _read_response(run.directory / PROTOTYPE_NPZ, notes)
    if point is not None:
        run.point = point
        run.model = _read_response(run.directory / DESIGN_POINT_NPZ, notes)
        mts = point.get("model_time_step")
        run.model_time_step = float(mts) if isinstance(mts, (int, float)) else None
        stats = point.get("statistics") or {}
        n = len(run.evaluations)
        if isinstance(stats.get("evaluations"), int) and stats["evaluations"] < n:
            notes.append(f"the store holds {n} evaluations, design_point.json "
                         f"{stats['evaluations']}: the run was resumed and not finished; the "
                         "design point may be outdated")
    else:
        notes.append("design_point.json missing (interrupted run): the design point was "
                     "rebuilt from the evaluations")
        run.point = _rebuild_point(run, simulate)
        run.point_rebuilt = True


def _rebuild_point(run: RunData, simulate: bool) -> dict[str, Any] | None:
    """Design point of an interrupted run: the runner's rule (:attr:`RunData.rule`,
    :func:`~hypate.scaling.engine.design_point.design_point_index`) over the successful
    evaluations."""
    ok = run.ok
    if ok.empty:
        return None
    row = ok.index[design_point_index(ok[run.objectives].to_numpy(float), run.rule,
                                      run.weights)]
    rec = run.evaluations.loc[row]
    design = {n: float(rec[n]) for n in run.variables}
    point: dict[str, Any] = {
        "design": design, "objectives": {o: float(rec[o]) for o in run.objectives},
        "similarity": [], "active_constraints": [], "evaluation": int(row),
        "rule": run.rule}
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

