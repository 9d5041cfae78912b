"""The run entry of the simulator: one case from its validated configuration tables."""
from __future__ import annotations

from dataclasses import replace

from hypate.solvers.aero.factory import make_fluid_model
from hypate.solvers.config import settings_from_config
from hypate.solvers.coupling.lc import run_lc
from hypate.solvers.coupling.model import PanelModel
from hypate.solvers.coupling.response import Response
from hypate.solvers.coupling.tc import run_tc
from hypate.solvers.flow import FlowCondition
from hypate.solvers.panel import PanelSpec


def simulate(panel: PanelSpec, flow: FlowCondition, sim, progress=None,
             keep_fields: bool = True) -> Response:
    """Run a case: ``sim`` is a validated ``[simulation]`` table (scheme, aero, heating...).

    The entry point of ``hypate simulate`` and of the scaling problem's evaluations.
    """

    fluid = make_fluid_model(sim.aero, sim.heating, sim.boundary_layer)
    settings = replace(settings_from_config(sim), keep_fields=keep_fields)
    model = PanelModel(panel, flow, fluid, settings)
    if sim.scheme == "tc":
        return run_tc(model, progress=progress)
    every = max(1, int(round(0.01 / sim.time_step)))  # record about every 10 ms
    return run_lc(model, sim.scheme, record_every=every, progress=progress)
