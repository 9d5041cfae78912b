"""Crash safety of `hypate run`: SIGKILL + --resume, process pools and a Dask cluster."""
from __future__ import annotations

import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import threadpoolctl
from conftest import kill_after, stored_evaluations, tiny_study_text
from hypate.scaling.engine.store import EvaluationStore
from hypate.scaling.report.rundata import load_run
from hypate.scaling.report.sections import BUILTIN_SECTIONS
from hypate.scaling.workflow.campaigns import campaign
from hypate.scaling.workflow.vocabulary.problem import ScalingProblem
from hypate.scaling.workflow.campaigns.run import run_study
from hypate.scaling.workflow.campaigns.rundir import PROTOTYPE_WARNINGS
from hypate.scaling.workflow.vocabulary.study import load_study
from pymoo.core.problem import Problem

STUDY = tiny_study_text(name="robust", mesh=3, steps=8, time_step=20.0, initial=6,
                        iterations=6, seed=5)


def _study(tmp_path: Path) -> Path:
    path = tmp_path / "robust.toml"
    path.write_text(STUDY)
    return path


def _table(run: Path) -> pd.DataFrame:
    df = pd.read_csv(run / "evaluations.csv")
    return df.sort_values(["iteration", "batch_index"]).reset_index(drop=True)


def _same(a: pd.DataFrame, b: pd.DataFrame) -> None:
    assert len(a) == len(b)
    cols = ["M", "p0", "T0", "h", "J_u", "J_T"]
    assert list(a["status"]) == list(b["status"])
    assert np.allclose(a[cols].to_numpy(float), b[cols].to_numpy(float), rtol=1e-9,
                       equal_nan=True)


def _cli(*args: str) -> list[str]:
    return [sys.executable, "-m", "hypate.scaling.cli.main", "run", *args]


def test_sigkill_and_resume_equals_uninterrupted_run(tmp_path: Path) -> None:
    study = _study(tmp_path)
    whole = tmp_path / "whole"
    subprocess.run(_cli(str(study), "--out", str(whole)), check=True, capture_output=True,
                   timeout=600)
    killed = tmp_path / "killed"
    proc = subprocess.Popen(_cli(str(study), "--out", str(killed)), stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    store = killed / "evaluations.sqlite"
    kill_after(proc, store, 5)
    done_before = stored_evaluations(store)
    assert 5 <= done_before < len(_table(whole))
    subprocess.run(_cli(str(study), "--out", str(killed), "--resume"), check=True,
                   capture_output=True, timeout=600)
    # no evaluation lost, none repeated, same proposals as the uninterrupted run
    _same(_table(killed), _table(whole))


def test_process_pool_gives_the_same_evaluations(tmp_path: Path) -> None:
    # given seeds (as a sweep's recycled designs) go to the pool too, committed in order
    study = load_study(_study(tmp_path))
    problem = ScalingProblem(study.spec)
    lo, hi = np.asarray(problem.xl, float), np.asarray(problem.xu, float)
    seeds = [(lo + f * (hi - lo), f"given seed {f}") for f in (0.25, 0.5, 0.75)]
    local = run_study(study, tmp_path / "local", seeds=seeds)
    pool = run_study(study, tmp_path / "pool", workers=2, seeds=seeds)
    a, b = _table(local.directory), _table(pool.directory)
    _same(a, b)
    assert (b.iteration == -1).sum() == 4  # the classical design and the three given
    with EvaluationStore(pool.directory / "evaluations.sqlite") as store:
        seeded = [r.batch_index for r in store.load() if r.iteration == -1]
    assert seeded == sorted(seeded)  # the store's order is the seeds' order


class _Stop(RuntimeError):
    pass


def test_a_resumed_run_counts_its_stored_evaluations_in_the_progress(tmp_path: Path) -> None:
    # the progress of a resume goes on from the stored evaluations (it said "1/15" after
    # a run that had stored 10), up to the whole budget
    study = load_study(_study(tmp_path))
    seen: list[tuple[int, int]] = []

    def stopping(done: int, budget: int, evaluation) -> None:
        seen.append((done, budget))
        if done == 5:
            raise _Stop("stopped after 5 evaluations")

    with pytest.raises(_Stop):
        run_study(study, tmp_path / "run", progress=stopping)
    assert [d for d, _ in seen] == [1, 2, 3, 4, 5]
    budget = seen[0][1]
    seen.clear()
    run_study(study, tmp_path / "run", resume=True,
              progress=lambda done, total, ev: seen.append((done, total)))
    assert seen == [(k, budget) for k in range(6, budget + 1)]
    assert stored_evaluations(tmp_path / "run" / "evaluations.sqlite") == budget


def test_dask_local_cluster_gives_the_same_evaluations(tmp_path: Path) -> None:
    distributed = pytest.importorskip("distributed")
    study = load_study(_study(tmp_path))
    local = run_study(study, tmp_path / "local")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                                  host="127.0.0.1", dashboard_address=None) as cluster:
        remote = run_study(study, tmp_path / "dask", scheduler=cluster.scheduler_address)
    _same(_table(local.directory), _table(remote.directory))


class _Killer(Problem):
    """Branin-like objective whose evaluation kills its worker process for x0 > 0.7."""

    def __init__(self) -> None:
        super().__init__(n_var=2, n_obj=1, xl=np.zeros(2), xu=np.ones(2))

    def _evaluate(self, X, out, *args, **kwargs):
        if np.any(X[:, 0] > 0.7):
            os._exit(3)  # the worker process dies mid-evaluation
        out["F"] = ((X[:, 0] - 0.3) ** 2 + (X[:, 1] - 0.6) ** 2)[:, None]


def test_a_dying_worker_costs_only_its_evaluation() -> None:
    from hypate.scaling.engine.executors import ResilientProcessPool
    from hypate.scaling.engine.optimizer import BayesianOptimizer

    pool = ResilientProcessPool(2)
    try:
        res = BayesianOptimizer(_Killer(), n_init=8, n_iter=3, batch_size=2, seed=1,
                                executor=pool).run()
    finally:
        pool.shutdown()
    data = res.data
    killers = data["x0"] > 0.7
    assert killers.any() and (~killers).any()
    # every evaluation that killed its worker is recorded as failed, every other one succeeded
    assert (data.loc[killers, "status"] == "error").all()
    assert data.loc[killers, "message"].str.startswith(
        "worker died while evaluating this design alone").all()
    assert (data.loc[~killers, "status"] == "ok").all()
    assert len(data) == 8 + 3 * 2


def test_the_prototype_s_warnings_are_recorded_stored_and_reported(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    simulate = ScalingProblem.prototype_response.fget

    def warning_prototype(self):
        if self._prototype_response is None:
            warnings.warn("prototype table clamped", RuntimeWarning, stacklevel=1)
        return simulate(self)

    monkeypatch.setattr(ScalingProblem, "prototype_response", property(warning_prototype))
    heard: list[tuple[str, tuple[str, ...]]] = []
    path = tmp_path / "tiny.toml"
    path.write_text(tiny_study_text(initial=3, iterations=1))
    with warnings.catch_warnings(record=True) as outside:
        warnings.simplefilter("always")
        outcome = run_study(load_study(path), tmp_path / "run",
                            on_warnings=lambda *a: heard.append(a))
    entry = "RuntimeWarning: prototype table clamped (1 time)"
    assert outcome.prototype_warnings == (entry,) and heard == [("prototype", (entry,))]
    assert not [w for w in outside if "prototype table" in str(w.message)]  # not printed
    with EvaluationStore(tmp_path / "run" / "evaluations.sqlite", read_only=True) as store:
        assert store.get_meta(PROTOTYPE_WARNINGS) == [entry]
    run = load_run(tmp_path / "run")
    sections = {s.title: s for s in (b(run) for b in BUILTIN_SECTIONS) if s is not None}
    assert ("<td>RuntimeWarning: prototype table clamped</td><td>prototype</td><td>1</td>"
            in sections["Warnings"].html)


def test_each_run_records_its_numerical_environment(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "tiny.toml"
    path.write_text(tiny_study_text(initial=3, iterations=1))
    run_study(load_study(path), tmp_path / "run")
    store_path = tmp_path / "run" / "evaluations.sqlite"
    with EvaluationStore(store_path, read_only=True) as store:
        (env,) = store.get_meta(campaign.ENVIRONMENTS)
    assert env["packages"]["numpy"] == np.__version__
    kernels = {(lib["internal_api"], lib["version"], lib["architecture"])
               for lib in threadpoolctl.threadpool_info() if lib["user_api"] == "blas"}
    assert {(b["internal_api"], b["version"], b["architecture"]) for b in env["blas"]} == kernels
    # the CPU and numpy's SIMD dispatch (AVX-512 or not changes last bits): numpy's own report
    from numpy._core._multiarray_umath import __cpu_features__
    assert env["simd"] == sorted(k for k, found in __cpu_features__.items() if found)
    assert isinstance(env["cpu"], str)
    # resumed unchanged: nothing appended; resumed on another numpy: appended, not replaced
    run_study(load_study(path), tmp_path / "run", resume=True)
    other = {**env, "packages": {**env["packages"], "numpy": "0.0-elsewhere"}}
    monkeypatch.setattr(campaign, "runtime_environment", lambda: other)
    run_study(load_study(path), tmp_path / "run", resume=True)
    with EvaluationStore(store_path, read_only=True) as store:
        assert store.get_meta(campaign.ENVIRONMENTS) == [env, other]
