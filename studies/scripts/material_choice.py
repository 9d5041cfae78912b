"""Choosing the model material (beyond the dissertation, issue "Richer model designs").

``sec9_2_2_xi4_material.toml`` searches the Sec. 9.2.2 xi = 4 problem with the model
material a categorical design variable (Ti 6242, Inconel 718, Al 7075). The question it
answers is the one a user would otherwise answer with one study per material: this script
runs both -- the material study and ``sec9_2_2_xi4.toml`` with each listed material fixed
(the same continuous variables, bounds, budget and seed) -- and tabulates, per optimizer
seed, each design point's max(J_u, J_T) (the design-point rule, Sec. 9.2.3), the best
fixed-material study, and whether the material study lands within :data:`RTOL` of it with
fewer evaluations than the fixed studies together.

Finished run directories under ``OUT/seed<k>/`` are read as they are (an interrupted one
resumes), so the comparison can be rebuilt without simulating again.

Run ``python -m hypate.studies.scripts.material_choice [--seeds 0 1 2] [--coarse] [--out DIR]``.
"""
from __future__ import annotations

import argparse
import json
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import pandas as pd
from hypate.scaling.workflow.campaigns.run import run_study
from hypate.scaling.workflow.campaigns.rundir import DESIGN_POINT_JSON, STORE
from hypate.scaling.workflow.vocabulary.derived import study_data
from hypate.scaling.workflow.vocabulary.shipped import shipped
from hypate.scaling.workflow.vocabulary.study import Study, load_study, parse_study

#: The material study and the fixed-material problem it is compared with.
MATERIAL_STUDY, FIXED_STUDY = "sec9_2_2_xi4_material", "sec9_2_2_xi4"
#: Acceptance: the material study's max(J_u, J_T) within 5 % (relative) of the best fixed one.
RTOL = 0.05
#: The coarse (test) variant: a 4 x 4 mesh, 8 steps, a small budget (the material study
#: 6 + 6 evaluations after its 3 classical seeds, each fixed one 6 + 4 after its one).
COARSE = {"simulation": {"mesh": [4, 4], "steps": 8, "time_step": 20.0},
          "optimizer": {"initial_samples": 6, "iterations": 4}}
COARSE_MATERIAL_ITERATIONS = 6


@dataclass(frozen=True)
class Config:
    seeds: tuple[int, ...] = (0,)
    out: str = "material_choice"
    coarse_run: bool = False

    @classmethod
    def coarse(cls) -> Config:
        return cls(coarse_run=True)


@dataclass(frozen=True)
class Result:
    table: pd.DataFrame  # one row per (seed, study)
    summary: pd.DataFrame  # one row per seed: the acceptance


def _data(name: str, coarse: bool) -> tuple[dict, str]:
    """A shipped study as data (coarsened when asked) and its path."""
    study = load_study(shipped("study")[name])
    data = study_data(study)
    if coarse:
        for section, values in COARSE.items():
            data.setdefault(section, {}).update(values)
    return data, study.path


def studies(coarse: bool = False) -> dict[str, Study]:
    """The material study and one fixed-material study per listed material, by run name."""
    data, path = _data(MATERIAL_STUDY, coarse)
    if coarse:
        data["optimizer"]["iterations"] = COARSE_MATERIAL_ITERATIONS
    out = {"material": parse_study(data, path)}
    for name in out["material"].spec.material_names:
        data, path = _data(FIXED_STUDY, coarse)
        data["model"]["material"] = name
        data["study"]["name"] = f"{FIXED_STUDY}_{name}"
        out[f"fixed_{name}"] = parse_study(data, path)
    return out


def finished_run(study: Study, out: Path, seed: int) -> dict:
    """design_point.json of ``study`` run at ``seed`` into ``out`` (run or resumed first
    unless finished)."""
    if not (out / DESIGN_POINT_JSON).exists():
        with warnings.catch_warnings():  # material tables clamped etc.: stored per evaluation
            warnings.simplefilter("ignore", RuntimeWarning)
            run_study(study, out, resume=(out / STORE).exists(), seed=seed)
    return json.loads((out / DESIGN_POINT_JSON).read_text())


def run(config: Config | None = None) -> Result:
    config = config or Config()
    rows, summary = [], []
    for seed in config.seeds:
        root = Path(config.out) / f"seed{seed}"
        for label, study in studies(config.coarse_run).items():
            point = finished_run(study, root / label, seed)
            objs = point.get("objectives") or {}
            rows.append({"seed": seed, "study": label,
                         "material": (point.get("material") or {}).get("name")
                         or label.removeprefix("fixed_"),
                         "J_u": objs.get("J_u"), "J_T": objs.get("J_T"),
                         "max_J": max(objs.values()) if objs else float("inf"),
                         "evaluations": point["statistics"]["evaluations"]})
        seed_rows = pd.DataFrame([r for r in rows if r["seed"] == seed])
        fixed = seed_rows[seed_rows["study"] != "material"]
        mixed = seed_rows[seed_rows["study"] == "material"].iloc[0]
        best = fixed.loc[fixed["max_J"].idxmin()]
        ratio = mixed["max_J"] / best["max_J"]
        summary.append({"seed": seed, "material study max_J": mixed["max_J"],
                        "material chosen": mixed["material"], "best fixed max_J": best["max_J"],
                        "best fixed material": best["material"], "ratio": ratio,
                        "within 5 %": bool(ratio <= 1.0 + RTOL),
                        "evaluations (material / fixed together)":
                            f"{mixed['evaluations']} / {int(fixed['evaluations'].sum())}",
                        "fewer evaluations": bool(mixed["evaluations"]
                                                  < fixed["evaluations"].sum())})
    return Result(table=pd.DataFrame(rows), summary=pd.DataFrame(summary))


def main(argv: Sequence[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, nargs="+", default=[0])
    p.add_argument("--coarse", action="store_true", help="the coarse (test) configuration")
    p.add_argument("--out", default="material_choice", help="run directories and tables")
    args = p.parse_args(argv)
    res = run(Config(seeds=tuple(args.seeds), out=args.out, coarse_run=args.coarse))
    out = Path(args.out)
    res.table.to_csv(out / "material_choice_runs.csv", index=False)
    res.summary.to_csv(out / "material_choice.csv", index=False)
    print(res.table.to_string(index=False))
    print()
    print(res.summary.to_string(index=False))


if __name__ == "__main__":
    main()
