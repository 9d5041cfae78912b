"""``hypate bench structure``: assembly vs factorization cost of the DCS9 tangent.

For a simply supported 16 x 16 Inconel 718 panel at a heated, deflected state it prints the
median time of one internal-force + tangent assembly, of one factorization of that tangent
with each back end (banded Cholesky after the best of RCM / grid orderings, SuperLU with
several ``permc_spec``), and the ratio assembly / fastest factorization (target <= 2).
Medians and ratios only; never pass/fail.
"""
from __future__ import annotations

import argparse

import numpy as np
from hypate.scaling.cli.jsonout import dumps
from hypate.scaling.cli.timing import median_seconds
from hypate.solvers.errors import InputError
from hypate.solvers.materials import library_material
from hypate.solvers.panel import Layer, PanelSpec
from hypate.solvers.structure.model import StructuralModel

PERMC_SPECS = ("COLAMD", "MMD_AT_PLUS_A", "NATURAL")


def register_bench(sub: argparse._SubParsersAction) -> None:
    """Add the ``structure`` target to ``hypate bench``."""
    p = sub.add_parser("structure", help="DCS9 assembly vs sparse factorization timing",
                       description="Median time of one internal-force + tangent assembly and "
                       "one sparse factorization of the tangent (16 x 16 mesh by default).")
    p.add_argument("--mesh", type=int, default=16, help="elements per side (default 16)")
    p.add_argument("--repeat", type=int, default=7, help="timed repetitions (default 7)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:

    if args.mesh < 1 or args.repeat < 1:
        raise InputError("--mesh/--repeat", "must be >= 1")
    n = args.mesh
    panel = PanelSpec(layers=(Layer(library_material("inconel718"), 2e-3, 0.0, 2),),
                      length=1.0, width=1.0, mesh=(n, n))
    model = StructuralModel(panel)
    rng = np.random.default_rng(0)
    u = np.zeros(model.n_dof)
    x, y = model.mesh.x, model.mesh.y
    u[2::5] = 2e-3 * np.sin(np.pi * x) * np.sin(np.pi * y)
    u += 1e-7 * rng.standard_normal(model.n_dof)
    u[model.constrained_dofs] = 0.0
    T = 300.2   # below buckling (0.41 K) for this panel: the tangent is positive definite
    model.force_and_tangent(u, T)
    t_asm = median_seconds(lambda: model.force_and_tangent(u, T), args.repeat)
    t_force = median_seconds(lambda: model.internal_force(u, T), args.repeat)
    _, K = model.force_and_tangent(u, T)
    solver = model.solver
    fact: dict[str, float] = {}
    try:
        fact["banded_cholesky"] = median_seconds(lambda: solver.banded(K.data), args.repeat)
    except np.linalg.LinAlgError:
        pass
    for spec in PERMC_SPECS:
        fact[f"splu_{spec}"] = median_seconds(
            lambda s=spec: solver.splu(K.data, s, False), args.repeat)  # type: ignore[misc]  # mypy#15459: lambda default
        fact[f"splu_{spec}_symmetric"] = median_seconds(
            lambda s=spec: solver.splu(K.data, s, True), args.repeat)  # type: ignore[misc]  # mypy#15459: lambda default
    best = min(fact, key=fact.__getitem__)
    fac = solver.factor(K)
    b = rng.standard_normal(model.n_dof)
    t_solve = median_seconds(lambda: fac.solve(b), args.repeat)
    out = {"mesh": [n, n], "n_dof": model.n_dof, "bandwidth": solver.bandwidth,
           "assembly_s": t_asm, "internal_force_s": t_force, "factorization_s": fact,
           "fastest_factorization": best, "solve_s": t_solve,
           "ratio_assembly_to_factorization": t_asm / fact[best]}
    if args.json:
        print(dumps(out))
        return 0
    print(f"DCS9 {n} x {n} mesh: {model.n_dof} DOFs, banded bandwidth {solver.bandwidth}")
    print(f"  internal force + tangent assembly  {1e3 * t_asm:9.2f} ms (median of {args.repeat})")
    print(f"  internal force only                {1e3 * t_force:9.2f} ms")
    for k, v in sorted(fact.items(), key=lambda kv: kv[1]):
        print(f"  factorization {k:<32} {1e3 * v:9.2f} ms")
    print(f"  solve with the {solver.factor(K).method} factor     {1e3 * t_solve:9.2f} ms")
    print(f"  ratio assembly / fastest factorization ({best}): {t_asm / fact[best]:.2f}"
          "  (target <= 2)")
    return 0
