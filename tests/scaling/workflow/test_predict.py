"""Full-scale prediction from a measured model test (scaling/workflow/analyses/predict.py).

Oracles: (a) closed forms -- the model's own simulated response, fed back without noise,
lands on the prototype's step grid (t_p / dt_p = k), in the prototype's units through the
nondimensionalization of J (w_p / h_p = w_m / h_m, T_p / T0_p = T_m / T0_m), and the J of
the prediction against the simulated prototype is the run's J; the band's parts are their
definitions; (b) the stated coverage -- the design point's model simulated with 2 % noise
(the sample file's script) predicts the simulated prototype within the band at >= 95 % of
the time points; (c) unit invariance.
"""
from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import REPO, tiny_study_text
from hypate.scaling.cli.main import main
from hypate.scaling.engine.store import EvaluationStore
from hypate.scaling.workflow.campaigns.integrity import record_outputs
from hypate.scaling.workflow.campaigns.laws import load_sweep
from hypate.scaling.workflow.vocabulary.measured import read_measured
from hypate.scaling.workflow.vocabulary.objectives import relative_rms
from hypate.scaling.workflow.analyses.predict import (
    COVERAGE,
    design_point_basis,
    predict,
    scatter_sigma,
    sweep_basis,
)
from hypate.scaling.workflow.vocabulary.problem import ScalingProblem
from hypate.solvers.coupling.response import Response
from hypate.solvers.errors import InputError
from hypate.studies.scripts.make_model_test import Config, add_noise, rms
from hypate.studies.scripts.make_model_test import run as make_model_test

#: The shipped sample measured file.
SAMPLE = REPO / "studies" / "data" / "model_test_xi4.csv"
#: Closed-form agreement: a handful of roundings (repr round trip through the CSV is exact;
#: the products and quotients of the mapping add a few ulp).
EXACT = 1e-12


def write_histories(path: Path, resp: Response, *, units: tuple[str, str, str] = ("s", "m", "K")
                    ) -> Path:
    """A measured file holding a response's histories exactly (repr floats)."""
    t, w, T = (np.asarray(v, float) for v in (resp.times, resp.center_deflection,
                                              resp.mean_temperature))
    t = t * {"s": 1.0, "ms": 1e3}[units[0]]
    w = w * {"m": 1.0, "mm": 1e3}[units[1]]
    T = T - {"K": 0.0, "degC": 273.15}[units[2]]
    pd.DataFrame({f"time [{units[0]}]": t, f"center_deflection [{units[1]}]": w,
                  f"mean_temperature [{units[2]}]": T}).to_csv(path, index=False)
    return path


def test_the_models_own_response_maps_onto_the_prototype_exactly(prediction_run, tmp_path):
    point = json.loads((prediction_run / "design_point.json").read_text())
    model = Response.load(prediction_run / "design_point.npz")
    proto = Response.load(prediction_run / "prototype.npz")
    basis = design_point_basis(prediction_run)
    pred = predict(basis, read_measured(write_histories(tmp_path / "m.csv", model)))
    dt_p = basis.scaling.prototype_time_step
    k = np.arange(len(model.times))
    # matched nondimensional time: model step k lands on prototype step k
    np.testing.assert_allclose(pred.time / dt_p, k, rtol=0, atol=EXACT * k.max())
    assert dt_p == 8.0 and basis.scaling.model_time_step == point["model_time_step"]
    w = pred.histories["center_deflection"]
    T = pred.histories["mean_temperature"]
    np.testing.assert_allclose(w.predicted / proto.thickness, model.deflection_over_thickness,
                               rtol=EXACT)
    np.testing.assert_allclose(T.predicted / proto.stagnation_temperature,
                               model.temperature_over_stagnation, rtol=EXACT)
    # the references are the ones J compared: J of the prediction is the run's J
    for h, name in ((w, "J_u"), (T, "J_T")):
        ref = proto.thickness if name == "J_u" else proto.stagnation_temperature
        J = relative_rms(h.predicted[1:] / ref, h.simulated[1:] / ref)
        assert J == pytest.approx(point["objectives"][name], rel=1e-10)
        assert h.parts.J == pytest.approx(point["objectives"][name], rel=1e-10)
        # no noise: the band is the residual bound alone, and every point is inside it
        assert h.parts.measurement < EXACT * h.parts.rms_prototype
        resid = np.max(np.abs(h.predicted - h.simulated))
        assert h.half_width == pytest.approx(resid, rel=1e-9)
        assert h.in_band == 1.0


@pytest.mark.parametrize("units", [("ms", "mm", "degC"), ("s", "mm", "K"), ("ms", "m", "degC")])
def test_units_convert_to_the_same_prediction(prediction_run, tmp_path, units):
    model = Response.load(prediction_run / "design_point.npz")
    basis = design_point_basis(prediction_run)
    si = predict(basis, read_measured(write_histories(tmp_path / "si.csv", model)))
    other = predict(basis, read_measured(write_histories(tmp_path / "o.csv", model,
                                                         units=units)))
    np.testing.assert_allclose(other.time, si.time, rtol=EXACT, atol=EXACT)
    for name, h in si.histories.items():
        np.testing.assert_allclose(other.histories[name].predicted, h.predicted,
                                   rtol=EXACT, atol=EXACT * np.max(np.abs(h.predicted)))


def test_noisy_model_test_predicts_the_prototype_within_the_band(prediction_run, tmp_path):
    study = prediction_run.parent / "tiny_predict.toml"
    res = make_model_test(Config(study=str(study), run_dir=prediction_run,
                                 out=tmp_path / "test.csv"))
    for name, clean in res.clean.items():  # the stated noise: 2 % of the history's RMS
        assert res.sigma[name] == pytest.approx(0.02 * rms(clean), rel=1e-12)
    measured = read_measured(res.path)
    pred = predict(design_point_basis(prediction_run), measured)
    assert set(pred.histories) == {"center_deflection", "mean_temperature"}
    for name, h in pred.histories.items():
        assert h.in_band >= 0.95, (name, h.in_band)
        # the measurement part sees the noise: about 2 % of the history's RMS (21 samples)
        sigma_nd = res.sigma[name] / pred.basis.scaling.reference(name, "model")
        assert 0.5 * sigma_nd < h.parts.measurement < 1.6 * sigma_nd
        # and the band is the stated construction H = B + z sqrt(s_s^2 + s_m^2)
        ref = pred.basis.scaling.reference(name, "prototype")
        assert h.half_width == pytest.approx(
            ref * (h.parts.residual + COVERAGE * h.parts.measurement), rel=1e-12)


def _with_scatter(run_dir: Path, tmp_path: Path, block: dict) -> Path:
    copy = tmp_path / "run"
    shutil.copytree(run_dir, copy, ignore=shutil.ignore_patterns("prediction", "run.lock"))
    point = json.loads((copy / "design_point.json").read_text())
    point.update(block)
    (copy / "design_point.json").write_text(json.dumps(point))
    # a run that propagated that scatter itself: its outputs recorded as they are now
    # (readers refuse a design_point.json changed after the run wrote it)
    with EvaluationStore(copy / "evaluations.sqlite") as store:
        record_outputs(store, copy)
    return copy


def test_the_scatter_widens_the_band_root_sum_square(prediction_run, tmp_path):
    block = {"scatter": {"status": "ok", "objectives": {
        "J_u": {"mean": 0.3, "std": 0.05, "q10": 0.25, "q50": 0.3, "q90": 0.36},
        "J_T": {"mean": 0.3, "std": math.inf, "q10": 0.2, "q50": 0.3, "q90": 0.4}}}}
    run_dir = _with_scatter(prediction_run, tmp_path, block)
    model = Response.load(run_dir / "design_point.npz")
    measured = read_measured(write_histories(tmp_path / "m.csv", model))
    pred = predict(design_point_basis(run_dir), measured)
    w, T = pred.histories["center_deflection"], pred.histories["mean_temperature"]
    assert pred.basis.scatter_source == "design_point.json scatter"
    # deflection: the std of J_u times the prototype history's RMS
    assert w.parts.scatter_statistic == "std"
    assert w.parts.scatter == pytest.approx(0.05 * w.parts.rms_prototype, rel=1e-12)
    # temperature: std infinite (failed scattered models) -> (q90 - q10) / 2.563
    assert T.parts.scatter_statistic == "interdecile"
    assert T.parts.scatter == pytest.approx(0.2 / 2.5631031310892007 * T.parts.rms_prototype,
                                            rel=1e-9)
    for h in (w, T):
        ref = pred.basis.scaling.reference(h.name, "prototype")
        expected = h.parts.residual + COVERAGE * math.hypot(h.parts.scatter,
                                                            h.parts.measurement)
        assert h.half_width == pytest.approx(ref * expected, rel=1e-12)
    # a robust run's block is preferred over the nominal scatter
    robust = {"robust": {"status": "ok", "objectives": {"J_u": {"std": 0.01},
                                                        "J_T": {"std": 0.02}}}}
    run2 = _with_scatter(run_dir, tmp_path / "r", robust)
    b2 = design_point_basis(run2)
    assert b2.scatter_source == "design_point.json robust"
    assert scatter_sigma(b2.scatter, "J_T") == (0.02, "std")
    # a failed propagation is said so and left out
    failed = _with_scatter(prediction_run, tmp_path / "f", {"scatter": {"status": "failed: x"}})
    b3 = design_point_basis(failed)
    assert b3.scatter is None and "failed" in b3.scatter_source


def test_the_time_span_must_lie_in_the_models_test(prediction_run, tmp_path):
    model = Response.load(prediction_run / "design_point.npz")
    basis = design_point_basis(prediction_run)
    late = model.times[-1] * (1.0 + 1e-6)
    path = tmp_path / "late.csv"
    path.write_text(f"time [s],center_deflection [m]\n0,0\n{late!r},0.001\n")
    with pytest.raises(InputError, match=r"column 'time \[s\]'.*outside the model's test"):
        predict(basis, read_measured(path))
    path.write_text("time [s],center_deflection [m]\n-0.1,0\n1,0.001\n")
    with pytest.raises(InputError, match="outside"):
        predict(basis, read_measured(path))
    # a part of the span is fine, between the steps too (interpolated comparison)
    path.write_text(f"time [s],center_deflection [m]\n{0.5 * model.times[3]!r},0.001\n")
    pred = predict(basis, read_measured(path))
    assert pred.time[0] == pytest.approx(1.5 * basis.scaling.prototype_time_step)


def test_run_directory_checks(prediction_run, tmp_path):
    with pytest.raises(InputError, match="no design point"):
        design_point_basis(tmp_path)
    copy = _with_scatter(prediction_run, tmp_path, {"model_time_step": 0.5})
    with pytest.raises(InputError, match="not simulated with the time step"):
        design_point_basis(copy)
    (copy / "prototype.npz").unlink()
    with pytest.raises(InputError, match="prototype.npz"):
        design_point_basis(copy)
    with pytest.raises(InputError) as exc:
        sweep_basis(prediction_run, 3.0)
    assert exc.value.field == "xi" and "not a sweep run" in exc.value.message


@pytest.fixture(scope="module")
def tiny_sweep(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("sweep")
    study = root / "tiny_sweep.toml"
    study.write_text(tiny_study_text(name="tiny_sweep", xi=2.0, steps=20, time_step=8.0,
                                     initial=3, iterations=0, tail="""
[sweep]
xi = [2, 4]
recycle = 2
initial_samples = 1
iterations = 0
"""))
    assert main(["run", str(study), "--out", str(root / "run"), "-q"]) == 0
    return root / "run"


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # material tables clamped
def test_another_size_through_the_refined_laws(tiny_sweep, tmp_path):
    basis = sweep_basis(tiny_sweep, 3.0)
    assert basis.source == "refined laws at xi = 3"
    # the model the laws give at xi = 3, on the study's time mapping for that design
    run = load_sweep(tiny_sweep)
    spec = run.study(3.0).spec
    problem = ScalingProblem(spec)
    x = np.array([basis.design[n] for n in spec.names])
    config = problem.model_configuration(x)
    assert basis.scaling.model_time_step == pytest.approx(config.simulation.time_step,
                                                          rel=1e-14)
    assert basis.scaling.model_thickness == pytest.approx(config.panel.thickness, rel=1e-14)
    assert config.panel.length == pytest.approx(spec.prototype.panel.length / 3.0)
    # its simulated response with 2 % noise predicts the sweep's prototype within the band
    clean = {n: np.asarray(getattr(basis.model, n), float)
             for n in ("center_deflection", "mean_temperature")}
    noisy, _ = add_noise(clean, 0.02, seed=1)
    path = tmp_path / "xi3.csv"
    pd.DataFrame({"time [s]": basis.model.times,
                  "center_deflection [m]": noisy["center_deflection"],
                  "mean_temperature [K]": noisy["mean_temperature"]}).to_csv(path, index=False)
    pred = predict(basis, read_measured(path))
    for h in pred.histories.values():
        assert h.in_band >= 0.95
    np.testing.assert_allclose(pred.time / basis.scaling.prototype_time_step,
                               np.arange(len(pred.time)), atol=1e-9)
    # a scale below 1 is refused naming the option
    with pytest.raises(InputError) as exc:
        sweep_basis(tiny_sweep, 0.5)
    assert exc.value.field == "xi"


def test_the_shipped_sample_file_reads_and_records_its_origin():
    text = SAMPLE.read_text()
    measured = read_measured(SAMPLE)
    assert set(measured.histories) == {"center_deflection", "mean_temperature"}
    assert measured.headers["center_deflection"] == "center_deflection [mm]"
    assert measured.time.size == 161  # the 160 steps of Sec. 9.2 and the initial state
    for needle in ("sec9_2_2_xi4", "design point:", "noise: normal, std 0.02",
                   "default_rng(4)", "make_model_test"):
        assert needle in text

