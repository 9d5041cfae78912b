"""hypate.scaling.report.glossary: every similarity parameter has its sentence."""
from __future__ import annotations

from hypate.scaling.report.glossary import MEANINGS, glossary_rows
from hypate.scaling.workflow.vocabulary.similarity import PARAMETERS


def test_every_parameter_has_a_meaning() -> None:
    assert set(MEANINGS) == set(PARAMETERS)
    assert all(text.endswith(".") and len(text) > 20 for text in MEANINGS.values())


def test_rows_carry_formula_and_equation() -> None:
    (row,) = glossary_rows(["Fo"])
    assert row[:3] == ("Fo", PARAMETERS["Fo"].formula, f"Eq. ({PARAMETERS['Fo'].equation})")
    assert glossary_rows(["unknown"]) == [("unknown", "", "", "")]
