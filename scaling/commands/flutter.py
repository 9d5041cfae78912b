"""``hypate flutter PANEL.toml``: panel flutter boundary by linearized stability analysis."""
from __future__ import annotations

import argparse
import json

from solvers.config import load_panel
from solvers.errors import InputError
from solvers.flutter import FlutterAnalysis


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "flutter", help="flutter boundary lambda_cr by a lambda sweep with LSA (Sec. 7.2.3)",
        description="Sweep the nondimensional dynamic pressure lambda = gamma p M a^3 / D "
        "(Eq. 6.2a) with piston theory for the panel uniformly heated to R * T_cr and report "
        "the flutter onset and the divergence range (LSA, Eqs. 5.33-5.37).")
    p.add_argument("panel", help="panel TOML file")
    p.add_argument("--aero", default="pt1", choices=("pt1", "pt"), help="piston theory order")
    p.add_argument("--delta-T-ratio", type=float, default=0.0, dest="ratio",
                   help="uniform temperature rise as a multiple of T_cr (default 0)")
    p.add_argument("--lambda-max", type=float, default=1000.0, help="end of the sweep")
    p.add_argument("--step", type=float, default=10.0, help="sweep step in lambda")
    p.add_argument("--mach", type=float, default=10.0,
                   help="Mach number (enters the aerodynamic damping only)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if not (args.lambda_max > 0 and args.step > 0):
        raise InputError("--lambda-max/--step", "must be > 0")
    if args.mach <= 1.0:
        raise InputError("--mach", "must be > 1")
    panel = load_panel(args.panel)
    fa = FlutterAnalysis(panel, args.ratio, args.aero, mach=args.mach)
    res = fa.sweep(lam_max=args.lambda_max, step=args.step)
    data = res.to_dict()
    if args.json:
        print(json.dumps(data))
        return 0
    if res.lambda_cr is None:
        print(f"no flutter up to lambda = {args.lambda_max:g}")
    else:
        print(f"flutter onset lambda_cr = {res.lambda_cr:.2f} (omega / omega_1 = "
              f"{res.frequency_ratio:.3f})")
    if res.divergence_range is not None:
        lo, hi = res.divergence_range
        print(f"flat state divergent (thermally buckled) for lambda in [{lo:g}, {hi:.2f}]")
    print(f"delta T = {res.delta_T:.4g} K (T_cr = {res.critical_delta_T:.4g} K)")
    return 0
