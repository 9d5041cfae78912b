"""The report's view of a categorical model material (``[variables] material = [...]``):
the design table's row and how close each material came (``design_point.json``'s
``material`` block, :func:`hypate.scaling.workflow.campaigns.outputs.best_by_material`)."""
from __future__ import annotations

import html
from typing import Any

from hypate.scaling.report.numbers import format_percent

__all__ = ["material_row", "materials_note"]


def material_row(point: dict[str, Any], classical: dict[str, Any] | None) -> tuple[Any, ...]:
    """The design table's row of a categorical material: its name, the listed values in
    the bounds' cells, the classical baseline's material."""
    chosen = point.get("material") or {}
    levels = chosen.get("levels") or []
    return ("material", "-", str(chosen.get("name", "-")),
            "one of: " + ", ".join(map(str, levels)), "", "",
            str((classical or {}).get("material", "-")))


def materials_note(point: dict[str, Any]) -> str:
    """A sentence with each material's best max(J) and its evaluation ("" without a
    categorical material)."""
    best = (point.get("material") or {}).get("best") or {}
    parts = [f"{html.escape(name)} {format_percent(max(b['objectives'].values()))} "
             f"(evaluation {b['evaluation']})" if b
             else f"{html.escape(name)}: no successful evaluation" for name, b in best.items()]
    return f"<p>Best max(J) per material: {'; '.join(parts)}.</p>" if parts else ""
