"""Ply stresses at the load-bearing surfaces against closed forms (solvers.structure.stress)."""
from __future__ import annotations

import numpy as np
import pytest
from hypate.solvers.materials import honeycomb_core, isotropic, library_material
from hypate.solvers.panel import Layer, PanelSpec
from hypate.solvers.structure.model import StructuralModel
from hypate.solvers.structure.static import static
from hypate.solvers.structure.stress import SurfaceStress, stressed_surfaces, von_mises


def test_von_mises_of_plane_stress_states() -> None:
    # uniaxial: |s|; equi-biaxial: |s|; pure shear: sqrt(3) t (closed forms)
    s = np.array([[2.0, 0.0, 0.0], [3.0, 3.0, 0.0], [0.0, 0.0, 1.0], [1.0, -1.0, 0.0]])
    np.testing.assert_allclose(von_mises(s), [2.0, 3.0, np.sqrt(3.0), np.sqrt(3.0)])


def test_fully_restrained_uniformly_heated_plate_membrane_stress() -> None:
    """A clamped plate (edges immovable in-plane) heated uniformly by Delta T below its
    buckling temperature stays flat: sigma_x = sigma_y = -E alpha Delta T / (1 - nu)
    everywhere (closed form), so von Mises = E alpha Delta T / (1 - nu); 0.5 % (issue 40)."""
    E, nu, alpha, dT = 204e9, 0.29, 1.237e-5, 20.0
    mat = isotropic("inconel", 8220.0, E, nu, alpha, 11.71, 418.4)
    h, a = 0.004, 0.25
    panel = PanelSpec(layers=(Layer(mat, h, 0.0, 2),), length=a, width=a, mesh=(4, 4),
                      boundary="clamped")
    model = StructuralModel(panel)
    res = static(model, T=300.0 + dT)
    assert res.converged
    T = np.full((model.n_nodes, 3), 300.0 + dT)
    vm, _ = SurfaceStress(model).fields(res.u, T)
    expected = E * alpha * dT / (1.0 - nu)
    np.testing.assert_allclose(vm, expected, rtol=5e-3)
    # the penalty boundary conditions leave the field uniform to far better than that
    assert np.ptp(vm) / expected < 1e-4


def _navier_moments(q: float, a: float, D: float, nu: float, x: np.ndarray, y: np.ndarray,
                    terms: int = 199) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mx, My, Mxy of a simply supported square plate under uniform pressure q (Navier
    double series, Timoshenko & Woinowsky-Krieger Sec. 30), at points (x, y)."""
    m = np.arange(1, terms + 1, 2)
    M, N = np.meshgrid(m, m, indexing="ij")
    wmn = 16.0 * q / (np.pi**6 * D * M * N * (M**2 / a**2 + N**2 / a**2) ** 2)
    ax, ay = M * np.pi / a, N * np.pi / a
    X, Y = x[..., None, None], y[..., None, None]
    s = np.sin(ax * X) * np.sin(ay * Y)
    c = np.cos(ax * X) * np.cos(ay * Y)
    wxx = -(wmn * ax**2 * s).sum(axis=(-2, -1))
    wyy = -(wmn * ay**2 * s).sum(axis=(-2, -1))
    wxy = (wmn * ax * ay * c).sum(axis=(-2, -1))
    return -D * (wxx + nu * wyy), -D * (wyy + nu * wxx), -D * (1.0 - nu) * wxy


def test_bending_stress_of_a_pressurized_plate_against_navier() -> None:
    """Simply supported thin square plate under uniform pressure, small deflection: the
    surface stresses are 6 M / h^2 of the classical (Navier) moments. At the Gauss points
    of the four elements around the centre (where the peak is) the FE von Mises matches
    within 2 % (8 x 8 nine-node mesh, h/a = 0.01: FSDT and discretization errors), there
    sigma_x approaches the classical centre value 6 x 0.0479 q a^2 / h^2; the peak von
    Mises is the corners' twisting stress (Mxy = 0.0325 q a^2 classically), within 2 % of
    the Navier field's peak over the same points."""
    E, nu, h, a, q = 70e9, 0.3, 0.01, 1.0, 1e3
    mat = isotropic("al", 2700.0, E, nu, 2e-5, 100.0, 900.0)
    panel = PanelSpec(layers=(Layer(mat, h),), length=a, width=a, mesh=(8, 8))
    model = StructuralModel(panel)
    u = model.factor(model.linear_stiffness()).solve(model.pressure_load(q))
    stress = SurfaceStress(model)
    T = np.full((model.n_nodes, 2), 300.0)
    vm, _ = stress.fields(u, T)
    D = E * h**3 / (12 * (1 - nu**2))
    xy = stress.points_xy                                           # (E, 9, 2)
    Mx, My, Mxy = _navier_moments(q, a, D, nu, xy[..., 0], xy[..., 1])
    sx, sy, txy = 6 * Mx / h**2, 6 * My / h**2, 6 * Mxy / h**2
    ref = von_mises(np.stack([sx, sy, txy], axis=-1))
    near = np.linalg.norm(xy - a / 2, axis=-1) < a / 8
    for k in range(2):  # bottom and top surface: the same magnitude
        np.testing.assert_allclose(vm[k][near], ref[near], rtol=0.02)
    centre = np.unravel_index(np.argmin(np.linalg.norm(xy - a / 2, axis=-1)), near.shape)
    # Timoshenko Table 8, nu = 0.3: Mx = 0.0479 q a^2 at the centre (the nearest Gauss
    # point is a/16 * 0.225 away: within 1 % of it)
    assert sx[centre] == pytest.approx(6 * 0.0479 * q * a**2 / h**2, rel=0.01)
    assert vm.max() == pytest.approx(ref.max(), rel=0.02)
    assert ref.max() == pytest.approx(np.sqrt(3) * 6 * 0.0325 * q * a**2 / h**2, rel=0.03)


def test_sandwich_stresses_only_its_face_sheets() -> None:
    inc = library_material("inconel718")
    core = honeycomb_core(inc, 0.016, 0.0048, 0.016)
    panel = PanelSpec(layers=(Layer(inc, 0.001), Layer(core, 0.016, 0.0, 2),
                              Layer(inc, 0.001)), length=1.0, width=1.0, mesh=(2, 2))
    surfaces = stressed_surfaces(panel)
    assert [s.layer for s in surfaces] == [0, 0, 2, 2]
    assert [s.level for s in surfaces] == [0, 1, 3, 4]
    np.testing.assert_allclose([s.z for s in surfaces], [-0.009, -0.008, 0.008, 0.009])


def test_stress_ratio_uses_the_yield_strength_at_the_local_temperature() -> None:
    """ratio = von Mises / yield(T) with the material's tabulated yield strength."""
    mat = library_material("inconel718")
    panel = PanelSpec(layers=(Layer(mat, 0.002, 0.0, 1),), length=0.25, width=0.25,
                      mesh=(2, 2), boundary="clamped")
    model = StructuralModel(panel)
    T = np.full((model.n_nodes, 2), 700.0)
    vm, ratio = SurfaceStress(model).fields(np.zeros(model.n_dof), T)
    np.testing.assert_allclose(ratio, vm / mat.limits.yield_strength(700.0), rtol=1e-12)
    peak = SurfaceStress(model).peak(np.zeros(model.n_dof), T)
    assert peak.von_mises == pytest.approx(vm.max())
    assert peak.ratio_stress / peak.ratio == pytest.approx(mat.limits.yield_strength(700.0))
