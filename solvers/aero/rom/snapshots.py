"""Where ROM snapshots come from: the built-in source or external files (Sec. 2.4.5).

:func:`generate_samples` evaluates the built-in shock-expansion source (chunks submitted to a
``concurrent.futures.Executor``); :func:`read_snapshots` reads external snapshots
(``[source] kind = "snapshots"``) in one of two layouts.

*NPZ* (``numpy.savez``; loaded with ``allow_pickle=False``):

* ``inputs`` -- float array (N_s, N_S + 1): the modal amplitudes ``a_1 .. a_NS`` in units of
  the panel thickness, in the order of the ``[[modes]]`` of the build file, then the
  uniform wall temperature (K);
* ``pressure`` -- float array (N_s, n): ``p - p_inf`` (Pa) on the points;
* ``heat_flux`` -- float array (N_s, n): heat flux into the wall (W/m^2);
* ``x``, ``y`` -- optional float arrays (n,): point coordinates (m, panel frame, x from the
  panel's leading edge); checked against the build file's grid (tolerance 1e-6 a).

The points are the ``[grid]`` of the build file, ordered ``k = j n_x + i`` (x fastest).

*CSV* (header row required, one row per sample and point, any row order):
``sample,a1,...,aNS,T_w,x,y,pressure,heat_flux`` -- ``sample`` an integer id, the inputs
repeated on each row of a sample (they must agree), ``x``/``y`` the point (m) which must
match a grid point, ``pressure`` ``p - p_inf`` (Pa), ``heat_flux`` (W/m^2).
Every sample must give every grid point exactly once.
"""
from __future__ import annotations

import csv
from collections.abc import Callable
from concurrent.futures import Executor
from pathlib import Path
from typing import Any

import numpy as np
from hypate.solvers.aero.base import Array
from hypate.solvers.aero.rom.geometry import RomGeometry
from hypate.solvers.aero.shock_expansion import ShockExpansionFluid
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition
from hypate.solvers.npz import float_member, read_npz

__all__ = ["generate_samples", "read_snapshots"]


def _source_chunk(geometry: RomGeometry, source_opts: dict[str, Any], flow: FlowCondition,
                  scale: float, amplitudes: Array, wall_temperature: Array
                  ) -> tuple[Array, Array]:
    """Worker: shock-expansion samples for a chunk (module-level for process pools)."""

    src = ShockExpansionFluid(boundary_layer=source_opts.get("boundary_layer", True),
                              regime=source_opts.get("regime", "turbulent"))
    pts = geometry.points(scale)
    _, ws = geometry.deformation(amplitudes, scale)
    return src.evaluate_batch(pts, ws, 0.0, wall_temperature, flow)


def generate_samples(geometry: RomGeometry, amplitudes: Array, wall_temperature: Array,
                     flow: FlowCondition, scale: float = 1.0,
                     source: dict[str, Any] | None = None, executor: Executor | None = None,
                     chunk_size: int = 50,
                     progress: Callable[[int, int], None] | None = None
                     ) -> tuple[Array, Array]:
    """Source snapshots (pressure ``p - p_inf`` and heat flux, each (N, n)) for modal
    amplitudes (N, N_S) in units of the reference thickness and wall temperatures (N,)
    uniform or (N, n), on the panel scaled by ``1/scale``.

    Chunks of ``chunk_size`` samples go to ``executor`` (any ``concurrent.futures.Executor``,
    e.g. a ``ProcessPoolExecutor`` or a dask ``Client``); ``None`` runs them in-process.
    ``progress(done, N)`` is called with the samples finished after each chunk (in order).
    """
    A = np.atleast_2d(np.asarray(amplitudes, float))
    N = A.shape[0]
    n = geometry.n_x * geometry.n_y
    T = np.asarray(wall_temperature, float)
    T = np.repeat(T[:, None], n, axis=1) if T.ndim == 1 else T
    if T.shape != (N, n):
        raise InputError("samples", f"wall temperatures must have shape ({N},) or ({N}, {n})")
    opts = dict(source or {"kind": "shock-expansion"})
    if opts.get("kind", "shock-expansion") != "shock-expansion":
        raise InputError("source.kind", "only the built-in 'shock-expansion' source can "
                         "generate samples")
    bounds = list(range(0, N, chunk_size)) + [N]
    jobs = [(A[s:e], T[s:e]) for s, e in zip(bounds[:-1], bounds[1:])]
    futures = None if executor is None else [
        executor.submit(_source_chunk, geometry, opts, flow, scale, a, t) for a, t in jobs]
    parts = []
    for k, (a, t) in enumerate(jobs):
        parts.append(_source_chunk(geometry, opts, flow, scale, a, t) if futures is None
                     else futures[k].result())
        if progress is not None:
            progress(bounds[k + 1], N)
    return np.concatenate([p for p, _ in parts]), np.concatenate([q for _, q in parts])


def read_snapshots(path: str | Path, geometry: RomGeometry) -> tuple[Array, Array, Array]:
    """External snapshots (NPZ or CSV; layout in the module docstring).

    Returns
    -------
    inputs : ndarray of shape (N_s, N_S + 1)
    pressure, heat_flux : ndarray of shape (N_s, n)
    """
    path = Path(path)
    field = f"source.path ({path})"
    if not path.is_file():
        raise InputError(field, "file not found")
    pts = geometry.points(1.0)
    n, n_s = pts.n, geometry.n_modes
    tol = 1e-6 * geometry.length
    if path.suffix.lower() == ".npz":
        data = read_npz(path, field, required=("inputs", "pressure", "heat_flux"))
        D, P, Q = (float_member(data, k, field) for k in ("inputs", "pressure", "heat_flux"))
        for key, ref in (("x", pts.x), ("y", pts.y)):
            if key in data:
                v = float_member(data, key, field)
                if v.shape != (n,) or (key == "x" or geometry.kind == "3d") and np.max(
                        np.abs(v - ref)) > tol:
                    raise InputError(field, f"{key} does not match the build file's grid "
                                     f"({geometry.n_x} x {geometry.n_y} points, edges included)")
    elif path.suffix.lower() == ".csv":
        D, P, Q = _read_snapshots_csv(path, geometry, field)
    else:
        raise InputError(field, "snapshots must be a .npz or .csv file")
    N = D.shape[0] if D.ndim == 2 else -1
    if D.ndim != 2 or D.shape[1] != n_s + 1:
        raise InputError(field, f"inputs must have shape (N_s, {n_s + 1}) = modal amplitudes "
                         f"a1..a{n_s} and the wall temperature; got {D.shape}")
    for name, Y in (("pressure", P), ("heat_flux", Q)):
        if Y.shape != (N, n):
            raise InputError(field, f"{name} must have shape ({N}, {n}); got {Y.shape}")
    if not all(np.all(np.isfinite(a)) for a in (D, P, Q)):
        raise InputError(field, "snapshots contain non-finite values")
    if np.any(D[:, -1] <= 0.0):
        raise InputError(field, "wall temperatures must be > 0 K")
    return D, P, Q


def _read_snapshots_csv(path: Path, geometry: RomGeometry, field: str
                        ) -> tuple[Array, Array, Array]:
    n_s = geometry.n_modes
    cols = ["sample"] + [f"a{k + 1}" for k in range(n_s)] + ["T_w", "x", "y", "pressure",
                                                            "heat_flux"]
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            reader = csv.reader(fh)
            header = [h.strip() for h in next(reader)]
            rows = [r for r in reader if r]
    except (OSError, UnicodeDecodeError, StopIteration) as exc:
        raise InputError(field, f"cannot read CSV ({type(exc).__name__})") from None
    if header != cols:
        raise InputError(field, f"CSV header must be {','.join(cols)}")
    try:
        arr = np.array(rows, dtype=float)
    except ValueError:
        raise InputError(field, "CSV contains non-numeric values") from None
    if arr.ndim != 2 or arr.shape[1] != len(cols):
        raise InputError(field, "CSV rows have the wrong number of columns")
    pts = geometry.points(1.0)
    n = pts.n
    tol = 1e-6 * geometry.length
    ix = np.rint(arr[:, 1 + n_s + 1] / geometry.length * (geometry.n_x - 1)).astype(int)
    if geometry.n_y > 1:
        iy = np.rint(arr[:, 1 + n_s + 2] / geometry.width * (geometry.n_y - 1)).astype(int)
    else:
        iy = np.zeros(arr.shape[0], int)
    k = iy * geometry.n_x + ix
    if np.any((k < 0) | (k >= n)) or np.any(np.abs(pts.x[np.clip(k, 0, n - 1)]
                                                   - arr[:, 1 + n_s + 1]) > tol):
        raise InputError(field, "CSV points do not match the build file's grid")
    ids, inv = np.unique(arr[:, 0], return_inverse=True)
    N = ids.size
    D = np.full((N, n_s + 1), np.nan)
    P = np.full((N, n), np.nan)
    Q = np.full((N, n), np.nan)
    counts = np.zeros((N, n), int)
    np.add.at(counts, (inv, k), 1)
    if np.any(counts != 1):
        raise InputError(field, "every sample must give every grid point exactly once")
    P[inv, k] = arr[:, -2]
    Q[inv, k] = arr[:, -1]
    D[inv] = arr[:, 1:2 + n_s]
    ins = arr[:, 1:2 + n_s]
    if np.any(np.abs(ins - D[inv]) > 1e-9 * (1.0 + np.abs(ins))):
        raise InputError(field, "the inputs of a sample differ between its rows")
    return D, P, Q
