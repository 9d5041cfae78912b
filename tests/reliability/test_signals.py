"""Signals (issue 43): SIGTERM is handled as Ctrl-C; a pool's workers leave the terminal's
Ctrl-C and a kill of the process group to hypate, which ends them, so stderr holds only
hypate's one line and no process is left; a Ctrl-C while hypate starts is one line; and a
resume after any of them stores the uninterrupted campaign.

Each run is a subprocess in its own session (its own process group, as a terminal's job),
signalled through its group like a terminal or ``kill -- -PGID``.
"""
from __future__ import annotations

import argparse
import os
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import stored_campaign, stored_evaluations, tiny_study_text
from hypate.scaling.cli.main import main
from hypate.scaling.cli.run import resume_command

#: 7 + 12 evaluations of about 0.15 s (as tests/reliability/test_campaign.py).
STUDY = tiny_study_text(name="signals", mesh=2, steps=4, initial=6, iterations=12, seed=5)


def _cli(*args: str) -> list[str]:
    return [sys.executable, "-m", "hypate.scaling.cli.entry", "run", *args]


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[tuple]]:
    folder = tmp_path_factory.mktemp("signals")
    study = folder / "signals.toml"
    study.write_text(STUDY)
    assert main(["run", str(study), "--out", str(folder / "whole"), "-q"]) == 0
    return study, stored_campaign(folder / "whole")


def _group_is_gone(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return True
    return False


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_signal_to_the_group_of_a_pool_run_is_one_line_and_resumes(
        tmp_path: Path, reference: tuple[Path, list[tuple]], sig: int) -> None:
    study, whole = reference
    out = tmp_path / "run"
    proc = subprocess.Popen(_cli(str(study), "--out", str(out), "-q", "--workers", "2"),
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    # past the initial batch, one design per iteration: one worker waits for work (a
    # worker interrupted while it waits printed a traceback), the other evaluates
    while stored_evaluations(out / "evaluations.sqlite") < 9 and proc.poll() is None:
        time.sleep(0.01)
    assert proc.poll() is None, "the run ended before the signal"
    os.killpg(proc.pid, sig)
    err = proc.communicate(timeout=120)[1]
    assert proc.returncode == 128 + sig, err
    n = stored_evaluations(out / "evaluations.sqlite")
    word = "interrupted" if sig == signal.SIGINT else "terminated (SIGTERM)"
    assert err.splitlines() == [f"hypate: {word} after {n} evaluations; continue with "
                                f"`hypate run {study} --out {out} --resume`"], err
    assert _group_is_gone(proc.pid)  # the workers ended with the run
    subprocess.run(_cli(str(study), "--out", str(out), "-q", "--resume"), check=True,
                   capture_output=True, timeout=600)
    assert stored_campaign(out) == whole


def _catches_sigterm(pid: int) -> bool:
    """Whether the process has a handler for SIGTERM (``SigCgt``, Linux): the console
    script sets one first thing, before it loads the command line."""
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return False
    mask = next(int(line.split()[1], 16) for line in status.splitlines()
                if line.startswith("SigCgt:"))
    return bool(mask & (1 << (signal.SIGTERM - 1)))


@pytest.mark.skipif(not Path("/proc/self/status").is_file(), reason="needs Linux /proc")
def test_ctrl_c_while_hypate_starts_is_one_line(tmp_path: Path,
                                                reference: tuple[Path, list[tuple]]) -> None:
    study, _ = reference
    script = Path(sys.executable).with_name("hypate")
    if not script.is_file():
        pytest.skip("no hypate console script beside this Python")
    out = tmp_path / "run"
    proc = subprocess.Popen([str(script), "run", str(study), "--out", str(out), "-q"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    while not _catches_sigterm(proc.pid) and proc.poll() is None:
        time.sleep(0.002)
    assert proc.poll() is None, "hypate ended before it set its start-up handler"
    os.killpg(proc.pid, signal.SIGINT)  # now it loads numpy, scipy, pandas ... (seconds)
    err = proc.communicate(timeout=60)[1]
    assert proc.returncode == 130, err
    assert err.splitlines() == ["hypate: interrupted during start-up; nothing was written"]
    assert not out.exists()


def test_the_printed_resume_command_is_shell_quoted(tmp_path: Path) -> None:
    out = tmp_path / "it's $HOME; rm -rf x"
    out.mkdir()
    (out / "evaluations.sqlite").write_bytes(b"")
    args = argparse.Namespace(study="my study.toml")
    words = shlex.split(resume_command(args, out))
    assert words == ["hypate", "run", "my study.toml", "--out", str(out), "--resume"]
