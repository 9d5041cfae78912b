"""Verification of the coupled schemes on the Sec. 7.3 benchmark (issue 6 acceptance).

The benchmark (``studies/cases/sec7_3_benchmark.toml``): 2D Al 7075 strip, a = 1 m,
h = 2.5 mm, L_le = 1 m, simply supported, M = 4, p = 2087.2 Pa, T = 266.7 K, full piston
theory + turbulent Eckert heating, emissivity 0 (radiation omitted as in Ref. [202]; at the
panel temperatures of the first 2.5 s, 300-330 K, the net radiative loss to the 266.7 K
surroundings is ~1 % of the Eckert heat input). The dissertation reports the snap-through
onset at 2.02 s (analytic models); acceptance 1.8-2.4 s.

Slow tests (``-m slow``) run the reference steps (LC S2 dt = 1 ms, TC dt = 25 ms); the fast
variants use coarser steps.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
import scipy.sparse.linalg as spla
from conftest import REPO
from hypate.solvers.aero.factory import make_fluid_model
from hypate.solvers.config import parse_case, read_toml, settings_from_config
from hypate.solvers.coupling.lc import run_lc
from hypate.solvers.coupling.model import PanelModel
from hypate.solvers.coupling.newton import solve_free_block
from hypate.solvers.coupling.tc import run_tc
from hypate.solvers.flow import FlowCondition
from hypate.solvers.materials import library_material
from hypate.solvers.panel import Layer, PanelSpec
from hypate.solvers.settings import SimulationSettings

CASE = REPO / "studies" / "cases" / "sec7_3_benchmark.toml"


def _benchmark(time_step: float, duration: float, keep_fields: bool = False) -> PanelModel:
    case = parse_case(read_toml(str(CASE)), source=str(CASE))
    sim = case.simulation
    settings = replace(settings_from_config(sim), time_step=time_step, duration=duration,
                       keep_fields=keep_fields)
    return PanelModel(case.panel, case.flow,
                      make_fluid_model(sim.aero, sim.heating, sim.boundary_layer), settings)


# -- 1. snap-through onset (Sec. 7.3.2.1) -----------------------------------------------------
@pytest.fixture(scope="module")
def reference_runs():
    """LC S2 (dt = 1 ms, rho_bar = 0.9) and TC (dt = 25 ms = 25 x the LC step) to 2.5 s."""
    lc = run_lc(_benchmark(0.001, 2.5), "s2", rho_bar=0.9, record_every=5)
    tc = run_tc(_benchmark(0.025, 2.5))
    return lc, tc


def _check_snap(resp, lo: float = 1.8, hi: float = 2.4) -> None:
    assert resp.status == "unstable" and resp.instability_type == "divergence"
    assert lo <= resp.instability_time <= hi
    w = np.asarray(resp.center_deflection)
    t = np.asarray(resp.times)
    pre = t < resp.instability_time
    # the thermally driven response deforms the panel into the flow (+z) first (the LC
    # response dips by < 0.01 h in its first milliseconds, before the heating takes over)
    assert np.all(w[pre] > -0.01 * 2.5e-3)
    assert np.all(w[pre & (t >= 0.05)] > 0.0)
    assert np.max(w[pre]) > 2.0 * 2.5e-3  # several thicknesses before the snap


@pytest.mark.slow
def test_benchmark_snap_through_onset_lc_s2_and_tc(reference_runs) -> None:
    lc, tc = reference_runs
    # dissertation 2.02 s; acceptance 1.8-2.4 s for both schemes (measured 2.02 / 1.975 s)
    _check_snap(lc)
    _check_snap(tc)
    # S2 snaps through: the deflection reverses and leaves the flow
    assert lc.center_deflection[-1] < 0.0


def test_benchmark_snap_through_onset_tc_coarse() -> None:
    # fast variant: TC with dt = 0.1 s
    _check_snap(run_tc(_benchmark(0.1, 2.5)))


# -- 4. TC vs LC (Sec. 7.3.3) -------------------------------------------------------------------
@pytest.mark.slow
def test_tc_follows_lc_and_flags_the_instability(reference_runs) -> None:
    lc, tc = reference_runs
    t_on = lc.instability_time
    t_lc, w_lc = np.asarray(lc.times), np.asarray(lc.center_deflection)
    t_tc, w_tc = np.asarray(tc.times), np.asarray(tc.center_deflection)
    # the impulsive start excites the fundamental mode of the LC (transient) response, which
    # oscillates about the quasi-steady path; compare the LC deflection averaged over one
    # fundamental period (from the TC's own LSA at t = 0.5 s) with the TC deflection, from
    # one period after the start up to 90 % of the LC onset
    k = int(np.argmin(np.abs(t_tc - 0.5)))
    omega = np.nanmin(np.abs(np.asarray(tc.lsa[k]).imag))
    period = 2.0 * math.pi / omega
    assert 0.08 < period < 0.25  # ~7 Hz first mode of the heated, loaded strip
    dt_rec = t_lc[1] - t_lc[0]
    n = int(round(period / dt_rec))
    kernel = np.ones(n) / n
    w_mean = np.convolve(w_lc, kernel, mode="valid")
    t_mean = np.convolve(t_lc, kernel, mode="valid")
    sel = (t_mean >= period) & (t_mean <= 0.9 * t_on)
    rel = np.abs(np.interp(t_mean[sel], t_tc, w_tc) - w_mean[sel]) / np.abs(w_mean[sel])
    assert rel.max() <= 0.05  # measured 2.7 %
    # the TC scheme (LSA / loss of the quasi-steady equilibrium) flags the instability
    # within two TC steps of the LC onset
    assert abs(tc.instability_time - t_on) <= 2 * 0.025 + 1e-12


# -- 5. GMRES / low-rank path == direct path (Sec. 5.4.4) --------------------------------------
def test_newton_update_gmres_and_low_rank_match_direct() -> None:
    flow = FlowCondition.from_altitude(6.0, 25000.0)
    panel = PanelSpec(layers=(Layer(library_material("inconel718"), 0.002, 0.0, 2),),
                      mesh=(6, 6))
    m = PanelModel(panel, flow, make_fluid_model("pt-bl"), SimulationSettings())
    st = m.structure
    u = np.zeros(st.n_dof)
    u[2::5] = 0.003 * np.sin(math.pi * st.mesh.x) * np.sin(math.pi * st.mesh.y)
    T = m.thermal.initial_state() + 150.0
    loads = m.fluid_loads(u, m.wall_temperature(T), jacobians=True)
    F_I, K = st.force_and_tangent(u, m.structural_temperature(T))
    R = F_I - m.aero_force(loads)
    free = st.free_dofs
    KA = m.aero_stiffness(loads)
    b = -R[free]
    direct = spla.splu((K[free][:, free] - KA[free][:, free]).tocsc()).solve(b)

    # the preconditioner is the factor of the previous step's Jacobian (a nearby state)
    u2, T2 = 1.05 * u, T - 5.0
    l2 = m.fluid_loads(u2, m.wall_temperature(T2), jacobians=True)
    K2 = st.tangent(u2, m.structural_temperature(T2))
    prec = spla.splu((K2[free][:, free] - m.aero_stiffness(l2)[free][:, free]).tocsc())

    factors: list[object] = []
    x_sparse = solve_free_block(K, KA, b, free, prec, on_factor=factors.append)
    assert not factors  # GMRES path taken, no new factorization
    # low-rank / operator K_A (the ROM path, Eq. 5.43): applied matrix-free
    op = spla.LinearOperator(K.shape, matvec=lambda x: KA @ x, dtype=float)
    x_op = solve_free_block(K, op, b, free, prec)
    # acceptance (issue 6): the same Newton update as the direct path to 1e-8 relative
    for x in (x_sparse, x_op):
        assert np.linalg.norm(x - direct) <= 1e-8 * np.linalg.norm(direct)


# -- 2./3. time and energy accuracy of S1/S2 (Sec. 7.3.2.2, Eqs. 7.10-7.11; Sec. 5.3.3) ---------
# Comparison at t = 0.512 s (pre-snap; the snap is at ~2.02 s) with steps 1, 0.5, 0.25,
# 0.125 ms, rho_bar = 0.9 and the smooth start (flow ramped on over 0.2 s, run_lc's
# ramp_time). Why not the dissertation's 0.1-12.8 ms at 2.048 s: the benchmark's transient
# carries physically excited oscillations of bending modes 2-5 (155-966 rad/s; identical in
# S1, S2 and at every step) whose generalized-alpha phase error ~ omega^3 dt^2 t / 12 is
# O(1) rad for these steps; the impulsive start excites all of them (mode 5 with ~1e-4 h),
# and with the smooth start mode 3 still grows to ~1e-3 h near 0.5-0.6 s and mode 4 near
# 1.4 s. Measured with the smooth start (rates from step triples dt, dt/2, dt/4): at
# 0.512 s every rate is 1.88-2.00 from dt = 1 ms down; at 1.0 s 1.85-2.09 from 0.5 ms down
# (but S2's p, q errors exceed S1's by 4-12 %); at 1.5 s only the 0.25/0.125/0.0625 ms
# triple gives 1.93-2.01, coarser ones -1.3 to 3.3. With the impulsive start the rates at
# 0.512 s are 0.5-2.8 for the same 1-0.125 ms steps. See studies/ch7_time_accuracy.py.
# ~1.5 min for both schemes.
HORIZON = 0.512
STEPS = (0.001, 0.0005, 0.00025, 0.000125)
RAMP = 0.2


@pytest.fixture(scope="module")
def accuracy_runs():
    out = {}
    for scheme in ("s1", "s2"):
        for dt in STEPS:
            m = _benchmark(dt, HORIZON, keep_fields=True)
            r = run_lc(m, scheme, rho_bar=0.9, record_every=m.settings.n_steps,
                       stop_on_snap=False, record_energy=True, ramp_time=RAMP)
            assert r.status == "completed"
            assert r.times[-1] == pytest.approx(HORIZON)
            out[scheme, dt] = (m, r)
    return out


def _fitted_exponent(dts, values) -> float:
    return float(np.polyfit(np.log(dts), np.log(values), 1)[0])


def _mean_energy(runs, scheme: str) -> np.ndarray:
    # mean |dE| per step over the last quarter of the horizon (Sec. 5.3.3)
    return np.array([np.nanmean(np.abs(np.asarray(runs[scheme, dt][1].artificial_energy)[
        int(round(0.75 * HORIZON / dt)):])) for dt in STEPS])


@pytest.mark.slow
def test_artificial_energy_order_s1(accuracy_runs) -> None:
    # Eq. (5.23): dE per step O(dt^3) for S1. Measured: fitted 2.99, pairwise 2.98, 3.00, 3.00
    E = _mean_energy(accuracy_runs, "s1")
    assert _fitted_exponent(STEPS, E) == pytest.approx(3.0, abs=0.15)
    assert np.all(np.abs(np.log2(E[:-1] / E[1:]) - 3.0) <= 0.25)


@pytest.mark.slow
def test_artificial_energy_order_s2(accuracy_runs) -> None:
    # Eq. (5.24): O(dt^4) for S2. Measured: fitted 3.99, pairwise 3.98, 3.99, 4.00 (with the
    # impulsive start the fit was 3.3 at rho_bar 0.9: the unresolved high modes, above)
    E = _mean_energy(accuracy_runs, "s2")
    assert _fitted_exponent(STEPS, E) == pytest.approx(4.0, abs=0.15)
    assert np.all(np.abs(np.log2(E[:-1] / E[1:]) - 4.0) <= 0.25)


def _field(model, resp, field: str) -> np.ndarray:
    # displacement: the normal displacement on the fluid points, u_F = H_FS u (Eq. 5.1c)
    if field == "u":
        return model.transfer.H_FS @ resp.u[-1]
    return np.asarray(getattr(resp, field)[-1])


def _errors(runs, scheme: str, field: str) -> np.ndarray:
    f = [_field(*runs[scheme, dt], field) for dt in STEPS]
    return np.array([np.linalg.norm(f[i + 1] - f[i]) for i in range(len(f) - 1)])


@pytest.mark.slow
@pytest.mark.parametrize("field", ["u", "T", "pressure", "heat_flux"])
def test_time_accuracy_rates_and_s2_below_s1(accuracy_runs, field: str) -> None:
    # Eq. (7.10): eps_i = ||f(dt_(i+1)) - f(dt_i)|| / eps_ref, eps_ref from S1 (Eq. 7.11).
    # Measured rates (S1; S2): u 1.99, 2.00; 1.95, 1.99 -- T 1.95, 1.98; 1.88, 1.95 --
    # p 1.98, 2.00; 1.94, 1.99 -- q 1.98, 2.00; 1.94, 1.99. eps_S2/eps_S1: u 0.86-0.89,
    # T 0.23-0.24, p and q 0.67-0.70 (the generalized-alpha error common to both schemes
    # dominates u, p and q at this time; the dissertation's ~0.1 holds in the early regime,
    # test_time_accuracy_early_coupling_error_regime). The ordering depends on rho_bar here:
    # 1.0 gives the same ratios, 0.5 gives u 1.12-1.15 (rates 1.87-1.99 for every rho_bar).
    e1, e2 = _errors(accuracy_runs, "s1", field), _errors(accuracy_runs, "s2", field)
    e1, e2 = e1 / e1[0], e2 / e1[0]
    for e in (e1, e2):
        rates = np.log2(e[:-1] / e[1:])
        assert np.all((rates >= 1.7) & (rates <= 2.3)), (field, rates)
    assert np.all(e2 < e1), (field, e2 / e1)


def test_time_accuracy_early_coupling_error_regime() -> None:
    # fast variant: t = 0.128 s, smooth start over 0.1 s, steps 4, 2, 1, 0.5 ms. This early
    # the structural response is still resolved by every step, and the coupling error
    # dominates S1: S2's errors in u, p and q are ~1/30 of S1's (Sec. 7.3.2.2: "approximately
    # one order of magnitude smaller"), T's about half. Measured rates (S1; S2): u 2.01, 2.00;
    # 1.95, 1.85 -- T 1.98, 1.98; 2.04, 2.02 -- p, q 2.01, 2.00; 2.15, 1.90. With S2's wall
    # velocity taken as 1.5 v^n - 0.5 v^(n-1) (v at t^(n+1/2), the defect fixed in run_lc)
    # S2's u, p, q rates were 1.24-1.48 and its ratios to S1 0.06-0.16.
    horizon, steps = 0.128, (0.004, 0.002, 0.001, 0.0005)
    fields = {}
    for scheme in ("s1", "s2"):
        for dt in steps:
            m = _benchmark(dt, horizon, keep_fields=True)
            r = run_lc(m, scheme, rho_bar=0.9, record_every=m.settings.n_steps,
                       stop_on_snap=False, ramp_time=0.1)
            assert r.status == "completed" and r.times[-1] == pytest.approx(horizon)
            fields[scheme, dt] = {"u": m.transfer.H_FS @ r.u[-1], "T": r.T[-1],
                                  "pressure": r.pressure[-1], "heat_flux": r.heat_flux[-1]}
    for field in ("u", "T", "pressure", "heat_flux"):
        e = {s: np.array([np.linalg.norm(fields[s, b][field] - fields[s, a][field])
                          for a, b in zip(steps[:-1], steps[1:])]) for s in ("s1", "s2")}
        for s in ("s1", "s2"):
            rates = np.log2(e[s][:-1] / e[s][1:])
            assert np.all((rates >= 1.7) & (rates <= 2.3)), (field, s, rates)
        ratio = e["s2"] / e["s1"]
        assert np.all(ratio < (0.6 if field == "T" else 0.1)), (field, ratio)
