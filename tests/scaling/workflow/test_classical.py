"""Classical scaling as a geometric program (left prong) against the analytical laws."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from conftest import REPO
from hypate.scaling.workflow.vocabulary.classical import classical_scaling, design_vector
from hypate.scaling.workflow.vocabulary.configuration import (
    Configuration,
    apply_design,
    scaled_panel,
)
from hypate.scaling.workflow.vocabulary.similarity import analytical_scaling, similarity_parameters
from hypate.scaling.workflow.vocabulary.tunnels import bound_set, tunnel
from hypate.solvers.config import load_case
from hypate.solvers.errors import InputError
from hypate.solvers.materials import library_material
from hypate.solvers.panel import Layer

SEC9_1 = ["h/L", "lambda_F", "DeltaT_NTx_L2/Dxx"]


@pytest.fixture(scope="module")
def sec9_1():
    case = load_case(REPO / "studies/cases/sec9_1_prototype.toml")
    proto = Configuration(case.panel, case.flow, delta_T=1.0)
    layer = dataclasses.replace(case.panel.layers[0], material=library_material("ti6242"))
    model = Configuration(dataclasses.replace(case.panel, layers=(layer,)), case.flow)
    return proto, model


def _at_scale(model: Configuration, xi: float) -> Configuration:
    return dataclasses.replace(model, panel=scaled_panel(model.panel, length=1.0 / xi))


@pytest.mark.parametrize("xi", [2.0, 3.0, 4.0])
def test_gp_equals_analytical_laws_when_matchable(sec9_1, xi):
    proto, model = sec9_1
    exact = analytical_scaling(proto, model, xi).design()
    res = classical_scaling(proto, _at_scale(model, xi), bound_set("table9_2"), SEC9_1)
    assert res.status == "optimal"
    # 1e-6 (the acceptance); measured about 1e-9: the GP is an LP in log space solved by an
    # interior-point method with tolerance 1e-8.
    for name in ("h", "p_inf", "delta_T"):
        assert res.design[name] == pytest.approx(exact[name], rel=1e-6), name
    assert all(abs(r) < 1e-6 for r in res.residuals.values())
    assert res.matched and res.active_bounds == ()
    assert res.objective < 1e-6


def test_tightened_bound_reports_residuals_and_active_bounds(sec9_1):
    proto, model = sec9_1
    p_exact = analytical_scaling(proto, model, 2.0).pressure
    bounds = {**bound_set("table9_2"), "p_inf": (3000.0, 0.8 * p_exact)}
    res = classical_scaling(proto, _at_scale(model, 2.0), bounds, SEC9_1)
    assert not res.matched
    assert [(b.name, b.side) for b in res.active_bounds] == [("p_inf", "upper")]
    assert res.design["p_inf"] == 0.8 * p_exact
    assert res.active_constraints() == [f"p_inf at upper bound {0.8 * p_exact:g}"]
    # Weighted-sum (product) objective: lambda_F ~ p h^-3 is cheaper to fix through h (1/3
    # of its log error) than to leave, so h/L carries the whole mismatch 0.8^(1/3) - 1.
    assert res.residuals["h/L"] == pytest.approx(0.8 ** (1 / 3) - 1, rel=1e-6)
    assert abs(res.residuals["lambda_F"]) < 1e-6
    assert abs(res.residuals["DeltaT_NTx_L2/Dxx"]) < 1e-6
    assert res.objective == pytest.approx(-math.log(0.8) / 3, rel=1e-6)
    # Residuals are the true parameters of the returned design.
    again = similarity_parameters(apply_design(_at_scale(model, 2.0), res.design), names=SEC9_1)
    for name in SEC9_1:
        assert again[name] / res.targets[name] - 1 == pytest.approx(res.residuals[name],
                                                                    abs=1e-12)
    # Minimax: the mismatch is shared equally by h/L and lambda_F (0.8^(1/4) - 1 each) and
    # the second stage still matches the temperature parameter.
    mm = classical_scaling(proto, _at_scale(model, 2.0), bounds, SEC9_1, objective="max")
    assert mm.residuals["h/L"] == pytest.approx(0.8 ** 0.25 - 1, rel=1e-6)
    assert mm.residuals["lambda_F"] == pytest.approx(0.8 ** 0.25 - 1, rel=1e-6)
    assert abs(mm.residuals["DeltaT_NTx_L2/Dxx"]) < 1e-6
    record = res.to_dict()
    assert record["active_constraints"] == [{"name": "p_inf", "bound": "upper",
                                             "value": 0.8 * p_exact}]


def test_seed_point_in_optimizer_order(sec9_1):
    proto, model = sec9_1
    res = classical_scaling(proto, _at_scale(model, 2.0), bound_set("table9_2"), SEC9_1)
    x = res.point(["delta_T", "h", "p_inf"])
    assert x == pytest.approx([res.design["delta_T"], res.design["h"], res.design["p_inf"]])
    x = design_vector(res.design, ["h", "L"], defaults={"L": 0.5},
                      bounds={"h": (0.0002, 0.0009)})
    assert x == pytest.approx([0.0009, 0.5])
    x = design_vector({"a": 5.0, "b": -1.0}, ["b", "a"], bounds=np.array([[0, 1], [0, 1]]))
    assert x.tolist() == [0.0, 1.0]
    with pytest.raises(InputError) as err:
        res.point(["h", "T0"])
    assert err.value.field == "design.T0"
    assert res.similarity_table(proto, SEC9_1).relative_difference.max() < 1e-6


def test_sequential_gp_for_non_monomial_parameters():
    """Re_0 (Sutherland viscosity) and the isentropic nozzle in M, p0, T0 are not monomials:
    sequential GP still matches lambda_F, Re_0, T0/T_S exactly in the ideal tunnel, and for
    an unattainable set it stops at a local minimum of the true mismatch."""
    case = load_case(REPO / "scaling/data/cases/sec9_2_prototype.toml")
    proto = Configuration(case.panel, case.flow)
    panel = dataclasses.replace(case.panel, layers=(Layer(library_material("ti6242"), 0.005),),
                                length=0.25, width=0.25)
    ideal = tunnel("ideal")
    template = Configuration(panel, ideal.flow(6.0, 1e7, 2000.0))
    bounds = {**ideal.bounds(), "h": bound_set("table9_7")["h"]}
    match = ["lambda_F", "Re_0", "T0/TS"]
    res = classical_scaling(proto, template, bounds, match)
    assert res.status == "optimal" and res.iterations > 1
    assert all(abs(r) < 1e-6 for r in res.residuals.values())

    match = ["h/L", "lambda_F", "Bi_F", "Re_0", "T0/TS"]
    res = classical_scaling(proto, template, bounds, match)
    assert res.status == "optimal" and not res.matched
    assert {(b.name, b.side) for b in res.active_bounds} >= {("T0", "upper")}

    def mismatch(design):
        vals = similarity_parameters(apply_design(template, design), names=match)
        return sum(abs(math.log(vals[n] / res.targets[n])) for n in match)

    base = mismatch(res.design)
    assert base == pytest.approx(res.objective, rel=1e-12)
    for name, (lo, hi) in bounds.items():
        for factor in (1.001, 0.999):
            trial = dict(res.design)
            trial[name] = float(np.clip(trial[name] * factor, lo, hi))
            # 1e-7: the GP solver's accuracy in log units.
            assert mismatch(trial) > base - 1e-7, (name, factor)


def test_zero_prototype_parameters_and_fixed_variables(sec9_1):
    proto, model = sec9_1
    bounds = {**bound_set("table9_2"), "L": (0.5, 0.5)}
    res = classical_scaling(proto, model, bounds, [*SEC9_1, "lambda_ext"])
    assert res.design["L"] == 0.5 and res.residuals["lambda_ext"] == 0.0
    assert res.matched


@pytest.mark.parametrize("kwargs, field", [
    ({"bounds": {"h": (0.002, 0.001)}}, "bounds.h"),
    ({"bounds": {"h": (0.0, 0.001)}}, "bounds.h"),
    ({"bounds": {"wings": (1.0, 2.0)}}, "design.wings"),
    ({"match": ["nope"]}, "similarity.nope"),
    ({"match": {"h/L": -1.0}}, "match.h/L"),
    ({"objective": "mean"}, "objective"),
])
def test_bad_inputs(sec9_1, kwargs, field):
    proto, model = sec9_1
    args = {"bounds": bound_set("table9_2"), "match": SEC9_1, **kwargs}
    with pytest.raises(InputError) as err:
        classical_scaling(proto, model, **args)
    assert err.value.field == field


def test_similarity_exponents_and_basis(sec9_1):
    # Eq. 9.1a as monomials of (h, p_inf, Delta T): h/L ~ h, lambda_F ~ p_inf h^-3 (D ~ h^3),
    # Delta T N_Tx L^2 / D_xx ~ Delta T h^-2 (N_Tx ~ h): exact to the central differences.
    from hypate.scaling.workflow.vocabulary.classical import similarity_basis, similarity_exponents

    _, model = sec9_1
    design = {"h": 1e-3, "p_inf": 5e3, "delta_T": 2.0}
    E = similarity_exponents(_at_scale(model, 2.0), design, ["h", "p_inf", "delta_T"], SEC9_1)
    assert np.allclose(E, [[1, 0, 0], [-3, 1, 0], [-2, 0, 1]], atol=1e-8)
    assert np.array_equal(similarity_basis(E), E)
    # fewer independent parameters than variables: kept rows first, then an orthonormal
    # complement of their null space; a repeated direction is skipped
    B = similarity_basis(np.array([[1.0, 1.0, 0.0], [2.0, 2.0, 0.0], [0.0, 0.0, 1.0]]))
    assert np.allclose(B[:2], [[1, 1, 0], [0, 0, 1]])
    assert np.allclose(B[2:] @ B[:2].T, 0.0) and np.allclose(np.abs(B[2]), [2**-0.5, 2**-0.5, 0])
    assert np.array_equal(similarity_basis(np.zeros((1, 2))), np.eye(2))
    with pytest.raises(InputError, match="delta_T"):
        similarity_exponents(model, {"h": 1e-3, "p_inf": 5e3}, ["h", "delta_T"], SEC9_1)
