"""Side-by-side comparison tables for the reproduction scripts (issue 9).

Every script in ``studies/`` reports its numbers as rows of
``quantity | dissertation | hypate | difference`` where ``difference`` is the relative
difference ``(hypate - dissertation) / |dissertation|`` in percent (NaN where the
dissertation value is missing, zero or not numeric).
"""
from __future__ import annotations

import argparse
import math
from collections.abc import Iterable, Sequence
from pathlib import Path

import pandas as pd

COLUMNS = ("quantity", "dissertation", "hypate", "difference")


def relative_difference_percent(dissertation: float | None, hypate: float | None) -> float:
    """``100 (hypate - dissertation) / |dissertation|``; NaN if undefined."""
    try:
        d, h = float(dissertation), float(hypate)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return math.nan
    if not (math.isfinite(d) and math.isfinite(h)) or d == 0.0:
        return math.nan
    return 100.0 * (h - d) / abs(d)


def side_by_side(rows: Iterable[Sequence[object]]) -> pd.DataFrame:
    """Build the comparison table.

    Parameters
    ----------
    rows : iterable of (quantity, dissertation, hypate) or (quantity, dissertation, hypate, note)
        ``dissertation`` and ``hypate`` may be numbers, ``None`` or short strings (e.g. a
        trend statement "delayed" / "yes").

    Returns
    -------
    pandas.DataFrame
        Columns ``quantity | dissertation | hypate | difference`` (relative, %), plus
        ``note`` when any row carries one.
    """
    records = []
    notes = False
    for row in rows:
        q, d, h = row[0], row[1], row[2]
        note = str(row[3]) if len(row) > 3 and row[3] is not None else ""
        notes = notes or bool(note)
        records.append({"quantity": str(q), "dissertation": d, "hypate": h,
                        "difference": relative_difference_percent(d, h), "note": note})
    df = pd.DataFrame.from_records(records, columns=[*COLUMNS, "note"])
    return df if notes else df.drop(columns="note")


def _fmt(v: object) -> str:
    if v is None:
        return "-"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, (int, float)):
        f = float(v)
        if math.isnan(f):
            return "-"
        return f"{f:.5g}"
    return str(v)


def to_markdown(df: pd.DataFrame) -> str:
    """GitHub-flavoured Markdown of the table (no ``tabulate`` dependency)."""
    cols = list(df.columns)
    head = ["difference (%)" if c == "difference" else c for c in cols]
    lines = ["| " + " | ".join(head) + " |", "|" + "|".join("---" for _ in cols) + "|"]
    for _, r in df.iterrows():
        cells = []
        for c in cols:
            v = r[c]
            cells.append((f"{v:+.3f}" if isinstance(v, float) and math.isfinite(v) else "-")
                         if c == "difference" else _fmt(v))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def write_table(df: pd.DataFrame, out: str | Path | None, name: str,
                title: str | None = None) -> list[Path]:
    """Write ``NAME.csv`` and ``NAME.md`` into directory ``out`` (created); nothing if None."""
    if out is None:
        return []
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    csv, md = out / f"{name}.csv", out / f"{name}.md"
    df.to_csv(csv, index=False)
    text = (f"# {title}\n\n" if title else "") + to_markdown(df)
    md.write_text(text, encoding="utf-8")
    return [csv, md]


def show(df: pd.DataFrame, title: str | None = None) -> None:
    """Print the table as Markdown (for ``main()`` only)."""
    if title:
        print(f"\n## {title}\n")
    print(to_markdown(df))


def standard_parser(description: str):
    """``argparse`` parser with the common ``--coarse`` and ``--out DIR`` options."""

    p = argparse.ArgumentParser(description=description)
    p.add_argument("--coarse", action="store_true", help="the coarse (test) configuration")
    p.add_argument("--out", default=None, help="directory for NAME.csv / NAME.md")
    return p


def publish(df: pd.DataFrame, out: str | Path | None, name: str, title: str) -> list[Path]:
    """Print the table (:func:`show`) and write it into ``out`` (:func:`write_table`)."""
    show(df, title)
    return write_table(df, out, name, title)


def simple_main(doc: str, run, config, name: str, title: str,
                argv: list[str] | None = None) -> None:
    """``main()`` of a script with only ``--coarse`` / ``--out``: run ``config()`` (or
    ``config.coarse()``) and publish ``run(...).table`` as ``name``."""
    args = standard_parser(doc.splitlines()[0]).parse_args(argv)
    res = run(config.coarse() if args.coarse else config())
    publish(res.table, args.out, name, title)

