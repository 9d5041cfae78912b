"""``hypate bench bo``: Bayesian optimization on a benchmark problem.

Prints the final hypervolume (or best value), its history and the median overhead per
iteration (surrogate fits + acquisition optimization, the objective excluded); ``--json``
prints the issue's public JSON instead. ``--baseline nsga2|random`` runs pymoo's NSGA-II
(population 10) or OLH random search on the same budget.
"""
from __future__ import annotations

import argparse
from typing import Any

import numpy as np
from hypate.scaling.cli.jsonout import dumps
from hypate.scaling.engine.acquisition import (
    MULTI_OBJECTIVE_ACQUISITIONS,
    SINGLE_OBJECTIVE_ACQUISITIONS,
    default_acquisition,
)
from hypate.scaling.engine.benchmarks import (
    BENCHMARKS,
    get_benchmark,
    run_nsga2,
    run_random,
)
from hypate.scaling.engine.optimizer import BayesianOptimizer
from hypate.solvers.errors import InputError


def register_bench(sub: argparse._SubParsersAction) -> None:
    """Add the ``bo`` target to ``hypate bench``."""

    p = sub.add_parser("bo", help="Bayesian optimization on a benchmark problem",
                       description="Multi-objective Bayesian optimization on a test problem.")
    p.add_argument("--problem", required=True, help=f"one of {', '.join(BENCHMARKS)}")
    p.add_argument("--n-var", type=int, default=None, help="variables (ZDT/DTLZ; default 6)")
    p.add_argument("--init", type=int, default=None, help="initial OLH samples")
    p.add_argument("--iterations", type=int, default=None, help="BO iterations")
    p.add_argument("--acquisition", default=None,
                   help="hvlcb|hvei|hvpoi|ws|cheb|mmei|mmlcb|mmlogei (two objectives) or "
                        "lcb|ei|poi (one); default: hvlcb (two), ei (one)")
    p.add_argument("--v-final", default="auto", metavar="V|auto|none",
                   help="exploration weight of the last iteration (auto: the acquisition's "
                   "schedule, HVLCB 1.5 -> 0.5; none: constant v)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--batch-size", type=int, default=1, help="designs per iteration (q)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--baseline", choices=("nsga2", "random"), default=None,
                   help="run a baseline on the same budget instead of BO")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:

    if args.problem.lower() not in BENCHMARKS:
        raise InputError("--problem", f"must be one of {', '.join(BENCHMARKS)}")
    if args.n_var is not None and args.n_var < 2:
        raise InputError("--n-var", "must be >= 2")
    bench = get_benchmark(args.problem, args.n_var)
    n_init = bench.n_init if args.init is None else args.init
    n_iter = bench.n_iter if args.iterations is None else args.iterations
    if n_init < 1 or n_iter < 0:
        raise InputError("--init/--iterations", "need --init >= 1 and --iterations >= 0")
    if args.batch_size < 1:
        raise InputError("--batch-size", "must be >= 1")
    # "wm" needs the metric's exponent g, which the command does not take
    valid = (tuple(a for a in MULTI_OBJECTIVE_ACQUISITIONS if a != "wm")
             if bench.multi_objective else SINGLE_OBJECTIVE_ACQUISITIONS)
    acq = args.acquisition or default_acquisition(bench.problem.n_obj)
    if acq not in valid:
        raise InputError("--acquisition", f"for {bench.name} must be one of {'|'.join(valid)}")
    n_eval = n_init + n_iter * args.batch_size
    v_final = _v_final(args.v_final)

    seconds = float("nan")
    history: np.ndarray | list[float]  # each run's curve, then as floats
    if args.baseline == "nsga2":
        history = run_nsga2(bench, n_eval, args.seed)
    elif args.baseline == "random":
        history = run_random(bench, n_eval, args.seed)
    else:
        opt = BayesianOptimizer(bench.problem, acquisition=acq, n_init=n_init, n_iter=n_iter,
                                batch_size=args.batch_size, ref_point=bench.ref_point,
                                v_final=v_final, seed=args.seed)
        res = opt.run()
        history = (res.hypervolume_history(bench.ref_point) if bench.multi_objective
                   else res.best_history())
        if len(res.seconds_per_iteration):
            seconds = float(np.median(res.seconds_per_iteration))
    history = [float(h) for h in history]
    out: dict[str, Any]
    if bench.multi_objective:
        assert bench.ref_point is not None  # every multi-objective benchmark has one
        out = {"hypervolume": history[-1] if history else 0.0,
               "reference_point": [float(r) for r in bench.ref_point], "history": history,
               "evaluations": len(history), "seconds_per_iteration_median": seconds}
    else:
        out = {"best": history[-1] if history else float("inf"), "history": history,
               "evaluations": len(history), "seconds_per_iteration_median": seconds}
    if args.json:
        print(dumps(out))
        return 0
    label = args.baseline or acq
    if bench.multi_objective:
        regret = bench.optimum - out["hypervolume"]
        print(f"{bench.name} [{label}] seed {args.seed}: hypervolume {out['hypervolume']:.6g} "
              f"(ref {out['reference_point']}, true front {bench.optimum:.6g}, regret "
              f"{regret:.4g}) after {out['evaluations']} evaluations")
    else:
        print(f"{bench.name} [{label}] seed {args.seed}: best {out['best']:.6g} (optimum "
              f"{bench.optimum:.6g}, gap {out['best'] - bench.optimum:.3g}) after "
              f"{out['evaluations']} evaluations")
    print(f"median seconds per iteration (overhead): {seconds:.3f}")
    return 0


def _v_final(text: str) -> float | str | None:
    """``--v-final``: a weight >= 0, ``auto`` or ``none``."""
    if text.lower() in ("auto", "none"):
        return None if text.lower() == "none" else "auto"
    try:
        value = float(text)
    except ValueError:
        value = -1.0
    if not value >= 0.0:
        raise InputError("--v-final", f"must be a number >= 0, auto or none; got {text!r}")
    return value
