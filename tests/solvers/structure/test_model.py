"""DCS9 structural model and solvers against closed forms, published tables and FD."""
from __future__ import annotations

import numpy as np
import pytest
from conftest import assert_matches_richardson, richardson_jacobian
from hypate.solvers.errors import InputError
from hypate.solvers.materials import isotropic, library_material, orthotropic
from hypate.solvers.panel import Layer, PanelSpec, thermal_levels
from hypate.solvers.structure.dynamics import AlphaStepper, GeneralizedAlpha, transient
from hypate.solvers.structure.modal import buckling_delta_T, modes
from hypate.solvers.structure.model import StructuralModel
from hypate.solvers.structure.static import static

INCH, LBFT3, PSI = 0.0254, 16.018463373960142, 6894.757293168361


def _inconel() -> object:
    # Table 9.1: Inconel 718 at 300 K, temperature independent (Sec. 9.1)
    return isotropic("inconel718", 8220.0, 204.0e9, 0.29, 1.237e-5, 11.71, 418.4)


def _navier_frequencies(E, nu, rho, h, a, b, count):
    D = E * h**3 / (12 * (1 - nu**2))
    lam = sorted((m * m / a**2 + n * n / b**2) for m in range(1, 9) for n in range(1, 9))
    return np.pi / 2 * np.sqrt(D / (rho * h)) * np.array(lam[:count])


# -- modal ------------------------------------------------------------------------------
def test_table_7_3_clamped_panel_frequencies():
    # Table 7.2 panel, clamped, 10 x 20 mesh; analytical column of Table 7.3 (Ref. [4]).
    # Tolerance 1 % (issue 4); the dissertation's own DCS9 is 0.25-0.32 % high.
    mat = isotropic("t72", 110.0 * LBFT3, 5.6e6 * PSI, 0.35, 1e-5, 1.0, 1.0)
    panel = PanelSpec(layers=(Layer(mat, 0.0401 * INCH),), length=9 * INCH, width=18 * INCH,
                      mesh=(10, 20), boundary="clamped")
    f = modes(StructuralModel(panel), 5).frequencies_hz
    ref = np.array([109.7, 142.0, 199.8, 282.6, 285.5])
    np.testing.assert_allclose(f, ref, rtol=0.01)
    # and close to the dissertation's "Current" column (110.0, 142.4, 200.3, 283.4, 286.4)
    np.testing.assert_allclose(f, [110.0, 142.4, 200.3, 283.4, 286.4], rtol=0.002)


@pytest.mark.parametrize("aspect", [1.0, 1.5, 2.0])
def test_simply_supported_plate_frequencies_and_convergence(aspect):
    # Navier closed form for a thin SS plate (a/h = 250): first six within 0.5 %
    # (issue 4). FSDT sits slightly below Kirchhoff (shear/rotary inertia ~1e-4 here).
    E, nu, rho, h, a = 70e9, 0.3, 2700.0, 4e-3, 1.0
    b = a * aspect
    mat = isotropic("al", rho, E, nu, 2e-5, 100.0, 900.0)
    ref = _navier_frequencies(E, nu, rho, h, a, b, 6)
    errs, sizes = [], []
    for n in (2, 4, 8):
        panel = PanelSpec(layers=(Layer(mat, h),), length=a, width=b,
                          mesh=(n, int(round(n * aspect))))
        f = modes(StructuralModel(panel), 6).frequencies_hz
        errs.append(np.max(np.abs(f / ref - 1)))
        sizes.append(a / n)
    assert errs[-1] < 0.005
    rate = np.polyfit(np.log(sizes[:2]), np.log(errs[:2]), 1)[0]
    # measured: rate ~3.5-4 on the coarse meshes (quadratic elements; the FSDT-vs-Kirchhoff
    # offset ~1e-4 floors the error on the finest mesh)
    print(f"aspect {aspect}: max errors {errs}, rate {rate:.2f}")
    assert rate > 2.5


# -- static -----------------------------------------------------------------------------
def test_linear_static_navier_center_deflection():
    # Navier series for an SS square plate under uniform pressure (Timoshenko &
    # Woinowsky-Krieger Sec. 30) plus the Mindlin shear term sum q_mn/(kappa G h k^2);
    # tolerance 1 % (issue 4).
    E, nu, h, a, q = 70e9, 0.3, 0.01, 1.0, 1e3
    mat = isotropic("al", 2700.0, E, nu, 2e-5, 100.0, 900.0)
    panel = PanelSpec(layers=(Layer(mat, h),), length=a, width=a, mesh=(8, 8))
    model = StructuralModel(panel)
    u = model.factor(model.linear_stiffness()).solve(model.pressure_load(q))
    D = E * h**3 / (12 * (1 - nu**2))
    ks = 5 / 6 * E / (2 * (1 + nu)) * h
    m = np.arange(1, 400, 2)[:, None]
    n = np.arange(1, 400, 2)[None, :]
    k2 = np.pi**2 * (m**2 + n**2) / a**2
    qmn = 16 * q / (np.pi**2 * m * n) * np.sin(m * np.pi / 2) * np.sin(n * np.pi / 2)
    w_ref = np.sum(qmn / (D * k2**2) + qmn / (ks * k2))
    w = u[5 * model.mesh.center + 2]
    assert w == pytest.approx(w_ref, rel=0.01)
    assert w == pytest.approx(w_ref, rel=1e-3)      # measured 1e-4 on 8 x 8
    # the nonlinear solver agrees at a tiny load (w/h ~ 6e-4, membrane stiffening ~1e-6)
    res = static(model, pressure=q / 100)
    assert res.converged and res.center_deflection(model) == pytest.approx(w / 100, rel=1e-4)


# -- thermal buckling / post-buckling ---------------------------------------------------
def test_thermal_buckling_sec_9_1_prototype():
    # pi^2 h^2 (1 + (a/b)^2) / (12 (1 + nu) alpha a^2) = 0.41233 K for the Sec. 9.1
    # prototype (1 m x 2 mm Inconel 718 at 300 K); tolerance 2 % (issue 4).
    a, h, nu, alpha = 1.0, 2e-3, 0.29, 1.237e-5
    ref = np.pi**2 * h**2 * 2 / (12 * (1 + nu) * alpha * a**2)
    assert ref == pytest.approx(0.4123, abs=1e-4)
    panel = PanelSpec(layers=(Layer(_inconel(), h),), length=a, width=a, mesh=(6, 6))
    dT = buckling_delta_T(StructuralModel(panel)).critical_delta_T
    assert dT == pytest.approx(ref, rel=0.02)
    assert dT == pytest.approx(ref, rel=2e-3)       # measured 3e-4 on 6 x 6


def test_thermal_buckling_rectangular_and_library_material():
    # a/b = 0.5 (m = n = 1 still critical); library Inconel 718 equals Table 9.1 at 300 K,
    # its temperature dependence is negligible over 0.3 K. Tolerance 2 %.
    a, b, h = 0.5, 1.0, 1e-3
    ref = np.pi**2 * h**2 * (1 + (a / b) ** 2) / (12 * 1.29 * 1.237e-5 * a**2)
    panel = PanelSpec(layers=(Layer(library_material("inconel718"), h),), length=a,
                      width=b, mesh=(4, 8))
    dT = buckling_delta_T(StructuralModel(panel)).critical_delta_T
    assert dT == pytest.approx(ref, rel=0.02)


def test_post_buckling_deflection_grows_like_square_root():
    # Beyond T_cr the flat plate buckles; near onset w ~ c sqrt(dT/T_cr - 1) (Koiter,
    # stable symmetric bifurcation): fitted exponent 0.5 +- 0.06, and the solution is
    # stable (positive definite tangent).
    h = 2e-3
    panel = PanelSpec(layers=(Layer(_inconel(), h),), length=1.0, width=1.0, mesh=(4, 4))
    model = StructuralModel(panel)
    Tcr = buckling_delta_T(model).critical_delta_T
    r = np.array([1.01, 1.02, 1.04, 1.08])
    w = []
    for ri in r:
        res = static(model, T=300.0 + ri * Tcr)
        assert res.converged and res.stable
        w.append(abs(res.center_deflection(model)))
    slope = np.polyfit(np.log(r - 1), np.log(w), 1)[0]
    assert slope == pytest.approx(0.5, abs=0.06)
    # below T_cr the plate stays flat
    res = static(model, T=300.0 + 0.9 * Tcr)
    assert abs(res.center_deflection(model)) < 1e-12 and res.stable


def test_heated_modes_soften_then_stiffen():
    # Uniform heating lowers the first frequency towards zero at T_cr; past buckling the
    # modes are about the buckled equilibrium (all positive).
    panel = PanelSpec(layers=(Layer(_inconel(), 2e-3),), length=1.0, width=1.0, mesh=(4, 4))
    model = StructuralModel(panel)
    Tcr = buckling_delta_T(model).critical_delta_T
    f0 = modes(model, 3).frequencies_hz[0]
    f_half = modes(model, 3, T=300.0 + 0.5 * Tcr).frequencies_hz[0]
    assert f_half == pytest.approx(f0 * np.sqrt(0.5), rel=5e-3)   # omega^2 linear in dT
    f_post = modes(model, 3, T=300.0 + 2.425 * Tcr).frequencies_hz
    assert np.all(f_post > 0)


# -- exact tangent ------------------------------------------------------------------------
def test_tangent_matches_central_differences_at_general_state():
    # Large deflection (w ~ 5 h), heated non-uniformly through the thickness with
    # temperature-dependent properties, doubly curved, unsymmetric laminate; central
    # differences of F_I column by column (extrapolated), each entry within the
    # difference's own measured error (conftest.richardson_derivative).
    ply = orthotropic("gr", density=1600.0, E1=150e9, E2=[(200, 12e9), (700, 8e9)],
                      G12=5e9, G13=5e9, G23=3e9, nu12=0.3, alpha1=[(200, -1e-6), (700, 1e-6)],
                      alpha2=3e-5, k1=5.0, k2=1.0, k3=1.0, specific_heat=900.0)
    layers = (Layer(ply, 5e-4, 0.0, 2), Layer(ply, 5e-4, np.pi / 2, 1),
              Layer(library_material("ti6242"), 1e-3, np.pi / 6, 2))
    panel = PanelSpec(layers=layers, length=0.5, width=0.4, mesh=(2, 2), radius_x=2.0,
                      radius_y=-3.0)
    model = StructuralModel(panel)
    rng = np.random.default_rng(0)
    T = 320.0 + 250.0 * rng.random((model.n_nodes, thermal_levels(panel).size))
    u = 1e-4 * rng.standard_normal(model.n_dof)
    u[2::5] = 0.01 * rng.standard_normal(model.n_nodes)
    u[3::5] *= 20
    u[4::5] *= 20
    u[model.constrained_dofs] = 0.0     # keep the penalty rows out of the cancellation
    K = model.tangent(u, T).toarray()
    steps = 2e-4 * np.maximum(np.abs(u), 1e-4)
    J, bound = richardson_jacobian(lambda v: model.internal_force(v, T), u, steps)
    assert_matches_richardson(K, J, bound, "K_T")
    Kc = model.penalty_stiffness().toarray()   # the boundary penalty K^c (Eq. 3.42)
    Kp = K - Kc
    # symmetric (conservative internal forces)
    np.testing.assert_allclose(Kp, Kp.T, atol=1e-10 * np.abs(Kp).max())


def test_von_karman_split_of_the_element_tangent_equals_the_full_product():
    # B = B0 + BL (Eq. 3.32): the cached B0^T C B0 plus the w-column update must equal
    # btdb of the full nonlinear operator (round-off only: 1e-13 relative), on a doubly
    # curved panel (B0 has w entries k_x N, k_y N) with a non-uniform temperature
    from hypate.solvers.structure.element import (
        btdb,
        btdb_von_karman,
        membrane_bending_B,
        von_karman_w_B,
    )

    panel = PanelSpec(layers=(Layer(library_material("ti6242"), 2e-3, 0.0, 2),),
                      length=0.5, width=0.4, mesh=(3, 2), radius_x=2.0, radius_y=-3.0)
    model = StructuralModel(panel)
    rng = np.random.default_rng(3)
    T = 320.0 + 250.0 * rng.random((model.n_nodes, thermal_levels(panel).size))
    u = 1e-3 * rng.standard_normal(model.n_dof)
    ue = model.element_dofs(u)
    E = model.mesh.n_elem
    q = model.q3
    full = membrane_bending_B(q, ue, model.kx, model.ky)
    lin = membrane_bending_B(q, None, model.kx, model.ky)
    BL = von_karman_w_B(q, ue)
    diff = (full - lin).reshape(E, 9, 6, 9, 5)
    assert np.array_equal(np.delete(diff, 2, axis=4), np.zeros_like(np.delete(diff, 2, axis=4)))
    assert not np.any(diff[:, :, 3:])
    np.testing.assert_allclose(diff[:, :, :3, :, 2], BL, rtol=0, atol=1e-15 * np.abs(BL).max())
    C = model.laminate_at_quadrature(T).ABD                      # (E, 9, 6, 6)
    B0, B = lin.reshape(E, 9, 6, 45), full.reshape(E, 9, 6, 45)
    ref = btdb(B, C, q.wdet)
    split = btdb_von_karman(btdb(B0, C, q.wdet), B0, C * q.wdet[..., None, None], BL)
    assert np.abs(split - ref).max() <= 1e-13 * np.abs(ref).max()


def test_mass_reuses_the_inertia_of_the_stiffness_evaluation():
    # the laminate data cached by a tangent at T hold I1..I3 (Eq. 3.38) at the same points:
    # the mass from them is the mass computed from scratch, bit for bit
    panel = PanelSpec(layers=(Layer(library_material("inconel718"), 1e-3, 0.0, 2),),
                      mesh=(2, 2))
    T = 300.0 + 400.0 * np.random.default_rng(1).random(
        (StructuralModel(panel).n_nodes, thermal_levels(panel).size))
    warm, cold = StructuralModel(panel), StructuralModel(panel)
    for Ti in (T, 650.0):  # a field and a uniform temperature
        warm.tangent(np.zeros(warm.n_dof), Ti)
        assert np.array_equal(warm.mass(Ti).toarray(), cold.mass(Ti).toarray())


def test_penalty_stiffness_is_what_the_constraints_add():
    # K^c (Eq. 3.42) is the difference of the constrained and unconstrained stiffness (to
    # the round-off of adding alpha_0 max|K_L| = 1e6 max|K_L|: 1e-9 of K^c); on a 3d panel
    # it is the penalty on the constrained diagonal, on a "2d" strip it also ties the three
    # node rows, so a field independent of y meets no tie force
    mat = library_material("ti6242")
    for kind, mesh in (("3d", (3, 2)), ("2d", (4, 1))):
        panel = PanelSpec(layers=(Layer(mat, 2e-3, 0.0, 2),), kind=kind, length=0.5,
                          width=0.4 if kind == "3d" else 0.05, mesh=mesh)
        model = StructuralModel(panel)
        Kc = model.penalty_stiffness()
        diff = model.linear_stiffness(400.0) - model.linear_stiffness(400.0, constrained=False)
        assert np.abs((diff - Kc).toarray()).max() <= 1e-9 * model.penalty
        d = Kc.diagonal()
        assert np.all(d[model.constrained_dofs] >= model.penalty)
        if kind == "3d":
            assert np.array_equal(Kc.toarray(), np.diag(d))
            assert not np.any(d[model.free_dofs])
        else:
            u = np.zeros(model.n_dof)
            u[model.dofs(2)] = np.sin(np.pi * model.mesh.x / 0.5)   # w(x) only
            u[model.constrained_dofs] = 0.0
            assert np.abs(Kc @ u).max() <= 1e-12 * model.penalty
            assert Kc.nnz > np.count_nonzero(d)                     # the ties couple rows


def test_laminate_at_quadrature_is_the_laminate_of_the_interpolated_field():
    # a temperature without in-plane variation: the nodal resultants; a field: the laminate
    # at the shape-function interpolation of the nodal profiles (bit for bit)
    from hypate.solvers.laminate import laminate

    panel = PanelSpec(layers=(Layer(library_material("ti6242"), 2e-3, 0.0, 2),),
                      length=0.5, width=0.4, mesh=(3, 2))
    model = StructuralModel(panel)
    profile = 300.0 + np.linspace(0.0, 200.0, model.n_levels)
    assert np.array_equal(model.laminate_at_quadrature(profile).thermal_resultants,
                          model.laminate_at_nodes(profile).thermal_resultants)
    T = 320.0 + 250.0 * np.random.default_rng(4).random((model.n_nodes, model.n_levels))
    lam = model.laminate_at_quadrature(T)
    assert lam.ABD.shape == (model.mesh.n_elem, 9, 6, 6)
    Tq = np.einsum("qa,eal->eql", model.q3.N, T[model.mesh.elements])
    ref = laminate(panel, Tq)
    assert np.array_equal(lam.ABD, ref.ABD)
    assert np.array_equal(lam.thermal_resultants, ref.thermal_resultants)


def test_thermal_load_and_pressure_load_consistency():
    # F_I(0, T) = -F_T(T) (Eq. 3.36); the pressure load integrates to p * area in w.
    panel = PanelSpec(layers=(Layer(_inconel(), 2e-3, 0.0, 2),), length=0.6, width=0.4,
                      mesh=(3, 2), radius_x=4.0)
    model = StructuralModel(panel)
    T = 300.0 + np.linspace(0, 50, thermal_levels(panel).size)
    np.testing.assert_allclose(model.internal_force(np.zeros(model.n_dof), T),
                               -model.thermal_load(T), rtol=1e-12, atol=1e-6)
    F = model.pressure_load(1000.0)
    assert F[2::5].sum() == pytest.approx(1000.0 * 0.6 * 0.4, rel=1e-12)
    assert np.abs(np.delete(F, np.arange(2, model.n_dof, 5))).max() == 0.0
    pq = np.full((model.mesh.n_elem, 9), 1000.0)
    np.testing.assert_allclose(model.pressure_load(pq), F, rtol=1e-12)
    M = model.mass()
    w = np.zeros(model.n_dof)
    w[2::5] = 1.0
    assert w @ (M @ w) == pytest.approx(8220.0 * 2e-3 * 0.24, rel=1e-12)


def test_2d_strip_matches_cylindrical_bending():
    # "2d" strip, SS: frequencies of a plate strip in cylindrical bending,
    # f_m = (m pi / a)^2 sqrt(D / (rho h)) / (2 pi); within 0.5 %.
    E, nu, rho, h, a = 70e9, 0.3, 2700.0, 2e-3, 0.5
    mat = isotropic("al", rho, E, nu, 2e-5, 100.0, 900.0)
    panel = PanelSpec(layers=(Layer(mat, h),), kind="2d", length=a, width=0.05, mesh=(12, 1))
    f = modes(StructuralModel(panel), 3).frequencies_hz
    D = E * h**3 / (12 * (1 - nu**2))
    ref = (np.arange(1, 4) * np.pi / a) ** 2 * np.sqrt(D / (rho * h)) / (2 * np.pi)
    np.testing.assert_allclose(f, ref, rtol=0.005)


def test_snap_through_of_shallow_arch_is_followed():
    # Clamped shallow circular arch (2d strip) under uniform pressure towards its centre:
    # the load has a limit point; the solver reaches the far (snapped) equilibrium, which
    # satisfies the equations and is stable, with a deflection several times the rise.
    mat = _inconel()
    a, h, R = 0.3, 1e-3, 2.0
    rise = a**2 / (8 * R)
    panel = PanelSpec(layers=(Layer(mat, h),), kind="2d", length=a, width=0.02, mesh=(12, 1),
                      radius_x=R, boundary="clamped")
    model = StructuralModel(panel)
    res = static(model, pressure=-2.0e5)
    assert res.converged and res.stable
    loads = np.array([lam for lam, _ in res.path])
    assert np.any(np.diff(loads) < 0)      # the path went over the limit point (arc length)
    w = res.center_deflection(model)
    assert w < -1.5 * rise
    r = model.internal_force(res.u) - model.pressure_load(-2.0e5)
    assert np.linalg.norm(r[model.free_dofs]) < 1e-6 * np.linalg.norm(model.pressure_load(2e5))


# -- transient ----------------------------------------------------------------------------
def _small_plate(n=3):
    mat = isotropic("al", 2700.0, 70e9, 0.3, 2e-5, 100.0, 900.0)
    return StructuralModel(PanelSpec(layers=(Layer(mat, 2e-3),), length=0.5, width=0.4,
                                     mesh=(n, n)))


def test_generalized_alpha_parameters():
    g = GeneralizedAlpha(1.0)
    assert (g.alpha_f, g.alpha_m, g.gamma, g.beta) == (0.5, 0.5, 0.5, 0.25)
    g0 = GeneralizedAlpha(0.0)
    assert (g0.alpha_f, g0.alpha_m) == (0.0, -1.0)


def test_transient_is_the_stepper_and_the_linear_stepper_factorizes_once():
    # transient() marches AlphaStepper (scale="net"): driving the stepper by hand gives the
    # same history bit for bit; the linear model's Newton matrix is constant (one factor)
    model = _small_plate()
    u0 = model.factor(model.linear_stiffness()).solve(model.pressure_load(1e3))
    res = transient(model, 1e-4, 20, u0=u0, rho_bar=0.8, nonlinear=False)
    st = AlphaStepper(model, 1e-4, rho_bar=0.8, u0=u0, rtol=1e-10, nonlinear=False,
                      mass=model.mass(), damping=model.damping(), scale="net")
    for _ in range(20):
        u, v, a = st.step(np.zeros(model.n_dof))
    assert np.array_equal(u, res.u[-1]) and np.array_equal(v, res.v[-1])
    assert st.factorizations == 1 and st.iterations == res.iterations
    with pytest.raises(InputError, match="scale"):
        AlphaStepper(model, 1e-4, scale="free")


def test_generalized_alpha_conserves_energy_of_free_vibration():
    # rho-bar = 1, no damping, linear: the scheme is the trapezoidal rule, energy
    # 1/2 v'Mv + 1/2 u'Ku conserved to 1e-6 (issue 4) over 1000 steps.
    model = _small_plate()
    K = model.linear_stiffness()
    M = model.mass()
    m = modes(model, 3)
    u0 = 1e-3 * (m.shapes[:, 0] + 0.5 * m.shapes[:, 2]) / np.abs(m.shapes[:, 0]).max()
    dt = 0.05 / m.frequencies_hz[0]
    res = transient(model, dt, 1000, u0=u0, rho_bar=1.0, nonlinear=False, record_every=10)
    energy = [0.5 * v @ (M @ v) + 0.5 * u @ (K @ u) for u, v in zip(res.u, res.v)]
    energy = np.asarray(energy)
    assert np.abs(energy / energy[0] - 1).max() < 1e-6


def test_generalized_alpha_second_order_convergence():
    # Single-mode free vibration, exact u = phi cos(omega t); state error at t = 1 period for
    # dt = T/16 .. T/128; fitted slope of log err vs log dt in [1.8, 2.2] (issue 4).
    model = _small_plate()
    m = modes(model, 1)
    phi = m.shapes[:, 0] * (1e-4 / np.abs(m.shapes[2::5, 0]).max())
    omega = 2 * np.pi * m.frequencies_hz[0]
    period = 1.0 / m.frequencies_hz[0]
    dts, errs = [], []
    for nst in (16, 32, 64, 128):
        dt = period / nst
        res = transient(model, dt, nst, u0=phi, rho_bar=0.8, nonlinear=False)
        t = res.t[-1]
        # state error (u and v / omega): at t = period u alone is at a peak, where the
        # phase error enters only quadratically
        du = res.u[-1] - phi * np.cos(omega * t)
        dv = (res.v[-1] + omega * phi * np.sin(omega * t)) / omega
        errs.append(np.sqrt(du @ du + dv @ dv) / np.linalg.norm(phi))
        dts.append(dt)
    slope = np.polyfit(np.log(dts), np.log(errs), 1)[0]
    print(f"generalized-alpha errors {errs}, slope {slope:.3f}")
    assert 1.8 <= slope <= 2.2


def test_transient_nonlinear_quasi_steady_reaches_static_solution():
    # rho-bar = 0 with a step load and proportional damping settles on the nonlinear
    # static equilibrium (quasi-steady limit, Sec. 3.2.3); tolerance 1e-3.
    mat = isotropic("al", 2700.0, 70e9, 0.3, 2e-5, 100.0, 900.0)
    panel = PanelSpec(layers=(Layer(mat, 1e-3),), length=0.3, width=0.3, mesh=(3, 3),
                      damping=(200.0, 0.0))
    model = StructuralModel(panel)
    p = 3e3
    ref = static(model, pressure=p)
    F = model.pressure_load(p)
    res = transient(model, 2e-3, 100, rho_bar=0.0, load=lambda t: F)
    w_ref = ref.center_deflection(model)
    assert abs(w_ref) > 1e-3          # nonlinear regime (w > h)
    assert res.u[-1, 5 * model.mesh.center + 2] == pytest.approx(w_ref, rel=1e-3)
