"""Schema of ROM build files (``hypate rom build CONFIG.toml``), validated with pydantic.

Public schema (keys are a contract; see README "Fluid ROM"), example
``studies/rom/rom_2d_panel.toml`` (Dissertation Sec. 7.1, Table 7.1)::

    [panel]                      # the reference geometry of the ROM (L_ref = length)
    kind = "2d"                  # "2d" (one line of points at mid-span) or "3d"
    length = 1.0                 # a (m)
    width = 1.0                  # b (m); ignored for "2d"
    leading_edge_length = 1.0    # L_le (m) rigid wall ahead of the panel
    thickness = 0.0025           # h (m); deformation amplitudes are in units of h
    flow_angle = 0.0             # beta (deg)

    [grid]                       # fluid surface points (edges included)
    n_x = 65
    n_y = 1

    [reference]                  # reference condition c_ref: mach + altitude (m) or
    mach = 6.0                   # mach + pressure (Pa) + temperature (K)
    altitude = 25000.0

    [[modes]]                    # deformation modes u/h = sum a_i sin(m pi x/a) sin(n pi y/b)
    m = 1                        # streamwise half-waves (>= 1)
    n = 0                        # spanwise half-waves (0 = uniform across; "2d" needs 0)
    range = [-6.0, 6.0]          # amplitude range in units of h (Table 7.1)

    [wall_temperature]
    range = [200.0, 900.0]       # mean (uniform) wall temperature range (K)

    [source]
    kind = "shock-expansion"     # built-in source, or "snapshots" (external samples)
    path = ""                    # snapshots: NPZ or CSV file, relative to this file
    boundary_layer = true        # shock-expansion: Cox-Crabtree effective shape
    regime = "turbulent"         # Eckert regime

    # or: kind = "openfoam"      # OpenFOAM rhoCentralFoam snapshots (2d panels)
    # model = "euler"            # "euler" | "laminar" | "spalart-allmaras"
    # holdout = 20               # extra OLH snapshots kept out of the fit (rom check)
    # timeout = 3600.0           # s per snapshot before it is rejected
    # [source.resolution]        # mesh and convergence (openfoam_case.Resolution)
    # cells_panel = 128          # streamwise cells on the panel (plate: cells_plate)
    # cells_normal = 60          # wall-normal cells, first one wall_cell (m) high
    # wall_cell = 5e-4
    # courant = 0.2              # local time stepping (default 0.2 Euler, 0.1 viscous)
    # max_iterations = 20000     # then the snapshot is rejected as unconverged
    # window = 20                # samples (every sample_every iterations) judged ...
    # tolerance = 5e-4           # ... by the relative drift of the wall averages

    [training]
    samples = 200                # OLH samples (shock-expansion and openfoam sources)
    seed = 0
    pod_tolerance = 0.005        # Eq. (A.14) energy criterion
    kernel = "rbf"               # "rbf" (Gaussian, Eq. A.4) or "matern52"
    trend = "linear"             # regression part of Eq. (A.2): constant | linear | quadratic
    restarts = 1                 # likelihood-optimization restarts (first POD coefficient)
    optimized_modes = 3          # POD coefficients with their own optimized hyperparameters

    [conventional]               # optional: build the conventional ROM (Eq. 2.62) instead,
    mach = [5.0, 7.0]            # with the flight condition as extra inputs
    altitude = [20000.0, 30000.0]
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any, Literal

from hypate.solvers.aero.rom.geometry import MAX_N_X, MAX_N_Y
from hypate.solvers.aero.rom.openfoam_case import Resolution
from hypate.solvers.config import InputModel, Pair, pydantic_input_error, read_toml
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition
from pydantic import Field, ValidationError, model_validator

__all__ = ["MAX_SAMPLES", "MIN_SAMPLES", "RomBuildConfig", "load_rom_config",
           "parse_rom_config"]

#: Training samples of a ROM (``[training] samples``, ``hypate rom build --samples``): the
#: kriging fit needs a handful; the cap bounds the sample generation and the O(N^3) fit.
MIN_SAMPLES, MAX_SAMPLES = 5, 20000

Length = Annotated[float, Field(gt=0.0, le=100.0)]
Range = Pair


def _ordered(r: list[float], name: str) -> None:
    if not r[0] < r[1]:
        raise ValueError(f"{name}: range must be [low, high] with low < high")


class RomPanel(InputModel):
    kind: Literal["2d", "3d"] = "2d"
    length: Length = 1.0
    width: Length = 1.0
    leading_edge_length: Annotated[float, Field(gt=0.0, le=100.0)] = 1.0
    thickness: Annotated[float, Field(gt=0.0, le=1.0)] = 0.0025
    flow_angle: Annotated[float, Field(ge=-60.0, le=60.0)] = 0.0


class RomGrid(InputModel):
    n_x: Annotated[int, Field(ge=3, le=MAX_N_X)] = 65
    n_y: Annotated[int, Field(ge=1, le=MAX_N_Y)] = 1


class RomReference(InputModel):
    mach: Annotated[float, Field(gt=1.0, le=30.0)]
    altitude: float | None = None
    pressure: Annotated[float, Field(gt=0.0)] | None = None
    temperature: Annotated[float, Field(gt=0.0)] | None = None

    @model_validator(mode="after")
    def _one_state(self) -> RomReference:
        alt = self.altitude is not None
        pt = self.pressure is not None or self.temperature is not None
        if alt == pt:
            raise ValueError("give either altitude or (pressure and temperature)")
        if pt and (self.pressure is None or self.temperature is None):
            raise ValueError("pressure and temperature are both required")
        return self

    def flow(self) -> FlowCondition:
        if self.altitude is not None:
            return FlowCondition.from_altitude(self.mach, self.altitude)
        # _one_state: both given without an altitude
        assert self.pressure is not None and self.temperature is not None
        return FlowCondition.from_static(self.mach, self.pressure, self.temperature)


class RomMode(InputModel):
    m: Annotated[int, Field(ge=1, le=100)]
    n: Annotated[int, Field(ge=0, le=100)] = 0
    range: Range

    @model_validator(mode="after")
    def _check(self) -> RomMode:
        _ordered(self.range, "range")
        return self


class RomWallTemperature(InputModel):
    range: Range = [200.0, 900.0]

    @model_validator(mode="after")
    def _check(self) -> RomWallTemperature:
        _ordered(self.range, "range")
        if self.range[0] <= 0.0:
            raise ValueError("range: wall temperatures must be > 0 K")
        return self


class RomOpenFoamResolution(InputModel):
    """``[source.resolution]`` of an ``openfoam`` source (see
    :class:`~hypate.solvers.aero.rom.openfoam_case.Resolution`)."""

    cells_panel: Annotated[int, Field(ge=4, le=4000)] = 128
    cells_plate: Annotated[int, Field(ge=2, le=4000)] = 64
    cells_normal: Annotated[int, Field(ge=4, le=1000)] = 60
    wall_cell: Annotated[float, Field(gt=0.0, le=1.0)] = 5e-4
    height: Annotated[float, Field(gt=0.05, le=10.0)] = 0.5
    upstream: Annotated[float, Field(ge=0.0, le=1.0)] = 0.0
    courant: Annotated[float, Field(gt=0.0, le=1.0)] | None = None
    smoothing: Annotated[float, Field(ge=0.0, le=1.0)] = 0.2
    max_iterations: Annotated[int, Field(ge=100, le=10_000_000)] = 20000
    sample_every: Annotated[int, Field(ge=1, le=100_000)] = 50
    window: Annotated[int, Field(ge=4, le=1000)] = 20
    tolerance: Annotated[float, Field(gt=0.0, lt=1.0)] = 5e-4

    def resolution(self, model: str) -> Resolution:
        """The case settings; the Courant number defaults to 0.2 (Euler) or 0.1 (viscous)."""
        values = self.model_dump()
        if values["courant"] is None:
            values["courant"] = 0.2 if model == "euler" else 0.1
        return Resolution(**values)


class RomSource(InputModel):
    kind: Literal["shock-expansion", "snapshots", "openfoam"] = "shock-expansion"
    path: str = ""
    boundary_layer: bool = True
    regime: Literal["turbulent", "laminar"] = "turbulent"
    model: Literal["euler", "laminar", "spalart-allmaras"] = "euler"
    holdout: Annotated[int, Field(ge=0, le=MAX_SAMPLES)] = 0
    timeout: Annotated[float, Field(gt=0.0, le=1e6)] = 3600.0
    resolution: RomOpenFoamResolution = RomOpenFoamResolution()

    @model_validator(mode="after")
    def _check(self) -> RomSource:
        if self.kind == "snapshots" and not self.path:
            raise ValueError("path: a snapshots source needs the path of an NPZ or CSV file")
        return self


class RomTraining(InputModel):
    samples: Annotated[int, Field(ge=MIN_SAMPLES, le=MAX_SAMPLES)] = 200
    seed: int = 0
    pod_tolerance: Annotated[float, Field(gt=0.0, lt=1.0)] = 0.005
    kernel: Literal["rbf", "matern52"] = "rbf"
    trend: Literal["constant", "linear", "quadratic"] = "linear"
    restarts: Annotated[int, Field(ge=0, le=20)] = 1
    optimized_modes: Annotated[int, Field(ge=1, le=1000)] = 3


class RomConventional(InputModel):
    mach: Range
    altitude: Range

    @model_validator(mode="after")
    def _check(self) -> RomConventional:
        _ordered(self.mach, "mach")
        _ordered(self.altitude, "altitude")
        if self.mach[0] <= 1.0:
            raise ValueError("mach: must be > 1")
        return self


class RomBuildConfig(InputModel):
    """A validated ROM build file (see the module docstring for the keys)."""

    panel: RomPanel = RomPanel()
    grid: RomGrid = RomGrid()
    reference: RomReference
    modes: Annotated[list[RomMode], Field(min_length=1, max_length=50)]
    wall_temperature: RomWallTemperature = RomWallTemperature()
    source: RomSource = RomSource()
    training: RomTraining = RomTraining()
    conventional: RomConventional | None = None

    @model_validator(mode="after")
    def _check(self) -> RomBuildConfig:
        if self.panel.kind == "2d":
            if self.grid.n_y != 1:
                raise ValueError("grid: a 2d panel has one line of points (n_y = 1)")
            if any(m.n != 0 for m in self.modes):
                raise ValueError("modes: a 2d panel has no spanwise waves (n = 0)")
            if self.panel.flow_angle != 0.0:
                raise ValueError("panel: a 2d panel is aligned with the flow (flow_angle = 0)")
        if self.source.kind == "openfoam" and self.panel.kind != "2d":
            raise ValueError("source: the openfoam source computes 2d snapshots (panel kind "
                             "= '2d'); a 3-D panel uses a 2-D ROM strip-wise")
        seen = {(m.m, m.n) for m in self.modes}
        if len(seen) != len(self.modes):
            raise ValueError("modes: each (m, n) pair may appear once")
        return self

    @property
    def flow_angle_rad(self) -> float:
        return math.radians(self.panel.flow_angle)


def parse_rom_config(data: dict[str, Any]) -> RomBuildConfig:
    """Validate a parsed TOML table; errors become :class:`InputError` naming the key."""
    try:
        cfg = RomBuildConfig.model_validate(data)
    except ValidationError as exc:
        raise pydantic_input_error(exc, model=RomBuildConfig) from None
    try:
        cfg.reference.flow()
    except InputError as exc:
        raise InputError(f"reference.{exc.field}", exc.message) from None
    return cfg


def load_rom_config(path: str | Path) -> tuple[RomBuildConfig, Path]:
    """Read and validate a ROM build file; returns the config and its directory (for
    resolving a relative ``source.path``)."""
    path = Path(path)
    return parse_rom_config(read_toml(path)), path.resolve().parent
