"""The page ``reproduction.html`` of a reproduction run (issue 21, ``hypate reproduce``).

One self-contained page (inline CSS, no script, no external reference; the run report's
style, :data:`hypate.scaling.report.html.PAGE_CSS`): a summary of every reproduction, the
accepted findings, then per chapter every table as *quantity | dissertation | hypate
(median) | min-max over seeds | difference | verdict | note*. The verdict is the row's
comparison against its stated tolerance (:func:`.comparison.compare`): ``yes (±5 %)``,
``NO (±5 %)``, ``NO: accepted finding`` (explained in the row's note), ``no comparison``
(a published number the run cannot resolve; the note says why), ``not measured`` (a
published value, no hypate value: e.g. a row not run with ``--quick``) or ``nothing
published`` (a hypate value the dissertation does not give).

The run is handed in duck-typed (``result.config``, ``.reproductions``, ``.planned``,
``.seconds``, ``.counts()``): this module does not import the runner, which imports it.
"""
from __future__ import annotations

import html
import math
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import pandas as pd
from hypate.scaling.report.html import PAGE_CSS
from hypate.scaling.report.numbers import format_number
from hypate.scaling.report.sections import html_table
from hypate.studies.scripts.comparison import summary

#: File name of the page (a public contract of ``hypate reproduce``).
PAGE_NAME = "reproduction.html"
#: Extra styles: accepted findings and rows without a verdict.
_EXTRA_CSS = """
tr.finding td{background:#fff4d6}tr.nocompare td{color:#666}
table.reproduction td:last-child{text-align:left;max-width:30em;font-size:.88em}
table.reproduction td:nth-child(6){white-space:nowrap}
table.summary td{text-align:right}table.summary td:nth-child(2){text-align:left}
"""
HEADER = ("quantity", "dissertation", "hypate (median)", "min-max over seeds",
          "difference (%)", "verdict", "note")


def _missing(v: Any) -> bool:
    return v is None or (isinstance(v, float) and math.isnan(v))


def _state(m: Any) -> bool | None:
    return None if _missing(m) else bool(m)


def verdict(row: pd.Series) -> str:
    """The verdict text of a table row (see the module docstring)."""
    state = _state(row.get("matches"))
    criterion = row.get("criterion") or ""
    if state is True:
        return f"yes ({criterion})" if criterion else "yes"
    if state is False:
        if row.get("finding"):
            return "NO: accepted finding"
        return f"NO ({criterion})" if criterion else "NO"
    published, measured = not _missing(row.get("dissertation")), not _missing(row.get("hypate"))
    if published and measured:
        return "no comparison"
    return "not measured" if published else "nothing published"


def row_class(row: pd.Series) -> str:
    """CSS class of a row: ``mismatch``, ``finding``, ``nocompare`` or none."""
    v = verdict(row)
    return {"NO: accepted finding": "finding", "no comparison": "nocompare"}.get(
        v, "mismatch" if v.startswith("NO") else "")


def _spread(row: pd.Series) -> str:
    lo, hi, n = row.get("hypate_min"), row.get("hypate_max"), row.get("seeds")
    if _missing(lo) or _missing(hi) or _missing(n) or int(n) < 2:
        return "-"
    return f"{format_number(lo)} to {format_number(hi)} ({int(n)} seeds)"


def _difference(v: Any) -> str:
    return f"{v:+.3g}" if isinstance(v, float) and math.isfinite(v) else "-"


def table_html(df: pd.DataFrame, numbers: dict[str, int] | None = None) -> str:
    """One reproduction's table (:data:`HEADER`), rows classed by their verdict.

    ``numbers`` maps an accepted finding's text to its number on the page: a row it
    explains (verdict ``NO: accepted finding``) shows the text, a row it concerns that
    matches anyway refers to it by number.
    """
    rows, classes = [], []
    for _, r in df.iterrows():
        note = r.get("note", "") or ""
        found = r.get("finding") or ""
        if found and verdict(r) != "NO: accepted finding":
            k = (numbers or {}).get(found)
            note = f"accepted finding {k} concerns this row (above)" if k else ""
        rows.append((r["quantity"], r["dissertation"], r["hypate"], _spread(r),
                     _difference(r["difference"]), verdict(r), note))
        classes.append(row_class(r))
    return html_table(HEADER, rows, row_classes=classes, css_class="reproduction")


def render(result: Any) -> str:
    """The page of a reproduction run (self-contained HTML5)."""
    cfg = result.config
    mode = "--quick (coarse variants)" if cfg.quick else "full"
    total = result.counts()
    stamp = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    state = ("all reproductions finished" if len(result.reproductions) == result.planned else
             f"partial: {len(result.reproductions)} of {result.planned} reproductions "
             "finished (the run was interrupted or is still running)")
    title = "hypate: reproduction of the dissertation"
    out = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
           '<meta name="viewport" content="width=device-width, initial-scale=1">',
           '<link rel="icon" href="data:,">',
           f"<title>{html.escape(title)}</title><style>{PAGE_CSS}{_EXTRA_CSS}</style>"
           "</head><body>", f"<h1>{html.escape(title)}</h1>",
           f"<p>Mode {html.escape(mode)}; optimizer "
           f"{'seed 0' if cfg.seeds == 1 else f'seeds 0 to {cfg.seeds - 1}'} "
           f"(Ch. 9 optimizations; the Ch. 7/8 scripts are deterministic and run once); "
           f"{html.escape(state)}; wall time {result.seconds / 60.0:.1f} min; generated "
           f"{stamp}.</p>",
           f"<p><strong>{total['match']} of {total['compared']} compared rows match</strong>"
           f" ({total['rows']} rows); {total['mismatch']} mismatch(es), of them "
           f"{total['accepted_findings']} accepted finding(s). Each verdict is the row's "
           "hypate value (the median over seeds) against the dissertation's, within the "
           "tolerance in brackets.</p>"]
    summary_rows = []
    for r in result.reproductions:
        c = r.counts()
        summary_rows.append((r.chapter, r.title, c["rows"], c["compared"], c["match"],
                             c["mismatch"], c["accepted_findings"], r.seeds,
                             f"{r.seconds:.0f}"))
    out.append("<h2>Summary</h2>" + html_table(
        ("chapter", "reproduction", "rows", "compared", "match", "NO", "accepted findings",
         "seeds", "seconds"), summary_rows, css_class="summary"))
    findings: dict[str, list[str]] = {}  # finding -> the reproductions with its rows
    for r in result.reproductions:
        if "finding" in r.table.columns:
            for f in r.table["finding"]:
                if f and r.title not in findings.setdefault(f, []):
                    findings[f].append(r.title)
    numbers = {f: k for k, f in enumerate(findings, start=1)}
    if findings:
        out.append("<h2>Accepted findings</h2><div class='notes'><ol>"
                   + "".join(f"<li>{html.escape(f)} <span class='note'>(rows in: "
                             f"{html.escape('; '.join(t))})</span></li>"
                             for f, t in findings.items())
                   + "</ol></div>")
    chapter = None
    for r in result.reproductions:
        if r.chapter != chapter:
            chapter = r.chapter
            out.append(f"<h2>{html.escape(chapter)}</h2>")
        warned = (f"; {len(r.warnings)} distinct solver warning(s) (in reproduction.json)"
                  if r.warnings else "")
        out.append(f'<section id="{html.escape(r.key)}"><h3>{html.escape(r.title)}</h3>'
                   f"{table_html(r.table, numbers)}<p class='note'>"
                   f"{html.escape(summary(r.table))}; {r.seconds:.0f} s{warned}</p></section>")
    out.append("<footer><p class='note'>Generated by hypate reproduce. Equations and tables "
               "refer to the dissertation (Ch. 7-9).</p></footer></body></html>")
    return "\n".join(out)


def write_page(result: Any, path: str | Path) -> Path:
    """Write :func:`render` to ``path`` atomically (a page is never half-written)."""
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(render(result), encoding="utf-8")
    tmp.replace(path)
    return path
