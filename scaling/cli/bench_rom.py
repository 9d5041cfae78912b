"""``hypate bench rom``: NRMSE of the Sec. 7.1 ROM versus the number of training samples.

Builds the shipped ``rom_2d_panel`` ROM (``studies/rom/rom_2d_panel.toml``, ROM/Avr set-up)
from 50, 100, 200 and 400 OLH samples of the built-in shock-expansion source and prints the mean
NRMSE (Eq. 7.7) of pressure and heat flux on 100 held-out samples -- the analogue of Fig. 7.3 --
with the build time of each ROM. A benchmark: it prints numbers, it never fails.
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

from hypate.scaling.cli.arguments import integer_in
from hypate.scaling.cli.jsonout import dumps
from hypate.scaling.workflow.vocabulary.shipped import resolve
from hypate.solvers.aero.rom.build import build_rom_from_config, check_rom
from hypate.solvers.aero.rom.config import MAX_SAMPLES, MIN_SAMPLES, load_rom_config

#: The shipped ROM build file, by name (:mod:`hypate.scaling.workflow.vocabulary.shipped`).
DEFAULT_CONFIG = "rom_2d_panel"


def register_bench(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("rom", help="ROM convergence: NRMSE vs sample count (Fig. 7.3)",
                       description="Mean NRMSE of the Sec. 7.1 ROM vs training-sample count.")
    p.add_argument("--config", default=DEFAULT_CONFIG, help="ROM build file or a shipped "
                   "one's name")
    p.add_argument("--counts", type=int, nargs="+", default=[50, 100, 200, 400],
                   help="training-sample counts (default 50 100 200 400)")
    p.add_argument("--test-samples", type=int, default=100, help="held-out samples")
    p.add_argument("--json", action="store_true", help="print a JSON list of "
                   '{"samples", "pressure_nrmse", "heat_flux_nrmse", "pressure_modes", '
                   '"heat_flux_modes", "build_seconds"} (NRMSE as fractions)')
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    for n in args.counts:
        integer_in(n, "--counts", MIN_SAMPLES, MAX_SAMPLES)
    integer_in(args.test_samples, "--test-samples", 1, MAX_SAMPLES)
    cfg, base = load_rom_config(resolve(args.config, "rom"))
    if not args.json:
        print(f"ROM convergence ({Path(args.config).name}; {args.test_samples} held-out "
              "samples, mean NRMSE Eq. 7.7)")
        print(f"{'samples':>8s} {'p NRMSE %':>10s} {'q NRMSE %':>10s} {'p modes':>8s} "
              f"{'q modes':>8s} {'build s':>8s}")
    rows = []
    for n in args.counts:
        t0 = time.perf_counter()
        rom = build_rom_from_config(cfg, base, samples=n)
        dt = time.perf_counter() - t0
        res = check_rom(rom, args.test_samples, rng=987654)
        rows.append({"samples": n, "pressure_nrmse": float(res["pressure_nrmse"]),
                     "heat_flux_nrmse": float(res["heat_flux_nrmse"]),
                     "pressure_modes": rom.pressure_model.n_modes,
                     "heat_flux_modes": rom.heat_model.n_modes, "build_seconds": dt})
        if not args.json:
            print(f"{n:8d} {100 * res['pressure_nrmse']:10.3f} "
                  f"{100 * res['heat_flux_nrmse']:10.3f} {rom.pressure_model.n_modes:8d} "
                  f"{rom.heat_model.n_modes:8d} {dt:8.1f}", flush=True)
    if args.json:
        print(dumps(rows, indent=2))
    return 0
