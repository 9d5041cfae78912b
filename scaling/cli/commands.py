"""The command registry without the commands: each ``hypate`` command's name, the module
that registers it and its one-line help, in ``--help`` order.

It imports nothing heavy, so ``hypate --help`` and ``hypate --version`` answer from here
(:mod:`hypate.scaling.cli.entry`) without loading numpy, scipy, pandas and matplotlib; a
command module's ``register`` takes its one-line help from :data:`HELP`.
"""
from __future__ import annotations

import argparse
from importlib.metadata import PackageNotFoundError, version

__all__ = ["COMMANDS", "HELP", "DESCRIPTION", "quick_answer"]

DESCRIPTION = ("Design aerothermoelastically scaled wind-tunnel models of hypersonic skin "
               "panels.")

#: command -> (module under hypate.scaling.cli, one-line help), in ``--help`` order
COMMANDS: dict[str, tuple[str, str]] = {
    "run": ("run", "run a scaling study (default: the quick-start study)"),
    "studies": ("studies", "list the shipped studies"),
    "reproduce": ("reproduce", "run the dissertation reproductions and write "
                  "reproduction.html"),
    "init": ("init", "write a commented study file to start from"),
    "validate": ("validate", "validate a study, case or ROM build file"),
    "report": ("report", "regenerate report.html of a run directory"),
    "whatif": ("whatif", "evaluate one model design of a study (no optimization)"),
    "laws": ("laws", "refined scaling laws of a sweep run (fit, predict)"),
    "predict": ("predict", "predict the full-scale histories from a measured model test"),
    "condition": ("condition", "free-stream state from (M, altitude), (M, p0, T0) or "
                  "(M, p, T)"),
    "modes": ("structure", "natural frequencies of a panel (optionally heated)"),
    "buckling": ("structure", "critical uniform temperature rise (thermal buckling)"),
    "static": ("structure", "nonlinear static deflection under pressure and heating"),
    "heat": ("thermal", "transient heat conduction under a uniform surface heat flux"),
    "simulate": ("simulate", "run a coupled aerothermoelastic case"),
    "flutter": ("flutter", "flutter boundary lambda_cr by a lambda sweep with LSA "
                "(Sec. 7.2.3)"),
    "rom": ("rom", "build, check and plan fluid ROMs (POD-kriging)"),
    "bench": ("bench", "run a benchmark and print medians and ratios"),
}
#: command -> its one-line help
HELP: dict[str, str] = {name: text for name, (_, text) in COMMANDS.items()}


def package_version() -> str:
    """The installed package's version ("unknown" outside an installation)."""
    try:
        return version("hypate")
    except PackageNotFoundError:
        return "unknown"


def top_level_parser() -> argparse.ArgumentParser:
    """The top-level parser with every command listed and none loaded: what
    ``hypate --help`` prints."""
    parser = argparse.ArgumentParser(prog="hypate", description=DESCRIPTION)
    parser.add_argument("--version", action="version", version=f"hypate {package_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, text in HELP.items():
        sub.add_parser(name, help=text)
    return parser


def quick_answer(argv: list[str]) -> int | None:
    """``hypate --version`` and ``hypate --help`` answered without loading a command (exit
    code 0); None for anything else (the full command line handles it)."""
    if argv not in (["--version"], ["-h"], ["--help"]):
        return None
    try:
        top_level_parser().parse_args(argv)
    except SystemExit as done:  # argparse's --version / --help exit
        return int(done.code or 0)
    return None
