"""README.md "Using hypate from Python": every example runs, and prints what it says."""
from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import pytest
from conftest import REPO

README = REPO / "README.md"


def python_examples() -> list[str]:
    text = README.read_text()
    section = text.split("## Using hypate from Python", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"```python\n(.*?)```", section, flags=re.S)


def test_the_section_has_examples() -> None:
    assert len(python_examples()) >= 2


@pytest.mark.parametrize("index", range(2))
def test_readme_python_example_runs(index: int, tmp_path: Path,
                                    monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)  # the examples write runs/ relative to the working folder
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(python_examples()[index], f"README example {index}", "exec"), {})
    printed = out.getvalue()
    if index == 0:  # "within 1e-4 of the minimum 0.397887"
        fun = float(printed.split("]")[1].split()[0])
        assert abs(fun - 0.397887) < 1e-4
    else:
        assert "J_u" in printed and (tmp_path / "runs/python-quickstart/report.html").is_file()
