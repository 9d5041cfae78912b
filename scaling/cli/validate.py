"""``hypate validate FILE.toml``: check a study, case (panel) or ROM build file and summarize
it; the schema is chosen by the file's tables (``[study]``: a study; ``[[modes]]`` or
``[reference]``: a ROM build; otherwise a case or panel file) and named in the output."""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from hypate.scaling.cli.commands import HELP
from hypate.scaling.cli.jsonout import dumps
from hypate.scaling.workflow.vocabulary.shipped import resolve
from hypate.scaling.workflow.vocabulary.study import parse_study
from hypate.solvers.aero.factory import check_fluid_model
from hypate.solvers.aero.rom.build import geometry_from_config, snapshots_path
from hypate.solvers.aero.rom.config import parse_rom_config
from hypate.solvers.aero.rom.snapshots import read_snapshots
from hypate.solvers.config import parse_case, read_toml, summary
from hypate.solvers.errors import InputError

SCHEMAS = ("study", "case", "rom")


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("validate", help=HELP["validate"],
                       description="Validate a study, case/panel or ROM build file (the "
                       "schema follows from its tables, or --schema). Exit 0 and a summary, "
                       "or exit 2 with a one-line error naming the key.")
    p.add_argument("file", help="TOML file, or a shipped study/case/ROM file's name")
    p.add_argument("--schema", choices=SCHEMAS, help="schema to apply (default: from the "
                   "file's tables)")
    p.add_argument("--json", action="store_true", help="print one JSON object "
                   '{"file", "schema", "valid", "summary"} or, when invalid, '
                   '{"file", "schema", "valid": false, "field", "message"} (and the '
                   'one-line error on stderr, exit code 2)')
    p.set_defaults(func=run)


def schema_of(data: dict[str, Any]) -> str:
    """Which schema a parsed TOML file follows."""
    if "study" in data:
        return "study"
    if "modes" in data or "reference" in data:
        return "rom"
    return "case"


def _path(arg: str) -> Path:
    for kind in ("study", "case", "rom"):
        path = resolve(arg, kind)
        if path.exists():
            return path
    return Path(arg)


def validate(path: Path, schema: str | None = None) -> tuple[str, list[str]]:
    """Validate ``path`` under ``schema`` (None: detected) and the files it refers to (the
    prototype case, materials, the tunnel, an ``aero = "rom:PATH"`` ROM file, a ROM build's
    snapshots); the schema and summary lines."""
    data = read_toml(path)
    schema = schema or schema_of(data)
    if schema == "study":
        study = parse_study(data, path)  # loads the prototype case, materials and tunnel
        check_fluid_model(study.spec.prototype.simulation.aero)
        return schema, study.summary()
    if schema == "rom":
        cfg = parse_rom_config(data)
        if cfg.source.kind == "snapshots":
            read_snapshots(snapshots_path(cfg, path.resolve().parent), geometry_from_config(cfg))
        return schema, [f"ROM build: {len(cfg.modes)} modes, {cfg.training.samples} training "
                        f"samples, reference M = {cfg.reference.mach:g}"]
    case = parse_case(data, source=str(path))
    if case.simulation is not None:
        check_fluid_model(case.simulation.aero)
    return schema, summary(case)


def run(args: argparse.Namespace) -> int:
    path = _path(args.file)
    try:
        schema, lines = validate(path, args.schema)
    except InputError as exc:
        if args.json:
            print(dumps({"file": str(args.file), "schema": args.schema, "valid": False,
                         "field": exc.field, "message": exc.message}))
        raise  # and the one error line on stderr, exit code 2 (hypate.scaling.cli.main)
    if args.json:
        print(dumps({"file": str(args.file), "schema": schema, "valid": True,
                     "summary": lines}))
        return 0
    print(f"{args.file}: valid ({schema} file)")
    for line in lines:
        print(f"  {line}")
    return 0
