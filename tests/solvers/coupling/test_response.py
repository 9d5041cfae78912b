"""Response files (solvers/coupling/response.py): round trip, and malformed files refused
with the file and the member named."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypate.scaling.workflow.vocabulary.configuration import simulate_configuration
from hypate.scaling.workflow.vocabulary.study import load_study
from hypate.solvers.aero.factory import make_fluid_model
from hypate.solvers.coupling.model import PanelModel
from hypate.solvers.coupling.response import Response
from hypate.solvers.errors import InputError


def _response() -> Response:
    r = Response(scheme="tc", thickness=0.002, length=0.5, stagnation_temperature=1500.0,
                 initial_temperature=300.0)
    for k in range(3):
        r.times.append(float(k))
        r.center_deflection.append(1e-4 * k)
        r.mean_temperature.append(300.0 + k)
        r.top_temperature.append(301.0 + k)
        r.max_wall_temperature.append(302.0 + k)
        r.modal.append(np.full(9, 0.1 * k))
        r.lsa.append(np.array([-1.0 + 2.0j, np.nan + 0j]))  # an eigenvalue not computed
    r.finish("completed", "", None)
    return r


def _arrays(path: Path) -> dict[str, np.ndarray]:
    with np.load(path, allow_pickle=False) as npz:
        return {k: npz[k] for k in npz.files}


def _meta(arrays: dict[str, np.ndarray]) -> dict:
    return json.loads(bytes(arrays["meta"]).decode())


def _with_meta(arrays: dict[str, np.ndarray], **changes) -> dict[str, np.ndarray]:
    meta = {**_meta(arrays), **changes}
    return dict(arrays, meta=np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8))


def test_round_trip_keeps_missing_eigenvalues(tmp_path: Path) -> None:
    r = _response()
    back = Response.load(r.save(tmp_path / "r.npz"))
    assert back.times == r.times and back.mean_temperature == r.mean_temperature
    np.testing.assert_array_equal(np.asarray(back.lsa), np.asarray(r.lsa))  # NaN kept


@pytest.mark.parametrize("tamper, message", [
    (lambda a: {k: v for k, v in a.items() if k != "times"}, "missing member 'times'"),
    (lambda a: dict(a, meta=np.frombuffer(b"\xff{", dtype=np.uint8)), "member 'meta'"),
    (lambda a: _with_meta(a, format_version=7), "unsupported response format 7"),
    (lambda a: _with_meta(a, thickness=float("nan")), "thickness must be a number > 0"),
    (lambda a: {k: v for k, v in _with_meta(a).items()}
     | {"meta": np.frombuffer(json.dumps({"format_version": 1}).encode(), np.uint8)},
     "member 'meta': missing scheme"),
    (lambda a: dict(a, times=np.array([0.0, np.inf, 2.0])), "member 'times': non-finite"),
    (lambda a: dict(a, center_deflection=np.array(["x"])), "member 'center_deflection'"),
])
def test_malformed_files_name_the_member(tmp_path: Path, tamper, message: str) -> None:
    good = _response().save(tmp_path / "good.npz")
    bad = tmp_path / "bad.npz"
    np.savez(bad, **tamper(_arrays(good)))
    with pytest.raises(InputError, match=message) as info:
        Response.load(bad)
    assert info.value.field == str(bad)


def test_what_the_structure_goes_through_is_recorded_from_the_fields(tmp_path: Path) -> None:
    """A short coupled run with its fields kept: every recorded maximum wall temperature
    is the maximum of the thermal solver's upper-surface nodes, each layer's range the
    extremes of its thermal levels, |w|/h the largest nodal deflection, and the von Mises
    peak the surface stress of the recorded state (issue 40); the histories survive a
    round trip and a file without them still loads."""
    study = load_study("quickstart")  # the Sec. 9.2 sandwich prototype, 4 x 4, 3 steps
    config = study.spec.with_steps(3).prototype
    resp = simulate_configuration(config, keep_fields=True)
    s = config.run_settings()
    model = PanelModel(config.panel, config.flow,
                       make_fluid_model(s.aero, s.heating, s.boundary_layer), s)
    th = model.thermal
    assert len(resp.T) == len(resp.max_wall_temperature) == 4
    for k, T in enumerate(resp.T):
        assert resp.max_wall_temperature[k] == np.max(th.wall_temperature(T))
        profile = th.profile(T)
        assert resp.layer_temperature[k][1][1] == profile[:, 1:4].max()  # the core
        assert resp.layer_temperature[k][0][0] == profile[:, 0:2].min()  # lower sheet
        w = np.asarray(resp.u[k])[2::5]
        assert resp.max_deflection_ratio[k] == np.max(np.abs(w)) / resp.thickness
        peak = model.surface_stress.peak(resp.u[k], profile)
        assert resp.max_von_mises[k] == peak.von_mises
    ext = resp.extremes()
    assert ext["max_wall_temperature"] == max(resp.max_wall_temperature)
    assert ext["layer_materials"] == ["inconel718", "core", "inconel718"]
    back = Response.load(resp.save(tmp_path / "r.npz"))
    assert json.dumps(back.extremes(), sort_keys=True) == json.dumps(ext, sort_keys=True)
    old = Response.load(_response().save(tmp_path / "old.npz"))  # no limit histories
    assert old.max_von_mises == [] and np.isnan(old.extremes()["max_von_mises"])
