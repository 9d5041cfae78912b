"""The building blocks of a report section: :class:`Section` and the small HTML helpers every
builder uses (:func:`html_table`, :func:`dl`, numbers through :mod:`.numbers`)."""
from __future__ import annotations

import html
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from hypate.scaling.report.numbers import (
    format_number,
    format_percent,
)


@dataclass(frozen=True)
class Section:
    """One report section: a title and its HTML body (inserted verbatim)."""

    title: str
    html: str


# -- small HTML helpers ---------------------------------------------------------------------
def fmt(value: Any, digits: int = 4) -> str:
    """Numbers to short text (:func:`.numbers.format_number`), other values escaped."""
    if value is None or isinstance(value, (bool, int, float, np.bool_, np.number)):
        return format_number(value, digits)
    return html.escape(str(value))


def pct(value: Any) -> str:
    """J or a relative difference in percent (:func:`.numbers.format_percent`)."""
    return format_percent(value)


def html_table(header: Sequence[str], rows: Iterable[Sequence[Any]],
               row_classes: Sequence[str] | None = None, css_class: str = "") -> str:
    """An HTML table; header cells are escaped, numbers formatted to 4 significant digits.

    Parameters
    ----------
    header : sequence of str
    rows : iterable of sequences
        Cell values: numbers are formatted; strings are escaped, except instances of
        :class:`Raw` (HTML kept verbatim).
    row_classes : sequence of str, optional
        A CSS class per row (``""`` for none), e.g. ``"mismatch"``.
    css_class : str
        CSS class of the table.
    """
    out = [f'<table class="{html.escape(css_class)}"><thead><tr>']
    out += [f"<th>{html.escape(str(h))}</th>" for h in header]
    out.append("</tr></thead><tbody>")
    for i, row in enumerate(rows):
        cls = row_classes[i] if row_classes is not None and i < len(row_classes) else ""
        out.append(f'<tr class="{cls}">' if cls else "<tr>")
        for cell in row:
            text = str(cell) if isinstance(cell, Raw) else fmt(cell)
            out.append(f"<td>{text}</td>")
        out.append("</tr>")
    out.append("</tbody></table>")
    return "".join(out)


class Raw(str):
    """A string inserted into :func:`html_table` without escaping."""



def dl(items: Sequence[tuple[str, str]]) -> str:
    return "<dl>" + "".join(f"<dt>{html.escape(k)}</dt><dd>{v}</dd>" for k, v in items) + "</dl>"
