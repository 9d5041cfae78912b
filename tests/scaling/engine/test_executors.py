"""Executors and their failure semantics (scaling/engine/executors.py): address checks,
fault classification, forked evaluations with time limits, batches with re-submission.
The end-to-end fault injection is tests/reliability/test_faults.py."""
from __future__ import annotations

import contextlib
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
import warnings
from concurrent.futures import CancelledError, Future, ThreadPoolExecutor
from concurrent.futures.process import BrokenProcessPool

import pytest
from hypate.scaling.engine.child import call_in_child, die_with_parent
from hypate.scaling.engine.executors import (
    ResilientProcessPool,
    check_scheduler_address,
    make_executor,
    run_batch,
)
from hypate.scaling.engine.faults import (
    SOLO_DEATHS,
    ExecutorError,
    InfrastructureError,
    KilledItsWorker,
    fault_kind,
)


@pytest.mark.parametrize("address", ["tcp://127.0.0.1:8786", "tcp://node-3.cluster:1",
                                     "tls://[::1]:65535", " tcp://h:80 ", "local:1",
                                     "local:16"])
def test_scheduler_addresses_of_the_documented_forms_pass(address):
    assert check_scheduler_address(address) == address.strip()


@pytest.mark.parametrize("address", ["127.0.0.1:8786", "tcp://127.0.0.1", "tcp://:8786",
                                     "tcp://h:0", "tcp://h:99999", "tcp://h:port",
                                     "http://h:8786", "tcp://h:8786/x", "local:0", "local:",
                                     "local:-2", "local:2.5", "local", ""])
def test_other_scheduler_addresses_fail_before_connecting(address):
    with pytest.raises(ExecutorError, match="expected tcp://HOST:PORT or local:N") as err:
        check_scheduler_address(address)
    assert err.value.field == "scheduler"
    t0 = time.monotonic()
    with pytest.raises(ExecutorError):
        make_executor(1, address or "local", lost_after=60.0)
    assert time.monotonic() - t0 < 1.0  # refused by its form, nothing was reached for


def test_fault_kinds():
    assert fault_kind(BrokenProcessPool("a worker died")) == "worker"
    assert fault_kind(CancelledError()) == "connection"
    assert fault_kind(ConnectionResetError()) == "connection"
    assert fault_kind(RuntimeError("solver diverged")) is None
    assert fault_kind(ValueError()) is None
    distributed = pytest.importorskip("distributed")
    from distributed.client import ClosedClientError, FutureCancelledError
    assert fault_kind(distributed.KilledWorker("k", "w", 3)) == "worker"
    assert fault_kind(FutureCancelledError("k", "scheduler-connection-lost")) == "connection"
    assert fault_kind(ClosedClientError()) == "connection"


def test_infrastructure_error_is_one_line_saying_what_was_lost():
    err = InfrastructureError("the Dask scheduler at tcp://h:1 (no connection) for 60 s", 3)
    assert str(err) == ("lost the Dask scheduler at tcp://h:1 (no connection) for 60 s; 3 "
                        "unfinished evaluation(s) not stored, a resume evaluates them")
    assert (err.unfinished, isinstance(err, RuntimeError)) == (3, True)


def _warn_and_return():
    warnings.warn("clamped to the table", RuntimeWarning, stacklevel=1)
    return {"pid": os.getpid()}


def test_call_in_child_returns_the_value_and_reissues_warnings():
    with pytest.warns(RuntimeWarning, match="clamped to the table"):
        value = call_in_child(_warn_and_return, 10.0)
    assert value["pid"] != os.getpid()  # it ran elsewhere


def test_call_in_child_kills_the_work_at_its_limit(tmp_path):
    flag = tmp_path / "finished"

    def slow():
        time.sleep(5.0)
        flag.write_text("the work went on")

    t0 = time.monotonic()
    with pytest.raises(TimeoutError):
        call_in_child(slow, 0.5)
    assert 0.5 <= time.monotonic() - t0 < 2.0
    time.sleep(5.0)
    assert not flag.exists()


def test_call_in_child_blames_a_child_that_always_dies():
    with pytest.raises(KilledItsWorker, match=f"alone \\({SOLO_DEATHS} times; last: killed "
                                              "by signal SIGKILL\\)"):
        call_in_child(lambda: os.kill(os.getpid(), signal.SIGKILL), 10.0)


def test_die_with_parent_exits_when_the_parent_is_not_the_expected_one():
    pid = os.fork()
    if pid == 0:
        die_with_parent(os.getppid() + 10**6)  # not our parent: as if it had died
        os._exit(0)
    assert os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]) == 1


def _square(x):
    return x * x


class _Flaky(ThreadPoolExecutor):
    """Cancels the futures of its first ``n`` submissions (a lost connection)."""

    def __init__(self, n):
        super().__init__(2)
        self.n = n

    def submit(self, fn, *args):
        if self.n <= 0:
            return super().submit(fn, *args)
        self.n -= 1
        lost = Future()
        lost.set_exception(CancelledError())
        return lost


def test_run_batch_resubmits_lost_work_in_batch_order():
    failures = []
    with _Flaky(2) as ex:
        got = list(run_batch(ex, _square, [(k,) for k in range(4)],
                             on_failure=lambda m, s: failures.append(m)))
    assert got == [(0, 0), (1, 1), (2, 4), (3, 9)] and failures == []


def test_run_batch_gives_up_on_a_broken_foreign_pool():
    class Broken(ThreadPoolExecutor):
        def submit(self, fn, *args):
            raise BrokenProcessPool("gone")

    with Broken(1) as ex, pytest.raises(InfrastructureError, match="Broken") as err:
        list(run_batch(ex, _square, [(1,), (2,)], on_failure=lambda m, s: None))
    assert err.value.unfinished == 2


def _certificates(folder):
    """A CA and a certificate for 127.0.0.1 signed by it (openssl), as the README's TLS set-up."""
    def openssl(*args):
        subprocess.run(["openssl", *args], cwd=folder, check=True, capture_output=True)

    openssl("req", "-x509", "-nodes", "-newkey", "rsa:2048", "-days", "2", "-keyout",
            "ca-key.pem", "-out", "ca.pem", "-subj", "/CN=hypate-test-ca")
    openssl("req", "-nodes", "-newkey", "rsa:2048", "-keyout", "key.pem", "-out", "req.pem",
            "-subj", "/CN=127.0.0.1")
    (folder / "ext.cnf").write_text("subjectAltName=IP:127.0.0.1\n")
    openssl("x509", "-req", "-in", "req.pem", "-CA", "ca.pem", "-CAkey", "ca-key.pem",
            "-CAcreateserial", "-out", "cert.pem", "-days", "2", "-extfile", "ext.cnf")
    return folder / "ca.pem", folder / "cert.pem", folder / "key.pem"


def test_a_tls_scheduler_needs_the_clients_certificates(tmp_path):
    """The README's secured cluster: without client certificates in Dask's configuration a
    tls:// scheduler is a one-line ExecutorError; with them the client connects."""
    pytest.importorskip("distributed")
    dask = pytest.importorskip("dask")
    if shutil.which("openssl") is None:
        pytest.skip("needs the openssl command to make certificates")
    ca, cert, key = _certificates(tmp_path)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    scheduler = subprocess.Popen(
        [sys.executable, "-m", "distributed.cli.dask_scheduler", "--protocol", "tls",
         "--host", "127.0.0.1", "--port", str(port), "--no-dashboard", "--tls-ca-file",
         str(ca), "--tls-cert", str(cert), "--tls-key", str(key)],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    address = f"tls://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            with contextlib.suppress(OSError), socket.create_connection(("127.0.0.1", port), 1):
                break
            time.sleep(0.2)
        tls = {"distributed.comm.tls.ca-file": str(ca),
               "distributed.comm.tls.client.cert": str(cert),
               "distributed.comm.tls.client.key": str(key)}
        with dask.config.set(tls):
            executor, close = make_executor(1, address, lost_after=10.0)
            try:
                assert executor.client.scheduler_info()["address"] == address
            finally:
                close()
        with pytest.raises(ExecutorError, match="no TLS certificates configured"):
            make_executor(1, address, lost_after=10.0)
    finally:
        scheduler.kill()
        scheduler.wait()


# -- errors cross the pool as themselves; terminate ends running work -----------------------------
def _raise(exc: BaseException) -> None:
    raise exc


def test_the_projects_errors_cross_a_process_pool_as_themselves() -> None:
    # an exception whose __init__ takes its fields would not unpickle in the parent, and
    # concurrent.futures then breaks the whole pool (BrokenProcessPool) instead
    from hypate.scaling.engine.settings import SettingError
    from hypate.solvers.errors import InputError

    errors = [InputError("panel.h", "must be > 0"), ExecutorError("scheduler", "unreachable"),
              InfrastructureError("the pool", 2), KilledItsWorker(3, "SIGKILL"),
              SettingError("v", "a number >= 0", -1.0)]
    pool = ResilientProcessPool(1)
    try:
        for exc in errors:
            with pytest.raises(type(exc)) as caught:
                pool.submit(_raise, exc).result(timeout=60)
            assert str(caught.value) == str(exc) and vars(caught.value) == vars(exc)
        assert pool.restarts == 0
    finally:
        pool.shutdown()


def test_terminate_ends_a_running_job_at_once() -> None:
    pool = ResilientProcessPool(1, ignore_interrupt=True)
    running = pool.submit(time.sleep, 120.0)
    queued = pool.submit(time.sleep, 120.0)
    time.sleep(1.0)  # the first job has started
    start = time.monotonic()
    pool.terminate()
    assert time.monotonic() - start < 30.0  # not the 120 s of the job
    # neither job ever finishes: the queued one is cancelled, or fails with the running one
    # (concurrent.futures hands one call ahead to its queue, and marks it running)
    for job in (running, queued):
        assert job.cancelled() or job.exception(timeout=30) is not None
