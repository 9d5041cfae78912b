"""Coupled model: aerodynamic operators, equilibrium, heat-input conservation, TC runs."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp
from conftest import assert_matches_richardson, richardson_derivative
from hypate.scaling.cli.main import main
from hypate.solvers.aero.factory import make_fluid_model
from hypate.solvers.config import parse_case, settings_from_config
from hypate.solvers.coupling.lc import run_lc
from hypate.solvers.coupling.model import PanelModel
from hypate.solvers.coupling.response import Response
from hypate.solvers.coupling.tc import extrapolate, run_tc
from hypate.solvers.flow import FlowCondition
from hypate.solvers.materials import isotropic, library_material
from hypate.solvers.numerics.sparse import csr_rows, splu_symmetric
from hypate.solvers.panel import Layer, PanelSpec
from hypate.solvers.settings import SimulationSettings

FLOW = FlowCondition.from_altitude(6.0, 25000.0)


def _panel(mesh=(4, 4), thickness=0.002, **kw) -> PanelSpec:
    mat = library_material("inconel718")
    return PanelSpec(layers=(Layer(mat, thickness, 0.0, 2),), mesh=mesh, **kw)


def test_aero_stiffness_and_damping_match_finite_differences() -> None:
    m = PanelModel(_panel(), FLOW, make_fluid_model("pt-bl"), SimulationSettings())
    st = m.structure
    rng = np.random.default_rng(2)
    u = np.zeros(st.n_dof)
    u[2::5] = 0.003 * np.sin(math.pi * st.mesh.x) * np.sin(math.pi * st.mesh.y)
    T = m.thermal.initial_state() + rng.uniform(0, 200, m.thermal.n_nodes)
    Tw = m.wall_temperature(T)
    loads = m.fluid_loads(u, Tw, jacobians=True)
    KA, CA = m.aero_stiffness(loads), m.aero_damping(loads)
    d = rng.normal(0, 1e-3, st.n_dof)
    # K_A = dF_S/du through the transfer (Eq. 5.34), C_A = dF_S/du_dot, along random
    # directions; tolerance: the extrapolated differences' own measured error
    # (conftest.richardson_derivative), entry by entry
    fd, bound = richardson_derivative(lambda t: m.aero_force(m.fluid_loads(u + t * d, Tw)),
                                      2e-3)
    assert_matches_richardson(KA @ d, fd, bound, "K_A d")
    v = rng.normal(0, 1.0, st.n_dof)
    fd, bound = richardson_derivative(
        lambda t: m.aero_force(m.fluid_loads(u, Tw, u_dot=t * v)), 2e-3)
    assert_matches_richardson(CA @ v, fd, bound, "C_A v")


def test_equilibrium_under_external_pressure_matches_navier() -> None:
    # A near-vacuum flow (p = 1 Pa) makes the aerodynamic load negligible; a small uniform
    # external pressure then gives the linear Navier deflection of a simply supported plate.
    flow = FlowCondition.from_static(6.0, 1.0, 220.0)
    mat = isotropic("plate", 8000.0, 200e9, 0.3, 1e-5, 10.0, 500.0)
    panel = PanelSpec(layers=(Layer(mat, 0.01),), mesh=(8, 8), emissivity=0.0)
    q = 100.0  # Pa, w/h ~ 1e-3: linear regime
    m = PanelModel(panel, flow, make_fluid_model("pt", "none"),
                   SimulationSettings(external_pressure=q))
    u, _ = m.equilibrium(np.zeros(m.structure.n_dof), m.thermal.initial_state())
    D = 200e9 * 0.01**3 / (12 * (1 - 0.3**2))
    # Navier series for the centre deflection of a uniformly loaded SS square plate
    w = sum(16 * q / (math.pi**6 * D * i * j * (i**2 + j**2) ** 2) * (-1) ** ((i + j) // 2 - 1)
            for i in range(1, 200, 2) for j in range(1, 200, 2))
    # external pressure pushes towards +z; 1 % (FE discretization + transverse shear)
    assert u[5 * m.structure.mesh.center + 2] == pytest.approx(w, rel=1e-2)


def test_heat_input_transfer_conserves_total_heat() -> None:
    m = PanelModel(_panel(), FLOW, make_fluid_model("pt-bl"), SimulationSettings())
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
    fd, bound = richardson_derivative(lambda t: loads.top.flux(Tw + t * d)[0], 2e-3)
    assert_matches_richardson(dQ @ d, fd, bound, "dQ/dT_w d")  # the difference's own error


@pytest.mark.parametrize("kind, scheme, time_step, steps",
                         [("3d", "tc", 1.0, 3), ("2d", "s2", 1e-3, 10), ("3d", "s1", 1e-3, 10)])
def test_external_heat_flux_heats_the_panel_by_the_energy_balance(
        kind: str, scheme: str, time_step: float, steps: int) -> None:
    # q_ext is the only heat input (no aerodynamic heating, emissivity 0, insulated lower
    # surface) into a slab of constant rho c_p: Crank-Nicolson conserves energy exactly
    # (1^T K = 0), so after time t the panel stores q_ext a b t (J) and its volume-mean
    # temperature has risen by q_ext t / (rho c_p h) (Eq. 6.1d's q_ext; round-off: 1e-9)
    rho, cp, h, q, a, b = 2800.0, 900.0, 0.002, 2e5, 0.5, 0.4
    mat = isotropic("slab", rho, 70e9, 0.3, 0.0, 150.0, cp)  # no expansion: stays flat
    panel = PanelSpec(layers=(Layer(mat, h, 0.0, 2),), kind=kind, length=a, width=b,
                      mesh=(4, 4), emissivity=0.0)
    settings = SimulationSettings(time_step=time_step, duration=steps * time_step,
                                external_heat_flux=q)
    model = PanelModel(panel, FLOW, make_fluid_model("pt", "none"), settings)
    assert not model.thermal_frozen  # q_ext heats even without aerodynamic heating
    resp = run_tc(model) if scheme == "tc" else run_lc(model, scheme)
    assert resp.status == "completed", resp.message
    t = np.asarray(resp.times)
    assert t[-1] == pytest.approx(steps * time_step)
    rise = np.asarray(resp.mean_temperature) - panel.initial_temperature
    np.testing.assert_allclose(rise, q * t / (rho * cp * h), rtol=1e-9, atol=1e-9)
    assert model.thermal.stored_energy(resp.T[-1]) == pytest.approx(q * a * b * t[-1],
                                                                    rel=1e-9)


def test_case_file_external_heat_flux_reaches_the_settings() -> None:
    data = {"panel": {"layers": [{"material": "ti6242", "thickness": 0.002}]},
            "simulation": {"external_heat_flux": 5e4}}
    assert settings_from_config(parse_case(data).simulation).external_heat_flux == 5e4
    assert settings_from_config(parse_case({**data, "simulation": {}}).simulation
                                ).external_heat_flux == 0.0


def test_tc_heats_and_bulges_into_the_flow(tmp_path: Path) -> None:
    s = SimulationSettings(time_step=1.0, duration=4.0)
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


# -- the TC hot path: predictors, pre-ordered factor, warm-started LSA (issue 6) -------------
def test_extrapolate_is_exact_for_polynomials_of_its_order() -> None:
    t = np.arange(4.0)
    a, b, c = np.array([1.0, -2.0]), np.array([0.5, 3.0]), np.array([-0.25, 0.125])
    x = [a + b * ti + c * ti**2 for ti in t]
    # quadratic from three states, newest first: x(3) to round-off
    np.testing.assert_allclose(extrapolate([x[2], x[1], x[0]]), x[3], rtol=1e-14)
    lin = [a + b * ti for ti in t]
    np.testing.assert_allclose(extrapolate([lin[2], lin[1]]), lin[3], rtol=1e-14)
    one = extrapolate([x[0]])
    assert np.array_equal(one, x[0]) and one is not x[0]


def test_equilibrium_from_a_prediction_is_the_same_equilibrium() -> None:
    m = PanelModel(_panel(), FLOW, make_fluid_model("pt-bl"), SimulationSettings())
    T0 = m.thermal.initial_state()
    u0, _ = m.equilibrium(np.zeros(m.structure.n_dof), T0 + 60.0)
    T1 = T0 + 80.0
    ref, it_ref = m.equilibrium(u0, T1)
    # a good prediction (0.05 % of the step off): the same equilibrium to the Newton
    # tolerance, in fewer iterations, and no other Newton run (every iteration made is one
    # of the iterations returned)
    near = u0 + 1.0005 * (ref - u0)
    spent = m.timer.newton_iterations
    x, it = m.equilibrium(u0, T1, guess=near)
    assert np.linalg.norm(x - ref) <= 1e-7 * np.linalg.norm(ref)
    assert it < it_ref and m.timer.newton_iterations - spent == it
    # a prediction whose correction exceeds its own step is not trusted: its Newton run is
    # discarded (iterations made beyond those returned), the solution restarts from u and
    # is again the same equilibrium
    poor = u0 + 1e-3 * (ref - u0)
    spent = m.timer.newton_iterations
    x, it = m.equilibrium(u0, T1, guess=poor)
    assert m.timer.newton_iterations - spent > it
    assert np.linalg.norm(x - ref) <= 1e-7 * np.linalg.norm(ref)


def test_pre_ordered_free_factor_equals_the_minimum_degree_factor() -> None:
    m = PanelModel(_panel(), FLOW, make_fluid_model("pt-bl"), SimulationSettings())
    st = m.structure
    u = np.zeros(st.n_dof)
    u[2::5] = 0.003 * np.sin(math.pi * st.mesh.x) * np.sin(math.pi * st.mesh.y)
    T = m.thermal.initial_state() + 150.0
    loads = m.fluid_loads(u, m.wall_temperature(T), jacobians=True)
    K = st.tangent(u, m.structural_temperature(T))
    fp = m.free_pattern
    # (K - K_A)_ff (Eq. 5.42) as CSR data of the free pattern
    free = st.free_dofs
    A_ff = (K - m.aero_stiffness(loads)).tocsr()[free][:, free]
    block = np.asarray(A_ff[csr_rows(fp.indptr), fp.indices]).ravel()
    lu = fp.factor(block)
    ref = splu_symmetric(fp.csc_from_block(block), "MMD_AT_PLUS_A")
    # the ordering is MMD(A^T + A), applied beforehand: the same fill ...
    assert lu.lu.L.nnz == ref.L.nnz and lu.lu.U.nnz == ref.U.nnz
    # ... and the same solution to round-off (1e-12 relative)
    b = np.random.default_rng(0).standard_normal(fp.n)
    x = lu.solve(b)
    assert np.linalg.norm(x - ref.solve(b)) <= 1e-12 * np.linalg.norm(x)
    A = sp.csr_matrix((block, fp.indices, fp.indptr), shape=(fp.n, fp.n))
    assert np.linalg.norm(A @ x - b) <= 1e-10 * np.linalg.norm(b)
    X = lu.solve(np.column_stack([b, 2 * b]))  # several right-hand sides
    assert np.linalg.norm(X[:, 1] - 2 * x) <= 1e-12 * np.linalg.norm(2 * x)


def test_warm_started_lsa_equals_a_cold_one() -> None:
    # the LSA of the next state starts ARPACK from the last modes (Eq. 5.36): the same
    # eigenvalues as a fresh model's LSA at that state, to ARPACK's tolerance (1e-10)
    s = SimulationSettings()
    warm = PanelModel(_panel(), FLOW, make_fluid_model("pt-bl"), s)
    cold = PanelModel(_panel(), FLOW, make_fluid_model("pt-bl"), s)
    T0 = warm.thermal.initial_state()
    u1, _ = warm.equilibrium(np.zeros(warm.structure.n_dof), T0 + 50.0)
    assert not warm.stability(u1, T0 + 50.0).warm_start  # the first LSA starts at random
    u2, _ = warm.equilibrium(u1, T0 + 60.0)
    a = warm.stability(u2, T0 + 60.0)
    b = cold.stability(u2, T0 + 60.0)
    assert a.warm_start and not b.warm_start
    assert np.allclose(a.lambda_p, b.lambda_p, rtol=1e-10, atol=0.0)
    assert a.status == b.status


def test_tc_states_are_the_equilibria_without_predictors() -> None:
    # run_tc predicts u and T by extrapolation; every recorded state must still be the
    # equilibrium reached from the previous state without a prediction (Eq. 5.31b) and the
    # thermal step from the previous temperature (Eq. 5.31a), to the Newton tolerances
    s = SimulationSettings(time_step=1.0, duration=5.0)
    m = PanelModel(_panel(), FLOW, make_fluid_model("pt-bl"), s)
    r = run_tc(m)
    assert r.status == "completed"
    ref = PanelModel(_panel(), FLOW, make_fluid_model("pt-bl"), s)
    for n in (3, 5):  # steps with two and three states of history
        T = ref.thermal_step(r.T[n - 1], r.u[n - 1], 1.0)
        assert np.max(np.abs(T - r.T[n])) <= 1e-8 * np.max(np.abs(r.T[n]))
        u, _ = ref.equilibrium(r.u[n - 1], r.T[n])
        assert np.linalg.norm(u - r.u[n]) <= 1e-7 * np.linalg.norm(r.u[n])


def test_a_rejected_prediction_leaves_the_solution_path_unchanged() -> None:
    # near a limit point the loss of the equilibrium is the snap-through signal: after a
    # failed or rejected prediction the solution from u must proceed exactly as without
    # one, i.e. with the same preconditioner (the LSA factor of the last state): bit for
    # bit the solution of a twin model that got no prediction, and the same equilibrium
    s = SimulationSettings()
    m = PanelModel(_panel(), FLOW, make_fluid_model("pt-bl"), s)
    twin = PanelModel(_panel(), FLOW, make_fluid_model("pt-bl"), s)
    T0 = m.thermal.initial_state()
    u0, _ = m.equilibrium(np.zeros(m.structure.n_dof), T0 + 60.0)
    ref, _ = m.equilibrium(u0, T0 + 80.0)
    # "too short": converges, but its correction exceeds its step from u0 (rejected);
    # "diverging": a Jacobian far from the kept factor (GMRES fails, a new factor is made),
    # then no convergence in 30 iterations
    for g in ((1.0 + 1e-3) * u0, u0 + 0.2 * np.sin(np.arange(u0.size))):
        for model in (m, twin):
            model.stability(u0, T0 + 60.0)  # the LSA factor preconditions the next Newton
        f0, spent = m.timer.factorizations, m.timer.newton_iterations
        x, it = m.equilibrium(u0, T0 + 80.0, guess=g)
        assert m.timer.newton_iterations - spent > it  # the prediction's run was discarded
        x_twin, it_twin = twin.equilibrium(u0, T0 + 80.0)
        assert np.array_equal(x, x_twin) and it == it_twin
        assert np.linalg.norm(x - ref) <= 1e-7 * np.linalg.norm(ref)
    assert m.timer.factorizations > f0  # the diverging attempt did refactor
