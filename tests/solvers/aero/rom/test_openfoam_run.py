"""OpenFOAM case writer and runner: real rhoCentralFoam runs on tiny meshes, checked against
the exact oblique-shock relations (the fast CI check of the CFD snapshot source)."""
from __future__ import annotations

import math
import shutil

import numpy as np
import pytest
from hypate.solvers.aero.rom.openfoam_case import (
    CaseSpec,
    Resolution,
    first_cell_grading,
    wedge_wall,
    write_case,
)
from hypate.solvers.aero.rom.openfoam_run import (
    NOT_FOUND,
    drift,
    find_openfoam,
    read_averages,
    run_case,
)
from hypate.solvers.aero.shock_expansion import oblique_shock
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition
from hypate.studies.scripts.cfd_verification import mapped_from

HAVE_OPENFOAM = shutil.which("rhoCentralFoam") is not None
needs_openfoam = pytest.mark.skipif(
    not HAVE_OPENFOAM, reason="OpenFOAM is not installed (apt-get install openfoam; "
    ".ci/run installs it as root)")


def test_grading_gives_the_first_cell():
    # geometric progression: first cell 1 mm, 40 cells over 0.5 m
    g = first_cell_grading(0.5, 1e-3, 40)
    r = g ** (1.0 / 39)
    assert 1e-3 * (r**40 - 1.0) / (r - 1.0) == pytest.approx(0.5, rel=1e-9)
    assert first_cell_grading(0.5, 0.1, 10) == 1.0  # uniform cells are already coarser


def test_drift_of_a_history():
    assert drift(np.full(10, 5.0)) == 0.0
    assert drift(np.r_[np.full(5, 1.0), np.full(5, 1.02)]) == pytest.approx(0.02 / 1.01)


def test_missing_openfoam_is_refused_in_one_line(monkeypatch):
    monkeypatch.setattr(shutil, "which", lambda name: None)
    with pytest.raises(InputError) as err:
        find_openfoam()
    assert err.value.field == "source.kind" and err.value.message == NOT_FOUND


def test_case_rejects_a_wall_that_goes_back(tmp_path):
    plate, panel = wedge_wall(5.0)
    panel = panel[::-1]
    with pytest.raises(InputError, match="wall"):
        write_case(tmp_path, CaseSpec(plate, panel, FlowCondition.from_altitude(6, 25000),
                                      300.0))


@needs_openfoam
def test_tiny_wedge_matches_the_oblique_shock(tmp_path):
    """Euler, M 6 at 25 km on a 5 deg wedge, 24 x 20 cells: the mean panel pressure within
    1 % of the exact oblique-shock value (the shock is captured over a few cells; the
    panel, a wall length behind the leading edge, sees the uniform post-shock state)."""
    flow = FlowCondition.from_altitude(6.0, 25000.0)
    res = Resolution(cells_panel=12, cells_plate=12, cells_normal=20, wall_cell=0.02,
                     height=0.5, courant=0.2, max_iterations=20000, sample_every=25, window=8,
                     tolerance=2e-3)
    spec = CaseSpec(*wedge_wall(5.0), flow, 300.0, "euler", res)
    result = run_case(write_case(tmp_path / "wedge", spec), find_openfoam(), res, False,
                      timeout=120.0)
    assert result.converged, result.reason
    exact = flow.pressure * float(oblique_shock(6.0, math.radians(5.0))[1])  # 5124.6 Pa
    assert np.mean(result.pressure) == pytest.approx(exact, rel=0.01)
    assert result.iterations < res.max_iterations  # stopped by the convergence check
    assert result.x.size == 12 and np.all(np.diff(result.x) > 0)


@needs_openfoam
def test_unconverged_case_is_rejected_with_its_reason(tmp_path):
    flow = FlowCondition.from_altitude(6.0, 25000.0)
    res = Resolution(cells_panel=8, cells_plate=8, cells_normal=10, wall_cell=0.03,
                     max_iterations=100, sample_every=25, window=8)
    spec = CaseSpec(*wedge_wall(5.0), flow, 300.0, "euler", res)
    result = run_case(write_case(tmp_path / "short", spec), find_openfoam(), res, False)
    assert not result.converged
    assert result.reason.startswith("not converged after 100 iterations")


@needs_openfoam
def test_a_case_folder_used_again_gives_the_new_cases_wall(tmp_path):
    """A second case written into the folder of a finished one: the solver's function
    objects would leave the first run's averages and samples beside the new ones; run_case
    starts without them, so the 10 deg wedge gives its own oblique-shock pressure (within
    1 %), not the 5 deg wedge's."""
    flow = FlowCondition.from_altitude(6.0, 25000.0)
    res = Resolution(cells_panel=12, cells_plate=12, cells_normal=20, wall_cell=0.02,
                     height=0.5, courant=0.2, max_iterations=20000, sample_every=25, window=8,
                     tolerance=2e-3)
    foam = find_openfoam()
    results = {}
    for angle in (5.0, 10.0):
        spec = CaseSpec(*wedge_wall(angle), flow, 300.0, "euler", res)
        results[angle] = run_case(write_case(tmp_path / "same", spec), foam, res, False,
                                  timeout=120.0)
        assert results[angle].converged, results[angle].reason
        exact = flow.pressure * float(oblique_shock(6.0, math.radians(angle))[1])
        assert np.mean(results[angle].pressure) == pytest.approx(exact, rel=0.01), angle
    assert results[10.0].iterations >= res.window * res.sample_every


@needs_openfoam
def test_a_finer_mesh_starts_from_the_coarser_cases_state(tmp_path):
    """The grid studies' coarse-to-fine start (``mapped_from``, OpenFOAM's mapFields): the
    5 deg wedge run 1,500 iterations on 24 x 20 cells (mean panel pressure within 1 % of the
    oblique-shock value), then a 36 x 30 mesh started from it: its first sample, 25
    iterations in, is within 2 % of that value, where the same mesh started from the free
    stream is still in its start-up transient (6,091 Pa, +19 %)."""
    flow = FlowCondition.from_altitude(6.0, 25000.0)
    coarse = Resolution(cells_panel=12, cells_plate=12, cells_normal=20, wall_cell=0.02,
                        height=0.5, courant=0.2, max_iterations=1500, sample_every=25,
                        window=8, tolerance=0.0)
    fine = Resolution(cells_panel=18, cells_plate=18, cells_normal=30, wall_cell=0.0133,
                      height=0.5, courant=0.2, max_iterations=25, sample_every=25, window=1,
                      tolerance=0.0)
    foam = find_openfoam()
    exact = flow.pressure * float(oblique_shock(6.0, math.radians(5.0))[1])
    first = run_case(write_case(tmp_path / "coarse", CaseSpec(*wedge_wall(5.0), flow, 300.0,
                                                              "euler", coarse)),
                     foam, coarse, False, timeout=120.0)
    assert first.iterations == coarse.max_iterations  # ran to its end and wrote its state
    assert read_averages(tmp_path / "coarse")[-1, 1] == pytest.approx(exact, rel=0.01)
    case = write_case(tmp_path / "fine", CaseSpec(*wedge_wall(5.0), flow, 300.0, "euler",
                                                  fine))
    run_case(case, foam, fine, False, timeout=120.0,
             after_mesh=mapped_from(tmp_path / "coarse"))
    first_sample = read_averages(case)[0]
    assert first_sample[0] == 25
    assert first_sample[1] == pytest.approx(exact, rel=0.02)
