"""The ``--json`` output of the commands: strict JSON, never a ``NaN`` or ``Infinity`` token
(which ``json.dumps`` writes by default and no JSON parser but Python's reads). A value that
is not finite is missing and written as ``null``; numpy scalars and arrays become numbers and
lists."""
from __future__ import annotations

import json
import math
from typing import Any

import numpy as np


def finite(obj: Any) -> Any:
    """A copy of ``obj`` (dicts, lists, tuples, numpy values) with every non-finite float
    replaced by None."""
    if isinstance(obj, dict):
        return {str(k): finite(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [finite(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return finite(obj.tolist())
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def dumps(obj: Any, **kwargs: Any) -> str:
    """``json.dumps`` of :func:`finite` ``(obj)``, refusing NaN/Infinity (``allow_nan=False``)."""
    return json.dumps(finite(obj), allow_nan=False, **kwargs)
