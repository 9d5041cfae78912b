"""The report's view of the categorical design variables (``[variables] material = [...]``,
``boundary = [...]``): the design table's row of each and how close each value came
(``design_point.json``'s block of the variable's name,
:func:`hypate.scaling.workflow.campaigns.outputs.best_by_level`)."""
from __future__ import annotations

import html
from typing import Any

from hypate.scaling.report.numbers import format_percent

__all__ = ["choice_row", "choices_note"]


def choice_row(point: dict[str, Any], name: str, classical: dict[str, Any] | None
               ) -> tuple[Any, ...]:
    """The design table's row of categorical ``name``: the chosen value's name, the listed
    values in the bounds' cells, the classical baseline's value."""
    chosen = point.get(name) or {}
    levels = chosen.get("levels") or []
    return (name, "-", str(chosen.get("name", "-")),
            "one of: " + ", ".join(map(str, levels)), "", "",
            str((classical or {}).get(name, "-")))


def choices_note(point: dict[str, Any], names: list[str]) -> str:
    """A sentence per categorical variable of ``names`` with each value's best max(J) and
    its evaluation ("" without one)."""
    out = ""
    for name in names:
        best = (point.get(name) or {}).get("best") or {}
        parts = [f"{html.escape(value)} {format_percent(max(b['objectives'].values()))} "
                 f"(evaluation {b['evaluation']})" if b
                 else f"{html.escape(value)}: no successful evaluation"
                 for value, b in best.items()]
        if parts:
            out += f"<p>Best max(J) per {html.escape(name)}: {'; '.join(parts)}.</p>"
    return out
