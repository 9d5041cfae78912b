"""``hypate bench ate``: the reference aerothermoelastic run (issue 6 benchmark).

The Sec. 9.2 prototype -- 1 m x 1 m simply supported Inconel 718 honeycomb sandwich
(1 mm / 16 mm core / 1 mm, ``scaling/data/cases/sec9_2_prototype.toml``), M = 6, H = 25 km,
L_le = 1 m, 8 x 8 shell mesh, emissivity 0.85, effective-shape piston theory + turbulent
Eckert heating -- run with the tightly coupled scheme, LSA every step, dt = 1 s, 160 s.
Prints the per-step wall-time breakdown (fluid / structural / thermal / stability, Table 8.6
style), the total, steps per second, one sparse factorization of the structural tangent and
the cost of one step in factorization-equivalents, medians over ``--repeat`` runs (3; the
runs must record the same histories, which the output confirms), and the work counts per
step behind that cost: aeroelastic Newton iterations, thermal residual evaluations, LSA
shifted solves and factorizations. Medians and ratios; never pass/fail.
"""
from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np
from hypate.scaling.cli.jsonout import dumps
from hypate.scaling.cli.timing import median_seconds
from hypate.scaling.workflow.vocabulary.shipped import shipped
from hypate.solvers.aero.factory import make_fluid_model
from hypate.solvers.config import parse_case, read_toml, settings_from_config
from hypate.solvers.coupling.model import PanelModel
from hypate.solvers.coupling.response import Response
from hypate.solvers.coupling.tc import run_tc
from hypate.solvers.errors import InputError


def register_bench(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("ate", help="reference coupled TC + LSA run (Sec. 9.2 prototype, 160 s)",
                       description="Time the reference aerothermoelastic run and print the "
                       "per-step breakdown, the step/factorization ratio and the work per "
                       "step (medians over --repeat runs).")
    p.add_argument("--duration", type=float, default=160.0, help="simulated seconds (160)")
    p.add_argument("--time-step", type=float, default=1.0, help="TC time step (1 s)")
    p.add_argument("--aero", default="pt-bl", help="fluid model (default pt-bl)")
    p.add_argument("--repeat", type=int, default=3, help="runs to take the medians of (3)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=run)


def _factorization_seconds(model, u, T, repeat: int = 7) -> float:
    """Median time of one sparse factorization of the structural tangent at (u, T)."""
    st = model.structure
    K = st.tangent(u, model.structural_temperature(T))
    return median_seconds(lambda: st.factor(K), repeat)


def reference_model(duration: float = 160.0, time_step: float = 1.0,
                    aero: str = "pt-bl") -> PanelModel:
    """A fresh model of the reference run (every repeat starts from scratch): the Sec. 9.2
    prototype over ``duration`` (s) with the TC time step ``time_step`` (s)."""
    path = shipped("case")["sec9_2_prototype"]
    case = parse_case(read_toml(str(path)), source=str(path))
    # the shipped prototype case has its [flow] and [simulation]
    assert case.simulation is not None and case.flow is not None
    sim = case.simulation.model_copy(update={"time_step": time_step, "duration": duration,
                                            "aero": aero})
    settings = replace(settings_from_config(sim), keep_fields=False)
    return PanelModel(case.panel, case.flow,
                      make_fluid_model(sim.aero, sim.heating, sim.boundary_layer), settings)


def work_counts(model: PanelModel) -> dict[str, int]:
    """A run's work counts (its :class:`~hypate.solvers.coupling.model.StepTimer` and its
    thermal model's counters): what the step's cost is made of. The LSA's shifted solves
    are counted on the pointwise path (piston theory and the other pointwise fluid models)
    only."""
    timer, thermal = model.timer, model.thermal
    return {"newton_iterations": timer.newton_iterations,
            "thermal_residuals": thermal.residual_evaluations,
            "lsa_shifted_solves": timer.shifted_solves,
            "structural_factorizations": timer.factorizations - thermal.factorizations,
            "thermal_factorizations": thermal.factorizations}


def _work_per_step(counts: dict[str, int], steps: int) -> dict[str, float | None]:
    """:func:`work_counts` per step; the shifted solves None off the pointwise path."""
    n = max(steps, 1)
    out: dict[str, float | None] = {k: v / n for k, v in counts.items()}
    if not counts["lsa_shifted_solves"]:
        out["lsa_shifted_solves"] = None
    return out


def _fingerprint(resp: Response, counts: dict[str, int]) -> bytes:
    """A run's recorded histories and work counts as bytes (the simulator is
    deterministic: repeats must agree bit for bit): times, centre deflection, mean, top
    and maximum wall temperatures, modal amplitudes, LSA eigenvalues and statuses, and the
    work counts."""
    arrays = (resp.times, resp.center_deflection, resp.mean_temperature,
              resp.top_temperature, resp.max_wall_temperature, resp.modal, resp.lsa,
              list(counts.values()))
    return (b"".join(np.ascontiguousarray(np.asarray(a)).tobytes() for a in arrays)
            + "|".join(resp.lsa_status).encode())


def run(args: argparse.Namespace) -> int:

    if not (args.duration > 0 and args.time_step > 0 and args.duration >= args.time_step):
        raise InputError("--duration/--time-step", "must be positive, duration >= time step")
    if not 1 <= args.repeat <= 50:
        raise InputError("--repeat", f"must be an integer in [1, 50]; got {args.repeat}")
    runs: list[tuple[float, Response, dict[str, int]]] = []
    for _ in range(args.repeat):
        model = reference_model(args.duration, args.time_step, args.aero)
        t0 = time.perf_counter()
        resp = run_tc(model)
        runs.append((time.perf_counter() - t0, resp, work_counts(model)))
    _, resp, counts = runs[0]
    steps = len(resp.times) - 1
    fact = _factorization_seconds(model, np.zeros(model.structure.n_dof),
                                  model.thermal.initial_state())
    walls = [w for w, _, _ in runs]
    ratios = [(w / max(steps, 1)) / fact for w in walls]
    # None: a single run, nothing to compare
    identical = (None if len(runs) == 1 else
                 all(_fingerprint(r, c) == _fingerprint(resp, counts) for _, r, c in runs[1:]))
    per_step = {k: float(np.median([r.timing[k] for _, r, _ in runs])) / max(steps, 1)
                for k in resp.timing}
    out = {"wall_seconds": float(np.median(walls)), "simulated_seconds": resp.times[-1],
           "steps": steps, "repeat": args.repeat, "seconds_per_step": per_step,
           "factorization_seconds": fact, "step_factorization_ratio": float(np.median(ratios)),
           "step_factorization_ratios": ratios,
           "work_per_step": _work_per_step(counts, steps), "runs_identical": identical,
           "status": resp.status, "final_center_deflection": resp.center_deflection[-1],
           "final_mean_temperature": resp.mean_temperature[-1]}
    if args.json:
        print(dumps(out))
        return 0
    work = out["work_per_step"]
    solves = ("LSA shifted solves not counted" if work["lsa_shifted_solves"] is None
              else f"{work['lsa_shifted_solves']:.1f} LSA shifted solves")
    print(f"Sec. 9.2 prototype, TC + LSA, dt = {args.time_step:g} s, {resp.times[-1]:g} s "
          f"simulated ({resp.status}); medians of {args.repeat} run(s)")
    print(f"  wall time            {out['wall_seconds']:8.2f} s   "
          f"({steps / out['wall_seconds']:.1f} steps/s)")
    for k, v in per_step.items():
        print(f"  {k:<20s} {1e3 * v:8.2f} ms/step")
    print(f"  factorization        {1e3 * fact:8.2f} ms (structural tangent)")
    print(f"  one step             {out['step_factorization_ratio']:8.2f} factorizations "
          f"(runs: {', '.join(f'{r:.2f}' for r in ratios)})")
    print(f"  work per step        {work['newton_iterations']:.2f} Newton iterations, "
          f"{work['thermal_residuals']:.2f} thermal residuals, {solves},")
    print(f"                       {work['structural_factorizations']:.2f} structural + "
          f"{work['thermal_factorizations']:.2f} thermal factorizations")
    print(f"  final: w_c = {resp.center_deflection[-1]:.4g} m, "
          f"T_mean = {resp.mean_temperature[-1]:.1f} K"
          + ("  (WARNING: the runs' histories differ)" if identical is False else ""))
    return 0
