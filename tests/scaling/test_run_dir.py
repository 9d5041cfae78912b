"""Default run directories of `hypate run` (a repeated run never refuses to start)."""
from __future__ import annotations

from pathlib import Path

from hypate.scaling.cli.run import default_run_dir


def test_default_run_dir_numbers_new_runs_and_resumes_the_latest(tmp_path: Path) -> None:
    root = tmp_path / "runs"
    assert default_run_dir("q", False, root) == root / "q"
    (root / "q").mkdir(parents=True)
    assert default_run_dir("q", False, root) == root / "q-2"
    (root / "q-2").mkdir()
    assert default_run_dir("q", False, root) == root / "q-3"
    assert default_run_dir("q", True, root) == root / "q-2"
    assert default_run_dir("other", True, root) == root / "other"
