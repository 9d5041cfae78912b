"""README.md "Quick tour" as a tested walkthrough.

Every line of the tour's ``bash`` block is a ``hypate`` command with its measured duration
in the comment (``~N s`` or ``~N min``; the first one counts). All lines are checked without
running them: argparse accepts them (the real parser), every repository path they name
exists, every output goes to its own folder under ``runs/``, and a line that reads a run
directory (``--resume``, ``--seed-from``) comes after the line that writes it. The lines
under :data:`FAST` seconds are then run, each as a subprocess in a fresh temporary folder
that holds only a link to the repository's ``studies/`` (so the README's repository-relative
paths resolve as from the root of a clone, and nothing is written into the checkout);
longer lines, and lines that read the output of a skipped one, are skipped with the reason.
"""
from __future__ import annotations

import re
import shlex
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest
from conftest import REPO
from hypate.scaling.cli.main import build_parser

README = REPO / "README.md"
#: Lines that take less than this (s) are run.
FAST = 30.0
DURATION = re.compile(r"~(\d+(?:\.\d+)?) ?(s|min)\b")
#: Options whose value is a run directory or file the command writes.
WRITES = ("--out",)
#: Options whose value is a run directory an earlier line wrote.
READS = ("--seed-from",)


@dataclass(frozen=True)
class TourLine:
    """One command of the tour: its words, comment and measured duration (s)."""

    number: int
    text: str
    argv: tuple[str, ...]
    comment: str
    seconds: float | None

    def option(self, name: str) -> list[str]:
        """Values of every ``name VALUE`` in the command."""
        return [b for a, b in zip(self.argv, self.argv[1:]) if a == name]


def tour_lines() -> list[TourLine]:
    """The commands of the README's Quick tour, in order."""
    section = README.read_text().split("## Quick tour", 1)[1].split("\n## ", 1)[0]
    block = re.search(r"```bash\n(.*?)```", section, flags=re.S).group(1)
    lines = []
    for k, raw in enumerate(line for line in block.splitlines() if line.strip()):
        command, _, comment = raw.partition("#")
        found = DURATION.search(comment)
        seconds = None if found is None else float(found.group(1)) * (
            60.0 if found.group(2) == "min" else 1.0)
        lines.append(TourLine(k + 1, raw.strip(), tuple(shlex.split(command)), comment.strip(),
                              seconds))
    return lines


LINES = tour_lines()


def skip_reason(line: TourLine, lines: list[TourLine] = LINES) -> str | None:
    """Why ``line`` is not run here (None: it is run)."""
    if line.seconds is None:
        return "states no duration (see test_the_tour_is_a_block_of_hypate_commands_...)"
    if line.seconds >= FAST:
        return (f"measured ~{line.seconds:g} s, over {FAST:g} s: its options, files and "
                "folders are checked, it is not run")
    skipped_outputs = {out for earlier in lines[:line.number - 1]
                       if skip_reason(earlier, lines) is not None
                       for out in earlier.option("--out")}
    needs = [word for word in line.argv[1:] if word in skipped_outputs]
    if needs:
        return f"reads {needs[0]}, which a skipped line writes"
    return None


def test_the_tour_is_a_block_of_hypate_commands_with_durations() -> None:
    assert len(LINES) >= 10
    for line in LINES:
        assert line.argv[0] == "hypate", line.text
        assert line.seconds is not None, f"line {line.number} states no duration: {line.text}"
    assert any(skip_reason(line) is None for line in LINES)


@pytest.mark.parametrize("line", LINES, ids=lambda line: f"{line.number}-{line.argv[1]}")
def test_argparse_accepts_every_line(line: TourLine) -> None:
    try:
        args = build_parser().parse_args(list(line.argv[1:]))
    except SystemExit as exc:  # argparse's way of refusing
        pytest.fail(f"line {line.number} is refused by argparse (exit {exc.code}): {line.text}")
    assert getattr(args, "func", None) is not None, line.text


def test_repository_paths_exist_and_outputs_are_distinct_folders_under_runs() -> None:
    written: dict[str, int] = {}
    for line in LINES:
        for word in line.argv[1:]:
            if word.startswith(("studies/", "scaling/")):
                assert (REPO / word).is_file(), f"line {line.number}: {word} is not shipped"
        for out in line.option("--out"):
            assert out.startswith("runs/"), f"line {line.number}: {out} is not under runs/"
            if "--resume" in line.argv:  # continues the run an earlier line started
                assert written.get(out, line.number) < line.number, line.text
                continue
            assert out not in written, (f"line {line.number} reuses line {written[out]}'s "
                                        f"--out {out} (hypate run would refuse it)")
            written[out] = line.number
        for name in READS:
            for run_dir in line.option(name):
                assert written.get(run_dir, line.number) < line.number, (
                    f"line {line.number}: {name} {run_dir} is written by no earlier line")


def test_the_gitignore_keeps_runs_out_of_git() -> None:
    assert "runs/" in (REPO / ".gitignore").read_text().split()


@pytest.mark.parametrize("line", LINES, ids=lambda line: f"{line.number}-{line.argv[1]}")
def test_tour_line_runs(line: TourLine, tmp_path: Path) -> None:
    reason = skip_reason(line)
    if reason is not None:
        pytest.skip(reason)
    (tmp_path / "studies").symlink_to(REPO / "studies", target_is_directory=True)
    exe = shutil.which("hypate")
    cmd = [exe, *line.argv[1:]] if exe else [sys.executable, "-m", "hypate.scaling.cli.main",
                                            *line.argv[1:]]
    res = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True,
                         timeout=10 * FAST)
    assert res.returncode == 0, f"line {line.number}: {line.text}\n{res.stderr[-2000:]}"
    for out in line.option("--out"):
        assert (tmp_path / out).exists(), f"line {line.number} wrote no {out}"
