"""Sweep studies (issue 10, Sec. 9.2.4): one optimization per point, recycling, resume."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import PROTOTYPE_CASE, REPO, tiny_study_text
from hypate.scaling.cli.main import main
from hypate.scaling.engine.store import EvaluationStore
from hypate.scaling.workflow.vocabulary.derived import study_at, sweep_points
from hypate.scaling.workflow.campaigns.rundir import STORE as STORE_NAME
from hypate.scaling.workflow.vocabulary.study import load_study
from hypate.scaling.workflow.campaigns.sweep import run_sweep
from hypate.solvers.errors import InputError

TINY_SWEEP = tiny_study_text(name="tiny_sweep", xi=2.0, tail="""
[sweep]
xi = [2, 3, 4]
recycle = 2
initial_samples = 2
iterations = 1
""")


def _tiny(tmp_path: Path) -> Path:
    path = tmp_path / "tiny_sweep.toml"
    path.write_text(TINY_SWEEP)
    return path


class _Interrupt(RuntimeError):
    pass


def _rows(store: Path) -> list[tuple[int, int, tuple[float, ...]]]:
    with EvaluationStore(store) as s:
        return [(r.iteration, r.batch_index, tuple(r.x)) for r in s.load()]


def test_sweep_interrupted_then_resumed_completes_without_repeating(tmp_path: Path) -> None:
    study = load_study(_tiny(tmp_path))
    out = tmp_path / "run"
    counter = {"label": None, "n": 0, "total": 0}

    def on_point(i, n, point) -> None:
        counter["label"], counter["n"] = point.label, 0

    def interrupting(done, budget, evaluation) -> None:
        counter["n"] += 1
        counter["total"] += 1
        if counter["label"] == "xi_3" and counter["n"] == 3:
            raise _Interrupt("simulated kill after 3 evaluations of the second point")

    with pytest.raises(_Interrupt):
        run_sweep(study, out, progress=interrupting, on_point=on_point)
    first_total = counter["total"]
    before = {p: _rows(out / p / STORE_NAME) for p in ("xi_2", "xi_3")}
    assert len(before["xi_3"]) == 3
    assert not (out / "xi_3" / "design_point.json").exists()
    # without --resume the directory is refused
    assert main(["run", str(_tiny(tmp_path)), "--out", str(out)]) == 2

    counter["total"] = 0
    outcome = run_sweep(study, out, resume=True, progress=interrupting_free(counter),
                        on_point=on_point)
    assert [r["label"] for r in outcome.points] == ["xi_2", "xi_3", "xi_4"]
    assert all(r["status"] == "done" for r in outcome.points)
    after = {p: _rows(out / p / STORE_NAME) for p in ("xi_2", "xi_3", "xi_4")}
    # finished point untouched, interrupted one extended (its first rows unchanged)
    assert after["xi_2"] == before["xi_2"]
    assert after["xi_3"][:3] == before["xi_3"]
    # no evaluation repeated: every stored evaluation was computed exactly once
    assert first_total + counter["total"] == sum(len(v) for v in after.values())
    for rows in after.values():
        assert len({(it, b) for it, b, _ in rows}) == len(rows)
    # later points: classical seed + recycled designs (iteration -1), 2 initial + 1 iteration
    recycled = [r for r in after["xi_4"] if r[0] == -1]
    assert 2 <= len(recycled) <= 4
    df = pd.read_csv(out / "xi_4" / "evaluations.csv")
    msgs = df[df.iteration == -1].message.astype(str)
    assert msgs.str.contains("recycled").any() and msgs.str.contains("prediction").any()
    assert (df.iteration == 0).sum() == 2 and df.iteration.max() == 1
    # run-level summary
    summary = json.loads((out / "sweep.json").read_text())
    assert [p["label"] for p in summary["points"]] == ["xi_2", "xi_3", "xi_4"]
    table = pd.read_csv(out / "sweep.csv")
    assert list(table.label) == ["xi_2", "xi_3", "xi_4"]
    assert {"xi", "M", "p0", "T0", "h", "J_u", "J_T", "status"} <= set(table.columns)
    for label in ("xi_2", "xi_3", "xi_4"):
        point = json.loads((out / label / "design_point.json").read_text())
        assert {"design", "objectives", "similarity", "active_constraints"} <= set(point)
    # resuming a finished sweep evaluates nothing
    counter["total"] = 0
    run_sweep(study, out, resume=True, progress=interrupting_free(counter))
    assert counter["total"] == 0

    # hypate laws on the run: public JSON shape, prediction at a new scale
    import contextlib
    import io
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert main(["laws", str(out), "--predict", "5", "--json"]) == 0
    doc = json.loads(buf.getvalue())
    assert set(doc) == {"laws", "prediction"}
    keys = {"variable", "coefficient", "exponent", "exponent_low", "exponent_high",
            "analytical_exponent", "at_bound"}
    assert {law["variable"] for law in doc["laws"]} >= {"M", "p0", "T0", "h"}
    for law in doc["laws"]:
        assert set(law) == keys and isinstance(law["at_bound"], bool)
    h = next(law for law in doc["laws"] if law["variable"] == "h")
    assert h["analytical_exponent"] == -1.0
    pred = doc["prediction"]
    assert set(pred["design"]) == {"M", "p0", "T0", "h"} and pred["similarity"]
    # text output and the report section
    assert main(["laws", str(out)]) == 0
    from hypate.scaling.report.laws import laws_section
    title, html = laws_section(out)
    assert title == "Scaling laws" and "data:image/png;base64," in html and "<table>" in html


def test_sweep_killed_with_sigkill_resumes_to_the_uninterrupted_result(tmp_path: Path) -> None:
    # A real kill -9 of `hypate run` in the middle of the second point, then --resume:
    # every point completes and each point's evaluations equal an uninterrupted sweep's
    # (nothing finished is evaluated again, nothing is lost).
    import subprocess
    import sys

    from conftest import kill_after
    from conftest import stored_evaluations as count

    text = TINY_SWEEP.replace("iterations = 1", "iterations = 3")
    path = tmp_path / "sweep.toml"
    path.write_text(text)

    def cli(*args: str) -> list[str]:
        return [sys.executable, "-m", "hypate.scaling.cli.main", "run", str(path), *args]

    whole = tmp_path / "whole"
    subprocess.run(cli("--out", str(whole)), check=True, capture_output=True, timeout=600)
    killed = tmp_path / "killed"
    proc = subprocess.Popen(cli("--out", str(killed)), stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    store = killed / "xi_3" / STORE_NAME
    kill_after(proc, store, 2)
    first = _rows(killed / "xi_2" / STORE_NAME)
    partial = _rows(store)
    assert 2 <= len(partial) < len(_rows(whole / "xi_3" / STORE_NAME))
    assert not (killed / "xi_4").exists() or count(killed / "xi_4" / STORE_NAME) == 0
    subprocess.run(cli("--out", str(killed), "--resume"), check=True, capture_output=True,
                   timeout=600)
    for label in ("xi_2", "xi_3", "xi_4"):
        a, b = _rows(killed / label / STORE_NAME), _rows(whole / label / STORE_NAME)
        assert [r[:2] for r in a] == [r[:2] for r in b], label
        assert np.allclose([r[2] for r in a], [r[2] for r in b], rtol=1e-9), label
        assert (killed / label / "design_point.json").exists()
    assert _rows(killed / "xi_2" / STORE_NAME) == first  # the finished point untouched
    assert _rows(store)[:len(partial)] == partial


def interrupting_free(counter):
    def progress(done, budget, evaluation) -> None:
        counter["total"] += 1
    return progress


def test_a_finished_sweep_resumes_from_a_moved_case_file_and_refuses_a_changed_one(
        tmp_path: Path) -> None:
    # A fresh clone (or a moved checkout) puts the prototype case at another absolute path:
    # the same content resumes the finished sweep without evaluating; other content is
    # refused naming the case (before: the path alone was refused, so `hypate reproduce`
    # could not re-read a finished envelope sweep from another clone).
    text = PROTOTYPE_CASE.read_text()
    cases = {}
    edited = text.replace("emissivity = 0.85", "emissivity = 0.8")
    for where, content in (("a", text), ("b", text), ("c", edited)):
        cases[where] = tmp_path / where / "case.toml"
        cases[where].parent.mkdir()
        cases[where].write_text(content)

    def study(where: str):
        path = tmp_path / f"sweep_{where}.toml"
        path.write_text(tiny_study_text(name="tiny_moved", xi=2.0, initial=2, iterations=1,
                                        tail="[sweep]\nxi = [2, 3]\nrecycle = 2\n")
                        .replace(PROTOTYPE_CASE.as_posix(), cases[where].as_posix()))
        return load_study(path)

    out = tmp_path / "run"
    run_sweep(study("a"), out)
    rows = {p: _rows(out / p / STORE_NAME) for p in ("xi_2", "xi_3")}
    outcome = run_sweep(study("b"), out, resume=True)
    assert all(r["status"] == "done" for r in outcome.points)
    assert {p: _rows(out / p / STORE_NAME) for p in rows} == rows  # nothing evaluated
    with pytest.raises(InputError, match=r"different campaign \(case\."):
        run_sweep(study("c"), out, resume=True)


def test_envelope_study_grid_is_serpentine_with_the_table_9_11_budget() -> None:
    study = load_study(REPO / "studies" / "optimization" / "sec9_2_4_envelope.toml")
    assert study.spec.objectives == ("J_s",) and study.acquisition == "lcb"
    assert set(study.spec.names) == {"p0", "T0", "L", "L_le", "h", "emissivity", "T_rad"}
    points = sweep_points(study)
    assert len(points) == 25
    assert [p.label for p in points[:6]] == ["M5_H20km", "M5_H22km", "M5_H25km", "M5_H28km",
                                             "M5_H30km", "M5.5_H30km"]
    # consecutive points are neighbours in the grid (one step in M or in H)
    machs = [5.0, 5.5, 6.0, 6.5, 7.0]
    alts = [20000.0, 22000.0, 25000.0, 28000.0, 30000.0]
    for a, b in zip(points, points[1:]):
        step = abs(machs.index(a.mach) - machs.index(b.mach)) + \
            abs(alts.index(a.altitude) - alts.index(b.altitude))
        assert step == 1
    first = study_at(study, points[0], first=True)
    later = study_at(study, points[7], first=False)
    assert (first.optimizer.initial_samples, first.optimizer.iterations) == (20, 20)
    assert (later.optimizer.initial_samples, later.optimizer.iterations) == (0, 20)
    assert later.spec.prototype.flow.mach == points[7].mach
    assert later.spec.prototype.flow.altitude == pytest.approx(points[7].altitude)
    assert later.sweep is None  # a point is a single study


def test_sweep_keys_validate(tmp_path: Path, capsys) -> None:
    text = _tiny(tmp_path).read_text()
    bad = text.replace("xi = [2, 3, 4]", "xi = [2, 2]")
    path = tmp_path / "bad.toml"
    path.write_text(bad)
    assert main(["run", str(path), "--out", str(tmp_path / "o")]) == 2
    assert "sweep.xi" in capsys.readouterr().err
    path.write_text(text.replace("xi = [2, 3, 4]", "conditions = [[6.0, 25000.0]]\n"
                                 "mach = [6.0]"))
    assert main(["run", str(path), "--out", str(tmp_path / "o")]) == 2
    assert "sweep" in capsys.readouterr().err
    assert main(["laws", str(tmp_path)]) == 2
    assert "sweep.json" in capsys.readouterr().err


def test_condition_points_labels_and_prototypes(tmp_path: Path) -> None:
    text = _tiny(tmp_path).read_text().replace("xi = [2, 3, 4]",
                                               "conditions = [[6.0, 25000.0], [5.5, 22000.0]]")
    path = tmp_path / "cond.toml"
    path.write_text(text)
    study = load_study(path)
    pts = sweep_points(study)
    assert [p.label for p in pts] == ["M6_H25km", "M5.5_H22km"]
    flows = [study_at(study, p).spec.prototype.flow for p in pts]
    assert flows[0].pressure != flows[1].pressure and flows[1].mach == 5.5
    assert np.isclose(study_at(study, pts[1]).spec.xi, 2.0)


def test_laws_from_several_single_study_runs(tmp_path: Path, capsys) -> None:
    # `hypate laws DIR_xi2 DIR_xi3 DIR_xi4`: independent runs of one scaling problem at
    # three scales give the same kind of law as a sweep; a different problem is refused.
    import contextlib
    import io

    from hypate.scaling.workflow.campaigns.laws import is_pinned, load_runs
    from hypate.scaling.workflow.campaigns.run import run_study

    dirs = []
    for xi in (2.0, 3.0, 4.0):
        path = tmp_path / f"xi{xi:g}.toml"
        path.write_text(tiny_study_text(name=f"tiny_xi{xi:g}", xi=xi, initial=3,
                                        iterations=1))
        dirs.append(tmp_path / f"run_xi{xi:g}")
        run_study(load_study(path), dirs[-1])
    run = load_runs(dirs)
    assert [p.xi for p in run.points] == [2.0, 3.0, 4.0]
    for p, d in zip(run.points, dirs):
        point = json.loads((d / "design_point.json").read_text())
        assert p.design == pytest.approx(point["design"], rel=1e-12)
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert main(["laws", *map(str, dirs), "--predict", "5", "--json"]) == 0
    doc = json.loads(buf.getvalue())
    h = next(law for law in doc["laws"] if law["variable"] == "h")
    assert h["analytical_exponent"] == -1.0
    # log-linear least squares through the points that are not pinned at a bound
    free = [(p.xi, p.design["h"]) for p in run.points
            if not is_pinned(p.design["h"], (0.001, 0.01))]
    assert h["at_bound"] == (len(free) < 3)
    if len(free) >= 2:
        k = np.polyfit(np.log([x for x, _ in free]), np.log([v for _, v in free]), 1)[0]
        assert h["exponent"] == pytest.approx(k, rel=1e-9)
    else:
        assert h["exponent"] is None
    assert doc["prediction"]["xi"] == 5.0
    # a different problem (other h bounds) cannot be mixed in
    other = tmp_path / "other.toml"
    other.write_text(tiny_study_text(name="other", xi=5.0, initial=3, iterations=1)
                     .replace("h = [0.001, 0.01]", "h = [0.002, 0.01]"))
    run_study(load_study(other), tmp_path / "run_other")
    assert main(["laws", *map(str, dirs), str(tmp_path / "run_other")]) == 2
    assert "different scaling problem" in capsys.readouterr().err
    # a directory that holds no run
    assert main(["laws", str(tmp_path)]) == 2
