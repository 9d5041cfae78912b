"""A run directory you can receive: planted links are refused before anything is written,
edited results are refused naming the first bad row, a run killed while it wrote its outputs
is completed by --resume, and commands that only read a finished run leave every byte and
mtime of it as it was (issue 43, items 1-3 and the readers); and a resumed run's
``wall_seconds`` counts every process that ran it.

Every run here is the tiny study of conftest.py (a few seconds); the finished run is made
once per module and copied (links kept, as a tar keeps them) by each test.
"""
from __future__ import annotations

import contextlib
import dataclasses
import errno
import json
import os
import shutil
import signal
import sqlite3
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pandas as pd
import pytest
from conftest import PREDICTION_RUN, foreground_sigint, kill_after, tiny_study_text
from hypate.scaling.cli.main import main
from hypate.scaling.engine.store import EvaluationStore
from hypate.scaling.workflow.vocabulary.study import load_study
from hypate.solvers.coupling.response import Response

#: 3 initial + 1 iteration + the classical seed: 5 evaluations of 20 steps.
STUDY = tiny_study_text(name="received", **PREDICTION_RUN)


@contextlib.contextmanager
def _sql(store: Path) -> Iterator[sqlite3.Connection]:
    """A connection that commits and closes (SQLite checkpoints its WAL then, not later
    while the test looks at the directory)."""
    con = sqlite3.connect(store)
    try:
        with con:
            yield con
    finally:
        con.close()


def _cli(*args: str) -> list[str]:
    return [sys.executable, "-m", "hypate.scaling.cli.main", *args]


def _snapshot(folder: Path) -> dict[str, tuple[bytes, int]]:
    """Every file below ``folder`` (links as links): its bytes and mtime (ns)."""
    out = {}
    for p in sorted(folder.rglob("*")):
        if p.is_symlink():
            out[str(p.relative_to(folder))] = (os.readlink(p).encode(), 0)
        elif p.is_file():
            out[str(p.relative_to(folder))] = (p.read_bytes(), p.stat().st_mtime_ns)
    return out


def _one_error_line(err: str) -> str:
    assert "Traceback" not in err, err
    lines = [ln for ln in err.splitlines() if ln.startswith("hypate: error:")]
    assert len(lines) == 1, err
    return lines[0]


def _rows(run: Path) -> pd.DataFrame:
    """evaluations.csv without the wall-time column."""
    return pd.read_csv(run / "evaluations.csv").drop(columns=["seconds"])


@pytest.fixture(scope="module")
def finished(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """(study file, a finished run directory) -- copy the run before changing it."""
    root = tmp_path_factory.mktemp("received")
    study = root / "received.toml"
    study.write_text(STUDY)
    assert main(["run", str(study), "--out", str(root / "ref"), "-q"]) == 0
    return study, root / "ref"


def _copy(run: Path, to: Path) -> Path:
    shutil.copytree(run, to, symlinks=True)
    return to


# -- 1. planted links --------------------------------------------------------------------
def test_report_refuses_a_planted_report_link_and_a_linked_figures_folder(
        tmp_path: Path, finished: tuple[Path, Path],
        capsys: pytest.CaptureFixture[str]) -> None:
    _, ref = finished
    recv = _copy(ref, tmp_path / "recv")
    shutil.rmtree(recv / "figures")
    (recv / "report.html").unlink()
    victim, vdir = tmp_path / "victim", tmp_path / "vdir"
    victim.write_text("precious\n")
    vdir.mkdir()
    (recv / "report.html.tmp").symlink_to(victim)
    (recv / "figures").symlink_to(vdir)
    before = _snapshot(recv)
    assert main(["report", str(recv)]) == 2
    line = _one_error_line(capsys.readouterr().err)
    assert "is a symbolic link" in line and ("figures" in line or "report.html.tmp" in line)
    assert victim.read_text() == "precious\n" and list(vdir.iterdir()) == []
    assert _snapshot(recv) == before  # nothing written


def test_a_linked_figure_is_refused(tmp_path: Path, finished: tuple[Path, Path],
                                    capsys: pytest.CaptureFixture[str]) -> None:
    _, ref = finished
    recv = _copy(ref, tmp_path / "recv")
    victim = tmp_path / "victim.png"
    victim.write_bytes(b"mine")
    (recv / "figures" / "pareto_front.png").unlink()
    (recv / "figures" / "pareto_front.png").symlink_to(victim)
    assert main(["report", str(recv)]) == 2
    assert "figures/pareto_front.png is a symbolic link" in _one_error_line(
        capsys.readouterr().err)
    assert victim.read_bytes() == b"mine"


def test_resume_refuses_a_linked_run_lock(tmp_path: Path, finished: tuple[Path, Path],
                                          capsys: pytest.CaptureFixture[str]) -> None:
    study, ref = finished
    recv = _copy(ref, tmp_path / "recv")
    (recv / "report.html").unlink()  # an unfinished final phase: the resume would write
    victim = tmp_path / "victim2"
    victim.write_text("precious\n")
    (recv / "run.lock").unlink()
    (recv / "run.lock").symlink_to(victim)
    before = _snapshot(recv)
    assert main(["run", str(study), "--out", str(recv), "--resume", "-q"]) == 2
    assert "run.lock is a symbolic link" in _one_error_line(capsys.readouterr().err)
    assert victim.read_text() == "precious\n"
    assert _snapshot(recv) == before


def test_a_linked_store_companion_is_refused(tmp_path: Path, finished: tuple[Path, Path],
                                             capsys: pytest.CaptureFixture[str]) -> None:
    study, ref = finished
    recv = _copy(ref, tmp_path / "recv")
    (recv / "design_point.json").unlink()
    victim = tmp_path / "victim3"
    victim.write_text("precious\n")
    for name in ("evaluations.sqlite-wal", "evaluations.sqlite-shm"):
        (recv / name).unlink(missing_ok=True)
    (recv / "evaluations.sqlite-wal").symlink_to(victim)
    assert main(["run", str(study), "--out", str(recv), "--resume", "-q"]) == 2
    assert "evaluations.sqlite-wal is a symbolic link" in _one_error_line(
        capsys.readouterr().err)
    assert victim.read_text() == "precious\n"


def test_a_dangling_link_as_out_is_one_line(tmp_path: Path, finished: tuple[Path, Path],
                                            capsys: pytest.CaptureFixture[str]) -> None:
    study, _ = finished
    (tmp_path / "out").symlink_to(tmp_path / "gone")
    assert main(["run", str(study), "--out", str(tmp_path / "out"), "-q"]) == 2
    assert "--out:" in _one_error_line(capsys.readouterr().err)
    assert not (tmp_path / "gone").exists()


# -- 2. tamper evidence -------------------------------------------------------------------
def _edit_row_and_cut(run: Path, row: int) -> None:
    """The issue's edit: one row's objectives made up, the later rows and the outputs
    deleted (the id column is 1-based in SQLite, evaluation ids are 0-based)."""
    with _sql(run / "evaluations.sqlite") as con:
        con.execute("UPDATE evaluations SET F = '[0.001, 0.002]' WHERE id = ?", (row + 1,))
        con.execute("DELETE FROM evaluations WHERE id > ?", (row + 1,))
    for name in ("design_point.json", "evaluations.csv", "pareto.csv", "report.html"):
        (run / name).unlink()


def test_an_edited_row_is_refused_by_resume_and_report_naming_it(
        tmp_path: Path, finished: tuple[Path, Path],
        capsys: pytest.CaptureFixture[str]) -> None:
    study, ref = finished
    recv = _copy(ref, tmp_path / "recv")
    _edit_row_and_cut(recv, 3)
    before = _snapshot(recv)
    assert main(["run", str(study), "--out", str(recv), "--resume", "-q"]) == 2
    assert "evaluation 3 does not match its digest" in _one_error_line(
        capsys.readouterr().err)
    assert main(["report", str(recv)]) == 2
    assert "evaluation 3 does not match its digest" in _one_error_line(
        capsys.readouterr().err)
    assert _snapshot(recv) == before


def test_deleted_last_rows_and_swapped_rows_are_refused(tmp_path: Path,
                                                        finished: tuple[Path, Path]) -> None:
    _, ref = finished
    cut = _copy(ref, tmp_path / "cut")
    with _sql(cut / "evaluations.sqlite") as con:
        con.execute("DELETE FROM evaluations WHERE id > 3")
    with pytest.raises(ValueError, match="evaluation 3 and the 1 after it are missing"):
        EvaluationStore(cut / "evaluations.sqlite", read_only=True)
    swapped = _copy(ref, tmp_path / "swapped")
    with _sql(swapped / "evaluations.sqlite") as con:
        a, b = (con.execute("SELECT x, F FROM evaluations WHERE id = ?", (i,)).fetchone()
                for i in (2, 3))
        con.execute("UPDATE evaluations SET x = ?, F = ? WHERE id = 2", b)
        con.execute("UPDATE evaluations SET x = ?, F = ? WHERE id = 3", a)
    with pytest.raises(ValueError, match="evaluation 1 does not match its digest"):
        EvaluationStore(swapped / "evaluations.sqlite", read_only=True)


def test_a_store_of_an_older_hypate_is_read_with_a_warning(
        tmp_path: Path, finished: tuple[Path, Path],
        capsys: pytest.CaptureFixture[str]) -> None:
    study, ref = finished
    old = _copy(ref, tmp_path / "old")
    with _sql(old / "evaluations.sqlite") as con:  # as hypate wrote it before
        con.execute("ALTER TABLE evaluations DROP COLUMN digest")
        con.execute("DELETE FROM meta WHERE key IN ('chain', 'outputs', 'sessions')")
    assert main(["report", str(old)]) == 0
    err = capsys.readouterr().err
    warnings = [ln for ln in err.splitlines() if ln.startswith("hypate: warning:")]
    assert len(warnings) == 1 and "written by an older hypate: 5 of its evaluations carry " \
        "no digest" in warnings[0], err
    (old / "report.html").unlink()  # and it resumes: the final phase completes
    assert main(["run", str(study), "--out", str(old), "--resume", "-q"]) == 0
    assert (old / "report.html").is_file()
    pd.testing.assert_frame_equal(_rows(old), _rows(ref))


# -- 3. the final phase resumes -------------------------------------------------------------
def test_resume_writes_the_outputs_a_run_killed_in_its_final_phase_lacks(
        tmp_path: Path, finished: tuple[Path, Path]) -> None:
    study, ref = finished
    recv = _copy(ref, tmp_path / "recv")
    for name in ("report.html", "pareto.csv", "evaluations.csv"):
        (recv / name).unlink()
    shutil.rmtree(recv / "figures")
    assert main(["run", str(study), "--out", str(recv), "--resume", "-q"]) == 0
    assert (recv / "report.html").is_file() and any((recv / "figures").glob("*.png"))
    pd.testing.assert_frame_equal(_rows(recv), _rows(ref))
    assert (recv / "pareto.csv").read_bytes() == (ref / "pareto.csv").read_bytes()
    # complete now: a second resume has nothing to do and changes nothing
    before = _snapshot(recv)
    assert main(["run", str(study), "--out", str(recv), "--resume", "-q"]) == 0
    assert _snapshot(recv) == before


def test_an_edited_output_is_not_complete(tmp_path: Path, finished: tuple[Path, Path],
                                          capsys: pytest.CaptureFixture[str]) -> None:
    study, ref = finished
    recv = _copy(ref, tmp_path / "recv")
    point = recv / "design_point.json"
    point.write_text(point.read_text().replace('"J_u": 0.', '"J_u": 0.0000'))
    assert main(["laws", str(recv)]) == 2  # a reader refuses it, naming the file
    assert "design_point.json (changed since the run wrote it)" in _one_error_line(
        capsys.readouterr().err)
    assert main(["run", str(study), "--out", str(recv), "--resume", "-q"]) == 0

    def fields(path: Path) -> dict:
        data = json.loads(path.read_text())
        data["statistics"].pop("wall_seconds")  # the resume's own seconds added
        return data

    assert fields(point) == fields(ref / "design_point.json")


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGINT, signal.SIGTERM],
                         ids=["SIGKILL", "SIGINT", "SIGTERM"])
def test_a_signal_during_the_report_then_resume_gives_a_complete_run(
        tmp_path: Path, finished: tuple[Path, Path], sig: int) -> None:
    study, ref = finished
    # the report made to take 5 s longer (a sitecustomize of the subprocess wraps
    # write_report): the signal lands inside it on a busy machine too, where the figures
    # alone can be done before the poll below notices design_point.json
    site = tmp_path / "site"
    site.mkdir()
    (site / "sitecustomize.py").write_text(
        "import time\n"
        "import hypate.scaling.report.html as html\n"
        "_write = html.write_report\n"
        "def _slow(*args, **kwargs):\n"
        "    time.sleep(5.0)\n"
        "    return _write(*args, **kwargs)\n"
        "html.write_report = _slow\n")
    env = {**os.environ,
           "PYTHONPATH": os.pathsep.join(filter(None, [str(site),
                                                       os.environ.get("PYTHONPATH")]))}
    for attempt in range(3):
        out = tmp_path / f"run{attempt}"
        proc = subprocess.Popen(_cli("run", str(study), "--out", str(out), "-q"),
                                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                text=True, start_new_session=True, env=env,
                                preexec_fn=foreground_sigint)
        # design_point.json is the last output before the report
        while not (out / "design_point.json").exists() and proc.poll() is None:
            time.sleep(0.005)
        os.killpg(proc.pid, sig)
        err = proc.communicate(timeout=120)[1]
        if not (out / "report.html").exists():
            break  # stopped in its final phase, as wanted
    assert not (out / "report.html").exists(), "the report was written before the signal"
    if sig != signal.SIGKILL:
        assert proc.returncode == 128 + sig and "Traceback" not in err, err
        assert err.strip().splitlines()[-1].endswith(f"--out {out} --resume`"), err
    done = subprocess.run(_cli("run", str(study), "--out", str(out), "--resume", "-q"),
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert (out / "report.html").is_file()
    pd.testing.assert_frame_equal(_rows(out), _rows(ref))


def test_a_full_disk_during_the_report_is_one_line_and_resumes(
        tmp_path: Path, finished: tuple[Path, Path], monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    """The report's first figure hits a full disk (ENOSPC injected at the write)."""

    import hypate.scaling.report.figures as figures

    study, ref = finished
    out = tmp_path / "run"

    def full(path: Path, data: bytes) -> Path:
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    monkeypatch.setattr(figures, "write_bytes", full)
    assert main(["run", str(study), "--out", str(out), "-q"]) == 4
    line = _one_error_line(capsys.readouterr().err)
    assert line.startswith(f"hypate: error: disk full writing {out}/figures/")
    assert line.endswith(f"free space and continue with `hypate run {study} --out {out} "
                         "--resume`")
    monkeypatch.undo()
    assert main(["run", str(study), "--out", str(out), "--resume", "-q"]) == 0
    assert (out / "report.html").is_file()
    pd.testing.assert_frame_equal(_rows(out), _rows(ref))


# -- readers leave a finished run as it was -------------------------------------------------
def test_report_laws_and_predict_change_no_byte_or_mtime_of_a_finished_run(
        tmp_path: Path, finished: tuple[Path, Path], capsys: pytest.CaptureFixture[str]
        ) -> None:
    _, recv = finished  # in place: the report names its directory
    model = Response.load(recv / "design_point.npz")  # the model test, as measured
    measured = tmp_path / "measured.csv"
    pd.DataFrame({"time [s]": model.times, "center_deflection [m]": model.center_deflection,
                  "mean_temperature [K]": model.mean_temperature}).to_csv(measured,
                                                                         index=False)
    before = _snapshot(recv)
    assert main(["report", str(recv)]) == 0
    main(["laws", str(recv)])  # one run is no sweep: whatever it says, it only reads
    assert main(["predict", str(recv), "--measured", str(measured),
                 "--out", str(tmp_path / "prediction")]) == 0
    capsys.readouterr()
    assert _snapshot(recv) == before


def test_report_of_a_zero_byte_store_reads_the_csv_and_leaves_the_store(
        tmp_path: Path, finished: tuple[Path, Path],
        capsys: pytest.CaptureFixture[str]) -> None:
    _, ref = finished
    recv = _copy(ref, tmp_path / "recv")
    (recv / "evaluations.sqlite").write_bytes(b"")
    for name in ("evaluations.sqlite-wal", "evaluations.sqlite-shm", "design_point.json"):
        (recv / name).unlink(missing_ok=True)
    assert main(["report", str(recv)]) == 0
    assert (recv / "evaluations.sqlite").stat().st_size == 0  # not made an empty store
    page = (recv / "report.html").read_text()
    assert "no successful evaluation" not in page.lower()
    assert not (recv / "evaluations.sqlite-wal").exists()


@contextlib.contextmanager
def _read_only(recv: Path, ro: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """``recv`` where no file or folder can be made: its permission bits for a user; for
    root (who writes through them) a read-only bind mount at ``ro``, or -- where this
    machine refuses root a mount -- ``EROFS`` from every ``os.open`` / ``os.mkdir`` that
    would create or write inside it (the calls under ``tempfile.mkstemp`` and
    ``Path.mkdir``), so the report meets the same error either way."""
    if os.geteuid() != 0:
        recv.chmod(0o555)
        try:
            yield recv
        finally:
            recv.chmod(0o755)
        return
    ro.mkdir()
    try:
        made = subprocess.run(["mount", "--bind", "-o", "ro", str(recv), str(ro)],
                              capture_output=True)
    except FileNotFoundError:  # no mount command at all
        made = None
    if made is not None and made.returncode == 0:
        try:
            yield ro
        finally:
            subprocess.run(["umount", str(ro)], check=True)
        return

    inside = recv.resolve()
    writes = os.O_WRONLY | os.O_RDWR | os.O_CREAT

    def refused(path: object) -> OSError | None:
        p = Path(os.fsdecode(path)).resolve()  # type: ignore[arg-type]
        if p == inside or inside in p.parents:
            return OSError(errno.EROFS, os.strerror(errno.EROFS), str(p))
        return None

    real_open, real_mkdir = os.open, os.mkdir

    def open_(path, flags, *args, **kwargs):  # type: ignore[no-untyped-def]
        if flags & writes and (exc := refused(path)) is not None:
            raise exc
        return real_open(path, flags, *args, **kwargs)

    def mkdir_(path, *args, **kwargs):  # type: ignore[no-untyped-def]
        if (exc := refused(path)) is not None:
            raise exc
        return real_mkdir(path, *args, **kwargs)

    monkeypatch.setattr(os, "open", open_)
    monkeypatch.setattr(os, "mkdir", mkdir_)
    yield recv


def test_report_into_a_read_only_directory_is_one_line(
        tmp_path: Path, finished: tuple[Path, Path], monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    _, ref = finished
    recv = _copy(ref, tmp_path / "recv")
    (recv / "report.html").unlink()
    shutil.rmtree(recv / "figures")
    with _read_only(recv, tmp_path / "ro", monkeypatch) as target:
        code = main(["report", str(target)])
    assert code == 2
    line = _one_error_line(capsys.readouterr().err)
    assert ("Read-only file system" in line or "Permission denied" in line), line
    assert not (recv / "report.html").exists()
    # the figure whose file could not be written was closed (it leaked into later tests of
    # the same process once: tests/scaling/report/test_figures.py counts open figures)
    import matplotlib.pyplot as plt

    assert not plt.get_fignums()


def test_wall_seconds_sum_every_process_of_a_resumed_run(tmp_path: Path) -> None:
    study = tmp_path / "study.toml"
    study.write_text(tiny_study_text(mesh=2, steps=4, initial=6, iterations=12, seed=5))
    out = tmp_path / "run"
    cli = [sys.executable, "-m", "hypate.scaling.cli.main", "run", str(study), "--out",
           str(out), "-q"]
    proc = subprocess.Popen(cli, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    kill_after(proc, out / "evaluations.sqlite", 12)
    with EvaluationStore(out / "evaluations.sqlite", read_only=True) as store:
        first = len(store)
    subprocess.run([*cli, "--resume"], check=True, capture_output=True, timeout=600)
    with EvaluationStore(out / "evaluations.sqlite", read_only=True) as store:
        created = [r.created for r in store.load()]
    # each process's own stretch of evaluations, from its first row to its last
    spans = (created[first - 1] - created[0]) + (created[-1] - created[first])
    wall = json.loads((out / "design_point.json").read_text())["statistics"]["wall_seconds"]
    assert wall >= spans


@dataclasses.dataclass(frozen=True)
class _Tiny:
    """A stand-in for studies.scripts.ch9_runs.Optimization: a name and its study."""

    name: str
    path: Path

    def study(self):
        return load_study(self.path)


# The tiny first point has no feasible design (3 of its 4 evaluations fail on the 4-step
# mesh, the fourth is above its temperature limit), so the second point draws initial
# samples instead of recycling, with its documented warning: not this test's subject.
@pytest.mark.filterwarnings("ignore:sweep point xi_4. only 0 recycled:RuntimeWarning")
def test_reproduce_reads_a_finished_sweep_without_writing_into_it(tmp_path: Path) -> None:
    """``hypate reproduce``'s runner (studies/scripts/ch9_runs.run_directory) on a finished
    sweep: it is verified and read, not resumed (which rewrote sweep.json and sweep.csv)."""
    from hypate.studies.scripts.ch9_runs import run_directory

    study = tmp_path / "tiny_sweep.toml"
    study.write_text(tiny_study_text(name="tiny_sweep", xi=2.0, steps=4, initial=3,
                                     iterations=0, tail="[sweep]\nxi = [2, 4]\nrecycle = 2\n"
                                     "initial_samples = 1\niterations = 0\n"))
    opt = _Tiny("tiny_sweep", study)
    root = tmp_path / "runs"
    assert run_directory(opt, root) == root / "tiny_sweep"
    before = _snapshot(root)
    assert run_directory(opt, root) == root / "tiny_sweep"
    assert _snapshot(root) == before
    assert main(["laws", str(root / "tiny_sweep")]) == 0  # two points: a fit, only read
    assert _snapshot(root) == before


def test_reproduce_reads_a_finished_run_without_writing_into_it(
        finished: tuple[Path, Path], capsys: pytest.CaptureFixture[str]) -> None:
    """The same runner on a finished single-study run: verified and read in place."""
    from hypate.studies.scripts.ch9_runs import run_directory

    study, ref = finished
    before = _snapshot(ref)
    assert run_directory(_Tiny(ref.name, study), ref.parent, seed=3) == ref  # its seed
    assert _snapshot(ref) == before
