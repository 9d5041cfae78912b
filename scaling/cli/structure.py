"""``hypate modes``, ``hypate buckling``, ``hypate static``: the structural solver (issue 4).

Each reads a panel file (``[panel]`` + ``[[panel.layers]]``, optional ``[materials.NAME]``)
with :func:`hypate.solvers.config.load_panel` and prints a short report, or with ``--json`` the
public JSON:

* ``hypate modes PANEL.toml [--count N] [--delta-T DT] --json`` ->
  ``{"frequencies_hz": [...]}`` (ascending; about the heated equilibrium when DT is given)
* ``hypate buckling PANEL.toml --json`` -> ``{"critical_delta_T": K}``
* ``hypate static PANEL.toml --pressure P [--delta-T DT] --json`` ->
  ``{"center_deflection": m, "max_deflection": m}`` (nonlinear; P > 0 pushes towards +z)
"""
from __future__ import annotations

import argparse
import math
import sys
import warnings

from hypate.scaling.cli.commands import HELP
from hypate.scaling.cli.jsonout import dumps
from hypate.scaling.workflow.vocabulary.shipped import resolve
from hypate.solvers.config import load_panel
from hypate.solvers.errors import InputError
from hypate.solvers.structure.modal import buckling_delta_T, modes
from hypate.solvers.structure.model import StructuralModel
from hypate.solvers.structure.static import static


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``modes``, ``buckling`` and ``static`` subcommands."""
    p = sub.add_parser("modes", help=HELP["modes"],
                       description="Natural frequencies (Hz, ascending) of the DCS9 shell model "
                       "about its equilibrium; with --delta-T about the heated (possibly "
                       "buckled) equilibrium under a uniform temperature rise.")
    p.add_argument("panel", help="panel TOML file")
    p.add_argument("--count", type=int, default=6, help="number of modes (default 6)")
    p.add_argument("--delta-T", dest="delta_T", type=float, default=0.0,
                   help="uniform temperature rise above the initial temperature (K)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=run_modes)

    p = sub.add_parser("buckling", help=HELP["buckling"],
                       description="Linear thermal buckling: the uniform temperature rise "
                       "(K) at which the panel first buckles.")
    p.add_argument("panel", help="panel TOML file")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=run_buckling)

    p = sub.add_parser("static", help=HELP["static"],
                       description="Nonlinear (von Karman) static equilibrium under a uniform "
                       "pressure (Pa, positive towards +z) and a uniform temperature rise.")
    p.add_argument("panel", help="panel TOML file")
    p.add_argument("--pressure", type=float, required=True, help="uniform pressure (Pa)")
    p.add_argument("--delta-T", dest="delta_T", type=float, default=0.0,
                   help="uniform temperature rise above the initial temperature (K)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=run_static)


def _finite(name: str, value: float) -> float:
    if not math.isfinite(value):
        raise InputError(name, "must be a finite number")
    return value


def _model(path: str):  # noqa: ANN202 - StructuralModel, imported lazily

    return StructuralModel(load_panel(resolve(path, "case")))


def _temperature(model, delta_T: float) -> float | None:  # noqa: ANN001
    dT = _finite("--delta-T", delta_T)
    return None if dT == 0.0 else model.T0 + dT


def run_modes(args: argparse.Namespace) -> int:

    if args.count < 1:
        raise InputError("--count", "must be >= 1")
    model = _model(args.panel)
    if args.count > model.n_dof - 2:
        raise InputError("--count", f"must be <= {model.n_dof - 2} for this mesh")
    T = _temperature(model, args.delta_T)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = modes(model, args.count, T=T)
    _report_warnings(caught)
    freqs = [float(f) for f in res.frequencies_hz]
    if args.json:
        print(dumps({"frequencies_hz": freqs}))
    else:
        print(f"{args.panel}: {len(freqs)} natural frequencies (Hz)")
        for i, f in enumerate(freqs, 1):
            print(f"  {i:3d}  {f:12.4f}")
    return 0


def run_buckling(args: argparse.Namespace) -> int:

    model = _model(args.panel)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            res = buckling_delta_T(model)
        except RuntimeError as exc:
            print(f"hypate: error: {exc}", file=sys.stderr)
            return 1
    _report_warnings(caught)
    if args.json:
        print(dumps({"critical_delta_T": float(res.critical_delta_T)}))
    else:
        print(f"{args.panel}: critical uniform temperature rise {res.critical_delta_T:.6g} K")
    return 0


def run_static(args: argparse.Namespace) -> int:

    model = _model(args.panel)
    p = _finite("--pressure", args.pressure)
    T = _temperature(model, args.delta_T)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = static(model, pressure=p, T=T)
    if not res.converged:
        print("hypate: error: static equilibrium not reached (load stepping and arc length "
              "failed)", file=sys.stderr)
        return 1
    _report_warnings(caught)
    out = {"center_deflection": res.center_deflection(model),
           "max_deflection": res.max_deflection(model)}
    if args.json:
        print(dumps(out))
    else:
        print(f"{args.panel}: centre deflection {out['center_deflection']:.6g} m, "
              f"max deflection {out['max_deflection']:.6g} m"
              + ("" if res.stable else " (unstable equilibrium)"))
    return 0


def _report_warnings(caught: list[warnings.WarningMessage]) -> None:
    # each distinct warning once (a material table clamps at every call)
    for message in dict.fromkeys(str(w.message) for w in caught):
        print(f"hypate: warning: {message}", file=sys.stderr)
