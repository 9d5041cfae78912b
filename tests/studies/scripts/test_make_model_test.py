"""The sample measured test's script (studies/scripts/make_model_test.py)."""
from __future__ import annotations

import numpy as np
import pytest
from hypate.scaling.workflow.vocabulary.measured import read_measured
from hypate.scaling.workflow.analyses.predict import design_point_basis, predict
from hypate.studies.scripts.make_model_test import Config, add_noise, rms, run


def test_the_noise_is_as_stated_and_seeded():
    clean = {"a": np.sin(np.linspace(0.0, 3.0, 20000)) + 2.0}
    noisy, sigma = add_noise(clean, 0.02, seed=4)
    again, _ = add_noise(clean, 0.02, seed=4)
    np.testing.assert_array_equal(noisy["a"], again["a"])  # fixed seed
    assert sigma["a"] == pytest.approx(0.02 * rms(clean["a"]))
    # 20000 samples: the sample std is within ~0.5 % of sigma
    assert np.std(noisy["a"] - clean["a"]) == pytest.approx(sigma["a"], rel=0.03)


def test_a_finished_run_of_another_study_is_refused(prediction_run, tmp_path):
    with pytest.raises(ValueError, match="another study"):
        run(Config(study="sec9_2_2_xi4", run_dir=prediction_run, out=tmp_path / "t.csv"))
    assert not (tmp_path / "t.csv").exists()


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # material tables clamped
def test_the_sample_files_recipe_predicts_its_prototype(tmp_path):
    # the shipped sample's recipe end to end: the full Sec. 9.2.2 xi = 4 study (~6 min on 2
    # cores), its design point simulated with 2 % noise, predicted within the band
    res = run(Config(run_dir=tmp_path / "xi4", out=tmp_path / "test.csv"))
    assert res.time.size == 161
    pred = predict(design_point_basis(tmp_path / "xi4"), read_measured(res.path))
    for h in pred.histories.values():
        assert h.in_band >= 0.95
