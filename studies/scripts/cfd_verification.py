"""Verification of the OpenFOAM snapshot source against exact theory (issue "CFD-grade fluid
loads"; the figures of the README's "CFD snapshots" section).

* :func:`wedge` -- Euler, a straight ramp from the leading edge: the mean panel pressure
  against the exact oblique-shock pressure (``oblique_shock``, weak solution);
* :func:`bump` -- Euler, the flat plate and a panel deformed by a sine mode: the panel
  pressure against the built-in shock-expansion march (no boundary layer);
* :func:`flat_plate` -- laminar, a flat plate at a uniform wall temperature on a family of
  grids refined in the wall-normal direction by a constant ratio: the panel-mean heat flux,
  its Richardson extrapolation (observed order from three grids) and the laminar Eckert
  reference-temperature estimate (Eqs. 2.39-2.43) with the Prandtl number the CFD gas has
  (OpenFOAM's Sutherland transport: Eucken conductivity, Pr 0.690).

``run(config)`` runs the parts named in ``config`` and returns their figures; nothing runs
at import. Each case runs on one core.
"""
from __future__ import annotations

import math
import tempfile
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from hypate.solvers.aero.analytic import eckert_heat_flux
from hypate.solvers.aero.base import SurfacePoints
from hypate.solvers.aero.rom.openfoam_case import (
    CaseSpec,
    Resolution,
    eucken_prandtl,
    wedge_wall,
    write_case,
)
from hypate.solvers.aero.rom.openfoam_run import CaseResult, find_openfoam, run_case
from hypate.solvers.aero.shock_expansion import ShockExpansionFluid, oblique_shock
from hypate.solvers.flow import FlowCondition

__all__ = ["FLAT_PLATE_GRIDS", "WEDGE_RESOLUTION", "bump", "flat_plate", "richardson", "run",
           "wedge"]

#: Euler wedge mesh of the issue's table: 7,200 cells, 6.7 mm wall cell.
WEDGE_RESOLUTION = Resolution(cells_panel=60, cells_plate=60, cells_normal=60, wall_cell=6.7e-3,
                              height=0.5, courant=0.2, max_iterations=20000, sample_every=50,
                              window=20, tolerance=1e-4)
#: Laminar flat-plate grids, coarse to fine: wall-normal cells and first-cell height refined
#: together by 1.5 (streamwise 40 cells per metre on all).
FLAT_PLATE_GRIDS = ((40, 1.5e-4), (60, 1.0e-4), (90, 6.667e-5))


def _run(spec: CaseSpec, folder: Path | None) -> CaseResult:
    with tempfile.TemporaryDirectory() as tmp:
        case = (folder or Path(tmp)) / "case"
        return run_case(write_case(case, spec), find_openfoam(), spec.resolution,
                        spec.viscous)


def wedge(mach: float, angle_deg: float = 5.0, altitude: float = 25000.0,
          resolution: Resolution = WEDGE_RESOLUTION, folder: Path | None = None
          ) -> dict[str, Any]:
    """Euler wedge: mean and largest pointwise error of the panel pressure (fractions)."""
    flow = FlowCondition.from_altitude(mach, altitude)
    r = _run(CaseSpec(*wedge_wall(angle_deg), flow, 300.0, "euler", resolution), folder)
    exact = flow.pressure * float(oblique_shock(mach, math.radians(angle_deg))[1])
    out: dict[str, Any] = {"mach": mach, "angle_deg": angle_deg, "exact_pa": exact,
                           "converged": r.converged, "reason": r.reason,
                           "iterations": r.iterations, "seconds": r.cpu_seconds}
    if r.converged:
        out.update(mean_pa=float(np.mean(r.pressure)),
                   mean_error=float(np.mean(r.pressure) / exact - 1.0),
                   max_error=float(np.max(np.abs(r.pressure / exact - 1.0))))
    return out


def bump(amplitude: float = 0.01, mode: int = 1, altitude: float = 25000.0,
         resolution: Resolution | None = None, folder: Path | None = None) -> dict[str, Any]:
    """Euler flat plate + panel ``w = amplitude sin(mode pi x / a)``, M 6: the panel
    pressure against shock-expansion: the largest pointwise error relative to the local
    shock-expansion pressure (``max_error``), the same in units of the largest
    ``|p - p_inf|`` (``max_error_overpressure``) and the error of the mean pressure."""
    flow = FlowCondition.from_altitude(6.0, altitude)
    res = resolution or Resolution(cells_panel=128, cells_plate=32, cells_normal=60,
                                   wall_cell=5e-4, height=0.5, courant=0.2,
                                   max_iterations=20000, sample_every=50, window=20,
                                   tolerance=1e-4)
    xs = np.linspace(0.0, 1.0, 4 * res.cells_panel + 1)
    panel = np.column_stack([1.0 + xs, amplitude * np.sin(mode * np.pi * xs)])
    plate = np.array([[0.0, 0.0], [1.0, 0.0]])
    r = _run(CaseSpec(plate, panel, flow, 300.0, "euler", res), folder)
    out: dict[str, Any] = {"amplitude": amplitude, "mode": mode, "converged": r.converged,
                           "reason": r.reason, "iterations": r.iterations,
                           "seconds": r.cpu_seconds}
    if r.converged:
        x = r.x - 1.0
        slope = amplitude * mode * np.pi * np.cos(mode * np.pi * x)
        pts = SurfacePoints.grid(1.0, 1.0, 1.0, x.size, 1, 0.0)
        pts = replace(pts, x=x, x_le=1.0 + x)  # the face centres
        se, _ = ShockExpansionFluid(boundary_layer=False, heating="none").evaluate_batch(
            pts, slope[None, :], 0.0, np.full((1, x.size), 300.0), flow)
        ref = se[0] + flow.pressure
        scale = float(np.max(np.abs(se[0])))
        out.update(max_error=float(np.max(np.abs(r.pressure / ref - 1.0))),
                   max_error_overpressure=float(np.max(np.abs(r.pressure - ref)) / scale),
                   mean_error=float(np.mean(r.pressure) / np.mean(ref) - 1.0))
    return out


def richardson(coarse: float, medium: float, fine: float, ratio: float
               ) -> tuple[float, float]:
    """Richardson extrapolation of three values on grids refined by ``ratio``: the observed
    order ``p = ln((f3 - f2)/(f2 - f1)) / ln r`` and ``f = f1 + (f1 - f2)/(r^p - 1)`` (f1
    the finest); NaN order when the values do not converge monotonically."""
    d21, d32 = fine - medium, medium - coarse
    if d21 == 0.0:
        return 0.0, fine
    if d32 == 0.0 or d21 / d32 <= 0.0:
        return math.nan, math.nan
    p = math.log(d32 / d21) / math.log(ratio)
    return p, fine + d21 / (ratio**p - 1.0)


def flat_plate(wall_temperature: float, grids: tuple[tuple[int, float], ...] = FLAT_PLATE_GRIDS,
               ratio: float = 1.5, altitude: float = 25000.0, cells_per_metre: int = 40,
               folder: Path | None = None) -> dict[str, Any]:
    """Laminar flat plate (plate + panel, each 1 m) at M 6: the panel-mean heat flux into the
    wall on each grid, the Richardson value, and the Eckert estimate (Pr of the CFD gas)."""
    flow = FlowCondition.from_altitude(6.0, altitude)
    plate = np.array([[0.0, 0.0], [1.0, 0.0]])
    panel = np.array([[1.0, 0.0], [2.0, 0.0]])
    levels = []
    x = p = None
    for cells, wall_cell in grids:
        res = Resolution(cells_panel=cells_per_metre, cells_plate=cells_per_metre,
                         cells_normal=cells, wall_cell=wall_cell, height=0.3, upstream=0.05,
                         courant=0.1, smoothing=0.2, max_iterations=200000,
                         sample_every=200, window=10, tolerance=2e-3)
        r = _run(CaseSpec(plate, panel, flow, wall_temperature, "laminar", res), folder)
        level = {"cells_normal": cells, "wall_cell": wall_cell, "converged": r.converged,
                 "reason": r.reason, "iterations": r.iterations, "seconds": r.cpu_seconds,
                 "drift_heat_flux": r.drift_heat_flux}
        if r.converged:
            level["mean_heat_flux"] = float(np.mean(r.heat_flux))
            level["point_scatter"] = float(np.std(np.diff(r.heat_flux, 2)) / np.mean(
                np.abs(r.heat_flux)))
            x, p = r.x, r.pressure
        levels.append(level)
    out: dict[str, Any] = {"wall_temperature": wall_temperature, "levels": levels,
                           "ratio": ratio}
    if x is not None:
        gas = replace(flow, prandtl=eucken_prandtl(flow.gamma))
        out["eckert_mean_heat_flux"] = float(np.mean(eckert_heat_flux(
            gas, p, wall_temperature, x, "laminar")))
    q = [lv.get("mean_heat_flux") for lv in levels]
    if len(q) == 3 and all(v is not None for v in q):
        order, value = richardson(q[0], q[1], q[2], ratio)
        out.update(observed_order=order, richardson_heat_flux=value)
    return out


def run(config: dict[str, Any]) -> dict[str, Any]:
    """The verification parts named in ``config``: ``wedge`` (list of Mach numbers),
    ``bump`` (true), ``flat_plate`` (list of wall temperatures)."""
    out: dict[str, Any] = {}
    for mach in config.get("wedge", ()):
        out.setdefault("wedge", []).append(wedge(float(mach)))
    if config.get("bump"):
        out["bump"] = bump()
    for T_w in config.get("flat_plate", ()):
        out.setdefault("flat_plate", []).append(flat_plate(float(T_w)))
    return out
