"""``hypate flutter PANEL.toml``: panel flutter boundary by linearized stability analysis."""
from __future__ import annotations

import argparse

from hypate.scaling.cli.arguments import finite, integer_in, positive
from hypate.scaling.cli.commands import HELP
from hypate.scaling.cli.jsonout import dumps
from hypate.scaling.workflow.vocabulary.shipped import resolve
from hypate.solvers.config import load_panel
from hypate.solvers.coupling.flutter import FlutterAnalysis
from hypate.solvers.errors import InputError

#: Guards against typos that would run for days: points of the lambda sweep, S2 runs of the
#: LCO curve and their length in first-mode periods.
MAX_SWEEP_POINTS = 100_000
MAX_LCO_POINTS = 100
MAX_LCO_PERIODS = 10_000.0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "flutter", help=HELP["flutter"],
        description="Sweep the nondimensional dynamic pressure lambda = gamma p M a^3 / D "
        "(Eq. 6.2a) with piston theory or a fluid ROM for the panel uniformly heated to "
        "R * T_cr and report the flutter onset and the divergence range (LSA, Eqs. "
        "5.33-5.37).")
    p.add_argument("panel", help="panel TOML file")
    p.add_argument("--aero", default="pt1",
                   help="pt1 or pt (piston theory order), or rom:PATH (a fluid ROM file, "
                   "e.g. rom:studies/rom/rom_2d_panel_cfd.npz: its reference free stream at "
                   "each lambda's pressure)")
    p.add_argument("--delta-T-ratio", type=float, default=0.0, dest="ratio",
                   help="uniform temperature rise as a multiple of T_cr (default 0)")
    p.add_argument("--lambda-max", type=float, default=1000.0, help="end of the sweep")
    p.add_argument("--step", type=float, default=10.0, help="sweep step in lambda")
    p.add_argument("--mach", type=float, default=None,
                   help="Mach number (piston theory: enters the aerodynamic damping only; "
                   "default 10; a ROM: its reference Mach number)")
    p.add_argument("--time-domain", action="store_true", dest="time_domain",
                   help="also run S2 transients for the LCO amplitude curve and its onset")
    p.add_argument("--lco-points", type=int, default=3,
                   help="S2 runs of the LCO curve (with --time-domain; default 3)")
    p.add_argument("--lco-span", type=float, default=0.02,
                   help="the runs cover lambda_cr * [1 + span/4, 1 + span] (default 0.02: "
                   "the Hopf fit needs runs just above the onset)")
    p.add_argument("--lco-periods", type=float, default=40.0,
                   help="run length in first-mode periods (default 40)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if positive(args.lambda_max, "--lambda-max") / positive(args.step, "--step") \
            > MAX_SWEEP_POINTS:
        raise InputError("--step", f"gives more than {MAX_SWEEP_POINTS} sweep points up to "
                         f"--lambda-max {args.lambda_max:g}; use a larger step")
    if args.mach is not None and not finite(args.mach, "--mach") > 1.0:
        raise InputError("--mach", f"must be > 1; got {args.mach:g}")
    if args.time_domain:  # checked before the sweep, which takes a while
        integer_in(args.lco_points, "--lco-points", 2, MAX_LCO_POINTS)
        positive(args.lco_span, "--lco-span")
        if positive(args.lco_periods, "--lco-periods") > MAX_LCO_PERIODS:
            raise InputError("--lco-periods", f"must be <= {MAX_LCO_PERIODS:g} (each S2 run "
                             "lasts that many first-mode periods)")
    panel = load_panel(resolve(args.panel, "case"))
    fa = FlutterAnalysis(panel, args.ratio, args.aero, mach=args.mach)
    res = fa.sweep(lam_max=args.lambda_max, step=args.step)
    data = res.to_dict()
    if args.time_domain:
        if res.lambda_cr is None:
            data["lco_onset"], data["lco_curve"] = None, []
        else:
            lco = fa.lco_onset(res.lambda_cr * (1.0 + 0.25 * args.lco_span),
                               res.lambda_cr * (1.0 + args.lco_span), n=args.lco_points,
                               periods=args.lco_periods)
            data["lco_onset"] = lco.lambda_onset
            data["lco_curve"] = [[lam, amp] for lam, amp in lco.curve]
    if args.json:
        print(dumps(data))
        return 0
    if res.lambda_cr is None:
        print(f"no flutter up to lambda = {args.lambda_max:g}")
    else:
        print(f"flutter onset lambda_cr = {res.lambda_cr:.2f} (omega / omega_1 = "
              f"{res.frequency_ratio:.3f})")
    if res.divergence_range is not None:
        lo, hi = res.divergence_range
        print(f"flat state divergent (thermally buckled) for lambda in [{lo:g}, {hi:.2f}]")
    if args.time_domain:
        onset = data["lco_onset"]
        print("time-domain LCO onset: " + ("none" if onset is None else f"{onset:.2f}"))
        for lam, amp in data["lco_curve"]:
            print(f"  lambda = {lam:8.2f}   LCO amplitude w/h = {amp:.4f}")
    print(f"delta T = {res.delta_T:.4g} K (T_cr = {res.critical_delta_T:.4g} K)")
    return 0
