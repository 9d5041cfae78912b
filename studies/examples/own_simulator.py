"""A scaling study's own simulator (README, "Your own simulator"; the protocol of
``hypate.scaling.workflow.vocabulary.external``).

``simulate(configuration)`` receives one test article -- the prototype in flight or a model
design in the tunnel -- and returns the nondimensional histories J compares. Here hypate's
own coupled solver stands in for "your code": replace the marked line with a call to your
FE code, a cluster job or a lookup of measured data, and convert what it gives into the
same four fields.
"""
from __future__ import annotations

import numpy as np
from hypate import ModelFailure, SimulatedHistories
from hypate.scaling.workflow.vocabulary.configuration import Configuration, simulate_configuration


def simulate(configuration: Configuration) -> SimulatedHistories:
    """The histories of ``configuration`` at time levels ``0, dt, ..., n_steps dt``
    (``configuration.simulation.time_step``, ``.n_steps``)."""
    response = simulate_configuration(configuration)  # <- your code here
    if response.status == "failed":  # a design it cannot simulate: a failed evaluation
        raise ModelFailure(response.message)
    extremes = response.extremes()
    return SimulatedHistories(
        deflection=np.asarray(response.center_deflection) / configuration.panel.thickness,
        temperature=(np.asarray(response.mean_temperature)
                     / configuration.flow.stagnation_temperature),
        layer_temperature=extremes["layer_temperature"],   # the temperature and data checks
        max_stress_ratio=extremes["max_stress_ratio"],     # the stress check
        stress_at_ratio=extremes["stress_at_ratio"])
