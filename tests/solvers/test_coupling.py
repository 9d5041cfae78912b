"""Coupled model: aerodynamic operators, equilibrium, heat-input conservation, TC runs."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from scaling.cli import main
from solvers.aero.analytic import make_fluid_model
from solvers.coupling import CouplingSettings, PanelModel, run_tc
from solvers.flow import FlowCondition
from solvers.materials import isotropic, library_material
from solvers.panel import Layer, PanelSpec
from solvers.response import Response

FLOW = FlowCondition.from_altitude(6.0, 25000.0)


def _panel(mesh=(4, 4), thickness=0.002, **kw) -> PanelSpec:
    mat = library_material("inconel718")
    return PanelSpec(layers=(Layer(mat, thickness, 0.0, 2),), mesh=mesh, **kw)


def test_aero_stiffness_and_damping_match_finite_differences() -> None:
    m = PanelModel(_panel(), FLOW, make_fluid_model("pt-bl"), CouplingSettings())
    st = m.structure
    rng = np.random.default_rng(2)
    u = np.zeros(st.n_dof)
    u[2::5] = 0.003 * np.sin(math.pi * st.mesh.x) * np.sin(math.pi * st.mesh.y)
    T = m.thermal.initial_state() + rng.uniform(0, 200, m.thermal.n_nodes)
    Tw = m.wall_temperature(T)
    loads = m.fluid_loads(u, Tw, jacobians=True)
    KA, CA = m.aero_stiffness(loads), m.aero_damping(loads)
    d = rng.normal(0, 1e-3, st.n_dof)
    h = 1e-3
    fd = (m.aero_force(m.fluid_loads(u + h * d, Tw)) - m.aero_force(m.fluid_loads(u - h * d, Tw))) / (2 * h)
    # K_A = dF_S/du through the transfer (Eq. 5.34); central differences, 1e-6 relative
    assert np.linalg.norm(KA @ d - fd) <= 1e-6 * np.linalg.norm(fd)
    v = rng.normal(0, 1.0, st.n_dof)
    fdv = (m.aero_force(m.fluid_loads(u, Tw, u_dot=h * v)) - m.aero_force(m.fluid_loads(u, Tw, u_dot=-h * v))) / (2 * h)
    assert np.linalg.norm(CA @ v - fdv) <= 1e-6 * np.linalg.norm(fdv)


def test_equilibrium_under_external_pressure_matches_navier() -> None:
    # A near-vacuum flow (p = 1 Pa) makes the aerodynamic load negligible; a small uniform
    # external pressure then gives the linear Navier deflection of a simply supported plate.
    flow = FlowCondition.from_static(6.0, 1.0, 220.0)
    mat = isotropic("plate", 8000.0, 200e9, 0.3, 1e-5, 10.0, 500.0)
    panel = PanelSpec(layers=(Layer(mat, 0.01),), mesh=(8, 8), emissivity=0.0)
    q = 100.0  # Pa, w/h ~ 1e-3: linear regime
    m = PanelModel(panel, flow, make_fluid_model("pt", "none"),
                   CouplingSettings(external_pressure=q))
    u, _ = m.equilibrium(np.zeros(m.structure.n_dof), m.thermal.initial_state())
    D = 200e9 * 0.01**3 / (12 * (1 - 0.3**2))
    # Navier series for the centre deflection of a uniformly loaded SS square plate
    w = sum(16 * q / (math.pi**6 * D * i * j * (i**2 + j**2) ** 2) * (-1) ** ((i + j) // 2 - 1)
            for i in range(1, 200, 2) for j in range(1, 200, 2))
    # external pressure pushes towards +z; 1 % (FE discretization + transverse shear)
    assert u[5 * m.structure.mesh.center + 2] == pytest.approx(w, rel=1e-2)


def test_heat_input_transfer_conserves_total_heat() -> None:
    m = PanelModel(_panel(), FLOW, make_fluid_model("pt-bl"), CouplingSettings())
    T = m.thermal.initial_state() + 100.0
    u = np.zeros(m.structure.n_dof)
    loads = m.thermal_loads(u)
    Q, dQ = loads.top.flux(m.thermal.wall_temperature(T))
    total_fluid = m.points.weights @ m.fluid_loads(u, m.wall_temperature(T)).heat_flux
    # partition of unity of the bilinear top faces: exact to round-off
    assert Q.sum() == pytest.approx(total_fluid, rel=1e-12)
    # the derivative handed to the thermal Newton matches central differences
    Tw = m.thermal.wall_temperature(T)
    d = np.random.default_rng(1).normal(0, 1.0, Tw.size)
    fd = (loads.top.flux(Tw + 1e-3 * d)[0] - loads.top.flux(Tw - 1e-3 * d)[0]) / 2e-3
    assert np.linalg.norm(dQ @ d - fd) <= 1e-6 * np.linalg.norm(fd)


def test_tc_heats_and_bulges_into_the_flow(tmp_path: Path) -> None:
    s = CouplingSettings(time_step=1.0, duration=4.0)
    m = PanelModel(_panel(), FLOW, make_fluid_model("pt-bl"), s)
    r = run_tc(m)
    assert r.status == "completed" and len(r.times) == 5
    T = np.asarray(r.mean_temperature)
    assert np.all(np.diff(T) > 0)  # aerodynamic heating
    # heating makes the panel expand: it bulges out, into the flow (+z)
    assert r.center_deflection[-1] > r.center_deflection[0]
    path = r.save(tmp_path / "r.npz")
    back = Response.load(path)
    assert back.times == r.times and np.allclose(back.center_deflection, r.center_deflection)
    assert np.allclose(np.asarray(back.lsa), np.asarray(r.lsa), equal_nan=True)


def test_simulate_cli_json_fields(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    case = tmp_path / "case.toml"
    case.write_text("""
[panel]
mesh = [4, 4]
[[panel.layers]]
material = "inconel718"
thickness = 0.002
[flow]
mach = 6.0
altitude = 25000.0
[simulation]
scheme = "tc"
aero = "pt"
time_step = 1.0
duration = 2.0
""")
    assert main(["simulate", str(case), "--json", "--out", str(tmp_path / "out")]) == 0
    data = json.loads(capsys.readouterr().out)
    # public fields (issue 6) plus the run's status and message
    assert {"times", "center_deflection", "mean_temperature", "instability_time",
            "instability_type"} <= set(data)
    assert data["status"] == "completed"
    assert data["times"] == [0.0, 1.0, 2.0]
    assert (tmp_path / "out" / "response.npz").is_file()
