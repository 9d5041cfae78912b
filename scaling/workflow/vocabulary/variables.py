"""THE design-variable table: every name a design, a what-if or a study may set, with its SI
unit, meaning, hard limits, whether a study may optimize it (Tables 6.1, 9.2, 9.7), where it
goes in a configuration and its analytical scaling law.

One row is the variable's one home:
:func:`hypate.scaling.workflow.vocabulary.configuration.apply_design` sets each row's value
into its :attr:`DesignVariable.target` (a loop over rows; the parts a target names compose as
the configuration module says),
:func:`~hypate.scaling.workflow.vocabulary.configuration.nominal_values` reads every target
back from a configuration (the nominal values of a robust study's scatter, the defaults of
recycled designs, the prototype's values of the laws), and the laws take the row's exponent. A
new continuous variable on an existing target part is one row here. A categorical variable
(``kind = "categorical"``) is a list of named values a study chooses among: its row names the
values it allows (``choices``; the material's are the study's material library) and the
configuration field a chosen value is set into
(:func:`~hypate.scaling.workflow.vocabulary.configuration.with_choice`); a new one on an
existing field is one row here too. The study schema, the tunnel bound sets, the what-if, the
report and the laws read this table and nothing else.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

Bounds = tuple[float, float]
#: A layer thickness ``h[k]`` (k = 0 at the bottom).
LAYER_PATTERN = re.compile(r"^h\[(\d+)\]$")
#: A control point ``T_rad[k]`` of a time-scheduled variable (k = 0 at t = 0).
SCHEDULE_PATTERN = re.compile(r"^(T_rad)\[(\d+)\]$")
#: Variables a study may schedule over nondimensional time (``[variables] NAME = { schedule
#: = n, range = [lo, hi], shape = ... }``): the radiant heater (Sec. 9.2.3 Case 2).
SCHEDULABLE: tuple[str, ...] = ("T_rad",)
#: Fewest and most control points of a schedule.
SCHEDULE_POINTS: tuple[int, int] = (2, 12)


@dataclass(frozen=True)
class DesignVariable:
    """One design variable.

    Attributes
    ----------
    name, unit, description : str
    limits : (float, float) or None
        Manufacturing / facility limits no design may leave (Table 9.7 and physics).
    optimizable : bool
        Whether a study's ``[variables]`` may list it.
    target : tuple of str
        Where the value goes in a configuration: a part (``"panel"``, ``"flow"``,
        ``"simulation"``, ``"temperatures"``, ``"configuration"``) and its field(s), e.g.
        ``("flow", "stagnation_pressure")``; a categorical variable's chosen value goes
        there too (``("panel", "material")``: every layer's material); empty for the names
        set otherwise (``h[k]``, ``T_rad[k]``).
    check : {"positive", "fraction", "real"}
        What a value must be: positive and finite, in [0, 1], or any number.
    exponent : float or None
        Analytical exponent k of the scaling law ``value ~ xi^k`` (laws; module table of
        :mod:`hypate.scaling.workflow.campaigns.laws`); None: no law.
    coefficient : {"prototype", "analytical"} or None
        The analytical law's coefficient: the prototype's own value (read from its
        configuration), Eq. 9.2's (computed by the laws), or none.
    kind : {"continuous", "categorical"}
        A number, or one of a study's listed values (``[variables] NAME = ["a", "b"]``; a
        design vector holds its level ``0 .. k-1``, no scaling law).
    choices : tuple of str
        The values a categorical variable allows, each set into the target as it is
        (empty: the material, whose values are the study's materials by name).
    """

    name: str
    unit: str
    description: str
    limits: Bounds | None = None
    optimizable: bool = False
    target: tuple[str, ...] = ()
    check: str = "positive"
    exponent: float | None = None
    coefficient: str | None = None
    kind: str = "continuous"
    choices: tuple[str, ...] = ()


DESIGN_VARIABLES: dict[str, DesignVariable] = {v.name: v for v in (
    DesignVariable("M", "-", "free-stream Mach number (continuous only in an 'ideal' tunnel)",
                   (1.0001, 30.0), True, ("flow", "mach"), "real", 0.0, "prototype"),
    DesignVariable("p0", "Pa", "tunnel stagnation pressure (Table 9.6)", (1.0, 1e9), True,
                   ("flow", "stagnation_pressure"), "real", 0.0, "prototype"),
    DesignVariable("T0", "K", "tunnel stagnation temperature (Table 9.6)", (1.0, 1e4), True,
                   ("flow", "stagnation_temperature"), "real", 0.0, "prototype"),
    DesignVariable("p_inf", "Pa", "free-stream static pressure (Table 9.2)", (1e-3, 1e7), True,
                   ("flow", "pressure"), "real", 0.0, "analytical"),
    DesignVariable("T_inf", "K", "free-stream static temperature", (1.0, 5000.0), True,
                   ("flow", "temperature"), "real", 0.0, "prototype"),
    DesignVariable("L", "m", "panel length a (width scaled with it: same aspect ratio)",
                   (0.01, 5.0), True, ("panel", "length"), "real", -1.0, "prototype"),
    DesignVariable("width", "m", "panel width b", target=("panel", "width"), check="real"),
    DesignVariable("L_le", "m", "leading-edge (rigid wall) length ahead of the panel",
                   (0.0, 10.0), True, ("panel", "leading_edge_length"), "real", -1.0,
                   "prototype"),
    DesignVariable("h", "m", "total thickness (all layers scaled proportionally)",
                   (1e-4, 0.05), True, ("panel", "thickness"), "real", -1.0, "prototype"),
    DesignVariable("h[k]", "m", "thickness of layer k (bottom = 0)"),
    DesignVariable("emissivity", "-", "upper-surface emissivity of the model", (0.0, 1.0), True,
                   ("panel", "emissivity"), "fraction", 0.0, "prototype"),
    DesignVariable("T_rad", "K", "radiant heater temperature (incomplete testing)",
                   (1.0, 5000.0), True, ("simulation", "radiation_temperature"), "positive",
                   0.0),
    DesignVariable("T_rad[k]", "K", "radiant heater temperature at control point k of a "
                   "schedule: nondimensional time k/(n-1) of the test, linear in between"),
    DesignVariable("p_ext", "Pa", "external (cavity) pressure (incomplete testing)",
                   (-1e7, 1e7), True, ("simulation", "external_pressure"), "real", 0.0),
    DesignVariable("q_ext", "W/m^2", "external heat flux (incomplete testing)", (-1e7, 1e7), True,
                   ("simulation", "external_heat_flux"), "real"),
    DesignVariable("delta_T", "K", "uniform temperature rise (Sec. 9.1)", (1e-6, 2000.0), True,
                   ("configuration", "delta_T"), "positive", 0.0, "analytical"),
    DesignVariable("time", "s", "reference time (time step or duration)",
                   target=("configuration", "time")),
    DesignVariable("T_w", "K", "reference wall temperature; T_S = T_T = T_w (Eq. 9.7)",
                   target=("temperatures", "wall", "structural", "thermal")),
    DesignVariable("material", "-", "model material, categorical: a [variables] list of "
                   "names; a design vector holds its level 0 .. k-1", None, True,
                   ("panel", "material"), kind="categorical"),
    DesignVariable("boundary", "-", "the model's edge support in the tunnel fixture "
                   "(the Sec. 9.2 prototypes are simply supported, Table 7.2's panel clamped), "
                   "categorical", None, True, ("panel", "boundary"),
                   kind="categorical", choices=("simply_supported", "clamped")),
)}

#: Names a study may optimize, in table order.
OPTIMIZABLE: tuple[str, ...] = tuple(n for n, v in DESIGN_VARIABLES.items() if v.optimizable)
#: Categorical variables: a design vector holds the level number ``0 .. k-1`` of one of
#: the study's listed values (``[variables] material = ["ti6242", "inconel718"]``); the
#: scaling problem sets the chosen value into the model (``with_choice``), never
#: ``apply_design``.
CATEGORICAL: tuple[str, ...] = tuple(n for n, v in DESIGN_VARIABLES.items()
                                     if v.kind == "categorical")
#: Hard limits by name (the optimizable variables).
HARD_LIMITS: dict[str, Bounds] = {n: v.limits for n, v in DESIGN_VARIABLES.items()
                                  if v.limits is not None}


def is_design_variable(name: str) -> bool:
    """Whether ``name`` is in the table (a layer thickness ``h[k]`` and a schedule's control
    point ``T_rad[k]`` included)."""
    return (name in DESIGN_VARIABLES or LAYER_PATTERN.match(name) is not None
            or SCHEDULE_PATTERN.match(name) is not None)


def schedule_point(name: str) -> tuple[str, int] | None:
    """``("T_rad", k)`` for a schedule's control point ``"T_rad[k]"``, else None."""
    m = SCHEDULE_PATTERN.match(name)
    return None if m is None else (m.group(1), int(m.group(2)))


def schedule_names(name: str, points: int) -> list[str]:
    """The control-point variables ``NAME[0] .. NAME[points - 1]`` of a schedule."""
    return [f"{name}[{k}]" for k in range(points)]


def base_name(name: str) -> str:
    """The table entry a name stands for: ``"T_rad"`` for ``"T_rad[2]"``, ``"h[k]"`` for
    ``"h[1]"``, the name itself otherwise."""
    point = schedule_point(name)
    if point is not None:
        return point[0]
    return "h[k]" if LAYER_PATTERN.match(name) else name


def variable_unit(name: str) -> str:
    """SI unit of a design variable (``"-"`` when dimensionless or unknown)."""
    var = DESIGN_VARIABLES.get(base_name(name))
    return var.unit if var is not None else "-"
