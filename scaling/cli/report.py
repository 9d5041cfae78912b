"""``hypate report DIR``: (re)generate the self-contained ``report.html`` of a run."""
from __future__ import annotations

import argparse

from hypate.scaling.cli.commands import HELP
from hypate.scaling.cli.jsonout import dumps
from hypate.scaling.report.html import write_report
from hypate.scaling.workflow.campaigns.rundir import FIGURES_DIR


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("report", help=HELP["report"],
                       description="Write DIR/figures/*.png and the self-contained "
                       "DIR/report.html (images embedded, mailable) from a run directory of "
                       "`hypate run`, also of an interrupted run (design point rebuilt from "
                       "evaluations.sqlite).")
    p.add_argument("run_dir", metavar="DIR", help="run directory (hypate run --out DIR)")
    p.add_argument("--study", help="the study file, when the run directory does not record "
                   "it (full study summary and similarity table of an interrupted run)")
    p.add_argument("--simulate", action="store_true",
                   help="interrupted run: simulate the rebuilt design point to plot its "
                   "response (one model simulation)")
    p.add_argument("--json", action="store_true", help='print {"report", "figures"} as JSON')
    p.set_defaults(func=run, field_flags={"study": "--study"})


def run(args: argparse.Namespace) -> int:
    path = write_report(args.run_dir, study_path=args.study, simulate=args.simulate)
    if args.json:
        figures = sorted(str(p) for p in (path.parent / FIGURES_DIR).glob("*.png"))
        print(dumps({"report": str(path), "figures": figures}))
    else:
        print(path)
    return 0
