"""``hypate bench thermal``: Crank-Nicolson step time vs one sparse factorization.

The default mesh is 16 x 16 x 6 hexahedra (shell mesh 8 x 8, so 17 x 17 in-plane nodes;
an Inconel 718 / honeycomb core / Inconel 718 sandwich with two thermal sub-layers per
layer: 2023 thermal nodes). It prints medians of

* one Crank-Nicolson step in three regimes: constant properties without radiation (the
  factorization is reused, so a step is residual evaluations + back-substitutions),
  temperature-dependent properties with radiation under full Newton, and the same under
  modified Newton (factorization kept while the iteration contracts);
* one factorization of the step Jacobian with each back end: LAPACK banded Cholesky /
  LU in the model's structured ordering (what the solver uses) and SuperLU;

and the ratios step / factorization. Medians and ratios only; never pass/fail.
"""
from __future__ import annotations

import argparse

import numpy as np
import scipy.sparse.linalg as spla
from hypate.scaling.cli.jsonout import dumps
from hypate.scaling.cli.timing import median_seconds
from hypate.solvers.errors import InputError
from hypate.solvers.materials import honeycomb_core, isotropic, library_material
from hypate.solvers.numerics.threads import blas_threads
from hypate.solvers.panel import Layer, PanelSpec
from hypate.solvers.thermal.loads import SurfaceCondition, ThermalLoads
from hypate.solvers.thermal.model import ThermalModel


def register_bench(sub: argparse._SubParsersAction) -> None:
    """Add the ``thermal`` target to ``hypate bench``."""
    p = sub.add_parser("thermal", help="thermal CN step time vs sparse factorization",
                       description="Median time of one Crank-Nicolson step of the HTSH "
                       "thermal model and of one sparse factorization of its Jacobian "
                       "(16 x 16 x 6 hexahedra by default).")
    p.add_argument("--cells", type=int, default=16,
                   help="hexahedra per in-plane side, even (default 16 = shell mesh 8 x 8)")
    p.add_argument("--sublayers", type=int, default=2,
                   help="thermal sub-layers per layer of the 3-layer sandwich (default 2: "
                   "6 hexahedra through the thickness)")
    p.add_argument("--repeat", type=int, default=7, help="timed repetitions (default 7)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:

    if args.cells < 2 or args.cells % 2:
        raise InputError("--cells", "must be an even number >= 2")
    if args.sublayers < 1 or args.repeat < 1:
        raise InputError("--sublayers/--repeat", "must be >= 1")
    n, s = args.cells // 2, args.sublayers
    inc = library_material("inconel718")
    core = honeycomb_core(inc, 0.05, 0.005, 0.02)

    def panel(materials: tuple) -> PanelSpec:
        return PanelSpec(layers=tuple(Layer(m, t, 0.0, s) for m, t in
                                      zip(materials, (1e-3, 2e-2, 1e-3))),
                         length=0.5, width=0.5, mesh=(n, n))

    const = tuple(isotropic(m.name + "_300K", float(m.density(300.0)), 2e11, 0.3, 1e-5,
                            float(m.k3(300.0)), float(m.specific_heat(300.0)))
                  for m in (inc, core, inc))
    dt = 0.5
    rng = np.random.default_rng(0)
    results: dict[str, float] = {}

    # (a) constant properties, no radiation: one factorization for the whole run
    lin = ThermalModel(panel(const))
    lin_loads = ThermalLoads(top=SurfaceCondition(flux=1e5))
    T_lin = lin.simulate(None, dt, 3, lin_loads).T
    f0 = lin.factorizations
    results["step_constant_reused_factor"] = median_seconds(
        lambda: lin.step(T_lin, dt, lin_loads), args.repeat)
    reused = lin.factorizations == f0

    # (b), (c) T-dependent sandwich with radiation
    nl_loads = ThermalLoads(top=SurfaceCondition(flux=1e5, emissivity=0.85, T_rad=300.0))
    full = ThermalModel(panel((inc, core, inc)))
    T_nl = full.simulate(None, dt, 3, nl_loads).T
    T_nl = T_nl + 0.01 * rng.standard_normal(T_nl.size)
    f0 = full.factorizations
    results["step_nonlinear_full_newton"] = median_seconds(
        lambda: full.step(T_nl, dt, nl_loads), args.repeat)
    fact_per_step = (full.factorizations - f0) / (args.repeat + 1)
    mod = ThermalModel(panel((inc, core, inc)), jacobian="modified")
    mod.simulate(None, dt, 3, nl_loads)
    results["step_nonlinear_modified_newton"] = median_seconds(
        lambda: mod.step(T_nl, dt, nl_loads), args.repeat)

    # one factorization of the step Jacobian, each back end
    ev = full._evaluate(T_nl + 1.0, T_nl, dt, 0.5, nl_loads, True)
    J = ev.J
    Jlin = lin._evaluate(T_lin, T_lin, dt, 0.5, lin_loads, True).J
    assert J is not None and Jlin is not None  # jacobian=True: _evaluate assembles it
    A = full._matrix(J).tocsc()
    with blas_threads(1):
        results["factor_banded_cholesky_constant"] = median_seconds(
            lambda: lin._banded.cholesky(Jlin), args.repeat)
        results["factor_banded_lu"] = median_seconds(lambda: full._banded.lu(J), args.repeat)
        for spec in ("MMD_AT_PLUS_A", "COLAMD"):
            results[f"factor_splu_{spec}"] = median_seconds(
                lambda sp_=spec: spla.splu(A, permc_spec=sp_), args.repeat)  # type: ignore[misc]  # mypy#15459: lambda default
        fac = full._banded.lu(J)
        b = rng.standard_normal(full.n_nodes)
        results["solve_banded_lu"] = median_seconds(lambda: fac.solve(b), args.repeat)

    splu_best = min(v for k, v in results.items() if k.startswith("factor_splu"))
    ratios = {
        "constant_step / banded_cholesky": results["step_constant_reused_factor"]
        / results["factor_banded_cholesky_constant"],
        "nonlinear_full_step / banded_lu": results["step_nonlinear_full_newton"]
        / results["factor_banded_lu"],
        "nonlinear_modified_step / banded_lu": results["step_nonlinear_modified_newton"]
        / results["factor_banded_lu"],
        "nonlinear_full_step / splu_best": results["step_nonlinear_full_newton"] / splu_best,
        "banded_lu / splu_best": results["factor_banded_lu"] / splu_best,
    }
    info = {"cells": [args.cells, args.cells, 3 * s], "nodes": full.n_nodes, "nnz": full.nnz,
            "half_bandwidth": full._banded.bw, "dt": dt,
            "factorizations_per_nonlinear_full_step": fact_per_step,
            "constant_step_reused_factorization": reused}
    if args.json:
        print(dumps({"info": info, "median_s": results, "ratios": ratios}))
        return 0
    print(f"thermal bench: {args.cells} x {args.cells} x {3 * s} hexahedra, "
          f"{full.n_nodes} nodes, nnz {full.nnz}, half bandwidth {full._banded.bw}, "
          f"dt = {dt} s, medians of {args.repeat}")
    for key, val in results.items():
        print(f"  {key:38s} {val * 1e3:10.3f} ms")
    print(f"  full-Newton factorizations per nonlinear step: {fact_per_step:.2f}; constant "
          f"step reused the factorization: {reused}")
    for key, val in ratios.items():
        print(f"  ratio {key:38s} {val:8.2f}")
    return 0
