"""What each dissertation reproduction of ``hypate reproduce`` computes (issue 21): the
plan (:func:`plan`, one :class:`Item` per table in page order), the builders of the tables
(the deterministic scripts through :func:`_script`, the Ch. 9 optimizations per seed), the
tolerances and accepted findings of the Ch. 9 rows, and the :class:`Context` every builder
gets (its settings, and the run directories of the optimizations: read, resumed, run, or
awaited from the process pool of :mod:`.reproduce`).

The run itself (serial or pooled), its result and the files it writes live in
:mod:`.reproduce`; the run directories in :mod:`.ch9_runs`; the rows' comparisons in
:mod:`.comparison`.
"""
from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_EXCEPTION, Future, wait
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from hypate.scaling.workflow.analyses.whatif import at_sweep_point, evaluate_whatif
from hypate.scaling.workflow.campaigns.rundir import SWEEP_CSV
from hypate.scaling.workflow.vocabulary.problem import ScalingProblem
from hypate.studies.scripts import (
    ch7_benchmark,
    ch7_flutter,
    ch7_table7_3_modes,
    ch7_time_accuracy,
    ch8_effects,
    ch9_table9_3,
    ch9_tables,
)
from hypate.studies.scripts.ch9_runs import (
    ENVELOPE_CFD,
    EQ_9_2_VARIABLES,
    TUNNELS_9_2_3,
    XI4_CFD,
    Optimization,
    best_minmax,
    design_point,
    eq_9_2_design,
    j_u_optimum,
    names_9_1,
    names_9_2_2,
    names_9_2_2_cfd,
    names_9_2_3,
    names_9_2_4,
    names_9_2_4_cfd,
    no_studies,
    published_design_errors,
    run_directory,
    runs_root,
    xis_9_1,
    xis_9_2_2,
)
from hypate.studies.scripts.comparison import (
    Approx,
    Bound,
    Finding,
    NotCompared,
    side_by_side_seeds,
)

#: Seconds between two progress reports while a pooled job is awaited.
POLL_SECONDS = 5.0

#: Sec. 9.2.2 coarse bound on min max(J_u, J_T) over the admissible evaluations (fraction).
#: Before admissibility (issue 40) seed 0 measured 11.9 % on 36 evaluations of a 4 x 4 mesh;
#: with the Ti 6242 model held to its service temperature and property data the coarse
#: search measured 47.5 % at seed 0 (every design below 10 % of the dissertation runs the
#: model hundreds of kelvin past them: ch9_tables.FINDING_ADMISSIBILITY), so a seed-0 coarse
#: run above 50 % is a regression (the fast test's bound).
COARSE_9_2_2_BOUND = 0.50
#: Coarse Sec. 9.1 tolerances on Table 9.3's model parameters (fractions): measured at
#: seed 0 lambda_F +0.45 % and the thermal load +1.35 % off the prototype (the
#: dissertation's own models lie up to 0.8 % off it), so 2 % and 3 %; h/L is not resolved
#: by the coarse budget (14 % off).
COARSE_9_1_RTOL = {"lambda_F": 0.02, "DeltaT_NTx_L2/Dxx": 0.03}
#: Full Sec. 9.1 tolerance on Table 9.3's model parameters: 1 % (ch9_table9_3.RTOL_MODEL).
FULL_9_1_RTOL = ch9_table9_3.RTOL_MODEL
#: Agreement asked of the J_u optimum with Eq. 9.2 (percent of each design variable):
#: issue 8's acceptance (2 %); with equal Poisson ratios, 0.5 % (measured within 0.1 %).
EQ_9_2_TOLERANCE, EQ_9_2_TOLERANCE_EQUAL_NU = 2.0, 0.5

FINDING_POISSON = Finding(
    "Accepted finding (Sec. 9.1, issue 8): Eq. 9.1a leaves out Poisson's ratio (Inconel 718 "
    "0.29, Ti 6242 0.32; the von Karman membrane energy has A_12 = nu A_11), so for the "
    "Table 9.1 pair the optimum of J_u is not Eq. 9.2 (full mesh, Nelder-Mead: J_u 1.44 % "
    "at h -1.0 %, p_inf -3.0 %, Delta T -0.9 %); with equal ratios (sec9_1_xi2_equal_nu) "
    "the optimum lies within 0.1 % of Eq. 9.2.")
FINDING_WT5 = Finding(
    "Accepted finding (Sec. 9.2.3, issues 8 and 10): in this heating model WT5 is not "
    "heat-starved, so the radiant heater (Case 2) does not beat Case 1 there (full studies: "
    "Case 1 8.4-8.7 %, Case 2 seeded from Case 1's best designs 8.43 %); WT6 and WT7 show "
    "the dissertation's finding.")

#: progress(step, done, total): the callback of :class:`hypate.scaling.cli.progress.StepProgress`.
Progress = Callable[[str, int, int], None]


# -- what each reproduction computes -------------------------------------------------------------
@dataclass(frozen=True)
class Context:
    """Settings of one reproduction run, handed to every item."""

    quick: bool
    seeds: int
    out: Path
    progress: Progress | None = None
    #: Optimizations given to a process pool (``jobs > 1``): ``(name, seed) -> future`` of
    #: (warnings raised, seconds); :meth:`run_dirs` waits for one before it reads its
    #: finished run directory.
    pending: dict[tuple[str, int], Future] = field(default_factory=dict)
    #: Every job in the pool (optimizations and deterministic items): the progress counts
    #: them, and the first failure among them ends the run.
    jobs: list[Future] = field(default_factory=list)
    #: Warnings and seconds of the pooled optimizations the current item read, and the
    #: seconds it waited for them.
    carried: list[str] = field(default_factory=list)
    carried_seconds: list[float] = field(default_factory=list)
    waited_seconds: list[float] = field(default_factory=list)

    def report(self, step: str, done: int, total: int) -> None:
        if self.progress is not None:
            self.progress(step, done, total)

    def run_dirs(self, title: str, names: Sequence[str], seeds: int | None = None
                 ) -> list[dict[str, Path]]:
        """Run directories ``{name: dir}`` of ``names`` for every seed, or for the first
        ``seeds`` (run when missing). A pooled run's warnings and seconds are carried by the
        first item that reads it (a later one finds its directory finished)."""
        per_seed = []
        for seed in range(self.seeds if seeds is None else min(seeds, self.seeds)):
            dirs = {}
            for name in names:
                step = f"{title}: {name} seed {seed}"
                if (name, seed) in self.pending:
                    start = time.monotonic()
                    seen, seconds = self.wait_for(title, self.pending.pop((name, seed)))
                    self.waited_seconds.append(time.monotonic() - start)
                    self.carried.extend(seen)
                    self.carried_seconds.append(seconds)

                def tick(done: int, budget: int, _ev: Any, step: str = step) -> None:
                    self.report(step, done, budget)

                dirs[name] = run_directory(Optimization(name, self.quick),
                                           runs_root(self.out, self.quick, seed), seed, tick)
            per_seed.append(dirs)
        return per_seed

    def wait_for(self, title: str, future: Future) -> Any:
        """The result of a pooled job. Meanwhile the progress step ``"<title>: pool jobs
        finished"`` counts the pool's finished jobs, and a job that failed anywhere in the
        pool raises its error here at once (not when its table's turn comes)."""
        while True:
            failed = next((f for f in self.jobs if f.done() and f.exception() is not None),
                          None)
            if failed is not None:
                failed.result()  # raises the job's error
            if future.done():
                return future.result()
            self.report(f"{title}: pool jobs finished", sum(f.done() for f in self.jobs),
                        len(self.jobs))
            wait(self.jobs, timeout=POLL_SECONDS, return_when=FIRST_EXCEPTION)


@dataclass(frozen=True)
class Item:
    """One reproduction: a key (file names), its chapter and title, and how to build its
    table from a :class:`Context`."""

    key: str
    chapter: str
    title: str
    build: Callable[[Context], pd.DataFrame]
    seeded: bool = False
    #: The shipped studies the item reads, by ``quick`` (run per seed).
    studies: Callable[[bool], tuple[str, ...]] = no_studies
    #: Reads the first seed's runs of ``studies`` only (built in the main process, as a
    #: seeded item, once those runs finish; recorded with one seed).
    first_seed: bool = False

    @property
    def in_main(self) -> bool:
        """Built in the main process (it reads optimizations), not in the pool."""
        return self.seeded or self.first_seed


def _script(module: Any, full_config: Any = None) -> Callable[[Context], pd.DataFrame]:
    """A deterministic script's table: ``run(Config.coarse())`` or ``run(full_config)``."""

    def build(ctx: Context) -> pd.DataFrame:
        config = module.Config.coarse() if ctx.quick else (full_config or module.Config())
        return module.run(config).table

    return build


def _sec9_1_bo(ctx: Context) -> pd.DataFrame:
    """Table 9.3 (models found by the BO) and Fig. 9.3 (J_u < 4 %), per seed."""
    xis = xis_9_1(ctx.quick)
    coarse = "coarse budget (4 x 4 mesh, 50 evaluations)"
    rows_by_seed = []
    for dirs in ctx.run_dirs("Sec. 9.1", names_9_1(ctx.quick)):
        rows: list[tuple] = []
        for xi in xis:
            dp = design_point(dirs[f"sec9_1_xi{xi}"])
            sim = {s["name"]: s["model"] for s in dp.get("similarity", [])}
            ref = ch9_table9_3.OPTIMIZED[float(xi)]
            for n in ch9_table9_3.NAMES:
                if ctx.quick:
                    d = (Approx(ref[n], rel=COARSE_9_1_RTOL[n]) if n in COARSE_9_1_RTOL else
                         NotCompared(ref[n], f"{coarse} does not resolve h (seed 0: 14 % off)"))
                    note: object = f"{coarse}: ±{100 * COARSE_9_1_RTOL[n]:g} %" \
                        if n in COARSE_9_1_RTOL else None
                else:  # h/L and the thermal load sit ~1 % off where nu differs
                    d = Approx(ref[n], rel=FULL_9_1_RTOL)
                    note = None if n == "lambda_F" else FINDING_POISSON
                rows.append((f"Table 9.3 xi = {xi} model {n} (BO)", d, sim.get(n), note))
            J = 100.0 * float(dp["objectives"]["J_u"])
            fig = Bound("<", 4.0, "< 4 % (Fig. 9.3)")
            rows.append((f"xi = {xi} J_u at the design point (%)",
                         NotCompared(fig, f"{coarse} does not reach it") if ctx.quick else fig,
                         J, None if ctx.quick else FINDING_POISSON))
        if not ctx.quick:  # Eq. 9.1a complete: the BO alone recovers Eq. 9.2 (Fig. 9.4)
            study = Optimization("sec9_1_xi2_equal_nu").study()
            dp = design_point(dirs["sec9_1_xi2_equal_nu"])
            x = np.array([dp["design"][v] for v in EQ_9_2_VARIABLES])
            for v, dev in zip(EQ_9_2_VARIABLES, 100.0 * (x / eq_9_2_design(study, 2.0) - 1.0)):
                rows.append((f"equal nu, xi = 2: BO design {v} relative to Eq. 9.2 (%)",
                             Approx(0.0, abs=EQ_9_2_TOLERANCE), float(dev),
                             "Fig. 9.4: the BO recovers the analytical laws"))
        rows_by_seed.append(rows)
    return side_by_side_seeds(rows_by_seed)


def _sec9_1_optimum(ctx: Context) -> pd.DataFrame:
    """The optimum of J_u next to Eq. 9.2, Table 9.1 pair and equal Poisson ratios
    (deterministic: Nelder-Mead, once)."""
    rows: list[tuple] = []
    names = ("sec9_1_xi2", "sec9_1_xi2_equal_nu")
    for k, name in enumerate(names):
        ctx.report("Sec. 9.1 optimum of J_u (Nelder-Mead)", k, len(names))
        study = Optimization(name, ctx.quick).study()
        problem = ScalingProblem(study.spec)
        x0 = eq_9_2_design(study, 2.0)
        J0 = problem.errors(x0)["J_u"]
        x, J = j_u_optimum(problem, x0)
        equal = name.endswith("equal_nu")
        label = "equal nu" if equal else "Table 9.1 pair"
        tol = EQ_9_2_TOLERANCE_EQUAL_NU if equal else EQ_9_2_TOLERANCE
        note = ("Eq. 9.1a complete (model nu = 0.29)" if equal else FINDING_POISSON)
        rows.append((f"{label}: J_u at Eq. 9.2 (%)", None, 100.0 * J0))
        rows.append((f"{label}: J_u at its optimum (%)", Bound("<", 4.0, "< 4 % (Fig. 9.3)"),
                     100.0 * J))
        for v, dev in zip(EQ_9_2_VARIABLES, 100.0 * (x / x0 - 1.0)):
            rows.append((f"{label}: optimum {v} relative to Eq. 9.2 (%)",
                         Approx(0.0, abs=tol), float(dev), note))
    ctx.report("Sec. 9.1 optimum of J_u (Nelder-Mead)", len(names), len(names))
    return side_by_side_seeds([rows])


def _sec9_2_2(ctx: Context) -> pd.DataFrame:
    """Table 9.8 / Fig. 9.9: the ideal tunnel (design point and best min-max error)."""
    xis = xis_9_2_2(ctx.quick)
    coarse = "coarse budget (4 x 4 mesh, 36 evaluations): one of many near-optimal designs"
    published = {} if ctx.quick else {
        xi: published_design_errors("9.8", f"xi{xi}") for xi in xis}
    rows_by_seed = []
    for dirs in ctx.run_dirs("Sec. 9.2.2", names_9_2_2(ctx.quick)):
        rows: list[tuple] = []
        for xi in xis:
            path = dirs[f"sec9_2_2_xi{xi}"]
            dp = design_point(path)
            found = ch9_tables.design_point_rows(
                path, dp, "9.8", f"xi{xi}", None if ctx.quick else ch9_tables.FINDING_SEC9_2_MODEL)
            if ctx.quick:
                found = [(r[0], NotCompared(r[1], coarse) if r[1] is not None else None,
                          *r[2:]) for r in found]
            else:
                found += ch9_tables.published_rows("9.8", f"xi{xi}", published[xi], dp)
            rows += found
            bound = Bound("<", 10.0, "< 10 % (Sec. 9.2.2)")
            rows.append((f"Table 9.8 xi{xi} min over admissible evaluations of max(J_u, J_T) "
                         "(%)", bound, 100.0 * best_minmax(path),
                         ch9_tables.FINDING_ADMISSIBILITY))
        rows_by_seed.append(rows)
    return side_by_side_seeds(rows_by_seed, rtol=ch9_tables.RTOL)


#: The two fluid models of the Sec. 9.2.2 xi = 4 study: pt-bl with Eckert heating (the
#: shipped study) and the CFD ROM of OpenFOAM snapshots (its ``_cfd`` variant, issue 44).
FLUID_STUDIES_9_2_2 = (("pt-bl + Eckert", "sec9_2_2_xi4"), ("CFD ROM", XI4_CFD))


def _model_peak_temperature(whatif: dict[str, Any]) -> float | None:
    """The model's peak wall temperature (K) of an :func:`evaluate_whatif` record (None:
    the model failed)."""
    return ((whatif.get("responses") or {}).get("model") or {}).get("max_wall_temperature")


def _sec9_2_2_fluids(ctx: Context) -> pd.DataFrame:
    """Table 9.8's xi = 4 design evaluated with both fluid models, side by side (one
    ``hypate whatif`` each at full resolution; not run with ``--quick``)."""
    design = ch9_tables.published_design("9.8", "xi4")
    bound = Bound("<", 10.0, "< 10 % (Sec. 9.2.2, with the dissertation's CFD ROM)")
    rows: list[tuple] = []
    J: dict[str, dict[str, float]] = {}
    for label, name in FLUID_STUDIES_9_2_2:
        quantity = f"Table 9.8 xi4 design, {label}"
        if ctx.quick:
            rows += [(f"{quantity}: {o} (%)",
                      NotCompared(bound, "not run with --quick (full resolution, about a minute)"),
                      None) for o in ("J_u", "J_T")]
            continue
        res = evaluate_whatif(Optimization(name).study(), design)
        obj = res["objectives"] or {}
        J[label] = {o: 100.0 * obj[o] for o in ("J_u", "J_T") if obj.get(o) is not None}
        rows += [(f"{quantity}: {o} (%)", bound, J[label].get(o),
                  ch9_tables.FINDING_ADMISSIBILITY) for o in ("J_u", "J_T")]
        rows.append((f"{quantity}: model's peak temperature (K)", None,
                     _model_peak_temperature(res), res["status"]))
    (a, _), (b, _) = FLUID_STUDIES_9_2_2
    for o in ("J_u", "J_T"):
        if o in J.get(a, {}) and o in J.get(b, {}):
            rows.append((f"Table 9.8 xi4 design: {o}, {b} minus {a} (points)", None,
                         J[b][o] - J[a][o], "the fluid model's share of the error"))
    return side_by_side_seeds([rows], rtol=ch9_tables.RTOL)


def _sec9_2_3(ctx: Context) -> pd.DataFrame:
    """Fig. 9.13 / Tables 9.9-9.10: Case 2 (radiant heater) against Case 1 in WT5-WT7."""
    published = {} if ctx.quick else {
        (table, t): published_design_errors(table, t)
        for t in TUNNELS_9_2_3 for table in ("9.9", "9.10")}
    rows_by_seed = []
    for dirs in ctx.run_dirs("Sec. 9.2.3", names_9_2_3(ctx.quick)):
        rows: list[tuple] = []
        for t in TUNNELS_9_2_3:
            J = {c: 100.0 * best_minmax(dirs[f"sec9_2_3_case{c}_{t}"]) for c in (1, 2)}
            T = t.upper()
            rows.append((f"{T} Case 1 min max(J_u, J_T) (%)", None, J[1]))
            rows.append((f"{T} Case 2 min max(J_u, J_T) (%)", None, J[2]))
            rows.append((f"{T} Case 2 better than Case 1 (Case 1 - Case 2, % points)",
                         Bound(">", 0.0, "Case 2 better (Fig. 9.13)"), J[1] - J[2],
                         FINDING_WT5 if t == "wt5" else
                         ("coarse: 36 evaluations per case" if ctx.quick else None)))
            if not ctx.quick:
                for c, table in ((1, "9.9"), (2, "9.10")):
                    path = dirs[f"sec9_2_3_case{c}_{t}"]
                    dp = design_point(path)
                    rows += ch9_tables.design_point_rows(path, dp, table, t,
                                                         ch9_tables.FINDING_SEC9_2_MODEL)
                    rows += ch9_tables.published_rows(table, t, published[table, t], dp)
        rows_by_seed.append(rows)
    return side_by_side_seeds(rows_by_seed, rtol=ch9_tables.RTOL)


def _sec9_2_4(ctx: Context) -> pd.DataFrame:
    """Table 9.11: errors over the flight envelope in WT7 (the sweep; full run only)."""
    if ctx.quick:
        rows = [(f"Table 9.11 error at M = {m:g}, H = {h:g} km (%)",
                 NotCompared(ref[i], "not run with --quick (25 optimizations, hours)"), None)
                for m, ref in ch9_tables.TABLE_9_11.items()
                for i, h in enumerate(ch9_tables.ALTITUDES_KM)]
        return side_by_side_seeds([rows], rtol=ch9_tables.RTOL)
    rows_by_seed = []
    for dirs in ctx.run_dirs("Sec. 9.2.4", names_9_2_4(ctx.quick)):
        path = dirs["sec9_2_4_envelope"]
        errors: dict[tuple[float, float], float] = {}
        rows = (ch9_tables.envelope_rows(path, errors, ch9_tables.FINDING_SEC9_2_MODEL)
                + ch9_tables.envelope_temperature_rows(path)
                if (path / SWEEP_CSV).exists() else [])
        rows_by_seed.append(rows + ch9_tables.envelope_trend_rows(errors))
    return side_by_side_seeds(rows_by_seed, rtol=ch9_tables.RTOL)


def envelope_fluid_rows(path: Path, progress: Progress | None = None) -> list[tuple]:
    """Rows of :func:`_sec9_2_4_fluids` from a ``pt-bl`` + Eckert envelope sweep directory
    (``sweep.csv`` and each point's ``design_point.json``): each finished point's design
    evaluated on the CFD ROM at that point's flight condition, then the mean and the
    largest difference from the sweep's own J_s (points) and how many of the designs stay
    admissible on the CFD ROM (with the model's peak temperatures there)."""
    done = pd.read_csv(path / SWEEP_CSV).dropna(subset=["J_s"])
    cfd = Optimization(ENVELOPE_CFD).study()
    rows: list[tuple] = []
    diffs: list[float] = []
    admissible: list[bool] = []
    peaks: list[float] = []
    for i, (_, r) in enumerate(done.iterrows()):
        if progress is not None:
            progress("Sec. 9.2.4: envelope designs on the CFD ROM", i, len(done))
        label, mach, h_km = str(r["label"]), float(r["mach"]), float(r["altitude"]) / 1000.0
        res = evaluate_whatif(at_sweep_point(cfd, label),
                              design_point(path / label)["design"])
        J_s = (res["objectives"] or {}).get("J_s")
        own = 100.0 * float(r["J_s"])
        rows.append((f"Table 9.11 M = {mach:g}, H = {h_km:g} km: the pt-bl design on the CFD "
                     "ROM, J_s (%)", None, None if J_s is None else 100.0 * J_s,
                     f"the pt-bl + Eckert sweep's J_s there: {own:.2f} %" if J_s is not None
                     else res["message"]))
        if J_s is not None:
            diffs.append(100.0 * J_s - own)
        admissible.append(res.get("admissible") is True)
        peak = _model_peak_temperature(res)
        if peak is not None:
            peaks.append(peak)
    if diffs:
        what = "Table 9.11 envelope designs: J_s, CFD ROM minus pt-bl + Eckert"
        rows.append((f"{what}, mean over the conditions (points)", None,
                     float(np.mean(diffs)), f"{len(diffs)} of {len(done)} designs ran on both"))
        rows.append((f"{what}, largest magnitude (points)", None,
                     diffs[int(np.argmax(np.abs(diffs)))],
                     "the fluid model's share of the envelope's errors"))
    if admissible:
        rows.append(("Table 9.11 envelope designs on the CFD ROM: admissible designs", None,
                     sum(admissible), f"of {len(admissible)}" + (
                         f"; the model's peak temperature {min(peaks):.0f}-{max(peaks):.0f} K"
                         if peaks else "")))
    return rows


def _sec9_2_4_fluids(ctx: Context) -> pd.DataFrame:
    """Table 9.11's envelope with both fluid models: the first seed's ``pt-bl`` + Eckert
    sweep's design of each flight condition evaluated on the CFD ROM at that condition
    (:func:`envelope_fluid_rows`: 25 full-resolution what-ifs, about 20 minutes; full run
    only). What the fluid model alone changes in the envelope's errors, without a second
    25-point sweep on the ROM."""
    if ctx.quick:
        return side_by_side_seeds([[(
            "Table 9.11 envelope designs on the CFD ROM: J_s, CFD ROM minus pt-bl + Eckert "
            "(points)", NotCompared(None, "not run with --quick (the 25-point envelope "
                                    "sweep, hours, then 25 what-ifs)"),
            None)]], rtol=ch9_tables.RTOL)
    path = ctx.run_dirs("Sec. 9.2.4", names_9_2_4(ctx.quick), seeds=1)[0]["sec9_2_4_envelope"]
    return side_by_side_seeds([envelope_fluid_rows(path, ctx.progress)], rtol=ch9_tables.RTOL)


def _on_the_cfd_rom(rows: list[tuple], prefix: str) -> list[tuple]:
    """``rows`` of a CFD-ROM run, their quantities marked: ``prefix`` -> ``prefix, CFD ROM``."""
    return [(r[0].replace(prefix, f"{prefix}, CFD ROM", 1), *r[1:]) for r in rows]


def _not_run_quick(quantity: str, reference: object, why: str) -> pd.DataFrame:
    """The one unjudged row of a CFD-ROM item under ``--quick`` (nothing runs)."""
    return side_by_side_seeds([[(quantity, NotCompared(reference, f"not run with --quick "
                                                      f"({why})"), None)]],
                              rtol=ch9_tables.RTOL)


def _sec9_2_2_cfd(ctx: Context) -> pd.DataFrame:
    """Table 9.8's xi = 4 study optimized on the CFD ROM (``sec9_2_2_xi4_cfd``, per seed;
    about 25 min a seed on one worker at c5ff16e; full run only): its design point against
    Table 9.8, and its best admissible max(J_u, J_T) and design-point errors beside the
    ``pt-bl`` + Eckert run of the same seed and budget (the fluid model's share in the
    optimum)."""
    bound = Bound("<", 10.0, "< 10 % (Sec. 9.2.2, with the dissertation's CFD ROM)")
    best = "Table 9.8 xi4 min over admissible evaluations of max(J_u, J_T)"
    if ctx.quick:
        return _not_run_quick(f"{best}, CFD ROM (%)", bound,
                              "the study on the CFD ROM, about 25 min a seed")
    rows_by_seed = []
    for dirs in ctx.run_dirs("Sec. 9.2.2 CFD ROM", names_9_2_2_cfd(ctx.quick)):
        cfd, ptbl = dirs[XI4_CFD], dirs["sec9_2_2_xi4"]
        dp, dp_ptbl = design_point(cfd), design_point(ptbl)
        rows = _on_the_cfd_rom(ch9_tables.design_point_rows(
            cfd, dp, "9.8", "xi4", ch9_tables.FINDING_SEC9_2_MODEL), "Table 9.8 xi4")
        J = {k: 100.0 * best_minmax(d) for k, d in (("cfd", cfd), ("ptbl", ptbl))}
        rows.append((f"{best}, CFD ROM (%)", bound, J["cfd"], ch9_tables.FINDING_ADMISSIBILITY))
        if np.isfinite(J["cfd"]) and np.isfinite(J["ptbl"]):  # inf: no admissible evaluation
            rows.append((f"{best}: CFD ROM minus pt-bl + Eckert (points)", None,
                         J["cfd"] - J["ptbl"], f"pt-bl + Eckert: {J['ptbl']:.2f} %, same seed "
                         "and budget"))
        for o in ("J_u", "J_T"):
            a, b = dp.get("objectives", {}).get(o), dp_ptbl.get("objectives", {}).get(o)
            if a is not None and b is not None:
                rows.append((f"Table 9.8 xi4 {o} at the design point: CFD ROM minus pt-bl + "
                             "Eckert (points)", None, 100.0 * (float(a) - float(b)),
                             "each run's own design point"))
        rows_by_seed.append(rows)
    return side_by_side_seeds(rows_by_seed, rtol=ch9_tables.RTOL)


def _sec9_2_4_cfd(ctx: Context) -> pd.DataFrame:
    """Table 9.11's envelope swept on the CFD ROM (``sec9_2_4_envelope_cfd``, the first
    seed; about three times the ``pt-bl`` sweep's time, some 5 h of one core; full run
    only): its errors against Table 9.11, each condition's difference from the ``pt-bl`` +
    Eckert sweep of the same seed, and the text's trend on the CFD errors."""
    if ctx.quick:
        return _not_run_quick("Table 9.11 error, CFD ROM (%)", None,
                              "25 optimizations on the CFD ROM, hours")
    dirs = ctx.run_dirs("Sec. 9.2.4 CFD ROM", names_9_2_4_cfd(ctx.quick), seeds=1)[0]
    errors: dict[tuple[float, float], float] = {}
    ptbl: dict[tuple[float, float], float] = {}
    rows = _on_the_cfd_rom(ch9_tables.envelope_rows(
        dirs[ENVELOPE_CFD], errors, ch9_tables.FINDING_SEC9_2_MODEL), "Table 9.11 error")
    ch9_tables.envelope_rows(dirs["sec9_2_4_envelope"], ptbl)
    diffs = {c: errors[c] - ptbl[c] for c in errors if c in ptbl}
    if diffs:
        what = "Table 9.11 error: CFD ROM sweep minus pt-bl + Eckert sweep"
        worst = max(diffs, key=lambda c: abs(diffs[c]))
        rows.append((f"{what}, mean over the conditions (points)", None,
                     float(np.mean(list(diffs.values()))),
                     f"{len(diffs)} conditions finished in both sweeps"))
        rows.append((f"{what}, largest magnitude (points)", None, diffs[worst],
                     f"at M = {worst[0]:g}, H = {worst[1]:g} km"))
    rows += _on_the_cfd_rom(ch9_tables.envelope_temperature_rows(dirs[ENVELOPE_CFD])
                            + ch9_tables.envelope_trend_rows(errors), "Table 9.11")
    return side_by_side_seeds([rows], rtol=ch9_tables.RTOL)


def plan() -> list[Item]:
    """Every reproduction, in page order."""
    flutter_full = ch7_flutter.Config(time_domain=True)
    return [
        Item("ch7_table7_3_modes", "Ch. 7", "Table 7.3: natural frequencies of the clamped "
             "panel", _script(ch7_table7_3_modes)),
        Item("ch7_flutter", "Ch. 7", "Sec. 7.2.3: flutter of the heated panel",
             _script(ch7_flutter, flutter_full)),
        Item("ch7_benchmark", "Ch. 7", "Sec. 7.3: aerothermoelastic benchmark (snap-through "
             "onset)", _script(ch7_benchmark)),
        Item("ch7_time_accuracy", "Ch. 7", "Sec. 7.3.2.2 / Fig. 7.17: time and energy "
             "accuracy of S1 and S2", _script(ch7_time_accuracy)),
        Item("ch8_effects", "Ch. 8", "Ch. 8: boundary layer, aspect ratio, flow angle and "
             "orthotropy (trends)", _script(ch8_effects)),
        Item("ch9_table9_3", "Ch. 9", "Table 9.3: similarity parameters (Eq. 9.2 models)",
             _script(ch9_table9_3)),
        Item("sec9_1_bo", "Ch. 9", "Sec. 9.1: the Bayesian optimization recovers Table 9.3",
             _sec9_1_bo, seeded=True, studies=names_9_1),
        Item("sec9_1_optimum", "Ch. 9", "Sec. 9.1: the optimum of J_u and Eq. 9.2 "
             "(Poisson's ratio)", _sec9_1_optimum),
        Item("sec9_2_2", "Ch. 9", "Sec. 9.2.2 / Table 9.8: the ideal tunnel", _sec9_2_2,
             seeded=True, studies=names_9_2_2),
        Item("sec9_2_2_fluids", "Ch. 9", "Sec. 9.2.2: Table 9.8's xi = 4 design with both "
             "fluid models (pt-bl + Eckert, CFD ROM)", _sec9_2_2_fluids),
        Item("sec9_2_2_cfd", "Ch. 9", "Sec. 9.2.2 / Table 9.8: the xi = 4 study optimized on "
             "the CFD ROM, beside pt-bl + Eckert", _sec9_2_2_cfd, seeded=True,
             studies=names_9_2_2_cfd),
        Item("sec9_2_3", "Ch. 9", "Sec. 9.2.3 / Fig. 9.13: realistic tunnels, Case 2 against "
             "Case 1", _sec9_2_3, seeded=True, studies=names_9_2_3),
        Item("sec9_2_4", "Ch. 9", "Sec. 9.2.4 / Table 9.11: errors over the flight envelope",
             _sec9_2_4, seeded=True, studies=names_9_2_4),
        Item("sec9_2_4_fluids", "Ch. 9", "Sec. 9.2.4: the first seed's envelope designs "
             "with both fluid models (pt-bl + Eckert, CFD ROM)", _sec9_2_4_fluids,
             studies=names_9_2_4, first_seed=True),
        Item("sec9_2_4_cfd", "Ch. 9", "Sec. 9.2.4 / Table 9.11: the envelope swept on the CFD "
             "ROM (first seed), beside pt-bl + Eckert", _sec9_2_4_cfd,
             studies=names_9_2_4_cfd, first_seed=True),
    ]
