"""hypate.scaling.workflow.campaigns.seeds: one study over several optimizer seeds (--seeds N)."""
from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest
from conftest import tiny_study_text
from hypate.scaling.cli.main import main
from hypate.scaling.workflow.campaigns.seeds import MAX_SEEDS, seed_list, seed_spread
from hypate.solvers.errors import InputError


def test_spread_is_median_min_max_over_the_finished_seeds() -> None:
    records = [{"status": "done", "design": {"h": h}, "objectives": {"J_u": j},
                "similarity": {"lambda_F": d}}
               for h, j, d in ((1.0, 0.3, -0.01), (3.0, 0.1, 0.02), (2.0, 0.2, 0.0))]
    records.append({"status": "not finished"})
    spread = seed_spread(records)
    assert spread["design"]["h"] == {"median": 2.0, "min": 1.0, "max": 3.0}
    assert spread["objectives"]["J_u"] == {"median": 0.2, "min": 0.1, "max": 0.3}
    assert spread["similarity"]["lambda_F"] == {"median": 0.0, "min": -0.01, "max": 0.02}


def test_seed_list_names_the_flag_and_range() -> None:
    assert seed_list(7, 3) == [7, 8, 9]
    for n in (0, MAX_SEEDS + 1):
        with pytest.raises(InputError, match=f"--seeds: a number of seeds in 1..{MAX_SEEDS}"):
            seed_list(0, n)


def test_run_with_seeds_writes_each_seed_and_the_spread(tmp_path: Path,
                                                        capsys: pytest.CaptureFixture[str]
                                                        ) -> None:
    study = tmp_path / "tiny.toml"
    study.write_text(tiny_study_text(initial=3, iterations=1))
    out = tmp_path / "runs"
    assert main(["run", str(study), "--seeds", "2", "--seed", "4", "--out", str(out), "-q"]) == 0
    data = json.loads((out / "seeds.json").read_text())
    assert [r["seed"] for r in data["seeds"]] == [4, 5] and data["finished"] == 2
    for r in data["seeds"]:
        point = json.loads((out / f"seed-{r['seed']}" / "design_point.json").read_text())
        assert r["design"] == point["design"] and r["objectives"] == point["objectives"]
        report = (out / f"seed-{r['seed']}" / "report.html").read_text()
        assert "<h2>Across seeds</h2>" in report and f"seed {r['seed']} of a" in report
    J = [r["objectives"]["J_u"] for r in data["seeds"]]
    assert data["spread"]["objectives"]["J_u"]["min"] == min(J)
    table = pd.read_csv(out / "seeds.csv")
    assert list(table["seed"]) == [4, 5] and list(table["J_u"]) == pytest.approx(J)
    assert "2 of 2 seeds finished" in capsys.readouterr().out
    # resumed: both seeds are complete, nothing is simulated again
    assert main(["run", str(study), "--seeds", "2", "--seed", "4", "--out", str(out), "-q",
                 "--resume"]) == 0
    assert capsys.readouterr().out.count("already complete") == 2
