"""The OpenFOAM snapshot source of the fluid ROM (``[source] kind = "openfoam"``; Secs. 2.2,
2.4.5, 7.1): CFD snapshots of the deformed, heated panel as campaign work.

Each snapshot (modal amplitudes ``a`` in units of the reference thickness, uniform wall
temperature ``T_w``) is one task on the caller's ``concurrent.futures.Executor`` (a process
pool, or a ``dask.distributed`` client): :func:`snapshot_spec` turns it into an OpenFOAM
case (the plate ahead of the panel and the panel deformed by ``h sum a_k phi_k``, Eq. 7.1,
at the reference condition), :func:`run_snapshot` runs it
(:func:`~hypate.solvers.aero.rom.openfoam_run.run_case`) and samples the wall onto the ROM
grid (``p - p_inf``; heat flux into the wall). A snapshot that did not converge or holds NaN
comes back rejected, with its reason.

Heat flux by model: the viscous models (``"laminar"``, ``"spalart-allmaras"``) give the
wall heat flux of the CFD solution; the Euler model gives the pressure of the CFD solution
and the heat flux of Eckert's reference temperature (Eqs. 2.39-2.43, ``[source] regime``)
on the *CFD's* edge state (the inviscid wall pressure and temperature, the edge velocity
from the conserved total temperature) -- the shock-expansion source's heat-flux law on a
CFD edge instead of the march's.

:class:`SnapshotStore` keeps finished snapshots crash-safe (one ``.npz`` per snapshot,
written to a temporary name and renamed), keyed by the snapshot's inputs and everything
that decides its result; :func:`run_snapshots` reuses stored ones and runs the rest, with
``progress(done, total)`` after each. :func:`provenance` summarizes a snapshot set
(OpenFOAM version, model, resolution, convergence figures) for the ROM file.
"""
from __future__ import annotations

import hashlib
import json
import math
import os
import shutil
import tempfile
from collections.abc import Callable, Sequence
from concurrent.futures import Executor, Future, as_completed
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from hypate.solvers.aero.base import Array
from hypate.solvers.aero.rom.geometry import RomGeometry
from hypate.solvers.aero.rom.openfoam_case import CaseSpec, Resolution, write_case
from hypate.solvers.aero.rom.openfoam_run import CaseResult, OpenFoam, run_case
from hypate.solvers.aero.shock_expansion import eckert_heat_flux_edge
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition

__all__ = ["OpenFoamSettings", "SnapshotRecord", "SnapshotSet", "SnapshotStore",
           "provenance", "resample", "run_snapshot", "run_snapshots", "snapshot_spec"]

#: Points of the panel's polyLine edge per streamwise cell: the deformed shape is followed
#: well inside a cell.
EDGE_POINTS_PER_CELL = 4
#: A snapshot whose solution diverges (the impulsive start of the free stream over a
#: strongly deformed panel) is run again from the start at half the Courant number, at
#: most this many times: its steady state does not depend on the pseudo-time step.
DIVERGED_RETRIES = 2


@dataclass(frozen=True)
class OpenFoamSettings:
    """How snapshots are computed (the ``[source]`` keys of an ``openfoam`` build file).

    Attributes
    ----------
    model : {"euler", "laminar", "spalart-allmaras"}
    resolution : Resolution
    regime : {"turbulent", "laminar"}
        Eckert regime of the Euler model's heat flux.
    timeout : float
        Wall-clock seconds a snapshot may take before it is rejected.
    """

    model: str
    resolution: Resolution
    regime: str = "turbulent"
    timeout: float = 3600.0

    def as_dict(self) -> dict[str, Any]:
        return {"model": self.model, "resolution": self.resolution.as_dict(),
                "regime": self.regime, "timeout": self.timeout}


@dataclass
class SnapshotRecord:
    """One finished snapshot (converged or rejected) on the ROM grid: ``pressure`` is
    ``p - p_inf`` (Pa), ``heat_flux`` into the wall (W/m^2), ``edge_temperature`` the CFD
    wall-cell temperature (K; the Euler model's edge temperature, from which the ROM forms
    its Eckert heat flux)."""

    inputs: Array
    converged: bool
    reason: str
    pressure: Array
    heat_flux: Array
    edge_temperature: Array
    iterations: int
    drift_pressure: float
    drift_heat_flux: float
    seconds: float
    courant: float = math.nan  # of the run that gave the record (nan: not recorded)

    def arrays(self) -> dict[str, np.ndarray]:
        return {"inputs": self.inputs, "converged": np.array(self.converged),
                "reason": np.array(self.reason), "pressure": self.pressure,
                "heat_flux": self.heat_flux, "edge_temperature": self.edge_temperature,
                "iterations": np.array(self.iterations),
                "drift_pressure": np.array(self.drift_pressure),
                "drift_heat_flux": np.array(self.drift_heat_flux),
                "seconds": np.array(self.seconds), "courant": np.array(self.courant)}

    @classmethod
    def from_arrays(cls, d: dict[str, np.ndarray]) -> SnapshotRecord:
        return cls(np.asarray(d["inputs"], float), bool(d["converged"]), str(d["reason"]),
                   np.asarray(d["pressure"], float), np.asarray(d["heat_flux"], float),
                   np.asarray(d["edge_temperature"], float), int(d["iterations"]),
                   float(d["drift_pressure"]), float(d["drift_heat_flux"]), float(d["seconds"]),
                   float(d["courant"]) if "courant" in d else math.nan)


def snapshot_spec(geometry: RomGeometry, amplitudes: Array, wall_temperature: float,
                  flow: FlowCondition, settings: OpenFoamSettings) -> CaseSpec:
    """The OpenFOAM case of one snapshot: the flat rigid plate of ``L_le`` and the panel
    deformed by ``w = h sum_k a_k sin(m_k pi x / a)`` (Eq. 7.1; ``a`` in units of ``h``)."""
    if geometry.kind != "2d":
        raise InputError("panel.kind", "the OpenFOAM source computes 2-D snapshots (kind = "
                         "'2d'); a 3-D panel uses a 2-D ROM strip-wise")
    a, l_le = geometry.length, geometry.leading_edge_length
    n = EDGE_POINTS_PER_CELL * settings.resolution.cells_panel + 1
    x = np.linspace(0.0, a, n)
    w = geometry.thickness * geometry.mode_shapes(x, np.zeros_like(x)) @ np.asarray(
        amplitudes, float)
    w[[0, -1]] = 0.0  # the sine modes vanish at the supports (exactly, not to round-off)
    plate = np.array([[0.0, 0.0], [l_le, 0.0]])
    panel = np.column_stack([l_le + x, w])
    return CaseSpec(plate, panel, flow, float(wall_temperature), settings.model,
                    settings.resolution)


def resample(x: Array, values: Array, x_new: Array) -> Array:
    """Piecewise-linear resampling of face values onto grid points, extended linearly past
    the first and last face (the panel edges lie half a cell outside the face centres)."""
    x, v, xn = (np.asarray(a, float) for a in (x, values, x_new))
    out = np.interp(xn, x, v)
    lo, hi = xn < x[0], xn > x[-1]
    out[lo] = v[0] + (xn[lo] - x[0]) * (v[1] - v[0]) / (x[1] - x[0])
    out[hi] = v[-1] + (xn[hi] - x[-1]) * (v[-1] - v[-2]) / (x[-1] - x[-2])
    return out


def _wall_loads(geometry: RomGeometry, case: CaseResult, wall_temperature: float,
                flow: FlowCondition, settings: OpenFoamSettings
                ) -> tuple[Array, Array, Array]:
    """``p - p_inf``, the heat flux into the wall and the wall-cell (edge) temperature on
    the ROM grid."""
    x_grid = geometry.points(1.0).x
    x_faces = case.x - geometry.leading_edge_length
    p_abs = resample(x_faces, case.pressure, x_grid)
    T_e = resample(x_faces, case.temperature, x_grid)
    if settings.model == "euler":  # Eckert on the CFD edge state, Eqs. (2.39)-(2.43)
        q = eckert_heat_flux_edge(flow, p_abs, T_e, np.full(x_grid.size, wall_temperature),
                                  geometry.leading_edge_length + x_grid, settings.regime)
    else:
        q = resample(x_faces, case.heat_flux, x_grid)
    return p_abs - flow.pressure, q, T_e


def run_snapshot(geometry: RomGeometry, inputs: Array, flow: FlowCondition,
                 settings: OpenFoamSettings, openfoam: OpenFoam, work: str | Path
                 ) -> SnapshotRecord:
    """Compute one snapshot (inputs ``[a_1 .. a_NS, T_w]``) in a fresh case folder under
    ``work`` (removed afterwards; a rejected case keeps its solver log beside it). A
    solution that diverges is run again at half the Courant number, up to
    :data:`DIVERGED_RETRIES` times; the record keeps the Courant number that gave it and the
    seconds of every attempt. Module-level, so that process pools and dask can run it."""
    inputs = np.asarray(inputs, float)
    n = geometry.n_x * geometry.n_y
    Path(work).mkdir(parents=True, exist_ok=True)
    res = settings.resolution
    seconds = 0.0
    for attempt in range(DIVERGED_RETRIES + 1):
        run = replace(settings, resolution=replace(res, courant=res.courant / 2**attempt))
        spec = snapshot_spec(geometry, inputs[:-1], inputs[-1], flow, run)
        folder = Path(tempfile.mkdtemp(prefix="case-", dir=work))
        try:
            case = run_case(write_case(folder, spec), openfoam, run.resolution,
                            spec.viscous, timeout=settings.timeout)
            seconds += case.cpu_seconds
            if case.diverged and attempt < DIVERGED_RETRIES:
                continue
            nan = np.full(n, np.nan)
            p, q, T_e = (_wall_loads(geometry, case, inputs[-1], flow, settings)
                         if case.converged else (nan, nan, nan))
            reason = case.reason
            if case.converged and not all(np.all(np.isfinite(v)) for v in (p, q, T_e)):
                reason = "NaN in the sampled wall loads"
            if reason:
                log = folder / "log.rhoCentralFoam"
                if log.is_file():
                    shutil.copy(log, folder.with_suffix(".log"))
            return SnapshotRecord(inputs, not reason, reason, p, q, T_e, case.iterations,
                                  case.drift_pressure, case.drift_heat_flux, seconds,
                                  run.resolution.courant)
        finally:
            shutil.rmtree(folder, ignore_errors=True)
    raise AssertionError("unreachable: the last attempt returns")


def snapshot_key(geometry: RomGeometry, inputs: Array, flow: FlowCondition,
                 settings: OpenFoamSettings, version: str) -> str:
    """SHA-256 of everything that decides a snapshot: a stored one is reused only when all
    of it is the same."""
    record = {"inputs": [float(v) for v in np.asarray(inputs, float)],
              "geometry": [float(v) for v in geometry.as_array()],
              "modes": np.asarray(geometry.modes).tolist(), "flow": flow.as_record(),
              "settings": settings.as_dict(), "openfoam": version}
    return hashlib.sha256(json.dumps(record, sort_keys=True).encode()).hexdigest()[:24]


class SnapshotStore:
    """Finished snapshots in a folder, one ``<key>.npz`` each, written atomically (temporary
    file + rename): a killed build loses at most the snapshots it was running."""

    def __init__(self, folder: str | Path) -> None:
        self.folder = Path(folder)

    def path(self, key: str) -> Path:
        return self.folder / f"{key}.npz"

    def count(self) -> int:
        return len(list(self.folder.glob("*.npz"))) if self.folder.is_dir() else 0

    def load(self, key: str) -> SnapshotRecord | None:
        path = self.path(key)
        if not path.is_file():
            return None
        try:
            with np.load(path, allow_pickle=False) as data:
                return SnapshotRecord.from_arrays(dict(data))
        except (OSError, ValueError, KeyError):
            return None  # a damaged file is computed again

    def save(self, key: str, record: SnapshotRecord) -> None:
        self.folder.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{key}-", suffix=".tmp", dir=self.folder)
        try:
            with os.fdopen(fd, "wb") as fh:
                np.savez(fh, **record.arrays())  # type: ignore[arg-type]  # no allow_pickle key in **arrays
                fh.flush()
                os.fsync(fh.fileno())
            os.replace(tmp, self.path(key))
        finally:
            if os.path.exists(tmp):
                os.unlink(tmp)


@dataclass
class SnapshotSet:
    """The records of a campaign, in the order of its inputs."""

    records: list[SnapshotRecord]
    reused: int = 0
    version: str = ""
    settings: OpenFoamSettings | None = None

    @property
    def converged(self) -> np.ndarray:
        return np.array([r.converged for r in self.records], bool)

    def arrays(self) -> tuple[Array, Array, Array, Array]:
        """Inputs, pressure, heat flux and edge temperature of the converged snapshots."""
        ok = [r for r in self.records if r.converged]
        if not ok:
            return np.zeros((0, 0)), np.zeros((0, 0)), np.zeros((0, 0)), np.zeros((0, 0))
        return (np.array([r.inputs for r in ok]), np.array([r.pressure for r in ok]),
                np.array([r.heat_flux for r in ok]),
                np.array([r.edge_temperature for r in ok]))

    def rejections(self) -> list[str]:
        return [f"{np.array2string(r.inputs, precision=3)}: {r.reason}"
                for r in self.records if not r.converged]


def run_snapshots(geometry: RomGeometry, inputs: Array, flow: FlowCondition,
                  settings: OpenFoamSettings, openfoam: OpenFoam, store: SnapshotStore,
                  executor: Executor | None = None,
                  progress: Callable[[int, int], None] | None = None) -> SnapshotSet:
    """All snapshots of ``inputs`` (N, N_S + 1): stored ones reused, the others run (on
    ``executor`` when given, else in-process) and stored as each finishes.

    ``progress(done, N)`` is called once with the reused count and after every snapshot.
    """
    X = np.atleast_2d(np.asarray(inputs, float))
    keys = [snapshot_key(geometry, x, flow, settings, openfoam.version) for x in X]
    records: list[SnapshotRecord | None] = [store.load(k) for k in keys]
    reused = sum(r is not None for r in records)
    todo = [i for i, r in enumerate(records) if r is None]
    work = store.folder / "work"
    done = reused
    if progress is not None:
        progress(done, len(X))

    def finish(i: int, record: SnapshotRecord) -> None:
        nonlocal done
        store.save(keys[i], record)
        records[i] = record
        done += 1
        if progress is not None:
            progress(done, len(X))

    if executor is None:
        for i in todo:
            finish(i, run_snapshot(geometry, X[i], flow, settings, openfoam, work))
    else:
        futures: dict[Future, int] = {
            executor.submit(run_snapshot, geometry, X[i], flow, settings, openfoam, work): i
            for i in todo}
        for fut in as_completed(futures):
            finish(futures[fut], fut.result())
    shutil.rmtree(work, ignore_errors=True)
    return SnapshotSet([r for r in records if r is not None], reused, openfoam.version,
                       settings)


def provenance(training: SnapshotSet, holdout: SnapshotSet | None = None) -> dict[str, Any]:
    """What a ROM file records about its CFD snapshots: solver and version, model,
    resolution, counts (training, held out, rejected with their reasons, converged only at
    a lower Courant number after a diverged start) and convergence figures (iterations,
    wall-average drifts, seconds per snapshot)."""
    s = training.settings
    records = training.records + (holdout.records if holdout is not None else [])
    ok = [r for r in records if r.converged]

    def stats(values: Sequence[float]) -> dict[str, float]:
        v = np.asarray(values, float)
        v = v[np.isfinite(v)]
        return ({"median": float(np.median(v)), "max": float(np.max(v))} if v.size
                else {"median": math.nan, "max": math.nan})

    rejections = training.rejections() + (holdout.rejections() if holdout else [])
    return {
        "solver": "OpenFOAM rhoCentralFoam", "openfoam_version": training.version,
        "model": s.model if s else "", "resolution": s.resolution.as_dict() if s else {},
        "heat_flux": ("CFD wall heat flux" if s and s.model != "euler" else
                      f"Eckert reference temperature ({s.regime if s else ''}) on the CFD "
                      "edge state"),
        "snapshots": int(training.converged.sum()),
        "holdout": int(holdout.converged.sum()) if holdout is not None else 0,
        "rejected": len(rejections), "rejections": rejections[:20],
        "iterations": stats([r.iterations for r in ok]),
        "drift_pressure": stats([r.drift_pressure for r in ok]),
        "drift_heat_flux": stats([r.drift_heat_flux for r in ok]),
        "seconds": stats([r.seconds for r in ok]),
        "lower_courant": sum(1 for r in ok if s is not None and math.isfinite(r.courant)
                             and r.courant < s.resolution.courant),
        "cpu_seconds_total": float(sum(r.seconds for r in records)),
    }
