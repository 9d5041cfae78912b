"""scaling/workflow/campaigns/resources.py: the sizes the estimate is built on are the simulator's
own, the estimate grows with them, and a study too large for the memory available is
refused before anything runs (``--force`` runs it)."""
from __future__ import annotations

import dataclasses
import math

import pytest
from conftest import PROTOTYPE_CASE
from hypate.scaling.workflow.campaigns.resources import (
    SimulationSize,
    check_resources,
    estimate,
    local_workers,
    simulation_size,
    study_estimate,
)
from hypate.scaling.workflow.vocabulary.study import load_study
from hypate.solvers.config import load_case
from hypate.solvers.errors import InputError
from hypate.solvers.panel import thermal_levels
from hypate.solvers.structure.model import StructuralModel
from hypate.solvers.thermal.model import ThermalModel


@pytest.mark.parametrize("mesh", [(2, 2), (4, 4), (6, 3), (3, 7)])
@pytest.mark.parametrize("core_sublayers", [1, 4])
def test_the_sizes_are_the_models_own(mesh: tuple[int, int], core_sublayers: int) -> None:
    panel = load_case(PROTOTYPE_CASE).panel
    layers = list(panel.layers)
    layers[1] = dataclasses.replace(layers[1], sublayers=core_sublayers)
    panel = dataclasses.replace(panel, mesh=mesh, layers=tuple(layers))
    size = SimulationSize(mesh, len(thermal_levels(panel)), 1)
    thermal = ThermalModel(panel)
    assert size.thermal == (thermal.n_nodes, thermal._banded.bw)
    shell = StructuralModel(panel)
    assert size.structural == (shell.n_dof, shell.solver.bandwidth)


def test_simulation_size_reads_mesh_levels_and_steps(tiny_study) -> None:
    study = load_study(tiny_study(mesh=3, steps=7))
    size = simulation_size(study.spec.prototype)
    assert size.mesh == (3, 3) and size.steps == 7
    assert size.levels == 5  # the Sec. 9.2 sandwich: 1 + 2 + 1 sub-layers


def test_the_estimate_grows_with_mesh_levels_and_steps() -> None:
    base = estimate(SimulationSize((8, 8), 3, 10))
    for bigger in (SimulationSize((16, 16), 3, 10), SimulationSize((8, 8), 6, 10)):
        e = estimate(bigger)
        assert e.memory > base.memory and e.seconds > base.seconds
    longer = estimate(SimulationSize((8, 8), 3, 40))
    assert longer.memory == base.memory and longer.seconds > base.seconds
    assert base.memory > 0 and base.seconds > 0  # calibrated, not left at zero


def test_a_study_beyond_the_memory_available_is_refused_unless_forced(tiny_study) -> None:
    study = load_study(tiny_study(mesh=6))
    needed = study_estimate(study, 2, available=math.inf).needed
    with pytest.raises(InputError) as info:
        check_resources(study, 2, available=needed / 2)
    assert info.value.field == "simulation.mesh"
    assert "6x6 mesh needs about" in info.value.message and "--force" in info.value.message
    assert check_resources(study, 2, available=needed / 2, force=True).needed == needed
    assert check_resources(study, 2, available=needed * 2).needed == needed
    # two model evaluations at once need twice one
    one = study_estimate(study, 1, available=math.inf)
    assert needed == pytest.approx(max(one.prototype.memory, 2 * one.model.memory))


def test_local_workers() -> None:
    assert local_workers(3, None) == 3
    assert local_workers(1, "local:4") == 4
    assert local_workers(2, "tls://cluster:8786") is None


def test_the_tiny_study_is_small_enough_anywhere(tiny_study) -> None:
    est = study_estimate(load_study(tiny_study()), 2, available=math.inf)
    assert est.needed < 200 * 2**20  # well under any CI machine's memory
