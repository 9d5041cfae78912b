"""Persistence of fluid ROMs: one ``.npz`` of plain arrays (no pickled objects).

:func:`save_rom` writes the ROM (``FORMAT_VERSION``, kind, reference condition, panel
geometry, grid, modes, training ranges, POD bases and kriging data; a SHA-256 digest of the
content). :func:`load_rom` validates the archive (member sizes capped before anything is
read, :func:`hypate.solvers.npz.read_npz`), version, digest, shapes, grid size and
finiteness and raises :class:`~hypate.solvers.errors.InputError` otherwise. Loading refits
the kriging Cholesky factors with the stored hyperparameters (no optimization).
"""
from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
from hypate.solvers.aero.rom.geometry import MAX_N_X, MAX_N_Y, RomGeometry
from hypate.solvers.aero.rom.model import RomFluid
from hypate.solvers.aero.rom.pod import PodKriging
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition
from hypate.solvers.npz import read_npz, require_finite
from hypate.solvers.numerics.files import atomic_file

__all__ = ["EDGE_TEMPERATURE_FORMAT_VERSION", "FORMAT_VERSION", "load_rom", "save_rom"]

#: Version of the NPZ layout written by :func:`save_rom` for a ROM without an
#: edge-temperature model (unchanged since the first layout: such files stay the same).
FORMAT_VERSION = 1
#: Version written for a ROM with one (``edge_temperature_*`` members): a reader of
#: version 1 refuses the file instead of ignoring the field and kriging the heat flux.
EDGE_TEMPERATURE_FORMAT_VERSION = 2
#: Prefix of the edge-temperature POD-kriging members.
_EDGE = "edge_temperature"


#: Optional members: the snapshots kept out of the fit (inputs, pressure, heat flux).
_HOLDOUT = ("holdout_inputs", "holdout_pressure", "holdout_heat_flux")

#: Members every ROM file has besides the ``pressure_*`` / ``heat_flux_*`` POD-kriging arrays.
_MEMBERS = ("format_version", "digest", "kind", "correction", "regime", "reference",
            "geometry", "panel_kind", "modes", "input_names", "input_bounds", "source")


def _check_grid(n_x: float, n_y: float, field: str) -> None:
    """The stored grid must be one a build file may ask for (its points are allocated)."""
    if not (n_x == int(n_x) and n_y == int(n_y) and 3 <= n_x <= MAX_N_X
            and 1 <= n_y <= MAX_N_Y):
        raise InputError(field, f"member 'geometry': grid {n_x:g} x {n_y:g} outside "
                         f"[3, {MAX_N_X}] x [1, {MAX_N_Y}] points")


def _digest(arrays: dict[str, np.ndarray]) -> str:
    h = hashlib.sha256()
    for key in sorted(arrays):
        a = np.ascontiguousarray(arrays[key])
        h.update(key.encode())
        h.update(str(a.dtype).encode())
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()


def save_rom(rom: RomFluid, path: str | Path) -> None:
    """Save a ROM as NPZ (plain arrays only; ``numpy.load(..., allow_pickle=False)`` reads it).

    Keys: ``format_version``, ``kind``, ``correction``, ``regime``, ``reference``
    ([M, p, T, gamma, R, Pr, altitude or nan]), ``geometry`` ([a, b, L_le, h, beta, n_x,
    n_y]), ``panel_kind``, ``modes`` (N_S, 2), ``input_names``, ``input_bounds`` (N_d, 2)
    (training ranges), ``source`` ([kind, boundary_layer, regime] as strings), the
    ``pressure_*`` and ``heat_flux_*`` POD-kriging arrays and ``digest`` (SHA-256 of the
    rest); optional ``provenance`` (JSON text) and ``holdout_inputs``,
    ``holdout_pressure``, ``holdout_heat_flux`` when the ROM has them, and the
    ``edge_temperature_*`` POD-kriging arrays of an Euler CFD ROM (then
    ``format_version`` is :data:`EDGE_TEMPERATURE_FORMAT_VERSION`).
    """
    ref = rom.reference
    g = rom.geometry
    arrays: dict[str, np.ndarray] = {
        "format_version": np.array(FORMAT_VERSION if rom.edge_temperature_model is None
                                   else EDGE_TEMPERATURE_FORMAT_VERSION),
        "kind": np.array(rom.kind), "correction": np.array(rom.correction),
        "regime": np.array(rom.regime),
        "reference": np.array([ref.mach, ref.pressure, ref.temperature, ref.gamma,
                               ref.gas_constant, ref.prandtl,
                               np.nan if ref.altitude is None else ref.altitude]),
        "geometry": g.as_array(), "panel_kind": np.array(g.kind),
        "modes": np.asarray(g.modes, np.int64),
        "input_names": np.array(rom.input_names()),
        "input_bounds": rom.input_bounds,
        "source": np.array([str(rom.source.get("kind", "unknown")),
                            str(rom.source.get("boundary_layer", True)),
                            str(rom.source.get("regime", rom.regime))]),
    }
    if rom.provenance:  # optional members: a CFD source's provenance and held-out set
        arrays["provenance"] = np.array(json.dumps(rom.provenance, sort_keys=True))
    if rom.holdout is not None:
        for key, value in zip(_HOLDOUT, rom.holdout):
            arrays[key] = np.asarray(value, float)
    arrays.update(rom.pressure_model.state("pressure"))
    arrays.update(rom.heat_model.state("heat_flux"))
    if rom.edge_temperature_model is not None:
        arrays.update(rom.edge_temperature_model.state(_EDGE))
    arrays["digest"] = np.array(_digest(arrays))
    path = Path(path)
    with atomic_file(path) as fh:
        np.savez_compressed(fh, **arrays)  # type: ignore[arg-type]  # no allow_pickle key in **arrays


def load_rom(path: str | Path, correction: str | None = None, unsteady: bool = True,
             scale: float | None = None, regime: str | None = None) -> RomFluid:
    """Load a ROM written by :func:`save_rom`.

    ``correction``, ``unsteady``, ``scale`` are :class:`RomFluid` options; ``regime``
    (the Eckert regime of the heat-flux correction) defaults to the one stored.

    Every problem (missing or unreadable file, wrong format version, digest mismatch,
    missing keys, inconsistent shapes, non-finite values) raises :class:`InputError`.
    """
    path = Path(path)
    field = f"rom:{path}"
    data = read_npz(path, field, required=_MEMBERS)
    try:
        version = int(data["format_version"])
        if version not in (FORMAT_VERSION, EDGE_TEMPERATURE_FORMAT_VERSION):
            raise InputError(field, f"format version {version} is not supported (this "
                             f"version reads {FORMAT_VERSION} and "
                             f"{EDGE_TEMPERATURE_FORMAT_VERSION})")
        digest = str(data.pop("digest"))
        if _digest(data) != digest:
            raise InputError(field, "corrupted ROM file (content digest mismatch)")
        ref = data["reference"].astype(float)
        geo = data["geometry"].astype(float)
        if ref.shape != (7,) or geo.shape != (7,):
            raise InputError(field, "reference/geometry arrays have the wrong shape")
        # every number must be finite, but for the reference altitude: NaN = not given
        require_finite(dict(data, reference=ref[:6]), field)
        _check_grid(geo[5], geo[6], field)
        reference = FlowCondition(mach=ref[0], pressure=ref[1], temperature=ref[2],
                                  gamma=ref[3], gas_constant=ref[4], prandtl=ref[5],
                                  altitude=None if np.isnan(ref[6]) else float(ref[6]))
        modes = np.asarray(data["modes"], np.int64)
        if modes.ndim != 2 or modes.shape[1] != 2 or modes.shape[0] < 1:
            raise InputError(field, "modes must have shape (N_S, 2)")
        geometry = RomGeometry(str(data["panel_kind"]), geo[0], geo[1], geo[2], geo[3],
                               geo[4], int(geo[5]), int(geo[6]), modes)
        if geometry.kind not in ("2d", "3d") or min(geo[:4]) <= 0:
            raise InputError(field, "invalid panel geometry")
        kind = str(data["kind"])
        p_model = PodKriging.from_state(data, "pressure")
        q_model = PodKriging.from_state(data, "heat_flux")
        has_edge = any(k.startswith(f"{_EDGE}_") for k in data)
        if has_edge != (version == EDGE_TEMPERATURE_FORMAT_VERSION):
            raise InputError(field, f"format version {version} " + (
                "cannot hold the" if has_edge else "needs the") + f" {_EDGE}_* members")
        t_model = PodKriging.from_state(data, _EDGE) if has_edge else None
        src = [str(s) for s in data["source"]]
        provenance = json.loads(str(data["provenance"])) if "provenance" in data else {}
        holdout = None
        if all(k in data for k in _HOLDOUT):
            x, p, q = (np.asarray(data[k], float) for k in _HOLDOUT)
            holdout = (x, p, q)
    except KeyError as exc:
        raise InputError(field, f"missing key {exc.args[0]!r} (not a hypate ROM file?)") \
            from None
    except InputError as exc:
        if exc.field == field:
            raise
        raise InputError(field, exc.message) from None  # a part's check, e.g. kriging data
    except (TypeError, ValueError) as exc:  # json.JSONDecodeError is a ValueError
        raise InputError(field, f"malformed ROM file ({exc})") from None
    n = geometry.n_x * geometry.n_y
    n_d = geometry.n_modes + (4 if kind == "conventional" else 1)
    models = [("pressure", p_model), ("heat_flux", q_model)] + (
        [(_EDGE, t_model)] if t_model is not None else [])
    for name, model in models:
        if model.pod_.modes_.shape[0] != n:
            raise InputError(field, f"{name} modes have {model.pod_.modes_.shape[0]} points; "
                             f"the grid has {n}")
        if model.D_.shape[1] != n_d:
            raise InputError(field, f"{name} inputs have {model.D_.shape[1]} columns; a "
                             f"{kind} ROM with {geometry.n_modes} modes needs {n_d}")
    if holdout is not None and (holdout[0].ndim != 2 or holdout[0].shape[1] != n_d
                                or any(h.shape != (holdout[0].shape[0], n) for h in holdout[1:])):
        raise InputError(field, "held-out snapshots have the wrong shapes")
    source = {"kind": src[0], "boundary_layer": src[1] == "True", "regime": src[2]}
    return RomFluid(geometry, reference, p_model, q_model, kind,
                    correction or str(data["correction"]), unsteady,
                    regime or str(data["regime"]), scale, source, provenance=provenance,
                    holdout=holdout, edge_temperature_model=t_model)
