"""The ``hypate`` command line.

Subcommands live in :mod:`scaling.commands`; each registers its own parser. Errors in user
input (``solvers.errors.InputError``) and malformed files end with a one-line message
naming the field and exit code 2 -- never a traceback.
"""
from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

from solvers.errors import InputError

#: Modules providing subcommands (each has ``register(subparsers)``), in ``--help`` order.
COMMAND_MODULES: tuple[str, ...] = (
    "scaling.commands.condition",
    "scaling.commands.run",
    "scaling.commands.laws",
    "scaling.commands.report",
    "scaling.commands.whatif",
    "scaling.commands.validate",
    "scaling.commands.structure",
    "scaling.commands.thermal",
    "scaling.commands.simulate",
    "scaling.commands.flutter",
    "scaling.commands.rom",
    "scaling.commands.bench",
)

EXIT_USAGE = 2


class _Parser(argparse.ArgumentParser):
    """argparse with a one-line error and exit code 2 (argparse's own convention)."""

    def error(self, message: str) -> None:  # noqa: D401 - argparse API
        self.exit(EXIT_USAGE, f"hypate: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    """Build the full parser with every registered subcommand."""
    parser = _Parser(
        prog="hypate",
        description="Design aerothermoelastically scaled wind-tunnel models of hypersonic "
        "skin panels.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for name in COMMAND_MODULES:
        importlib.import_module(name).register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``hypate`` console script; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if getattr(args, "func", None) is None:
        parser.print_help()
        return EXIT_USAGE
    try:
        return int(args.func(args) or 0)
    except InputError as exc:
        print(f"hypate: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except FileNotFoundError as exc:
        print(f"hypate: error: file not found: {exc.filename}", file=sys.stderr)
        return EXIT_USAGE


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
