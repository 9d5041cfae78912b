"""Reading a measured model test (``hypate predict --measured FILE``): the file contract and
its checks, each error naming its column (:func:`read_measured`).

The measured file
-----------------
A CSV table (pandas; ``#`` starts a comment, so a file may carry its provenance in comment
lines). The header names every column as ``NAME [UNIT]``: a name of :data:`COLUMNS`, a
space (optional), the unit in square brackets; whitespace around the cell is ignored, names
and units are case-sensitive. Accepted (:data:`UNITS`):

==========================  ============  ==================================================
column                      units         meaning
==========================  ============  ==================================================
``time``                    ``s``, ``ms`` model time since the start of the test (required;
                                          strictly increasing, within the model's test span)
``center_deflection``       ``m``, ``mm`` deflection at the panel centre
``mean_temperature``        ``K``,        volume-mean panel temperature
                            ``degC``
==========================  ============  ==================================================

``time`` and at least one of the two histories are required. Any other column, a unit not
listed, a name given twice, an empty cell, a text that is not a number, NaN or infinity, a
temperature below absolute zero, a time that does not increase and a time outside
``[0, t_end]`` of the model's test (the design point's simulated span) each raise
:class:`~hypate.solvers.errors.InputError` (field ``measured``) naming the column.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from hypate.solvers.errors import InputError

#: The field of every error about the measured file (the CLI's ``--measured``).
FIELD = "measured"
#: Accepted columns and their SI unit.
COLUMNS = {"time": "s", "center_deflection": "m", "mean_temperature": "K"}
#: The measured histories (every column but ``time``).
HISTORIES = ("center_deflection", "mean_temperature")
#: Accepted units per column: ``SI value = factor * value + offset``.
UNITS: dict[str, dict[str, tuple[float, float]]] = {
    "time": {"s": (1.0, 0.0), "ms": (1e-3, 0.0)},
    "center_deflection": {"m": (1.0, 0.0), "mm": (1e-3, 0.0)},
    "mean_temperature": {"K": (1.0, 0.0), "degC": (1.0, 273.15)},
}
#: A header cell: ``NAME [UNIT]``.
HEADER = re.compile(r"^\s*(?P<name>[^\[\]]*?)\s*\[\s*(?P<unit>[^\[\]]*?)\s*\]\s*$")


def _allowed(name: str) -> str:
    return f"{name} [{'|'.join(UNITS[name])}]"


ACCEPTED = ", ".join(_allowed(n) for n in COLUMNS)


# -- the measured file --------------------------------------------------------------------
@dataclass(frozen=True)
class Measured:
    """A measured model test in SI units.

    Attributes
    ----------
    path : Path
    time : ndarray of shape (n,)
        Model time (s), strictly increasing.
    histories : dict
        ``"center_deflection"`` (m) and/or ``"mean_temperature"`` (K), each (n,).
    headers : dict
        Column name -> the header cell as written (for messages).
    """

    path: Path
    time: np.ndarray
    histories: dict[str, np.ndarray]
    headers: dict[str, str]


def column_error(path: Path, header: str, message: str) -> InputError:
    """The error about one column of the measured file (field ``measured``)."""
    return InputError(FIELD, f"{path}, column '{header}': {message}")


def _parse_header(path: Path, cells: list[str]) -> dict[str, tuple[int, str, str]]:
    """``name -> (position, unit, header cell)`` of a header row (every rule of the module
    docstring about names and units)."""
    out: dict[str, tuple[int, str, str]] = {}
    for i, cell in enumerate(cells):
        text = cell.strip()
        match = HEADER.match(cell)
        if match is None:
            bare = text if text in COLUMNS else None
            hint = (f"give its unit, e.g. '{_allowed(bare)}'" if bare is not None
                    else f"write NAME [UNIT], one of {ACCEPTED}")
            raise column_error(path, text, f"not of the form NAME [UNIT]; {hint}")
        name, unit = match["name"], match["unit"]
        if name not in COLUMNS:
            raise column_error(path, text, f"unknown column {name!r}; accepted: {ACCEPTED}")
        if unit not in UNITS[name]:
            raise column_error(path, text, f"unit {unit!r} is not accepted for {name}; use "
                                f"{' or '.join(UNITS[name])}")
        if name in out:
            raise column_error(path, text, f"{name} is given twice (also as "
                                f"'{out[name][2]}')")
        out[name] = (i, unit, text)
    if "time" not in out:
        raise column_error(path, _allowed("time"), "missing (required)")
    if not any(h in out for h in HISTORIES):
        raise column_error(path, " or ".join(_allowed(h) for h in HISTORIES),
                            "missing: the file needs at least one measured history")
    return out


def _values(path: Path, header: str, raw: pd.Series) -> np.ndarray:
    """A column's numbers; the first empty, non-numeric or non-finite cell is an error."""
    text = raw.fillna("").astype(str).str.strip()
    values = pd.to_numeric(text, errors="coerce").to_numpy(dtype=float)
    bad = ~np.isfinite(values)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        cell = text.iloc[i]
        what = ("empty (a missing value)" if cell == "" else
                "NaN" if np.isnan(values[i]) and cell.lower() in ("nan", "na", "n/a", "null")
                else "not finite" if cell.lower().lstrip("+-") in ("inf", "infinity")
                else f"{cell!r} is not a number")
        raise column_error(path, header, f"data row {i + 1}: {what}")
    return values


def read_measured(path: str | Path) -> Measured:
    """Read and check a measured model test (header contract: module docstring).

    Parameters
    ----------
    path : path
        CSV file.

    Returns
    -------
    Measured
        In SI units (s, m, K).

    Raises
    ------
    InputError
        Field ``measured``: the file is missing or empty, a column is missing, unknown,
        given twice or has a unit not accepted, a value is missing or not a finite number,
        the time does not increase strictly, a temperature is below 0 K.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(FIELD, f"{path}: file not found")
    try:
        table = pd.read_csv(path, header=None, dtype=str, keep_default_na=False,
                            comment="#", skip_blank_lines=True, encoding="utf-8-sig")
    except pd.errors.EmptyDataError:
        raise InputError(FIELD, f"{path}: empty file (no header, no data)") from None
    except (pd.errors.ParserError, UnicodeDecodeError, ValueError) as exc:
        raise InputError(FIELD, f"{path}: not a CSV table ({str(exc).strip()})") from None
    cells = [str(c) for c in table.iloc[0]]
    columns = _parse_header(path, cells)
    data = table.iloc[1:]
    if data.empty:
        raise InputError(FIELD, f"{path}: no data rows below the header")
    out: dict[str, np.ndarray] = {}
    for name, (i, unit, header) in columns.items():
        factor, offset = UNITS[name][unit]
        out[name] = factor * _values(path, header, data.iloc[:, i]) + offset
    headers = {name: header for name, (_, _, header) in columns.items()}
    time = out.pop("time")
    steps = np.diff(time)
    if np.any(steps <= 0.0):
        i = int(np.flatnonzero(steps <= 0.0)[0])
        raise column_error(path, headers["time"], f"must increase strictly; data row {i + 2}"
                            f" ({time[i + 1]:.9g} s) does not follow data row {i + 1} "
                            f"({time[i]:.9g} s)")
    if "mean_temperature" in out and np.any(out["mean_temperature"] <= 0.0):
        i = int(np.flatnonzero(out["mean_temperature"] <= 0.0)[0])
        raise column_error(path, headers["mean_temperature"], f"data row {i + 1}: "
                            f"{out['mean_temperature'][i]:.6g} K is not above absolute zero")
    return Measured(path=path, time=time, histories=out, headers=headers)
