"""Building and checking fluid ROMs (Sec. 2.4, Sec. 7.1).

:func:`build_rom_from_config` turns a ROM build file into a :class:`RomFluid`: OLH plan
(:mod:`.plan`), snapshots of the built-in source or external ones (:mod:`.snapshots`),
POD-kriging (:mod:`.pod`). :func:`check_rom` measures the mean NRMSE (Eq. 7.7) against
fresh source samples (data sets 2 and 3 of Sec. 7.1).
"""
from __future__ import annotations

import contextlib
import math
import tempfile
import warnings
from collections.abc import Callable
from concurrent.futures import Executor
from pathlib import Path
from typing import Any

import numpy as np
from hypate.solvers.aero.base import Array, SurfaceState
from hypate.solvers.aero.rom.config import MIN_SAMPLES, RomBuildConfig
from hypate.solvers.aero.rom.geometry import RomGeometry, eq76_wall_temperature
from hypate.solvers.aero.rom.model import RomFluid
from hypate.solvers.aero.rom.openfoam import (
    OpenFoamSettings,
    SnapshotStore,
    provenance,
    run_snapshots,
)
from hypate.solvers.aero.rom.openfoam_run import find_openfoam
from hypate.solvers.aero.rom.plan import olh_plan
from hypate.solvers.aero.rom.pod import PodKriging
from hypate.solvers.aero.rom.snapshots import generate_samples, read_snapshots
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition
from hypate.solvers.numerics.kriging import KernelName
from hypate.solvers.numerics.random import as_rng

__all__ = ["BUILD_STEPS", "EDGE_TEMPERATURE_STEP", "build_rom", "build_rom_from_config",
           "check_holdout", "check_rom", "check_samples", "geometry_from_config", "nrmse",
           "snapshots_path"]

#: The steps of a build, in order, as named to a ``progress(step, done, total)`` callback:
#: source samples (``done`` of ``total`` samples; external snapshots are read in one go),
#: then the pressure and the heat-flux POD-kriging (the POD, one kriging fit per optimized
#: POD coefficient, the multi-output model).
BUILD_STEPS = ("snapshots", "pressure POD-kriging", "heat-flux POD-kriging")
#: The step that follows them in a build with an edge-temperature field (Euler CFD
#: snapshots: the ROM forms its heat flux from the kriged p and T_e, :mod:`.model`).
EDGE_TEMPERATURE_STEP = "edge-temperature POD-kriging"

#: ``progress(step, done, total)``: ``step`` one of :data:`BUILD_STEPS`.
BuildProgress = Callable[[str, int, int], None]


def _stage(progress: BuildProgress | None, step: str) -> Callable[[int, int], None] | None:
    """The ``(done, total)`` callback of one build step (None without ``progress``)."""
    if progress is None:
        return None
    return lambda done, total: progress(step, done, total)


def nrmse(reference: Array, predicted: Array, weights: Array) -> Array:
    """Normalized RMS error of each row, Eq. (7.7), as a fraction:
    ``sqrt(sum(w e^2) / sum(w)) / (max(y_ref) - min(y_ref))``."""
    Y = np.atleast_2d(reference)
    E = np.atleast_2d(predicted) - Y
    w = np.asarray(weights, float)
    rms = np.sqrt((E**2 @ w) / w.sum())
    return rms / np.maximum(np.ptp(Y, axis=1), 1e-300)


def build_rom(geometry: RomGeometry, reference: FlowCondition, inputs: Array,
              pressure: Array, heat_flux: Array, *, bounds: Array | None = None,
              kind: str = "scaled", tolerance: float = 0.005, kernel: KernelName = "rbf",
              trend: str = "linear", n_restarts: int = 2,
              source: dict[str, Any] | None = None, regime: str = "turbulent",
              rng: np.random.Generator | int | None = None,
              optimized_modes: int = 3, progress: BuildProgress | None = None,
              edge_temperature: Array | None = None) -> RomFluid:
    """Fit a ROM from samples ``inputs`` (N_s, N_d) and snapshots (N_s, n) each.

    ``edge_temperature`` (N_s, n), the edge temperature of Euler snapshots whose heat flux
    is Eckert's on it: fitted as a third POD-kriging field, from which (with the pressure)
    the ROM forms its heat flux (:class:`RomFluid`). ``progress(step, done, total)``
    reports the two POD-kriging steps of :data:`BUILD_STEPS` (and
    :data:`EDGE_TEMPERATURE_STEP` with ``edge_temperature``).
    """
    rng = as_rng(rng)
    p_model = PodKriging(tolerance, kernel, trend, n_restarts, rng, optimized_modes).fit(
        inputs, pressure, bounds, progress=_stage(progress, BUILD_STEPS[1]))
    q_model = PodKriging(tolerance, kernel, trend, n_restarts, rng, optimized_modes).fit(
        inputs, heat_flux, bounds, progress=_stage(progress, BUILD_STEPS[2]))
    t_model = None if edge_temperature is None else PodKriging(
        tolerance, kernel, trend, n_restarts, rng, optimized_modes).fit(
        inputs, edge_temperature, bounds, progress=_stage(progress, EDGE_TEMPERATURE_STEP))
    return RomFluid(geometry, reference, p_model, q_model, kind=kind, regime=regime,
                    source=source, edge_temperature_model=t_model)


def geometry_from_config(cfg: RomBuildConfig) -> RomGeometry:
    """:class:`RomGeometry` of a :class:`~hypate.solvers.aero.rom.config.RomBuildConfig`."""
    p = cfg.panel
    modes = np.array([[m.m, m.n] for m in cfg.modes], np.int64)
    return RomGeometry(p.kind, p.length, p.width, p.leading_edge_length, p.thickness,
                       math.radians(p.flow_angle), cfg.grid.n_x, cfg.grid.n_y, modes)


def snapshots_path(cfg: RomBuildConfig, base_dir: str | Path | None = None) -> Path:
    """The external snapshots file of ``[source] path``: relative to ``base_dir`` (the
    build file's folder) unless absolute."""
    path = Path(cfg.source.path)
    return Path(base_dir) / path if base_dir is not None and not path.is_absolute() else path


def _openfoam_snapshots(cfg: RomBuildConfig, geometry: RomGeometry, reference: FlowCondition,
                        D: Array, holdout: Array, executor: Executor | None,
                        store: str | Path | None, resume: bool,
                        progress: BuildProgress | None
                        ) -> tuple[Array, Array, Array, Array, dict[str, Any], tuple | None]:
    """Training and held-out snapshots of the OpenFOAM source (:mod:`.openfoam`): inputs,
    pressure, heat flux, edge temperature of the converged training snapshots, the
    provenance, the held-out set (inputs, pressure, heat flux). Rejected snapshots are left
    out with a warning that gives their reasons."""
    openfoam = find_openfoam()
    src = cfg.source
    settings = OpenFoamSettings(src.model, src.resolution.resolution(src.model), src.regime,
                                src.timeout)
    with contextlib.ExitStack() as stack:
        if store is None:
            store = stack.enter_context(tempfile.TemporaryDirectory(prefix="hypate-cfd-"))
        snapshot_store = SnapshotStore(store)
        if snapshot_store.count() and not resume:
            raise InputError("--resume", f"the snapshot store {store} holds "
                             f"{snapshot_store.count()} finished snapshots: resume to reuse "
                             "them, or remove the folder")
        total = D.shape[0] + holdout.shape[0]
        stage = _stage(progress, BUILD_STEPS[0])
        train = run_snapshots(geometry, D, reference, settings, openfoam, snapshot_store,
                              executor, None if stage is None else
                              (lambda done, _n: stage(done, total)))
        held = run_snapshots(geometry, holdout, reference, settings, openfoam,
                             snapshot_store, executor, None if stage is None else
                             (lambda done, _n: stage(D.shape[0] + done, total)))
    rejected = train.rejections() + held.rejections()
    X, P, Q, T_e = train.arrays()
    if X.shape[0] < MIN_SAMPLES:
        raise InputError("source", f"only {X.shape[0]} of {D.shape[0]} CFD snapshots "
                         f"converged (at least {MIN_SAMPLES} needed): "
                         + "; ".join(rejected[:3]))
    if rejected:
        warnings.warn(f"{len(rejected)} CFD snapshot(s) rejected and left out: "
                      + "; ".join(rejected[:5]), RuntimeWarning, stacklevel=3)
    Xh, Ph, Qh, _ = held.arrays()
    return X, P, Q, T_e, provenance(train, held), ((Xh, Ph, Qh) if Xh.shape[0] else None)


def build_rom_from_config(cfg: RomBuildConfig, base_dir: str | Path | None = None,
                          executor: Executor | None = None, samples: int | None = None,
                          progress: BuildProgress | None = None,
                          store: str | Path | None = None, resume: bool = False
                          ) -> RomFluid:
    """Build the ROM described by a :class:`~hypate.solvers.aero.rom.config.RomBuildConfig`:
    OLH plan + built-in source (or external snapshots) + POD-kriging.

    Parameters
    ----------
    cfg : RomBuildConfig
    base_dir : str or Path, optional
        Folder that relative snapshot paths are taken from.
    executor : concurrent.futures.Executor, optional
        Runs the source samples (in chunks).
    samples : int, optional
        Overrides ``[training] samples``.
    progress : callable, optional
        ``progress(step, done, total)`` as each step of :data:`BUILD_STEPS` advances (the
        caller decides how to show it; the builder prints nothing).
    store : str or Path, optional
        OpenFOAM source: the folder of finished snapshots (:class:`.openfoam.SnapshotStore`;
        default a temporary one).
    resume : bool
        OpenFOAM source: reuse the snapshots already in ``store`` (otherwise a store that
        holds some is refused).
    """
    geometry = geometry_from_config(cfg)
    reference = cfg.reference.flow()
    tr = cfg.training
    rng = np.random.default_rng(tr.seed)
    a_bounds = np.array([m.range for m in cfg.modes], float)
    t_bounds = np.array([cfg.wall_temperature.range], float)
    src: dict[str, Any] = {"kind": cfg.source.kind,
                           "boundary_layer": cfg.source.boundary_layer,
                           "regime": cfg.source.regime}
    n_s = geometry.n_modes
    if cfg.conventional is not None:
        if cfg.source.kind != "shock-expansion":
            raise InputError("conventional", "the conventional ROM is built from the "
                             "built-in source")
        N = samples or tr.samples
        box = np.vstack([[cfg.conventional.mach], [cfg.conventional.altitude], a_bounds,
                         t_bounds])
        plan = olh_plan(box, N, rng)
        P = np.empty((N, geometry.n_x * geometry.n_y))
        Q = np.empty_like(P)
        D = np.empty((N, n_s + 4))
        for i, row in enumerate(plan):
            flow = FlowCondition.from_altitude(row[0], row[1])
            P[i:i + 1], Q[i:i + 1] = generate_samples(geometry, row[None, 2:2 + n_s],
                                                      row[None, -1], flow, source=src)
            D[i] = np.r_[flow.mach, flow.pressure, flow.temperature, row[2:]]
            if progress is not None:
                progress(BUILD_STEPS[0], i + 1, N)
        return build_rom(geometry, reference, D, P, Q, kind="conventional",
                         tolerance=tr.pod_tolerance, kernel=tr.kernel, trend=tr.trend,
                         n_restarts=tr.restarts, source=src, regime=cfg.source.regime, rng=rng,
                         optimized_modes=tr.optimized_modes, progress=progress)
    bounds = np.vstack([a_bounds, t_bounds])
    if cfg.source.kind == "openfoam":
        D = olh_plan(bounds, samples or tr.samples, rng)
        # the held-out plan has its own seed: the training plan stays that of the samples
        H = olh_plan(bounds, cfg.source.holdout, tr.seed + 1) if cfg.source.holdout else \
            np.zeros((0, bounds.shape[0]))
        D, P, Q, T_e, prov, held = _openfoam_snapshots(cfg, geometry, reference, D, H,
                                                       executor, store, resume, progress)
        src["model"] = cfg.source.model
        euler = cfg.source.model == "euler"  # its heat flux is Eckert's on the edge state
        rom = build_rom(geometry, reference, D, P, Q, bounds=bounds,
                        tolerance=tr.pod_tolerance, kernel=tr.kernel, trend=tr.trend,
                        n_restarts=tr.restarts, source=src, regime=cfg.source.regime,
                        rng=rng, optimized_modes=tr.optimized_modes, progress=progress,
                        edge_temperature=T_e if euler else None)
        rom.provenance = dict(prov, heat_flux_rom=rom.heat_flux_law)
        rom.holdout = held
        return rom
    if cfg.source.kind == "snapshots":
        D, P, Q = read_snapshots(snapshots_path(cfg, base_dir), geometry)
        bounds = np.stack([np.minimum(bounds[:, 0], D.min(axis=0)),
                           np.maximum(bounds[:, 1], D.max(axis=0))], axis=1)
        if progress is not None:
            progress(BUILD_STEPS[0], D.shape[0], D.shape[0])
    else:
        D = olh_plan(bounds, samples or tr.samples, rng)
        P, Q = generate_samples(geometry, D[:, :n_s], D[:, -1], reference, source=src,
                                executor=executor, progress=_stage(progress, BUILD_STEPS[0]))
    return build_rom(geometry, reference, D, P, Q, bounds=bounds, tolerance=tr.pod_tolerance,
                     kernel=tr.kernel, trend=tr.trend, n_restarts=tr.restarts, source=src,
                     regime=cfg.source.regime, rng=rng, progress=progress)


def check_samples(rom: RomFluid, n_samples: int, temperature: str = "uniform",
                  rng: np.random.Generator | int | None = None) -> tuple[Array, Array]:
    """Fresh check inputs: modal amplitudes (N, N_S) and wall temperatures (N, n).

    ``temperature = "uniform"`` draws an OLH plan of the training box (amplitudes and a
    uniform wall temperature, as data set 2 of Sec. 7.1); ``"eq76"`` follows data set 3:
    the first three modes from their training ranges (others zero) and the non-uniform wall
    temperature of Eq. (7.6) with b1 in [0.2, 0.9], b2, b5 in [-0.3, 0.3] (Table 7.1),
    rescaled into the training temperature range by Eqs. (7.4)-(7.5).
    """
    g = rom.geometry
    n_s = g.n_modes
    i_a = slice(3, 3 + n_s) if rom.kind == "conventional" else slice(0, n_s)
    box = np.vstack([rom.input_bounds[i_a], rom.input_bounds[-1:]])
    rng = as_rng(rng)
    x_norm = g.points(1.0).x / g.length
    if temperature == "uniform":
        X = olh_plan(box, n_samples, rng)
        return X[:, :n_s], np.repeat(X[:, -1:], x_norm.size, axis=1)
    if temperature != "eq76":
        raise InputError("--temperature", "must be 'uniform' or 'eq76'")
    k = min(3, n_s)
    X = olh_plan(np.vstack([box[:k], [[0.2, 0.9], [-0.3, 0.3], [-0.3, 0.3]]]), n_samples, rng)
    A = np.zeros((n_samples, n_s))
    A[:, :k] = X[:, :k]
    return A, eq76_wall_temperature(x_norm, X[:, k:], tuple(rom.input_bounds[-1]))


def check_rom(rom: RomFluid, n_samples: int = 100, flow: FlowCondition | None = None,
              scale: float = 1.0, temperature: str = "uniform",
              rng: np.random.Generator | int | None = None, executor: Executor | None = None
              ) -> dict[str, float]:
    """Mean NRMSE (Eq. 7.7, fractions) of the ROM against the built-in source on fresh
    samples at ``flow`` (default: the reference condition) and geometric scale ``scale``.

    Returns ``{"pressure_nrmse", "heat_flux_nrmse", "samples"}``.
    """
    if rom.source.get("kind") != "shock-expansion":
        raise InputError("rom", "this ROM was trained on external snapshots; checking it "
                         "needs the built-in source (rebuild with [source] kind = "
                         "'shock-expansion') or your own held-out snapshots")
    if n_samples < 1:
        raise InputError("--samples", "must be >= 1")
    if not scale > 0.0:
        raise InputError("--scale", "must be > 0")
    flow = flow or rom.reference
    g = rom.geometry
    A, T = check_samples(rom, n_samples, temperature, rng)
    P, Q = generate_samples(g, A, T, flow, scale, rom.source, executor)
    pts = g.points(scale)
    w, ws = g.deformation(A, scale)
    fluid = rom.with_options(scale=None)
    pr = np.empty_like(P)
    qr = np.empty_like(Q)
    zero = np.zeros(pts.n)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        for i in range(n_samples):
            loads = fluid.evaluate(pts, SurfaceState(w[i], ws[i], zero, T[i]), flow)
            pr[i], qr[i] = loads.pressure, loads.heat_flux
    return {"pressure_nrmse": float(nrmse(P, pr, pts.weights).mean()),
            "heat_flux_nrmse": float(nrmse(Q, qr, pts.weights).mean()),
            "samples": int(n_samples)}


def check_holdout(rom: RomFluid) -> dict[str, Any]:
    """Errors of the ROM on its held-out snapshots (snapshots of the source kept out of the
    fit, stored in the ROM file): per snapshot the NRMSE of Eq. (7.7) and the largest
    pointwise error, both in units of the snapshot's range ``max(y) - min(y)``; their median
    and maximum for pressure and heat flux (fractions).

    At the reference condition and scale, with a uniform wall temperature, the corrections
    of :class:`RomFluid` are the identity (Eqs. 2.65, 2.72), so the POD-kriging prediction
    at the snapshot's inputs is what the ROM returns (:meth:`RomFluid.reference_loads`:
    the heat flux kriged, or formed from the kriged pressure and edge temperature).
    """
    if rom.holdout is None:
        raise InputError("rom", "this ROM file holds no held-out snapshots (build it with "
                         "[source] holdout > 0)")
    D, P, Q = rom.holdout
    w = rom.geometry.points(1.0).weights
    out: dict[str, Any] = {"samples": int(D.shape[0])}
    for name, pred, Y in zip(("pressure", "heat_flux"), rom.reference_loads(D), (P, Q)):
        e_rms = nrmse(Y, pred, w)
        e_max = np.max(np.abs(pred - Y), axis=1) / np.maximum(np.ptp(Y, axis=1), 1e-300)
        out[name] = {"nrmse_median": float(np.median(e_rms)), "nrmse_max": float(e_rms.max()),
                     "max_error_median": float(np.median(e_max)),
                     "max_error_max": float(e_max.max())}
    return out
