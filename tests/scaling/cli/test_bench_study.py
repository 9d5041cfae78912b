"""``hypate bench study``: time, simulator seconds and evaluations to a target design point,
medians over seeds, side by side with the one-worker configuration."""
from __future__ import annotations

import json
import sqlite3

import numpy as np
import pandas as pd
import pytest
from conftest import tiny_study_text
from hypate.scaling.cli.main import main


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    folder = tmp_path_factory.mktemp("bench")
    study = folder / "tiny_b2.toml"
    study.write_text(tiny_study_text(iterations=2, tail="batch_size = 2\n"))
    return study, folder


def test_bench_study_json_fields_and_their_runs(bench, capsys):
    study, folder = bench
    out = folder / "runs"
    assert main(["bench", "study", str(study), "--target", "1e9", "--seeds", "2",
                 "--compare", "single", "--out", str(out), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    for key in ("study", "target", "seeds", "seconds_to_target", "median_seconds_to_target",
                "final", "compare", "speedup"):
        assert key in data
    assert set(data["final"]) == {"J_u", "J_T", "hypervolume", "evaluations",
                                  "simulator_seconds"}
    assert data["seeds"] == [3, 4] and data["compare"]["workers"] == 1
    # any finite J reaches 1e9: the target is reached at the first successful evaluation
    # that holds the enforced admissibility columns
    for block, label in ((data, "main"), (data["compare"], "single")):
        for s, n in zip(block["seeds"], block["evaluations_to_target"]):
            table = pd.read_csv(out / label / f"seed-{s}" / "evaluations.csv")
            cols = [c for c in table.columns if c.startswith("G_")]
            good = (table["status"] == "ok") & (table[cols] <= 0.0).all(axis=1)
            assert n == int(good.to_numpy().argmax()) + 1
            assert block["simulator_seconds_to_target"][block["seeds"].index(s)] == \
                pytest.approx(table["seconds"].iloc[:n].sum(), rel=1e-9)
        # each seed's design point, and the failures after the initial design
        for s, point, (failed, evaluated) in zip(block["seeds"], block["design_points"],
                                                 block["failed_after_initial"]):
            run = out / label / f"seed-{s}"
            rec = json.loads((run / "design_point.json").read_text())
            assert point == max(rec["objectives"].values())
            table = pd.read_csv(run / "evaluations.csv")
            after = table["iteration"] >= 1
            assert (failed, evaluated) == (int((after & (table["status"] != "ok")).sum()),
                                           int(after.sum()))
        assert block["worst_design_point"] == max(block["design_points"])
        assert block["best_known"] is None and block["gap"] == [None, None]
        assert block["final"]["evaluations"] == 1 + 4 + 2 * 2
    # the campaign depends on the batch, not on the workers: the same final design point
    assert data["final"]["J_u"] == data["compare"]["final"]["J_u"]
    assert data["speedup"] == pytest.approx(data["compare"]["median_seconds_to_target"]
                                            / data["median_seconds_to_target"])
    # evaluations per second, first to last commit: the store's commit times say the same
    # (the callback runs right after each commit: 20 ms allowed over the span)
    for block, label in ((data, "main"), (data["compare"], "single")):
        for s, rate in zip(block["seeds"], block["evaluations_per_second"]):
            with sqlite3.connect(out / label / f"seed-{s}" / "evaluations.sqlite") as con:
                created = [row[0] for row in con.execute(
                    "SELECT created FROM evaluations ORDER BY id")]
            span = created[-1] - created[0]
            assert (len(created) - 1) / rate == pytest.approx(span, abs=0.02)
        assert block["median_evaluations_per_second"] == pytest.approx(
            float(np.median(block["evaluations_per_second"])))
    assert data["throughput"] == pytest.approx(data["median_evaluations_per_second"]
                                               / data["compare"]["median_evaluations_per_second"])


def test_an_unreached_target_is_null(bench, capsys):
    study, _ = bench
    assert main(["bench", "study", str(study), "--target", "1e-9", "--seeds", "1",
                 "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["seconds_to_target"] == [None] and data["median_seconds_to_target"] is None
    assert data["compare"] is None and data["speedup"] is None and data["throughput"] is None


@pytest.mark.parametrize("argv, field", [(["--target", "0"], "--target"),
                                         (["--seeds", "0"], "--seeds")])
def test_bad_bench_study_options_exit_2(bench, capsys, argv, field):
    study, _ = bench
    assert main(["bench", "study", str(study), *argv]) == 2
    assert field in capsys.readouterr().err
