"""A scaling study on the user's own simulator (``[simulation] simulator = "..."``).

The protocol. A simulator is a callable ``simulator(configuration) -> SimulatedHistories``,
named in the study as ``"package.module:function"`` (importable) or
``"file.py:function"`` (a file next to the study). It is called once on the prototype's
:class:`~hypate.scaling.workflow.vocabulary.configuration.Configuration` (flight) and once per model
design (tunnel); each configuration carries everything the similarity parameters see:
``panel`` (length, width, layers with their materials and thicknesses, boundary, mesh),
``flow`` (Mach number, stagnation pressure and temperature, ...) and ``simulation`` (the
time step at matched nondimensional time, ``n_steps``, fluid model, external loads). It
returns the nondimensional histories J compares (Eqs. 6.4, 9.8), one value per time level
``0, dt, ..., n_steps dt``:

- ``deflection``: the centre deflection over the panel thickness, ``w_c / h``;
- ``temperature``: the volume-mean temperature over the stagnation temperature, ``T / T0``;

and, for the simulated admissibility checks (``[admissibility]``, Sec. "Models a tunnel
can test"), what the structure went through: ``layer_temperature`` (each layer's
``[min, max]`` temperature over the run, K, bottom layer first; the temperature and data
checks) and ``max_stress_ratio`` with ``stress_at_ratio`` (the largest von Mises stress over
the yield strength, and the von Mises stress there, Pa; the stress check). A check whose
input the simulator does not return must be ``"off"`` (every response is checked).

A design the simulator cannot simulate raises
:class:`~hypate.scaling.workflow.vocabulary.objectives.ModelFailure` (a failed evaluation the
engine learns to avoid), or returns fewer time levels than asked (an instability at that step, as
the built-in simulator reports it); any other exception is a bug and stops the run.
"""
from __future__ import annotations

import hashlib
import importlib.util
import pkgutil
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np
from hypate.scaling.workflow.vocabulary.configuration import Configuration
from hypate.scaling.workflow.vocabulary.objectives import ModelFailure
from hypate.solvers.coupling.response import Response
from hypate.solvers.errors import InputError

__all__ = ["SimulatedHistories", "Simulator", "check_checks", "external_response", "load_simulator",
           "resolve_simulator", "simulator_source"]


@dataclass(frozen=True)
class SimulatedHistories:
    """What a user's simulator returns for one configuration (module docstring).

    Attributes
    ----------
    deflection : sequence or 1-D array of float
        ``w_c / h`` at time levels ``0, dt, ..., n dt``.
    temperature : sequence or 1-D array of float
        Volume-mean temperature over the stagnation temperature at the same levels.
    layer_temperature : sequence of (float, float), optional
        Each layer's ``[min, max]`` temperature over the run (K), bottom first.
    max_stress_ratio : float, optional
        Largest von Mises stress over the yield strength over the run.
    stress_at_ratio : float, optional
        The von Mises stress (Pa) where that ratio is reached (with ``max_stress_ratio``).
    message : str
        A note stored with the evaluation (e.g. the code's version).
    """

    deflection: Sequence[float] | np.ndarray
    temperature: Sequence[float] | np.ndarray
    layer_temperature: Sequence[Sequence[float]] | None = None
    max_stress_ratio: float | None = None
    stress_at_ratio: float | None = None
    message: str = ""


class Simulator(Protocol):
    """``simulator(configuration) -> SimulatedHistories`` (module docstring)."""

    def __call__(self, configuration: Configuration) -> SimulatedHistories: ...


def external_response(histories: SimulatedHistories, config: Configuration,
                      field: str = "simulation.simulator") -> Response:
    """The :class:`Response` of ``config`` from its simulated ``histories``: the centre
    deflection and the mean temperature in SI units (times ``h`` and ``T0``), the time levels
    of ``config.simulation``, the extremes the admissibility checks read.

    Raises
    ------
    InputError
        The simulator returned something else than the protocol's histories (a bug in it).
    ModelFailure
        Non-finite values (a diverged simulation).
    """
    if not isinstance(histories, SimulatedHistories):
        raise InputError(field, f"must return SimulatedHistories, not "
                         f"{type(histories).__name__}")
    u = np.asarray(histories.deflection, dtype=float)
    T = np.asarray(histories.temperature, dtype=float)
    n = config.simulation.n_steps + 1
    if u.ndim != 1 or T.shape != u.shape or not 1 <= u.size <= n:
        raise InputError(field, f"deflection and temperature must be two series of equal "
                         f"length, 1 to {n} values (time levels 0 .. {n - 1}); got shapes "
                         f"{u.shape} and {T.shape}")
    if not (np.all(np.isfinite(u)) and np.all(np.isfinite(T))):
        raise ModelFailure("the simulator returned non-finite histories")
    panel, flow = config.panel, config.flow
    dt = config.simulation.time_step
    resp = Response(scheme="external", thickness=panel.thickness, length=panel.length,
                    stagnation_temperature=flow.stagnation_temperature,
                    initial_temperature=panel.initial_temperature,
                    times=[k * dt for k in range(u.size)],
                    center_deflection=(u * panel.thickness).tolist(),
                    mean_temperature=(T * flow.stagnation_temperature).tolist(),
                    keep_fields=False,
                    layer_materials=[layer.material.name for layer in panel.layers])
    if histories.layer_temperature is not None:
        layers = np.asarray(histories.layer_temperature, dtype=float)
        if layers.shape != (len(panel.layers), 2):
            raise InputError(field, f"layer_temperature must be [min, max] K of each of the "
                             f"{len(panel.layers)} layers; got shape {layers.shape}")
        resp.layer_temperature.append(layers)
    if histories.max_stress_ratio is not None and histories.stress_at_ratio is not None:
        resp.max_stress_ratio.append(float(histories.max_stress_ratio))
        resp.stress_ratio_location.append(np.full(3, np.nan))
        resp.stress_at_ratio.append(float(histories.stress_at_ratio))
    complete = u.size == n
    resp.finish("completed" if complete else "unstable", histories.message,
                None if complete else ((u.size - 1) * dt, "instability"))
    return resp


def check_checks(histories: SimulatedHistories, modes: dict[str, str],
                 field: str = "simulation.simulator") -> None:
    """The simulated admissibility checks that are on (``modes``: check -> mode) need the
    simulator's extremes (module docstring); :class:`InputError` naming the first that
    lacks its input (checked on every response: a simulator that stops returning them is
    a broken protocol, not a design that passes)."""
    stress = None if histories.stress_at_ratio is None else histories.max_stress_ratio
    needs = {"temperature": histories.layer_temperature, "data": histories.layer_temperature,
             "stress": stress}
    for check, given in needs.items():
        if modes.get(check, "off") != "off" and given is None:
            what = ("max_stress_ratio and stress_at_ratio" if check == "stress"
                    else "layer_temperature")
            raise InputError(f"admissibility.{check}", f"the simulator returns no {what}; "
                             f"return it, or set {check} = \"off\"")


_LOADED: dict[str, Callable[[Configuration], SimulatedHistories]] = {}


def load_simulator(name: str, field: str = "simulation.simulator"
                   ) -> Callable[[Configuration], SimulatedHistories]:
    """The callable ``"package.module:function"`` or ``"/path/file.py:function"`` names
    (loaded once per process)."""
    if name in _LOADED:
        return _LOADED[name]
    target, sep, attr = name.rpartition(":")
    if not sep or not target or not attr.isidentifier():
        raise InputError(field, f"must be \"package.module:function\" or "
                         f"\"file.py:function\"; got {name!r}")
    try:
        if target.endswith(".py"):
            path = Path(target)
            # one module name per file: two studies' "sim.py" do not replace each other
            key = hashlib.sha256(str(path.resolve()).encode()).hexdigest()[:12]
            spec = importlib.util.spec_from_file_location(f"_hypate_simulator_{key}", path)
            if spec is None or spec.loader is None or not path.is_file():
                raise FileNotFoundError(f"no file {path}")
            module = importlib.util.module_from_spec(spec)
            sys.modules[spec.name] = module  # so that its functions pickle to the workers
            spec.loader.exec_module(module)
        else:  # the standard library's resolver of dotted names (as entry points use it)
            module = pkgutil.resolve_name(target)
    except Exception as exc:  # the user's module: any import error is theirs to see
        raise InputError(field, f"cannot import {target!r}: {type(exc).__name__}: "
                         f"{exc}") from None
    function = getattr(module, attr, None)
    if not callable(function):
        raise InputError(field, f"{target!r} has no function {attr!r}")
    _LOADED[name] = function
    return function


def simulator_source(name: str) -> Path | None:
    """The file that defines the simulator ``name`` names: its ``file.py``, or the source
    file of ``package.module`` (found without running it; None when there is none, e.g. a
    compiled module). Its hash is part of a campaign's identity
    (:func:`hypate.scaling.workflow.campaigns.campaign.campaign_identity`): an edited simulator is
    another campaign. Modules the simulator imports in turn are not followed."""
    target = name.rpartition(":")[0]
    if target.endswith(".py"):
        return Path(target)
    try:
        spec = importlib.util.find_spec(target)
    except (ImportError, ValueError):
        return None
    origin = None if spec is None else spec.origin
    return Path(origin) if origin and origin.endswith(".py") else None


def resolve_simulator(name: str, base: Path) -> str:
    """``name`` with a relative ``file.py`` made absolute against the study's folder
    ``base`` (what the spec keeps: the same file from any working directory)."""
    target, sep, attr = name.rpartition(":")
    if sep and target.endswith(".py") and not Path(target).is_absolute():
        return f"{(base / target).resolve()}:{attr}"
    return name
