"""What a run directory must be before hypate writes into it or trusts it: no planted links,
a store that matches its digests, and (finished) every output it promised.

A run directory travels (a tar, a shared drive) and keeps symbolic links. Before any
command writes into one, :func:`check_run_directory` refuses a link where hypate's own
files or folders belong (the names of :mod:`.rundir`, their ``-wal`` / ``.tmp`` companions
and everything inside ``figures/`` and ``prediction/``), naming it, so that nothing is
written (exit 2). The writes themselves never follow a link either
(:mod:`hypate.solvers.numerics.files`); this check makes the refusal come first, before a
single file changes.

A run is complete only when every output it wrote at its end still exists and matches the
store: :func:`record_outputs` keeps their list (and the content hash of the data files) in
the store once the last one is written, :func:`missing_outputs` compares. A run killed while
it wrote its outputs (the report, say) is therefore not complete, and ``--resume`` writes
them. :func:`verify_run` is what every reader calls before trusting a run directory.
"""
from __future__ import annotations

import hashlib
import json
import os
import stat
from pathlib import Path
from typing import Any

from hypate.scaling.engine.store import EvaluationStore, StoreError, StoreTampered
from hypate.scaling.workflow.campaigns.rundir import (
    CLASSICAL_JSON,
    DESIGN_POINT_JSON,
    DESIGN_POINT_NPZ,
    EVALUATIONS_CSV,
    FIGURES_DIR,
    LOCK_FILE,
    PARETO_CSV,
    PREDICTION_DIR,
    PROTOTYPE_NPZ,
    REPORT_HTML,
    SEEDS_CSV,
    SEEDS_JSON,
    STORE,
    SWEEP_CSV,
    SWEEP_JSON,
)
from hypate.solvers.errors import InputError
from hypate.solvers.numerics.files import LinkRefused

__all__ = ["HASHED_OUTPUTS", "OUTPUTS_META", "RUN_FILES", "RUN_FOLDERS", "VIEW_OUTPUTS",
           "check_run_directory", "is_run_file_name", "missing_outputs", "record_outputs",
           "verify_run"]

#: The files hypate writes at the top of a run directory (the run-directory contract).
RUN_FILES = (STORE, EVALUATIONS_CSV, PARETO_CSV, DESIGN_POINT_JSON, CLASSICAL_JSON,
             PROTOTYPE_NPZ, DESIGN_POINT_NPZ, REPORT_HTML, SWEEP_JSON, SWEEP_CSV, SEEDS_JSON,
             SEEDS_CSV, LOCK_FILE)
#: Its folders: every entry inside them is hypate's.
RUN_FOLDERS = (FIGURES_DIR, PREDICTION_DIR)


def is_run_file_name(name: str) -> bool:
    """Whether ``name`` (an entry of a run directory) is one hypate writes: a run file or
    folder, a companion of one (``evaluations.sqlite-wal``, ``report.html.tmp``) or one of
    its temporaries (``.report.html.<random>.tmp``)."""
    for own in RUN_FILES + RUN_FOLDERS:
        if name == own or name.startswith((own + ".", own + "-", "." + own + ".")):
            return True
    return False


def _link_target(path: Path) -> str | None:
    try:
        info = os.lstat(path)
    except FileNotFoundError:
        return None
    return os.readlink(path) if stat.S_ISLNK(info.st_mode) else None


def check_run_directory(out: str | Path, field: str = "out") -> None:
    """Refuse a run directory with a symbolic link where hypate writes (nothing is written).

    Checked: ``out`` itself (give the directory a link points to instead), every entry of
    ``out`` that is a run file, folder or their companion (:func:`is_run_file_name`), and
    every entry of its ``figures/`` and ``prediction/`` folders. Other entries (a linked
    ``study.toml``, say) are left alone: hypate never writes them.

    Parameters
    ----------
    out : str or Path
        The run directory (it need not exist yet).
    field : str
        The setting the error names (``out``, ``run_dir``).

    Raises
    ------
    InputError
        ``field``: the first link found, and where it points.
    """
    out = Path(out)
    candidates = [out]
    if out.is_dir() and _link_target(out) is None:
        entries = sorted(os.scandir(out), key=lambda e: e.name)
        candidates += [Path(e.path) for e in entries if is_run_file_name(e.name)]
        for folder in RUN_FOLDERS:
            sub = out / folder
            if sub.is_dir() and _link_target(sub) is None:
                candidates += sorted(Path(e.path) for e in os.scandir(sub))
    for path in candidates:
        target = _link_target(path)
        if target is not None:
            raise InputError(field, str(LinkRefused(path, target)))


# -- a finished run: every output it promised, consistent with the store ------------------
#: Store ``meta`` key of the outputs a run wrote at its end: ``{"rows", "head", "files"}``,
#: ``files`` mapping each output's name (``figures/NAME.png`` inside the folder) to its
#: SHA-256, or to None for the report's files (``hypate report`` rewrites them).
OUTPUTS_META = "outputs"
#: Outputs whose content the record fixes (derived from the store; a resume rewrites them).
HASHED_OUTPUTS = (EVALUATIONS_CSV, PARETO_CSV, DESIGN_POINT_JSON, CLASSICAL_JSON,
                  DESIGN_POINT_NPZ, PROTOTYPE_NPZ, SEEDS_JSON, SEEDS_CSV)
#: Outputs that only have to exist (the report is a view: ``hypate report`` redraws it).
VIEW_OUTPUTS = (REPORT_HTML,)


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _regular_file(path: Path) -> bool:
    try:
        return stat.S_ISREG(os.lstat(path).st_mode)
    except FileNotFoundError:
        return False


def record_outputs(store: EvaluationStore, out: str | Path) -> dict[str, Any]:
    """Record in ``store`` the outputs of the run in ``out`` as they are now (called once
    every output is written: the run is complete from then on, :func:`missing_outputs`).

    Returns
    -------
    dict
        The record (``rows``, ``head``, ``files``).
    """
    out = Path(out)
    files: dict[str, str | None] = {name: _sha256(out / name) for name in HASHED_OUTPUTS
                                    if _regular_file(out / name)}
    files.update({name: None for name in VIEW_OUTPUTS if _regular_file(out / name)})
    figures = out / FIGURES_DIR
    if figures.is_dir() and _link_target(figures) is None:
        files.update({f"{FIGURES_DIR}/{p.name}": None for p in sorted(figures.glob("*.png"))
                      if _regular_file(p)})
    record = {"rows": len(store), "head": store.head, "files": files}
    store.set_meta(OUTPUTS_META, record, replace=True)
    return record


def missing_outputs(out: str | Path) -> list[str]:
    """What keeps the run in ``out`` from being complete: the outputs missing or not
    matching the store (empty: complete; a store that cannot be read counts as missing).

    A run recorded by :func:`record_outputs` is complete when the store still holds the
    rows it held then and every recorded output exists (a regular file) with the recorded
    content (the report's files: existing). A run of a hypate without that record is
    complete when ``design_point.json`` counts the store's rows and ``evaluations.csv``,
    ``pareto.csv`` and ``report.html`` exist.

    Parameters
    ----------
    out : str or Path

    Returns
    -------
    list of str
        File names, each with what is wrong (``"report.html (missing)"``).

    Raises
    ------
    StoreTampered
        The store's rows do not match their digests.
    """
    out = Path(out)
    if not _regular_file(out / STORE):
        return [f"{STORE} (missing)"]
    try:
        with EvaluationStore(out / STORE, read_only=True) as store:
            rows, head = len(store), store.head
            record = store.get_meta(OUTPUTS_META)
    except StoreTampered:
        raise
    except StoreError as exc:
        return [f"{STORE} ({exc})"]
    if not isinstance(record, dict):
        return _missing_without_record(out, rows)
    if record.get("rows") != rows or record.get("head") != head:
        return [f"outputs (written for {record.get('rows')} evaluations, the store holds "
                f"{rows})"]
    missing = []
    for name, digest in (record.get("files") or {}).items():
        path = out / name
        if not _regular_file(path):
            missing.append(f"{name} (missing)")
        elif digest is not None and _sha256(path) != digest:
            missing.append(f"{name} (changed since the run wrote it)")
    return missing


def _missing_without_record(out: Path, rows: int) -> list[str]:
    """:func:`missing_outputs` of a run directory written before the record existed."""
    missing = [f"{name} (missing)" for name in (DESIGN_POINT_JSON, EVALUATIONS_CSV,
                                                 PARETO_CSV, REPORT_HTML)
               if not _regular_file(out / name)]
    if _regular_file(out / DESIGN_POINT_JSON):
        try:
            point = json.loads((out / DESIGN_POINT_JSON).read_text())
            counted = point["statistics"]["evaluations"]
        except (OSError, ValueError, KeyError, TypeError):
            counted = None
        if counted != rows:
            missing.append(f"{DESIGN_POINT_JSON} (counts {counted} evaluations, the store "
                           f"holds {rows})")
    return missing


def verify_run(run_dir: str | Path, field: str = "RUN_DIR") -> None:
    """Check a run directory before its results are read: its store's digest chain and,
    for a run that recorded its outputs, that ``evaluations.csv``, ``pareto.csv`` and
    ``design_point.json`` are the files the run wrote (a store of an older hypate is read
    with the store's warning). Reads only (a snapshot of the store).

    Raises
    ------
    InputError
        ``field``: the first row that does not match its digest, or an output changed since
        the run wrote it.
    """
    run_dir = Path(run_dir)
    if not (run_dir / STORE).is_file():
        return
    try:
        problems = missing_outputs(run_dir)
    except StoreTampered as exc:
        raise InputError(field, str(exc)) from None
    changed = [p for p in problems if p.endswith("(changed since the run wrote it)")]
    if changed:
        raise InputError(field, f"{run_dir}: {changed[0]}: it no longer matches the store; "
                         "hypate run --resume rewrites it")
