"""Sec. 7.2.3: flutter of a heated simply supported square panel (a/h = 500).

First-order piston theory, LSA sweep of the nondimensional dynamic pressure lambda
(Eq. 6.2a) at Delta T = T_cr and 2 T_cr. Dissertation (Sec. 7.2.3): lambda_F = 344.0
(time domain) / 343.3 (LSA) at T_cr; 191.1 / 190.9 at 2 T_cr, with the divergence
(type I, thermally buckled) range lambda < 183.5 (time domain) / 183.4 (LSA).

Run ``python -m hypate.studies.scripts.ch7_flutter [--coarse] [--out DIR]``.
"""
from __future__ import annotations

from dataclasses import dataclass

import pandas as pd
from hypate.solvers.coupling.flutter import FlutterAnalysis
from hypate.solvers.materials import isotropic
from hypate.solvers.panel import Layer, PanelSpec
from hypate.studies.scripts._table import side_by_side, simple_main

#: Sec. 7.2.3 values (time domain, LSA).
LAMBDA_TCR = (344.0, 343.3)
LAMBDA_2TCR = (191.1, 190.9)
DIVERGENCE_2TCR = (183.5, 183.4)


@dataclass(frozen=True)
class Config:
    """Mesh (n x n elements) and sweep steps for the two temperatures."""

    mesh: int = 12
    step_tcr: float = 20.0
    step_2tcr: float = 10.0
    rtol: float = 1e-4

    @classmethod
    def coarse(cls) -> Config:
        """8 x 8 mesh, coarser sweep and bisection."""
        return cls(mesh=8, step_tcr=40.0, step_2tcr=20.0, rtol=1e-3)


@dataclass(frozen=True)
class Result:
    """Flutter points, divergence bound and the side-by-side table."""

    lambda_tcr: float | None
    lambda_2tcr: float | None
    divergence_upper_2tcr: float | None
    frequency_ratio_tcr: float | None
    table: pd.DataFrame


def panel(mesh: int):
    """The Sec. 7.2.3 plate: a = 1 m, h = 2 mm (a/h = 500), nu = 0.3, alpha = 1.2e-6/K.

    lambda is independent of E and rho; emissivity 0 (no heat transfer in this test).
    """

    mat = isotropic("plate", 2700.0, 70e9, 0.3, 1.2e-6, 100.0, 900.0)
    return PanelSpec(layers=(Layer(mat, 0.002),), mesh=(mesh, mesh), emissivity=0.0)


def run(config: Config | None = None) -> Result:
    """Sweep lambda at T_cr and 2 T_cr (Sec. 7.2.3, Figs. 7.13-7.15)."""

    config = Config() if config is None else config
    p = panel(config.mesh)
    r1 = FlutterAnalysis(p, 1.0, "pt1").sweep(lam_max=400.0, step=config.step_tcr,
                                              rtol=config.rtol)
    r2 = FlutterAnalysis(p, 2.0, "pt1").sweep(lam_max=300.0, step=config.step_2tcr,
                                              rtol=config.rtol)
    div = r2.divergence_range[1] if r2.divergence_range else None
    rows = [
        ("lambda_F at T_cr (time domain)", LAMBDA_TCR[0], r1.lambda_cr),
        ("lambda_F at T_cr (LSA)", LAMBDA_TCR[1], r1.lambda_cr),
        ("lambda_F at 2 T_cr (time domain)", LAMBDA_2TCR[0], r2.lambda_cr),
        ("lambda_F at 2 T_cr (LSA)", LAMBDA_2TCR[1], r2.lambda_cr),
        ("divergence upper bound at 2 T_cr (time domain)", DIVERGENCE_2TCR[0], div),
        ("divergence upper bound at 2 T_cr (LSA)", DIVERGENCE_2TCR[1], div),
        ("instability type at T_cr", "flutter", r1.instability_type),
        ("instability type at 2 T_cr", "flutter", r2.instability_type),
    ]
    return Result(r1.lambda_cr, r2.lambda_cr, div, r1.frequency_ratio,
                  side_by_side(rows))


def main(argv: list[str] | None = None) -> None:
    """``python -m hypate.studies.scripts.ch7_flutter [--coarse] [--out DIR]``."""
    simple_main(__doc__, run, Config, "ch7_flutter",
                "Sec. 7.2.3: panel flutter (first-order piston theory, LSA)", argv)


if __name__ == "__main__":
    main()
