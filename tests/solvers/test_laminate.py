"""Laminate integrals (Eqs. 3.3-3.9, 3.13) against classical lamination theory and closed forms."""
from __future__ import annotations

import numpy as np
import pytest
from hypate.solvers.laminate import (
    SHEAR_CORRECTION,
    classical_abd,
    laminate,
    level_temperatures,
)
from hypate.solvers.materials import isotropic, orthotropic
from hypate.solvers.panel import Layer, PanelSpec, thermal_levels

E1, E2, G12, NU12 = 140e9, 10e9, 5e9, 0.3


def _ply(**over: object):
    props = dict(density=1600.0, E1=E1, E2=E2, G12=G12, G13=G12, G23=3.5e9, nu12=NU12,
                 alpha1=-0.5e-6, alpha2=25e-6, k1=5.0, k2=1.0, k3=1.0, specific_heat=900.0)
    props.update(over)
    return orthotropic("ply", **props)


def _q_material() -> np.ndarray:
    """Reduced stiffness written out by hand (Jones, Mechanics of Composite Materials)."""
    nu21 = NU12 * E2 / E1
    d = 1.0 - NU12 * nu21
    return np.array([[E1 / d, NU12 * E2 / d, 0.0], [NU12 * E2 / d, E2 / d, 0.0],
                     [0.0, 0.0, G12]])


def test_antisymmetric_cross_ply_matches_classical_lamination_theory():
    # [0/90] antisymmetric cross-ply: B != 0 (B11 = -B22, Jones Sec. 4.3.3); closed-form CLT
    # sums written independently here. Tolerance 1e-10: Simpson's rule is exact for
    # constant properties (polynomials of degree <= 3 in z).
    t = 0.5e-3
    ply = _ply()
    panel = PanelSpec(layers=(Layer(ply, t, 0.0), Layer(ply, t, np.pi / 2)))
    lam = laminate(panel)
    Q0 = _q_material()
    Q90 = Q0[[1, 0, 2]][:, [1, 0, 2]]
    z = np.array([-t, 0.0, t])
    A = Q0 * (z[1] - z[0]) + Q90 * (z[2] - z[1])
    B = 0.5 * (Q0 * (z[1] ** 2 - z[0] ** 2) + Q90 * (z[2] ** 2 - z[1] ** 2))
    D = (Q0 * (z[1] ** 3 - z[0] ** 3) + Q90 * (z[2] ** 3 - z[1] ** 3)) / 3.0
    for got, ref in ((lam.A, A), (lam.B, B), (lam.D, D)):
        np.testing.assert_allclose(got, ref, rtol=1e-10, atol=1e-10 * np.abs(ref).max())
    assert abs(lam.B[0, 0]) > 1e-3 * lam.A[0, 0] * t          # B != 0
    assert lam.B[0, 0] == pytest.approx(-lam.B[1, 1], rel=1e-10)
    Ac, Bc, Dc = classical_abd(panel)
    np.testing.assert_allclose(lam.D, Dc, rtol=1e-10)


def test_angle_ply_rotation_and_quasi_isotropy():
    # [0/60/-60]s is quasi-isotropic: A11 = A22, A16 = A26 = 0, A66 = (A11 - A12)/2 (exact).
    ply = _ply()
    t = 0.2e-3
    angles = np.radians([0, 60, -60, -60, 60, 0])
    panel = PanelSpec(layers=tuple(Layer(ply, t, a) for a in angles))
    A = laminate(panel).A
    s = A[0, 0]
    assert A[1, 1] == pytest.approx(s, rel=1e-12)
    assert abs(A[0, 2]) < 1e-12 * s and abs(A[1, 2]) < 1e-12 * s
    assert A[2, 2] == pytest.approx(0.5 * (A[0, 0] - A[0, 1]), rel=1e-12)
    np.testing.assert_allclose(laminate(panel).B, 0.0, atol=1e-12 * s * t)  # symmetric


def test_isotropic_closed_forms_and_thermal_resultants():
    # Plate formulas: A = Eh/(1-nu^2), D = Eh^3/(12(1-nu^2)), S = 5/6 G h,
    # N_T = E alpha dT h/(1-nu), M_T = 0, I1 = rho h, I3 = rho h^3/12 (exact).
    E, nu, a, rho, h = 200e9, 0.3, 1.2e-5, 8000.0, 2e-3
    mat = isotropic("steel", rho, E, nu, a, 15.0, 500.0)
    panel = PanelSpec(layers=(Layer(mat, h, 0.0, 3),), initial_temperature=300.0)
    lam = laminate(panel, 350.0)
    assert lam.A[0, 0] == pytest.approx(E * h / (1 - nu**2), rel=1e-12)
    assert lam.D[0, 0] == pytest.approx(E * h**3 / (12 * (1 - nu**2)), rel=1e-12)
    assert lam.S[0, 0] == pytest.approx(SHEAR_CORRECTION * E / (2 * (1 + nu)) * h, rel=1e-12)
    assert lam.NT[0] == pytest.approx(E * a * 50.0 * h / (1 - nu), rel=1e-12)
    assert lam.NT[2] == pytest.approx(0.0, abs=1e-9)
    np.testing.assert_allclose(lam.MT, 0.0, atol=1e-9)
    assert lam.I1 == pytest.approx(rho * h, rel=1e-12)
    assert lam.I2 == pytest.approx(0.0, abs=1e-15)
    assert lam.I3 == pytest.approx(rho * h**3 / 12, rel=1e-12)


def test_linear_gradient_gives_closed_form_thermal_moment():
    # Linear T(z) = T0 + g z with constant properties: M_T = E alpha g h^3 / (12 (1 - nu)),
    # N_T = 0 (exact; Simpson integrates z * linear exactly).
    E, nu, a, h, g = 100e9, 0.25, 1e-5, 4e-3, 2e4
    mat = isotropic("m", 4000.0, E, nu, a, 10.0, 500.0)
    panel = PanelSpec(layers=(Layer(mat, h, 0.0, 2),), initial_temperature=300.0)
    T = 300.0 + g * thermal_levels(panel)
    lam = laminate(panel, T)
    assert lam.MT[0] == pytest.approx(E * a * g * h**3 / (12 * (1 - nu)), rel=1e-12)
    assert abs(lam.NT[0]) < 1e-9 * E * a * g * h**2


def test_temperature_dependent_simpson_converges_to_fine_integral():
    # Temperature-dependent E2 and alpha1 with a steep profile: Simpson per sub-layer
    # converges (4th order) to a fine trapezoid integral; with 4 sub-layers per ply the
    # difference is < 1e-4 (tolerance from the observed error ~1e-6, kept loose).
    ply = _ply(E2=[(200.0, 12e9), (500.0, 9e9), (800.0, 4e9)],
               alpha1=[(200.0, -1e-6), (800.0, 2e-6)])
    t = 1e-3
    panel = PanelSpec(layers=(Layer(ply, t, 0.0, 4), Layer(ply, t, np.pi / 2, 4)))
    z = thermal_levels(panel)
    T = 300.0 + 400.0 * ((z - z[0]) / (z[-1] - z[0])) ** 2   # sampled at levels
    lam = laminate(panel, T)
    # fine reference: piecewise linear T between levels, 20000 points per interval set
    zf = np.linspace(z[0], z[-1], 200001)
    Tf = np.interp(zf, z, T)
    lay = (zf > 0).astype(int)
    Qb = np.empty(zf.shape + (3, 3))
    for k, ang in enumerate((0.0, np.pi / 2)):
        from hypate.solvers.laminate import strain_rotation
        sel = lay == k
        Q, _ = ply.plane_stress_stiffness(Tf[sel])
        R = strain_rotation(ang)
        Qb[sel] = np.einsum("ji,...jk,kl->...il", R, Q, R)
    Aref = np.trapezoid(Qb, zf, axis=0)
    Dref = np.trapezoid(Qb * zf[:, None, None] ** 2, zf, axis=0)
    np.testing.assert_allclose(lam.A, Aref, rtol=1e-4, atol=1e-4 * Aref.max())
    np.testing.assert_allclose(lam.D, Dref, rtol=1e-4, atol=1e-4 * Dref.max())


def test_vectorized_over_points():
    # A profile per point: results stack along leading axes, each equal to a single call.
    ply = _ply()
    panel = PanelSpec(layers=(Layer(ply, 1e-3, 0.3, 2), Layer(ply, 1e-3, -0.3, 1)))
    nl = thermal_levels(panel).size
    rng = np.random.default_rng(1)
    T = 300.0 + 100.0 * rng.random((4, 3, nl))
    lam = laminate(panel, T)
    assert lam.A.shape == (4, 3, 3, 3) and lam.NT.shape == (4, 3, 3) and lam.I1.shape == (4, 3)
    one = laminate(panel, T[2, 1])
    np.testing.assert_allclose(lam.ABD[2, 1], one.ABD, rtol=1e-14)
    np.testing.assert_allclose(lam.NT[2, 1], one.NT, rtol=1e-14)
    assert level_temperatures(panel, 310.0).shape == (nl,)
