"""``hypate condition``: free-stream state from flight altitude or tunnel settings."""
from __future__ import annotations

import argparse

from hypate.scaling.cli.commands import HELP
from hypate.scaling.cli.jsonout import dumps
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition

#: The FlowCondition arguments, each given by the flag of its name.
FLOW_ARGUMENTS = ("mach", "altitude", "p0", "T0", "pressure", "temperature")

_LABELS = (("mach", "Mach number", "-"), ("pressure", "static pressure", "Pa"),
           ("temperature", "static temperature", "K"), ("density", "density", "kg/m^3"),
           ("velocity", "velocity", "m/s"), ("speed_of_sound", "speed of sound", "m/s"),
           ("dynamic_pressure", "dynamic pressure", "Pa"), ("viscosity", "viscosity", "Pa s"),
           ("reynolds_per_meter", "Reynolds number", "1/m"),
           ("stagnation_pressure", "stagnation pressure", "Pa"),
           ("stagnation_temperature", "stagnation temperature", "K"))


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "condition", help=HELP["condition"],
        description="Free-stream state of a calorically perfect gas: flight at a geometric "
        "altitude (1976 standard atmosphere), tunnel stagnation conditions (isentropic), or "
        "static pressure and temperature.")
    p.add_argument("--mach", type=float, required=True, help="free-stream Mach number (> 1)")
    p.add_argument("--altitude", type=float, help="geometric altitude (m)")
    p.add_argument("--p0", type=float, help="stagnation pressure (Pa), with --T0")
    p.add_argument("--T0", type=float, help="stagnation temperature (K), with --p0")
    p.add_argument("--pressure", type=float, help="static pressure (Pa), with --temperature")
    p.add_argument("--temperature", type=float, help="static temperature (K), with --pressure")
    p.add_argument("--json", action="store_true", help="print JSON")
    # FlowCondition names its arguments; the user typed flags
    p.set_defaults(func=run, field_flags={name: f"--{name}" for name in FLOW_ARGUMENTS})


def flow_from_args(args: argparse.Namespace) -> FlowCondition:
    """The FlowCondition named by exactly one of the three option groups."""
    groups = {"--altitude": args.altitude is not None,
              "--p0/--T0": args.p0 is not None or args.T0 is not None,
              "--pressure/--temperature": args.pressure is not None or args.temperature is not None}
    if sum(groups.values()) != 1:
        raise InputError("--altitude|--p0/--T0|--pressure/--temperature",
                         "give exactly one of --altitude, (--p0 and --T0), "
                         "(--pressure and --temperature)")
    if args.altitude is not None:
        return FlowCondition.from_altitude(args.mach, args.altitude)
    if groups["--p0/--T0"]:
        if args.p0 is None or args.T0 is None:
            raise InputError("--p0/--T0", "both --p0 and --T0 are required")
        return FlowCondition.from_stagnation(args.mach, args.p0, args.T0)
    if args.pressure is None or args.temperature is None:
        raise InputError("--pressure/--temperature",
                         "both --pressure and --temperature are required")
    return FlowCondition.from_static(args.mach, args.pressure, args.temperature)


def run(args: argparse.Namespace) -> int:
    flow = flow_from_args(args)
    data = flow.to_dict()
    if args.json:
        print(dumps(data, indent=2))
    else:
        for key, label, unit in _LABELS:
            print(f"{label:>24s}: {data[key]:.6g} {unit}")
    return 0
