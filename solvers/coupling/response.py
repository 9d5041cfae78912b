"""Response of a coupled run: time histories, nondimensionalization, save/load (NPZ).

Histories: center deflection, volume-mean and upper-surface (mean wall) temperatures,
maximum wall temperature, modal coordinates of the deflection on the sinusoidal modes
``sin(i pi x/a) sin(j pi y/b)`` (Eq. 8.9 form, amplitude / thickness), the LSA eigenvalues
per step, and optionally the nodal displacement/temperature and the fluid pressure and heat
flux fields. Files are NPZ written without pickle.

What the structure goes through, per step, for the admissibility of a design: the largest
``|w| / h`` over the shell nodes, each layer's lowest and highest temperature (K; against
its material's data and service temperature), the largest von Mises stress at the
load-bearing surfaces with where it occurs, and the largest ratio of von Mises stress to
the local yield strength (:mod:`hypate.solvers.structure.stress`). :meth:`Response.extremes`
sums them up over the run (SI units).
"""
from __future__ import annotations

import io
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol, cast

import numpy as np
from hypate.solvers.aero.base import SurfacePoints
from hypate.solvers.coupling.stability import StabilityResult
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition
from hypate.solvers.npz import float_member, read_npz, require_finite
from hypate.solvers.numerics.files import write_bytes
from hypate.solvers.panel import PanelSpec
from numpy.typing import NDArray

Array = NDArray[np.float64]
CArray = NDArray[np.complex128]


class RecordedModel(Protocol):
    """What a response reads from the coupled model it records (the coupling's
    ``PanelModel``): the response knows this interface, not the model's module."""

    panel: PanelSpec
    flow: FlowCondition
    modes: tuple[Array, list[tuple[int, int]]]
    points: SurfacePoints
    settings: Any
    structure: Any
    thermal: Any
    transfer: Any

    def fluid_loads(self, u: Array, T_wall: Array, u_dot: Array | None = None) -> Any: ...

    def wall_temperature(self, T: Array) -> Array: ...

    def structural_temperature(self, T: Array) -> Array: ...

    surface_stress: Any

FORMAT_VERSION = 1
#: Members of a saved response that every file has (``u``, ``T``, ``pressure``, ``heat_flux``
#: and ``artificial_energy`` only when recorded), and the keys of its ``meta`` header.
_ARRAYS = ("times", "center_deflection", "mean_temperature", "top_temperature",
           "max_wall_temperature", "modal", "lsa")
_META = ("scheme", "thickness", "length", "stagnation_temperature", "initial_temperature",
         "status", "message", "instability_time", "instability_type", "wall_seconds", "timing",
         "mode_indices", "lsa_status")
#: The histories of what the structure went through (module docstring); a file written
#: before they were recorded has none.
_LIMIT_ARRAYS = ("max_deflection_ratio", "max_von_mises", "von_mises_location",
                 "max_stress_ratio", "stress_ratio_location", "stress_at_ratio",
                 "layer_temperature")
#: Sinusoidal modes (i, j) on which the deflection is projected.
MODE_INDICES = tuple((i, j) for j in (1, 2, 3) for i in (1, 2, 3))


def sinusoidal_modes(panel: PanelSpec,
                     points: SurfacePoints) -> tuple[Array, list[tuple[int, int]]]:
    """Mode shapes ``sin(i pi x/a) sin(j pi y/b)`` on the fluid points, shape (n_modes, n_f).

    A "2d" strip uses j = 1 only, with the y factor dropped.
    """
    idx = [(i, 1) for i in (1, 2, 3, 4, 5, 6)] if panel.kind == "2d" else list(MODE_INDICES)
    x, y = points.x / panel.length, points.y / panel.width
    shapes = [np.sin(i * math.pi * x) * (np.sin(j * math.pi * y) if panel.kind == "3d" else 1.0)
              for i, j in idx]
    return np.array(shapes), idx


def modal_coordinates(w: Array, modes: Array, weights: Array) -> Array:
    """Least-squares (L2-weighted) coordinates of ``w`` (n_f,) on ``modes`` (n_modes, n_f)."""
    G = (modes * weights) @ modes.T
    # float64 (numpy's stub: solve gives floating)
    return cast(Array, np.linalg.solve(G, (modes * weights) @ w))


@dataclass
class Response:
    """Time histories of a coupled run (SI units; see module docstring)."""

    scheme: str
    thickness: float
    length: float
    stagnation_temperature: float
    initial_temperature: float
    times: list[float] = field(default_factory=list)
    center_deflection: list[float] = field(default_factory=list)
    mean_temperature: list[float] = field(default_factory=list)
    top_temperature: list[float] = field(default_factory=list)
    max_wall_temperature: list[float] = field(default_factory=list)
    modal: list[Array] = field(default_factory=list)
    lsa: list[CArray] = field(default_factory=list)
    lsa_status: list[str] = field(default_factory=list)
    u: list[Array] = field(default_factory=list)
    T: list[Array] = field(default_factory=list)
    pressure: list[Array] = field(default_factory=list)
    heat_flux: list[Array] = field(default_factory=list)
    status: str = "running"
    message: str = ""
    instability_time: float | None = None
    instability_type: str | None = None
    wall_seconds: float = 0.0
    timing: dict[str, float] = field(default_factory=dict)
    mode_indices: list[tuple[int, int]] = field(default_factory=list)
    keep_fields: bool = True
    artificial_energy: list[float] = field(default_factory=list)
    max_deflection_ratio: list[float] = field(default_factory=list)
    max_von_mises: list[float] = field(default_factory=list)
    von_mises_location: list[Array] = field(default_factory=list)
    max_stress_ratio: list[float] = field(default_factory=list)
    stress_ratio_location: list[Array] = field(default_factory=list)
    stress_at_ratio: list[float] = field(default_factory=list)
    layer_temperature: list[Array] = field(default_factory=list)
    #: The layers' material names, bottom to top (the columns of ``layer_temperature``).
    layer_materials: list[str] = field(default_factory=list)
    #: Times (s) of the TC steps whose equilibrium was replaced by the continuation's (one
    #: Newton's diverged or jumped branches: ``SimulationSettings.continuation_steps``).
    continued: list[float] = field(default_factory=list)

    # -- building ------------------------------------------------------------------------
    @classmethod
    def start(cls, model: RecordedModel, scheme: str) -> Response:
        p = model.panel
        return cls(scheme=scheme, thickness=p.thickness, length=p.length,
                   stagnation_temperature=model.flow.stagnation_temperature,
                   initial_temperature=p.initial_temperature,
                   mode_indices=list(model.modes[1]), keep_fields=model.settings.keep_fields,
                   layer_materials=[layer.material.name for layer in p.layers])

    def record(self, t: float, u: Array, T: Array, model: RecordedModel,
               lsa: StabilityResult | None, u_dot: Array | None = None) -> None:
        """Append the state at time ``t``; ``u_dot`` (transient schemes) enters the stored
        surface pressure through the piston-theory velocity term."""
        st, th = model.structure, model.thermal
        tr = model.transfer
        self.times.append(float(t))
        self.center_deflection.append(float(u[5 * st.mesh.center + 2]))
        self.mean_temperature.append(float(th.mean_temperature(T)))
        self.top_temperature.append(float(th.surface_mean(T, "top")))
        self.max_wall_temperature.append(float(np.max(th.wall_temperature(T))))
        self._record_limits(u, T, model)
        self.modal.append(modal_coordinates(tr.H_FS @ u, model.modes[0], model.points.weights)
                          / self.thickness)
        lam = (np.full(model.settings.lsa_modes, np.nan + 0j) if lsa is None else
               np.pad(lsa.lambda_p, (0, max(0, model.settings.lsa_modes - lsa.lambda_p.size)),
                      constant_values=np.nan)[:model.settings.lsa_modes])
        self.lsa.append(lam)
        self.lsa_status.append("" if lsa is None else lsa.status)
        if self.keep_fields:
            self.u.append(np.array(u, copy=True))
            self.T.append(np.array(T, copy=True))
            loads = model.fluid_loads(u, model.wall_temperature(T), u_dot=u_dot)
            self.pressure.append(loads.pressure.copy())
            self.heat_flux.append(loads.heat_flux.copy())

    def _record_limits(self, u: Array, T: Array, model: RecordedModel) -> None:
        """Append what the structure goes through at this state (module docstring)."""
        w = np.asarray(u)[2::5]
        self.max_deflection_ratio.append(float(np.max(np.abs(w))) / self.thickness)
        profile = model.structural_temperature(T)                  # (n_nodes, n_levels)
        bounds = np.cumsum([0] + [max(int(layer.sublayers), 1) for layer in model.panel.layers])
        self.layer_temperature.append(np.array(
            [[profile[:, a:b + 1].min(), profile[:, a:b + 1].max()]
             for a, b in zip(bounds[:-1], bounds[1:])]))
        peak = model.surface_stress.peak(u, profile)
        self.max_von_mises.append(peak.von_mises)
        self.von_mises_location.append(np.array(peak.location))
        self.max_stress_ratio.append(peak.ratio)
        self.stress_ratio_location.append(np.array(peak.ratio_location))
        self.stress_at_ratio.append(peak.ratio_stress)

    def extremes(self) -> dict[str, Any]:
        """What the structure went through over the run, SI units (NaN where not recorded).

        Returns
        -------
        dict
            ``max_wall_temperature`` (K), ``mean_wall_temperature`` (K, the largest
            area-mean of the upper surface), ``mean_temperature`` (K, the largest
            volume-mean), ``max_deflection_ratio`` (largest ``|w| / h``), ``max_von_mises``
            (Pa) with ``von_mises_location`` ([x, y, z] m) and ``von_mises_time`` (s),
            ``max_stress_ratio`` (largest von Mises / yield(T)) with its location and
            ``stress_at_ratio`` (Pa, the von Mises stress there),
            ``layer_temperature`` (per layer ``[min, max]`` K over the run) and
            ``layer_materials``.
        """
        def peak(values: list[float]) -> tuple[float, int | None]:
            a = np.asarray(values, float)
            ok = np.isfinite(a)
            if not ok.any():
                return float("nan"), None
            i = int(np.argmax(np.where(ok, a, -np.inf)))
            return float(a[i]), i

        def at(values: list[Array], i: int | None) -> list[float] | None:
            return None if i is None else [float(v) for v in values[i]]

        vm, i_vm = peak(self.max_von_mises)
        ratio, i_r = peak(self.max_stress_ratio)
        layers = (np.asarray(self.layer_temperature, float) if self.layer_temperature
                  else np.zeros((0, 0, 2)))
        return {
            "max_wall_temperature": peak(self.max_wall_temperature)[0],
            "mean_wall_temperature": peak(self.top_temperature)[0],
            "mean_temperature": peak(self.mean_temperature)[0],
            "max_deflection_ratio": peak(self.max_deflection_ratio)[0],
            "max_von_mises": vm, "von_mises_location": at(self.von_mises_location, i_vm),
            "von_mises_time": None if i_vm is None else float(self.times[i_vm]),
            "max_stress_ratio": ratio,
            "stress_ratio_location": at(self.stress_ratio_location, i_r),
            "stress_at_ratio": (float("nan") if i_r is None
                                else float(self.stress_at_ratio[i_r])),
            "layer_temperature": [[float(layers[:, k, 0].min()), float(layers[:, k, 1].max())]
                                  for k in range(layers.shape[1])],
            "layer_materials": list(self.layer_materials)}

    def finish(self, status: str, message: str, instability: tuple[float, str] | None) -> None:
        self.status = status
        self.message = message
        if instability is not None:
            self.instability_time, self.instability_type = float(instability[0]), instability[1]

    # -- nondimensional views (Sec. 9.2.1.1) -----------------------------------------------
    @property
    def deflection_over_thickness(self) -> Array:
        return np.asarray(self.center_deflection) / self.thickness

    @property
    def temperature_over_stagnation(self) -> Array:
        return np.asarray(self.mean_temperature) / self.stagnation_temperature

    def summary(self) -> dict[str, Any]:
        """The public JSON of ``hypate simulate --json``."""
        return {"times": list(self.times), "center_deflection": list(self.center_deflection),
                "mean_temperature": list(self.mean_temperature),
                "instability_time": self.instability_time,
                "instability_type": self.instability_type}

    # -- persistence (NPZ, no pickle) -----------------------------------------------------
    def save(self, path: str | Path) -> Path:
        path = Path(path)
        meta = {"format_version": FORMAT_VERSION, "scheme": self.scheme,
                "thickness": self.thickness, "length": self.length,
                "stagnation_temperature": self.stagnation_temperature,
                "initial_temperature": self.initial_temperature, "status": self.status,
                "message": self.message, "instability_time": self.instability_time,
                "instability_type": self.instability_type, "wall_seconds": self.wall_seconds,
                "timing": self.timing, "mode_indices": self.mode_indices,
                "lsa_status": self.lsa_status, "layer_materials": self.layer_materials,
                "continued": self.continued}
        arrays: dict[str, Array] = {
            "times": np.asarray(self.times),
            "center_deflection": np.asarray(self.center_deflection),
            "mean_temperature": np.asarray(self.mean_temperature),
            "top_temperature": np.asarray(self.top_temperature),
            "max_wall_temperature": np.asarray(self.max_wall_temperature),
            "modal": np.asarray(self.modal), "lsa": np.asarray(self.lsa),
            "meta": np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)}
        for name in ("u", "T", "pressure", "heat_flux", "artificial_energy") + _LIMIT_ARRAYS:
            if getattr(self, name):
                arrays[name] = np.asarray(getattr(self, name), dtype=float)
        buf = io.BytesIO()
        np.savez_compressed(buf, **arrays)  # type: ignore[arg-type]  # no allow_pickle key in **arrays
        write_bytes(path, buf.getvalue())  # never through a planted link; unchanged: kept
        return path

    @classmethod
    def load(cls, path: str | Path) -> Response:
        """Read a file written by :meth:`save`.

        The archive is checked before it is read (:func:`hypate.solvers.npz.read_npz`); the
        scales (thickness, length, temperatures) and the times must be finite numbers, the
        histories may hold NaN (a failed run, LSA eigenvalues not computed). Every problem
        raises :class:`InputError` naming the file and the member.
        """
        path = Path(path)
        field = str(path)
        arrays = read_npz(path, field, required=_ARRAYS + ("meta",))
        try:
            meta = json.loads(bytes(arrays.pop("meta")).decode())
        except ValueError as exc:  # not UTF-8, not JSON
            raise InputError(field, f"member 'meta': not a hypate response header ({exc})") \
                from None
        if not isinstance(meta, dict) or meta.get("format_version") != FORMAT_VERSION:
            version = meta.get("format_version") if isinstance(meta, dict) else None
            raise InputError(field, f"unsupported response format {version}")
        missing = [key for key in _META if key not in meta]
        if missing:
            raise InputError(field, f"member 'meta': missing {', '.join(missing)}")
        for key in ("thickness", "length", "stagnation_temperature", "initial_temperature"):
            value = meta[key]
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise InputError(field, f"member 'meta': {key} must be a number > 0; "
                                 f"got {value!r}")
        for name in _ARRAYS:
            if name not in ("modal", "lsa"):
                arrays[name] = float_member(arrays, name, field)
        require_finite(arrays, field, ["times"])
        r = cls(scheme=meta["scheme"], thickness=meta["thickness"], length=meta["length"],
                stagnation_temperature=meta["stagnation_temperature"],
                initial_temperature=meta["initial_temperature"])
        r.times = arrays["times"].tolist()
        r.center_deflection = arrays["center_deflection"].tolist()
        r.mean_temperature = arrays["mean_temperature"].tolist()
        r.top_temperature = arrays["top_temperature"].tolist()
        r.max_wall_temperature = arrays["max_wall_temperature"].tolist()
        r.modal = list(arrays["modal"])
        r.lsa = list(arrays["lsa"])
        for name in ("u", "T", "pressure", "heat_flux"):
            setattr(r, name, list(arrays[name]) if name in arrays else [])
        if "artificial_energy" in arrays:
            r.artificial_energy = arrays["artificial_energy"].tolist()
        for name in _LIMIT_ARRAYS:  # optional: a file of an older hypate has none
            if name in arrays:
                values = float_member(arrays, name, field)
                setattr(r, name, values.tolist() if values.ndim == 1 else list(values))
        r.layer_materials = [str(n) for n in meta.get("layer_materials", [])]
        r.continued = [float(t) for t in meta.get("continued", [])]
        r.status, r.message = meta["status"], meta["message"]
        r.instability_time, r.instability_type = meta["instability_time"], meta["instability_type"]
        r.wall_seconds, r.timing = meta["wall_seconds"], meta["timing"]
        r.mode_indices = [tuple(m) for m in meta["mode_indices"]]
        r.lsa_status = meta["lsa_status"]
        return r
