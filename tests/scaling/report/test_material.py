"""The report's categorical pieces (scaling/report/material.py): the material and any other
categorical variable (the model's edge support) alike."""
from __future__ import annotations

from hypate.scaling.report.material import choice_row, choices_note

POINT = {"material": {"name": "inconel718", "level": 1,
                      "levels": ["ti6242", "inconel718", "al7075"],
                      "best": {"ti6242": {"evaluation": 7, "objectives": {"J_u": 0.0804,
                                                                         "J_T": 0.0603}},
                               "inconel718": {"evaluation": 40, "objectives": {
                                   "J_u": 0.0737, "J_T": 0.0801}},
                               "al7075": None}},
         "boundary": {"name": "clamped", "level": 1, "levels": ["simply_supported", "clamped"],
                      "best": {"simply_supported": {"evaluation": 3, "objectives": {
                          "J_u": 0.12, "J_T": 0.05}}, "clamped": None}}}


def test_choice_row_names_the_choice_the_levels_and_the_classical_value() -> None:
    row = choice_row(POINT, "material", {"material": "ti6242"})
    assert row == ("material", "-", "inconel718", "one of: ti6242, inconel718, al7075", "",
                   "", "ti6242")
    assert choice_row({}, "material", None)[2] == "-"
    row = choice_row(POINT, "boundary", {"boundary": "simply_supported"})
    assert row == ("boundary", "-", "clamped", "one of: simply_supported, clamped", "", "",
                   "simply_supported")


def test_choices_note_gives_each_values_larger_objective() -> None:
    note = choices_note(POINT, ["material", "boundary"])
    assert "Best max(J) per material: ti6242 8.04 % (evaluation 7)" in note  # max(8.04, 6.03)
    assert "inconel718 8.01 % (evaluation 40)" in note
    assert "al7075: no successful evaluation" in note
    assert "Best max(J) per boundary: simply_supported 12 % (evaluation 3)" in note
    assert choices_note({"design": {}}, []) == ""
    assert "boundary" not in choices_note(POINT, ["material"])
