"""Calibrate the memory and time estimate of one simulation
(:mod:`hypate.scaling.workflow.campaigns.resources`) against measured simulations.

Each point simulates the quick-start study's prototype (the Sec. 9.2 sandwich: 5 thermal
levels) or its model (one Ti 6242 layer: ``sublayers + 1`` levels) at a mesh and a number of
steps, alone in a fresh process: the memory is the rise of the peak resident set
(``VmHWM`` after resetting it through ``/proc/self/clear_refs``, Linux) over the resident
set just before the simulation, the time its wall time. The coefficients are the
non-negative least-squares fit of the features of
:class:`~hypate.scaling.workflow.campaigns.resources.SimulationSize` (memory: relative errors, so
that small and large meshes weigh alike), printed with each point's error::

    python -m hypate.studies.scripts.calibrate_resources [--points quick|full] [--check] [--json]

Does nothing at import; :func:`run` returns the points and the fit.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from hypate.scaling.workflow.campaigns.resources import SimulationSize, estimate, simulation_size
from hypate.scaling.workflow.vocabulary.derived import study_data
from hypate.scaling.workflow.vocabulary.problem import ScalingProblem
from hypate.scaling.workflow.vocabulary.shipped import default_study
from hypate.scaling.workflow.vocabulary.study import load_study, parse_study
from scipy.optimize import nnls

#: (which, mesh, steps, model sub-layers) of the calibration points.
POINTS = {
    "quick": [("prototype", n, s, 2) for n in (2, 4, 8, 12) for s in (2, 10)]
    + [("model", n, 6, s) for n in (4, 8, 12) for s in (1, 4)],
    "full": [("prototype", n, 10, 2) for n in (2, 4, 8, 12, 16, 24, 32, 40)]
    + [("prototype", n, s, 2) for n in (8, 24) for s in (2, 5)]
    + [("model", n, 6, s) for n in (4, 8, 16, 24, 32) for s in (1, 4, 8)],
    # held out of the fit: a larger mesh, more steps, other layers than any fitted point
    "check": [("prototype", 56, 4, 2), ("prototype", 16, 24, 2), ("model", 40, 8, 6),
              ("model", 20, 3, 3)],
}


@dataclass(frozen=True)
class Point:
    """One measured simulation: its sizes, the memory rise (bytes) and wall time (s)."""

    which: str
    size: SimulationSize
    memory: float
    seconds: float
    status: str


def _status() -> dict[str, float]:
    """VmRSS and VmHWM of this process (bytes)."""
    out = {}
    for line in Path("/proc/self/status").read_text().splitlines():
        key, _, value = line.partition(":")
        if key in ("VmRSS", "VmHWM"):
            out[key] = float(value.split()[0]) * 1024.0
    return out


def measure_here(which: str, mesh: int, steps: int, sublayers: int) -> dict[str, Any]:
    """Simulate one point in this process (call it in a fresh one: :func:`measure`)."""
    study = load_study(default_study())
    data = study_data(study)
    data["simulation"].update(mesh=[mesh, mesh], steps=steps)
    data["model"]["sublayers"] = sublayers
    study = parse_study(data, study.path)
    problem = ScalingProblem(study.spec)
    x = (np.asarray(problem.xl, float) + np.asarray(problem.xu, float)) / 2.0
    config = study.spec.prototype if which == "prototype" else problem.model_configuration(x)
    size = simulation_size(config)
    Path("/proc/self/clear_refs").write_text("5")  # the peak from here on
    before = _status()["VmRSS"]
    t0 = time.perf_counter()
    if which == "prototype":
        status = problem.prototype_response.status
    else:
        status = problem.simulate_model(x, keep_fields=False)[1].status
    seconds = time.perf_counter() - t0
    return {"which": which, "mesh": list(size.mesh), "levels": size.levels,
            "steps": size.steps, "memory": _status()["VmHWM"] - before, "seconds": seconds,
            "status": status}


def measure(which: str, mesh: int, steps: int, sublayers: int) -> Point:
    """One point, measured in a fresh Python process (one BLAS thread, as the simulator)."""
    code = ("import json, sys; from hypate.studies.scripts.calibrate_resources import "
            f"measure_here; print(json.dumps(measure_here({which!r}, {mesh}, {steps}, "
            f"{sublayers})))")
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True,
                         text=True).stdout
    rec = json.loads(out.strip().splitlines()[-1])
    size = SimulationSize(tuple(rec["mesh"]), rec["levels"], rec["steps"])
    return Point(rec["which"], size, rec["memory"], rec["seconds"], rec["status"])


def fit(points: list[Point]) -> dict[str, float]:
    """Non-negative least-squares coefficients of the estimate (the keys of
    :data:`~hypate.scaling.workflow.campaigns.resources.CALIBRATION`); memory in relative error."""
    A = np.array([[*p.size.memory_features(), 1.0] for p in points])
    # columns (thermal LU, shell Cholesky, unknowns, cached mass matrices, 1)
    y = np.array([p.memory for p in points])
    w = 1.0 / np.maximum(y, 1.0)
    m, _ = nnls(A * w[:, None], y * w)
    T = np.array([[p.size.steps * f for f in p.size.work_features()] + [1.0] for p in points])
    t = np.array([p.seconds for p in points])
    wt = 1.0 / np.maximum(t, 1e-3)
    s, _ = nnls(T * wt[:, None], t * wt)
    return {"m_t": float(m[0]), "m_s": float(m[1]), "m_n": float(m[2]), "m_c": float(m[3]),
            "m_0": float(m[4]),
            "s_t": float(s[0]), "s_s": float(s[1]), "s_n": float(s[2]), "s_0": float(s[3])}


def errors(points: list[Point], coefficients: dict[str, float] | None = None
           ) -> list[dict[str, Any]]:
    """Each point with its estimate and the relative errors (estimate / measured - 1)."""
    rows = []
    for p in points:
        e = estimate(p.size, coefficients)
        rows.append({"which": p.which, "mesh": "x".join(map(str, p.size.mesh)),
                     "levels": p.size.levels, "steps": p.size.steps,
                     "memory_MB": p.memory / 2**20, "estimate_MB": e.memory / 2**20,
                     "memory_error": e.memory / p.memory - 1.0,
                     "seconds": p.seconds, "estimate_s": e.seconds,
                     "time_error": e.seconds / p.seconds - 1.0, "status": p.status})
    return rows


def run(points: str = "quick", check: bool = False) -> dict[str, Any]:
    """Measure the points of :data:`POINTS` ``points`` and fit: ``{"fit", "errors",
    "shipped"}`` (each point's errors with the fitted and with the shipped coefficients);
    with ``check``, also ``"check"``: the held-out points of ``POINTS["check"]`` with the
    fitted coefficients."""
    measured = [measure(*spec) for spec in POINTS[points]]
    coefficients = fit(measured)
    out = {"fit": coefficients, "errors": errors(measured, coefficients),
           "shipped": errors(measured)}
    if check:
        out["check"] = errors([measure(*spec) for spec in POINTS["check"]], coefficients)
    return out


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", choices=("quick", "full"), default="quick")
    parser.add_argument("--check", action="store_true", help="also measure the held-out "
                        "points and their errors with the fitted coefficients")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    result = run(args.points, args.check)
    if args.json:
        print(json.dumps(result, indent=2))
        return
    print("fit:", ", ".join(f"{k} = {v:.3g}" for k, v in result["fit"].items()))
    for label in ("errors", "shipped", "check"):
        print(f"-- {label} (estimate / measured - 1)")
        for r in result.get(label, []):
            print(f"{r['which']:>9s} {r['mesh']:>7s} L={r['levels']} steps={r['steps']:<3d} "
                  f"memory {r['memory_MB']:8.1f} MB est {r['estimate_MB']:8.1f} "
                  f"({100 * r['memory_error']:+5.1f} %)  time {r['seconds']:7.2f} s est "
                  f"{r['estimate_s']:7.2f} ({100 * r['time_error']:+5.1f} %)")


if __name__ == "__main__":  # pragma: no cover
    main()
