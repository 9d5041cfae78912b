"""The report's one number formatter: plain numbers, errors J in percent, similarity ratios.

Every number the page or a figure prints goes through :func:`format_number` (plain values),
:func:`format_percent` (objectives J and relative differences, ``"8.84 %"``) or
:func:`format_difference` (a similarity parameter's model against its prototype: a
relative difference in percent near 1, the ratio ``"x13.2"`` far from it, because
"1.32e+03 %" reads worse than "13 times the prototype's value").
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["DASH", "RATIO_LIMITS", "format_number", "format_percent", "format_ratio",
           "format_difference", "percent"]

#: Text of a missing or non-finite value (HTML entity).
DASH = "&ndash;"
#: model/prototype ratios outside this interval are written as ratios ("x13.2", "x0.31"):
#: inside it the relative difference is at most 100 % and reads naturally in percent.
RATIO_LIMITS = (0.5, 2.0)


def _finite(value: Any) -> float | None:
    """``value`` as a finite float, or None (missing, NaN, not a number)."""
    if value is None or isinstance(value, (bool, np.bool_)):
        return None
    if not isinstance(value, (int, float, np.integer, np.floating)):
        return None
    v = float(value)
    return v if math.isfinite(v) else None


def percent(value: Any) -> Any:
    """A fraction (float or ndarray) in percent (the unit of J everywhere in the report)."""
    return 100.0 * value


def format_number(value: Any, digits: int = 4) -> str:
    """A plain number to ``digits`` significant digits; integers as they are; yes/no for
    booleans; :data:`DASH` for None/NaN. Anything else is returned as ``str`` (unescaped)."""
    if value is None:
        return DASH
    if isinstance(value, (bool, np.bool_)):
        return "yes" if value else "no"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        v = float(value)
        return f"{v:.{digits}g}" if math.isfinite(v) else DASH
    return str(value)


def format_percent(value: Any, digits: int = 3) -> str:
    """A fraction (J, relative difference) in percent: ``0.0884 -> "8.84 %"``."""
    v = _finite(value)
    return DASH if v is None else f"{percent(v):.{digits}g} %"


def format_ratio(ratio: Any, digits: int = 3) -> str:
    """A model/prototype ratio: ``13.2 -> "x13.2"``."""
    v = _finite(ratio)
    return DASH if v is None else f"x{v:.{digits}g}"


def format_difference(relative_difference: Any, prototype: Any = None,
                      model: Any = None) -> str:
    """A similarity parameter's mismatch: the relative difference in percent while the
    model/prototype ratio lies in :data:`RATIO_LIMITS`, else the ratio (``"x13.2"``).

    Parameters
    ----------
    relative_difference : float or None
        ``|model - prototype| / |prototype|``.
    prototype, model : float, optional
        The two values; without them (or with a zero prototype) the percent form is used.
    """
    p, m = _finite(prototype), _finite(model)
    if p is not None and m is not None and p != 0.0:
        ratio = m / p
        if not RATIO_LIMITS[0] <= ratio <= RATIO_LIMITS[1]:
            return format_ratio(ratio)
    return format_percent(relative_difference)
