"""hypate.scaling.report.sections: the table helper and the built-in sections."""
from __future__ import annotations

import json
from collections.abc import Callable

import numpy as np
from hypate.scaling.report.rundata import RunData
from hypate.scaling.report.sections import BUILTIN_SECTIONS, Section, html_table


def test_html_table_formats_and_escapes() -> None:
    table = html_table(["a<b", "value"], [["x&y", 1234.5678], [True, np.nan], [3, None]],
                       row_classes=["mismatch", ""], css_class="t")
    assert table.startswith('<table class="t"><thead><tr><th>a&lt;b</th>')
    assert "<td>x&amp;y</td><td>1235</td>" in table  # 4 significant digits
    assert "<td>yes</td><td>&ndash;</td>" in table  # bool; NaN shown as a dash
    assert "<td>3</td><td>&ndash;</td>" in table  # int kept; None a dash
    assert table.count("<tr class=\"mismatch\">") == 1 and table.count("<tr>") == 3  # + header


def _sections(run: RunData) -> dict[str, Section]:
    built = [build(run) for build in BUILTIN_SECTIONS]
    return {s.title: s for s in built if s is not None}


def test_builtin_sections_of_a_run_without_study(fabricated_run: Callable[..., RunData]
                                                 ) -> None:
    """Every built-in section copes with a run that knows no study; page order kept."""
    sections = _sections(fabricated_run())
    assert list(sections) == ["Study", "Design point", "Similarity parameters", "Glossary",
                              "Figures", "Pareto set (3 designs)",
                              "Run statistics"]  # no sweep: no laws
    similarity = sections["Similarity parameters"].html
    assert "1 of 2 parameters differ by more than 10 %" in similarity
    assert similarity.count('<tr class="mismatch">') == 1
    statistics = sections["Run statistics"].html
    assert "Failures by reason" in statistics and "LSA diverged at step 3" in statistics
    assert "study file is unknown" in sections["Study"].html


def test_design_point_missing(fabricated_run: Callable[..., RunData]) -> None:
    run = fabricated_run()
    run.point = {"message": "every evaluation failed"}
    design = _sections(run)["Design point"].html
    assert "No design point: every evaluation failed." in design


def test_design_section_states_the_rule(fabricated_run: Callable[..., RunData]) -> None:
    """The rule is stated on every report, finished or rebuilt; the point's id is cited."""
    run = fabricated_run()
    run.point["evaluation"] = 2
    design = _sections(run)["Design point"].html
    assert "Selection rule." in design and "evaluation 2" in design
    assert "smallest max(J_u, J_T)" in design and 'design_point = "minmax"' in design
    run.point["rule"] = "knee"
    design = _sections(run)["Design point"].html
    assert "knee of the Pareto front" in design and 'design_point = "knee"' in design


def test_design_section_shows_the_leave_one_out_prediction(
        fabricated_run: Callable[..., RunData]) -> None:
    run = fabricated_run()
    design = _sections(run)["Design point"].html
    assert "<td>J_u</td><td>20 %</td><td>-</td>" in design  # no check recorded: a dash
    assert "How sure the search is" not in design
    run.point["surrogate"] = {"transform": "none", "objectives": {
        "J_u": {"observed": 0.2, "predicted": 0.25, "std": 0.04, "lower": 0.21,
                "upper": 0.29, "z": -1.25}}}
    design = _sections(run)["Design point"].html
    assert "<td>25 % (21 % &ndash; 29 %), <i>z</i> = -1.2</td>" in design
    assert "<td>J_T</td><td>20 %</td><td>-</td>" in design and "How sure the search is" in design


def test_pareto_table_marks_the_design_point(fabricated_run: Callable[..., RunData]) -> None:
    run = fabricated_run()
    run.point["evaluation"] = 2  # (0.2, 0.2): on the front
    table = _sections(run)["Pareto set (3 designs)"].html
    assert table.count('<tr class="design">') == 1
    row = table.split('<tr class="design">')[1].split("</tr>")[0]
    assert row.startswith("<td>2</td>") and "20 %" in row  # the id; J in percent
    assert "<th>J_u (%)</th>" in table


def test_similarity_far_from_one_is_a_ratio(fabricated_run: Callable[..., RunData]) -> None:
    run = fabricated_run()
    run.point["similarity"].append({"name": "Re_0", "prototype": 1.0e5, "model": 1.32e6,
                                    "relative_difference": 12.2})
    similarity = _sections(run)["Similarity parameters"].html
    assert "<td>x13.2</td>" in similarity and "1.22e+03 %" not in similarity
    assert "<td>50 %</td>" in similarity  # Bi: 2 -> 3, near 1: percent


def test_glossary_explains_every_parameter_of_the_table(
        fabricated_run: Callable[..., RunData]) -> None:
    run = fabricated_run()
    glossary = _sections(run)["Glossary"].html
    assert "<td>lambda_F</td><td>gamma p_inf M_inf L^3 / D_xx</td><td>Eq. (6.2a)</td>" \
        in glossary
    assert "flutter" in glossary  # lambda_F's meaning
    assert "<td>Bi</td>" in glossary  # unknown to PARAMETERS: listed with empty cells


def test_failure_ids_are_the_evaluation_ids(fabricated_run: Callable[..., RunData]) -> None:
    run = fabricated_run()  # evaluation 5 failed
    statistics = _sections(run)["Run statistics"].html
    assert "<td>failed</td><td>1</td><td>5</td>" in statistics


def test_warnings_section_lists_each_warning_with_its_evaluations(
        fabricated_run: Callable[..., RunData]) -> None:
    run = fabricated_run()
    assert "Warnings" not in _sections(run)  # none recorded: no section
    run.evaluations["warnings"] = [
        "", json.dumps(["RuntimeWarning: ti6242.conductivity: below <250 K (3 times)"]), "",
        json.dumps(["RuntimeWarning: ti6242.conductivity: below <250 K (2 times)",
                    "UserWarning: other (1 time)"]), "", float("nan")]
    run.prototype_warnings = ["UserWarning: other (4 times)"]
    body = _sections(run)["Warnings"].html
    assert ("<td>UserWarning: other</td><td>prototype, evaluation 3</td><td>5</td>"
            in body)
    assert ("<td>RuntimeWarning: ti6242.conductivity: below &lt;250 K</td>"
            "<td>evaluations 1, 3</td><td>5</td>") in body
    assert list(_sections(run))[-1] == "Warnings"  # after the run statistics
