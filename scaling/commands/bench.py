"""``hypate bench TARGET``: benchmarks that print medians and ratios (never tests).

Each benchmark module in :data:`BENCH_MODULES` defines ``register_bench(subparsers)``.
"""
from __future__ import annotations

import argparse
import importlib
import time
from collections.abc import Callable

import numpy as np

#: Modules providing benchmark targets (each has ``register_bench(subparsers)``).
BENCH_MODULES: tuple[str, ...] = ("scaling.commands.bench_bo",
                                  "scaling.commands.bench_structure",
                                  "scaling.commands.bench_thermal",
                                  "scaling.commands.bench_ate",
                                  "scaling.commands.bench_rom")


def register(sub: argparse._SubParsersAction) -> None:
    parser = sub.add_parser("bench", help="run a benchmark and print medians and ratios",
                            description="Benchmarks: medians and ratios, never pass/fail.")
    targets = parser.add_subparsers(dest="target", metavar="TARGET", parser_class=type(parser))
    for name in BENCH_MODULES:
        importlib.import_module(name).register_bench(targets)
    parser.set_defaults(func=lambda args: (parser.print_help(), 2)[1])


def median_seconds(fn: Callable[[], object], repeat: int) -> float:
    """Median wall time (s) of ``repeat`` calls of ``fn`` after one warm-up call."""
    fn()
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return float(np.median(times))
