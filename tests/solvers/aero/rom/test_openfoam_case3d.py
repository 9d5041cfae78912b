"""The 3-D Euler case of a deformed panel in a flat wall (the check of the strip-wise 2-D CFD
ROM): its deformation, its mesh after blockMesh and the point move, and a flat wall that
keeps the free stream."""
from __future__ import annotations

import re
import shutil
import subprocess
from functools import partial

import numpy as np
import pytest
from hypate.solvers.aero.rom.openfoam_case import Resolution
from hypate.solvers.aero.rom.openfoam_case3d import (
    PanelCase3D,
    deform_points,
    panel_deflection,
    write_case_3d,
)
from hypate.solvers.aero.rom.openfoam_run import find_openfoam, run_case
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition

needs_openfoam = pytest.mark.skipif(
    shutil.which("rhoCentralFoam") is None, reason="OpenFOAM is not installed (apt-get "
    "install openfoam; .ci/run installs it as root)")

FLOW = FlowCondition.from_altitude(6.0, 25000.0)
#: A coarse half-span case: (2 + 8) x (4 + 2) x 6 = 360 cells.
RES = Resolution(courant=0.2, sample_every=25, window=8, tolerance=1e-3, max_iterations=4000)


def _case(amplitudes=(0.02, -0.005), modes=((1, 1), (2, 3)), **kw) -> PanelCase3D:
    kw = {"cells_plate": 2, "cells_panel": 8, "cells_span": 4, "cells_margin": 2,
          "cells_normal": 6, "wall_cell": 0.02, "height": 0.5, "resolution": RES, **kw}
    return PanelCase3D(0.8, 0.6, 0.3, np.array(modes), np.array(amplitudes, float), FLOW, **kw)


def test_panel_deflection_is_the_sum_of_its_modes_and_zero_off_the_panel():
    case = _case()
    x, y = np.array([0.2, 0.4, -0.1, 0.9, 0.4]), np.array([0.15, 0.3, 0.3, 0.3, 0.7])
    want = (0.02 * np.sin(np.pi * x / 0.8) * np.sin(np.pi * y / 0.6)
            - 0.005 * np.sin(2 * np.pi * x / 0.8) * np.sin(3 * np.pi * y / 0.6))
    want[2:] = 0.0  # ahead of, behind and beside the panel
    np.testing.assert_allclose(panel_deflection(case, x, y), want, rtol=0, atol=1e-15)


def test_a_half_span_case_needs_modes_symmetric_about_the_centre_line(tmp_path):
    with pytest.raises(InputError, match="odd n"):
        write_case_3d(tmp_path / "c", _case(modes=((1, 1), (1, 2))))


def _mesh(folder, case):
    write_case_3d(folder, case)
    foam = find_openfoam()
    subprocess.run([foam.block_mesh, "-case", str(folder)], env=foam.environment(),
                   capture_output=True, check=True, timeout=120)


def _points(folder):
    text = (folder / "constant" / "polyMesh" / "points").read_text()
    body = text[text.index("(", text.index("\n", text.index("}"))):]
    return np.array(re.findall(r"\(([-+0-9.eE]+) ([-+0-9.eE]+) ([-+0-9.eE]+)\)", body),
                    float)


@needs_openfoam
@pytest.mark.parametrize("half_span", [True, False])
def test_meshed_wall_is_moved_onto_the_deformed_panel(tmp_path, half_span):
    modes = ((1, 1), (2, 3)) if half_span else ((1, 1), (2, 2))
    case = _case(modes=modes, half_span=half_span)
    _mesh(tmp_path, case)
    flat = _points(tmp_path)
    # blockMesh's points: (nx + 1)(ny + 1)(nz + 1) of the four blocks' structured mesh
    assert flat.shape == ((2 + 8 + 1) * (4 + 2 + 1) * (6 + 1), 3)
    applied = deform_points(tmp_path, case)
    moved = _points(tmp_path)
    w = panel_deflection(case, flat[:, 0] - 0.3, flat[:, 1])
    # z + w (1 - z / H): the wall (z = 0) exactly on the panel, the top (z = H) fixed
    np.testing.assert_allclose(moved[:, 2], flat[:, 2] + w * (1 - flat[:, 2] / 0.5),
                               atol=1e-11)
    np.testing.assert_array_equal(moved[:, :2], flat[:, :2])
    wall, top = np.isclose(flat[:, 2], 0.0), np.isclose(flat[:, 2], 0.5)
    np.testing.assert_allclose(moved[wall, 2], w[wall], atol=1e-11)
    np.testing.assert_array_equal(moved[top, 2], flat[top, 2])
    assert applied == pytest.approx(np.max(np.abs(w)), rel=1e-12) and applied > 0.01
    # the half-span mesh starts at the centre line
    assert flat[:, 1].min() == pytest.approx(0.3 if half_span else 0.0)


@needs_openfoam
def test_flat_wall_keeps_the_free_stream(tmp_path):
    """Euler over an undeformed wall: the uniform free stream is the exact steady solution,
    so the panel's wall pressure is p_inf (conservation; here within 0.1 %)."""
    case = _case(amplitudes=(0.0, 0.0))
    r = run_case(write_case_3d(tmp_path / "c", case), find_openfoam(), RES, False,
                 after_mesh=partial(deform_points, case=case), timeout=300)
    assert r.converged, r.reason
    assert r.x.size == 8 * 4  # the panel's faces, half span
    assert np.all((r.x > 0.3) & (r.x < 1.1) & (r.y > 0.3) & (r.y < 0.6))
    np.testing.assert_allclose(r.pressure, FLOW.pressure, rtol=1e-3)
    np.testing.assert_allclose(r.temperature, FLOW.temperature, rtol=1e-3)
