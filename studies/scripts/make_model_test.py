"""Sample measured model test for ``hypate predict``: a design point's simulated model
response plus stated measurement noise, written in the command's CSV header contract.

What it does, in order:

1. The run directory ``--run-dir`` (default ``runs/sec9_2_2_xi4``) of the study
   ``--study`` (default the shipped ``studies/optimization/sec9_2_2_xi4.toml``, Sec. 9.2.2,
   xi = 4): a finished run there is used as it is (its store must record this study: same
   parsed study and simulation settings); otherwise the study is run there (``run_study``,
   the same as ``hypate run``: about 6 min on a 2-core machine). ``--coarse`` uses the
   coarse Sec. 9.2 variant of ``hypate reproduce --quick`` instead (4 x 4 mesh, 8 steps of
   20 s, 12 + 24 evaluations) and writes below ``runs/`` (never over the shipped file).
2. The design point of ``design_point.json`` is simulated again from the study
   (``ScalingProblem.simulate_model``: the model on its matched time step, Eq. 9.6) and
   compared with the run's ``design_point.npz`` (the largest relative difference is
   recorded; the same code gives the same history).
3. Noise: to each history (centre deflection, volume-mean temperature) independent normal
   noise of standard deviation ``--noise`` (default 0.02) times the RMS of that history
   over the test, drawn from ``numpy.random.default_rng(--seed)`` (default 4), deflection
   first, then temperature.
4. The CSV (default ``studies/data/model_test_xi4.csv``): ``#`` comment lines recording the
   study file and its SHA-256, the coarse overrides, the run directory, the design, J_u,
   J_T, the model time step, the noise and seed, the hypate version; then the columns
   ``time [s]``, ``center_deflection [mm]``, ``mean_temperature [K]``.

Run ``python -m hypate.studies.scripts.make_model_test [--coarse] [--study STUDY]
[--run-dir DIR] [--out FILE] [--noise F] [--seed S]``, then
``hypate predict RUN_DIR --measured FILE``.
"""
from __future__ import annotations

import argparse
import hashlib
import io
import json
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from hypate.scaling.engine.store import EvaluationStore
from hypate.scaling.workflow.campaigns.campaign import campaign_identity, package_version
from hypate.scaling.workflow.campaigns.run import run_study
from hypate.scaling.workflow.campaigns.rundir import DESIGN_POINT_JSON, DESIGN_POINT_NPZ, STORE
from hypate.scaling.workflow.vocabulary.derived import study_data
from hypate.scaling.workflow.vocabulary.problem import ScalingProblem
from hypate.scaling.workflow.vocabulary.shipped import resolve
from hypate.scaling.workflow.vocabulary.study import Study, load_study, parse_study
from hypate.solvers.coupling.response import Response
from hypate.studies.scripts.ch9_runs import COARSE_9_2

#: Relative noise (of each history's RMS) and seed of the shipped sample.
NOISE, SEED = 0.02, 4
#: The shipped sample's study, run directory and file.
STUDY = "sec9_2_2_xi4"
RUN_DIR = Path("runs") / STUDY
SAMPLE = Path("studies") / "data" / "model_test_xi4.csv"
#: Histories written, their column headers and factors from SI.
COLUMNS = {"center_deflection": ("center_deflection [mm]", 1e3),
           "mean_temperature": ("mean_temperature [K]", 1.0)}


@dataclass(frozen=True)
class Config:
    """Which study and run, where the file goes, the noise."""

    study: str = STUDY
    quick: bool = False
    run_dir: Path = RUN_DIR
    out: Path = SAMPLE
    noise: float = NOISE
    seed: int = SEED

    @classmethod
    def coarse(cls) -> Config:
        """The coarse variant (``--coarse``), written below ``runs/``."""
        return cls(quick=True, run_dir=Path("runs") / f"{STUDY}_coarse",
                   out=Path("runs") / f"{STUDY}_coarse" / "model_test.csv")


@dataclass(frozen=True)
class Result:
    """The file written, the clean and noisy histories (SI) and the provenance."""

    path: Path
    time: np.ndarray
    clean: dict[str, np.ndarray]
    noisy: dict[str, np.ndarray]
    sigma: dict[str, float]
    provenance: dict[str, Any] = field(default_factory=dict)


def study_of(config: Config) -> Study:
    """The study to run: the file, with the coarse Sec. 9.2 overrides when ``quick``."""
    study = load_study(config.study)
    if not config.quick:
        return study
    data = study_data(study)
    for section, values in COARSE_9_2.items():
        data[section].update(values)
    return parse_study(data, study.path)


def finished_run(study: Study, run_dir: Path) -> dict[str, Any]:
    """``design_point.json`` of ``run_dir``, running the study there first when it holds no
    finished run. A finished run of another study (or other simulation settings) is
    refused."""
    if not (run_dir / DESIGN_POINT_JSON).is_file():
        run_study(study, run_dir, resume=(run_dir / STORE).exists())
    with EvaluationStore(run_dir / STORE, read_only=True) as store:
        meta = store.get_meta("campaign")
    record = meta if isinstance(meta, dict) else {}
    expected = campaign_identity(study, 0)
    for key in ("study", "simulation"):
        if json.dumps(record.get(key), sort_keys=True) != \
                json.dumps(expected[key], sort_keys=True, default=str):
            raise ValueError(f"{run_dir} holds a run of another study or settings ({key} "
                             "differs); choose another --run-dir")
    return json.loads((run_dir / DESIGN_POINT_JSON).read_text())


def rms(values: np.ndarray) -> float:
    """Root mean square of a history."""
    return float(np.sqrt(np.mean(np.square(values))))


def add_noise(histories: dict[str, np.ndarray], noise: float, seed: int
              ) -> tuple[dict[str, np.ndarray], dict[str, float]]:
    """Each history plus independent normal noise of std ``noise * RMS(history)``, drawn
    from ``default_rng(seed)`` in the order of ``histories``; returns (noisy, sigmas)."""
    rng = np.random.default_rng(seed)
    noisy, sigma = {}, {}
    for name, values in histories.items():
        sigma[name] = noise * rms(values)
        noisy[name] = values + sigma[name] * rng.standard_normal(values.size)
    return noisy, sigma


def shown(path: str | Path) -> str:
    """``path`` relative to the working directory when inside it (the repository root for
    the shipped sample), else absolute."""
    full = Path(path).resolve()
    try:
        return full.relative_to(Path.cwd().resolve()).as_posix()
    except ValueError:
        return str(full)


def _sha256(path: str | Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def write_csv(path: Path, time: np.ndarray, histories: dict[str, np.ndarray],
              comments: list[str]) -> Path:
    """The measured-test CSV (``#`` comments, then the header contract's columns)."""
    table = pd.DataFrame({"time [s]": time, **{COLUMNS[n][0]: COLUMNS[n][1] * v
                                               for n, v in histories.items()}})
    buf = io.StringIO()
    buf.write("".join(f"# {line}\n" for line in comments))
    table.to_csv(buf, index=False, float_format="%.12g")
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(buf.getvalue())
    tmp.replace(path)
    return path


def run(config: Config) -> Result:
    """Write the sample measured test of ``config`` (module docstring)."""
    study = study_of(config)
    run_dir = Path(config.run_dir)
    point = finished_run(study, run_dir)
    if not point.get("design"):
        raise ValueError(f"{run_dir}: the run found no design point")
    problem = ScalingProblem(study.spec)
    x = np.array([point["design"][n] for n in study.spec.names])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # material tables clamped
        config_m, resp = problem.simulate_model(x)
    time = np.asarray(resp.times, float)
    clean = {n: np.asarray(getattr(resp, n), float) for n in COLUMNS}
    saved = Response.load(run_dir / DESIGN_POINT_NPZ)
    diff = max(float(np.max(np.abs(np.asarray(getattr(saved, n)) - v)) / max(rms(v), 1e-300))
               for n, v in clean.items())
    noisy, sigma = add_noise(clean, config.noise, config.seed)
    obj = point.get("objectives") or {}
    provenance = {
        "study": study.name, "study_file": shown(study.path),
        "study_sha256": _sha256(study.path),
        "overrides": COARSE_9_2 if config.quick else {},
        "run_dir": shown(run_dir), "design": point["design"],
        "J_u": obj.get("J_u"), "J_T": obj.get("J_T"),
        "model_time_step": config_m.simulation.time_step,
        "steps": len(time) - 1, "noise": config.noise, "seed": config.seed,
        "design_point_npz_difference": diff, "hypate": package_version()}
    design = ", ".join(f"{k} = {v:.10g}" for k, v in point["design"].items())
    comments = [
        f"Measured model test for `hypate predict`: the {study.name}"
        f"{' (coarse)' if config.quick else ''} design point, simulated, plus noise",
        f"generated by python -m hypate.studies.scripts.make_model_test "
        f"(hypate {provenance['hypate']})",
        f"study {provenance['study']}: {provenance['study_file']} "
        f"(sha256 {provenance['study_sha256']})",
        f"overrides: {json.dumps(provenance['overrides']) if config.quick else 'none'}",
        f"run directory: {provenance['run_dir']}",
        f"design point: {design}",
        f"J_u = {obj.get('J_u')}, J_T = {obj.get('J_T')}, model time step "
        f"{provenance['model_time_step']:.10g} s, {provenance['steps']} steps",
        f"noise: normal, std {config.noise:g} x RMS of each history "
        f"(deflection {1e3 * sigma['center_deflection']:.4g} mm, temperature "
        f"{sigma['mean_temperature']:.4g} K), numpy default_rng({config.seed})",
        f"re-simulated design point vs the run's design_point.npz: largest difference "
        f"{diff:.3g} x RMS"]
    path = write_csv(Path(config.out), time, noisy, comments)
    return Result(path=path, time=time, clean=clean, noisy=noisy, sigma=sigma,
                  provenance=provenance)


def main(argv: list[str] | None = None) -> None:
    """``python -m hypate.studies.scripts.make_model_test [--coarse] [--study STUDY]
    [--run-dir DIR] [--out FILE] [--noise F] [--seed S]``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--coarse", action="store_true",
                        help="the coarse Sec. 9.2 variant (writes below runs/)")
    parser.add_argument("--study", default=STUDY, help="study file or shipped name")
    parser.add_argument("--run-dir", type=Path, help="run directory (used, or run, there)")
    parser.add_argument("--out", type=Path, help="CSV file to write")
    parser.add_argument("--noise", type=float, default=NOISE, help="std / RMS of a history")
    parser.add_argument("--seed", type=int, default=SEED)
    args = parser.parse_args(argv)
    base = Config.coarse() if args.coarse else Config()
    config = Config(study=str(resolve(args.study, "study")), quick=args.coarse,
                    run_dir=args.run_dir or base.run_dir, out=args.out or base.out,
                    noise=args.noise, seed=args.seed)
    res = run(config)
    print(f"wrote {res.path} ({res.time.size} points; noise {config.noise:g} x RMS, "
          f"seed {config.seed}) from {res.provenance['run_dir']}")


if __name__ == "__main__":
    main()
