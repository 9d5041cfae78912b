"""The ``hypate`` command line.

Subcommands live in the modules of :mod:`hypate.scaling.cli`; each registers its own parser. Errors
in user input (``hypate.solvers.errors.InputError``) and malformed files end with a one-line message
naming the field and exit code 2 -- never a traceback. So do a link where a command would
write, a run directory it may not write, a full disk (exit 4), Ctrl-C (130) and SIGTERM
(143; :mod:`.failures`). The logged warnings of the package (a store without digests) are
printed once each, as ``hypate: warning: ...``.
"""
from __future__ import annotations

import argparse
import contextlib
import difflib
import logging
import re
import sys
from collections.abc import Iterator, Sequence
from types import ModuleType
from typing import NoReturn

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
from hypate.scaling.cli.commands import DESCRIPTION
from hypate.scaling.cli.failures import (
    EXIT_OUTPUT,
    EXIT_USAGE,
    interrupt_code,
    interrupt_word,
    is_write_failure,
    sigterm_as_interrupt,
    write_failure,
)
from hypate.scaling.engine.store import StoreError
from hypate.scaling.workflow.campaigns.campaign import package_version
from hypate.solvers.errors import InputError
from hypate.solvers.numerics.files import LinkRefused

#: The command registry: modules providing subcommands (each has ``register(subparsers)``),
#: in ``--help`` order.
COMMAND_MODULES: tuple[ModuleType, ...] = (run, studies, reproduce, init, validate, report,
                                           whatif, laws, predict, condition, structure,
                                           thermal, simulate, flutter, rom, bench)


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

    def error(self, message: str) -> NoReturn:  # noqa: D401 - argparse API (self.exit)
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
        description=DESCRIPTION,
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


class _Once(logging.Filter):
    """Each distinct message once (a store is opened several times by one command)."""

    def __init__(self) -> None:
        super().__init__()
        self.seen: set[str] = set()

    def filter(self, record: logging.LogRecord) -> bool:
        text = record.getMessage()
        if text in self.seen:
            return False
        self.seen.add(text)
        return True


@contextlib.contextmanager
def package_warnings() -> Iterator[None]:
    """The package's logged warnings (logger ``hypate``) as ``hypate: warning: ...`` lines
    on stderr, each once, while a command runs."""
    logger = logging.getLogger("hypate")
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("hypate: warning: %(message)s"))
    handler.addFilter(_Once())
    handler.setLevel(logging.WARNING)
    logger.addHandler(handler)
    try:
        yield
    finally:
        logger.removeHandler(handler)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``hypate`` console script; returns the exit code."""
    command = "start-up"
    try:
        with sigterm_as_interrupt(), package_warnings():
            parser = build_parser()
            args = parser.parse_args(argv)
            command = args.command or command
            if getattr(args, "func", None) is None:
                parser.print_help()
                return EXIT_USAGE
            try:
                return int(args.func(args) or 0)
            except InputError as exc:
                print(f"hypate: error: {command_line_field(args, exc.field)}: {exc.message}",
                      file=sys.stderr)
                return EXIT_USAGE
    except KeyboardInterrupt as exc:  # Ctrl-C, or SIGTERM (failures.Terminated)
        print(f"hypate: {interrupt_word(exc)} ({command})", file=sys.stderr)
        return interrupt_code(exc)
    except (LinkRefused, StoreError) as exc:
        print(f"hypate: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except FileNotFoundError as exc:
        print(f"hypate: error: file not found: {exc.filename}", file=sys.stderr)
        return EXIT_USAGE
    except MemoryError:
        print(f"hypate: error: out of memory ({command}); use a coarser [simulation] mesh or "
              "fewer workers", file=sys.stderr)
        return EXIT_OUTPUT
    except OSError as exc:
        if is_write_failure(exc):
            what, todo = write_failure(exc)
            print(f"hypate: error: {what}; {todo} and run the command again",
                  file=sys.stderr)
            return EXIT_OUTPUT
        print(f"hypate: error: {exc.filename or ''}{': ' if exc.filename else ''}"
              f"{exc.strerror or exc}", file=sys.stderr)
        return EXIT_USAGE


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
