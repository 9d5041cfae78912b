"""Checks of the command-line option values (scaling/cli/arguments.py)."""
from __future__ import annotations

import math
import re
from pathlib import Path

import pytest
from hypate.scaling.cli.arguments import (
    finite,
    integer_in,
    output_directory,
    output_file,
    positive,
)
from hypate.solvers.errors import InputError


def test_numbers_in_range_pass_unchanged() -> None:
    assert finite(-1.5e3, "--x") == -1.5e3 and positive(2.0, "--x") == 2.0
    assert integer_in(5, "--n", 1, 5) == 5 and integer_in(10**12, "--n", 0) == 10**12


@pytest.mark.parametrize("check, message", [
    (lambda: finite(math.nan, "--x"), "must be a finite number; got nan"),
    (lambda: finite(-math.inf, "--x"), "must be a finite number; got -inf"),
    (lambda: positive(0.0, "--x"), "must be a finite number > 0; got 0"),
    (lambda: positive(math.inf, "--x"), "must be a finite number > 0; got inf"),
    (lambda: integer_in(6, "--x", 1, 5), "must be an integer in [1, 5]; got 6"),
    (lambda: integer_in(-1, "--x", 0), "must be an integer >= 0; got -1"),
])
def test_out_of_range_names_the_flag(check, message: str) -> None:
    with pytest.raises(InputError, match=re.escape(message)) as info:
        check()
    assert info.value.field == "--x"


def test_output_paths(tmp_path: Path) -> None:
    (tmp_path / "file").write_text("")
    assert output_file(str(tmp_path / "new.csv"), "--out") == tmp_path / "new.csv"
    assert output_directory(str(tmp_path / "new" / "dir"), "--out") == tmp_path / "new" / "dir"
    for check, path, message in [(output_file, tmp_path, "is a directory"),
                                 (output_file, tmp_path / "no" / "f.csv", "does not exist"),
                                 (output_directory, tmp_path / "file", "not a directory")]:
        with pytest.raises(InputError, match=re.escape(message)) as info:
            check(str(path), "--out")
        assert info.value.field == "--out"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]  # checks write nothing
