"""hypate.scaling.report.numbers: the one number formatter of the report."""
from __future__ import annotations

import numpy as np
from hypate.scaling.report.numbers import (
    DASH,
    format_difference,
    format_number,
    format_percent,
    format_ratio,
)


def test_percent_and_plain_numbers() -> None:
    assert format_percent(0.08844) == "8.84 %"
    assert format_percent(None) == DASH and format_percent(np.nan) == DASH
    assert format_number(1234.5678) == "1235" and format_number(3) == "3"
    assert format_number(True) == "yes" and format_number(np.inf) == DASH


def test_difference_is_a_ratio_far_from_one() -> None:
    assert format_difference(12.2, 1.0e5, 1.32e6) == "x13.2"  # not "1.22e+03 %"
    assert format_difference(0.69, 1.0, 0.31) == "x0.31"
    assert format_difference(0.05, 1.0, 1.05) == "5 %"
    assert format_difference(0.5, 2.0, 3.0) == "50 %"
    assert format_difference(0.5) == "50 %"  # without the values: percent
    assert format_difference(np.inf, 0.0, 1.0) == DASH  # zero prototype: no ratio
    assert format_ratio(13.24) == "x13.2"
