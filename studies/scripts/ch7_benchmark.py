"""Sec. 7.3: aerothermoelastic benchmark of the 2D Al 7075 panel (snap-through onset).

Case ``studies/cases/sec7_3_benchmark.toml``: a = 1 m, h = 2.5 mm, L_le = 1 m, simply
supported, M = 4, p = 2087.2 Pa, T = 266.7 K, full piston theory with turbulent Eckert
heating. The panel heats up, deforms into the flow and snaps through; the dissertation
reports the onset at 2.02 s (Table 8.2, analytic models, case 2) and "near t = 2.1 s" in
Fig. 7.16. Here both coupled schemes are run: the loosely coupled S2 (transient, dt = 1 ms,
rho_bar = 0.9) and the tightly coupled quasi-steady TC (dt on the thermal scale, LSA each
step).

Run ``python -m hypate.studies.scripts.ch7_benchmark [--coarse] [--out DIR]``.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from hypate.scaling.workflow.vocabulary.shipped import shipped
from hypate.solvers.aero.factory import make_fluid_model
from hypate.solvers.config import parse_case, read_toml, settings_from_config
from hypate.solvers.coupling.lc import run_lc
from hypate.solvers.coupling.model import PanelModel
from hypate.solvers.coupling.tc import run_tc
from hypate.studies.scripts.comparison import Approx, side_by_side, simple_main

CASE = shipped("case")["sec7_3_benchmark"]
#: Snap-through onset (s): Table 8.2 AM case 2 (= the Sec. 7.3 benchmark).
ONSET = 2.02
#: Fig. 7.16 text: "Near t = 2.1 s ... snap-through occurs".
ONSET_FIG_7_16 = 2.1
#: Agreement asked of an onset: 5 % (the dissertation's own two values, 2.02 and "near
#: 2.1 s", are 4 % apart).
RTOL = 0.05


def benchmark_model(time_step: float, duration: float, *, aero: str | None = None,
                    leading_edge_length: float | None = None, width: float | None = None,
                    mesh: tuple[int, ...] | None = None, keep_fields: bool = False):
    """The Sec. 7.3 benchmark as a :class:`hypate.solvers.coupling.model.PanelModel`.

    Parameters
    ----------
    time_step, duration : float
        s.
    aero : str, optional
        Aerodynamic model (default that of the case file, full piston theory ``"pt"``;
        ``"pt-bl"`` adds the boundary-layer effective shape, Sec. 8.1).
    leading_edge_length : float, optional
        L_le (m), sets the boundary-layer thickness (Table 8.1).
    width : float, optional
        Makes the panel 3D with this span (m), Sec. 8.2.
    mesh : tuple of int, optional
        Element counts (one for 2D, two for 3D).
    """

    case = parse_case(read_toml(str(CASE)), source=str(CASE))
    assert case.simulation is not None and case.flow is not None  # the shipped case has both
    sim = case.simulation
    panel = case.panel
    changes: dict[str, Any] = {}
    if leading_edge_length is not None:
        changes["leading_edge_length"] = float(leading_edge_length)
    if width is not None:
        changes["kind"] = "3d"
        changes["width"] = float(width)
    if mesh is not None:
        changes["mesh"] = tuple(mesh)
    if changes:
        panel = dataclasses.replace(panel, **changes)
    settings = dataclasses.replace(settings_from_config(sim), time_step=time_step,
                                   duration=duration, keep_fields=keep_fields)
    fluid = make_fluid_model(aero or sim.aero, sim.heating, sim.boundary_layer)
    return PanelModel(panel, case.flow, fluid, settings)


def snap_summary(resp, thickness: float = 2.5e-3) -> tuple[float | None, float]:
    """(onset time or None, peak centre deflection / h before the onset)."""
    t = np.asarray(resp.times)
    w = np.asarray(resp.center_deflection)
    onset = resp.instability_time if resp.status == "unstable" else None
    pre = t < onset if onset is not None else np.ones_like(t, dtype=bool)
    peak = float(np.max(w[pre]) / thickness) if np.any(pre) else float("nan")
    return onset, peak


@dataclass(frozen=True)
class Config:
    """Time steps and which schemes to run."""

    duration: float = 2.5
    tc_time_step: float = 0.025
    lc_time_step: float = 0.001
    run_lc: bool = True
    rho_bar: float = 0.9

    @classmethod
    def coarse(cls) -> Config:
        """TC only, dt = 0.1 s (about 3 s of computing)."""
        return cls(tc_time_step=0.1, run_lc=False)


@dataclass(frozen=True)
class Result:
    """Onsets (s), peak deflections (w/h) and the side-by-side table."""

    tc_onset: float | None
    tc_type: str | None
    tc_peak: float
    lc_onset: float | None
    lc_peak: float | None
    table: pd.DataFrame


def run(config: Config | None = None) -> Result:
    """Run the TC (and, by default, LC S2) scheme on the Sec. 7.3 benchmark."""

    config = Config() if config is None else config
    tc = run_tc(benchmark_model(config.tc_time_step, config.duration))
    tc_on, tc_peak = snap_summary(tc)
    none = f"none by {config.duration:g} s"
    rows = [(f"snap-through onset, TC dt = {config.tc_time_step:g} s (s)", ONSET,
             none if tc_on is None else tc_on),
            ("snap-through onset, TC vs Fig. 7.16 'near 2.1 s' (s)", ONSET_FIG_7_16,
             none if tc_on is None else tc_on),
            ("instability type, TC (a snap-through is a divergence)", "divergence",
             tc.instability_type or "none"),
            ("peak w/h before the snap, TC", None, tc_peak, "Fig. 7.16 (not tabulated)")]
    lc_on = lc_peak = None
    if config.run_lc:
        lc = run_lc(benchmark_model(config.lc_time_step, config.duration), "s2",
                    rho_bar=config.rho_bar, record_every=5)
        lc_on, lc_peak = snap_summary(lc)
        rows += [(f"snap-through onset, LC S2 dt = {config.lc_time_step:g} s (s)", ONSET,
                  none if lc_on is None else lc_on),
                 ("peak w/h before the snap, LC S2", None, lc_peak,
                  "Fig. 7.16 (not tabulated)"),
                 # "almost identical": within the onsets' own tolerance
                 ("TC onset - LC onset (s)", Approx(0.0, abs=RTOL * ONSET),
                  None if (tc_on is None or lc_on is None) else tc_on - lc_on,
                  "schemes 'almost identical' (Sec. 7.3.2.1)")]
    return Result(tc_on, tc.instability_type, tc_peak, lc_on, lc_peak,
                  side_by_side(rows, rtol=RTOL))


def main(argv: list[str] | None = None) -> None:
    """``python -m hypate.studies.scripts.ch7_benchmark [--coarse] [--out DIR]``."""
    simple_main(__doc__, run, Config, "ch7_benchmark",
                "Sec. 7.3: aerothermoelastic benchmark (2D Al 7075 panel, M = 4)", argv)


if __name__ == "__main__":
    main()
