"""``hypate run --workers auto`` (the default): the usable cores, capped by the study's batch;
the campaign depends on the batch, not on the worker count."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import tiny_study_text
from hypate.scaling.cli.main import main
from hypate.scaling.cli.run import resolve_workers
from hypate.scaling.engine.executors import auto_workers, usable_cores
from hypate.scaling.workflow.vocabulary.study import load_study
from hypate.solvers.errors import InputError


def _study(folder: Path, batch: int) -> Path:
    path = folder / f"batch{batch}.toml"
    path.write_text(tiny_study_text(iterations=2, tail=f"batch_size = {batch}\n"))
    return path


def test_auto_is_the_usable_cores_capped_by_the_batch(tmp_path):
    assert auto_workers(1) == 1
    assert auto_workers(64) == usable_cores() >= 1
    assert resolve_workers("auto", load_study(_study(tmp_path, 3))) == min(usable_cores(), 3)
    assert resolve_workers("2", load_study(_study(tmp_path, 1))) == 2


@pytest.mark.parametrize("value", ["0", "-1", "two", "1.5"])
def test_bad_worker_counts_are_refused(tmp_path, value):
    with pytest.raises(InputError) as err:
        resolve_workers(value, load_study(_study(tmp_path, 2)))
    assert err.value.field == "--workers" and ">= 1" in err.value.message


def test_bad_worker_count_exits_2(tmp_path, capsys):
    assert main(["run", str(_study(tmp_path, 2)), "--out", str(tmp_path / "r"),
                 "--workers", "none", "-q"]) == 2
    assert "--workers" in capsys.readouterr().err
    assert not (tmp_path / "r").exists()


def test_one_and_two_workers_store_the_same_campaign(tmp_path):
    path = _study(tmp_path, 2)
    tables = []
    for workers in ("1", "2"):
        out = tmp_path / f"w{workers}"
        assert main(["run", str(path), "--out", str(out), "--workers", workers, "-q"]) == 0
        tables.append(pd.read_csv(out / "evaluations.csv"))
    a, b = tables
    cols = ["iteration", "batch_index", "M", "p0", "T0", "h", "J_u", "J_T", "status"]
    assert len(a) == 1 + 4 + 2 * 2  # the classical seed, the initial sample, 2 batches
    pd.testing.assert_frame_equal(a[cols], b[cols])
    assert np.array_equal(a["J_u"].to_numpy(), b["J_u"].to_numpy(), equal_nan=True)
