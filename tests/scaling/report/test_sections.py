"""hypate.scaling.report.sections: the table helper and the built-in sections."""
from __future__ import annotations

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
    assert list(sections) == ["Study", "Design point", "Similarity parameters", "Figures",
                              "Pareto set (3 designs)", "Run statistics"]  # no sweep: no laws
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
