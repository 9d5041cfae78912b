"""``hypate studies``: the shipped studies, each with its description, budget and measured
duration (run one with ``hypate run NAME``, start your own with ``hypate init``)."""
from __future__ import annotations

import argparse

from hypate.scaling.cli.commands import HELP
from hypate.scaling.cli.jsonout import dumps
from hypate.scaling.workflow.campaigns.robust import robust_budget
from hypate.scaling.workflow.vocabulary.derived import sweep_points
from hypate.scaling.workflow.vocabulary.shipped import shipped
from hypate.scaling.workflow.vocabulary.study import load_study


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("studies", help=HELP["studies"],
                       description="List the shipped studies (the quick-start and the "
                       "dissertation reproductions) with their description, evaluation "
                       "budget and measured duration.")
    p.add_argument("--json", action="store_true", help="print a JSON list of "
                   '{"name", "description", "kind", "evaluations", "sweep_points", '
                   '"duration", "classical_baseline", "path"}')
    p.set_defaults(func=run)


def catalog() -> list[dict[str, object]]:
    """One record per shipped study, by name."""
    out = []
    for name, path in shipped("study").items():
        study = load_study(path)
        points = len(sweep_points(study)) if study.sweep is not None else 1
        robust = study.uncertainty is not None and study.uncertainty.optimize
        budget = robust_budget(study) if robust else study.budget  # both campaigns
        out.append({"name": name, "description": study.description,
                    "kind": study.raw.study.kind, "evaluations": budget * points,
                    "sweep_points": points, "duration": study.raw.study.duration or None,
                    # the classical GP design, evaluated first and stored beside the budget
                    "classical_baseline": bool(study.raw.optimizer.classical_seed),
                    "path": str(path)})
    return out


def run(args: argparse.Namespace) -> int:
    rows = catalog()
    if args.json:
        print(dumps(rows, indent=2))
        return 0
    width = max(len(str(r["name"])) for r in rows)
    for r in rows:
        sweep = f", {r['sweep_points']} points" if r["sweep_points"] != 1 else ""
        print(f"{r['name']:<{width}}  {r['description']}")
        extra = " (+1: the classical baseline)" if r["classical_baseline"] else ""
        print(f"{'':<{width}}  {r['evaluations']} evaluations{extra}{sweep}; "
              f"{r['duration'] or 'duration not measured'}")
    return 0
