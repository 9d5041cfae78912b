"""Similarity parameters (Eqs. 6.1-6.3, 9.1) and analytical scaling laws (Eqs. 9.2-9.6)."""
from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest
from conftest import REPO
from hypate.scaling.workflow.vocabulary.configuration import (
    Configuration,
    ReferenceTemperatures,
    apply_design,
    scaled_panel,
)
from hypate.scaling.workflow.vocabulary.similarity import (
    PARAMETERS,
    analytical_scaling,
    compare,
    comparison_records,
    fourier_time_scale,
    log_mismatch,
    matched_time,
    reference_quantities,
    similarity_parameters,
    structural_time_scale,
)
from hypate.solvers.config import load_case
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition, sutherland_viscosity
from hypate.solvers.materials import isotropic, library_material
from hypate.solvers.panel import Layer, PanelSpec

# Table 9.1 (temperature-independent properties at 300 K).
INCONEL = dict(density=8220.0, youngs_modulus=204.0e9, poisson_ratio=0.29,
               thermal_expansion=1.237e-5, conductivity=11.71, specific_heat=418.4)
TI6242 = dict(density=4540.0, youngs_modulus=114.3e9, poisson_ratio=0.32,
              thermal_expansion=0.6975e-5, conductivity=6.937, specific_heat=459.4)
SEC9_1 = ("h/L", "lambda_F", "DeltaT_NTx_L2/Dxx")


@pytest.fixture(scope="module")
def sec9_1():
    """Sec. 9.1 prototype (case file: library Inconel 718 at 300 K = Table 9.1) with
    Delta T = 1 K and dt = 1 ms, and the Ti 6242 model template."""
    case = load_case(REPO / "studies/cases/sec9_1_prototype.toml")
    proto = Configuration(case.panel, case.flow, delta_T=1.0, time=1e-3)
    layer = dataclasses.replace(case.panel.layers[0], material=library_material("ti6242"))
    model = Configuration(dataclasses.replace(case.panel, layers=(layer,)), case.flow)
    return proto, model


def _plate(props: dict, h: float, L: float = 1.0) -> PanelSpec:
    return PanelSpec(layers=(Layer(isotropic("m", **props), h),), length=L, width=L,
                     initial_temperature=300.0)


def test_table_9_3_prototype_values(sec9_1):
    proto, _ = sec9_1
    p = similarity_parameters(proto)
    assert p["h/L"] == pytest.approx(0.002, rel=1e-12)
    # Measured here: lambda_F = 565.703 (0.065 % below 566.07) and Delta T N_Tx L^2/D_xx =
    # 47.872 (0.021 % below 47.882), both from the closed forms D = E h^3/(12 (1 - nu^2)),
    # N_Tx = E alpha h/(1 - nu) with gamma = 1.4 exactly. The two table values are not
    # consistent with one common D (that would shift both by the same factor); they were
    # presumably read off the shell model. Tolerance 1e-3 covers both.
    assert p["lambda_F"] == pytest.approx(566.07, rel=1e-3)
    assert p["DeltaT_NTx_L2/Dxx"] == pytest.approx(47.882, rel=1e-3)


def test_reference_quantities_closed_forms(sec9_1):
    proto, _ = sec9_1
    ref = reference_quantities(proto)
    E, nu, a, h = 204.0e9, 0.29, 1.237e-5, 0.002
    # 1e-12: Simpson's rule (laminate) is exact for constant properties.
    assert ref.D_xx == pytest.approx(E * h**3 / (12 * (1 - nu**2)), rel=1e-12)
    assert ref.A_xx == pytest.approx(E * h / (1 - nu**2), rel=1e-12)
    assert ref.B_xx == pytest.approx(0.0, abs=1e-9)
    assert ref.N_Tx_per_K == pytest.approx(E * a * h / (1 - nu), rel=1e-12)
    assert ref.N_Tx == pytest.approx(ref.N_Tx_per_K * 300.0, rel=1e-12)   # Eq. (3.21c)
    assert ref.M_Tx == pytest.approx(ref.N_Tx * h, rel=1e-12)             # Eq. (3.21d)
    assert ref.mass_per_area == pytest.approx(8220.0 * h, rel=1e-12)
    assert ref.rho_cp == pytest.approx(8220.0 * 418.4, rel=1e-12)
    assert ref.conductivity == pytest.approx(11.71, rel=1e-12)
    assert ref.thermal_time == pytest.approx(8220.0 * 418.4 * h**2 / 11.71, rel=1e-12)
    assert ref.temperatures == ReferenceTemperatures(300.0, 300.0, 300.0,
                                                     proto.flow.temperature)


def test_library_materials_at_300K_equal_table_9_1(sec9_1):
    """The case file's temperature-dependent library material gives the Table 9.1 plate."""
    proto, _ = sec9_1
    table = dataclasses.replace(proto, panel=_plate(INCONEL, 0.002))
    a, b = similarity_parameters(proto), similarity_parameters(table)
    for name in a:
        assert a[name] == pytest.approx(b[name], rel=1e-12, abs=1e-300), name


def test_parameter_formulas(sec9_1):
    proto, _ = sec9_1
    f = proto.flow
    p = similarity_parameters(proto)
    assert list(p) == [n for n in PARAMETERS if n in p]
    ref = reference_quantities(proto)
    mu = float(sutherland_viscosity(f.temperature))
    assert p["Re_0"] == pytest.approx(f.density * f.velocity / mu, rel=1e-12)
    # Eq. (6.2b) with k_f = c_p mu / Pr reduces to rho V^3 L / (k T_T).
    assert p["Bi_F"] == pytest.approx(f.density * f.velocity**3 / (11.71 * 300.0), rel=1e-12)
    assert p["Fo"] == pytest.approx(1e-3 / ref.thermal_time, rel=1e-12)
    assert p["I_L4/(Dxx_t2)"] == pytest.approx(ref.mass_per_area / ref.D_xx / 1e-6, rel=1e-12)
    assert p["T0/TS"] == pytest.approx(f.stagnation_temperature / 300.0, rel=1e-12)
    assert p["TF/TS"] == pytest.approx(f.temperature / 300.0, rel=1e-12)
    assert p["M_h/L"] == pytest.approx(6 * 0.002, rel=1e-12)
    assert p["Bi_ext"] == 0.0 and p["lambda_ext"] == 0.0


def test_optional_parameters_and_inputs(sec9_1):
    proto, _ = sec9_1
    bare = dataclasses.replace(proto, delta_T=None, time=None)
    p = similarity_parameters(bare)
    assert "DeltaT_NTx_L2/Dxx" not in p and "Fo" not in p
    with pytest.raises(InputError) as err:
        similarity_parameters(bare, names=["Fo"])
    assert err.value.field == "similarity.Fo"
    with pytest.raises(InputError):
        similarity_parameters(bare, names=["nope"])
    heated = dataclasses.replace(proto, simulation=dataclasses.replace(
        proto.simulation, radiation_temperature=1000.0, external_pressure=500.0,
        external_heat_flux=100.0))
    q = heated.panel.emissivity * 5.670374419e-8 * 1000.0**4 + 100.0
    ref = reference_quantities(heated)
    hp = similarity_parameters(heated)
    assert hp["Bi_ext"] == pytest.approx(q * 0.002 / (11.71 * 300.0), rel=1e-12)
    assert hp["lambda_ext"] == pytest.approx(500.0 / ref.D_xx, rel=1e-12)
    hot = dataclasses.replace(proto, temperatures=ReferenceTemperatures(wall=400.0, fluid=250.0))
    hp = similarity_parameters(hot)
    assert hp["Tw/TS"] == 1.0 and hp["TF/TS"] == pytest.approx(250.0 / 400.0)


@pytest.mark.parametrize("xi", [2.0, 3.0, 4.0])
def test_analytical_laws_reproduce_the_prototype(sec9_1, xi):
    proto, model = sec9_1
    a = analytical_scaling(proto, model, xi)
    p, m = similarity_parameters(proto), similarity_parameters(a.model)
    # Eq. (9.1): exact up to round-off.
    for name in (*SEC9_1, "I_L4/(Dxx_t2)"):
        assert m[name] == pytest.approx(p[name], rel=1e-12), name
    # Closed forms of Eq. (9.2) for isotropic plates (Table 9.1 properties).
    Ep, nup, ap = 204.0e9, 0.29, 1.237e-5
    Em, num, am = 114.3e9, 0.32, 0.6975e-5
    assert a.thickness == pytest.approx(0.002 / xi, rel=1e-14)
    assert a.length == pytest.approx(1.0 / xi, rel=1e-14)
    d_ratio = (Em / (1 - num**2)) / (Ep / (1 - nup**2)) / xi**3
    assert a.pressure == pytest.approx(xi**3 * d_ratio * 1e4, rel=1e-12)
    n_ratio = (Ep * ap / (1 - nup)) / (Em * am / (1 - num) / xi)
    assert a.delta_T == pytest.approx(xi**2 * d_ratio * n_ratio * 1.0, rel=1e-12)
    # Eq. (9.3)
    i_ratio = 4540.0 / 8220.0 / xi
    assert a.time_step == pytest.approx(1e-3 / xi**2 * math.sqrt(i_ratio / d_ratio), rel=1e-12)
    # Eq. (9.6) vs Eq. (6.5): the same when h scales with 1/xi; it keeps Fo equal.
    ref_p, ref_m = reference_quantities(proto), reference_quantities(a.model)
    assert a.fourier_time_scale == pytest.approx(fourier_time_scale(ref_p, ref_m), rel=1e-12)
    assert structural_time_scale(ref_p, ref_m) == pytest.approx(a.time_scale, rel=1e-14)
    fo_model = dataclasses.replace(a.model, time=a.fourier_time_scale * 1e-3)
    assert similarity_parameters(fo_model)["Fo"] == pytest.approx(p["Fo"], rel=1e-12)
    assert set(a.design()) == {"L", "h", "p_inf", "delta_T", "time"}


def test_compare_table_and_public_records(sec9_1):
    proto, model = sec9_1
    a = analytical_scaling(proto, model, 2.0)
    table = compare(proto, a.model)
    assert list(table.columns) == ["name", "prototype", "model", "relative_difference"]
    assert np.all(table.loc[table.name.isin(SEC9_1), "relative_difference"] < 1e-12)
    small = compare(proto, a.model, names=SEC9_1)
    assert list(small.name) == list(SEC9_1)
    zero = compare({"x": 0.0, "y": 0.0, "z": 2.0}, {"x": 0.0, "y": 1.0, "z": 3.0})
    assert zero.relative_difference.iloc[0] == 0.0
    assert math.isnan(zero.relative_difference.iloc[1])
    assert zero.relative_difference.iloc[2] == pytest.approx(0.5)
    records = comparison_records(zero)
    assert records[1] == {"name": "y", "prototype": 0.0, "model": 1.0,
                          "relative_difference": None}
    json.dumps(comparison_records(table), allow_nan=False)  # strict JSON


def test_apply_design_variables(sec9_1):
    _, model = sec9_1
    two = dataclasses.replace(model, panel=dataclasses.replace(
        model.panel, layers=model.panel.layers * 2, width=2.0))
    c = apply_design(two, {"L": 0.5, "h": 0.004, "L_le": 0.3, "M": 7.0, "p0": 5e6, "T0": 2200.0,
                           "emissivity": 0.6, "T_rad": 1500.0, "delta_T": 2.0, "time": 0.1})
    assert c.panel.length == 0.5 and c.panel.width == 1.0  # aspect ratio kept
    assert [layer.thickness for layer in c.panel.layers] == pytest.approx([0.002, 0.002])
    assert c.panel.leading_edge_length == 0.3 and c.panel.emissivity == 0.6
    assert c.flow.mach == 7.0
    assert c.flow.stagnation_pressure == pytest.approx(5e6, rel=1e-12)
    assert c.flow.stagnation_temperature == pytest.approx(2200.0, rel=1e-12)
    assert c.radiation_temperature == 1500.0 and c.delta_T == 2.0 and c.time == 0.1
    c = apply_design(two, {"h[1]": 0.003, "p_inf": 5000.0, "T_w": 500.0})
    assert [layer.thickness for layer in c.panel.layers] == pytest.approx([0.002, 0.003])
    assert c.flow.pressure == 5000.0 and c.flow.temperature == model.flow.temperature
    assert c.resolved_temperatures().structural == 500.0
    for bad, field in (({"p0": 1e6, "p_inf": 1e3}, "design.p_inf"),
                       ({"wings": 1.0}, "design.wings"), ({"h": -1.0}, "design.h"),
                       ({"h[5]": 0.001}, "design.h[5]")):
        with pytest.raises(InputError) as err:
            apply_design(two, bad)
        assert err.value.field == field


def test_sandwich_reference_conductivity_is_a_series_sum():
    """Eq. (4.12): series conductivity through the layers; rho c_p thickness-averaged."""
    case = load_case(REPO / "scaling/data/cases/sec9_2_prototype.toml")
    config = Configuration(case.panel, case.flow)
    layers = case.panel.layers
    for axis, comp in (("thickness", 2), ("x", 0)):
        ref = reference_quantities(config, conductivity_axis=axis)
        k = [float(layer.material.conductivity(300.0)[0][comp]) for layer in layers]
        series = 0.018 / sum(layer.thickness / ki for layer, ki in zip(layers, k))
        assert ref.conductivity == pytest.approx(series, rel=1e-12)
    rc = sum(float(layer.material.heat_capacity(300.0)[0]) * layer.thickness for layer in layers)
    assert reference_quantities(config).rho_cp == pytest.approx(rc / 0.018, rel=1e-12)


def test_scaled_panel_and_tunnel_flow_roundtrip(sec9_1):
    _, model = sec9_1
    p = scaled_panel(model.panel, length=0.25, thickness=0.0005)
    assert p.width == 0.25 and p.thickness == pytest.approx(0.0005)
    f = FlowCondition.from_stagnation(6.0, 2e6, 1700.0)
    c = apply_design(dataclasses.replace(model, flow=f), {"T0": 1800.0})
    assert c.flow.stagnation_pressure == pytest.approx(2e6, rel=1e-12)
    assert c.flow.stagnation_temperature == pytest.approx(1800.0, rel=1e-12)


def test_matched_time_and_log_mismatch(sec9_1):
    proto, model = sec9_1
    a = analytical_scaling(proto, model, 3.0)
    assert matched_time(proto, a.model, 1e-3, "structural") == pytest.approx(a.time_step,
                                                                             rel=1e-12)
    assert matched_time(proto, a.model, 1.0) == pytest.approx(a.fourier_time_scale, rel=1e-12)
    with pytest.raises(InputError):
        matched_time(proto, a.model, 1.0, "thermal")
    e = log_mismatch(proto, a.model, list(SEC9_1))
    assert np.all(np.abs(e) < 1e-12)
    doubled = dataclasses.replace(a.model, delta_T=2 * a.delta_T)
    e = log_mismatch(similarity_parameters(proto), doubled, ["DeltaT_NTx_L2/Dxx"])
    assert e[0] == pytest.approx(math.log(2.0), rel=1e-12)


def test_fourier_length_rule_uses_the_cell_wall_material_of_a_honeycomb_core() -> None:
    # Sec. 9.2 sandwich (Table 9.4: Inconel 718 sheets and Inconel 718 honeycomb): the
    # Eq. (9.5) reference is Inconel 718 itself (Table 9.5 at 300 K), whereas the effective
    # Eq. (4.12) conductivity is dominated by the core (Swann-Pittman: 0.27 W/(m K)).
    case = load_case(REPO / "scaling/data/cases/sec9_2_prototype.toml")
    proto = Configuration(case.panel, case.flow)
    ref = reference_quantities(proto)
    assert ref.solid_conductivity == pytest.approx(11.71, rel=1e-3)
    assert ref.solid_rho_cp == pytest.approx(8220.0 * 418.4, rel=1e-3)
    assert ref.conductivity < 0.05 * ref.solid_conductivity
    # a Ti 6242 plate of a quarter the length: Eq. (9.6) = material ratio / 16
    model = Configuration(_plate(TI6242, 0.004, L=0.25), case.flow)
    ref_m = reference_quantities(model)
    material = (11.71 * 4540.0 * 459.4) / (6.937 * 8220.0 * 418.4)
    scale = fourier_time_scale(ref, ref_m)
    assert scale == pytest.approx(material / 16.0, rel=2e-3)
    assert fourier_time_scale(ref, ref_m, xi=4.0) == pytest.approx(scale, rel=1e-12)
    assert matched_time(proto, model, 160.0) == pytest.approx(160.0 * scale, rel=1e-12)
    # the matched times keep the length-based Fourier number Fo_L equal
    fo_p = similarity_parameters(dataclasses.replace(proto, time=1.0), names=["Fo_L"])
    fo_m = similarity_parameters(dataclasses.replace(model, time=scale), names=["Fo_L"])
    assert fo_m["Fo_L"] == pytest.approx(fo_p["Fo_L"], rel=1e-12)
    # Eq. (6.5) with the layups' effective properties and (h_m / h_p)^2 instead
    thick = fourier_time_scale(ref, ref_m, rule="thickness")
    assert thick == pytest.approx(ref.conductivity * ref_m.rho_cp / (ref_m.conductivity
                                  * ref.rho_cp) * (0.004 / 0.018) ** 2, rel=1e-12)
