"""README.md "Using hypate from Python": every example runs, and prints what it says."""
from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from conftest import REPO

README = REPO / "README.md"
#: The examples, in README order.
EXAMPLES = ("minimize", "constraints", "asktell", "study")
BRANIN_MIN = 0.397887


def python_examples() -> list[str]:
    text = README.read_text()
    section = text.split("## Using hypate from Python", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"```python\n(.*?)```", section, flags=re.S)


def run_example(index: int) -> tuple[str, dict[str, Any]]:
    """What example ``index`` prints, and its namespace after it ran."""
    space: dict[str, Any] = {}
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(python_examples()[index], f"README example {index}", "exec"), space)
    return out.getvalue(), space


def test_the_section_has_every_example() -> None:
    assert len(python_examples()) == len(EXAMPLES)


@pytest.mark.parametrize("name", EXAMPLES)
def test_readme_python_example_runs(name: str, tmp_path: Path,
                                    monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)  # the examples write runs/ relative to the working folder
    printed, space = run_example(EXAMPLES.index(name))
    res = space.get("res")
    if name == "minimize":  # "within 1e-4 of the minimum 0.397887"
        fun = float(printed.split("]")[1].split()[0])
        assert abs(fun - BRANIN_MIN) < 1e-4
        assert list(res.evaluations.columns[2:5]) == ["u", "v", "f0"]
    elif name == "constraints":
        bnh, P, F = space["bnh"], res.pareto_x, res.pareto_fun
        assert len(P) >= 3
        np.testing.assert_array_equal(np.array([bnh(x) for x in P]), F)  # row-aligned
        assert np.all((P[:, 0] - 5)**2 + P[:, 1]**2 <= 25)               # expensive one
        X = res.evaluations[["a", "b"]].to_numpy()
        assert np.all(X[:, 0] <= 2.5 + 1e-8)     # the cheap one holds in every design
        assert "['a', 'b', 'f1', 'f2', 'g0']" in printed
    elif name == "asktell":
        fun = float(printed.split("]")[1].split()[0])
        assert abs(fun - BRANIN_MIN) < 1e-3
        store = tmp_path / "runs/branin/asktell.sqlite"
        assert store.is_file()
        again, _ = run_example(EXAMPLES.index(name))  # run again: resumed, nothing to do
        assert again == printed
    else:
        assert "J_u" in printed and (tmp_path / "runs/python-quickstart/report.html").is_file()
        outcome = space["outcome"]
        ev, pareto = outcome.evaluations, outcome.pareto
        named = ["M", "p0", "T0", "L_le", "h", "J_u", "J_T"]
        for df in (ev, pareto):
            assert set(named + ["id", "status", "message"]) <= set(df.columns)
        run = tmp_path / "runs/python-quickstart"
        csv = pd.read_csv(run / "evaluations.csv").set_index("id")
        assert len(ev) == len(csv) and len(pareto) >= 2
        # each Pareto row is its design's row of evaluations.csv: design and objectives
        np.testing.assert_array_equal(pareto[named].to_numpy(float),
                                      csv.loc[pareto["id"], named].to_numpy(float))
        assert (pareto["status"] == "ok").all()
        assert np.all(np.diff(pareto["J_u"].to_numpy()) >= 0)
        assert ev.attrs["units"]["p0"] == "Pa" and ev.attrs["units"]["J_u"] == "-"
        assert (ev["message"].map(type) == str).all()
