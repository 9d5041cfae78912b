"""The Ch. 9 optimizations of ``hypate reproduce`` (issue 21) as run directories: the shipped
studies as they are or coarsened (:class:`Optimization`, :data:`COARSE_9_1`,
:data:`COARSE_9_2`), where each seed's run lives (:func:`runs_root`), how a run directory is
obtained (:func:`run_directory`: read, resumed or run) and read (:func:`design_point`,
:func:`best_minmax`), which studies each Ch. 9 reproduction reads (``names_9_*``), the
Sec. 9.1 references computed without the BO (:func:`eq_9_2_design`, :func:`j_u_optimum`) and
the dissertation's Sec. 9.2 design points evaluated by hypate (:func:`published_design_errors`).

The reproduction runner (:mod:`.reproduce`) and the slow Ch. 9 tests both go through
:func:`run_directory`, so they read the same results.
"""
from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from hypate.scaling.workflow.analyses.whatif import evaluate_whatif
from hypate.scaling.workflow.campaigns.integrity import missing_outputs, verify_run
from hypate.scaling.workflow.campaigns.run import run_study
from hypate.scaling.workflow.campaigns.rundir import (
    DESIGN_POINT_JSON,
    EVALUATIONS_CSV,
    STORE,
    SWEEP_JSON,
)
from hypate.scaling.workflow.campaigns.sweep import run_sweep
from hypate.scaling.workflow.vocabulary.derived import study_data, sweep_points
from hypate.scaling.workflow.vocabulary.problem import ScalingProblem
from hypate.scaling.workflow.vocabulary.shipped import shipped
from hypate.scaling.workflow.vocabulary.similarity import analytical_scaling
from hypate.scaling.workflow.vocabulary.study import Study, load_study, parse_study
from hypate.solvers.aero.factory import ROM_PREFIX
from hypate.studies.scripts.ch9_tables import published_design, study_of
from scipy.optimize import minimize

#: Coarse Sec. 9.1 variant: 4 x 4 mesh, 40 of the 100 steps, 10 + 40 evaluations of BO
#: without the shipped studies' final polish (about 15 s each here).
COARSE_9_1 = {"simulation": {"mesh": [4, 4], "steps": 40},
              "optimizer": {"initial_samples": 10, "iterations": 40, "polish": 0}}
#: Coarse Sec. 9.2 variant: 4 x 4 mesh, 8 steps of 20 s (the same 160 s), 12 + 24
#: evaluations (about 12 s each here).
COARSE_9_2 = {"simulation": {"mesh": [4, 4], "steps": 8, "time_step": 20.0},
              "optimizer": {"initial_samples": 12, "iterations": 24}}
#: Design variables of Eq. (9.2) (Sec. 9.1) in the order of the studies' variables.
EQ_9_2_VARIABLES = ("h", "p_inf", "delta_T")


# -- the Ch. 9 optimizations ------------------------------------------------------------------
@dataclass(frozen=True)
class Optimization:
    """A shipped Ch. 9 study, as it is or coarsened (``quick``).

    Parameters
    ----------
    name : str
        Shipped study name (``studies/optimization/<name>.toml``).
    quick : bool
        The coarse variant (:data:`COARSE_9_1` for Sec. 9.1, :data:`COARSE_9_2` else).
    """

    name: str
    quick: bool = False

    def study(self) -> Study:
        """The study to run (the shipped file, with the coarse settings when ``quick``)."""
        study = load_study(shipped("study")[self.name])
        if not self.quick:
            return study
        coarse = COARSE_9_1 if self.name.startswith("sec9_1") else COARSE_9_2
        data = study_data(study)
        for section, values in coarse.items():
            data[section].update(values)
        return parse_study(data, study.path)


def runs_root(out: str | Path, quick: bool, seed: int) -> Path:
    """``OUT/runs/{quick,full}/seed<k>``: the run directories of one seed."""
    return Path(out) / "runs" / ("quick" if quick else "full") / f"seed{seed}"


def run_directory(opt: Optimization, root: str | Path, seed: int = 0,
                  progress: Callable[[int, int, Any], None] | None = None) -> Path:
    """The finished run directory ``root/<name>`` of ``opt`` at optimizer ``seed``.

    A complete study directory (every output its run wrote, matching its store:
    :func:`~hypate.scaling.workflow.campaigns.integrity.missing_outputs`) is only read,
    after its store and outputs are verified
    (:func:`~hypate.scaling.workflow.campaigns.integrity.verify_run`); an interrupted one is
    resumed (nothing finished is evaluated again; another study or seed there is refused by
    the run's campaign check); otherwise the study runs
    (:func:`hypate.scaling.workflow.campaigns.run.run_study`). A ``[sweep]`` study whose
    every point is complete is only read likewise; one that has begun is resumed through
    :func:`~hypate.scaling.workflow.campaigns.sweep.run_sweep`.
    """
    out = Path(root) / opt.name
    study = opt.study()
    if study.sweep is not None:
        if _complete_sweep(out, len(sweep_points(study))):
            return out
        run_sweep(study, out, resume=(out / SWEEP_JSON).exists(), seed=seed, progress=progress)
        return out
    if (out / STORE).exists() and not missing_outputs(out):
        verify_run(out)
        return out
    run_study(study, out, resume=(out / STORE).exists(), seed=seed, progress=progress)
    return out


def _complete_sweep(out: Path, n_points: int) -> bool:
    """Whether the sweep in ``out`` has every point done and complete (each verified)."""
    if not (out / SWEEP_JSON).is_file():
        return False
    records = json.loads((out / SWEEP_JSON).read_text(encoding="utf-8")).get("points", [])
    dirs = [out / str(r.get("directory")) for r in records if r.get("status") == "done"]
    if len(dirs) != n_points or any(missing_outputs(d) for d in dirs):
        return False
    for d in dirs:
        verify_run(d)
    return True


def design_point(run_dir: Path) -> dict:
    """``design_point.json`` of a run directory."""
    return json.loads((run_dir / DESIGN_POINT_JSON).read_text(encoding="utf-8"))


def best_minmax(run_dir: Path) -> float:
    """min over the successful, admissible evaluations of max(J_u, J_T) (fraction; a run
    written before admissibility was recorded: over the successful ones)."""
    ev = pd.read_csv(run_dir / EVALUATIONS_CSV)
    keep = ev["status"] == "ok"
    if "admissible" in ev.columns:
        keep &= ev["admissible"].astype(str) == "True"
    ok = ev[keep]
    return float(np.max(ok[["J_u", "J_T"]].to_numpy(), axis=1).min()) if len(ok) else \
        float("inf")


def published_design_errors(table: str, col: str) -> dict[str, Any]:
    """The dissertation's design point of column ``col`` of Table ``table`` (9.8-9.10)
    evaluated by hypate in the column's shipped study, as ``hypate whatif --set`` does
    (:func:`~hypate.scaling.workflow.analyses.whatif.evaluate_whatif`: ``objectives`` J_u, J_T, J_s
    as fractions or None when the model failed; ``constraints`` with the bounds it lies
    outside and the equality residuals). Values are taken as published, so a T0 that
    misses the Eq. (9.7) equality shows as its residual, not as a corrected design."""
    return evaluate_whatif(Optimization(study_of(table, col)).study(),
                           published_design(table, col))


def eq_9_2_design(study: Study, xi: float) -> np.ndarray:
    """The analytical design (h, p_inf, Delta T) of Eq. (9.2) at scale ``xi``."""
    law = analytical_scaling(study.spec.prototype, study.spec.model, xi).design()
    return np.array([law[v] for v in EQ_9_2_VARIABLES])


def j_u_optimum(problem: ScalingProblem, x0: np.ndarray, maxfev: int = 120
                ) -> tuple[np.ndarray, float]:
    """Nelder-Mead on J_u (Eq. 9.4) from ``x0`` in log coordinates (5 % simplex): the
    optimum the BO should find, independent of it.

    Returns
    -------
    x : ndarray of shape (3,)
        The design (h m, p_inf Pa, Delta T K) at the optimum.
    J_u : float
        J_u there (fraction).
    """
    def f(z: np.ndarray) -> float:
        return problem.errors(x0 * np.exp(z))["J_u"]

    simplex = np.vstack([np.zeros(3), 0.05 * np.eye(3)])
    res = minimize(f, np.zeros(3), method="Nelder-Mead",
                   options={"initial_simplex": simplex, "xatol": 1e-3, "fatol": 1e-5,
                            "maxfev": maxfev})
    return x0 * np.exp(res.x), float(res.fun)


# -- the optimizations each Ch. 9 reproduction reads ------------------------------------------
def xis_9_1(quick: bool) -> tuple[int, ...]:
    """Geometric scales of the Sec. 9.1 studies."""
    return (2,) if quick else (2, 3, 4)


def xis_9_2_2(quick: bool) -> tuple[int, ...]:
    """Geometric scales of the Sec. 9.2.2 studies."""
    return (4,) if quick else (2, 3, 4, 5)


#: Tunnels of Sec. 9.2.3.
TUNNELS_9_2_3 = ("wt5", "wt6", "wt7")


def names_9_1(quick: bool) -> tuple[str, ...]:
    """Sec. 9.1 studies (Table 9.3; with equal Poisson ratios in the full run)."""
    return tuple(f"sec9_1_xi{xi}" for xi in xis_9_1(quick)) + \
        (() if quick else ("sec9_1_xi2_equal_nu",))


def names_9_2_2(quick: bool) -> tuple[str, ...]:
    """Sec. 9.2.2 studies (Table 9.8)."""
    return tuple(f"sec9_2_2_xi{xi}" for xi in xis_9_2_2(quick))


def names_9_2_3(quick: bool) -> tuple[str, ...]:
    """Sec. 9.2.3 studies, Cases 1 and 2 in each tunnel (Tables 9.9-9.10)."""
    return tuple(f"sec9_2_3_case{c}_{t}" for t in TUNNELS_9_2_3 for c in (1, 2))


def names_9_2_4(quick: bool) -> tuple[str, ...]:
    """Sec. 9.2.4: the envelope sweep (Table 9.11), full run only."""
    return () if quick else ("sec9_2_4_envelope",)


#: The CFD-ROM variants of the Sec. 9.2 studies (issue 44), full run only.
XI4_CFD = "sec9_2_2_xi4_cfd"
ENVELOPE_CFD = "sec9_2_4_envelope_cfd"


def names_9_2_2_cfd(quick: bool) -> tuple[str, ...]:
    """The Sec. 9.2.2 xi = 4 study with both fluid models (``pt-bl`` + Eckert and its
    CFD-ROM variant), full run only."""
    return () if quick else ("sec9_2_2_xi4", XI4_CFD)


def names_9_2_4_cfd(quick: bool) -> tuple[str, ...]:
    """The envelope sweep with both fluid models, full run only."""
    return () if quick else ("sec9_2_4_envelope", ENVELOPE_CFD)


def no_studies(quick: bool) -> tuple[str, ...]:
    """No optimization (the deterministic reproductions)."""
    return ()


#: Cost of a simulation on a CFD fluid ROM (``aero = "rom:..."``) relative to ``pt-bl``: the
#: Sec. 9.2.2 xi = 4 study took 2,183 s on the CFD ROM against 689 s with ``pt-bl`` (one
#: worker each, at e90e6a0).
ROM_COST = 3.2


def budget(opt: Optimization) -> float:
    """Relative cost of an optimization for the schedule: evaluations x time steps (a sweep:
    every point's), times :data:`ROM_COST` on a fluid ROM."""
    study = opt.study()
    rom = str(study.raw.simulation.aero).startswith(ROM_PREFIX)
    o, sweep = study.optimizer, study.sweep
    evaluations = o.initial_samples + study.iteration_cap + o.polish
    if sweep is not None:  # the later points' budgets (None: the study's)
        later = (o.initial_samples if sweep.initial_samples is None else sweep.initial_samples)
        later += study.iteration_cap if sweep.iterations is None else sweep.iterations
        evaluations += (len(sweep_points(study)) - 1) * later
    return float(evaluations * study.raw.simulation.steps) * (ROM_COST if rom else 1.0)
