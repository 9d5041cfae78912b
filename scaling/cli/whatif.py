"""``hypate whatif STUDY --set NAME=VALUE ...``: the command line of
:mod:`hypate.scaling.workflow.analyses.whatif` (rules and output fields documented there)."""
from __future__ import annotations

import argparse
import math
import sys
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from hypate.scaling.cli.arguments import output_directory
from hypate.scaling.cli.commands import HELP
from hypate.scaling.cli.jsonout import dumps
from hypate.scaling.cli.progress import StepProgress
from hypate.scaling.report.figures import plot_sweep
from hypate.scaling.workflow.analyses.whatif import (
    MISMATCH,
    at_sweep_point,
    base_point,
    evaluate_whatif,
    load_base,
    scatter_whatif,
    sweep_whatif,
)
from hypate.scaling.workflow.campaigns.verdict import admissibility_lines, prototype_note
from hypate.scaling.workflow.vocabulary.shipped import resolve
from hypate.scaling.workflow.vocabulary.study import Study, load_study
from hypate.scaling.workflow.vocabulary.variables import CATEGORICAL, variable_unit
from hypate.solvers.errors import InputError


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "whatif", help=HELP["whatif"],
        description="Evaluate one wind-tunnel model design: J_u, J_T, the similarity table "
        "and the constraint activity. Values not given with --set take the midpoint of their "
        "bounds; values outside their bounds are evaluated and flagged. Example: hypate "
        "whatif quickstart --set p0=6e6")
    p.add_argument("study", help="study TOML file")
    p.add_argument("--set", dest="set_values", action="append", default=None,
                   metavar="NAME=VALUE", help="design value in SI units (repeatable)")
    p.add_argument("--sweep", metavar="NAME=LOW:HIGH:N",
                   help="evaluate N designs with NAME linearly spaced in [LOW, HIGH]; writes "
                   "whatif_NAME.png and whatif_NAME.csv to --out")
    p.add_argument("--base", metavar="RUN_DIR", help="unset variables take the design point "
                   "of this run directory (or design_point.json) instead of their midpoints")
    p.add_argument("--point", metavar="LABEL", help="a point of the study's [sweep] "
                   "(e.g. M7_H20km, xi_3): evaluate at its scale and flight condition "
                   "(default: the point whose run directory --base names, else the study's "
                   "own)")
    p.add_argument("--out", help="output directory of --sweep (default: runs/whatif-STUDY)")
    p.add_argument("--scatter", action="store_true", help="propagate the study's "
                   "[uncertainty] at the design (polynomial chaos on the simulator): "
                   "mean, std, quantiles and Sobol indices of J_u, J_T")
    p.add_argument("--samples", type=int, help="simulator runs of --scatter (default: the "
                   "study's [robust] samples, else twice the chaos terms)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run, field_flags={"set": "--set", "sweep": "--sweep", "base": "--base",
                                          "scatter": "--scatter", "samples": "--samples"})


# -- parsing --------------------------------------------------------------------------------
def _number(text: str, option: str, what: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise InputError(option, f"{what}: {text!r} is not a number") from None
    if not math.isfinite(value):
        raise InputError(option, f"{what}: must be finite; got {text!r}")
    return value


def parse_set(items: Sequence[str] | None) -> dict[str, float | str]:
    """``["p0=6e6", "h=0.004"]`` -> ``{"p0": 6e6, "h": 0.004}`` (InputError on ``--set``);
    a categorical variable keeps its text (``material=inconel718``) unless it is a number
    (a level)."""
    out: dict[str, float | str] = {}
    for item in items or ():
        name, sep, text = item.partition("=")
        name = name.strip()
        if not sep or not name:
            raise InputError("--set", f"expected NAME=VALUE; got {item!r}")
        if name in out:
            raise InputError("--set", f"{name} is given twice")
        text = text.strip()
        if name in CATEGORICAL and not _is_number(text):
            if not text:
                raise InputError("--set", f"{name}: give a name, e.g. {name}=inconel718")
            out[name] = text
        else:
            out[name] = _number(text, "--set", name)
    return out


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def parse_sweep(text: str) -> tuple[str, float, float, int]:
    """``"p0=1e6:8e6:8"`` -> ``("p0", 1e6, 8e6, 8)`` (InputError on ``--sweep``)."""
    name, sep, rest = text.partition("=")
    parts = rest.split(":")
    if not sep or not name.strip() or len(parts) != 3:
        raise InputError("--sweep", f"expected NAME=LOW:HIGH:N; got {text!r}")
    lo = _number(parts[0], "--sweep", "LOW")
    hi = _number(parts[1], "--sweep", "HIGH")
    try:
        n = int(parts[2])
    except ValueError:
        raise InputError("--sweep", f"N: {parts[2]!r} is not an integer") from None
    if not 2 <= n <= 500:
        raise InputError("--sweep", f"N must be in [2, 500]; got {n}")
    if lo == hi:
        raise InputError("--sweep", "LOW and HIGH must differ")
    return name.strip(), lo, hi, n


# -- output ---------------------------------------------------------------------------------
def _pct(v: float | None) -> str:
    return "failed" if v is None else f"{100.0 * v:.3g} %"


def _print_result(res: dict[str, Any]) -> None:

    print(f"what-if {res['study']}: one model design (no optimization)")
    print(f"  {'variable':<10s} {'value':>12s} {'unit':<4s}  source")
    for name, value in res["design"].items():
        shown = res[name] if name in CATEGORICAL and name in res else f"{value:.6g}"
        print(f"  {name:<10s} {shown:>12s} {variable_unit(name):<4s}  "
              f"{res['sources'].get(name, '')}")
    for name in [n for n in CATEGORICAL if n in res and n not in res["design"]]:
        print(f"  {name:<10s} {res[name]:>12s} {'-':<4s}  {res['sources'].get(name, '')}")
    obj = res["objectives"]
    if res["status"] == "ok":
        print(f"J_u = {_pct(obj['J_u'])}   J_T = {_pct(obj['J_T'])}   J_s = {_pct(obj['J_s'])}")
    else:
        print(f"model failed: {res['message']}")
    print(f"model time step {res['model_time_step']:.4g} s")
    print("similarity parameters (* relative difference > 10 %):")
    print(f"  {'parameter':<16s} {'prototype':>12s} {'model':>12s} {'rel. diff.':>11s}")
    for rec in res["similarity"]:
        rd = rec["relative_difference"]
        flag = "*" if rd is not None and abs(rd) > MISMATCH else " "
        fmt = (lambda v: "-" if v is None else f"{v:.5g}")  # noqa: E731
        print(f"{flag} {rec['name']:<16s} {fmt(rec['prototype']):>12s} {fmt(rec['model']):>12s} "
              f"{'-' if rd is None else f'{100 * rd:.3g} %':>11s}")
    con = res["constraints"]
    print("constraints:")
    print(f"  bounds hit: {', '.join(con['active']) or 'none'}")
    for flag in con["outside"]:
        print(f"  OUTSIDE: {flag}")
    for eq in con["equalities"]:
        print(f"  equality {eq['name']}: residual {eq['residual']:.3g} "
              f"({'satisfied' if eq['satisfied'] else 'NOT satisfied'})")
    for ineq in con.get("inequalities", []):
        print(f"  {ineq['name']}: {'satisfied' if ineq['satisfied'] else 'NOT satisfied'}")
    for line in admissibility_lines(res):
        print(line)
    note = prototype_note(res.get("prototype_admissibility") or [])
    if note:
        print(note)


def _print_sweep(sw: dict[str, Any]) -> None:
    name = sw["name"]
    print(f"sweep of {name}: {len(sw['rows'])} designs")
    print(f"  {name:>12s} {'J_u':>10s} {'J_T':>10s} {'J_s':>10s}  note")
    for r in sw["rows"]:
        note = r["message"] if r["status"] != "ok" else "; ".join(
            r["outside"] + [f"violates {c}" for c in r["violated"]])
        print(f"  {r['value']:>12.6g} {_pct(r['J_u']):>10s} {_pct(r['J_T']):>10s} "
              f"{_pct(r['J_s']):>10s}  {note}")
    print(f"wrote {sw['png']}")
    print(f"wrote {sw['csv']}")


def _print_scatter(res: dict[str, Any]) -> None:
    if res["status"] != "ok":
        print(f"scatter: {res['samples']} simulator runs; {res['status']}")
        return
    print(f"scatter: {res['samples']} simulator runs ({res['failed']} failed), order-"
          f"{res['order']} chaos (leave-one-out error {100 * res['chaos_error']:.3g} % of the "
          f"std); statistics from the {'chaos' if res['method'] == 'chaos' else 'samples'}")
    for name, dist in res["inputs"].items():
        print(f"  {name:<22s} {dist}")
    print(f"  {'':<6s} {'mean':>9s} {'std':>9s} {'q10':>9s} {'q50':>9s} {'q90':>9s}  "
          f"{res['statistic']}")
    for k, st in res["objectives"].items():
        print(f"  {k:<6s} " + " ".join(f"{_pct(st[q]):>9s}" for q in
                                       ("mean", "std", "q10", "q50", "q90"))
              + f"  {_pct(st['robust'])}")
    print("first-order Sobol indices" + ("" if res["sobol_valid"] else
                                         " (from the chaos, which does not hold here: "
                                         "indicative only)") + ":")
    names = list(res["inputs"])
    print(f"  {'':<22s} " + " ".join(f"{k:>7s}" for k in res["sobol"]))
    for n in names:
        print(f"  {n:<22s} " + " ".join(f"{res['sobol'][k][n]:>7.3f}" for k in res["sobol"]))
    for msg in res["failures"]:
        print(f"  failed: {msg}")


def _print_point(point: str | None) -> None:
    if point is not None:
        print(f"at sweep point {point}")


def _at_point(study: Study, point: str | None, base: str | None
              ) -> tuple[Study, str | None]:
    """The study at the sweep point ``--point`` names, else at the one the ``--base`` run
    directory is; a sweep study evaluated at its own condition, or a base design evaluated
    at another point, says so (stderr)."""
    from_base = base_point(study, base) if base else None
    label = point or from_base
    if study.sweep is not None and label is None:
        print(f"note: {study.name} has a [sweep]; evaluated at its own scale and flight "
              "condition (--point LABEL for one of its points)", file=sys.stderr)
        return study, None
    if point is not None and from_base is not None and from_base != point:
        print(f"note: the design of point {from_base} (--base) evaluated at point {point}",
              file=sys.stderr)
    return (study, None) if label is None else (at_sweep_point(study, label), label)


def run(args: argparse.Namespace) -> int:
    values = parse_set(args.set_values)
    sweep = parse_sweep(args.sweep) if args.sweep else None
    if args.samples is not None and not args.scatter:
        raise InputError("--samples", "only used with --scatter")
    if args.scatter and sweep is not None:
        raise InputError("--scatter", "cannot be combined with --sweep")
    study = load_study(resolve(args.study, "study"))
    stem = study.name
    study, point = _at_point(study, args.point, args.base)
    base = load_base(args.base) if args.base else None
    if args.out and not sweep:
        raise InputError("--out", "only used with --sweep")
    # like every command, under runs/ unless --out says otherwise
    default = str(Path("runs") / f"whatif-{stem}{'' if point is None else '-' + point}"
                  ) if sweep else "."
    out = output_directory(args.out or default, "--out")
    with warnings.catch_warnings():
        # numerical noise of a diverging what-if design; property tables left behind are
        # not warnings but the design's "data" admissibility row
        warnings.simplefilter("ignore", RuntimeWarning)
        if args.scatter:
            bar = StepProgress("whatif")  # stderr: --json stdout stays clean
            try:
                result: dict[str, Any] = scatter_whatif(
                    study, values, base=base, samples=args.samples,
                    progress=lambda d, t: bar("scatter", d, t))
            finally:
                bar.close()
            result["point"] = point
            if args.json:
                print(dumps(result, indent=2))
            else:
                _print_point(point)
                _print_scatter(result)
            return 0
        if sweep is not None:
            name, lo, hi, n = sweep
            result = {"study": study.name, "point": point,
                      "sweep": sweep_whatif(study, values, name, lo, hi, n, out, base=base,
                                            plot=plot_sweep)}
        else:
            result = {**evaluate_whatif(study, values, base=base), "point": point}
    if args.json:
        print(dumps(result, indent=2))
    elif sweep is not None:
        _print_point(point)
        _print_sweep(result["sweep"])
    else:
        _print_result(result)
    return 0
