"""``hypate bench ate``: the reference aerothermoelastic run (issue 6 benchmark).

The Sec. 9.2 prototype -- 1 m x 1 m simply supported Inconel 718 honeycomb sandwich
(1 mm / 16 mm core / 1 mm, ``scaling/data/cases/sec9_2_prototype.toml``), M = 6, H = 25 km,
L_le = 1 m, 8 x 8 shell mesh, emissivity 0.85, effective-shape piston theory + turbulent
Eckert heating -- run with the tightly coupled scheme, LSA every step, dt = 1 s, 160 s.
Prints the per-step wall-time breakdown (fluid / structural / thermal / stability, Table 8.6
style), the total, steps per second, one sparse factorization of the structural tangent and
the cost of one step in factorization-equivalents. Medians and ratios; never pass/fail.
"""
from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np
from hypate.scaling.cli.jsonout import dumps
from hypate.scaling.cli.timing import median_seconds
from hypate.scaling.workflow.shipped import shipped
from hypate.solvers.aero.factory import make_fluid_model
from hypate.solvers.config import parse_case, read_toml, settings_from_config
from hypate.solvers.coupling.model import PanelModel
from hypate.solvers.coupling.tc import run_tc
from hypate.solvers.errors import InputError


def register_bench(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("ate", help="reference coupled TC + LSA run (Sec. 9.2 prototype, 160 s)",
                       description="Time the reference aerothermoelastic run and print the "
                       "per-step breakdown and the step/factorization ratio.")
    p.add_argument("--duration", type=float, default=160.0, help="simulated seconds (160)")
    p.add_argument("--time-step", type=float, default=1.0, help="TC time step (1 s)")
    p.add_argument("--aero", default="pt-bl", help="fluid model (default pt-bl)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=run)


def _factorization_seconds(model, u, T, repeat: int = 7) -> float:
    """Median time of one sparse factorization of the structural tangent at (u, T)."""
    st = model.structure
    K = st.tangent(u, model.structural_temperature(T))
    return median_seconds(lambda: st.factor(K), repeat)


def run(args: argparse.Namespace) -> int:

    if not (args.duration > 0 and args.time_step > 0 and args.duration >= args.time_step):
        raise InputError("--duration/--time-step", "must be positive, duration >= time step")
    path = shipped("case")["sec9_2_prototype"]
    case = parse_case(read_toml(str(path)), source=str(path))
    sim = case.simulation.model_copy(update={"time_step": args.time_step,
                                            "duration": args.duration, "aero": args.aero})
    settings = replace(settings_from_config(sim), keep_fields=False)
    model = PanelModel(case.panel, case.flow,
                       make_fluid_model(sim.aero, sim.heating, sim.boundary_layer), settings)
    t0 = time.perf_counter()
    resp = run_tc(model)
    wall = time.perf_counter() - t0
    steps = len(resp.times) - 1
    per_step = {k: v / max(steps, 1) for k, v in resp.timing.items()}
    u = resp.u[-1] if resp.u else np.zeros(model.structure.n_dof)
    fact = _factorization_seconds(model, np.zeros(model.structure.n_dof),
                                  model.thermal.initial_state())
    out = {"wall_seconds": wall, "simulated_seconds": resp.times[-1], "steps": steps,
           "seconds_per_step": per_step, "factorization_seconds": fact,
           "step_factorization_ratio": (wall / max(steps, 1)) / fact,
           "status": resp.status, "final_center_deflection": resp.center_deflection[-1],
           "final_mean_temperature": resp.mean_temperature[-1]}
    del u
    if args.json:
        print(dumps(out))
        return 0
    print(f"Sec. 9.2 prototype, TC + LSA, dt = {args.time_step:g} s, {resp.times[-1]:g} s "
          f"simulated ({resp.status})")
    print(f"  wall time            {wall:8.2f} s   ({steps / wall:.1f} steps/s)")
    for k, v in per_step.items():
        print(f"  {k:<20s} {1e3 * v:8.2f} ms/step")
    print(f"  factorization        {1e3 * fact:8.2f} ms (structural tangent)")
    print(f"  one step             {out['step_factorization_ratio']:8.2f} factorizations")
    print(f"  final: w_c = {resp.center_deflection[-1]:.4g} m, "
          f"T_mean = {resp.mean_temperature[-1]:.1f} K")
    return 0
