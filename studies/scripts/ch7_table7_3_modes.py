"""Table 7.3: natural frequencies of the clamped Table 7.2 panel (Sec. 7.2.1.1).

Panel: 9 in x 18 in x 0.0401 in, rho = 110 lb/ft^3, E = 5.6 Msi, nu = 0.35, clamped on all
edges, 10 x 20 elements (the dissertation's structural mesh). The dissertation compares the
first five frequencies with the analytical values of Ref. [4] (109.7, 142.0, 199.8, 282.6,
285.5 Hz) and reports its own shell model 0.25-0.32 % high.

Run ``python -m hypate.studies.scripts.ch7_table7_3_modes [--coarse] [--out DIR]``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from hypate.solvers.materials import isotropic
from hypate.solvers.panel import Layer, PanelSpec
from hypate.solvers.structure.modal import modes
from hypate.solvers.structure.model import StructuralModel
from hypate.studies.scripts.comparison import Approx, side_by_side, simple_main

INCH, LBFT3, PSI = 0.0254, 16.018463373960142, 6894.757293168361
#: Table 7.3, "Analytical, Hz [4]" column.
ANALYTICAL_HZ = (109.7, 142.0, 199.8, 282.6, 285.5)
#: Table 7.3, "Current, Hz" column (the dissertation's own DCS9 shell model).
DISSERTATION_HZ = (110.0, 142.4, 200.3, 283.4, 286.4)
#: Agreement asked: 1 % of the analytical values (the dissertation's DCS9 on this mesh sits
#: 0.25-0.32 % high: the discretization error) and 0.2 % of its DCS9 values (the same
#: element and mesh; the table rounds to 0.05-0.1 %).
RTOL_ANALYTICAL, RTOL_DCS9 = 0.01, 0.002


@dataclass(frozen=True)
class Config:
    """Mesh (streamwise, spanwise) and number of modes."""

    mesh: tuple[int, int] = (10, 20)
    count: int = 5

    @classmethod
    def coarse(cls) -> Config:
        """The same mesh (the modal problem takes well under a second)."""
        return cls(mesh=(10, 20))


@dataclass(frozen=True)
class Result:
    """Frequencies (Hz) and the side-by-side table."""

    frequencies_hz: tuple[float, ...]
    table: pd.DataFrame


def run(config: Config | None = None) -> Result:
    """Compute the first five frequencies of the Table 7.2 panel (Table 7.3)."""

    config = Config() if config is None else config
    mat = isotropic("table7_2", 110.0 * LBFT3, 5.6e6 * PSI, 0.35, 1e-5, 1.0, 1.0)
    panel = PanelSpec(layers=(Layer(mat, 0.0401 * INCH),), length=9 * INCH, width=18 * INCH,
                      mesh=(config.mesh[0], config.mesh[1]), boundary="clamped")
    f = np.asarray(modes(StructuralModel(panel), config.count).frequencies_hz, dtype=float)
    rows = []
    for i in range(min(config.count, 5)):
        rows.append((f"mode {i + 1} frequency (Hz), vs analytical [4]",
                     Approx(ANALYTICAL_HZ[i], rel=RTOL_ANALYTICAL), float(f[i])))
        rows.append((f"mode {i + 1} frequency (Hz), vs dissertation DCS9",
                     Approx(DISSERTATION_HZ[i], rel=RTOL_DCS9), float(f[i])))
    return Result(tuple(float(x) for x in f), side_by_side(rows))


def main(argv: list[str] | None = None) -> None:
    """``python -m hypate.studies.scripts.ch7_table7_3_modes [--coarse] [--out DIR]``."""
    simple_main(__doc__, run, Config, "ch7_table7_3_modes",
                "Table 7.3: natural frequencies of the clamped panel", argv)


if __name__ == "__main__":
    main()
