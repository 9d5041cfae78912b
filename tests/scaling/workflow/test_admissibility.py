"""Admissibility of scaled models: material limits, what a model goes through, the checks
and their switching (scaling.workflow.vocabulary.admissibility,
campaigns.verdict; issue 40)."""
from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest
from hypate.scaling.workflow.vocabulary.admissibility import (
    AdmissibilitySection,
    admissible,
    violation,
)
from hypate.scaling.workflow.vocabulary.problem import ScalingProblem
from hypate.scaling.workflow.vocabulary.study import load_study, parse_study
from hypate.scaling.workflow.vocabulary.tunnels import tunnel
from hypate.scaling.workflow.campaigns.verdict import verdict_fields
from hypate.scaling.workflow.analyses.whatif import evaluate_whatif
from hypate.solvers.config import read_toml
from hypate.solvers.errors import InputError
from hypate.solvers.materials import OutsideDataError, library_material

#: An admissible Inconel 718 design of the shipped quick-start problem (found by hand,
#: issue 40): max wall temperature about 932 K against the 977.6 K service limit.
HAND_DESIGN = {"M": 5.457, "p0": 41.64e6, "T0": 1400.0, "L_le": 0.349, "h": 0.00371}


def _study(**admissibility: object):
    """The shipped quick-start with its [admissibility] table replaced."""
    data = read_toml(load_study("quickstart").path)
    data["admissibility"] = dict(admissibility)
    return parse_study(data, load_study("quickstart").path)


def _rows(study, design=HAND_DESIGN):
    res = evaluate_whatif(study, design)
    return res, {r["check"]: r for r in res["admissibility"] if r["check"] != "envelope"}


# -- material limits -------------------------------------------------------------------------
def test_library_materials_state_their_limits_with_sources() -> None:
    for name, service in (("inconel718", 977.6), ("ti6242", 810.9), ("al7075", 394.3)):
        m = library_material(name)
        assert m.limits.service_temperature == service
        assert m.limits.sources
        lo, hi = m.data_range
        assert lo == 250.0 and hi > service  # every table covers the service range
        assert m.limits.yield_strength.range[1] == hi  # the yield table spans the data
        assert np.all(np.diff(m.limits.yield_strength.values) <= 0)  # weaker when hotter


def test_property_query_outside_its_table_raises_the_inadmissibility() -> None:
    k = library_material("ti6242").k1
    assert k.checked(np.array([300.0, 900.0])) == pytest.approx(k([300.0, 900.0]))
    with pytest.raises(OutsideDataError, match="inadmissible") as info:
        k.checked(np.array([400.0, 1475.0]))
    assert info.value.temperatures == (400.0, 1475.0) and info.value.table == (250.0, 950.0)
    # the silent solver query still clamps (the run goes on; the design is flagged)
    assert float(k(1475.0)) == float(k(950.0))


def test_a_trusted_range_extends_the_admissible_temperatures() -> None:
    ti = library_material("ti6242")
    trusted = dataclasses.replace(ti, limits=dataclasses.replace(
        ti.limits, trusted_range=(250.0, 1100.0)))
    assert ti.valid_range == (250.0, 950.0) and trusted.valid_range == (250.0, 1100.0)


# -- the checks ------------------------------------------------------------------------------
def test_tunnel_core_length_and_run_time_closed_forms() -> None:
    t = tunnel("WT6")
    # test rhombus: (D - w) / (2 tan(asin(1/M))) = (1.07 - 0.25) / (2 / sqrt(35))
    assert t.core_length(6.0, 0.25) == pytest.approx(0.82 * math.sqrt(35.0) / 2.0)
    assert t.core_length(1.2, 0.25) == pytest.approx(0.82 / (2 * math.tan(math.asin(1 / 1.2))))
    # the smallest mass flow (lowest p0, highest T0) runs longest; a 2x flow half as long
    assert t.run_time_at(6.0, t.p0[0], t.T0[1]) == pytest.approx(294.0)
    assert t.run_time_at(6.0, 2 * t.p0[0], t.T0[1]) == pytest.approx(147.0)
    assert t.run_time_at(6.0, t.p0[1], t.T0[0]) == pytest.approx(42.0)  # the floor


def test_the_hand_found_inconel_design_is_admissible_with_its_margins() -> None:
    res, rows = _rows(_study())
    assert res["status"] == "ok" and res["admissible"] is True
    assert rows["temperature"]["limit"] == 977.6
    model = res["responses"]["model"]
    assert rows["temperature"]["value"] == pytest.approx(model["max_wall_temperature"])
    assert 0.0 < rows["temperature"]["margin"] < 60.0  # about 46 K on the coarse mesh
    assert rows["stress"]["mode"] == "report" and rows["stress"]["ok"] is False
    assert res["prototype_yields"] is True  # the Sec. 9.2 prototype itself yields
    assert max(res["objectives"]["J_u"], res["objectives"]["J_T"]) < 0.09


@pytest.mark.parametrize("check, relaxed, enforced, design", [
    # 46 K of margin: a 60 K study margin makes the design inadmissible
    ("temperature", {}, {"temperature": {"margin": 60.0}}, HAND_DESIGN),
    # the data range of Inconel ends at 1227.6 K: a 300 K margin moves it below 932 K
    ("data", {}, {"data": {"margin": 300.0}}, HAND_DESIGN),
    # the prototype yields, so stress only reports by default; enforced, it fails
    ("stress", {}, {"stress": "constraint"}, HAND_DESIGN),
    # a 1.9 m leading edge at M 5: a 2.15 m plate in a 2.0 m core
    ("size", {"size": "report"}, {}, {**HAND_DESIGN, "M": 5.0, "L_le": 1.9}),
    # a 40 s injection does not fit the 42 s run with an 11 s test
    ("duration", {}, {"duration": {"injection_time": 40.0}}, HAND_DESIGN),
])
def test_each_check_switches_a_known_design(check, relaxed, enforced, design) -> None:
    base, _ = _rows(_study(**relaxed), design)
    assert base["admissible"] is True
    res, rows = _rows(_study(**enforced), design)
    assert rows[check]["ok"] is False and rows[check]["mode"] == "constraint"
    assert res["admissible"] is False
    assert violation(res["admissibility"]) > 0.0 and not admissible(res["admissibility"])


def test_off_and_report_modes() -> None:
    res, rows = _rows(_study(temperature={"mode": "report", "margin": 60.0}))
    assert rows["temperature"]["ok"] is False and res["admissible"] is True
    res, rows = _rows(_study(temperature="off"))
    assert "temperature" not in rows


def test_titanium_at_the_dissertations_point_is_600_k_past_its_service_limit() -> None:
    """Table 9.8's xi = 4 point on the coarse problem, Ti 6242: far beyond its service
    temperature and its property data (about -600 K of margin on the full problem)."""
    res, rows = _rows(_study(), {"material": "ti6242", "M": 5.407, "p0": 3.858e7,
                                 "T0": 2130.0, "L_le": 0.3516, "h": 0.004317})
    assert res["admissible"] is False
    assert rows["temperature"]["margin"] < -400.0 and rows["data"]["ok"] is False


def test_admissibility_section_errors() -> None:
    with pytest.raises(ValueError, match="auto"):
        AdmissibilitySection(temperature="auto").rules()
    with pytest.raises(InputError, match="admissibility.temperature"):
        _study(temperature="sometimes")
    with pytest.raises(InputError, match="admissibility.size.margin"):
        _study(size={"margin": -1.0})


def test_the_stress_checks_auto_follows_the_prototype() -> None:
    study = load_study("quickstart")
    problem = ScalingProblem(study.spec)
    assert problem.admissibility.mode("stress") == "report"  # the prototype yields
    assert problem.n_ieq_constr == 2 and problem.constraint_names == ("temperature", "data")
    ext = problem.prototype_response.extremes()
    assert ext["max_stress_ratio"] > 1.0


def test_verdict_fields_are_the_public_json_contract() -> None:
    study = load_study("quickstart")
    problem = ScalingProblem(study.spec)
    x = np.array([HAND_DESIGN[n] for n in study.spec.names])
    _, _, aux = problem.outputs(problem.model_configuration(x))
    fields = verdict_fields(problem, x, aux["extremes"])
    for row in fields["admissibility"]:
        assert {"check", "value", "limit", "margin", "unit", "binding", "ok"} <= set(row)
    for who in ("model", "prototype"):
        rec = fields["responses"][who]
        for key in ("max_wall_temperature", "mean_temperature", "max_deflection_ratio",
                    "max_von_mises"):
            assert isinstance(rec[key], float) and rec[key] > 0.0


def test_a_run_states_its_design_points_limits_and_failures(tiny_study, tmp_path,
                                                            capsys) -> None:
    """`hypate run`'s last lines: the design point's admissibility and binding limits, the
    prototype's own stress once, the failed evaluations before and after the initial
    design; no warning lines; the report's admissibility section; no absolute path in the
    page (issue 40)."""
    from hypate.scaling.cli.main import main

    out = tmp_path / "run"
    study = tiny_study(sections='[admissibility]\ntemperature = { margin = 5.0 }\n')
    assert main(["run", str(study), "--out", str(out)]) == 0
    cap = capsys.readouterr()
    assert "Warning" not in cap.out + cap.err
    lines = cap.out.splitlines()
    assert any(ln.strip().startswith(("admissible; binding limits:",
                                      "NOT admissible; binding limits:")) for ln in lines)
    assert sum("the prototype's own elastic stress" in ln for ln in lines) == 1
    point = json.loads((out / "design_point.json").read_text())
    stats = point["statistics"]
    assert lines[-2] == (f"failed evaluations: {stats['failed']} of {stats['evaluations']}"
                         + (f" ({stats['failed_iterations']} of the "
                            f"{stats['iteration_evaluations']} after the initial design)"
                            if stats["iteration_evaluations"] else "")
                         + f"; admissible: {stats['admissible']}")
    temp = next(r for r in point["admissibility"] if r["check"] == "temperature")
    assert temp["limit"] == pytest.approx(810.9 - 5.0)  # the tiny study's Ti 6242, margin 5 K
    page = (out / "report.html").read_text()
    assert "<h2>Admissibility</h2>" in page and "What the model and the prototype go through" \
        in page and "Definitions." in page
    assert str(tmp_path) not in page and "/root" not in page
