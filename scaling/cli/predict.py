"""``hypate predict RUN_DIR --measured test.csv [--out DIR] [--json] [--xi X]``: the
full-scale histories a wind-tunnel test of the run's design point predicts (the command line
of :mod:`hypate.scaling.workflow.analyses.predict`; header contract, mapping and band there)."""
from __future__ import annotations

import argparse
import warnings
from pathlib import Path

from hypate.scaling.cli.arguments import output_directory
from hypate.scaling.cli.commands import HELP
from hypate.scaling.cli.jsonout import dumps
from hypate.scaling.report.figures import png_bytes, prediction_figure
from hypate.scaling.report.prediction import prediction_page
from hypate.scaling.workflow.analyses.predict import (
    design_point_basis,
    predict,
    sweep_basis,
    write_prediction,
)
from hypate.scaling.workflow.campaigns.rundir import (
    PREDICTION_DIR,
    PREDICTION_HTML,
    PREDICTION_PNG,
)
from hypate.scaling.workflow.vocabulary.measured import ACCEPTED, read_measured


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "predict", help=HELP["predict"],
        description="Map measured model histories (a CSV of the wind-tunnel test of the "
        "run's design point) onto the prototype through the design point's "
        "nondimensionalization (time by the run's time mapping, deflection by the thickness "
        "ratio, temperature by the stagnation-temperature ratio), with an error band from "
        "the design point's residual mismatch, the propagated scatter and the measurement's "
        f"deviation. CSV header: NAME [UNIT] columns {ACCEPTED}; time and at least one "
        "history required. Writes prediction.csv, prediction.json, prediction.png and "
        "prediction.html.")
    p.add_argument("run_dir", metavar="RUN_DIR", help="run directory of `hypate run` (with "
                   "--xi: a sweep run directory)")
    p.add_argument("--measured", required=True, metavar="CSV",
                   help="measured model test (model time, centre deflection and/or mean "
                   "temperature)")
    p.add_argument("--out", help="output directory (default: RUN_DIR/prediction)")
    p.add_argument("--xi", type=float, metavar="X", help="the model tested is the one the "
                   "sweep's refined scaling laws give at geometric scale X (hypate laws "
                   "RUN_DIR --predict X; simulated once for the band)")
    p.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    p.set_defaults(func=run, field_flags={"measured": "--measured", "xi": "--xi",
                                          "out": "--out"})


def _print(summary: dict) -> None:
    print(f"prediction from {summary['measured']} ({summary['points']} points) through the "
          f"{summary['source']} of {summary['run_dir']}")
    print(f"  time: 1 model s = {summary['time_ratio']:.6g} prototype s (model step "
          f"{summary['model_time_step']:.6g} s, prototype step "
          f"{summary['prototype_time_step']:.6g} s)")
    for name, h in summary["histories"].items():
        inside = h["in_band"]
        print(f"  {name}: +-{h['half_width']:.4g} {h['unit']} (residual {h['residual']:.3g},"
              f" scatter {'-' if h['scatter'] is None else format(h['scatter'], '.3g')}, "
              f"measurement {h['measurement']:.3g}); simulated prototype in band at "
              f"{'-' if inside is None else format(100.0 * inside, '.3g')} % of the points")
    for path in summary["files"].values():
        print(f"wrote {path}")


def run(args: argparse.Namespace) -> int:
    run_dir = Path(args.run_dir)
    out = output_directory(args.out if args.out else str(run_dir / PREDICTION_DIR), "--out")
    measured = read_measured(args.measured)
    with warnings.catch_warnings():
        # material tables clamped outside their range etc. (the --xi simulation): noise here
        warnings.simplefilter("ignore", RuntimeWarning)
        basis = (sweep_basis(run_dir, args.xi) if args.xi is not None
                 else design_point_basis(run_dir))
    pred = predict(basis, measured)
    png = png_bytes(prediction_figure(pred))
    page = prediction_page(pred, png).encode("utf-8")
    summary = write_prediction(pred, out, {PREDICTION_PNG: png, PREDICTION_HTML: page})
    if args.json:
        print(dumps(summary, indent=2))
    else:
        _print(summary)
    return 0
