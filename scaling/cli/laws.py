"""``hypate laws RUN_DIR [--predict XI] [--evaluate] [--json]``: refined scaling laws.

Fits the design points of a sweep run (``hypate run`` of a study with ``[sweep] xi``), or
of several single-study runs of one scaling problem at different scales
(``hypate laws runs/xi2 runs/xi3 runs/xi4``), as power laws of the geometric scale and compares them
with the analytical laws (:mod:`hypate.scaling.workflow.campaigns.laws`, Sec. 6.1.3, Fig. 9.4/9.12);
``--predict XI`` gives the design the refined laws predict at a new scale and its similarity table,
``--evaluate`` simulates it.
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path

from hypate.scaling.cli.commands import HELP
from hypate.scaling.cli.jsonout import dumps
from hypate.scaling.report.laws import laws_table
from hypate.scaling.workflow.campaigns.laws import (
    laws_json,
    laws_of_run,
    load_runs,
    materials_by_scale,
    predict,
)
from hypate.solvers.errors import InputError


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("laws", help=HELP["laws"],
                       description="Fit the design points of a sweep run against the "
                       "geometric scale xi as power laws c xi^k, next to the analytical "
                       "exponents; optionally predict (and evaluate) the design at a new xi.")
    p.add_argument("run_dir", metavar="RUN_DIR", nargs="+",
                   help="run directory of a sweep study, or several run directories of one "
                   "scaling problem at different xi")
    p.add_argument("--predict", type=float, metavar="XI", help="predict the design at scale XI")
    p.add_argument("--evaluate", action="store_true",
                   help="simulate the predicted design (J_u, J_T)")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=run)


def _g(v: float | None) -> str:
    return "-" if v is None else f"{v:.5g}"


def run(args: argparse.Namespace) -> int:
    if args.predict is not None and not (math.isfinite(args.predict) and args.predict >= 1.0):
        raise InputError("--predict", f"XI must be a scale >= 1; got {args.predict:g}")
    if args.evaluate and args.predict is None:
        raise InputError("--evaluate", "needs --predict XI")
    run_ = load_runs([Path(d) for d in args.run_dir])
    laws = laws_of_run(run_)
    prediction = None
    if args.predict is not None:
        prediction = predict(run_, args.predict, evaluate=args.evaluate, laws=laws)
    if args.json:
        print(dumps(laws_json(laws, prediction, run_.points), indent=2))
        return 0
    scales = sorted({p.xi for p in run_.points})
    print(f"{run_.directory}: {len(run_.points)} design points at xi = "
          f"{', '.join(f'{x:g}' for x in scales)}")
    for chosen in materials_by_scale(run_.points):  # categorical: reported, not fitted
        print(f"  material at xi = {chosen['xi']:g}: {chosen['material']}")
    rows = laws_table(laws)
    if rows:
        cols = ["variable", "coefficient", "exponent", "95% interval", "analytical exponent",
                "points (free/all)", "at bound"]
        width = {c: max(len(c), *(len(r[c]) for r in rows)) for c in cols}
        print("  ".join(c.rjust(width[c]) for c in cols))
        for r in rows:
            print("  ".join(r[c].rjust(width[c]) for c in cols) + (f"  ({r['note']})"
                                                                     if r["note"] else ""))
    if prediction is not None:
        print(f"\nprediction at xi = {prediction['xi']:g}:")
        for name, value in prediction["design"].items():
            mark = "  (clipped to a bound)" if name in prediction["clipped"] else ""
            shown = prediction["material"] if name == "material" else f"{value:.6g}"
            print(f"  {name:>10s} = {shown}{mark}")
        print("  similarity (prototype / model / relative difference):")
        for r in prediction["similarity"]:
            rd = r.get("relative_difference")
            rd_s = "-" if rd is None or not math.isfinite(rd) else f"{rd:+.3%}"
            print(f"    {r['name']:>22s}  {_g(r['prototype'])}  {_g(r['model'])}  {rd_s}")
        if args.evaluate:
            objs = prediction.get("objectives")
            if objs:
                print("  simulated: " + ", ".join(f"{k} = {v:.4g}" for k, v in objs.items()))
            else:
                print(f"  simulation failed: {prediction.get('evaluation_error')}")
    return 0
