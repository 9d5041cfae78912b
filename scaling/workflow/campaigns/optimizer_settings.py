"""The engine's settings of a study's campaign, built in one place from the study (issue 42):
the algorithm's settings (:class:`~hypate.scaling.engine.settings.OptimizerSettings`) come
from ``[optimizer]`` (and ``[robust]`` for the robust search) with the runner's seed and
surrogate coordinates; the run's context (:class:`~hypate.scaling.engine.settings.RunContext`:
executor, time limit, store, callback) from the runner and ``[optimizer] timeout``.
"""
from __future__ import annotations

from collections.abc import Callable
from typing import Any

from hypate.scaling.engine.settings import OptimizerSettings, RunContext
from hypate.scaling.engine.store import Evaluation, EvaluationStore
from hypate.scaling.workflow.vocabulary.problem import ScalingProblem
from hypate.scaling.workflow.vocabulary.study import Study

#: Probability settings passed only when the study sets them (the engine's defaults else).
PROBABILITIES = ("p_feasible", "p_success", "p_exploit")


def optimizer_settings(study: Study, problem: ScalingProblem, *, executor: Any,
                       store: EvaluationStore, seed: int,
                       callback: Callable[[Evaluation], None], coordinates: Any,
                       robust: bool = False) -> tuple[OptimizerSettings, RunContext]:
    """The engine's settings and run context of ``study``'s campaign.

    Parameters
    ----------
    study, problem
        The study and its scaling problem (its cheap constraints, its categorical variable).
    executor, store, callback
        The run's context: where evaluations run, where they are kept, the hook after each
        stored evaluation (with ``[optimizer] timeout``: the :class:`RunContext`).
    seed, coordinates
        The run's seed and the surrogates' input coordinates (settings of the algorithm).
    robust : bool
        The robust search of ``[robust]`` (:mod:`hypate.scaling.workflow.campaigns.robust`): its own
        initial sample and iterations, one design per iteration (the robust optimizer
        refuses a batch); the nominal campaign's stopping rule, polish, exploitation and
        probability settings stay the engine's defaults there, as they always have.

    Returns
    -------
    (OptimizerSettings, RunContext)
    """
    opt = study.optimizer
    context = RunContext(executor=executor, timeout=opt.timeout, store=store, callback=callback)
    common: dict[str, Any] = dict(
        acquisition=study.acquisition, v=opt.v, v_final=opt.v_final, weights=opt.weights,
        cheap_constraints=problem.cheap_constraints(), seed=seed,
        output_transform=opt.transform, surrogate=opt.surrogate, coordinates=coordinates)
    if robust:
        unc = study.uncertainty
        assert unc is not None, "a robust campaign needs [uncertainty]"
        return OptimizerSettings(
            n_init=unc.initial_samples,
            n_iter=study.iteration_cap if unc.iterations is None else unc.iterations,
            **common), context
    return OptimizerSettings(
        n_init=opt.initial_samples, n_iter=study.iteration_cap, batch_size=opt.batch_size,
        stopping=study.stopping_rule, polish=opt.polish, polish_method=opt.polish_method,
        categorical=problem.categorical,
        exploit_last=opt.exploit_last,
        **{k: getattr(opt, k) for k in PROBABILITIES if getattr(opt, k) is not None},
        **common), context
