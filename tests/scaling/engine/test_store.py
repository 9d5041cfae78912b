"""The append-only SQLite evaluation store (scaling/store.py)."""
from __future__ import annotations

import hashlib
import sqlite3

import numpy as np
import pytest
from hypate.scaling.engine.store import (
    Evaluation,
    EvaluationStore,
    warnings_from_text,
    warnings_text,
)


def _evals():
    return [
        Evaluation(x=np.array([0.1 + 0.2, 1e-300, -3.5]), F=np.array([np.pi, np.e]),
                   G=np.array([-1.0]), iteration=0, batch_index=0, seed=7, seconds=0.25),
        Evaluation(x=np.array([1.0, 2.0, 3.0]), F=np.array([np.nan, np.inf]), G=np.array([np.nan]),
                   status="error", message="RuntimeError: solver diverged", iteration=0,
                   batch_index=1, seed=7, seconds=1.5,
                   warnings=("RuntimeWarning: clamped; below [250, 950] K (3 times)",
                             'UserWarning: "quoted" (1 time)')),
        Evaluation(x=np.array([5e-324, -0.0, 1.0 / 3.0]), F=np.array([-np.inf, 1e308]),
                   G=np.array([0.0]), status="invalid", message="non-finite", iteration=1,
                   batch_index=0, seed=7),
    ]


def _same(a: Evaluation, b: Evaluation) -> bool:
    arrs = all(np.array_equal(getattr(a, k), getattr(b, k), equal_nan=True) for k in "xFG")
    bits = all(np.array_equal(np.asarray(getattr(a, k)).view(np.int64),
                              np.asarray(getattr(b, k)).view(np.int64)) for k in "xFG")
    rest = all(getattr(a, k) == getattr(b, k) for k in
               ("status", "message", "seconds", "iteration", "batch_index", "seed", "created",
                "warnings"))
    return arrs and bits and rest


def test_round_trip_is_bit_exact_across_connections(tmp_path):
    path = tmp_path / "run.sqlite"
    evals = _evals()
    with EvaluationStore(path) as store:
        for e in evals:
            store.append(e)
        # committed per row: a second connection sees every row while the first is open
        assert len(EvaluationStore(path)) == 3
    loaded = EvaluationStore(path).load()
    assert len(loaded) == 3
    assert all(_same(a, b) for a, b in zip(evals, loaded))


def test_append_only_and_unique_per_iteration_slot(tmp_path):
    store = EvaluationStore(tmp_path / "a.sqlite")
    store.append(_evals()[0])
    with pytest.raises(sqlite3.IntegrityError):
        store.append(_evals()[0])
    assert len(store) == 1


def test_meta_guards_against_resuming_a_different_run(tmp_path):
    store = EvaluationStore(tmp_path / "m.sqlite")
    store.set_meta("seed", 3)
    store.set_meta("seed", 3)
    assert store.get_meta("seed") == 3
    with pytest.raises(ValueError, match="seed"):
        store.set_meta("seed", 4)


def test_dataframe_columns():
    store = EvaluationStore(":memory:")
    for e in _evals():
        store.append(e)
    df = store.to_dataframe()
    assert list(df.columns) == ["iteration", "batch_index", "x0", "x1", "x2", "f0", "f1", "g0",
                                "status", "message", "warnings", "seconds", "seed", "aux"]
    assert list(df["status"]) == ["ok", "error", "invalid"]
    assert df.loc[0, "x0"] == 0.1 + 0.2


#: The evaluations table of stores written before the ``warnings`` column existed.
OLD_SCHEMA = """
CREATE TABLE evaluations (
    id INTEGER PRIMARY KEY AUTOINCREMENT, iteration INTEGER NOT NULL,
    batch_index INTEGER NOT NULL, x TEXT NOT NULL, F TEXT NOT NULL, G TEXT NOT NULL,
    status TEXT NOT NULL, message TEXT NOT NULL, seconds REAL NOT NULL, seed INTEGER,
    created REAL NOT NULL, UNIQUE (iteration, batch_index));
CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
INSERT INTO evaluations (iteration, batch_index, x, F, G, status, message, seconds, seed,
    created) VALUES (0, 0, '[0.5, 0.25]', '[1.5]', '[]', 'ok', '', 0.5, 3, 1.0);
"""


def _digest(path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_a_store_without_the_warnings_column_still_loads(tmp_path):
    path = tmp_path / "old.sqlite"
    with sqlite3.connect(path) as con:
        con.executescript(OLD_SCHEMA)
    con.close()
    before = _digest(path)
    with EvaluationStore(path, read_only=True) as store:  # a snapshot: nothing written
        (row,) = store.load()
        assert (row.warnings, row.status, row.F.tolist()) == ((), "ok", [1.5])
        assert list(store.to_dataframe()["warnings"]) == [""]
    assert _digest(path) == before
    with EvaluationStore(path) as store:  # writable: the column is added, rows kept
        new = Evaluation(x=np.array([0.1, 0.2]), F=np.array([2.0]), G=np.zeros(0),
                         iteration=1, warnings=("RuntimeWarning: w (2 times)",))
        store.append(new)
    with EvaluationStore(path, read_only=True) as store:
        assert [e.warnings for e in store.load()] == [(), ("RuntimeWarning: w (2 times)",)]


def test_the_csv_cell_of_the_warnings():
    entries = ("RuntimeWarning: a, b; c (2 times)",)
    assert warnings_text(()) == "" and warnings_from_text("") == ()
    assert warnings_from_text(float("nan")) == ()  # pandas' empty cell
    assert warnings_from_text(warnings_text(entries)) == entries


#: One edit per stored column of a row: every one, the auxiliary outputs (``aux``: a
#: simulation's extremes and histories) and the constraints (``G``: the admissibility
#: columns) included, must break the digest chain.
EDITS = {
    "iteration": "5", "batch_index": "7", "x": "'[0.5, 0.5, 0.5]'", "F": "'[0.001, 0.002]'",
    "G": "'[-2.0]'", "status": "'ok'", "message": "'edited'", "seconds": "9.0",
    "seed": "8", "created": "created + 1", "warnings": "'[]'",
    "aux": "'{\"extremes\": {\"max_temperature\": 300.0}}'",
}


@pytest.mark.parametrize("column", sorted(EDITS))
def test_an_edit_to_any_stored_column_is_refused_naming_the_row(tmp_path, column):
    path = tmp_path / "chain.sqlite"
    evals = _evals()
    evals[1].aux.update({"extremes": {"max_temperature": 912.5}, "history": [1.0, 2.0]})
    with EvaluationStore(path) as store:
        for e in evals:
            store.append(e)
    with EvaluationStore(path, read_only=True) as store:  # intact: verified and read
        assert store.load()[1].aux["extremes"] == {"max_temperature": 912.5}
    with sqlite3.connect(path) as con:
        select = f"SELECT {column} FROM evaluations WHERE id = 2"
        before = con.execute(select).fetchone()
        con.execute(f"UPDATE evaluations SET {column} = {EDITS[column]} WHERE id = 2")
        assert con.execute(select).fetchone() != before  # the edit changed the row
    con.close()
    for read_only in (True, False):
        with pytest.raises(ValueError, match="evaluation 1 does not match its digest"):
            EvaluationStore(path, read_only=read_only)
