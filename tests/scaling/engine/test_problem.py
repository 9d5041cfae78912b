"""evaluate_design records the warnings of each evaluation (in-process, in a forked child,
in pool and Dask workers), aggregated on the Outcome and stored with the evaluation; a NaN
that numpy warned about says so."""
from __future__ import annotations

import warnings
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest
from fault_injection import WARNING, problem
from hypate.scaling.engine.functional import FunctionProblem
from hypate.scaling.engine.optimizer import BayesianOptimizer
from hypate.scaling.engine.problem import (
    MAX_WARNING_CHARS,
    MAX_WARNINGS,
    evaluate_design,
    parse_warning,
    recorded_warnings,
    summarize_warnings,
    tally_warnings,
)
from hypate.scaling.engine.store import EvaluationStore

FAST = dict(acquisition="ei", n_raw=64, n_starts=2, n_restarts=0, seed=7, n_init=6, n_iter=2,
            batch_size=2)
EXPECTED = (f"RuntimeWarning: {WARNING} (3 times)",)


@pytest.mark.parametrize("timeout", [None, 30.0], ids=["in-process", "forked-child"])
def test_an_evaluation_records_its_warnings_and_prints_none(timeout, capfd) -> None:
    with warnings.catch_warnings(record=True) as outside:
        warnings.simplefilter("always")
        warned = evaluate_design(problem(warn_above=0.5), np.array([0.8, 0.2]), timeout)
        quiet = evaluate_design(problem(warn_above=0.5), np.array([0.2, 0.2]), timeout)
    assert warned.ok and warned.warnings == EXPECTED
    assert quiet.ok and quiet.warnings == ()
    assert outside == []  # not re-issued in the caller (nor by the forked child)
    assert capfd.readouterr().err == ""


def test_a_failed_evaluation_keeps_the_warnings_raised_before_it_failed() -> None:
    out = evaluate_design(problem(warn_above=0.5, nan_above=0.5), np.array([0.8, 0.8]))
    assert out.status == "invalid" and out.warnings == ()  # NaN returned before the warning

    def fun(x):
        warnings.warn("about to fail", UserWarning, stacklevel=1)
        raise ValueError("diverged")

    out = evaluate_design(FunctionProblem(fun, [(0.0, 1.0)]), np.array([0.5]))
    assert out.status == "error" and out.warnings == ("UserWarning: about to fail (1 time)",)


def test_a_numpy_nan_is_a_failure_that_says_where_it_came_from() -> None:
    out = evaluate_design(problem(numpy_nan_above=0.5), np.array([0.2, 0.8]))
    assert out.status == "invalid"
    assert out.message == ("non-finite objective or constraint "
                           "(numpy: invalid value encountered in sqrt)")
    assert out.warnings == ("RuntimeWarning: invalid value encountered in sqrt (1 time)",)
    plain = evaluate_design(problem(nan_above=0.5), np.array([0.2, 0.8]))
    assert (plain.status, plain.message) == ("invalid", "non-finite objective or constraint")


def test_summaries_are_aggregated_ordered_and_capped() -> None:
    with recorded_warnings() as caught:
        warnings.warn("b", RuntimeWarning, stacklevel=1)
        for k in range(MAX_WARNINGS + 5):
            warnings.warn(f"kind {k}", UserWarning, stacklevel=1)
        warnings.warn("b", RuntimeWarning, stacklevel=1)
        warnings.warn("x" * 2 * MAX_WARNING_CHARS, UserWarning, stacklevel=1)
    entries = summarize_warnings(caught)
    assert entries[:2] == ("RuntimeWarning: b (2 times)", "UserWarning: kind 0 (1 time)")
    assert len(entries) == MAX_WARNINGS + 1  # b, 25 kinds and the long one: 7 left over
    assert entries[-1] == "Other warnings: 7 more kinds (7 times)"
    assert summarize_warnings(caught) == entries  # deterministic
    long = summarize_warnings(caught[-1:])[0]
    assert parse_warning(long)[0].endswith("...") and len(parse_warning(long)[0]) == \
        MAX_WARNING_CHARS
    assert parse_warning("RuntimeWarning: a (b) (12 times)") == ("RuntimeWarning: a (b)", 12)
    assert parse_warning("bare") == ("bare", 1)


def test_tally_says_where_and_how_often_most_frequent_first() -> None:
    tally = tally_warnings([("prototype", ["W: a (1 time)"]),
                            (3, ["W: a (2 times)", "W: b (5 times)"]), (4, []),
                            (7, ["W: a (1 time)"])])
    assert tally == [("W: b", [3], 5), ("W: a", ["prototype", 3, 7], 4)]


def _stored_warnings(store) -> list[tuple]:
    with EvaluationStore(store, read_only=True) as s:
        return [(e.iteration, e.batch_index, e.warnings, e.F.tobytes()) for e in s.load()]


def test_warnings_are_stored_alike_in_process_in_a_pool_and_in_dask(tmp_path, capfd) -> None:
    distributed = pytest.importorskip("distributed")
    faulty = dict(warn_above=0.5)
    BayesianOptimizer(problem(**faulty), store=tmp_path / "serial.sqlite", **FAST).run()
    serial = _stored_warnings(tmp_path / "serial.sqlite")
    warned = [row for row in serial if row[2]]
    assert warned and all(row[2] == EXPECTED for row in warned)
    assert len(warned) < len(serial)  # attributed: only the designs that warned
    with ProcessPoolExecutor(2) as pool:
        BayesianOptimizer(problem(**faulty), executor=pool, store=tmp_path / "pool.sqlite",
                          timeout=30.0, **FAST).run()
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  host="127.0.0.1", dashboard_address=":0") as cluster, \
            distributed.Client(cluster) as client:
        BayesianOptimizer(problem(**faulty), executor=client, store=tmp_path / "dask.sqlite",
                          **FAST).run()
    # the same rows, warnings and (bit for bit) objectives wherever the evaluations ran
    assert _stored_warnings(tmp_path / "pool.sqlite") == serial
    assert _stored_warnings(tmp_path / "dask.sqlite") == serial
    assert "RuntimeWarning" not in capfd.readouterr().err  # no worker printed one
