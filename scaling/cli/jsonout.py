"""The ``--json`` output of the commands: strict JSON, never a ``NaN`` or ``Infinity`` token
(which ``json.dumps`` writes by default and no JSON parser but Python's reads). A value that
is not finite is missing and written as ``null``; numpy scalars and arrays become numbers and
lists."""
from __future__ import annotations

import json
from typing import Any

from hypate.scaling.workflow.campaigns.rundir import finite


def dumps(obj: Any, **kwargs: Any) -> str:
    """``json.dumps`` of :func:`finite` ``(obj)``, refusing NaN/Infinity (``allow_nan=False``)."""
    return json.dumps(finite(obj), allow_nan=False, **kwargs)


__all__ = ["dumps", "finite"]
