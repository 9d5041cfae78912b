"""Response files (solvers/coupling/response.py): round trip, and malformed files refused
with the file and the member named."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
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
