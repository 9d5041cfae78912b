"""The refined scaling laws as a reader sees them (Sec. 6.1.3, Fig. 9.4, Fig. 9.12): the
exponent table of ``hypate laws`` and the report, the figure of each variable against the
geometric scale ``xi`` with its fitted and analytical laws, and the report's "Scaling
laws" section of a sweep directory. The laws themselves are fitted in
:mod:`hypate.scaling.workflow.campaigns.laws`.
"""
from __future__ import annotations

import base64
import html
import io
import math
from collections.abc import Sequence
from pathlib import Path

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
from hypate.scaling.workflow.campaigns.laws import ScalingLaw, laws_of_run, load_sweep
from hypate.solvers.errors import InputError


def _fmt(v: float | None, spec: str = ".4g") -> str:
    return "-" if v is None else format(v, spec)


def laws_table(laws: Sequence[ScalingLaw]) -> list[dict[str, str]]:
    """Rows of the exponent table (strings, for the CLI and the report)."""
    rows = []
    for law in laws:
        f = law.fit
        ci = ("-" if f.exponent_low is None else f"[{f.exponent_low:.3f}, {f.exponent_high:.3f}]")
        rows.append({"variable": law.variable, "coefficient": _fmt(f.coefficient),
                     "exponent": _fmt(f.exponent, ".3f"), "95% interval": ci,
                     "analytical exponent": _fmt(law.analytical_exponent, "g"),
                     "analytical coefficient": _fmt(law.analytical_coefficient),
                     "points (free/all)": f"{f.n}/{len(law.values)}",
                     "at bound": "yes" if law.at_bound else "no", "note": f.note})
    return rows


def laws_figure(laws: Sequence[ScalingLaw]):
    """Fig. 9.4/9.12-style figure: each variable against xi on log-log axes, with the
    numerical design points (bound-pinned ones hollow and labelled), the fitted law and
    the analytical line. Returns a matplotlib Figure (Agg)."""
    matplotlib.use("Agg", force=False)

    laws = [law for law in laws if law.values]
    n = max(1, len(laws))
    ncol = min(3, n)
    nrow = math.ceil(n / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.0 * ncol, 3.2 * nrow), squeeze=False)
    for ax in axes.ravel()[len(laws):]:
        ax.set_visible(False)
    for ax, law in zip(axes.ravel(), laws):
        xs, ys, pins = (np.array(law.xi), np.array(law.values), np.array(law.pinned, bool))
        lo_x, hi_x = xs.min() / 1.15, xs.max() * 1.15
        grid = np.geomspace(lo_x, hi_x, 50)
        ax.plot(xs[~pins], ys[~pins], "o", color="C0", label="numerical")
        if pins.any():
            ax.plot(xs[pins], ys[pins], "s", mfc="none", color="C3", label="at bound")
        if law.fit.coefficient is not None:
            ax.plot(grid, law.fit(grid), "-", color="C0",
                    label=f"fit $\\xi^{{{law.fit.exponent:.2f}}}$")
        an = law.analytical(grid)
        if an is not None:
            ax.plot(grid, an, "--", color="C2",
                    label=f"analytical $\\xi^{{{law.analytical_exponent:g}}}$")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(r"$\xi = L_p / L_m$")
        ax.set_title(law.variable)
        ax.legend(fontsize=7)
        ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    return fig


def laws_section(run_dir: str | Path) -> tuple[str, str]:
    """The "Scaling laws" section of ``report.html``: ``(title, html)``.

    The HTML holds the Fig. 9.12-style figure (inline PNG) and the exponent table; a
    directory without a sweep gives a short explanation instead.
    """

    title = "Scaling laws"
    try:
        run = load_sweep(run_dir)
    except InputError as exc:
        return title, f"<p>{html.escape(str(exc))}</p>"
    if len({p.xi for p in run.points}) < 2:
        return title, ("<p>Refined scaling laws need finished design points at two or more "
                       "geometric scales; this run has "
                       f"{len({p.xi for p in run.points})}.</p>")
    laws = laws_of_run(run)
    fig = laws_figure(laws)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    img = base64.b64encode(buf.getvalue()).decode("ascii")
    rows = laws_table(laws)
    head = "".join(f"<th>{html.escape(k)}</th>" for k in rows[0])
    body = "".join("<tr>" + "".join(f"<td>{html.escape(v)}</td>" for v in r.values()) + "</tr>"
                   for r in rows)
    text = (f"<p>Design points of {len(run.points)} scales fitted as c&nbsp;&xi;<sup>k</sup> "
            "(log-linear least squares, 95&nbsp;% interval of k from the residuals); hollow "
            "squares sit on a bound and are not fitted. Dashed: analytical law (Eq. 9.2, "
            "geometric similarity, Eq. 9.3/9.6 for the time step).</p>"
            f'<img alt="scaling laws" src="data:image/png;base64,{img}"/>'
            f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>")
    return title, text
