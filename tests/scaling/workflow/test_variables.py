"""One home per design variable (issue 42): a row of scaling.workflow.vocabulary.variables says how the
variable is set into a configuration and read back from one, and its scaling law."""
from __future__ import annotations

import pytest
from conftest import PROTOTYPE_CASE
from hypate.scaling.workflow.vocabulary.configuration import (
    Configuration,
    apply_design,
    nominal_values,
)
from hypate.scaling.workflow.campaigns.laws import ANALYTICAL_EXPONENTS
from hypate.scaling.workflow.vocabulary.variables import DESIGN_VARIABLES, OPTIMIZABLE
from hypate.solvers.config import load_case
from hypate.solvers.errors import InputError

#: One value of every optimizable continuous variable, inside its hard limits and away from
#: the template's own value.
VALUES = {"M": 6.3, "p0": 4.1e6, "T0": 1234.0, "p_inf": 2345.0, "T_inf": 231.0, "L": 0.31,
          "L_le": 0.47, "h": 0.0031, "emissivity": 0.61, "T_rad": 987.0, "p_ext": -1500.0,
          "q_ext": 4.5e4, "delta_T": 55.0}


def _template() -> Configuration:
    case = load_case(PROTOTYPE_CASE)
    return Configuration(panel=case.panel, flow=case.flow)


def test_every_optimizable_row_has_a_value_here():
    assert set(VALUES) == {n for n in OPTIMIZABLE if DESIGN_VARIABLES[n].target
                           and DESIGN_VARIABLES[n].kind == "continuous"}


@pytest.mark.parametrize("name", sorted(VALUES))
def test_a_row_sets_what_it_reads_back(name):
    # apply_design sets each row's value through its target; nominal_values reads the
    # same target back: the value comes back (to rounding: a thickness is the layers' sum)
    template = _template()
    assert nominal_values(template).get(name) != pytest.approx(VALUES[name], rel=1e-9)
    config = apply_design(template, {name: VALUES[name]})
    assert nominal_values(config)[name] == pytest.approx(VALUES[name], rel=1e-12)


def test_rows_check_their_values_naming_the_variable():
    template = _template()
    for name, bad in (("emissivity", 1.5), ("T_rad", -3.0), ("delta_T", 0.0), ("h", -1e-3)):
        with pytest.raises(InputError) as err:
            apply_design(template, {name: bad})
        assert err.value.field == f"design.{name}"
    with pytest.raises(InputError, match="cannot mix"):
        apply_design(template, {"p0": 1e6, "p_inf": 1e3})


def test_the_laws_exponents_are_the_rows():
    # Sec. 6.1.3 / Eq. 9.2: lengths and the thickness ~ xi^-1, intensive settings xi^0
    assert ANALYTICAL_EXPONENTS == {n: v.exponent for n, v in DESIGN_VARIABLES.items()
                                    if v.exponent is not None}
    assert {n for n, k in ANALYTICAL_EXPONENTS.items() if k == -1.0} == {"L", "L_le", "h"}
    assert set(ANALYTICAL_EXPONENTS) == set(VALUES) - {"q_ext"}


def test_the_first_bad_value_is_reported_as_before_the_rows():
    # the parts check their values as they are composed, in the former if-chain's order:
    # panel (scaled sizes, layer thicknesses, then the rest), flow, temperatures, loads
    template = _template()
    for design, field in (({"h": -1.0, "T_rad": -5.0}, "design.h"),
                          ({"h[0]": -1.0, "emissivity": 2.0}, "design.h[0]"),
                          ({"p0": 1e5, "p_inf": 1e3, "delta_T": -1.0}, "design.p_inf")):
        with pytest.raises(InputError) as err:
            apply_design(template, design)
        assert err.value.field == field, design
    # a size given as None is not set (as scaled_panel takes it)
    assert apply_design(template, {"L": None, "h": None}) == apply_design(template, {})
