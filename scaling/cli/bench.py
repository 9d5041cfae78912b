"""``hypate bench TARGET``: benchmarks that print medians and ratios (never tests).

Each benchmark module in :data:`BENCH_MODULES` defines ``register_bench(subparsers)``.
"""
from __future__ import annotations

import argparse
from types import ModuleType

from hypate.scaling.cli import (
    bench_ate,
    bench_best,
    bench_bo,
    bench_rom,
    bench_structure,
    bench_study,
    bench_thermal,
)
from hypate.scaling.cli.commands import HELP

#: Modules providing benchmark targets (each has ``register_bench(subparsers)``).
BENCH_MODULES: tuple[ModuleType, ...] = (bench_bo, bench_structure, bench_thermal, bench_ate,
                                         bench_rom, bench_study, bench_best)


def register(sub: argparse._SubParsersAction) -> None:
    parser = sub.add_parser("bench", help=HELP["bench"],
                            description="Benchmarks: medians and ratios, never pass/fail.")
    targets = parser.add_subparsers(dest="target", metavar="TARGET", parser_class=type(parser))
    for module in BENCH_MODULES:
        module.register_bench(targets)
    parser.set_defaults(func=lambda args: (parser.print_help(), 2)[1])
