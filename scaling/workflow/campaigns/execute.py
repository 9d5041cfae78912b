"""The one runner: how a study runs is decided here and only here (issue 42).

``hypate run`` and :func:`hypate.run_study` both call :func:`execute`, which picks one of
four ways from the study and the request (:func:`run_kind`):

==========  =========================================================================
``sweep``   the study has a ``[sweep]``: one campaign per point (:func:`.sweep.run_sweep`)
``seeds``   ``seeds=N``: one campaign per seed into ``OUT/seed-<s>`` and ``seeds.json``
``robust``  ``[uncertainty]`` with ``[robust]``: the nominal then the robust campaign
            (:func:`.robust.run_robust_study`)
``single``  one campaign (:func:`.run.run_study`; multi-fidelity when ``[fidelity]``)
==========  =========================================================================

Every way resumes (``resume=True``). The caller's terminal is not the runner's business:
it receives hooks -- :class:`RunStart` before each campaign, the campaign's outcome after
it, ``on_complete`` for a run found complete on resume.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from hypate.scaling.engine.executors import LOST_AFTER
from hypate.scaling.workflow.campaigns.campaign import preflight
from hypate.scaling.workflow.campaigns.integrity import missing_outputs
from hypate.scaling.workflow.campaigns.robust import run_robust_study
from hypate.scaling.workflow.campaigns.run import RunOutcome, run_study
from hypate.scaling.workflow.campaigns.rundir import STORE
from hypate.scaling.workflow.campaigns.seeds import seed_directory, seed_list, write_seeds_summary
from hypate.scaling.workflow.campaigns.sweep import SweepOutcome, run_sweep
from hypate.scaling.workflow.vocabulary.study import Study
from hypate.solvers.errors import InputError

#: The ways a study runs (:func:`run_kind`).
RUN_KINDS = ("sweep", "seeds", "robust", "single")


@dataclass(frozen=True)
class RunStart:
    """One campaign about to start (or be found complete): what the caller's hooks see.

    ``kind`` is the study's way (:data:`RUN_KINDS`); ``index`` / ``total`` count the
    campaigns of a ``seeds`` or ``sweep`` run (0 / 1 otherwise); ``label`` names it
    (``seed 3``, a sweep point's label, the study's name); ``resume`` whether it continues
    a stored campaign.
    """

    kind: str
    index: int
    total: int
    label: str
    directory: Path
    resume: bool
    seed: int | None = None


@dataclass
class SeedsOutcome:
    """A ``seeds`` run: each seed's outcome (None: found complete on resume and left as it
    was) and the content of ``seeds.json``."""

    directory: Path
    seeds: list[int]
    runs: dict[int, RunOutcome | None] = field(default_factory=dict)
    summary: dict[str, Any] = field(default_factory=dict)


Outcome = RunOutcome | SweepOutcome | SeedsOutcome


def run_kind(study: Study, seeds: int | None = None) -> str:
    """How ``study`` runs (:data:`RUN_KINDS`): a ``[sweep]`` first, then ``seeds``, then a
    robust study, else a single campaign."""
    if study.sweep is not None:
        return "sweep"
    if seeds is not None:
        return "seeds"
    if study.uncertainty is not None and study.uncertainty.optimize:
        return "robust"
    return "single"


def default_run_dir(name: str, resume: bool, root: Path = Path("runs")) -> Path:
    """``runs/NAME``, or ``runs/NAME-2``, ``-3``... when earlier runs exist (a repeated run
    starts a new directory instead of refusing); with ``resume`` the latest."""
    candidates = [root / name] + [root / f"{name}-{k}" for k in range(2, 1000)]
    existing = [c for c in candidates if c.exists()]
    if resume:
        return existing[-1] if existing else candidates[0]
    return next(c for c in candidates if not c.exists())


def check_request(study: Study, seeds: int | None, seed_runs: Sequence[str | Path]) -> str:
    """The study's way (:func:`run_kind`) once the request fits it.

    Raises
    ------
    InputError
        ``seed_runs`` or ``seeds`` with a sweep, ``seed_runs`` with a robust study.
    """
    kind = run_kind(study, seeds)
    if kind == "sweep" and seed_runs:
        raise InputError("--seed-from", "not available for sweep studies (their points "
                         "are seeded by recycling, [sweep] recycle)")
    if kind == "sweep" and seeds is not None:
        raise InputError("--seeds", "not available for sweep studies (run the sweep "
                         "once per --seed instead)")
    return kind


def execute(study: Study, out: str | Path | None = None, *, resume: bool = False,
            workers: int = 1, scheduler: str | None = None, seed: int | None = None,
            seeds: int | None = None, seed_runs: Sequence[str | Path] = (),
            progress: Callable[[int, int, Any], None] | None = None,
            on_run: Callable[[RunStart], None] | None = None,
            on_done: Callable[[RunStart, RunOutcome], None] | None = None,
            on_complete: Callable[[RunStart], None] | None = None,
            on_written: Callable[[Path], object] | None = None,
            on_seeds_written: Callable[[Path], object] | None = None,
            on_warnings: Callable[[str, tuple[str, ...]], None] | None = None,
            on_scatter: Callable[..., None] | None = None,
            lost_after: float = LOST_AFTER, force: bool = False) -> Outcome | None:
    """Run (or, with ``resume``, continue) ``study`` into ``out`` the way it runs.

    Parameters
    ----------
    study : Study
    out : path, optional
        The run directory; default :func:`default_run_dir` of the study's name.
    resume, workers, scheduler, seed, progress, lost_after, force, on_written, on_warnings
        As :func:`hypate.scaling.workflow.campaigns.run.run_study` (``seed``: the first seed of a
        ``seeds`` run; ``progress`` restarts with each campaign).
    seeds : int, optional
        Runs of seeds ``seed .. seed + seeds - 1`` (the study's seed when ``seed`` is None),
        each into ``out/seed-<s>``; ``seeds.json`` / ``seeds.csv`` rewritten after each
        (and when one is interrupted); ``on_seeds_written(directory)`` (default
        ``on_written``) for every seed at the end, so that each report shows the spread over
        all.
    seed_runs : sequence of paths
        Earlier run directories whose best designs seed a single campaign
        (``--seed-from``).
    on_run : callable, optional
        ``on_run(start)`` before each campaign (:class:`RunStart`), after its checks.
    on_done : callable, optional
        ``on_done(start, outcome)`` after each campaign of a single, robust or seeds run.
    on_complete : callable, optional
        ``on_complete(start)`` for a campaign found complete on resume, which is then left
        as it is; without it a complete campaign is replayed from its store (its outputs
        rewritten, nothing simulated).
    on_scatter : callable, optional
        ``on_scatter(done, total)`` of a single run's scatter, ``on_scatter(done, total,
        which)`` of a robust run's two (``which``: "the nominal design", "the robust
        design").

    Returns
    -------
    RunOutcome, SweepOutcome, SeedsOutcome or None
        None: a single or robust campaign found complete and handed to ``on_complete``.
    """
    kind = check_request(study, seeds, seed_runs)
    out = Path(out) if out is not None else default_run_dir(study.name, resume)
    common: dict[str, Any] = dict(workers=workers, scheduler=scheduler, lost_after=lost_after,
                                  force=force, on_written=on_written, progress=progress)
    if kind == "sweep":
        def on_point(i: int, n: int, point: Any) -> None:
            if on_run is not None:
                on_run(RunStart("sweep", i, n, point.label, out / point.label, resume))
        return run_sweep(study, out, resume=resume, seed=seed, on_point=on_point, **common)

    def one(start: RunStart) -> RunOutcome | None:
        preflight(study, start.directory, resume=start.resume, seed=start.seed,
                  workers=workers, scheduler=scheduler, force=force)
        if kind == "robust" and seed_runs:
            raise InputError("--seed-from", "not available for a robust study ([robust]: "
                             "its search starts from its nominal campaign)")
        if start.resume and on_complete is not None and not missing_outputs(start.directory):
            on_complete(start)
            return None
        if on_run is not None:
            on_run(start)
        if kind == "robust":
            scatter = None if on_scatter is None else \
                (lambda which, done, total: on_scatter(done, total, f"the {which} design"))
            outcome = run_robust_study(study, start.directory, resume=start.resume,
                                       seed=start.seed, on_scatter=scatter, **common)
        else:
            outcome = run_study(study, start.directory, resume=start.resume, seed=start.seed,
                                seed_runs=seed_runs, on_warnings=on_warnings,
                                on_scatter=on_scatter, **common)
        if on_done is not None:
            on_done(start, outcome)
        return outcome

    if kind != "seeds":
        return one(RunStart(kind, 0, 1, study.name, out, resume, seed))

    first = study.optimizer.seed if seed is None else seed
    chosen = seed_list(first, seeds or 0)
    out.mkdir(parents=True, exist_ok=True)
    result = SeedsOutcome(out, chosen)
    for k, s in enumerate(chosen):
        sub = seed_directory(out, s)
        try:
            result.runs[s] = one(RunStart("seeds", k, len(chosen), f"seed {s}", sub,
                                          resume and (sub / STORE).is_file(), s))
        except InputError:
            raise  # refused before it ran: nothing to summarize
        except BaseException:  # interrupted: the summary of the seeds finished so far
            write_seeds_summary(study, out, chosen)
            raise
        result.summary = write_seeds_summary(study, out, chosen)
    again = on_written if on_seeds_written is None else on_seeds_written
    if again is not None:  # every report shows the spread over all seeds
        for s in chosen:
            again(seed_directory(out, s))
    return result
