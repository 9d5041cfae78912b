"""Temperature-dependent materials against the dissertation's 300 K tables."""
from __future__ import annotations

import warnings

import numpy as np
import pytest
from conftest import assert_matches_richardson, richardson_derivative
from hypate.solvers import materials as m
from hypate.solvers.errors import InputError

# Tables 7.5 (Al 7075), 8.4 / 9.5 (Inconel 718), 9.5 (Ti 6242) at 300 K.
TABLES = {
    "al7075": dict(density=2768.1, E=72.86e9, nu=0.325, alpha=2.236e-5, k=132.05, cp=850.99),
    "inconel718": dict(density=8220.0, E=204.0e9, nu=0.29, alpha=1.237e-5, k=11.71, cp=418.4),
    "ti6242": dict(density=4540.0, E=114.3e9, nu=0.32, alpha=0.6975e-5, k=6.937, cp=459.4),
}


@pytest.mark.parametrize("name", sorted(TABLES))
def test_library_matches_dissertation_at_300K(name: str) -> None:
    mat, ref = m.library_material(name), TABLES[name]
    got = dict(density=mat.density(300.0), E=mat.youngs_modulus(300.0),
               nu=mat.poisson_ratio(300.0), alpha=mat.alpha1(300.0),
               k=mat.k1(300.0), cp=mat.specific_heat(300.0))
    for key, value in ref.items():
        # acceptance: within 0.5 % of the tables (they are met to rounding by construction)
        assert float(got[key]) == pytest.approx(value, rel=5e-3), key


@pytest.mark.parametrize("name, lo, hi", [("inconel718", 250.0, 1200.0),
                                          ("ti6242", 250.0, 900.0), ("al7075", 250.0, 650.0)])
def test_tables_cover_required_range_and_derivatives(name: str, lo: float, hi: float) -> None:
    mat = m.library_material(name)
    rng = np.random.default_rng(0)
    T = rng.uniform(lo, hi, 200)
    h = 2e-4
    for prop in (mat.density, mat.E1, mat.nu12, mat.alpha1, mat.k1, mat.specific_heat):
        assert prop.range[0] <= lo and prop.range[1] >= hi, prop.name
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # inside the table: no clamping warning
            fd, bound = richardson_derivative(lambda t, prop=prop: prop(T + t), h)
        # piecewise linear: away from the nodes the difference is the segment slope up to
        # round-off; tolerance: its measured round-off. No node within h of these T (a kink
        # inside the stencil would widen the bound and hide the entry)
        assert np.abs(T[:, None] - prop.T[None, :]).min() > h, prop.name
        assert_matches_richardson(prop.derivative(T), fd, bound, prop.name)
    # moduli stay positive and fall with temperature
    E = mat.youngs_modulus(np.linspace(lo, hi, 50))
    assert np.all(E > 0) and E[-1] < E[0]


def test_clamp_outside_table_is_silent_and_checked_queries_raise() -> None:
    # outside its table a property clamps to the end value without a warning (the
    # temperatures a structure reached are held against the data afterwards); the strict
    # query names the excursion (issue 40)
    prop = m.Property("test.clamp", np.array([300.0, 600.0]), np.array([1.0, 2.0]))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert float(prop(1000.0)) == 2.0 and float(prop(100.0)) == 1.0
        assert np.allclose(prop(np.array([400.0, 500.0])), [4 / 3, 5 / 3])  # inside
    assert float(prop.derivative(1000.0)) == 0.0
    np.testing.assert_allclose(prop.checked(np.array([300.0, 600.0])), [1.0, 2.0])
    with pytest.raises(m.OutsideDataError, match=r"test.clamp: temperatures 100.0-450.0 K"):
        prop.checked(np.array([100.0, 450.0]))


def test_isotropic_stiffness_closed_form_and_derivative() -> None:
    mat = m.library_material("inconel718")
    T = np.array([350.0, 640.0, 905.0])
    Q, dQ = mat.plane_stress_stiffness(T)
    E, nu = mat.youngs_modulus(T), mat.poisson_ratio(T)
    assert np.allclose(Q[:, 0, 0], E / (1 - nu**2), rtol=1e-14)
    assert np.allclose(Q[:, 0, 1], nu * E / (1 - nu**2), rtol=1e-14)
    assert np.allclose(Q[:, 2, 2], E / (2 * (1 + nu)), rtol=1e-14)
    # tolerance: the extrapolated difference's own measured error (E/(1 - nu^2) of
    # piecewise-linear E, nu is smooth inside a segment)
    fd, bound = richardson_derivative(lambda t: mat.plane_stress_stiffness(T + t)[0], 2e-3)
    assert_matches_richardson(dQ, fd, bound, "dQ/dT")


def test_orthotropic_stiffness_and_reciprocity() -> None:
    mat = m.orthotropic("cfrp", density=1600.0, E1=[[300.0, 140e9], [600.0, 120e9]], E2=10e9,
                        G12=5e9, G13=5e9, G23=3e9, nu12=0.3, alpha1=-0.5e-6, alpha2=30e-6,
                        k1=5.0, k2=0.6, k3=0.6, specific_heat=900.0)
    Q, dQ = mat.plane_stress_stiffness(450.0)
    E1, E2, nu12 = 130e9, 10e9, 0.3
    nu21 = nu12 * E2 / E1
    assert Q[0, 0] == pytest.approx(E1 / (1 - nu12 * nu21), rel=1e-12)
    assert Q[0, 1] == pytest.approx(nu21 * E1 / (1 - nu12 * nu21), rel=1e-12)  # symmetric
    fd, bound = richardson_derivative(lambda t: mat.plane_stress_stiffness(450.0 + t)[0], 2e-3)
    assert_matches_richardson(dQ, fd, bound, "dQ/dT")  # the difference's own measured error


def test_thermal_strain_constant_alpha_is_exact() -> None:
    mat = m.isotropic("c", 1000.0, 1e9, 0.3, 2e-5, 1.0, 1.0)
    eps, deps = mat.thermal_strain(np.array([350.0, 500.0]), 320.0)
    assert np.allclose(eps[:, 0], 2e-5 * (np.array([350.0, 500.0]) - 320.0), rtol=1e-14)
    assert np.allclose(deps, 2e-5)


def test_thermal_strain_derivative_temperature_dependent() -> None:
    mat = m.library_material("inconel718")
    T = np.array([420.0, 777.0])
    eps, deps = mat.thermal_strain(T, 300.0)
    fd, bound = richardson_derivative(lambda t: mat.thermal_strain(T + t, 300.0)[0], 2e-3)
    assert_matches_richardson(deps, fd, bound, "d eps/dT")  # the difference's own error


def test_homogenized_stiffener_eq_8_10() -> None:
    base = m.library_material("inconel718")
    st = m.homogenized_stiffener(base, t1=0.002, l1=0.06, t2=0.002, l2=0.06)
    c1 = 0.002 / 0.062  # Eq. (8.11)
    assert st.E1(300.0) == pytest.approx(c1 * 204e9, rel=1e-12)
    assert st.density(300.0) == pytest.approx(2 * c1 * 8220.0, rel=1e-12)
    assert st.k3(300.0) == pytest.approx(2 * c1 * 11.71, rel=1e-12)
    Q, _ = st.plane_stress_stiffness(300.0)
    assert Q[0, 1] == 0.0 and Q[2, 2] == 0.0  # nu12 = G12 = 0
    only_x = m.homogenized_stiffener(base, t1=0.004, l1=0.06, t2=0.0, l2=0.06)
    Qx, _ = only_x.plane_stress_stiffness(300.0)
    assert Qx[1, 1] == 0.0 and Qx[0, 0] > 0.0


def test_honeycomb_core() -> None:
    base = m.library_material("inconel718")
    core = m.honeycomb_core(base, relative_density=0.016, cell_size=0.0048, core_thickness=0.016)
    G, _ = core.transverse_shear_moduli(300.0)
    Gs = 204e9 / (2 * 1.29)
    # Gibson-Ashby regular hexagons: G13 = G23 = rho_rel G_s / 2; G_s = E/(2(1+nu)) is
    # tabulated on the E/nu grid, so linear interpolation of the ratio costs ~1e-5 relative.
    assert np.allclose(G, 0.5 * 0.016 * Gs, rtol=2e-5)
    k3 = core.k3(np.array([300.0, 600.0, 900.0, 1200.0]))
    assert np.all(np.diff(k3) > 0)  # radiation makes conductivity rise with T
    assert core.density(300.0) == pytest.approx(0.016 * 8220.0)
    with pytest.raises(InputError):
        m.honeycomb_core(base, relative_density=0.0, cell_size=0.005, core_thickness=0.01)


def test_user_property_validation() -> None:
    with pytest.raises(InputError, match="youngs_modulus"):
        m.isotropic("bad", 1000.0, -1e9, 0.3, 1e-5, 1.0, 1.0)
    with pytest.raises(InputError, match="poisson_ratio"):
        m.isotropic("bad", 1000.0, 1e9, 0.7, 1e-5, 1.0, 1.0)
    with pytest.raises(InputError, match="increasing"):
        m.as_property("bad.k", [[600.0, 1.0], [300.0, 2.0]])
    with pytest.raises(InputError, match="unknown material"):
        m.library_material("unobtainium")
