"""Table 9.3: similarity parameters of the Sec. 9.1 prototype and its scaled models.

Prototype (``studies/cases/sec9_1_prototype.toml``, Table 9.1 properties): 1 m x 1 m x 2 mm
Inconel 718 plate, M = 6, p = 1e4 Pa, Delta T = 1 K. Model: Ti 6242 at L = 1/xi m,
xi = 2, 3, 4. The dissertation tabulates the parameters h/L, lambda_F and
Delta T N_Tx L^2/D_xx (Eq. 9.1) of the prototype and of the models found by its Bayesian
optimization. Here the model rows are those of the analytical laws (Eq. 9.2), which match
the prototype exactly; with ``optimize_dirs`` (``--optimize DIR ...``) the models of
``hypate run studies/optimization/sec9_1_xi*.toml`` run directories are tabulated as well.

Run ``python -m hypate.studies.scripts.ch9_table9_3 [--coarse] [--out DIR]
[--optimize RUN_DIR ...]``.
"""
from __future__ import annotations

import dataclasses
import json
import warnings
from dataclasses import dataclass
from pathlib import Path

import pandas as pd
from hypate.scaling.workflow.vocabulary.configuration import Configuration
from hypate.scaling.workflow.vocabulary.shipped import shipped
from hypate.scaling.workflow.vocabulary.similarity import analytical_scaling, similarity_parameters
from hypate.solvers.config import load_case
from hypate.solvers.materials import library_material
from hypate.studies.scripts.comparison import Approx, publish, side_by_side, standard_parser

NAMES = ("h/L", "lambda_F", "DeltaT_NTx_L2/Dxx")
#: Table 9.3 (prototype, then the optimized models at xi = 2, 3, 4).
PROTOTYPE = {"h/L": 0.002, "lambda_F": 566.07, "DeltaT_NTx_L2/Dxx": 47.882}
OPTIMIZED = {2.0: {"h/L": 0.00201, "lambda_F": 566.85, "DeltaT_NTx_L2/Dxx": 47.581},
             3.0: {"h/L": 0.00200, "lambda_F": 561.38, "DeltaT_NTx_L2/Dxx": 47.759},
             4.0: {"h/L": 0.00200, "lambda_F": 566.69, "DeltaT_NTx_L2/Dxx": 47.671}}
#: Agreement asked: the prototype row to 0.1 % (Table 9.1's properties give it exactly up
#: to their rounding); a model row to 1 % (the dissertation's optimized models lie up to
#: 0.8 % off its prototype); a design variable to 5 % of Eq. 9.2 (the numerically best
#: model lies 1-3 % off it, README "Study files").
RTOL_PROTOTYPE, RTOL_MODEL, RTOL_DESIGN = 0.001, 0.01, 0.05


@dataclass(frozen=True)
class Config:
    """Geometric scales and optional ``hypate run`` directories of the Sec. 9.1 studies."""

    xis: tuple[float, ...] = (2.0, 3.0, 4.0)
    optimize_dirs: tuple[str, ...] = ()

    @classmethod
    def coarse(cls) -> Config:
        """Same as the default (closed forms only; well under a second)."""
        return cls()


@dataclass(frozen=True)
class Result:
    """Prototype parameters, analytical designs per xi and the side-by-side table."""

    prototype: dict[str, float]
    analytical: dict[float, dict[str, float]]
    designs: dict[float, dict[str, float]]
    optimized: dict[str, dict[str, float | None]]
    table: pd.DataFrame


def sec9_1_configurations():
    """(prototype, model template)
    :class:`hypate.scaling.workflow.vocabulary.similarity.Configuration` of Sec. 9.1."""

    case = load_case(shipped("case")["sec9_1_prototype"])
    proto = Configuration(case.panel, case.flow, delta_T=1.0, time=1e-3)
    layer = dataclasses.replace(case.panel.layers[0], material=library_material("ti6242"))
    model = Configuration(dataclasses.replace(case.panel, layers=(layer,)), case.flow)
    return proto, model


def read_design_point(run_dir: str | Path) -> dict:
    """``design_point.json`` of a ``hypate run`` directory."""
    path = Path(run_dir) / "design_point.json"
    return json.loads(path.read_text(encoding="utf-8"))


def _model(value: float | None) -> Approx | None:
    """A published model-row value with its tolerance."""
    return None if value is None else Approx(value, rel=RTOL_MODEL)


def run(config: Config | None = None) -> Result:
    """Tabulate Table 9.3 against hypate (Eqs. 9.1-9.3)."""

    config = Config() if config is None else config
    proto, template = sec9_1_configurations()
    p = similarity_parameters(proto, names=list(NAMES))
    rows: list[tuple] = [(f"prototype {n}", Approx(PROTOTYPE[n], rel=RTOL_PROTOTYPE), p[n])
                         for n in NAMES]
    analytical: dict[float, dict[str, float]] = {}
    designs: dict[float, dict[str, float]] = {}
    for xi in config.xis:
        a = analytical_scaling(proto, template, xi)
        m = similarity_parameters(a.model, names=list(NAMES))
        analytical[xi], designs[xi] = dict(m), a.design()
        ref = OPTIMIZED.get(float(xi), {})
        for n in NAMES:
            rows.append((f"xi = {xi:g} {n} (dissertation: BO model; hypate: Eq. 9.2)",
                         _model(ref.get(n)), m[n]))
        for k, v in a.design().items():
            rows.append((f"xi = {xi:g} Eq. 9.2 design {k}", None, v, "Fig. 9.4 (not tabulated)"))
    optimized: dict[str, dict[str, float | None]] = {}
    for d in config.optimize_dirs:
        try:
            dp = read_design_point(d)
        except (OSError, ValueError) as exc:
            warnings.warn(f"{d}: no readable design_point.json ({exc})", stacklevel=2)
            continue
        xi = float(dp.get("xi") or 0.0)
        sim = {s["name"]: s["model"] for s in dp.get("similarity", [])}
        optimized[str(d)] = {**{n: sim.get(n) for n in NAMES}, **dp.get("design", {})}
        ref = OPTIMIZED.get(xi, {})
        for n in NAMES:
            rows.append((f"xi = {xi:g} {n} (optimized, {Path(d).name})", _model(ref.get(n)),
                         sim.get(n)))
        for k, v in dp.get("design", {}).items():
            rows.append((f"xi = {xi:g} optimized design {k} ({Path(d).name})",
                         designs.get(xi, {}).get(k), v, "dissertation column: Eq. 9.2 value"))
    return Result(dict(p), analytical, designs, optimized,
                  side_by_side(rows, rtol=RTOL_DESIGN))


def main(argv: list[str] | None = None) -> None:
    """``python -m hypate.studies.scripts.ch9_table9_3 [--coarse] [--out DIR]
    [--optimize RUN_DIR ...]``."""
    parser = standard_parser(__doc__.splitlines()[0])
    parser.add_argument("--optimize", nargs="*", default=[], metavar="RUN_DIR",
                        help="run directories of `hypate run studies/optimization/sec9_1_xi*.toml`")
    args = parser.parse_args(argv)
    base = Config.coarse() if args.coarse else Config()
    res = run(dataclasses.replace(base, optimize_dirs=tuple(args.optimize)))
    title = "Table 9.3: similarity parameters, prototype and scaled models"
    publish(res.table, args.out, "ch9_table9_3", title)


if __name__ == "__main__":
    main()
