"""``hypate init PATH.toml [--from STUDY]``: write a study file to start from -- a copy of a
shipped study (default the quick-start) with its comments, its prototype case referred to by
the shipped name so the file works from any folder, and a header saying where it came from.
``hypate validate PATH.toml`` accepts the result."""
from __future__ import annotations

import argparse
import json
import re
from pathlib import Path

from hypate.scaling.cli.commands import HELP
from hypate.scaling.workflow.vocabulary.shipped import resolve, shipped
from hypate.scaling.workflow.vocabulary.study import load_study
from hypate.solvers.config import did_you_mean
from hypate.solvers.errors import InputError
from hypate.solvers.numerics.files import write_text

CASE_LINE = re.compile(r'^(case\s*=\s*)"([^"]+)"', re.M)
#: The ``[study]`` table's ``name`` line (the first ``name =`` after ``[study]``).
NAME_LINE = re.compile(r'(^\[study\][^\[]*?^name\s*=\s*)"[^"]*"', re.M | re.S)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("init", help=HELP["init"],
                       description="Write PATH (a new study file) from a shipped study, "
                       "comments included; edit it, check it with `hypate validate PATH`, "
                       "run it with `hypate run PATH`.")
    p.add_argument("path", metavar="PATH", help="study file to write (must not exist)")
    p.add_argument("--from", dest="source", default="quickstart", metavar="STUDY",
                   help="shipped study to start from (see `hypate studies`)")
    p.set_defaults(func=run, field_flags={"source": "--from", "path": "PATH"})


def study_text(source: str) -> str:
    """The text of shipped study ``source`` with its case by shipped name."""
    studies = shipped("study")
    if source not in studies:
        raise InputError("source", f"no shipped study {source!r}"
                         + did_you_mean(source, list(studies)) + "; see `hypate studies`")
    path = studies[source]
    cases = shipped("case")

    def by_name(m: re.Match[str]) -> str:
        target = resolve(m.group(2), "case", path.parent).resolve()
        known = cases.get(target.stem)
        name = target.stem if known is not None and known.resolve() == target else str(target)
        return f'{m.group(1)}"{name}"'

    header = (f"# Study file written by `hypate init --from {source}`; edit freely.\n"
              "# Check it with `hypate validate FILE`, run it with `hypate run FILE`.\n")
    return header + CASE_LINE.sub(by_name, path.read_text(encoding="utf-8"))


def run(args: argparse.Namespace) -> int:
    out = Path(args.path)
    if out.suffix != ".toml":
        raise InputError("path", f"must end in .toml; got {out.name}")
    if out.exists():
        raise InputError("path", f"{out} exists; choose a new file name")
    if not out.parent.is_dir():
        raise InputError("path", f"folder {out.parent} does not exist")
    # the new study is named after its file: its runs go to runs/<stem>, not the source's
    text = NAME_LINE.sub(lambda m: m.group(1) + json.dumps(out.stem), study_text(args.source),
                         count=1)
    write_text(out, text)  # never through a link; whole or not at all
    try:
        load_study(out)  # what is written validates (a shipped study always does)
    except BaseException:
        out.unlink()
        raise
    print(f"{out}: written from {args.source} as study {out.stem!r} (runs/{out.stem}); "
          f"next: hypate validate {out}")
    return 0
