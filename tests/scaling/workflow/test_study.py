"""Study files and `hypate run`: validation errors, outputs and their public fields."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import pandas as pd
import pytest
from conftest import REPO, tiny_study_text
from hypate.scaling.cli.main import main
from hypate.scaling.workflow.campaigns import optimizer_settings as settings_module
from hypate.scaling.workflow.vocabulary.study import load_study

TINY = tiny_study_text()


def _tiny(tmp_path: Path, text: str = TINY) -> Path:
    path = tmp_path / "tiny.toml"
    path.write_text(text)
    return path


def test_shipped_studies_validate() -> None:
    paths = {p.name: p for p in (REPO / "studies" / "optimization").glob("*.toml")}
    paths["quickstart.toml"] = REPO / "scaling" / "data" / "quickstart.toml"
    names = sorted(paths)
    # public study names (issues 8 and 9)
    for required in ["quickstart.toml", "sec9_1_xi2.toml", "sec9_1_xi3.toml", "sec9_1_xi4.toml",
                     "sec9_2_2_xi2.toml", "sec9_2_2_xi5.toml", "sec9_2_3_case1_wt5.toml",
                     "sec9_2_3_case2_wt7.toml", "sec9_2_2_xi4_material.toml",
                     "sec9_2_2_xi4_mf.toml"]:
        assert required in names
    for name in names:
        study = load_study(paths[name])
        assert study.spec.variables


MALFORMED = [
    ("unknown key", ("[optimizer]", "[optimizer]\ncolour = 1"), "optimizer.colour"),
    ("bounds reversed", ('h = [0.001, 0.01]', 'h = [0.01, 0.001]'), "variables.h"),
    ("tunnel unknown", ('name = "ideal"', 'name = "WT9"'), "tunnel"),
    ("negative budget", ("iterations = 2", "iterations = -5"), "optimizer.iterations"),
    ("thickness outside manufacturing", ('h = [0.001, 0.01]', 'h = [1e-6, 0.01]'), "variables.h"),
    ("missing prototype", ("[prototype]", "[prototypes]"), "prototype"),
    ("unknown variable", ('h = [0.001, 0.01]', 'wingspan = [1.0, 2.0]'), "variables.wingspan"),
    ("bad objective", ('objectives = ["J_u", "J_T"]', 'objectives = ["drag"]'), "study.objectives"),
    ("acquisition mismatch", ("seed = 3", 'seed = 3\nacquisition = "ei"'), "optimizer.acquisition"),
    ("p0 outside tunnel", ('p0 = "tunnel"', "p0 = [1.0e5, 1.0e9]"), "variables.p0"),
    ("missing case file", ("case = ", 'case = "nope.toml" #'), "prototype.case"),
    ("zero xi", ("xi = 4.0", "xi = 0.0"), "study.xi"),
    ("bad equality", ("[optimizer]", '[constraints]\nequality = ["Mach"]\n[optimizer]'),
     "constraints.equality"),
    ("negative v_final", ("[optimizer]", "[optimizer]\nv_final = -0.5"), "optimizer.v_final"),
    ("polish of a knee", ("[optimizer]", '[optimizer]\npolish = 4\ndesign_point = "knee"'),
     "optimizer.polish"),
    ("unknown polish method", ("[optimizer]", '[optimizer]\npolish = 4\npolish_method = "bfgs"'),
     "optimizer.polish_method"),
    ("simulator not found", ('aero = "pt-bl"', 'aero = "pt-bl"\nsimulator = "nosuch.py:f"'),
     "simulation.simulator"),
]


@pytest.mark.parametrize("label, change, key", MALFORMED, ids=[m[0] for m in MALFORMED])
def test_malformed_study_exits_2_and_writes_nothing(tmp_path: Path, capsys, label, change, key):
    text = TINY.replace(*change)
    path = _tiny(tmp_path, text)
    out = tmp_path / "run"
    assert main(["run", str(path), "--out", str(out)]) == 2, label
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("hypate: error: ") and key in err[-1], (label, err[-1])
    assert not out.exists()


def test_gauss_newton_polish_of_the_fields_projection_is_refused(tmp_path: Path,
                                                                 capsys) -> None:
    # the "fields" projection composes no histories for the Gauss-Newton polish to linearize
    text = TINY.replace("[study]\n", '[study]\nprojection = "fields"\n').replace(
        "[optimizer]", '[optimizer]\npolish = 4\npolish_method = "gauss-newton"')
    out = tmp_path / "run"
    assert main(["run", str(_tiny(tmp_path, text)), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "optimizer.polish_method" in err and "fields" in err
    assert not out.exists()


def test_run_writes_public_outputs_and_resume_adds_nothing(tmp_path: Path, capsys) -> None:
    path = _tiny(tmp_path)
    out = tmp_path / "run"
    assert main(["run", str(path), "--out", str(out)]) == 0
    for name in ("evaluations.sqlite", "evaluations.csv", "pareto.csv", "design_point.json",
                 "prototype.npz"):
        assert (out / name).is_file(), name
    point = json.loads((out / "design_point.json").read_text())
    assert set(point["design"]) == {"M", "p0", "T0", "h"}
    assert set(point["objectives"]) == {"J_u", "J_T"}
    assert isinstance(point["active_constraints"], list)
    rows = point["similarity"]
    assert rows and set(rows[0]) == {"name", "prototype", "model", "relative_difference"}
    df = pd.read_csv(out / "evaluations.csv")
    assert {"M", "p0", "T0", "h", "J_u", "J_T", "status", "seconds"} <= set(df.columns)
    n = len(df)
    assert n == 1 + 4 + 2  # classical seed + initial sample + iterations
    # the design point is the evaluation with the smallest max(J_u, J_T)
    ok = df[df.status == "ok"]
    assert max(point["objectives"].values()) == pytest.approx(ok[["J_u", "J_T"]].max(axis=1).min())
    # an existing run is refused without --resume; --resume re-evaluates nothing
    assert main(["run", str(path), "--out", str(out)]) == 2
    assert main(["run", str(path), "--out", str(out), "--resume"]) == 0
    assert len(pd.read_csv(out / "evaluations.csv")) == n
    shutil.rmtree(out)


def test_every_evaluated_design_satisfies_the_cheap_equality(tmp_path: Path) -> None:
    # Eq. (9.7) T_w/T_inf equality: the classical seed, the initial sample and every BO
    # proposal satisfy it to 1e-8 (the GP design is projected onto it before evaluation).
    from hypate.scaling.workflow.vocabulary.problem import ScalingProblem
    from hypate.scaling.workflow.campaigns.run import run_study

    text = tiny_study_text(name="eq", initial=3, iterations=2,
                           sections='[constraints]\nequality = ["T_inf"]\n')
    study = load_study(_tiny(tmp_path, text))
    run_study(study, tmp_path / "run")
    problem = ScalingProblem(study.spec)
    con = problem.cheap_constraints()[0]  # then the tunnel's size and duration checks
    ev = pd.read_csv(tmp_path / "run" / "evaluations.csv")
    assert (ev.iteration == -1).sum() == 1  # the classical seed was evaluated
    X = ev[study.spec.names].to_numpy(float)
    assert max(abs(float(con.fun(x)[0])) for x in X) < 1e-8


def test_similarity_coordinates_run_and_zero_bounds_are_refused(tmp_path: Path, capsys) -> None:
    # a tiny run with the surrogates in similarity coordinates completes like any other
    text = TINY.replace("[optimizer]", '[optimizer]\ncoordinates = "similarity"')
    out = tmp_path / "run"
    assert main(["run", str(_tiny(tmp_path, text)), "--out", str(out)]) == 0
    assert len(pd.read_csv(out / "evaluations.csv")) == 1 + 4 + 2  # classical seed + OLH + BO
    # log coordinates need positive bounds: refused before anything is written
    bad = text.replace("h = [0.001, 0.01]", "h = [0.001, 0.01]\nemissivity = [0.0, 1.0]")
    out2 = tmp_path / "run2"
    assert main(["run", str(_tiny(tmp_path, bad)), "--out", str(out2)]) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "optimizer.coordinates" in err and "emissivity" in err
    assert not out2.exists()


def test_v_final_reaches_the_optimizer_and_studies_default_to_a_constant_v(
        tmp_path: Path, monkeypatch) -> None:
    # the engine's own default is HVLCB's schedule ("auto"); a study without the key keeps
    # a constant v (its figures were measured so), a study with it hands it on
    seen: list[object] = []
    real = settings_module.OptimizerSettings

    def spy(**kw):
        seen.append(kw["v_final"])
        return real(**kw)

    monkeypatch.setattr(settings_module, "OptimizerSettings", spy)
    assert main(["run", str(_tiny(tmp_path)), "--out", str(tmp_path / "a")]) == 0
    text = TINY.replace("[optimizer]", "[optimizer]\nv_final = 0.25")
    assert main(["run", str(_tiny(tmp_path, text)), "--out", str(tmp_path / "b")]) == 0
    assert seen == [None, 0.25]


def test_seed_from_an_earlier_run(tmp_path: Path, capsys) -> None:
    # Case 1 -> Case 2 (Sec. 9.2.3): the richer strategy starts from the best designs of
    # the simpler one; shared variables keep their values, the new one takes the
    # template's (emissivity 0.85 of the prototype case here).
    first = tmp_path / "case1"
    assert main(["run", str(_tiny(tmp_path)), "--out", str(first)]) == 0
    done = pd.read_csv(first / "evaluations.csv")
    done = done[done["status"] == "ok"]
    best = done.loc[done[["J_u", "J_T"]].max(axis=1).sort_values(kind="stable").index]
    richer = TINY.replace("h = [0.001, 0.01]", "h = [0.001, 0.01]\nemissivity = [0.5, 1.0]")
    second = tmp_path / "case2"
    path = tmp_path / "case2.toml"
    path.write_text(richer)
    assert main(["run", str(path), "--out", str(second), "--seed-from", str(first)]) == 0
    df = pd.read_csv(second / "evaluations.csv")
    seeded = df[df["message"].str.contains("seed: case1 evaluation", na=False)]
    assert len(seeded) == min(10, len(best))
    for (_, a), (_, b) in zip(seeded.iterrows(), best.iterrows()):
        for name in ("p0", "h"):
            assert a[name] == pytest.approx(b[name], rel=1e-9)
        assert a["emissivity"] == pytest.approx(0.85)
    capsys.readouterr()
    assert main(["run", str(path), "--out", str(tmp_path / "x"), "--seed-from",
                 str(tmp_path / "nowhere")]) == 2
    assert "--seed-from" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


def test_a_rom_fluid_model_is_found_beside_the_study_or_shipped(tmp_path: Path,
                                                                 monkeypatch) -> None:
    """``aero = "rom:PATH"``: PATH from the working directory, else beside the study file,
    else the shipped ROM of that file name; the sweep's stored study keeps what was found."""
    from hypate.scaling.workflow.vocabulary.derived import study_data
    from hypate.scaling.workflow.vocabulary.shipped import shipped
    from hypate.solvers.aero.factory import ROM_PREFIX

    shipped_rom = (REPO / "studies" / "rom" / "rom_sec9_2_cfd.npz").resolve()
    monkeypatch.chdir(tmp_path)  # not the repository: the relative path does not exist here
    study = load_study(shipped("study")["sec9_2_2_xi4_cfd"])
    aero = study.spec.prototype.simulation.aero
    assert aero.startswith(ROM_PREFIX) and Path(aero[len(ROM_PREFIX):]).resolve() == shipped_rom
    assert study_data(study)["simulation"]["aero"] == aero
    # a ROM file beside the study wins over the shipped one of the same name
    sub = tmp_path / "mine"
    sub.mkdir()
    shutil.copy(shipped_rom, sub / "rom_sec9_2_cfd.npz")
    text = TINY.replace('aero = "pt-bl"', 'aero = "rom:rom_sec9_2_cfd.npz"')
    assert text != TINY
    (sub / "s.toml").write_text(text)
    aero = load_study(sub / "s.toml").spec.prototype.simulation.aero
    assert aero == ROM_PREFIX + str((sub / "rom_sec9_2_cfd.npz").resolve())
    # from the working directory first (the rule of case files)
    monkeypatch.chdir(sub)
    assert load_study(sub / "s.toml").spec.prototype.simulation.aero == \
        "rom:rom_sec9_2_cfd.npz"
