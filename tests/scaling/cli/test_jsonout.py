"""Strict JSON output of the commands (scaling/cli/jsonout.py)."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypate.scaling.cli.jsonout import dumps


def _strict(text: str) -> object:
    """Parse as a non-Python JSON parser would: NaN/Infinity tokens are errors."""
    def refuse(token: str) -> None:
        raise ValueError(f"invalid JSON token {token}")

    return json.loads(text, parse_constant=refuse)


def test_non_finite_values_become_null_and_numpy_values_plain() -> None:
    data = {"nan": math.nan, "inf": -math.inf, "np": np.float64("nan"), "ok": np.float32(0.5),
            "n": np.int64(3), "flag": np.bool_(True), "arr": np.array([1.0, np.inf]),
            "nested": [(1.0, math.nan)], 4: "key"}
    assert _strict(dumps(data)) == {"nan": None, "inf": None, "np": None, "ok": 0.5, "n": 3,
                                    "flag": True, "arr": [1.0, None],
                                    "nested": [[1.0, None]], "4": "key"}


def test_finite_values_are_written_unchanged() -> None:
    values = [0.1, 1e-300, 6.02214076e23, -2.5, 0]
    assert _strict(dumps(values)) == values


def test_objects_json_cannot_hold_still_fail() -> None:
    with pytest.raises(TypeError):
        dumps({"c": 1j})
