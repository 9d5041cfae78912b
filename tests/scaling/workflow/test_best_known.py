"""The shipped best known designs (scaling/data/best_known.toml): each record is what its
design gives on the shipped study, so `hypate bench study` measures gaps to a real design."""
from __future__ import annotations

import json

import pytest
from hypate.scaling.cli.main import main
from hypate.scaling.workflow.analyses.best_known import best_known


@pytest.mark.parametrize("study", ["quickstart", "sec9_2_2_xi4"])
def test_each_record_is_its_design_evaluated(study: str, capsys: pytest.CaptureFixture
                                             ) -> None:
    record = best_known(study)
    assert record is not None and record.value == max(record.J_u, record.J_T)
    argv = ["whatif", study, "--json"]
    for name, value in record.design.items():
        argv += ["--set", f"{name}={value!r}"]
    assert main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    # one simulation of the shipped problem: the recorded objectives (bit-identical on the
    # machine that measured them; 1e-6 allows another CPU's last bits) and admissible
    assert out["objectives"]["J_u"] == pytest.approx(record.J_u, rel=1e-6)
    assert out["objectives"]["J_T"] == pytest.approx(record.J_T, rel=1e-6)
    assert out["admissible"] is True
    assert all(row["ok"] for row in out["admissibility"] if row["mode"] == "constraint")
