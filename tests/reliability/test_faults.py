"""Fault injection: a campaign survives what happens to the machinery under it
(scaling/engine/executors.py, evaluate_design in scaling/engine/problem.py).

Infrastructure faults (a worker SIGKILLed from outside, two worker deaths in one batch, a
killed scheduler, the last worker killed) are re-submitted or end the run with
InfrastructureError; they are never stored, and a resumed run ends with the campaign of an
uninterrupted one. Design faults (a design that kills its worker, a time limit) are results.
Processes end with their work and with their parent.

The problems are small FunctionProblems of tests/fault_injection.py (importable by workers):
a run takes seconds. Campaigns are compared exactly, as the (iteration, batch_index, x, F,
status) rows of EvaluationStore.load().
"""
from __future__ import annotations

import contextlib
import importlib.util
import logging
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import REPO, stored_evaluations, tiny_study_text
from fault_injection import alive, campaign, children, descendants, log_lines, problem
from hypate.scaling.engine.child import TERMINATE_GRACE
from hypate.scaling.engine.executors import (
    HEALTH_INTERVAL,
    ResilientProcessPool,
    make_executor,
    run_batch,
)
from hypate.scaling.engine.faults import (
    SHARED_RETRIES,
    SOLO_DEATHS,
    InfrastructureError,
)
from hypate.scaling.engine.optimizer import BayesianOptimizer
from hypate.scaling.engine.problem import Outcome, evaluate_design
from hypate.scaling.engine.store import EvaluationStore

TESTS = REPO / "tests"
#: Small inner optimizations: the proposals take milliseconds, the faults are the subject.
FAST = dict(acquisition="ei", n_raw=64, n_starts=2, n_restarts=0, seed=7)
#: The message of a design stored as a failure after killing its worker alone.
KILLER_MESSAGE = f"worker died while evaluating this design alone ({SOLO_DEATHS} times"


def _reference(tmp_path: Path, name: str = "reference", **settings) -> list[tuple]:
    """The campaign of an uninterrupted in-process run (no faults, no sleeping)."""
    store = tmp_path / f"{name}.sqlite"
    BayesianOptimizer(problem(), store=store, **settings).run()
    return campaign(store)


class _Sniper(threading.Thread):
    """SIGKILLs, from outside, the process that started evaluation number ``n`` (1-based,
    from the start log) for each ``n`` of ``at``, ``delay`` seconds after it started (while
    it computes)."""

    def __init__(self, log: Path, at: list[int], delay: float = 0.1) -> None:
        super().__init__(daemon=True)
        self.log, self.at, self.delay = log, sorted(at), delay
        self.killed: list[tuple[int, float, float]] = []
        self.stop = threading.Event()

    def run(self) -> None:
        for n in self.at:
            while len(log_lines(self.log)) < n:
                if self.stop.wait(0.005):
                    return
            line = log_lines(self.log)[n - 1]
            time.sleep(self.delay)
            try:
                os.kill(line[0], signal.SIGKILL)
            except ProcessLookupError:
                continue
            self.killed.append(line)


def _run_with_sniper(tmp_path: Path, at: list[int], **settings) -> tuple[list[tuple], _Sniper,
                                                                          ResilientProcessPool]:
    log = tmp_path / "started.log"
    store = tmp_path / "sniped.sqlite"
    pool = ResilientProcessPool(2)
    sniper = _Sniper(log, at)
    sniper.start()
    try:
        BayesianOptimizer(problem(sleep=0.4, log=str(log)), store=store, executor=pool,
                          **settings).run()
    finally:
        sniper.stop.set()
        sniper.join()
        pool.shutdown()
    return campaign(store), sniper, pool


# ------------------------------------------------------------------ process pool
def test_worker_killed_from_outside_mid_batch_is_resubmitted_not_stored(tmp_path: Path) -> None:
    kw = dict(FAST, n_init=4, n_iter=2, batch_size=2)
    ref = _reference(tmp_path, **kw)
    # evaluation 3 starts when the first two are done: it is the third design of the
    # four-design initial batch, running on one of the two workers
    got, sniper, pool = _run_with_sniper(tmp_path, [3], **kw)
    assert len(sniper.killed) == 1 and pool.restarts == 1
    assert got == ref  # no BrokenProcessPool row, nothing lost, same proposals
    assert {row[4] for row in got} == {"ok"}
    assert len(log_lines(tmp_path / "started.log")) > len(ref)  # the lost work re-ran


def test_two_worker_deaths_in_one_batch_are_both_survived(tmp_path: Path) -> None:
    kw = dict(FAST, n_init=6, n_iter=1, batch_size=2)
    ref = _reference(tmp_path, **kw)
    # evaluation 2 is in the first round of the six-design initial batch; evaluation 5 in
    # its re-submission (6 designs on 2 workers take three rounds of 0.4 s)
    got, sniper, pool = _run_with_sniper(tmp_path, [2, 5], **kw)
    assert len(sniper.killed) == 2 and pool.restarts == 2
    initial = {(float.fromhex(r[2][0]), float.fromhex(r[2][1])) for r in ref if r[0] == 0}
    assert all((x0, x1) in initial for _, x0, x1 in sniper.killed)  # both in batch 0
    assert got == ref
    assert {row[4] for row in got} == {"ok"}


@pytest.mark.parametrize("where", ["pool", "pool+timeout", "in-process+timeout"])
def test_a_design_that_kills_its_worker_is_a_failure_after_bounded_retries(
        tmp_path: Path, where: str) -> None:
    # without a time limit the design kills the pool worker (the pool breaks); with one it
    # kills the forked child evaluating it (the worker, or the optimizer, survives)
    log = tmp_path / "started.log"
    pool = ResilientProcessPool(2) if where.startswith("pool") else None
    timeout = 30.0 if where.endswith("timeout") else None
    try:
        res = BayesianOptimizer(problem(kill_above=0.75, log=str(log)), executor=pool,
                                timeout=timeout, n_init=6, n_iter=2, batch_size=2,
                                **FAST).run()
    finally:
        if pool is not None:
            pool.shutdown()
    data = res.data
    killers = (data["x0"] > 0.75).to_numpy()
    assert killers.any() and (~killers).any() and len(data) == 6 + 2 * 2  # the run went on
    assert (data.loc[killers, "status"] == "error").all()
    assert data.loc[killers, "message"].str.startswith(KILLER_MESSAGE).all()
    assert (data.loc[~killers, "status"] == "ok").all()
    # bounded: each killer ran at least SOLO_DEATHS times alone, and at most that plus
    # the shared rounds of its batch
    starts = [x0 for _, x0, _ in log_lines(log)]
    for x0 in data.loc[killers, "x0"]:
        assert SOLO_DEATHS <= starts.count(x0) <= SOLO_DEATHS + SHARED_RETRIES + 1


# ------------------------------------------------------------------------ timeouts
@pytest.mark.parametrize("where", ["in-process", "pool"])
def test_a_timeout_ends_the_work(tmp_path: Path, where: str) -> None:
    log = tmp_path / "started.log"
    limit = 1.5
    threads_before = set(threading.enumerate())
    children_before = children(os.getpid())
    pool = ResilientProcessPool(2) if where == "pool" else None
    t0 = time.monotonic()
    try:
        res = BayesianOptimizer(problem(slow_above=0.8, slow=60.0, log=str(log)),
                                executor=pool, timeout=limit, n_init=6, n_iter=1,
                                batch_size=2, **FAST).run()
    finally:
        if pool is not None:
            pool.shutdown()
    wall = time.monotonic() - t0
    data = res.data
    slow = (data["x0"] > 0.8).to_numpy()
    assert slow.any()
    assert (data.loc[slow, "status"] == "timeout").all()
    assert (data.loc[~slow, "status"] == "ok").all()
    assert (data.loc[slow, "message"] == f"exceeded {limit} s").all()
    # each timed-out evaluation ended at its limit (plus the SIGTERM grace at most)
    assert ((data.loc[slow, "seconds"] >= limit)
            & (data.loc[slow, "seconds"] < limit + TERMINATE_GRACE + 1.0)).all()
    assert wall < 30.0  # nothing waited for the 60 s evaluations
    # no thread left computing, no process left: the evaluating children are gone
    assert set(threading.enumerate()) == threads_before
    assert children(os.getpid()) == children_before
    slow_pids = [pid for pid, x0, _ in log_lines(log) if x0 > 0.8]
    assert slow_pids and not any(alive(pid) for pid in slow_pids)


def test_the_time_limit_counts_from_the_start_of_the_evaluation() -> None:
    # one worker, three designs of 0.6 s each: the third finishes 1.8 s after submission
    # but 0.6 s after its start, within a 1.2 s limit
    prob = problem(sleep=0.6)
    X = np.array([[0.2, 0.2], [0.4, 0.4], [0.6, 0.6]])
    pool = ResilientProcessPool(1)
    try:
        got = list(run_batch(pool, evaluate_design, [(prob, x, 1.2) for x in X],
                             on_failure=lambda m, s: Outcome.failure(1, 0, "error", m, s)))
    finally:
        pool.shutdown()
    assert [k for k, _ in got] == [0, 1, 2]
    assert [o.status for _, o in got] == ["ok"] * 3


RUN_WITH_TIMEOUTS = """
import sys
sys.path.insert(0, {tests!r})
from fault_injection import problem
from hypate.scaling.engine.optimizer import BayesianOptimizer
res = BayesianOptimizer(problem(slow_above=0.7, slow=60.0), timeout=1.0, n_init=5,
                        n_iter=0, acquisition="ei", seed=7).run()
print(sorted(set(res.data["status"])))
"""


def test_a_run_with_timeouts_exits_cleanly(tmp_path: Path) -> None:
    # before: abandoned daemon threads still computing at exit -> exit code 120 after
    # "Exception ignored ... TypeError"
    script = tmp_path / "timeouts.py"
    script.write_text(RUN_WITH_TIMEOUTS.format(tests=str(TESTS)))
    t0 = time.monotonic()
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "['ok', 'timeout']"
    assert "Exception ignored" not in done.stderr and "Traceback" not in done.stderr
    assert time.monotonic() - t0 < 30.0


# --------------------------------------------------------------- parent death
KILLED_PARENT = """
import sys
sys.path.insert(0, {tests!r})
from fault_injection import problem
from hypate.scaling.engine.executors import make_executor
from hypate.scaling.engine.optimizer import BayesianOptimizer
pool, close = make_executor(2, None)
BayesianOptimizer(problem(slow_above=-1.0, slow=600.0, log={log!r}), executor=pool,
                  timeout=900.0, n_init=4, n_iter=0, acquisition="ei", seed=7).run()
"""


def test_workers_and_their_children_die_with_a_killed_parent(tmp_path: Path) -> None:
    # the --workers 2 pool, each worker evaluating in a forked child (time limit set)
    log = tmp_path / "started.log"
    script = tmp_path / "parent.py"
    script.write_text(KILLED_PARENT.format(tests=str(TESTS), log=str(log)))
    proc = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60.0
        while len(log_lines(log)) < 2 and time.monotonic() < deadline:
            assert proc.poll() is None, "the run ended before it could be killed"
            time.sleep(0.05)
        assert len(log_lines(log)) >= 2
        family = descendants(proc.pid)
        evaluating = {pid for pid, _, _ in log_lines(log)}
        assert len(children(proc.pid)) >= 2 and evaluating <= family
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10)
        t0 = time.monotonic()
        while any(alive(pid) for pid in family) and time.monotonic() - t0 < 5.0:
            time.sleep(0.02)
        survivors = [pid for pid in family if alive(pid)]
    finally:
        if proc.poll() is None:
            proc.kill()
    for pid in survivors:  # do not leave them behind if the test fails
        os.kill(pid, signal.SIGKILL)
    assert survivors == [], f"{len(survivors)} of {len(family)} processes outlived the parent"


# ------------------------------------------------------------------------- dask
needs_dask = pytest.mark.skipif(importlib.util.find_spec("distributed") is None,
                                reason="needs the cluster extra (dask.distributed)")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class _Cluster:
    """A Dask scheduler and one worker (no nanny: a killed worker stays dead) as
    subprocesses on a fixed loopback port, so that they can be restarted on the same
    address."""

    def __init__(self) -> None:
        self.port = _free_port()
        self.address = f"tcp://127.0.0.1:{self.port}"
        self.env = dict(os.environ, PYTHONPATH=os.pathsep.join(
            [str(TESTS), *filter(None, [os.environ.get("PYTHONPATH")])]))
        self.scheduler: subprocess.Popen | None = None
        self.worker: subprocess.Popen | None = None

    def _spawn(self, *args: str) -> subprocess.Popen:
        return subprocess.Popen([sys.executable, "-m", *args], env=self.env,
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)

    def start(self) -> _Cluster:
        self.scheduler = self._spawn("distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                                     "--port", str(self.port), "--no-dashboard")
        deadline = time.monotonic() + 60.0
        while True:  # the worker needs the scheduler up
            try:
                socket.create_connection(("127.0.0.1", self.port), timeout=1.0).close()
                break
            except OSError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.1)
        self.worker = self._spawn("distributed.cli.dask_worker", self.address, "--nthreads",
                                  "2", "--no-nanny", "--no-dashboard")
        return self

    def kill(self, which: str) -> None:
        proc = getattr(self, which)
        if proc is not None and proc.poll() is None:
            proc.kill()
            proc.wait(timeout=30)

    def stop(self) -> None:
        self.kill("worker")
        self.kill("scheduler")


@pytest.fixture
def cluster() -> _Cluster:
    c = _Cluster().start()
    yield c
    c.stop()


def _connect(address: str, lost_after: float = 5.0):
    executor, close = make_executor(1, address, lost_after=lost_after)
    executor.client.wait_for_workers(1, timeout=60)
    return executor, close


@contextlib.contextmanager
def _distributed_log():
    """The error records (or records with a traceback) distributed logs meanwhile: its
    loggers print to the terminal through their own handlers, which pytest's capture
    fixtures do not see."""
    records: list[logging.LogRecord] = []

    class Keep(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            if record.levelno >= logging.ERROR or record.exc_info:
                records.append(record)

    handler = Keep()
    logger = logging.getLogger("distributed")  # distributed.client etc. propagate to it
    logger.addHandler(handler)
    try:
        yield records
    finally:
        logger.removeHandler(handler)


def _kill_at(rows: int, kill) -> tuple[list[float], object]:
    """A callback calling ``kill()`` once ``rows`` evaluations are stored; the list gets the
    time of the kill."""
    when: list[float] = []
    count = [0]

    def callback(ev) -> None:
        count[0] += 1
        if count[0] == rows:
            kill()
            when.append(time.monotonic())
    return when, callback


@needs_dask
def test_killed_scheduler_ends_the_run_and_a_resume_completes_it(
        tmp_path: Path, cluster: _Cluster) -> None:
    kw = dict(FAST, n_init=4, n_iter=3, batch_size=2)
    ref = _reference(tmp_path, **kw)
    store = tmp_path / "dask.sqlite"
    executor, close = _connect(cluster.address)
    when, callback = _kill_at(5, lambda: cluster.kill("scheduler"))  # mid-batch 1
    with pytest.raises(InfrastructureError, match="scheduler") as err:
        BayesianOptimizer(problem(sleep=0.2), executor=executor, store=store,
                          callback=callback, **kw).run()
    waited = time.monotonic() - when[0]
    with _distributed_log() as records:
        close()  # after the scheduler died: no raise, no error or traceback logged
    assert records == []
    assert waited < 5.0 + 2 * HEALTH_INTERVAL + 2.0
    assert err.value.unfinished >= 1 and "\n" not in str(err.value)
    stored = campaign(store)
    assert 5 <= len(stored) < len(ref) and stored == ref[:len(stored)]  # no fault row
    cluster.stop()
    cluster.start()  # the same address
    executor, close = _connect(cluster.address)
    try:
        BayesianOptimizer(problem(), executor=executor, store=store, **kw).run()
    finally:
        close()
    assert campaign(store) == ref


@needs_dask
def test_hypate_run_exits_3_when_the_scheduler_dies_and_resumes_to_the_same_campaign(
        tmp_path: Path, cluster: _Cluster) -> None:
    """The command line end to end: exit code 3 with one line naming what was lost and the
    resume command; no infrastructure row stored; after a restart on the same address,
    ``--resume`` gives the campaign of an uninterrupted run."""
    study = tmp_path / "study.toml"
    study.write_text(tiny_study_text(initial=6, iterations=6, seed=4))
    whole, out = tmp_path / "whole", tmp_path / "run"
    cli = [sys.executable, "-m", "hypate.scaling.cli.main", "run", str(study), "-q"]
    subprocess.run([*cli, "--out", str(whole)], check=True, capture_output=True, timeout=600)
    flags = ["--scheduler", cluster.address, "--cluster-timeout", "5"]
    proc = subprocess.Popen([*cli, "--out", str(out), *flags], stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True, env=cluster.env)
    deadline = time.monotonic() + 300
    while stored_evaluations(out / "evaluations.sqlite") < 4 and proc.poll() is None \
            and time.monotonic() < deadline:
        time.sleep(0.02)
    cluster.kill("scheduler")
    err = proc.communicate(timeout=120)[1]
    assert proc.returncode == 3, err
    lines = [ln for ln in err.splitlines() if ln.startswith("hypate: ")]
    assert "Traceback" not in err and len(lines) == 1
    assert lines[0].startswith("hypate: error: lost the Dask scheduler")
    assert "--resume" in lines[0]
    rows = campaign(out / "evaluations.sqlite")
    assert {row[4] for row in rows} <= {"ok", "error", "invalid", "timeout"}
    assert not any("Cancelled" in msg or "Closed" in msg
                   for msg in _messages(out / "evaluations.sqlite"))
    cluster.stop()
    cluster.start()
    subprocess.run([*cli, "--out", str(out), "--resume", *flags], check=True,
                   capture_output=True, timeout=600, env=cluster.env)
    resumed, uninterrupted = (sorted(campaign(d / "evaluations.sqlite")) for d in (out, whole))
    assert resumed == uninterrupted


def _messages(store: Path) -> list[str]:
    with EvaluationStore(store, read_only=True) as s:
        return [r.message for r in s.load()]


@needs_dask
def test_last_worker_killed_ends_the_run_within_lost_after(tmp_path: Path,
                                                           cluster: _Cluster) -> None:
    lost_after = 5.0
    store = tmp_path / "dask.sqlite"
    executor, close = _connect(cluster.address, lost_after)
    when, callback = _kill_at(2, lambda: cluster.kill("worker"))
    try:
        with pytest.raises(InfrastructureError, match="every worker") as err:
            BayesianOptimizer(problem(sleep=0.5), executor=executor, store=store,
                              callback=callback, n_init=6, n_iter=0, **FAST).run()
        waited = time.monotonic() - when[0]
    finally:
        close()
    # the loss is declared after lost_after seconds without a worker, not much later
    assert lost_after <= waited < lost_after + 2 * HEALTH_INTERVAL + 2.0
    assert err.value.unfinished >= 1
    assert {row[4] for row in campaign(store)} == {"ok"}


@needs_dask
def test_local_cluster_gives_the_serial_campaign(tmp_path: Path) -> None:
    # time limits (forked children inside Dask workers), exceptions and NaN included
    faults = dict(slow_above=0.85, slow=60.0, raise_below=0.1, nan_above=0.9)
    kw = dict(FAST, n_init=8, n_iter=2, batch_size=2, timeout=2.0)
    BayesianOptimizer(problem(**faults), store=tmp_path / "serial.sqlite", **kw).run()
    executor, close = make_executor(1, "local:2")
    try:
        BayesianOptimizer(problem(**faults), executor=executor,
                          store=tmp_path / "local.sqlite", **kw).run()
    finally:
        close()
    serial = campaign(tmp_path / "serial.sqlite")
    assert campaign(tmp_path / "local.sqlite") == serial
    assert {"ok", "timeout"} <= {row[4] for row in serial}
