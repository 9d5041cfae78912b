"""Side-by-side comparison tables for the reproduction scripts (issue 9).

Every script in ``studies/`` reports its numbers as rows of
``quantity | dissertation | hypate | difference | matches`` where ``difference`` is the
relative difference ``(hypate - dissertation) / |dissertation|`` in percent (NaN where the
dissertation value is missing, zero or not numeric) and ``matches`` says whether the two
agree by the row's criterion (:func:`compare`): ``yes``, ``NO`` (a mismatch, counted in the
footer :func:`summary`) or ``-`` (nothing to compare: no published value, or nothing
measured).

A published value is a number (matches within the table's relative tolerance), an
:class:`Approx` (a number with its own tolerance), a :class:`Bound` (an inequality such as
"> 35 %"), a bool or ``"yes"``/``"no"`` (a trend statement), or a word that must be equal
(``"flutter"``). ``None`` on the hypate side means "not measured" (not a mismatch); a
script that measured the absence of an event says so in words (``"stable"``), which then
differs from a published number.
"""
from __future__ import annotations

import argparse
import math
import operator
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

COLUMNS = ("quantity", "dissertation", "hypate", "difference", "matches", "criterion")
#: Default relative tolerance of a published number without its own (:class:`Approx`).
RTOL = 0.05
_OPS = {"<": operator.lt, "<=": operator.le, ">": operator.gt, ">=": operator.ge}


@dataclass(frozen=True)
class Approx:
    """A published number that matches within ``max(rel |value|, abs)``.

    Parameters
    ----------
    value : float
        The dissertation's number.
    rel : float
        Relative tolerance (fraction).
    abs : float
        Absolute tolerance (the unit of ``value``); needed where ``value`` is 0.
    """

    value: float
    rel: float = 0.0
    abs: float = 0.0

    def holds(self, x: float) -> bool:
        return abs(x - self.value) <= max(self.rel * abs(self.value), self.abs)

    def criterion(self) -> str:
        if self.rel * abs(self.value) >= self.abs:
            return f"±{100.0 * self.rel:g} %"
        return f"±{self.abs:g}"


@dataclass(frozen=True)
class Bound:
    """A published inequality: hypate matches when ``hypate OP value``.

    Parameters
    ----------
    op : {"<", "<=", ">", ">="}
    value : float
    text : str, optional
        How the dissertation says it (shown in its column; default ``"OP value"``).
    """

    op: str
    value: float
    text: str | None = None

    def __post_init__(self) -> None:
        if self.op not in _OPS:
            raise ValueError(f"Bound op must be one of {sorted(_OPS)}; got {self.op!r}")

    def holds(self, x: float) -> bool:
        return bool(_OPS[self.op](x, self.value))

    def criterion(self) -> str:
        return f"{self.op} {self.value:g}"

    def __str__(self) -> str:
        return self.text or f"{self.op} {self.value:g}"


def _number(v: object) -> float | None:
    """``v`` as a finite-or-NaN float when it is a number (not a bool), else None."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return None
    return float(v)


def _truth(v: object) -> bool | None:
    """A bool, or ``"yes"``/``"no"`` as one; None otherwise."""
    if isinstance(v, bool):
        return v
    if isinstance(v, str) and v.strip().lower() in ("yes", "no"):
        return v.strip().lower() == "yes"
    return None


def _missing(v: object) -> bool:
    n = _number(v)
    return v is None or (n is not None and math.isnan(n))


def compare(dissertation: object, hypate: object, rtol: float = RTOL
            ) -> tuple[bool | None, str]:
    """Whether ``hypate`` matches the published ``dissertation`` value, and by what rule.

    Returns
    -------
    matches : bool or None
        None when there is nothing to compare (no published value, or ``hypate`` is None:
        not measured).
    criterion : str
        The rule applied (``"±5 %"``, ``"> 35"``, ``"same"``), empty when not compared.
    """
    if _missing(dissertation) or _missing(hypate):
        return None, ""
    h = _number(hypate)
    if isinstance(dissertation, (Approx, Bound)):
        return (h is not None and dissertation.holds(h)), dissertation.criterion()
    d = _number(dissertation)
    if d is not None:
        if h is None:  # a word where a number was published (e.g. "stable" vs an onset)
            return False, f"±{100.0 * rtol:g} %"
        return Approx(d, rel=rtol).holds(h), f"±{100.0 * rtol:g} %"
    t = _truth(dissertation)
    if t is not None:
        return _truth(hypate) is t, "same"
    return str(dissertation).strip().lower() == str(hypate).strip().lower(), "same"


def relative_difference_percent(dissertation: object, hypate: object) -> float:
    """``100 (hypate - dissertation) / |dissertation|``; NaN if undefined."""
    if isinstance(dissertation, Approx):
        dissertation = dissertation.value
    d, h = _number(dissertation), _number(hypate)
    if d is None or h is None or not (math.isfinite(d) and math.isfinite(h)) or d == 0.0:
        return math.nan
    return 100.0 * (h - d) / abs(d)


def side_by_side(rows: Iterable[Sequence[object]], rtol: float = RTOL) -> pd.DataFrame:
    """Build the comparison table.

    Parameters
    ----------
    rows : iterable of (quantity, dissertation, hypate) or (quantity, dissertation, hypate, note)
        ``dissertation`` may be a number, :class:`Approx`, :class:`Bound`, bool, ``None`` or
        a short string ("yes", "flutter"); ``hypate`` a number, bool, string or ``None``
        (not measured).
    rtol : float
        Relative tolerance of the published plain numbers (an :class:`Approx` carries its
        own).

    Returns
    -------
    pandas.DataFrame
        Columns ``quantity | dissertation | hypate | difference`` (relative, %) ``| matches
        | criterion`` (:func:`compare`), plus ``note`` when any row carries one. The
        dissertation column holds plain values (an :class:`Approx` its number, a
        :class:`Bound` its text).
    """
    records = []
    notes = False
    for row in rows:
        q, d, h = row[0], row[1], row[2]
        note = str(row[3]) if len(row) > 3 and row[3] is not None else ""
        notes = notes or bool(note)
        matches, criterion = compare(d, h, rtol)
        shown = d.value if isinstance(d, Approx) else str(d) if isinstance(d, Bound) else d
        records.append({"quantity": str(q), "dissertation": shown, "hypate": h,
                        "difference": relative_difference_percent(d, h), "matches": matches,
                        "criterion": criterion, "note": note})
    df = pd.DataFrame.from_records(records, columns=[*COLUMNS, "note"])
    return df if notes else df.drop(columns="note")


def _state(m: object) -> bool | None:
    """A ``matches`` cell as True / False / None (pandas may hold numpy bools or NaN)."""
    return None if m is None or (isinstance(m, float) and math.isnan(m)) else bool(m)


def mismatches(df: pd.DataFrame) -> list[str]:
    """Quantities of the rows that do not match (``matches`` is False)."""
    return [str(q) for q, m in zip(df["quantity"], df["matches"]) if _state(m) is False]


def summary(df: pd.DataFrame) -> str:
    """Footer line: how many compared values match, and which do not."""
    compared = sum(_state(m) is not None for m in df["matches"])
    bad = mismatches(df)
    text = f"{compared - len(bad)} of {compared} compared values match"
    if bad:
        text += f"; {len(bad)} mismatch{'es' if len(bad) > 1 else ''} (NO): " + "; ".join(bad)
    return text


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


def _fmt_match(m: object, criterion: str) -> str:
    state = _state(m)
    if state is None:
        return "-"
    return ("yes" if state else "NO") + (f" ({criterion})" if criterion else "")


def to_markdown(df: pd.DataFrame) -> str:
    """GitHub-flavoured Markdown of the table (no ``tabulate`` dependency); the criterion
    is shown in the ``matches`` cell."""
    cols = [c for c in df.columns if c != "criterion"]
    head = ["difference (%)" if c == "difference" else c for c in cols]
    lines = ["| " + " | ".join(head) + " |", "|" + "|".join("---" for _ in cols) + "|"]
    for _, r in df.iterrows():
        cells = []
        for c in cols:
            v = r[c]
            if c == "difference":
                cells.append(f"{v:+.3f}" if isinstance(v, float) and math.isfinite(v) else "-")
            elif c == "matches":
                cells.append(_fmt_match(v, r.get("criterion", "")))
            else:
                cells.append(_fmt(v))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def write_table(df: pd.DataFrame, out: str | Path | None, name: str,
                title: str | None = None) -> list[Path]:
    """Write ``NAME.csv`` and ``NAME.md`` (with the :func:`summary` footer) into directory
    ``out`` (created); nothing if None."""
    if out is None:
        return []
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    csv, md = out / f"{name}.csv", out / f"{name}.md"
    df.to_csv(csv, index=False)
    text = (f"# {title}\n\n" if title else "") + to_markdown(df) + f"\n{summary(df)}\n"
    md.write_text(text, encoding="utf-8")
    return [csv, md]


def show(df: pd.DataFrame, title: str | None = None) -> None:
    """Print the table as Markdown with the :func:`summary` footer (for ``main()`` only)."""
    if title:
        print(f"\n## {title}\n")
    print(to_markdown(df))
    print(summary(df))


def standard_parser(description: str) -> argparse.ArgumentParser:
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
