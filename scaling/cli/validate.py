"""``hypate validate FILE.toml``: check a panel/case file and print a short summary."""
from __future__ import annotations

import argparse

from hypate.scaling.workflow.shipped import resolve
from hypate.solvers.config import load_case, summary


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("validate", help="validate a panel/case TOML file and summarize it",
                       description="Validate a panel or case file. Exit 0 and a summary, or "
                       "exit 2 with a one-line error naming the key.")
    p.add_argument("file", help="panel or case TOML file")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    case = load_case(resolve(args.file, "case"))
    print(f"{args.file}: valid")
    for line in summary(case):
        print(f"  {line}")
    return 0
