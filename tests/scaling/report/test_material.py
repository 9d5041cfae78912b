"""The report's categorical-material pieces (scaling/report/material.py)."""
from __future__ import annotations

from hypate.scaling.report.material import material_row, materials_note

POINT = {"material": {"name": "inconel718", "level": 1,
                      "levels": ["ti6242", "inconel718", "al7075"],
                      "best": {"ti6242": {"evaluation": 7, "objectives": {"J_u": 0.0804,
                                                                         "J_T": 0.0603}},
                               "inconel718": {"evaluation": 40, "objectives": {
                                   "J_u": 0.0737, "J_T": 0.0801}},
                               "al7075": None}}}


def test_material_row_names_the_choice_the_levels_and_the_classical_material() -> None:
    row = material_row(POINT, {"material": "ti6242"})
    assert row == ("material", "-", "inconel718", "one of: ti6242, inconel718, al7075", "",
                   "", "ti6242")
    assert material_row({}, None)[2] == "-"


def test_materials_note_gives_each_materials_larger_objective() -> None:
    note = materials_note(POINT)
    assert "ti6242 8.04 % (evaluation 7)" in note  # max(8.04, 6.03)
    assert "inconel718 8.01 % (evaluation 40)" in note
    assert "al7075: no successful evaluation" in note
    assert materials_note({"design": {}}) == ""
