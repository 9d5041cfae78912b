"""``hypate run`` reports solver warnings once, attributed to the prototype and the
evaluations (ids of evaluations.csv) they occurred in; workers print nothing."""
from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import pandas as pd
from conftest import tiny_study_text
from hypate.scaling.cli.progress import Progress
from hypate.scaling.cli.run import warning_summary
from hypate.scaling.engine.problem import parse_warning, tally_warnings
from hypate.scaling.engine.store import warnings_from_text
from hypate.scaling.workflow.campaigns.rundir import describe_occurrences

#: The columns of evaluations.csv after the design variables and objectives.
TAIL = ["status", "message", "warnings", "seconds", "seed", "max_wall_temperature",
        "max_deflection_ratio", "max_von_mises", "admissible"]


def test_summary_lines_say_where_each_warning_occurred() -> None:
    lines = warning_summary(
        [], evaluations=[(3, ["RuntimeWarning: a (2 times)"]),
                         (7, ["RuntimeWarning: a (1 time)", "UserWarning: b (1 time)"])]
        + [(i, ["RuntimeWarning: c (1 time)"]) for i in range(10, 40, 2)],
        prototype=["RuntimeWarning: a (4 times)"])
    assert lines[0].startswith("23 solver warnings of 3 kinds during the run")
    assert lines[1:] == [
        "  RuntimeWarning: c: evaluations 10, 12, 14, 16, 18, 20, 22, 24, ... (15 in all)"
        " (15 times)",
        "  RuntimeWarning: a: prototype, evaluations 3, 7 (7 times)",
        "  UserWarning: b: evaluation 7 (1 time)"]
    assert describe_occurrences([4, 5, 6, 9]) == "evaluations 4-6, 9"


def test_verbose_progress_prints_each_evaluation_s_warnings_with_its_id(capsys) -> None:
    # a resumed run: 5 evaluations stored before, then ids 5 and 6 (done counts all)
    bar = Progress(quiet=True, verbose=True)
    ev = SimpleNamespace(status="ok", F=[0.1, 0.2], warnings=("RuntimeWarning: w (2 times)",))
    bar(6, 8, SimpleNamespace(status="ok", F=[0.3, 0.3], warnings=()))
    bar(7, 8, ev)
    bar.close()
    assert capsys.readouterr().err == "evaluation 6: RuntimeWarning: w (2 times)\n"


#: A solver warning injected into ``hypate run`` (its pool workers fork from the patched
#: process): every wall-temperature query above 500 K warns, as a clamped property table
#: did before the tables were checked after the run instead (issue 40).
INJECT = """
import sys, warnings
import hypate.solvers.thermal.model as thermal
original = thermal.ThermalModel.wall_temperature
def wall_temperature(self, T):
    out = original(self, T)
    if out.max() > 500.0:
        warnings.warn("injected: hot wall", RuntimeWarning, stacklevel=2)
    return out
thermal.ThermalModel.wall_temperature = wall_temperature
from hypate.scaling.cli.main import main
sys.exit(main(sys.argv[1:]))
"""


def test_a_pool_run_prints_no_raw_warning_and_attributes_them(tmp_path: Path) -> None:
    study = tmp_path / "tiny.toml"
    study.write_text(tiny_study_text())
    out = tmp_path / "run"
    proc = subprocess.run([sys.executable, "-c", INJECT, "run", str(study),
                           "--out", str(out), "--workers", "2"],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    err = proc.stderr.splitlines()
    heads = [i for i, line in enumerate(err) if "solver warnings of" in line]
    assert len(heads) == 1, proc.stderr
    summary = err[heads[0] + 1:]
    # nothing before the summary mentions a warning (workers and the CLI alike)
    assert not [line for line in err[:heads[0]] if "Warning" in line], proc.stderr
    csv = pd.read_csv(out / "evaluations.csv")
    assert list(csv.columns[-len(TAIL):]) == TAIL
    stored = [(int(i), warnings_from_text(w)) for i, w in zip(csv["id"], csv["warnings"])]
    # evaluations through the pool (iteration >= 0) warned too, and are attributed
    assert any(w for (i, w), it in zip(stored, csv["iteration"]) if it >= 0)
    expected = tally_warnings(stored)
    shown = {line.strip() for line in summary if line.startswith("  ")}
    for text, ids, n in expected:
        # the evaluations' occurrences as stored, after the prototype's and the run's own
        # (the main process simulates the prototype and, at the end, the design point)
        line = next(s for s in shown if s.startswith(f"{text}: "))
        where, times = re.fullmatch(r".*?: (.*) \((\d+) times?\)", line).groups()
        assert where.endswith(describe_occurrences(ids)) and int(times) >= n, line
    assert all(re.search(r"\(\d+ times?\)$", line) for line in shown)
    assert all(parse_warning(e)[1] >= 1 for _, w in stored for e in w)
    assert json.loads(csv["warnings"].dropna().iloc[0])  # a JSON list in the cell
