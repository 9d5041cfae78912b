"""Tunnel envelopes (Table 9.6) and design-variable bound sets (Tables 9.2, 9.7) as data."""
from __future__ import annotations

import pytest
from hypate.scaling.workflow.vocabulary.tunnels import (
    TunnelEnvelope,
    bound_set,
    bound_set_names,
    envelope_from_table,
    load_tunnels,
    resolve_tunnel,
    tunnel,
    tunnel_names,
)
from hypate.scaling.workflow.vocabulary.variables import DESIGN_VARIABLES
from hypate.solvers.errors import InputError

# Table 9.6 as printed (p0 in MPa, T0 in K); the data file stores Pa.
TABLE_9_6 = {
    "ideal": ((5.0, 7.0), None, (0.27579, 86.184466), (416.483, 2500.0)),
    "WT5": (None, (5.0,), (0.4860804, 2.82685), (1222.22, 1344.44)),
    "WT6": (None, (6.0,), (0.992845, 8.273709), (1647.22, 1838.89)),
    "WT7": (None, (7.0,), (2.96475, 8.273709), (2127.778, 2500.0)),
}


@pytest.mark.parametrize("name", list(TABLE_9_6))
def test_table_9_6_values(name):
    mach, values, p0_mpa, T0 = TABLE_9_6[name]
    env = tunnel(name)
    assert env.name == name
    assert env.mach == mach
    assert env.mach_values == (values or ())
    # 1e-12: only the MPa -> Pa conversion (a decimal shift) separates file and table.
    assert env.p0 == pytest.approx(tuple(v * 1e6 for v in p0_mpa), rel=1e-12)
    assert env.T0 == pytest.approx(T0, rel=1e-12)
    assert env.is_discrete == (values is not None)


@pytest.mark.parametrize("name", list(TABLE_9_6))
def test_envelope_round_trips_through_its_table(name):
    env = tunnel(name)
    again = envelope_from_table(env.to_table())
    assert again == env


def test_shipped_names_and_case_insensitive_lookup():
    assert tunnel_names() == ("ideal", "WT5", "WT6", "WT7")
    assert tunnel("wt7") is tunnel("WT7")


def test_unknown_tunnel_is_an_input_error_listing_known_names():
    with pytest.raises(InputError) as err:
        tunnel("WT9")
    assert err.value.field == "tunnel"
    assert "WT7" in err.value.message


def test_bounds_and_contains():
    ideal = tunnel("ideal")
    assert ideal.bounds() == {"M": (5.0, 7.0), "p0": ideal.p0, "T0": ideal.T0}
    wt6 = tunnel("WT6")
    assert set(wt6.bounds()) == {"p0", "T0"}  # discrete Mach: not a continuous variable
    assert wt6.mach_bounds == (6.0, 6.0)
    assert wt6.contains(6.0, 2e6, 1700.0)
    assert not wt6.contains(7.0, 2e6, 1700.0)
    assert not wt6.contains(6.0, 9e6, 1700.0)


def test_flow_from_a_setting_and_outside_setting_rejected():
    wt7 = tunnel("WT7")
    flow = wt7.flow(7.0, 5e6, 2200.0)
    assert flow.stagnation_pressure == pytest.approx(5e6, rel=1e-12)
    assert flow.stagnation_temperature == pytest.approx(2200.0, rel=1e-12)
    with pytest.raises(InputError) as err:
        wt7.flow(7.0, 1e6, 2200.0)
    assert err.value.field == "tunnels.WT7"


def test_table_9_7_and_9_2_bound_sets():
    assert set(bound_set_names()) == {"table9_7", "table9_2"}
    assert bound_set("table9_7") == {"L": (0.1, 0.5), "L_le": (0.1, 2.0), "h": (0.001, 0.01),
                                     "emissivity": (0.5, 1.0), "T_rad": (300.0, 2500.0)}
    b = bound_set("table9_2")
    assert b["h"] == pytest.approx((0.2e-3, 1.2e-3), rel=1e-12)
    assert b["p_inf"] == (3000.0, 11000.0)
    assert b["delta_T"] == (0.5, 4.5)
    for s in bound_set_names():
        assert set(bound_set(s)) <= set(DESIGN_VARIABLES)
    with pytest.raises(InputError) as err:
        bound_set("table9_9")
    assert err.value.field == "bounds"


GOOD = {"mach": [5.5, 6.5], "p0": [1.0e6, 8.0e6], "T0": [1600.0, 1900.0]}


def test_user_envelope_from_a_table():
    env = envelope_from_table({**GOOD, "name": "mine", "test_section": [1.0, 3.0]})
    assert env.name == "mine" and env.mach == (5.5, 6.5) and env.test_section == (1.0, 3.0)
    one = envelope_from_table({**GOOD, "mach": 6.0})
    assert one.mach_values == (6.0,) and one.is_discrete
    many = envelope_from_table({"mach_values": [7.0, 5.0], "p0": GOOD["p0"], "T0": GOOD["T0"]})
    assert many.mach_values == (5.0, 7.0)


@pytest.mark.parametrize("change, field", [
    ({"p0": [8.0e6, 1.0e6]}, "tunnel.p0"),                 # reversed
    ({"T0": [1900.0, 1600.0]}, "tunnel.T0"),               # reversed
    ({"mach": [7.0, 5.0]}, "tunnel.mach"),                 # reversed
    ({"test_section": [3.0, 1.0]}, "tunnel.test_section"),  # reversed
    ({"p0": [-1.0, 1.0e6]}, "tunnel.p0"),                  # non-positive
    ({"p0": [1.0e6]}, "tunnel.p0"),                        # not a pair
    ({"T0": ["hot", 1900.0]}, "tunnel.T0"),                # not a number
    ({"mach": [0.5, 2.0]}, "tunnel.mach"),                 # not supersonic
    ({"mach_values": [6.0]}, "tunnel.mach"),               # both mach and mach_values
    ({"pressure": 1.0}, "tunnel.pressure"),                # unknown key
])
def test_bad_user_envelopes_name_the_key(change, field):
    with pytest.raises(InputError) as err:
        envelope_from_table({**GOOD, **change})
    assert err.value.field == field


def test_missing_keys_are_named():
    with pytest.raises(InputError) as err:
        envelope_from_table({"mach": [5.0, 6.0], "p0": [1e6, 2e6]})
    assert err.value.field == "tunnel.T0"
    with pytest.raises(InputError) as err:
        envelope_from_table({"p0": [1e6, 2e6], "T0": [1e3, 2e3]}, field="study.tunnel")
    assert err.value.field == "study.tunnel.mach"


def test_dataclass_validates_too():
    with pytest.raises(InputError) as err:
        TunnelEnvelope(name="x", p0=(2e6, 1e6), T0=(1e3, 2e3), mach=(5.0, 6.0))
    assert err.value.field == "tunnels.x.p0"


def test_resolve_tunnel_forms(tmp_path):
    assert resolve_tunnel("WT5") is tunnel("WT5")
    assert resolve_tunnel({"name": "ideal"}) is tunnel("ideal")
    assert resolve_tunnel(GOOD).name == "user"
    with pytest.raises(InputError) as err:
        resolve_tunnel({"name": "nope"}, field="study.tunnel")
    assert err.value.field == "study.tunnel.name"
    path = tmp_path / "t.toml"
    path.write_text('[tunnels.A]\nmach = 6.0\np0 = [1e6, 2e6]\nT0 = [1500.0, 1800.0]\n'
                    '[tunnels.B]\nmach = [5.0, 6.0]\np0 = [3e6, 2e6]\nT0 = [1500.0, 1800.0]\n')
    with pytest.raises(InputError) as err:
        load_tunnels(path)
    assert err.value.field == "tunnels.B.p0"
