"""Wind-tunnel operating envelopes (Table 9.6) and model design-variable bounds (Tables 9.2, 9.7).

The envelopes and the named bound sets are data, shipped in ``scaling/data/tunnels.toml``
in SI units (Pa, K, m, s). A :class:`TunnelEnvelope` is the box of attainable tunnel
settings: a continuous Mach range or a list of discrete Mach numbers (one nozzle each,
handled by exhaustive search, Eq. 6.7), and ranges of the stagnation pressure ``p0`` and
temperature ``T0`` within which every combination is assumed attainable (Sec. 9.2.1.2).

User envelopes come from a TOML table with the same keys as the shipped file::

    [tunnel]
    name = "my_tunnel"          # optional
    mach = [5.0, 7.0]           # or mach_values = [6.0]   (or mach = 6.0: one value)
    p0 = [1.0e6, 8.0e6]         # Pa
    T0 = [1600.0, 1900.0]       # K
    test_section = [1.07, 3.05] # optional: nozzle/test-section diameter and length, m
    run_time = [42.0, 294.0]    # optional: s

Every error is an :class:`~solvers.errors.InputError` naming the offending key
(``tunnel.p0``), e.g. for reversed bounds.

Design-variable names used here and in
:func:`hypate.scaling.workflow.vocabulary.configuration.apply_design`: ``M``, ``p0``, ``T0``,
``p_inf``, ``T_inf``, ``L``, ``width``, ``L_le``, ``h``, ``h[k]``, ``emissivity``, ``T_rad``,
``p_ext``, ``q_ext``, ``delta_T``, ``time``, ``T_w`` (see
:data:`DESIGN_VARIABLES`).
"""
from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cache, lru_cache
from importlib import resources
from pathlib import Path
from typing import Any

from hypate.scaling.workflow.vocabulary.variables import DESIGN_VARIABLES
from hypate.solvers.config import read_toml
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition

__all__ = [
    "TunnelEnvelope",
    "bound_set",
    "bound_set_names",
    "envelope_from_table",
    "load_tunnels",
    "resolve_tunnel",
    "tunnel",
    "tunnel_names",
]

Bounds = tuple[float, float]


_ENVELOPE_KEYS = ("name", "description", "mach", "mach_values", "p0", "T0", "test_section",
                  "run_time")


def _is_number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _check_pair(value: Any, field: str, unit: str, *, positive: bool = True) -> Bounds:
    """A ``[lo, hi]`` pair of finite numbers with ``lo <= hi`` (and ``lo > 0`` if positive)."""
    if (not isinstance(value, (list, tuple)) or len(value) != 2
            or not all(_is_number(v) for v in value)):
        raise InputError(field, f"must be a pair [lower, upper] of numbers ({unit}); "
                         f"got {value!r}")
    lo, hi = float(value[0]), float(value[1])
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise InputError(field, f"bounds must be finite numbers ({unit}); got [{lo:g}, {hi:g}]")
    if positive and lo <= 0.0:
        raise InputError(field, f"lower bound must be > 0 ({unit}); got {lo:g}")
    if lo > hi:
        raise InputError(field, f"reversed bounds: lower {lo:g} exceeds upper {hi:g} ({unit})")
    return lo, hi


@dataclass(frozen=True)
class TunnelEnvelope:
    """Operating envelope of a hypersonic wind tunnel (Table 9.6), SI units.

    Attributes
    ----------
    name : str
    p0 : tuple of float
        Stagnation-pressure range ``(lower, upper)``, Pa.
    T0 : tuple of float
        Stagnation-temperature range ``(lower, upper)``, K.
    mach : tuple of float or None
        Continuous Mach range ``(lower, upper)``; ``None`` for a discrete tunnel.
    mach_values : tuple of float
        Discrete Mach numbers (one per nozzle); empty for a continuous range.
    test_section : tuple of float or None
        ``(diameter, length)`` of the test section, m (upper limits of the model size).
    run_time : tuple of float or None
        Range of the run time, s (Sec. 9.2.1.2).
    description : str
    """

    name: str
    p0: Bounds
    T0: Bounds
    mach: Bounds | None = None
    mach_values: tuple[float, ...] = ()
    test_section: Bounds | None = None
    run_time: Bounds | None = None
    description: str = ""

    def __post_init__(self) -> None:
        where = f"tunnels.{self.name}"
        object.__setattr__(self, "p0", _check_pair(self.p0, f"{where}.p0", "Pa"))
        object.__setattr__(self, "T0", _check_pair(self.T0, f"{where}.T0", "K"))
        if (self.mach is None) == (not self.mach_values):
            raise InputError(f"{where}.mach", "give exactly one of a Mach range 'mach' or a "
                             "list of discrete 'mach_values'")
        if self.mach is not None:
            lo, hi = _check_pair(self.mach, f"{where}.mach", "-")
            if lo <= 1.0:
                raise InputError(f"{where}.mach", f"must be > 1 (hypersonic tunnel); got {lo:g}")
            object.__setattr__(self, "mach", (lo, hi))
        else:
            values = tuple(float(m) for m in self.mach_values)
            if any(not (math.isfinite(m) and m > 1.0) for m in values):
                raise InputError(f"{where}.mach_values", f"each Mach number must be > 1; got "
                                 f"{list(values)}")
            object.__setattr__(self, "mach_values", tuple(sorted(set(values))))
        if self.test_section is not None:
            object.__setattr__(self, "test_section", _check_pair(
                self.test_section, f"{where}.test_section", "m"))
        if self.run_time is not None:
            object.__setattr__(self, "run_time", _check_pair(
                self.run_time, f"{where}.run_time", "s"))

    # -- queries ------------------------------------------------------------------------
    @property
    def is_discrete(self) -> bool:
        """True when the Mach number is a discrete choice (one nozzle per value)."""
        return self.mach is None

    @property
    def mach_bounds(self) -> Bounds:
        """``(lower, upper)`` Mach number (the extreme nozzles of a discrete tunnel)."""
        if self.mach is not None:
            return self.mach
        return (self.mach_values[0], self.mach_values[-1])

    def bounds(self) -> dict[str, Bounds]:
        """Continuous design-variable bounds of the tunnel setting.

        Returns
        -------
        dict
            ``{"M": (lo, hi)}`` for a continuous Mach range (omitted when discrete), then
            ``{"p0": (lo, hi), "T0": (lo, hi)}`` (Pa, K).
        """
        out: dict[str, Bounds] = {}
        if self.mach is not None:
            out["M"] = self.mach
        out["p0"] = self.p0
        out["T0"] = self.T0
        return out

    def contains(self, mach: float, p0: float, T0: float, rtol: float = 1e-9) -> bool:
        """Whether the setting ``(mach, p0, T0)`` is inside the envelope (relative slack
        ``rtol`` on every bound)."""
        def inside(x: float, b: Bounds) -> bool:
            return b[0] * (1.0 - rtol) <= x <= b[1] * (1.0 + rtol)

        if self.mach is not None:
            ok_mach = inside(mach, self.mach)
        else:
            ok_mach = any(abs(mach - m) <= rtol * m for m in self.mach_values)
        return ok_mach and inside(p0, self.p0) and inside(T0, self.T0)

    def flow(self, mach: float, p0: float, T0: float, *, check: bool = True) -> FlowCondition:
        """The free stream of the setting ``(mach, p0, T0)`` (isentropic nozzle).

        Raises
        ------
        InputError
            If ``check`` and the setting is outside the envelope.
        """
        if check and not self.contains(mach, p0, T0):
            raise InputError(f"tunnels.{self.name}", f"setting M = {mach:g}, p0 = {p0:g} Pa, "
                             f"T0 = {T0:g} K is outside the envelope {self.describe()}")
        return FlowCondition.from_stagnation(mach, p0, T0)

    def core_length(self, mach: float, width: float) -> float | None:
        """Longest flat-plate model (leading edge at the nozzle exit plane, aligned with the
        flow, ``width`` m across) inside the uniform core of the free jet, m; None without a
        ``test_section``.

        The core is the test rhombus bounded by the Mach lines from the nozzle lip
        (half-angle ``mu = asin(1 / M)``): at ``x`` downstream of the exit it is
        ``D - 2 x tan(mu)`` wide, so the plate's trailing corners stay inside up to
        ``x = (D - width) / (2 tan mu)``; never beyond the test section's length.
        """
        if self.test_section is None:
            return None
        diameter, length = self.test_section
        mu = math.asin(1.0 / float(mach))
        return max(0.0, min(length, (diameter - float(width)) / (2.0 * math.tan(mu))))

    def run_time_at(self, mach: float, p0: float, T0: float, gamma: float = 1.4
                    ) -> float | None:
        """Run time (s) of the tunnel at the setting ``(M, p0, T0)``; None without a
        ``run_time`` range.

        A blow-down tunnel empties a fixed store: the run lasts inversely as long as the mass
        flow of its choked throat, ``mdot ~ p0 / sqrt(T0) * A*/A_exit(M)`` (the exit
        diameter fixed, isentropic area ratio). The stated range ``[t_lo, t_hi]`` is taken
        as the run at the envelope's smallest mass flow (``t_hi``) and the floor no setting
        goes below (``t_lo``): ``t = clip(t_hi mdot_min / mdot, t_lo, t_hi)``.
        """
        if self.run_time is None:
            return None
        t_lo, t_hi = self.run_time

        def throat_ratio(m: float) -> float:  # A*/A of an isentropic nozzle at exit Mach m
            g = gamma
            return m * ((1.0 + 0.5 * (g - 1.0) * m * m) / (0.5 * (g + 1.0))) ** (
                -(g + 1.0) / (2.0 * (g - 1.0)))

        def mass_flow(m: float, p: float, T: float) -> float:
            return p / math.sqrt(T) * throat_ratio(m)

        m_hi = self.mach_bounds[1]  # A*/A falls with M: the smallest flow at the top Mach
        if self.mach is None:  # one nozzle per value: the flow of the nozzle in use
            m_hi = min(self.mach_values, key=lambda v: abs(v - float(mach)))
        low = mass_flow(m_hi, self.p0[0], self.T0[1])
        return float(min(t_hi, max(t_lo, t_hi * low / mass_flow(float(mach), p0, T0))))

    def describe(self) -> str:
        """One-line human-readable summary."""
        m = (f"M in [{self.mach[0]:g}, {self.mach[1]:g}]" if self.mach is not None
             else "M = " + "/".join(f"{v:g}" for v in self.mach_values))
        return (f"{self.name}: {m}, p0 in [{self.p0[0] / 1e6:g}, {self.p0[1] / 1e6:g}] MPa, "
                f"T0 in [{self.T0[0]:g}, {self.T0[1]:g}] K")

    def to_table(self) -> dict[str, Any]:
        """The TOML-table form (inverse of :func:`envelope_from_table`), SI units."""
        out: dict[str, Any] = {"name": self.name}
        if self.description:
            out["description"] = self.description
        if self.mach is not None:
            out["mach"] = list(self.mach)
        else:
            out["mach_values"] = list(self.mach_values)
        out["p0"] = list(self.p0)
        out["T0"] = list(self.T0)
        if self.test_section is not None:
            out["test_section"] = list(self.test_section)
        if self.run_time is not None:
            out["run_time"] = list(self.run_time)
        return out


# -- construction from tables -----------------------------------------------------------------
def envelope_from_table(table: Mapping[str, Any], name: str | None = None,
                        field: str = "tunnel") -> TunnelEnvelope:
    """Validate a user envelope table (keys as in ``scaling/data/tunnels.toml``).

    Parameters
    ----------
    table : mapping
        ``mach`` (``[lo, hi]`` or one number) or ``mach_values`` (list), ``p0`` ``[lo, hi]``
        (Pa), ``T0`` ``[lo, hi]`` (K), optional ``name``, ``description``, ``test_section``
        ``[diameter, length]`` (m), ``run_time`` ``[lo, hi]`` (s).
    name : str, optional
        Envelope name if the table has no ``name`` key (default ``"user"``).
    field : str
        Key path of the table, used in error messages (``tunnel.p0``).

    Raises
    ------
    InputError
        Naming the offending key: unknown keys, missing ``p0``/``T0``/Mach, non-numeric or
        non-positive values, reversed bounds.
    """
    if not isinstance(table, Mapping):
        raise InputError(field, "must be a table with mach/mach_values, p0 and T0")
    unknown = sorted(set(table) - set(_ENVELOPE_KEYS))
    if unknown:
        raise InputError(f"{field}.{unknown[0]}", "unknown key (allowed: "
                         f"{', '.join(_ENVELOPE_KEYS)})")
    for key in ("p0", "T0"):
        if key not in table:
            raise InputError(f"{field}.{key}", "required key is missing")
    p0 = _check_pair(table["p0"], f"{field}.p0", "Pa")
    T0 = _check_pair(table["T0"], f"{field}.T0", "K")
    has_range, has_values = "mach" in table, "mach_values" in table
    if has_range == has_values:
        raise InputError(f"{field}.mach", "give exactly one of 'mach' (a range [lo, hi] or one "
                         "number) or 'mach_values' (a list of discrete Mach numbers)")
    mach: Bounds | None = None
    values: tuple[float, ...] = ()
    if has_range:
        raw = table["mach"]
        if _is_number(raw):
            values = (float(raw),)
        else:
            mach = _check_pair(raw, f"{field}.mach", "-")
    else:
        raw = table["mach_values"]
        if (not isinstance(raw, (list, tuple)) or not raw
                or not all(_is_number(v) for v in raw)):
            raise InputError(f"{field}.mach_values", f"must be a non-empty list of Mach "
                             f"numbers; got {raw!r}")
        values = tuple(float(v) for v in raw)
    if mach is not None and mach[0] <= 1.0:
        raise InputError(f"{field}.mach", f"must be > 1 (hypersonic tunnel); got {mach[0]:g}")
    if any(not (math.isfinite(v) and v > 1.0) for v in values):
        raise InputError(f"{field}.{'mach' if has_range else 'mach_values'}",
                         f"each Mach number must be > 1; got {list(values)}")
    test_section = (_check_pair(table["test_section"], f"{field}.test_section", "m")
                    if "test_section" in table else None)
    run_time = (_check_pair(table["run_time"], f"{field}.run_time", "s")
                if "run_time" in table else None)
    env_name = table.get("name", name or "user")
    if not isinstance(env_name, str) or not env_name:
        raise InputError(f"{field}.name", "must be a non-empty string")
    description = table.get("description", "")
    if not isinstance(description, str):
        raise InputError(f"{field}.description", "must be a string")
    return TunnelEnvelope(name=env_name, p0=p0, T0=T0, mach=mach, mach_values=values,
                          test_section=test_section, run_time=run_time,
                          description=description)


@lru_cache(maxsize=1)
def _shipped() -> dict[str, Any]:
    path = resources.files("hypate.scaling").joinpath("data", "tunnels.toml")
    text = path.read_text(encoding="utf-8")
    return tomllib.loads(text)


@cache
def _shipped_envelope(name: str) -> TunnelEnvelope:
    return envelope_from_table(_shipped()["tunnels"][name], name=name, field=f"tunnels.{name}")


def tunnel_names() -> tuple[str, ...]:
    """Names of the shipped envelopes (``"ideal"``, ``"WT5"``, ``"WT6"``, ``"WT7"``)."""
    return tuple(_shipped()["tunnels"])


def tunnel(name: str) -> TunnelEnvelope:
    """A shipped envelope of Table 9.6 by name (case-insensitive).

    Raises
    ------
    InputError
        ``tunnel``: unknown name, listing the known ones.
    """
    names = tunnel_names()
    lookup = {n.lower(): n for n in names}
    key = lookup.get(str(name).lower())
    if key is None:
        raise InputError("tunnel", f"unknown tunnel {name!r}; shipped envelopes are "
                         f"{', '.join(names)} (or give a table with mach, p0, T0)")
    return _shipped_envelope(key)


def resolve_tunnel(spec: str | Mapping[str, Any], field: str = "tunnel") -> TunnelEnvelope:
    """A tunnel from a study entry: a shipped name, ``{name = "WT7"}``, or a full table.

    A table holding only ``name`` refers to a shipped envelope; any other table is a user
    envelope validated by :func:`envelope_from_table`.
    """
    if isinstance(spec, str):
        try:
            return tunnel(spec)
        except InputError as exc:
            raise InputError(field, exc.message) from None
    if isinstance(spec, Mapping) and set(spec) == {"name"}:
        try:
            return tunnel(spec["name"])
        except InputError as exc:
            raise InputError(f"{field}.name", exc.message) from None
    return envelope_from_table(spec, field=field)


def load_tunnels(path: str | Path) -> dict[str, TunnelEnvelope]:
    """User envelopes from a TOML file with ``[tunnels.NAME]`` tables (same keys as the
    shipped data file)."""

    data = read_toml(path)
    tables = data.get("tunnels")
    if not isinstance(tables, Mapping) or not tables:
        raise InputError("tunnels", f"{path}: no [tunnels.NAME] tables found")
    return {name: envelope_from_table(t, name=name, field=f"tunnels.{name}")
            for name, t in tables.items()}


# -- named design-variable bound sets ---------------------------------------------------------
def bound_set_names() -> tuple[str, ...]:
    """Names of the shipped bound sets: ``"table9_7"`` (Sec. 9.2), ``"table9_2"`` (Sec. 9.1)."""
    return tuple(_shipped()["bounds"])


def bound_set(name: str) -> dict[str, Bounds]:
    """A named default bound set ``{variable: (lower, upper)}`` in SI units.

    ``"table9_7"``: L [0.1, 0.5] m, L_le [0.1, 2.0] m, h [0.001, 0.01] m, emissivity
    [0.5, 1.0], T_rad [300, 2500] K (Table 9.7). ``"table9_2"``: h [0.2, 1.2] mm,
    p_inf [3, 11] kPa, delta_T [0.5, 4.5] K (Table 9.2).
    """
    sets = _shipped()["bounds"]
    if name not in sets:
        raise InputError("bounds", f"unknown bound set {name!r}; shipped sets are "
                         f"{', '.join(sets)}")
    return {var: _check_pair(pair, f"bounds.{name}.{var}", DESIGN_VARIABLES[var].unit)
            for var, pair in sets[name].items()}
