"""``hypate simulate CASE.toml``: one coupled aerothermoelastic run."""
from __future__ import annotations

import argparse
import sys

from hypate.scaling.cli.arguments import output_directory
from hypate.scaling.cli.commands import HELP
from hypate.scaling.cli.jsonout import dumps
from hypate.scaling.workflow.vocabulary.shipped import resolve
from hypate.solvers.config import load_case
from hypate.solvers.coupling.run import simulate
from hypate.solvers.errors import InputError
from hypate.solvers.numerics.files import ensure_directory, write_text
from tqdm import tqdm


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("simulate", help=HELP["simulate"],
                       description="Run the case's [simulation] (scheme tc: tightly coupled "
                       "quasi-steady with LSA each step; s1/s2: loosely coupled transient).")
    p.add_argument("case", help="case TOML file with [panel], [flow] and [simulation]")
    p.add_argument("--out", help="directory for response.npz and summary.json")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    case = load_case(resolve(args.case, "case"))
    if case.flow is None:
        raise InputError("flow", "a case for simulate needs a [flow] table")
    if case.simulation is None:
        raise InputError("simulation", "a case for simulate needs a [simulation] table")
    out = output_directory(args.out, "--out") if args.out else None
    bar = tqdm(total=1, desc="simulate", unit="step", disable=args.json or not sys.stderr.isatty())

    def progress(n: int, total: int) -> None:
        bar.total = total
        bar.update(n - bar.n)

    resp = simulate(case.panel, case.flow, case.simulation, progress=progress,
                    keep_fields=out is not None)
    bar.close()
    summary = {**resp.summary(), "status": resp.status, "message": resp.message}
    if out is not None:
        ensure_directory(out)
        resp.save(out / "response.npz")
        write_text(out / "summary.json", dumps(
            {**summary, "wall_seconds": resp.wall_seconds, "timing": resp.timing}, indent=2))
    if args.json:
        print(dumps(summary))
    else:
        simulated = resp.times[-1] if resp.times else 0.0
        print(f"{args.case}: {resp.status} after {simulated:g} s simulated "
              f"({resp.wall_seconds:.1f} s wall)")
        if resp.message:
            print(f"  {resp.message}")
        if resp.instability_type:
            print(f"  instability: {resp.instability_type} at t = {resp.instability_time:g} s")
        if resp.times:
            print(f"  final centre deflection {resp.center_deflection[-1]:.4g} m, "
                  f"mean temperature {resp.mean_temperature[-1]:.1f} K")
    return 0
