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

Two more kinds serve the reproductions page (``hypate reproduce``, issue 21): a
:class:`NotCompared` published value is shown but not judged (a coarse variant that cannot
resolve the number; the row says why), and a :class:`Finding` note marks a mismatch that is
an accepted finding (explained next to the row, counted apart by :func:`summary`).
:func:`side_by_side_seeds` builds the table of a reproduction run with several optimizer
seeds: the median of each row's values, their min and max, and the verdict on the median.
"""
from __future__ import annotations

import argparse
import math
import operator
import statistics
from collections import Counter
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


@dataclass(frozen=True)
class NotCompared:
    """A published value shown next to hypate's but not judged, and why.

    Parameters
    ----------
    value : object
        The dissertation's value (a number, :class:`Approx`, :class:`Bound` or word).
    reason : str
        Why no verdict is given (e.g. "the coarse budget does not resolve h"); shown in the
        row's note.
    """

    value: object
    reason: str

    def shown(self) -> object:
        v = self.value
        return v.value if isinstance(v, Approx) else str(v) if isinstance(v, Bound) else v


@dataclass(frozen=True)
class Finding:
    """A row note marking an accepted finding: hypate differs from the dissertation for a
    reason that was investigated and accepted (issues 8 and 10), explained in ``text``."""

    text: str

    def __str__(self) -> str:
        return self.text


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
    if isinstance(dissertation, NotCompared) or _missing(dissertation) or _missing(hypate):
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
    if isinstance(dissertation, NotCompared):
        dissertation = dissertation.value
    if isinstance(dissertation, Approx):
        dissertation = dissertation.value
    d, h = _number(dissertation), _number(hypate)
    if d is None or h is None or not (math.isfinite(d) and math.isfinite(h)) or d == 0.0:
        return math.nan
    return 100.0 * (h - d) / abs(d)


def _shown(d: object) -> object:
    """The dissertation column's plain value of a published value."""
    if isinstance(d, NotCompared):
        return d.shown()
    return d.value if isinstance(d, Approx) else str(d) if isinstance(d, Bound) else d


def _note(d: object, note: object) -> str:
    """A row's note; a :class:`NotCompared` row's reason comes first."""
    parts = [d.reason] if isinstance(d, NotCompared) and d.reason else []
    if note is not None and str(note):
        parts.append(str(note))
    return "; ".join(parts)


def _finalize(records: list[dict], extra: Sequence[str] = ()) -> pd.DataFrame:
    """The DataFrame of ``records``; ``note`` / ``finding`` kept only when any row has one."""
    df = pd.DataFrame.from_records(records, columns=[*COLUMNS, *extra, "note", "finding"])
    drop = [c for c in ("note", "finding") if not any(df[c].astype(bool))]
    return df.drop(columns=drop)


def side_by_side(rows: Iterable[Sequence[object]], rtol: float = RTOL) -> pd.DataFrame:
    """Build the comparison table.

    Parameters
    ----------
    rows : iterable of (quantity, dissertation, hypate) or (quantity, dissertation, hypate, note)
        ``dissertation`` may be a number, :class:`Approx`, :class:`Bound`,
        :class:`NotCompared`, bool, ``None`` or a short string ("yes", "flutter");
        ``hypate`` a number, bool, string or ``None`` (not measured); ``note`` a string or a
        :class:`Finding`.
    rtol : float
        Relative tolerance of the published plain numbers (an :class:`Approx` carries its
        own).

    Returns
    -------
    pandas.DataFrame
        Columns ``quantity | dissertation | hypate | difference`` (relative, %) ``| matches
        | criterion`` (:func:`compare`), plus ``note`` when any row carries one and
        ``finding`` (the text of a :class:`Finding` note) when any row is an accepted
        finding. The dissertation column holds plain values (an :class:`Approx` its number,
        a :class:`Bound` its text).
    """
    return _finalize([_record(row[0], row[1], row[2], row[3] if len(row) > 3 else None, rtol)
                      for row in rows])


def _record(q: object, d: object, h: object, note: object, rtol: float) -> dict:
    """One table row (:func:`side_by_side`'s columns)."""
    matches, criterion = compare(d, h, rtol)
    return {"quantity": str(q), "dissertation": _shown(d), "hypate": h,
            "difference": relative_difference_percent(d, h), "matches": matches,
            "criterion": criterion, "note": _note(d, note),
            "finding": str(note) if isinstance(note, Finding) else ""}


def _aggregate(values: list[object]) -> object:
    """One value for several seeds: the median of numbers, else the most common value."""
    present = [v for v in values if not _missing(v)]
    if not present:
        return None
    numbers = [n for n in map(_number, present) if n is not None]
    if len(numbers) == len(present):
        return present[0] if len(present) == 1 else float(statistics.median(numbers))
    counts = Counter(map(str, present))
    top = counts.most_common(1)[0][0]
    return next(v for v in present if str(v) == top)


def side_by_side_seeds(rows_by_seed: Sequence[Sequence[Sequence[object]]], rtol: float = RTOL
                       ) -> pd.DataFrame:
    """The comparison table of a reproduction run over several optimizer seeds.

    Parameters
    ----------
    rows_by_seed : sequence of row lists
        One list of rows (as in :func:`side_by_side`) per seed; a row is identified by its
        quantity (published value and note are taken from the first seed that has it).
    rtol : float
        As in :func:`side_by_side`.

    Returns
    -------
    pandas.DataFrame
        As :func:`side_by_side`, with ``hypate`` the median over seeds (numbers; other
        values: the most common) and ``matches`` the verdict on it, plus the columns
        ``hypate_min``, ``hypate_max`` (over the seeds' numbers, NaN when not numeric),
        ``seeds`` (how many seeds gave a value) and ``seeds_matching`` (how many of those
        match on their own; NaN when not compared). A quantity that occurs twice in one
        seed's rows is one row (its values are pooled).
    """
    order: list[str] = []
    first: dict[str, Sequence[object]] = {}
    values: dict[str, list[object]] = {}
    for rows in rows_by_seed:
        for row in rows:
            q = str(row[0])
            if q not in first:
                order.append(q)
                first[q] = row
                values[q] = []
            values[q].append(row[2])
    records = []
    for q in order:
        row = first[q]
        d = row[1]
        h = _aggregate(values[q])
        rec = _record(q, d, h, row[3] if len(row) > 3 else None, rtol)
        present = [v for v in values[q] if not _missing(v)]
        nums = [n for n in map(_number, present) if n is not None]
        rec.update(hypate_min=min(nums) if nums else math.nan,
                   hypate_max=max(nums) if nums else math.nan, seeds=len(present),
                   seeds_matching=(sum(compare(d, v, rtol)[0] is True for v in present)
                                   if rec["matches"] is not None else math.nan))
        records.append(rec)
    return _finalize(records, ("hypate_min", "hypate_max", "seeds", "seeds_matching"))


def _state(m: object) -> bool | None:
    """A ``matches`` cell as True / False / None (pandas may hold numpy bools or NaN)."""
    return None if m is None or (isinstance(m, float) and math.isnan(m)) else bool(m)


def mismatches(df: pd.DataFrame) -> list[str]:
    """Quantities of the rows that do not match (``matches`` is False)."""
    return [str(q) for q, m in zip(df["quantity"], df["matches"]) if _state(m) is False]


def accepted_findings(df: pd.DataFrame) -> list[str]:
    """Quantities of the mismatches that are accepted findings (a :class:`Finding` note)."""
    if "finding" not in df.columns:
        return []
    return [str(q) for q, m, f in zip(df["quantity"], df["matches"], df["finding"])
            if _state(m) is False and f]


def summary(df: pd.DataFrame) -> str:
    """Footer line: how many compared values match, and which do not (and of those, which
    are accepted findings)."""
    compared = sum(_state(m) is not None for m in df["matches"])
    bad = mismatches(df)
    text = f"{compared - len(bad)} of {compared} compared values match"
    if bad:
        text += f"; {len(bad)} mismatch{'es' if len(bad) > 1 else ''} (NO): " + "; ".join(bad)
    found = accepted_findings(df)
    if found:
        text += f" ({len(found)} of them accepted finding{'s' if len(found) > 1 else ''}: " \
            + "; ".join(found) + ")"
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
    cols = [c for c in df.columns if c not in ("criterion", "finding")]
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
