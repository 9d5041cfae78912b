"""A robust study (``[uncertainty]`` + ``[robust]``): the nominal campaign, the robust
search over (design, uncertain inputs), the verified design point beside the nominal
optimum, the report, and kill -9 / --resume (scaling.workflow.campaigns.robust)."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import kill_after, tiny_study_text
from hypate.scaling.cli.main import main
from hypate.scaling.engine.store import EvaluationStore
from hypate.scaling.workflow.vocabulary.objectives import response_errors
from hypate.scaling.workflow.vocabulary.problem import ScalingProblem
from hypate.scaling.workflow.campaigns.robust import INPUT_PREFIX, JointProblem, verified_statistic
from hypate.scaling.workflow.vocabulary.study import load_study
from hypate.scaling.workflow.vocabulary.uncertainty import scattered_configuration

ROBUST = """
[uncertainty]
p0 = { normal = 0.03 }
"model.youngs_modulus" = { normal = 0.05 }
[robust]
statistic = "q90"
order = 1
initial_samples = 4
iterations = {iterations}
"""


def _study(folder: Path, iterations: int = 4, nominal_iterations: int = 3) -> Path:
    path = folder / "tiny_robust.toml"
    path.write_text(tiny_study_text(iterations=nominal_iterations,
                                    sections=ROBUST.replace("{iterations}", str(iterations))))
    return path


def _rows(run_dir: Path) -> list[tuple]:
    """The stored campaign: (iteration, batch_index, x, F, status), NaN as None."""
    def values(a: np.ndarray) -> tuple:
        return tuple(None if not np.isfinite(v) else round(float(v), 12) for v in a)

    with EvaluationStore(run_dir / "evaluations.sqlite", read_only=True) as store:
        return sorted((r.iteration, r.batch_index, values(r.x), values(r.F), r.status)
                      for r in store.load())


@pytest.fixture(scope="module")
def robust_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    folder = tmp_path_factory.mktemp("robust")
    path = _study(folder)
    assert main(["run", str(path), "--out", str(folder / "run"), "-q"]) == 0
    return path, folder / "run"


def test_robust_run_writes_both_designs_and_their_propagations(robust_run):
    path, out = robust_run
    point = json.loads((out / "design_point.json").read_text())
    for key in ("robust", "nominal", "robust_search", "design", "objectives", "chosen"):
        assert key in point, key
    block = point["robust"]
    assert {"statistic", "samples", "objectives", "sobol", "distribution"} <= set(block)
    assert block["statistic"] == "q90" and block["samples"] == 8  # order 1, 2 inputs: 3 -> 8
    assert set(block["sobol"]["J_u"]) == {"p0", "model.youngs_modulus"}
    nominal = json.loads((out / "nominal" / "design_point.json").read_text())
    assert point["nominal"]["design"] == nominal["design"]
    assert point["nominal"]["robust"] == nominal["scatter"]
    # the design point is the better verified design: never worse than the nominal optimum
    assert verified_statistic(point["robust"]) <= verified_statistic(point["nominal"]["robust"])
    stats = point["statistics"]
    assert stats["evaluations"] == 4 + 4
    assert stats["nominal_evaluations"] == nominal["statistics"]["evaluations"]
    assert stats["simulator_runs"] == 8 + stats["nominal_evaluations"] + 16
    # the distribution's quantiles are the q10/q50/q90 the block reports where they coincide
    dist = block["distribution"]
    assert dist["probabilities"][0] == pytest.approx(0.01) and len(dist["J_max"]) == 50
    assert np.all(np.diff(np.array(dist["J_max"], float)) >= 0.0)


def test_each_stored_pair_is_the_scattered_model_at_its_inputs(robust_run):
    path, out = robust_run
    study = load_study(path)
    table = pd.read_csv(out / "evaluations.csv")
    inputs = [INPUT_PREFIX + n for n in study.uncertainty.names]
    assert list(table.columns[1:1 + len(study.spec.names) + len(inputs)]) == \
        study.spec.names + inputs
    scattered = table[(table[inputs] != 1.0).any(axis=1) & (table["status"] == "ok")]
    assert len(scattered) >= 3
    joint = JointProblem(ScalingProblem(study.spec), study.uncertainty)
    lo, hi = joint.xl[-2:], joint.xu[-2:]
    assert np.all(table[inputs].to_numpy() >= lo) and np.all(table[inputs].to_numpy() <= hi)
    row = scattered.iloc[-1]
    x = row[study.spec.names].to_numpy(float)
    factors = row[inputs].to_numpy(float)
    p = joint.scaling
    err = response_errors(p.checked_response(scattered_configuration(
        p, x, study.uncertainty.names, factors)), p.prototype_response)
    assert err["J_u"] == pytest.approx(row["J_u"], rel=1e-9)
    assert err["J_T"] == pytest.approx(row["J_T"], rel=1e-9)


def test_report_overlays_the_robust_and_nominal_distributions(robust_run):
    _, out = robust_run
    html = (out / "report.html").read_text()
    assert "Robustness" in html and "nominal optimum" in html and "robust search&#x27;s design" in html
    assert (out / "figures" / "distribution.png").is_file()
    assert (out / "figures" / "sobol.png").is_file()


def test_robust_keys_and_flags_are_checked(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text(tiny_study_text(sections=ROBUST.replace("{iterations}", "-1")))
    assert main(["validate", str(bad)]) == 2
    assert "robust.iterations" in capsys.readouterr().err
    path = _study(tmp_path)
    assert main(["run", str(path), "--out", str(tmp_path / "r"), "--seed-from",
                 str(tmp_path), "-q"]) == 2
    assert "--seed-from" in capsys.readouterr().err


def test_killed_robust_run_resumes_to_the_same_campaign(tmp_path, robust_run):
    """SIGKILL inside the robust search (after its initial pairs), then --resume: the same
    pairs, objectives and statuses as the uninterrupted run, in both campaigns."""
    path, whole = robust_run
    out = tmp_path / "killed"
    cmd = [sys.executable, "-m", "hypate.scaling.cli.main", "run", str(path), "--out",
           str(out), "-q"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    kill_after(proc, out / "evaluations.sqlite", 5)
    subprocess.run([*cmd, "--resume"], check=True, capture_output=True, timeout=600)
    assert _rows(out) == _rows(whole)
    assert _rows(out / "nominal") == _rows(whole / "nominal")
    a = json.loads((out / "design_point.json").read_text())
    b = json.loads((whole / "design_point.json").read_text())
    assert a["design"] == b["design"] and a["robust"]["objectives"] == b["robust"]["objectives"]


class _Stop(RuntimeError):
    pass


def test_a_resumed_robust_run_counts_both_stored_campaigns(tmp_path):
    """Stopped three evaluations into the robust search, then resumed: the progress goes
    on from the stored nominal and robust evaluations and ends at the total (it started
    at 1 before; counting the stored ones without the nominal seeds in the total, it ran
    past it)."""
    from hypate.scaling.workflow.campaigns.robust import run_robust_study

    study = load_study(_study(tmp_path))
    seen: list[tuple[int, int]] = []

    def stopping(done: int, total: int, evaluation) -> None:
        seen.append((done, total))
        with EvaluationStore(tmp_path / "r" / "evaluations.sqlite", read_only=True) as s:
            if len(s) == 3:  # the robust store (the nominal campaign's is r/nominal)
                raise _Stop("three robust evaluations stored")

    with pytest.raises(_Stop):
        run_robust_study(study, tmp_path / "r", progress=stopping)
    stopped_at, total = seen[-1]
    assert [d for d, _ in seen] == list(range(1, stopped_at + 1))
    seen.clear()
    run_robust_study(study, tmp_path / "r", resume=True,
                     progress=lambda done, t, ev: seen.append((done, t)))
    assert seen == [(k, total) for k in range(stopped_at + 1, total + 1)]
