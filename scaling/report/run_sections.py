"""The report's run-health sections: *Run statistics* (evaluations, failures grouped by reason,
why the run stopped, wall time, the numerical environment), *Across seeds* (one seed of a
``--seeds`` run against the spread) and *Warnings* (the distinct solver warnings)."""
from __future__ import annotations

import html
import re
from typing import Any

import numpy as np
from hypate.scaling.report.blocks import Raw, Section, dl, fmt, html_table, pct
from hypate.scaling.report.rundata import RunData
from hypate.scaling.workflow.campaigns.rundir import (
    describe_occurrences,
)

_NUM = re.compile(r"[-+]?\d+(\.\d+)?([eE][-+]?\d+)?")


def statistics_section(run: RunData) -> Section:
    df = run.evaluations
    n = len(df)
    stats = (run.point or {}).get("statistics") or {}
    failed = df[df["status"] != "ok"] if n else df
    items = [("evaluations", fmt(n)), ("successful", fmt(n - len(failed))),
             ("failed", fmt(len(failed)))]
    if n and "iteration" in df and len(failed):
        it_f = failed["iteration"].to_numpy()
        after = int((df["iteration"].to_numpy() >= 1).sum())
        items.append(("failed in the initial design / after it",
                      f"{int((it_f <= 0).sum())} / {int((it_f >= 1).sum())} of {after} "
                      "(after it, the classifier of failures steers the proposals)"))
    stopping = (run.point or {}).get("stopping")
    if stopping:
        ev = stopping.get("evidence") or {}
        rule = stopping.get("rule") or {}
        if stopping.get("reason") == "converged":
            why = (f"converged before iteration {stopping.get('iteration')}: the design point "
                   f"improved by {100 * (ev.get('improvement') or 0.0):.2g} % over the last "
                   f"{rule.get('patience')} iterations, its leave-one-out z = "
                   + ", ".join(f"{z:+.2g}" for z in ev.get("z") or [])
                   + ", the largest predicted improvement "
                   f"{100 * (ev.get('predicted_gain') or 0.0):.2g} %")
        else:
            why = ("the iteration cap was reached before the stopping rule held (last check: "
                   + ", ".join(f"{k} {'yes' if ev.get(k) else 'no'}" for k in
                               ("stalled", "surrogate_knows_it", "no_promise_left")) + ")")
        items.append(("why the run stopped", html.escape(why)))
    if n:
        sec = df["seconds"].to_numpy(float)
        items.append(("median time per evaluation", f"{np.median(sec):.3g} s"))
        items.append(("total evaluation time", f"{np.sum(sec):.4g} s"))
    if stats.get("wall_seconds") is not None:
        items.append(("wall time", f"{float(stats['wall_seconds']):.4g} s"))
    elif run.interrupted:
        items.append(("wall time", "not recorded (interrupted run)"))
    if stats.get("pareto_size") is not None:
        items.append(("Pareto-set size", fmt(stats["pareto_size"])))
    low = run.lower_fidelity
    if len(low):  # multi-fidelity: the tables and figures are the top level's
        for name, grp in low.groupby("fidelity_name"):
            items.append((f"lower-fidelity evaluations ({html.escape(str(name))})",
                          f"{len(grp)}, {np.sum(grp['seconds'].to_numpy(float)):.4g} s "
                          "(not in the tables and figures, which are the top level's)"))
    for env in run.environments:
        items.append(("numerical environment", html.escape(describe_environment(env))))
    if n and "iteration" in df:
        it = df["iteration"].to_numpy()
        opt = run.study.optimizer if run.study is not None else None
        if opt is not None and opt.polish:
            polish = it > run.study.iteration_cap
            items.append(("classical seed / initial / BO / polish evaluations",
                          f"{int((it < 0).sum())} / {int((it == 0).sum())} / "
                          f"{int(((it > 0) & ~polish).sum())} / {int(polish.sum())}"))
        else:
            items.append(("classical seed / initial / BO evaluations",
                          f"{int((it < 0).sum())} / {int((it == 0).sum())} / "
                          f"{int((it > 0).sum())}"))
    body = dl(items)
    if len(failed):
        groups: dict[tuple[str, str], list[int]] = {}
        examples: dict[tuple[str, str], str] = {}
        for i, r in failed.iterrows():
            msg = str(r.get("message", "") or "")
            key = (str(r["status"]), _NUM.sub("#", msg)[:160])
            groups.setdefault(key, []).append(int(i))
            examples.setdefault(key, msg)
        rows = [(st, len(idx), ", ".join(map(str, idx[:12])) + (" ..." if len(idx) > 12 else ""),
                 examples[(st, k)][:300])
                for (st, k), idx in sorted(groups.items(), key=lambda kv: -len(kv[1]))]
        body += "<h3>Failures by reason</h3>" + html_table(
            ["status", "count", "evaluations", "example message"], rows)
    return Section("Run statistics", body)


def seeds_section(run: RunData) -> Section | None:
    """One seed of a ``--seeds`` run: its design point next to the spread over the seeds."""
    data = run.seeds
    if not data:
        return None
    this, spread = data["this"], data.get("spread") or {}
    rows, classes = [], []
    for group, as_pct in (("objectives", True), ("design", False), ("similarity", True)):
        for name, st in (spread.get(group) or {}).items():
            mine = (this.get(group) or {}).get(name)
            show = pct if as_pct else fmt
            label = f"{name} (relative difference)" if group == "similarity" else name
            rows.append((label, Raw(show(mine)), Raw(show(st.get("median"))),
                         Raw(show(st.get("min"))), Raw(show(st.get("max")))))
            classes.append("")
    seeds = ", ".join(f"{r['seed']} ({r['status']})" for r in data.get("seeds", []))
    body = (f"<p>This run is seed {this['seed']} of a <code>--seeds</code> run; "
            f"{data.get('finished', 0)} of {len(data.get('seeds', []))} seeds have a design "
            f"point (seeds: {html.escape(seeds)}). A design whose spread is wide depends on "
            "the optimizer's seed: read the median and the range, not one seed.</p>")
    body += html_table(["quantity", "this seed", "median over seeds", "min", "max"],
                       rows, classes)
    return Section("Across seeds", body)



def describe_environment(env: dict[str, Any]) -> str:
    """``Python 3.11.7, numpy 2.4.6, ..., BLAS openblas 0.3.31 Haswell`` (one line)."""
    pkgs = ", ".join(f"{k} {v}" for k, v in (env.get("packages") or {}).items() if v)
    blas = "; ".join(f"{b.get('internal_api')} {b.get('version')} {b.get('architecture')}"
                     for b in env.get("blas") or [])
    simd = env.get("simd")
    cpu = (f"; CPU {env['cpu']}" + ("" if simd is None else
                                    " (AVX-512)" if "AVX512F" in simd else " (no AVX-512)")
           if env.get("cpu") else "")
    return (f"Python {env.get('python')}, hypate {env.get('hypate')}, {pkgs}"
            + (f"; BLAS {blas}" if blas else "") + cpu)


#: Distinct warnings listed in the Warnings section (the rest are counted below it).
REPORT_WARNINGS = 30


def warnings_section(run: RunData) -> Section | None:
    """The "Warnings" section: one row per distinct warning (the prototype's and each
    evaluation's, as recorded), with the evaluations it occurred in and its count."""
    tally = run.warnings
    if not tally:
        return None
    rows = [(text[:300], describe_occurrences(where), n)
            for text, where, n in tally[:REPORT_WARNINGS]]
    body = ("<p>Warnings raised by the solvers during the prototype's simulation and the "
            "evaluations (evaluation ids as in <code>evaluations.csv</code>, whose "
            "<code>warnings</code> column lists each evaluation's).</p>"
            + html_table(["warning", "where", "times"], rows))
    if len(tally) > REPORT_WARNINGS:
        body += f"<p>... and {len(tally) - REPORT_WARNINGS} more distinct warnings.</p>"
    return Section("Warnings", body)
