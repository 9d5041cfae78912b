"""``hypate bench ate``: the reference coupled run's timing, repeats and work counts."""
from __future__ import annotations

import json

import numpy as np
from hypate.scaling.cli import bench_ate
from hypate.scaling.cli.bench_ate import reference_model
from hypate.scaling.cli.main import main
from hypate.solvers.coupling.tc import run_tc


def test_json_medians_repeats_and_work(capsys):
    assert main(["bench", "ate", "--duration", "3", "--repeat", "2", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    steps = out["steps"]
    assert steps == 3 and out["repeat"] == 2 and out["status"] == "completed"
    ratios = out["step_factorization_ratios"]
    assert len(ratios) == 2 and out["step_factorization_ratio"] == np.median(ratios)
    # the ratio is the median wall per step over one factorization
    per_step = out["wall_seconds"] / steps / out["factorization_seconds"]
    assert np.isclose(out["step_factorization_ratio"], per_step, rtol=1e-12)
    assert out["runs_identical"] is True  # the simulator is deterministic
    work = out["work_per_step"]
    lsa_modes = reference_model(3.0).settings.lsa_modes
    # an LSA at t = 0 and after every step, each its own factorization and at least
    # lsa_modes + 1 Arnoldi (shifted) solves; at least one thermal residual a step
    assert work["structural_factorizations"] * steps >= steps + 1
    assert work["lsa_shifted_solves"] * steps >= (steps + 1) * (lsa_modes + 1)
    assert work["thermal_residuals"] >= 1.0 and work["thermal_factorizations"] > 0
    assert work["newton_iterations"] > 0


def test_work_counts_add_up():
    """The structural factorizations are the timer's total less the thermal model's own
    (every thermal factorization of a TC run is a thermal step's, counted in the total),
    and the thermal residuals are at least one per thermal Newton iteration plus its start."""
    model = reference_model(4.0)
    th = model.thermal
    iterations = []
    step = th.step

    def counted(*args, **kwargs):
        res = step(*args, **kwargs)
        iterations.append(res.iterations)
        return res

    th.step = counted
    run_tc(model)
    counts = bench_ate.work_counts(model)
    assert counts["thermal_factorizations"] == th.factorizations > 0
    assert counts["thermal_residuals"] >= sum(iterations) + len(iterations) == 4 + sum(iterations)
    # every LSA factorizes once (t = 0 and 4 steps); the Newton's own factorizations on top
    assert counts["structural_factorizations"] >= 5
    assert counts["lsa_shifted_solves"] >= 5 * (model.settings.lsa_modes + 1)


def test_runs_that_differ_are_reported(capsys, monkeypatch):
    """The determinism check compares the histories: a repeat whose last deflection is one
    ulp off is flagged, and a single run compares nothing (null)."""
    calls = []

    def perturbed(model):
        resp = run_tc(model)
        calls.append(resp)
        if len(calls) == 2:
            w = resp.center_deflection[-1]
            resp.center_deflection[-1] = float(np.nextafter(w, np.inf))
        return resp

    monkeypatch.setattr(bench_ate, "run_tc", perturbed)
    assert main(["bench", "ate", "--duration", "2", "--repeat", "2", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["runs_identical"] is False
    calls.clear()
    assert main(["bench", "ate", "--duration", "2", "--repeat", "2"]) == 0
    assert "WARNING: the runs' histories differ" in capsys.readouterr().out
    assert main(["bench", "ate", "--duration", "2", "--repeat", "1", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["runs_identical"] is None


def test_shifted_solves_not_counted_off_the_pointwise_path(capsys):
    """Another fluid model's LSA (the general GEP) is not counted: null, not zero."""
    assert main(["bench", "ate", "--duration", "2", "--repeat", "1", "--aero", "se",
                 "--json"]) == 0
    work = json.loads(capsys.readouterr().out)["work_per_step"]
    assert work["lsa_shifted_solves"] is None and work["structural_factorizations"] >= 1.5
