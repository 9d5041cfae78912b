"""The ``hypate`` command line.

Subcommands live in the modules of :mod:`hypate.scaling.cli`; each registers its own parser. Errors in user
input (``hypate.solvers.errors.InputError``) and malformed files end with a one-line message
naming the field and exit code 2 -- never a traceback.
"""
from __future__ import annotations

import argparse
import difflib
import re
import sys
from collections.abc import Sequence
from types import ModuleType

from hypate.scaling.cli import (
    bench,
    condition,
    flutter,
    init,
    laws,
    predict,
    report,
    reproduce,
    rom,
    run,
    simulate,
    structure,
    studies,
    thermal,
    validate,
    whatif,
)
from hypate.scaling.workflow.campaign import package_version
from hypate.solvers.errors import InputError

#: The command registry: modules providing subcommands (each has ``register(subparsers)``),
#: in ``--help`` order.
COMMAND_MODULES: tuple[ModuleType, ...] = (run, studies, reproduce, init, validate, report,
                                           whatif, laws, predict, condition, structure,
                                           thermal, simulate, flutter, rom, bench)

EXIT_USAGE = 2
EXIT_INTERRUPTED = 130


class DefaultsHelpFormatter(argparse.HelpFormatter):
    """Every option's help ends with its default, unless it already states one."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        if ("default" in text.lower() or action.default in (None, False, [], "==SUPPRESS==")
                or not action.option_strings):
            return text
        return f"{text} (default: %(default)s)"


class _Parser(argparse.ArgumentParser):
    """argparse with a one-line error, exit code 2 (argparse's own convention), a "did you
    mean" for a mistyped command, and every option's default in ``--help``."""

    def __init__(self, *args, **kwargs) -> None:  # noqa: ANN002, ANN003 - argparse API
        kwargs.setdefault("formatter_class", DefaultsHelpFormatter)
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> None:  # noqa: D401 - argparse API
        choice = re.search(r"invalid choice: '([^']*)' \(choose from (.*)\)", message)
        if choice:
            options = re.findall(r"'?([\w-]+)'?", choice.group(2))
            close = difflib.get_close_matches(choice.group(1), options, n=1, cutoff=0.5)
            if close:
                message += f"; did you mean {close[0]!r}?"
        self.exit(EXIT_USAGE, f"hypate: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    """Build the full parser with every registered subcommand."""
    parser = _Parser(
        prog="hypate",
        description="Design aerothermoelastically scaled wind-tunnel models of hypersonic "
        "skin panels.",
    )
    parser.add_argument("--version", action="version", version=f"hypate {package_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for module in COMMAND_MODULES:
        module.register(sub)
    return parser


def command_line_field(args: argparse.Namespace, field: str) -> str:
    """The name a user typed for an error's ``field``: the library names parameters
    (``seed_runs``, ``scheduler``), a command maps them to its flags with
    ``set_defaults(field_flags={"seed_runs": "--seed-from", ...})``; other fields (study and
    case keys such as ``optimizer.seed``) are shown as they are."""
    flags = dict(getattr(args, "field_flags", {}) or {})
    head, sep, tail = field.partition(" ")  # "set p0": the input, then what in it
    return flags[head] + sep + tail if head in flags else field


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
        print(f"hypate: error: {command_line_field(args, exc.field)}: {exc.message}",
              file=sys.stderr)
        return EXIT_USAGE
    except FileNotFoundError as exc:
        print(f"hypate: error: file not found: {exc.filename}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print(f"hypate: interrupted ({args.command})", file=sys.stderr)
        return EXIT_INTERRUPTED


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
