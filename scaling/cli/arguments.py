"""Checks of the commands' option values, made before a command starts its work.

argparse's ``type=float`` takes ``nan`` and ``inf`` and ``type=int`` any integer; a command
passes each numeric option through :func:`finite`, :func:`positive` or :func:`integer_in`,
and each output option through :func:`output_file` or :func:`output_directory`, so a bad
value ends in one line naming the flag (``hypate: error: --mach: must be a finite number;
got nan``, exit code 2) and nothing is computed or half-written. Ranges that follow from a
command's physics stay with the command.
"""
from __future__ import annotations

import math
from pathlib import Path

from hypate.solvers.errors import InputError


def finite(value: float, flag: str) -> float:
    """``value`` if it is a finite number, else :class:`InputError` naming ``flag``."""
    if not math.isfinite(value):
        raise InputError(flag, f"must be a finite number; got {value:g}")
    return value


def positive(value: float, flag: str) -> float:
    """``value`` if it is a finite number > 0, else :class:`InputError` naming ``flag``."""
    if not (math.isfinite(value) and value > 0.0):
        raise InputError(flag, f"must be a finite number > 0; got {value:g}")
    return value


def integer_in(value: int, flag: str, low: int, high: int | None = None) -> int:
    """``value`` if ``low <= value <= high`` (``high=None``: no upper bound), else
    :class:`InputError` naming ``flag``."""
    if value < low or (high is not None and value > high):
        allowed = f">= {low}" if high is None else f"in [{low}, {high}]"
        raise InputError(flag, f"must be an integer {allowed}; got {value}")
    return value


def output_file(text: str, flag: str, *, make_folders: bool = False) -> Path:
    """``text`` as a file a command will write: not a directory, and its folder exists
    (``make_folders``: or can be made -- the nearest existing one is a directory; the
    command makes the rest when it writes). :class:`InputError` names ``flag``."""
    path = Path(text)
    if path.is_dir():
        raise InputError(flag, f"{path} is a directory; give a file name")
    if make_folders:
        existing = next(p for p in (path.parent, *path.parent.parents) if p.exists())
        if not existing.is_dir():
            raise InputError(flag, f"{existing} is not a directory")
    elif not path.parent.is_dir():
        raise InputError(flag, f"directory {path.parent} does not exist")
    return path


def output_directory(text: str, flag: str) -> Path:
    """``text`` as a directory a command will write into (created when missing): it is not
    an existing file (:class:`InputError` naming ``flag``)."""
    path = Path(text)
    if path.exists() and not path.is_dir():
        raise InputError(flag, f"{path} exists and is not a directory")
    return path
