"""Append-only, crash-safe evaluation store (SQLite, stdlib ``sqlite3``).

Every finished evaluation (x, F, G, status, message, warnings, seconds, iteration, seed) is
one row,
committed before the optimizer proposes anything else, in WAL mode with
``synchronous=FULL``: a run killed at any point loses at most the evaluation in flight, and
:class:`hypate.scaling.engine.optimizer.BayesianOptimizer` resumes from the rows without
re-evaluating.
Arrays are stored as JSON (Python's float ``repr`` round-trips exactly; NaN/inf allowed).
Rows are never updated or deleted. A store written before the ``warnings`` (or ``aux``)
column existed gets it (empty) when opened for writing, and reads as evaluations without
warnings (auxiliary outputs).

``aux`` holds a problem's auxiliary outputs of an evaluation as one JSON object (names of
the problem's choosing, e.g. what a simulated structure went through): data the engine
stores and hands back, never models.

Tamper evidence
---------------
Each row carries a ``digest``: the SHA-256 of the previous row's digest and the row's own
stored text (its position, every column as stored); the first row's "previous digest" is
the anchor, a SHA-256 of the campaign ``fingerprint`` in ``meta`` (empty for a store without
one). The ``meta`` key ``chain`` holds the number of rows and the last digest, written in
the same transaction as the row. :meth:`EvaluationStore.verify` (run whenever a store is
opened) recomputes the chain: a changed, deleted, inserted or reordered row, rows cut off
the end, or rows copied from another campaign's store raise :class:`StoreTampered` naming
the first row that does not match. This catches accidental edits, a careless merge or a
half-copied file; it does not stop someone who edits a row and recomputes every digest
after it (the code that does so is public): it is evidence, not a signature.

A store written before digests existed (no ``digest`` column or no ``chain`` record) has
no such evidence: its rows are read as they are, :attr:`EvaluationStore.unverified` counts
them and a warning is logged (logger ``hypate.store``). Rows appended to it later are
chained over the old rows' content, so an edit of an old row made after that is caught too.
"""
from __future__ import annotations

import contextlib
import errno
import hashlib
import json
import logging
import shutil
import sqlite3
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
from hypate.scaling.engine.problem import STATUS_OK, Outcome
from hypate.solvers.numerics.files import refuse_link

__all__ = ["CHAIN_META", "Evaluation", "EvaluationStore", "StoreError", "StoreTampered",
           "evaluations_to_dataframe", "warnings_text", "warnings_from_text"]

#: ``meta`` key of the digest chain's state: ``{"version", "rows", "head"}``.
CHAIN_META = "chain"
#: Version of the row digest (what is hashed, and how).
CHAIN_VERSION = 1
#: The logger of the warning about a store without digests.
LOG = logging.getLogger("hypate.store")
#: SQLite's primary result codes of a write that found no room or failed at the disk.
_SQLITE_FULL, _SQLITE_IOERR = 13, 10
#: Files SQLite keeps beside a database (never followed through a link).
_COMPANIONS = ("", "-wal", "-shm", "-journal")
#: The stored columns a row's digest covers, in order.
_ROW_COLUMNS = ("iteration", "batch_index", "x", "F", "G", "status", "message", "seconds",
                "seed", "created", "warnings", "aux")

_SCHEMA = """
CREATE TABLE IF NOT EXISTS evaluations (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    iteration INTEGER NOT NULL,
    batch_index INTEGER NOT NULL,
    x TEXT NOT NULL,
    F TEXT NOT NULL,
    G TEXT NOT NULL,
    status TEXT NOT NULL,
    message TEXT NOT NULL,
    seconds REAL NOT NULL,
    seed INTEGER,
    created REAL NOT NULL,
    warnings TEXT NOT NULL DEFAULT '[]',
    aux TEXT NOT NULL DEFAULT '{}',
    digest TEXT,
    UNIQUE (iteration, batch_index)
);
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
"""


class StoreError(ValueError):
    """A file that is not a readable evaluation store (corrupt, foreign, or a directory)."""


class StoreTampered(StoreError):
    """A store whose rows do not match their digest chain (see the module docstring).

    Attributes
    ----------
    row : int
        The first row (0-based, the evaluation id of ``evaluations.csv``) that does not
        match: changed, deleted, inserted or reordered at or before it.
    """

    def __init__(self, path: str, row: int, why: str) -> None:
        self.row = int(row)
        super().__init__(f"{path}: evaluation {row} {why}; the store was changed after "
                         "hypate wrote it (an edited, deleted or reordered row), so its "
                         "results are not used")


def anchor_digest(fingerprint: object) -> str:
    """The chain's digest before the first row: SHA-256 of the campaign fingerprint
    (``meta`` key ``fingerprint``; empty without one)."""
    text = fingerprint if isinstance(fingerprint, str) else ""
    return hashlib.sha256(f"hypate-evaluations-v{CHAIN_VERSION}\n{text}".encode()).hexdigest()


def row_digest(previous: str, position: int, row: tuple) -> str:
    """Digest of the row at ``position`` (0-based) with the stored values ``row`` (the
    columns of ``_ROW_COLUMNS``, as SQLite returns them), chained to ``previous``."""
    cells = [position, *(repr(v) if isinstance(v, float) else v for v in row)]
    text = json.dumps(cells, separators=(",", ":"))
    return hashlib.sha256(f"{previous}\n{text}".encode()).hexdigest()


@dataclass(frozen=True)
class Evaluation:
    """One finished evaluation (a committed row of the store).

    Attributes
    ----------
    x : ndarray of shape (d,)
    F : ndarray of shape (m,)
        Objectives (NaN where the evaluation failed).
    G : ndarray of shape (k,)
        Inequality constraints, feasible where ``G <= 0``.
    status : str
        ``"ok"``, ``"error"`` (raised), ``"invalid"`` (NaN/inf) or ``"timeout"``.
    message : str
    seconds : float
        Wall time of the evaluation.
    warnings : tuple of str
        The warnings raised during the evaluation
        (:func:`hypate.scaling.engine.problem.summarize_warnings`).
    iteration : int
        ``-1`` recycled samples, ``0`` initial design, ``t >= 1`` BO iteration.
    batch_index : int
        Position within the iteration's batch.
    seed : int or None
    aux : dict
        The problem's auxiliary outputs (JSON data; empty when it gives none).
    """

    x: np.ndarray
    F: np.ndarray
    G: np.ndarray
    status: str = STATUS_OK
    message: str = ""
    seconds: float = 0.0
    iteration: int = 0
    batch_index: int = 0
    seed: int | None = None
    created: float = field(default_factory=time.time)
    warnings: tuple[str, ...] = ()
    aux: dict = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.status == STATUS_OK

    @classmethod
    def from_outcome(cls, x: np.ndarray, outcome: Outcome, *, iteration: int,
                     batch_index: int, seed: int | None) -> Evaluation:
        """The record of design ``x`` evaluated to ``outcome`` in slot (iteration, index)."""
        return cls(x=np.asarray(x, float), F=np.asarray(outcome.F, float),
                   G=np.asarray(outcome.G, float), status=outcome.status,
                   message=outcome.message, seconds=float(outcome.seconds),
                   iteration=iteration, batch_index=batch_index, seed=seed,
                   warnings=tuple(outcome.warnings), aux=dict(outcome.aux))


def _dump(a: np.ndarray) -> str:
    return json.dumps([float(v) for v in np.asarray(a, dtype=float).ravel()])


def _load(s: str) -> np.ndarray:
    return np.asarray(json.loads(s), dtype=float)


def warnings_text(entries: tuple[str, ...] | list[str]) -> str:
    """The ``warnings`` cell of evaluations.csv: ``""`` without warnings, else a JSON list.

    Parameters
    ----------
    entries : sequence of str

    Returns
    -------
    str
    """
    return json.dumps(list(entries)) if entries else ""


def warnings_from_text(text: object) -> tuple[str, ...]:
    """Inverse of :func:`warnings_text` (also for the store's JSON and pandas' NaN of an
    empty CSV cell).

    Parameters
    ----------
    text : str or None or float

    Returns
    -------
    tuple of str
    """
    if not isinstance(text, str) or not text.strip():
        return ()
    return tuple(str(v) for v in json.loads(text))


def _columns(con: sqlite3.Connection) -> set[str]:
    return {row[1] for row in con.execute("PRAGMA table_info(evaluations)")}


class EvaluationStore:
    """SQLite store of evaluations; one committed row per finished evaluation.

    Parameters
    ----------
    path : str or Path
        Database file (created if missing); ``":memory:"`` for a throwaway store.
    read_only : bool
        Read an existing store without writing anything in its directory (a private
        snapshot of the database and its WAL is read).

    Attributes
    ----------
    unverified : int
        Rows written without a digest (by a hypate older than the chain): read as they
        are, a warning logged (see the module docstring).

    Raises
    ------
    StoreError
        The file is not a SQLite database, or (read-only) not a hypate store.
    StoreTampered
        The rows do not match their digest chain (:meth:`verify`).
    LinkRefused
        (writing) The database or one of SQLite's companion files is a symbolic link.
    """

    def __init__(self, path: str | Path, *, read_only: bool = False) -> None:
        self.path = str(path)
        self.read_only = read_only
        self._snapshot: tempfile.TemporaryDirectory[str] | None = None
        try:
            if read_only:
                self._con = self._snapshot_connection(Path(path))
                self._con.execute("SELECT COUNT(*) FROM evaluations").fetchone()
                self._con.execute("SELECT COUNT(*) FROM meta").fetchone()
            else:
                if self.path != ":memory:":  # SQLite opens (and creates) through links
                    for suffix in _COMPANIONS:
                        refuse_link(self.path + suffix)
                self._con = sqlite3.connect(self.path)
                if self.path != ":memory:":
                    self._con.execute("PRAGMA journal_mode=WAL")
                self._con.execute("PRAGMA synchronous=FULL")
                self._con.executescript(_SCHEMA)
                for column, kind in (("warnings", "TEXT NOT NULL DEFAULT '[]'"),
                                     ("aux", "TEXT NOT NULL DEFAULT '{}'"),
                                     ("digest", "TEXT")):  # a store of an earlier version
                    if column not in _columns(self._con):
                        self._con.execute(f"ALTER TABLE evaluations ADD COLUMN {column} {kind}")
                self._con.commit()
            self._rows, self._head, self.unverified = self.verify()
        except sqlite3.Error as exc:
            self.close()
            raise StoreError(f"{self.path} is not a readable hypate evaluation store: {exc}"
                             ) from None
        except BaseException:
            self.close()
            raise
        if self.unverified:
            LOG.warning("%s was written by an older hypate: %d of its evaluations carry no "
                        "digest, so a change to them cannot be detected", self.path,
                        self.unverified)

    def verify(self) -> tuple[int, str, int]:
        """Recompute the digest chain over every row (see the module docstring).

        Returns
        -------
        rows : int
        head : str
            The last row's digest (the anchor for an empty store).
        unverified : int
            Leading rows without a digest (a store of an older hypate).

        Raises
        ------
        StoreTampered
            Naming the first row that does not match.
        """
        cols = _columns(self._con)
        # the later columns as a store of an earlier version reads once opened for writing
        later = {"warnings": "'[]'", "aux": "'{}'", "digest": "NULL"}
        select = [c if c in cols or c not in later else later[c]
                  for c in (*_ROW_COLUMNS, "digest")]
        head = anchor_digest(self.get_meta("fingerprint"))
        rows = unverified = 0
        query = f"SELECT {', '.join(select)} FROM evaluations ORDER BY id"
        for *values, stored in self._con.execute(query):
            expected = row_digest(head, rows, tuple(values))
            if stored is None:
                if unverified < rows:  # a digest removed after the chain had begun
                    raise StoreTampered(self.path, rows, "has lost its digest")
                unverified += 1
            elif stored != expected:
                raise StoreTampered(self.path, rows, "does not match its digest")
            head, rows = expected, rows + 1
        record = self.get_meta(CHAIN_META)
        if not isinstance(record, dict):
            if rows > unverified:  # digests without the record that counts them
                raise StoreTampered(self.path, unverified, "is chained, but the chain's "
                                    "record is missing")
            return rows, head, unverified
        recorded = record.get("rows")
        if isinstance(recorded, int) and recorded > rows:
            after = (f" and the {recorded - rows - 1} after it are" if recorded - rows > 1
                     else " is")
            raise StoreTampered(self.path, rows, f"{after.strip()} missing (the chain records "
                                f"{recorded} evaluations, the store holds {rows})")
        if recorded != rows or record.get("head") != head:
            raise StoreTampered(self.path, rows - 1, "does not match the chain's record "
                                "(rows added, removed or reordered)")
        return rows, head, unverified

    def _snapshot_connection(self, path: Path) -> sqlite3.Connection:
        """A connection to a private copy of the database and its WAL: even a read-only
        SQLite connection writes the WAL index (``-shm``) of a store left by a killed run,
        and a refused resume must leave the directory byte for byte as it was."""
        if not path.is_file():
            raise StoreError(f"{path} is not a file")
        self._snapshot = tempfile.TemporaryDirectory(prefix="hypate-store-")
        copy = Path(self._snapshot.name) / path.name
        shutil.copyfile(path, copy)
        wal = path.with_name(path.name + "-wal")
        if wal.is_file():
            shutil.copyfile(wal, copy.with_name(copy.name + "-wal"))
        return sqlite3.connect(copy)

    @contextlib.contextmanager
    def _writing(self) -> Iterator[None]:
        """A failed write as the ``OSError`` it is: SQLite's "database or disk is full" as
        ``ENOSPC``, its I/O errors (a file-size limit, a failing disk) as ``EIO``, naming
        the store, so that a caller tells a full disk from a corrupt store. The transaction
        is rolled back: the store keeps every row committed before."""
        try:
            yield
        except sqlite3.OperationalError as exc:
            code = getattr(exc, "sqlite_errorcode", None)
            if code is None or code & 0xFF not in (_SQLITE_FULL, _SQLITE_IOERR):
                raise
            full = code & 0xFF == _SQLITE_FULL
            raise OSError(errno.ENOSPC if full else errno.EIO,
                          f"{exc} ({getattr(exc, 'sqlite_errorname', code)})",
                          self.path) from exc

    @property
    def head(self) -> str:
        """The last row's digest (the chain's anchor while the store is empty)."""
        if self._rows == 0:
            return anchor_digest(self.get_meta("fingerprint"))
        return self._head

    def append(self, ev: Evaluation) -> None:
        """Insert one evaluation, chained to the previous one, and commit it.

        The row, its digest and the chain's record are one transaction: an interruption
        (Ctrl-C, SIGTERM, a full disk) commits all of them or none.
        """
        if self.read_only:
            raise StoreError(f"{self.path} is open read-only")
        if self._rows == 0:  # the campaign's fingerprint is recorded after the store opens
            self._head = anchor_digest(self.get_meta("fingerprint"))
        with self._writing(), self._con:  # commits, or rolls back on any exception
            cur = self._con.execute(
                f"INSERT INTO evaluations ({', '.join(_ROW_COLUMNS)}) VALUES "
                "(?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                (int(ev.iteration), int(ev.batch_index), _dump(ev.x), _dump(ev.F),
                 _dump(ev.G), str(ev.status), str(ev.message), float(ev.seconds),
                 None if ev.seed is None else int(ev.seed), float(ev.created),
                 json.dumps([str(w) for w in ev.warnings]), json.dumps(ev.aux, sort_keys=True)))
            # the digest of the values as SQLite returns them, as verify() reads them
            values = self._con.execute(f"SELECT {', '.join(_ROW_COLUMNS)} FROM evaluations "
                                       "WHERE id = ?", (cur.lastrowid,)).fetchone()
            digest = row_digest(self._head, self._rows, tuple(values))
            self._con.execute("UPDATE evaluations SET digest = ? WHERE id = ?",
                              (digest, cur.lastrowid))
            self._con.execute("INSERT OR REPLACE INTO meta (key, value) VALUES (?, ?)",
                              (CHAIN_META, json.dumps({"version": CHAIN_VERSION,
                                                       "rows": self._rows + 1,
                                                       "head": digest}, sort_keys=True)))
        self._head, self._rows = digest, self._rows + 1

    def load(self) -> list[Evaluation]:
        """All evaluations in insertion order."""
        # a read-only snapshot of an earlier version's store lacks the later columns
        columns = _columns(self._con)
        warn = "warnings" if "warnings" in columns else "'[]'"
        aux = "aux" if "aux" in columns else "'{}'"
        rows = self._con.execute(
            "SELECT iteration, batch_index, x, F, G, status, message, seconds, seed, created,"
            f" {warn}, {aux} FROM evaluations ORDER BY id").fetchall()
        return [Evaluation(x=_load(x), F=_load(F), G=_load(G), status=st, message=msg,
                           seconds=sec, iteration=it, batch_index=bi, seed=seed, created=cr,
                           warnings=warnings_from_text(w), aux=json.loads(a))
                for it, bi, x, F, G, st, msg, sec, seed, cr, w, a in rows]

    def __len__(self) -> int:
        return int(self._con.execute("SELECT COUNT(*) FROM evaluations").fetchone()[0])

    def set_meta(self, key: str, value: object, *, replace: bool = False) -> None:
        """Record a run setting (JSON) once; later calls with the same key must agree
        (``replace``: a pointer such as the study file's path, which may move)."""
        text = json.dumps(value, sort_keys=True)
        if replace:
            with self._writing(), self._con:
                self._con.execute("INSERT OR REPLACE INTO meta (key, value) VALUES (?, ?)",
                                  (key, text))
            return
        old = self.get_meta(key)
        if old is not None and json.dumps(old, sort_keys=True) != text:
            raise ValueError(f"store {self.path!r} holds a run with {key}={old!r}, not {value!r}")
        with self._writing(), self._con:
            self._con.execute("INSERT OR IGNORE INTO meta (key, value) VALUES (?, ?)",
                              (key, text))

    def get_meta(self, key: str) -> object | None:
        row = self._con.execute("SELECT value FROM meta WHERE key = ?", (key,)).fetchone()
        return None if row is None else json.loads(row[0])

    def to_dataframe(self) -> pd.DataFrame:
        """Evaluations as a DataFrame (see :func:`evaluations_to_dataframe`)."""
        return evaluations_to_dataframe(self.load())

    def close(self) -> None:
        if getattr(self, "_con", None) is not None:
            self._con.close()
        if self._snapshot is not None:
            self._snapshot.cleanup()
            self._snapshot = None

    def __enter__(self) -> EvaluationStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def evaluations_to_dataframe(evals: list[Evaluation]) -> pd.DataFrame:
    """One row per evaluation: ``iteration, batch_index, x0.., f0.., g0.., status, message,
    warnings, seconds, seed, aux`` (``warnings``: :func:`warnings_text`; ``aux``: the
    auxiliary outputs, a dict per row)."""
    if not evals:
        return pd.DataFrame(columns=["iteration", "batch_index", "status", "message",
                                     "warnings", "seconds", "seed", "aux"])
    d, m, k = len(evals[0].x), len(evals[0].F), len(evals[0].G)
    cols: dict[str, object] = {
        "iteration": [e.iteration for e in evals],
        "batch_index": [e.batch_index for e in evals],
    }
    X = np.array([e.x for e in evals]).reshape(len(evals), d)
    F = np.array([e.F for e in evals]).reshape(len(evals), m)
    G = np.array([e.G for e in evals]).reshape(len(evals), k)
    cols.update({f"x{i}": X[:, i] for i in range(d)})
    cols.update({f"f{i}": F[:, i] for i in range(m)})
    cols.update({f"g{i}": G[:, i] for i in range(k)})
    cols.update(status=[e.status for e in evals], message=[e.message for e in evals],
                warnings=[warnings_text(e.warnings) for e in evals],
                seconds=[e.seconds for e in evals], seed=[e.seed for e in evals],
                aux=[e.aux for e in evals])
    return pd.DataFrame(cols)
