"""The report's matplotlib figures (PNG, embedded in the page as ``data:`` URIs).

Run figures take a :class:`~hypate.scaling.report.rundata.RunData` and return an HTML
``<figure>`` (empty string when the run has nothing to plot), saving the PNG as
``figures/<name>.png`` too: the Pareto front with the classical baseline (Fig. 9.9 / 9.13
style; every evaluation on log-log axes in %, admissible and inadmissible ones marked
differently), the hypervolume history (two objectives) or best-J history (one objective), and the
nondimensional response of the prototype vs the design-point model (Figs. 9.10, 9.11, 9.14,
9.15 style) and, for a study with a heater schedule, the optimized ``T_rad(t)`` next to the
prototype's and the model's wall temperatures. :func:`plot_sweep` draws the what-if sweep
of ``hypate whatif --sweep``.

Every figure's labels are wrapped to fit its axes (:func:`fit_labels`) before it is saved.
This is the one module of the report that imports pyplot (Agg backend: no display needed)
besides :mod:`hypate.scaling.report.laws`, whose scaling-law figure moved there from the
workflow with its table.

Size: about 610 lines -- every figure of the report, the robustness distributions and the
prediction page share the label fitting, axis and embedding helpers and the one pyplot
import, which is the reason they live together.
"""
from __future__ import annotations

import base64
import html
import io
import textwrap
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from hypate.scaling.engine.pareto import hypervolume, non_dominated_mask  # noqa: E402
from hypate.scaling.report.numbers import format_percent, percent  # noqa: E402
from hypate.scaling.report.rundata import RunData  # noqa: E402
from hypate.scaling.workflow.analyses.predict import Prediction  # noqa: E402
from hypate.scaling.workflow.vocabulary.variables import schedule_point, variable_unit  # noqa: E402
from hypate.solvers.coupling.response import Response  # noqa: E402
from hypate.solvers.numerics.files import atomic_file, write_bytes  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.ticker import FuncFormatter, LogLocator  # noqa: E402

if TYPE_CHECKING:
    from matplotlib.backends.backend_agg import FigureCanvasAgg

__all__ = ["MISMATCH_THRESHOLD", "HV_REFERENCE", "LOG_PAD", "embed_png",
           "figure_html", "fit_labels", "label_overflows", "log_limits",
           "pareto_figure", "history_figure", "response_figure", "schedule_figure",
           "plot_sweep", "close_figures", "png_bytes", "prediction_figure"]

#: Relative difference above which a similarity parameter is highlighted (10 %); also the
#: dotted 10 % error lines of the Pareto and what-if figures.
MISMATCH_THRESHOLD = 0.10
#: Reference point of the hypervolume history when the front dominates it (100 % errors).
HV_REFERENCE = np.array([1.0, 1.0])


def close_figures() -> None:
    """Close every open figure (after a figure builder failed half way)."""
    plt.close("all")


def embed_png(path_or_bytes: str | Path | bytes, alt: str) -> str:
    """An ``<img>`` whose ``src`` is a base64 ``data:image/png`` URI (self-contained)."""
    data = path_or_bytes if isinstance(path_or_bytes, bytes) else Path(path_or_bytes).read_bytes()
    b64 = base64.b64encode(data).decode("ascii")
    return f'<img src="data:image/png;base64,{b64}" alt="{html.escape(alt)}">'


def label_overflows(fig: Figure) -> list[str]:
    """Axis labels and titles of ``fig`` longer than their axes (y-labels taller than the
    axes, x-labels and titles wider), as ``"<text>: <size> px > <span> px"``."""
    fig.canvas.draw()
    renderer = cast("FigureCanvasAgg", fig.canvas).get_renderer()  # the Agg backend's canvas
    out = []
    for ax in fig.axes:
        box = ax.get_window_extent(renderer)
        for label, vertical in ((ax.yaxis.label, True), (ax.xaxis.label, False),
                                (ax.title, False)):
            if not label.get_text():
                continue
            ext = label.get_window_extent(renderer)
            size, span = (ext.height, box.height) if vertical else (ext.width, box.width)
            # 1 px of slack: rounding of the text extent, not a visible overflow
            if size > span + 1.0:
                out.append(f"{label.get_text()!r}: {size:.0f} px > {span:.0f} px")
    return out


def _wrap_labels(fig: Figure, min_chars: int) -> None:
    """One pass of :func:`fit_labels`: wrap each too long label to its axes' current size."""
    fig.canvas.draw()
    renderer = cast("FigureCanvasAgg", fig.canvas).get_renderer()  # the Agg backend's canvas
    for ax in fig.axes:
        box = ax.get_window_extent(renderer)
        for label, vertical in ((ax.yaxis.label, True), (ax.xaxis.label, False),
                                (ax.title, False)):
            text = " ".join(label.get_text().split())
            span = box.height if vertical else box.width
            chars = len(text)
            while chars > min_chars:
                ext = label.get_window_extent(renderer)
                if (ext.height if vertical else ext.width) <= span:
                    break
                chars = int(chars * 0.8)
                label.set_text(textwrap.fill(text, chars))


def fit_labels(fig: Figure, min_chars: int = 12, passes: int = 3) -> Figure:
    """Wrap every axis label and title of ``fig`` onto more lines until it fits its axes
    (see :func:`label_overflows`), laying the figure out again after each pass (the
    layout shrinks the axes to make room for the wrapped text, hence a few passes).

    A label longer than its axes runs into the neighbouring axes or past the image edge at
    the report's page width; wrapping keeps the text whole, unlike shrinking the font.
    """
    for _ in range(passes):
        _wrap_labels(fig, min_chars)
        if fig.get_layout_engine() is None:
            fig.tight_layout()
        if not label_overflows(fig):
            break
    return fig


def png_bytes(fig: Figure) -> bytes:
    """``fig`` as PNG bytes (labels wrapped to their axes by :func:`fit_labels`, 110 dpi,
    tight box); the figure is closed afterwards."""
    buf = io.BytesIO()
    try:
        fit_labels(fig)
        fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    finally:  # an interrupt or error while rendering leaves no figure open
        plt.close(fig)
    return buf.getvalue()


def figure_html(fig: Figure, run: RunData, name: str, caption: str) -> str:
    """Save ``fig`` as ``figures/<name>.png`` and return it embedded with a caption.

    Labels are wrapped to their axes first (:func:`fit_labels`). The figure is closed
    afterwards.
    """
    data = png_bytes(fig)  # first: the figure is closed whatever happens to its file
    write_bytes(run.figure_path(name), data)
    return (f'<figure>{embed_png(data, caption)}<figcaption>{html.escape(caption)}'
            f"</figcaption></figure>")


#: Padding of the Pareto figure's log axes around every point, in decades.
LOG_PAD = 0.08


def log_limits(V: np.ndarray) -> tuple[float, float]:
    """Log-axis limits that hold every positive value of ``V`` with :data:`LOG_PAD` decades
    on each side (at least a decade in all)."""
    V = np.asarray(V, float)
    V = V[np.isfinite(V) & (V > 0)]
    if V.size == 0:
        return 0.1, 100.0
    a, b = np.log10(V.min()), np.log10(V.max())
    pad = max(LOG_PAD, 0.5 * (1.0 - (b - a))) if b - a < 1.0 else LOG_PAD
    return 10.0 ** (a - pad), 10.0 ** (b + pad)


def _pareto_plot(run: RunData, F: np.ndarray) -> Figure:
    """The Pareto figure of ``F`` (n, 2; in %): every successful evaluation at its true
    coordinates on log-log axes -- admissible ones as filled circles coloured by iteration,
    inadmissible ones as grey crosses -- the Pareto set of the admissible evaluations, the
    design point and the classical baseline."""
    ok, objs = run.ok, run.objectives
    pobj = (run.point or {}).get("objectives") or {}
    point = np.array([[percent(pobj[o]) for o in objs]]) \
        if all(isinstance(pobj.get(o), (int, float)) for o in objs) else np.zeros((0, 2))
    cobj = (run.classical or {}).get("objectives") or {}
    classical = np.array([[percent(cobj[o]) for o in objs]]) \
        if all(isinstance(cobj.get(o), (int, float)) for o in objs) else np.zeros((0, 2))
    adm = (ok["admissible"].fillna(False).astype(bool).to_numpy() if "admissible" in ok
           else np.ones(len(ok), bool))
    FA = F[adm]
    P = (FA[non_dominated_mask(FA)] if len(FA) else FA)
    P = P[np.argsort(P[:, 0], kind="stable")] if len(P) else P
    frame = np.vstack([F, point, classical])
    fig, ax = plt.subplots(figsize=(6.4, 4.8), layout="constrained")
    ax.set_xscale("log")
    ax.set_yscale("log")
    it = ok["iteration"].to_numpy() if "iteration" in ok else np.zeros(len(ok))
    init = it <= 0
    ax.scatter(F[adm & init, 0], F[adm & init, 1], s=18, c="0.6", zorder=3,
               label="initial samples (admissible)")
    if (adm & ~init).any():
        sc = ax.scatter(F[adm & ~init, 0], F[adm & ~init, 1], s=18, c=it[adm & ~init],
                        cmap="viridis", zorder=3, vmin=it[~init].min(), vmax=it[~init].max(),
                        label="BO iterations (admissible)")
        fig.colorbar(sc, ax=ax, label="iteration")
    if (~adm).any():
        ax.scatter(F[~adm, 0], F[~adm, 1], marker="x", s=22, c="0.45", lw=1.0, zorder=3,
                   label=f"inadmissible ({int((~adm).sum())})")
    # the star goes *behind* the hollow Pareto circles so that it never hides one
    if len(point):
        ax.scatter(point[:, 0], point[:, 1], marker="*", s=380, c="gold", edgecolors="0.2",
                   linewidths=0.8, zorder=2, label="design point")
    if len(P):
        ax.step(P[:, 0], P[:, 1], where="post", color="tab:red", lw=1.2, zorder=4)
        ax.scatter(P[:, 0], P[:, 1], s=60, facecolors="none", edgecolors="tab:red", lw=1.5,
                   zorder=5, label="Pareto set (admissible)")
    if len(classical):
        ax.scatter(classical[:, 0], classical[:, 1], marker="s", s=60, c="tab:blue",
                   edgecolors="k", zorder=5, label="classical baseline")
    threshold = percent(MISMATCH_THRESHOLD)
    ax.axvline(threshold, color="0.5", ls=":", lw=0.8)
    ax.axhline(threshold, color="0.5", ls=":", lw=0.8)
    ax.set_xlim(*log_limits(frame[:, 0]))
    ax.set_ylim(*log_limits(frame[:, 1]))
    plain = FuncFormatter(lambda v, _: f"{v:g}")  # "60", not "6 x 10^1"
    for axis in (ax.xaxis, ax.yaxis):
        axis.set_major_formatter(plain)
        axis.set_minor_locator(LogLocator(subs=(2.0, 5.0)))
        axis.set_minor_formatter(plain)
    ax.set_xlabel(f"{objs[0]} (%)")
    ax.set_ylabel(f"{objs[1]} (%)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7)
    ax.set_title("Pareto front, every evaluation at its coordinates (log axes); "
                 "dotted: 10 % error", fontsize=9)
    return fig


def pareto_figure(run: RunData) -> str:
    """Pareto front of a two-objective run on log-log axes (:func:`_pareto_plot`): every
    successful evaluation where it is -- nothing clipped to an edge -- admissible and
    inadmissible evaluations drawn differently, the admissible Pareto set (hollow circles),
    the design point (a star behind them) and the classical baseline.

    Returns
    -------
    str
        The embedded ``figures/pareto_front.png``; ``""`` unless there are two objectives
        and a successful evaluation.
    """
    ok = run.ok
    objs = run.objectives
    if len(objs) != 2 or ok.empty:
        return ""
    F = percent(ok[objs].to_numpy(float))
    fig = _pareto_plot(run, F)
    n_bad = int((~ok["admissible"].fillna(False).astype(bool)).sum()) \
        if "admissible" in ok else 0
    return figure_html(fig, run, "pareto_front",
                       f"Pareto front: {objs[0]} vs {objs[1]} in %, log axes, all {len(F)} "
                       "successful evaluations at their coordinates"
                       + (f" ({n_bad} inadmissible: grey crosses)" if n_bad else "")
                       + "; the design point (star), the admissible Pareto set and the "
                       "classical baseline.")


def history_figure(run: RunData) -> str:
    """Hypervolume history (two objectives) or best-objective history (otherwise), with
    failed evaluations marked and the start of the Bayesian iterations dashed.

    Returns
    -------
    str
        The embedded ``figures/hypervolume_history.png`` or
        ``figures/best_objective_history.png``; ``""`` without a successful evaluation.
    """
    df = run.evaluations
    objs = run.objectives
    if df.empty or not objs:
        return ""
    F = df[objs].to_numpy(float)
    good = (df["status"] == "ok").to_numpy() & np.all(np.isfinite(F), axis=1)
    if not good.any():
        return ""
    n = np.arange(1, len(df) + 1)
    fig, ax = plt.subplots(figsize=(6.4, 3.8), layout="constrained")
    it = df["iteration"].to_numpy() if "iteration" in df else np.zeros(len(df))
    first_bo = np.flatnonzero(it >= 1)
    if len(objs) == 2:
        feasible = F[good]
        ref = HV_REFERENCE if np.any(np.all(feasible < HV_REFERENCE, axis=1)) else \
            feasible.max(axis=0) * (1.0 + 1e-9) + 1e-12
        hv = np.empty(len(df))
        for i in range(len(df)):
            sel = good[: i + 1]
            hv[i] = hypervolume(F[: i + 1][sel], ref) if sel.any() else 0.0
        ax.plot(n, hv, drawstyle="steps-post", color="tab:blue")
        ax.set_ylabel("hypervolume (J as fractions)")
        ref_text = "[100 %, 100 %]" if ref is HV_REFERENCE else \
            f"the nadir [{format_percent(ref[0])}, {format_percent(ref[1])}]"
        title = f"Hypervolume history (reference point {ref_text})"
        name = "hypervolume_history"
    else:
        f = percent(np.where(good, F[:, 0], np.nan))
        best = np.fmin.accumulate(np.where(np.isnan(f), np.inf, f))
        best[~np.isfinite(best)] = np.nan
        ax.scatter(n, f, s=12, c="0.6", label=f"{objs[0]} per evaluation")
        ax.plot(n, best, drawstyle="steps-post", color="tab:blue", label=f"best {objs[0]}")
        ax.set_ylabel(f"{objs[0]} (%)")
        ax.legend(fontsize=8)
        title = f"Best-{objs[0]} history"
        name = "best_objective_history"
    bad = ~good
    if bad.any():
        ax.scatter(n[bad], np.full(bad.sum(), ax.get_ylim()[0]), marker="x", c="tab:red",
                   s=20, label="failed", clip_on=False)
        ax.legend(fontsize=8)
    if first_bo.size:
        ax.axvline(n[first_bo[0]] - 0.5, color="0.5", ls="--", lw=0.8)
    ax.set_xlabel("evaluation")
    ax.grid(alpha=0.3)
    ax.set_title(title)
    return figure_html(fig, run, name, title + "; dashed: start of the Bayesian iterations; "
                       "crosses: failed evaluations.")


def _nondimensional_time(resp: Response, dt: float | None, steps: int | None) -> np.ndarray:
    """t / t_end of the matched run: the model's time divided by its own duration
    ``dt * steps`` (Fourier- or structural-time matched, Eqs. 9.3 / 9.6)."""
    t = np.asarray(resp.times, float)
    if dt is not None and steps:
        return t / (dt * steps)
    if len(t) > 1 and t[-1] > 0:
        return t / t[-1]
    return t


def _lsa_markers(ax: Any, tau: np.ndarray, y: np.ndarray, resp: Response, color: str,
                 label_prefix: str, seen: set[str]) -> None:
    status = list(resp.lsa_status)[: len(tau)]
    for kind, marker in (("flutter", "v"), ("divergence", "^")):
        idx = [i for i, s in enumerate(status) if s == kind]
        if idx:
            label = f"{label_prefix} LSA: {kind}"
            ax.scatter(tau[idx], y[idx], marker=marker, s=60, c=color, edgecolors="k",
                       zorder=6, label=label if label not in seen else None)
            seen.add(label)


def response_figure(run: RunData) -> str:
    """Prototype vs design-point model: w/h and T/T0 over nondimensional time, with the
    linearized-stability status of each step (Figs. 9.10, 9.11).

    Returns
    -------
    str
        The embedded ``figures/response.png``; ``""`` without any response.
    """
    proto, model = run.prototype, run.model
    if proto is None and model is None:
        return ""
    steps, dt_p = _matched_steps(run)
    fig, axes = plt.subplots(1, 2, figsize=(10.0, 3.9), layout="constrained")
    seen: set[str] = set()
    for resp, label, color, style in ((proto, "prototype", "k", "-"),
                                      (model, "model (design point)", "tab:red", "--")):
        if resp is None or not resp.times:
            continue
        dt = dt_p if resp is proto else run.model_time_step
        tau = _nondimensional_time(resp, dt, steps)
        u, T = resp.deflection_over_thickness, resp.temperature_over_stagnation
        axes[0].plot(tau, u, style, color=color, marker="o", ms=3, label=label)
        axes[1].plot(tau, T, style, color=color, marker="o", ms=3, label=label)
        short = "prototype" if resp is proto else "model"
        _lsa_markers(axes[0], tau, u, resp, color, short, seen)
        _lsa_markers(axes[1], tau, T, resp, color, short, seen)
        if resp.instability_time is not None and dt is not None and steps:
            for ax in axes:
                ax.axvline(resp.instability_time / (dt * steps), color=color, ls=":", lw=1)
    axes[0].set_ylabel("center deflection / thickness  w/h")
    # long labels are wrapped to the axes by fit_labels (figure_html)
    axes[1].set_ylabel("mean temperature / stagnation temperature  T/T0")
    for ax in axes:
        ax.set_xlabel("nondimensional time  t / t_end")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    axes[0].set_title("structural response")
    axes[1].set_title("thermal response")
    note = "" if model is not None else " (no design-point response in the run directory)"
    return figure_html(fig, run, "response",
                       "Nondimensional response of the prototype and the design-point model "
                       "at matched nondimensional time (Figs. 9.10, 9.11); triangles mark "
                       "steps where the linearized stability analysis reports flutter or "
                       f"divergence{note}.")


def _matched_steps(run: RunData) -> tuple[int | None, float | None]:
    """Steps of both runs and the prototype time step (s): the study's, else the prototype
    response's own (None when neither is known)."""
    if run.study is not None:
        return run.study.spec.simulation.n_steps, run.study.spec.simulation.time_step
    proto = run.prototype
    if proto is not None and len(proto.times) > 1:
        return len(proto.times) - 1, proto.times[1] - proto.times[0]
    return None, None


def design_schedule(design: dict[str, Any] | None) -> dict[str, np.ndarray]:
    """The heater schedules of a design: ``{"T_rad": control temperatures (K) in the
    order of k}`` for every scheduled variable (``T_rad[k]``); empty without one."""
    points: dict[str, dict[int, float]] = {}
    for name, value in (design or {}).items():
        if (p := schedule_point(name)) is not None:
            points.setdefault(p[0], {})[p[1]] = float(value)
    return {n: np.array([pts[k] for k in sorted(pts)]) for n, pts in points.items()}


def schedule_figure(run: RunData) -> str:
    """The design point's heater schedule ``T_rad(t / t_end)`` (control points and the
    piecewise-linear law between them) next to the wall (upper-surface mean) temperature
    histories of the prototype and the design-point model over nondimensional time: in K
    beside the schedule (where ``T_rad > T_w`` the heater heats), and as ``T_w / T0`` (the
    nondimensional wall temperature similarity asks to match, Sec. 9.2.1.1).

    Returns
    -------
    str
        The embedded ``figures/schedule.png``; ``""`` when the design point has no
        schedule.
    """
    schedules = design_schedule((run.point or {}).get("design"))
    if not schedules:
        return ""
    steps, dt_p = _matched_steps(run)
    fig, axes = plt.subplots(1, 2, figsize=(10.0, 3.9), layout="constrained")
    for name, values in schedules.items():
        tau = np.linspace(0.0, 1.0, values.size)
        axes[0].plot(tau, values, "-s", color="tab:orange", lw=2, ms=6,
                     label=f"heater {name}(t), {values.size} control points")
    for resp, label, color, style in ((run.prototype, "prototype", "k", "-"),
                                      (run.model, "model (design point)", "tab:red", "--")):
        if resp is None or not resp.top_temperature:
            continue
        dt = dt_p if resp is run.prototype else run.model_time_step
        tau = _nondimensional_time(resp, dt, steps)
        T_w = np.asarray(resp.top_temperature)
        axes[0].plot(tau, T_w, style, color=color, marker="o", ms=2, label=f"{label} T_w")
        axes[1].plot(tau, T_w / resp.stagnation_temperature, style, color=color, marker="o",
                     ms=2, label=f"{label} T_w/T0")
        axes[1].plot(tau, resp.temperature_over_stagnation, style, color=color, lw=0.8,
                     alpha=0.5, label=f"{label} mean T/T0 (J_T)")
    axes[0].set_ylabel("temperature (K)")
    axes[0].set_title("heater schedule and wall temperatures")
    axes[1].set_ylabel("temperature / stagnation temperature  T/T0")
    axes[1].set_title("nondimensional wall and mean temperatures")
    for ax in axes:
        ax.set_xlabel("nondimensional time  t / t_end")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    return figure_html(fig, run, "schedule",
                       "Optimized radiant-heater temperature T_rad(t) (piecewise linear between "
                       "its control points, equally spaced over the model's test) with the "
                       "upper-surface mean temperature T_w of the prototype and of the "
                       "design-point model at matched nondimensional time (left, K; right, "
                       "T_w/T0, with the volume-mean T/T0 that J_T compares). The model absorbs "
                       "the heater flux emissivity sigma T_rad^4 and "
                       "emits emissivity sigma T_w^4: while T_rad > T_w the heater heats it.")


def plot_sweep(rows: Sequence[dict[str, Any]], name: str, path: str | Path,
               bounds: tuple[float, float] | None = None,
               objectives: Sequence[str] = ("J_u", "J_T", "J_s"), title: str = "") -> Path:
    """Plot a one-variable what-if sweep (``hypate whatif --sweep``) to a PNG.

    Parameters
    ----------
    rows : sequence of dict
        ``{"value": float, "status": str, <objective>: float or None, ...}`` per design.
    name : str
        Swept variable (axis label, with its unit).
    path : path
        PNG to write.
    bounds : (float, float), optional
        The study's bounds of the variable (shaded outside).
    objectives : sequence of str
    title : str

    Returns
    -------
    Path
    """
    path = Path(path)
    v = np.array([float(r["value"]) for r in rows])
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    for obj, color in zip(objectives, ("tab:blue", "tab:orange", "tab:green", "tab:purple")):
        y = np.array([r.get(obj) if r.get(obj) is not None else np.nan for r in rows], float)
        if np.isfinite(y).any():
            ax.plot(v, 100.0 * y, "o-", color=color, ms=4, label=obj)
    failed = np.array([r.get("status") != "ok" for r in rows])
    if failed.any():
        lo = ax.get_ylim()[0]
        ax.scatter(v[failed], np.full(failed.sum(), lo), marker="x", c="tab:red", s=40,
                   clip_on=False, label="model failed")
    ax.axhline(100.0 * MISMATCH_THRESHOLD, color="0.5", ls=":", lw=0.8)
    if bounds is not None:
        lo_b, hi_b = bounds
        xmin, xmax = min(v.min(), lo_b), max(v.max(), hi_b)
        if v.min() < lo_b:
            ax.axvspan(xmin, lo_b, color="tab:red", alpha=0.08, label="outside bounds")
        if v.max() > hi_b:
            ax.axvspan(hi_b, xmax, color="tab:red", alpha=0.08,
                       label=None if v.min() < lo_b else "outside bounds")
    unit = variable_unit(name)
    ax.set_xlabel(f"{name} ({unit})" if unit != "-" else name)
    ax.set_ylabel("error (%)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(title or f"What-if sweep of {name}")
    fit_labels(fig)
    try:
        with atomic_file(path) as handle:
            fig.savefig(handle, format="png", dpi=110)
    finally:  # a file that cannot be written leaves no figure open
        plt.close(fig)
    return path


def sobol_figure(sobol: dict[str, dict[str, float]]) -> Figure:
    """First-order Sobol indices of each objective (grouped bars, one group per uncertain
    input): which tolerance matters (``design_point.json`` ``scatter.sobol``)."""
    names = list(next(iter(sobol.values())))
    objs = list(sobol)
    fig, ax = plt.subplots(figsize=(6.4, 3.4), layout="constrained")
    width = 0.8 / len(objs)
    pos = np.arange(len(names))
    for k, obj in enumerate(objs):
        ax.bar(pos + (k - (len(objs) - 1) / 2) * width, [sobol[obj][n] for n in names],
               width, label=obj)
    ax.set_xticks(pos, names, rotation=20, ha="right")
    ax.set_ylim(0.0, 1.0)
    ax.set_ylabel("first-order Sobol index")
    ax.legend(fontsize="small")
    return fig


def distribution_figure(blocks: dict[str, dict[str, Any]]) -> Figure:
    """Cumulative distributions of J_u, J_T and max(J_u, J_T) under the study's scatter,
    one line per design (``design_point.json`` ``robust`` / ``nominal.robust``
    ``distribution``: quantiles at 50 probabilities), overlaid per objective."""
    objs = [("J_u", "J_u"), ("J_T", "J_T"), ("J_max", "max(J_u, J_T)")]
    fig, axes = plt.subplots(1, 3, figsize=(9.6, 3.2), layout="constrained", sharey=True)
    for ax, (key, label) in zip(axes, objs):
        for name, block in blocks.items():
            dist = block["distribution"]
            q = np.array([np.inf if v is None else v for v in dist[key]], float)
            ax.step(100.0 * q, dist["probabilities"], where="post", label=name)
        ax.set_xlabel(f"{label} [%]")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("probability J <= x")
    axes[0].legend(fontsize="small")
    return fig


#: Axis labels of the predicted histories.
PREDICTION_LABELS = {"center_deflection": "center deflection  w [m]",
                     "mean_temperature": "mean temperature  T [K]"}


def prediction_figure(pred: Prediction) -> Figure:
    """Predicted prototype histories over prototype time (``hypate predict``): the measured
    model test mapped through the design point's nondimensionalization, its band (shaded)
    and the simulated prototype (dashed), one panel per measured history."""
    names = list(pred.histories)
    fig, axes = plt.subplots(1, len(names), figsize=(5.2 * len(names), 3.9),
                             layout="constrained", squeeze=False)
    for ax, name in zip(axes[0], names):
        h = pred.histories[name]
        ax.fill_between(pred.time, h.lower, h.upper, color="tab:blue", alpha=0.2,
                        label=f"band ±{h.half_width:.3g} {h.unit}")
        ax.plot(pred.time, h.predicted, "-", color="tab:blue", marker="o", ms=2.5,
                label="predicted from the model test")
        ax.plot(pred.time, h.simulated, "--", color="k", label="simulated prototype")
        out = ~h.inside
        if out.any():
            ax.plot(pred.time[out], h.simulated[out], "x", color="tab:red", ms=6,
                    label="simulated prototype outside the band")
        ax.set_xlabel("prototype time  t [s]")
        ax.set_ylabel(PREDICTION_LABELS[name])
        ax.set_title(f"{name.replace('_', ' ')}: {100.0 * h.in_band:.3g} % in band")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    return fig
