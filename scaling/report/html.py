"""Self-contained HTML report of a scaling run (what a test engineer mails around).

:func:`write_report` reads a run directory written by ``hypate run``
(:mod:`hypate.scaling.workflow.campaigns.run`) -- also an *interrupted* one, where only
``evaluations.sqlite`` (and perhaps ``prototype.npz`` / ``classical.json``) exist -- and writes

* ``figures/*.png`` -- the figures of :mod:`.figures`;
* ``report.html`` -- ONE page with every image embedded as a base64 ``data:`` URI, inline
  CSS, no JavaScript and no external reference, so that it can be sent by mail.

The report in four modules, each importing only those before it:
:mod:`.rundata` (:class:`RunData`, :func:`load_run`), :mod:`.figures` (matplotlib),
:mod:`.sections` (:class:`Section`, :func:`html_table`, the built-in sections in page order)
and this one (the page, and the plug-in registry).

Extending the report
--------------------
Two ways to add sections after the built-in ones:

* static: ``write_report(run_dir, extra_sections=[("Notes", "<p>...</p>")])``;
* dynamic: a provider registered once at import time of the providing module::

      from hypate.scaling.report.figures import figure_html
      from hypate.scaling.report.html import register_section
      from hypate.scaling.report.rundata import RunData
      from hypate.scaling.report.sections import Section, html_table

      def margins_section(run: RunData) -> Section | None:
          if run.study is None:
              return None                      # nothing to say: section left out
          fig = ...                            # a matplotlib Figure
          img = figure_html(fig, run, "margins", "Flutter margins of the Pareto set")
          return Section("Flutter margins", img + html_table(...))

      register_section("flutter_margins", margins_section)

  The providing module must be imported before :func:`write_report` runs (nothing here
  imports plug-ins by name). Providers get the :class:`RunData` (study, evaluations, design
  point, responses) and return a :class:`Section` (or ``None``); they run after the built-in
  sections in registration order. A provider that raises is reported in the page (a short
  note), never breaks the report. HTML returned by providers is inserted verbatim: escape
  user text with :func:`html.escape` and embed images with
  :func:`~hypate.scaling.report.figures.figure_html` /
  :func:`~hypate.scaling.report.figures.embed_png`.
"""
from __future__ import annotations

import html
import re
import warnings
from collections.abc import Callable, Sequence
from datetime import UTC, datetime
from pathlib import Path

from hypate.scaling.report.figures import close_figures
from hypate.scaling.report.rundata import RunData, load_run
from hypate.scaling.report.sections import BUILTIN_SECTIONS, Section
from hypate.scaling.workflow.campaigns.integrity import check_run_directory
from hypate.scaling.workflow.campaigns.rundir import REPORT_HTML as REPORT_NAME
from hypate.solvers.errors import InputError
from hypate.solvers.numerics.files import write_text

__all__ = ["SectionProvider", "register_section", "unregister_section", "render_html",
           "write_report", "write_report_safely", "REPORT_NAME"]

#: Name of the report file in the run directory.

#: A dynamic section: ``provider(run) -> Section | None``.
SectionProvider = Callable[[RunData], Section | None]
_PROVIDERS: dict[str, SectionProvider] = {}


def register_section(name: str, provider: SectionProvider) -> None:
    """Register a dynamic report section (appended after the built-in ones).

    Parameters
    ----------
    name : str
        Key of the provider; registering the same name again replaces it (idempotent
        module reloads).
    provider : callable
        ``provider(run: RunData) -> Section | None``; ``None`` leaves the section out.
    """
    _PROVIDERS[str(name)] = provider


def unregister_section(name: str) -> None:
    """Remove a registered provider (no error when absent)."""
    _PROVIDERS.pop(str(name), None)


_CSS = """
body{font-family:-apple-system,Segoe UI,Helvetica,Arial,sans-serif;max-width:1100px;
margin:2em auto;padding:0 1em;color:#222;line-height:1.4}
h1{border-bottom:2px solid #345;padding-bottom:.2em}h2{color:#345;margin-top:1.8em;
border-bottom:1px solid #ccd}h3{margin-bottom:.3em}
table{border-collapse:collapse;margin:.5em 0 1em;font-size:.92em}
th,td{border:1px solid #ccd;padding:.25em .6em;text-align:right}
th{background:#eef1f6}td:first-child,th:first-child{text-align:left}
tr.mismatch td{background:#fde2e1}tr.active td{background:#fff4d6}
tr.design td{background:#fff1b8;font-weight:600}tr.design td:first-child::before{content:"\\2605  "}
.rule{background:#eef5ee;border-left:4px solid #5a5;padding:.4em .8em}
table.glossary td,table.glossary th{text-align:left}\
details.figure-toggle summary{cursor:pointer;color:#345}
dl{display:grid;grid-template-columns:max-content auto;gap:.2em 1em}dt{font-weight:600}dd{margin:0}
figure{margin:1em 0}figure img{max-width:100%;height:auto;border:1px solid #ddd}
figcaption{font-size:.9em;color:#555}.note{color:#555;font-style:italic}
.warn{color:#a40}.notes{background:#fff8e5;border:1px solid #eb5;padding:.5em 1em}
nav ul{columns:2}code{background:#f3f3f3;padding:0 .2em}
"""
#: The page style, public for the other self-contained pages (``hypate reproduce``).
PAGE_CSS = _CSS


def _slug(title: str, used: set[str]) -> str:
    base = re.sub(r"[^a-z0-9]+", "-", title.lower()).strip("-") or "section"
    slug, k = base, 2
    while slug in used:
        slug, k = f"{base}-{k}", k + 1
    used.add(slug)
    return slug


#: How the page states when it was made (``render_html``), and the pattern that finds it.
STAMP_FORMAT = "%Y-%m-%d %H:%M UTC"
_STAMP = re.compile(r"generated \d{4}-\d\d-\d\d \d\d:\d\d UTC")


def render_html(run: RunData, sections: Sequence[Section], stamp: str | None = None) -> str:
    """The report page of ``sections`` (self-contained HTML5), stating ``stamp`` as the
    time it was generated (default: now, :data:`STAMP_FORMAT`)."""
    name = run.study.name if run.study is not None else str((run.point or {}).get("study")
                                                            or run.directory.name)
    title = f"hypate scaling report: {name}"
    used: set[str] = set()
    slugs = [_slug(s.title, used) for s in sections]
    stamp = stamp or datetime.now(UTC).strftime(STAMP_FORMAT)
    state = "interrupted run (partial results)" if run.interrupted else "finished run"
    out = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
           '<meta name="viewport" content="width=device-width, initial-scale=1">',
           '<link rel="icon" href="data:,">',
           f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>",
           f"<h1>{html.escape(title)}</h1>",
           f"<p>Run directory <code>{html.escape(run.directory.name)}</code> &mdash; "
           f"{state} &mdash; generated {stamp}.</p>"]
    if run.notes:
        out.append("<div class='notes'><strong>Notes</strong><ul>"
                   + "".join(f"<li>{html.escape(n)}</li>" for n in run.notes) + "</ul></div>")
    out.append("<nav><ul>" + "".join(f'<li><a href="#{s}">{html.escape(sec.title)}</a></li>'
                                     for s, sec in zip(slugs, sections)) + "</ul></nav>")
    for slug, sec in zip(slugs, sections):
        out.append(f'<section id="{slug}"><h2>{html.escape(sec.title)}</h2>{sec.html}</section>')
    out.append("<footer><p class='note'>Generated by hypate (scaling.report). Equations and "
               "tables refer to the dissertation (Ch. 6, 9).</p></footer></body></html>")
    return "\n".join(out)


def write_report(run_dir: str | Path, *, study_path: str | Path | None = None,
                 extra_sections: Sequence[tuple[str, str]] | None = None,
                 simulate: bool = False) -> Path:
    """Build ``run_dir/figures/*.png`` and the self-contained ``run_dir/report.html``.

    Parameters
    ----------
    run_dir : path
        A run directory of ``hypate run`` (finished or interrupted).
    study_path : path, optional
        The study file when the run directory does not record it (see :func:`load_run`).
    extra_sections : sequence of (title, html), optional
        Static sections appended after the built-in and registered ones (HTML verbatim).
    simulate : bool
        Interrupted run: simulate the rebuilt design point for the response figure.

    Returns
    -------
    Path
        ``run_dir/report.html``.

    Raises
    ------
    InputError
        ``run_dir`` is not a run directory, ``study_path`` does not fit the run, its store
        does not match its digests, or a symbolic link stands where the report writes
        (nothing is written then).
    """
    check_run_directory(run_dir, field="DIR")  # no planted link where the report writes
    run = load_run(run_dir, study_path=study_path, simulate=simulate)
    sections: list[Section] = []
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", category=RuntimeWarning)
        for build in BUILTIN_SECTIONS:
            sec = build(run)
            if sec is not None:
                sections.append(sec)
    for key, provider in list(_PROVIDERS.items()):
        try:
            sec = provider(run)
        except Exception as exc:  # noqa: BLE001 - a plug-in must never break the report
            close_figures()
            warnings.warn(f"report section {key!r} failed: {exc}", RuntimeWarning,
                          stacklevel=2)
            sec = Section(key, f"<p class='warn'>This section failed: "
                          f"{html.escape(f'{type(exc).__name__}: {exc}')}</p>")
        if sec is not None:
            sections.append(sec if isinstance(sec, Section) else Section(*sec))
    for title, body in extra_sections or ():
        sections.append(Section(str(title), str(body)))
    page = render_html(run, sections)
    path = run.directory / REPORT_NAME
    if _unchanged(path, page):  # only its time stamp would change: keep the file as it is
        return path
    return write_text(path, page)


def _unchanged(path: Path, page: str) -> bool:
    """Whether the report at ``path`` says what ``page`` says, apart from when it was made
    (so that ``hypate report`` of a finished run leaves its directory as it was)."""
    try:
        old = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return False
    return _STAMP.sub("generated", old) == _STAMP.sub("generated", page)


def write_report_safely(run_dir: Path) -> Path | None:
    """``report.html`` + ``figures/`` of a run; a failing report never costs the run."""
    try:
        return write_report(run_dir)
    except (OSError, ValueError, KeyError, RuntimeError, InputError) as exc:
        warnings.warn(f"report of {run_dir} not written: {exc}", RuntimeWarning, stacklevel=2)
        return None
