"""A machine you cannot exhaust (issue 43, items 4 and 5): a mesh whose simulations would
not fit is refused before the first simulation, naming ``[simulation] mesh`` and the
estimate; a disk that fills while the evaluations are stored ends the run with one line and
exit code 4, the store stays consistent, and the resume stores the uninterrupted campaign.

The full disk is real: a file-size limit (``RLIMIT_FSIZE``, set on the running process with
``prlimit``) makes the store's next write fail with ``EFBIG`` -- the same failed write as a
full disk to SQLite, which reports a disk I/O error -- and, where this machine lets the test
mount one, a small tmpfs filled up gives the store ``ENOSPC`` itself.
"""
from __future__ import annotations

import os
import resource
import shutil
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import stored_campaign, stored_evaluations, tiny_study_text
from hypate.scaling.cli.main import main

#: 7 + 12 evaluations of about 0.15 s (as tests/reliability/test_campaign.py).
STUDY = tiny_study_text(name="disk", mesh=2, steps=4, initial=6, iterations=12, seed=5)
#: Address space of the child that is refused a 100 x 100 mesh (bytes): the issue's limit.
ADDRESS_LIMIT = 6 * 2**30


def _cli(*args: str) -> list[str]:
    return [sys.executable, "-m", "hypate.scaling.cli.main", "run", *args]


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[tuple]]:
    folder = tmp_path_factory.mktemp("disk")
    study = folder / "disk.toml"
    study.write_text(STUDY)
    assert main(["run", str(study), "--out", str(folder / "whole"), "-q"]) == 0
    return study, stored_campaign(folder / "whole")


def _one_line(err: str) -> str:
    assert "Traceback" not in err, err
    lines = [ln for ln in err.splitlines() if ln.startswith("hypate: ")]
    assert len(lines) == 1, err
    return lines[0]


def test_a_mesh_beyond_the_memory_is_refused_before_any_simulation(tmp_path: Path) -> None:
    study = tmp_path / "big.toml"
    study.write_text(tiny_study_text(name="big", mesh=100))
    out = tmp_path / "run"

    def limited() -> None:  # the address-space limit
        resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_LIMIT, ADDRESS_LIMIT))

    done = subprocess.run(_cli(str(study), "--out", str(out), "-q"), capture_output=True,
                          text=True, timeout=300, preexec_fn=limited)
    assert done.returncode == 2, done.stderr
    line = _one_line(done.stderr)
    assert line.startswith("hypate: error: simulation.mesh: a 100x100 mesh needs about ")
    assert " GB " in line and "--force" in line
    assert not out.exists()  # refused before anything was written or simulated


def test_a_full_disk_while_evaluations_are_stored_is_one_line_and_resumes(
        tmp_path: Path, reference: tuple[Path, list[tuple]]) -> None:
    study, whole = reference
    out = tmp_path / "run"
    store = out / "evaluations.sqlite"
    proc = subprocess.Popen(_cli(str(study), "--out", str(out), "-q"),
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    while stored_evaluations(store) < 5 and proc.poll() is None:
        time.sleep(0.01)
    assert proc.poll() is None, "the run ended before the disk filled"
    wal = store.with_name(store.name + "-wal")
    # no file of the run may grow from here on: the store's next commit finds no room
    size = max(wal.stat().st_size, store.stat().st_size)
    resource.prlimit(proc.pid, resource.RLIMIT_FSIZE, (size, resource.RLIM_INFINITY))
    err = proc.communicate(timeout=300)[1]
    assert proc.returncode == 4, err
    line = _one_line(err)
    assert line.startswith(f"hypate: error: I/O error writing {store} ("), line
    assert line.endswith(f"free space and continue with `hypate run {study} --out {out} "
                         "--resume`")
    stored = stored_evaluations(store)
    assert 5 <= stored < len(whole)  # the rows committed before are kept, readable
    done = subprocess.run(_cli(str(study), "--out", str(out), "-q", "--resume"),
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert stored_campaign(out) == whole


def _rows(store: Path) -> int:
    """Rows in a store, read through a connection that is closed at once (an open file on
    the tmpfs would keep it from being unmounted)."""
    if not store.exists():
        return 0
    con = sqlite3.connect(f"file:{store}?mode=ro", uri=True, timeout=1.0)
    try:
        return int(con.execute("SELECT COUNT(*) FROM evaluations").fetchone()[0])
    except sqlite3.Error:
        return 0
    finally:
        con.close()


def _mount_tmpfs(where: Path, size: str) -> bool:
    if os.geteuid() != 0 or shutil.which("mount") is None:
        return False
    where.mkdir()
    return subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(where)],
                          capture_output=True).returncode == 0


def test_a_really_full_disk_says_disk_full(tmp_path: Path,
                                           reference: tuple[Path, list[tuple]]) -> None:
    """On a tmpfs of 4 MB: a filler takes what the run leaves once 5 rows are stored."""
    study, whole = reference
    disk = tmp_path / "disk"
    if not _mount_tmpfs(disk, "4m"):
        pytest.skip("cannot mount a tmpfs here (needs root and mount permission)")
    proc = None
    try:
        out = disk / "run"
        store = out / "evaluations.sqlite"
        proc = subprocess.Popen(_cli(str(study), "--out", str(out), "-q"),
                                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        while _rows(store) < 5 and proc.poll() is None:
            time.sleep(0.01)
        assert proc.poll() is None, "the run ended before the disk filled"
        filler = disk / "filler"
        fd = os.open(filler, os.O_WRONLY | os.O_CREAT)
        try:  # every free block
            while os.write(fd, b"\0" * 4096):
                pass
        except OSError:
            pass
        finally:
            os.close(fd)
        err = proc.communicate(timeout=300)[1]
        assert proc.returncode == 4, err
        line = _one_line(err)
        assert line.startswith(f"hypate: error: disk full writing {store}"), line
        assert line.endswith(f"free space and continue with `hypate run {study} --out {out} "
                             "--resume`")
        filler.unlink()  # free space, and continue
        done = subprocess.run(_cli(str(study), "--out", str(out), "-q", "--resume"),
                              capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stderr
        assert stored_campaign(out) == whole
        assert _rows(store) == len(whole)
    finally:
        if proc is not None and proc.poll() is None:
            proc.kill()
            proc.wait()
        if subprocess.run(["umount", str(disk)], capture_output=True).returncode != 0:
            subprocess.run(["umount", "-l", str(disk)], check=True)  # detached once unused
