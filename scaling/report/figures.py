"""The report's matplotlib figures (PNG, embedded in the page as ``data:`` URIs).

Run figures take a :class:`~hypate.scaling.report.rundata.RunData` and return an HTML
``<figure>`` (empty string when the run has nothing to plot), saving the PNG as
``figures/<name>.png`` too: the Pareto front with the classical baseline (Fig. 9.9 / 9.13
style), the hypervolume history (two objectives) or best-J history (one objective), and the
nondimensional response of the prototype vs the design-point model (Figs. 9.10, 9.11, 9.14,
9.15 style). :func:`plot_sweep` draws the what-if sweep of ``hypate whatif --sweep``.

This is the one module of the report that imports pyplot (Agg backend: no display needed).
"""
from __future__ import annotations

import base64
import html
import io
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from hypate.scaling.engine.pareto import hypervolume, non_dominated_mask  # noqa: E402
from hypate.scaling.report.rundata import RunData  # noqa: E402
from hypate.scaling.workflow.variables import variable_unit  # noqa: E402
from hypate.solvers.coupling.response import Response  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

__all__ = ["MISMATCH_THRESHOLD", "HV_REFERENCE", "embed_png", "figure_html",
           "pareto_figure", "history_figure", "response_figure", "plot_sweep",
           "close_figures"]

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


def figure_html(fig: Figure, run: RunData, name: str, caption: str) -> str:
    """Save ``fig`` as ``figures/<name>.png`` and return it embedded with a caption.

    The figure is closed afterwards.
    """
    path = run.figure_path(name)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    data = buf.getvalue()
    path.write_bytes(data)
    return (f'<figure>{embed_png(data, caption)}<figcaption>{html.escape(caption)}'
            f"</figcaption></figure>")


def pareto_figure(run: RunData) -> str:
    """Pareto front of a two-objective run: all successful evaluations (coloured by
    iteration), the Pareto set, the design point and the classical baseline.

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
    F = ok[objs].to_numpy(float)
    fig, ax = plt.subplots(figsize=(6.0, 4.6))
    it = ok["iteration"].to_numpy() if "iteration" in ok else np.zeros(len(ok))
    init = it <= 0
    ax.scatter(F[init, 0], F[init, 1], s=18, c="0.65", label="initial samples")
    if (~init).any():
        sc = ax.scatter(F[~init, 0], F[~init, 1], s=18, c=it[~init], cmap="viridis",
                        label="BO iterations")
        fig.colorbar(sc, ax=ax, label="iteration")
    mask = non_dominated_mask(F)
    P = F[mask][np.argsort(F[mask][:, 0])]
    ax.step(P[:, 0], P[:, 1], where="post", color="tab:red", lw=1.2)
    ax.scatter(P[:, 0], P[:, 1], s=36, facecolors="none", edgecolors="tab:red",
               label="Pareto set")
    pobj = (run.point or {}).get("objectives") or {}
    if all(isinstance(pobj.get(o), (int, float)) for o in objs):
        ax.scatter([pobj[objs[0]]], [pobj[objs[1]]], marker="*", s=220, c="gold",
                   edgecolors="k", zorder=5, label="design point")
    cobj = (run.classical or {}).get("objectives") or {}
    if all(isinstance(cobj.get(o), (int, float)) for o in objs):
        ax.scatter([cobj[objs[0]]], [cobj[objs[1]]], marker="s", s=70, c="tab:blue",
                   edgecolors="k", zorder=5, label="classical baseline")
    ax.axvline(MISMATCH_THRESHOLD, color="0.5", ls=":", lw=0.8)
    ax.axhline(MISMATCH_THRESHOLD, color="0.5", ls=":", lw=0.8)
    ax.set_xlabel(objs[0])
    ax.set_ylabel(objs[1])
    if np.nanmax(F) / max(np.nanmin(F[F > 0]) if (F > 0).any() else 1.0, 1e-300) > 100:
        ax.set_xscale("log")
        ax.set_yscale("log")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title("Pareto front (dotted: 10 % error)")
    return figure_html(fig, run, "pareto_front",
                       f"Pareto front: {objs[0]} vs {objs[1]} of all successful evaluations, "
                       "the Pareto set, the design point and the classical baseline.")


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
    fig, ax = plt.subplots(figsize=(6.0, 3.8))
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
        ax.set_ylabel("hypervolume")
        ref_text = "[1, 1]" if ref is HV_REFERENCE else \
            f"the nadir [{ref[0]:.3g}, {ref[1]:.3g}]"
        title = f"Hypervolume history (reference point {ref_text})"
        name = "hypervolume_history"
    else:
        f = np.where(good, F[:, 0], np.nan)
        best = np.fmin.accumulate(np.where(np.isnan(f), np.inf, f))
        best[~np.isfinite(best)] = np.nan
        ax.scatter(n, f, s=12, c="0.6", label=f"{objs[0]} per evaluation")
        ax.plot(n, best, drawstyle="steps-post", color="tab:blue", label=f"best {objs[0]}")
        ax.set_ylabel(objs[0])
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
    steps = None
    dt_p = None
    if run.study is not None:
        steps = run.study.spec.simulation.steps
        dt_p = run.study.spec.simulation.time_step
    elif proto is not None and len(proto.times) > 1:
        steps = len(proto.times) - 1
        dt_p = proto.times[1] - proto.times[0]
    fig, axes = plt.subplots(1, 2, figsize=(10.0, 3.9))
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
    axes[1].set_ylabel("mean temperature / stagnation temperature  T/T0")
    for ax in axes:
        ax.set_xlabel("nondimensional time  t / t_end")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    axes[0].set_title("structural response")
    axes[1].set_title("thermal response")
    fig.tight_layout()
    note = "" if model is not None else " (no design-point response in the run directory)"
    return figure_html(fig, run, "response",
                       "Nondimensional response of the prototype and the design-point model "
                       "at matched nondimensional time (Figs. 9.10, 9.11); triangles mark "
                       "steps where the linearized stability analysis reports flutter or "
                       f"divergence{note}.")


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
    fig.tight_layout()
    fig.savefig(path, format="png", dpi=110)
    plt.close(fig)
    return path

