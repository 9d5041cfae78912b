"""solvers/numerics/files.py: outputs are written whole, never through a link, and an
unchanged file is left alone."""
from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypate.solvers.numerics.files import (
    LinkRefused,
    atomic_file,
    ensure_directory,
    write_bytes,
    write_text,
)


def test_a_link_at_the_file_is_refused_and_its_target_keeps_its_bytes(tmp_path: Path) -> None:
    victim = tmp_path / "victim"
    victim.write_text("precious")
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "report.html").symlink_to(victim)
    with pytest.raises(LinkRefused, match="report.html is a symbolic link"):
        write_text(tmp_path / "out" / "report.html", "<html>")
    assert victim.read_text() == "precious"


def test_a_linked_folder_is_refused_and_nothing_lands_in_it(tmp_path: Path) -> None:
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (tmp_path / "figures").symlink_to(elsewhere)
    with pytest.raises(LinkRefused):
        ensure_directory(tmp_path / "figures")
    with pytest.raises(LinkRefused):
        write_bytes(tmp_path / "figures" / "a.png", b"png")
    assert list(elsewhere.iterdir()) == []


def test_a_dangling_link_is_refused_too(tmp_path: Path) -> None:
    (tmp_path / "pareto.csv").symlink_to(tmp_path / "nowhere")
    with pytest.raises(LinkRefused):
        write_text(tmp_path / "pareto.csv", "a,b\n")
    assert not (tmp_path / "nowhere").exists()


def test_a_failed_write_leaves_the_old_file_and_no_temporary(tmp_path: Path) -> None:
    path = tmp_path / "design_point.json"
    path.write_text("old")
    with pytest.raises(RuntimeError), atomic_file(path, "w") as handle:
        handle.write("half")
        raise RuntimeError("interrupted")
    assert path.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["design_point.json"]


def test_an_unchanged_file_keeps_its_mtime_and_a_new_one_gets_the_umask_mode(
        tmp_path: Path) -> None:
    path = tmp_path / "evaluations.csv"
    write_text(path, "a\n1\n")
    os.utime(path, ns=(1_000_000_000, 1_000_000_000))
    write_text(path, "a\n1\n")
    assert path.stat().st_mtime_ns == 1_000_000_000
    write_text(path, "a\n2\n")
    assert path.read_text() == "a\n2\n" and path.stat().st_mtime_ns != 1_000_000_000
    mask = os.umask(0)
    os.umask(mask)
    assert path.stat().st_mode & 0o777 == 0o666 & ~mask  # as open() would make it


def test_a_write_error_names_the_file_not_the_temporary(tmp_path: Path) -> None:
    missing = tmp_path / "no-such-folder" / "report.html"
    with pytest.raises(FileNotFoundError) as info:
        write_text(missing, "x")
    assert info.value.filename == str(missing)
