"""Verification of the OpenFOAM snapshot source against exact theory (issue "CFD-grade fluid
loads"; the figures of the README's "CFD snapshots" section).

* :func:`wedge` -- Euler, a straight ramp from the leading edge: the mean panel pressure
  against the exact oblique-shock pressure (``oblique_shock``, weak solution);
* :func:`bump` -- Euler, the flat plate and a panel deformed by a sine mode: the panel
  pressure against the built-in shock-expansion march (no boundary layer);
* :func:`flat_plate` -- laminar, a flat plate at a uniform wall temperature on a family of
  grids refined in the wall-normal direction by a constant ratio, run coarse to fine (each
  started from the coarser one's state, :func:`mapped_from`): the panel-mean heat flux,
  its Richardson extrapolation (observed order from the three finest), the exact
  compressible similarity solution (:mod:`~hypate.solvers.aero.similarity`, Sutherland
  viscosity) and the laminar Eckert reference-temperature estimate (Eqs. 2.39-2.43), both
  with the Prandtl number the CFD gas has (OpenFOAM's Sutherland transport: Eucken
  conductivity, Pr 0.690) and on the level's own wall pressure;
* :func:`leading_edge` -- Euler, the same deformed panel behind rigid plates of different
  lengths ``L_le``: the premise of an inviscid ROM serving any ``a / L_le`` (the panel
  pressure does not depend on ``L_le``);
* :func:`strips` -- Euler, a 3-D panel in a flat wall (:mod:`~hypate.solvers.aero.rom.
  openfoam_case3d`, deformed as the Sec. 9.2 prototype at the end of its 160 s) against 2-D
  Euler cases of its streamwise strips on the same mesh spacing and against a 2-D CFD ROM
  applied strip-wise: what strip theory (Eq. 2.36) misses in 3-D.

``run(config)`` runs the parts named in ``config`` and returns their figures; nothing runs
at import. Each case runs on one core.
"""
from __future__ import annotations

import math
import subprocess
import tempfile
from collections.abc import Callable
from dataclasses import replace
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
from hypate.scaling.workflow.vocabulary.shipped import shipped
from hypate.solvers.aero.analytic import eckert_heat_flux
from hypate.solvers.aero.base import Array, SurfacePoints, SurfaceState
from hypate.solvers.aero.rom.io import load_rom
from hypate.solvers.aero.rom.openfoam_case import (
    CaseSpec,
    Resolution,
    eucken_prandtl,
    wedge_wall,
    write_case,
)
from hypate.solvers.aero.rom.openfoam_case3d import (
    PanelCase3D,
    deform_points,
    panel_deflection,
    write_case_3d,
)
from hypate.solvers.aero.rom.openfoam_run import (
    CaseResult,
    drift,
    find_openfoam,
    read_averages,
    read_samples,
    run_case,
)
from hypate.solvers.aero.shock_expansion import (
    ShockExpansionFluid,
    eckert_heat_flux_edge,
    oblique_shock,
)
from hypate.solvers.aero.similarity import similarity_heat_flux
from hypate.solvers.config import load_case
from hypate.solvers.coupling.run import simulate
from hypate.solvers.flow import FlowCondition

__all__ = ["FLAT_PLATE_GRIDS", "FLAT_PLATE_ITERATIONS", "WEDGE_RESOLUTION", "bump", "flat_plate",
           "leading_edge", "mapped_from", "prototype_deflection", "richardson", "run", "strips",
           "wedge"]

#: Euler wedge mesh of the issue's table: 7,200 cells, 6.7 mm wall cell.
WEDGE_RESOLUTION = Resolution(cells_panel=60, cells_plate=60, cells_normal=60, wall_cell=6.7e-3,
                              height=0.5, courant=0.2, max_iterations=20000, sample_every=50,
                              window=20, tolerance=1e-4)
#: Laminar flat-plate grids, coarse to fine: wall-normal cells and first-cell height refined
#: together by 1.5 (streamwise 40 cells per metre on all).
FLAT_PLATE_GRIDS = ((40, 1.5e-4), (60, 1.0e-4), (90, 6.667e-5), (135, 4.444e-5),
                    (203, 2.963e-5))
#: Iterations of the coarsest flat-plate level (from the free stream) and of each finer one
#: (from the coarser level's last state, by mapFields). A level's heat flux is the mean of
#: its samples over the second half of its iterations: the panel mean oscillates from sample
#: to sample about a mean that settles, and a drift test stops inside the swings (README,
#: "CFD snapshots").
FLAT_PLATE_ITERATIONS = (100000, 60000)


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


def mapped_from(source: Path) -> Callable[[Path], None]:
    """An ``after_mesh`` hook of :func:`run_case` that starts the case from the last written
    state of the case in ``source`` (OpenFOAM's ``mapFields``, same geometry)."""
    def map_fields(case: Path) -> None:
        of = find_openfoam()
        tool = str(Path(of.solver).parent / "mapFields")
        with open(case / "log.mapFields", "w", encoding="utf-8") as log:
            code = subprocess.run([tool, str(source), "-consistent", "-sourceTime",
                                   "latestTime", "-case", str(case)], env=of.environment(),
                                  stdout=log, stderr=subprocess.STDOUT).returncode
        if code != 0:
            raise RuntimeError(f"mapFields from {source} failed: see {case / 'log.mapFields'}")
    return map_fields


def _settled_mean(folder: Path, iterations: int) -> dict[str, float]:
    """Panel-mean heat flux into the wall over the second half of a run's samples: the mean,
    the 5-95 % spread of the samples and the drift between the halves of that window."""
    avg = read_averages(folder)
    q = -avg[avg[:, 0] > iterations / 2, 3]
    if q.size < 2 or not np.all(np.isfinite(q)):
        raise RuntimeError(f"no finite wall averages in {folder}")
    return {"mean_heat_flux": float(np.mean(q)), "p05": float(np.percentile(q, 5)),
            "p95": float(np.percentile(q, 95)), "drift_heat_flux": drift(q)}


def flat_plate(wall_temperature: float, grids: tuple[tuple[int, float], ...] = FLAT_PLATE_GRIDS,
               iterations: tuple[int, int] = FLAT_PLATE_ITERATIONS, ratio: float = 1.5,
               altitude: float = 25000.0, cells_per_metre: int = 40,
               folder: Path | None = None) -> dict[str, Any]:
    """Laminar flat plate (plate + panel, each 1 m) at M 6: the panel-mean heat flux into the
    wall on each grid, the Richardson value of the three finest, the exact similarity
    solution on each grid's mean wall pressure (zero pressure gradient: the wall pressure
    varies by < 1 % along the panel) and the Eckert estimate on each grid's own wall
    pressure (both with the Pr of the CFD gas).

    The grids run coarse to fine, each finer one started from the coarser one's last state
    (``iterations``: of the coarsest, of each finer one); the levels' cases stay in
    ``folder``/``level<i>`` when given."""
    flow = FlowCondition.from_altitude(6.0, altitude)
    gas = replace(flow, prandtl=eucken_prandtl(flow.gamma))
    plate = np.array([[0.0, 0.0], [1.0, 0.0]])
    panel = np.array([[1.0, 0.0], [2.0, 0.0]])
    of = find_openfoam()
    levels: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory() as tmp:
        root = folder or Path(tmp)
        previous: Path | None = None
        for i, (cells, wall_cell) in enumerate(grids):
            n = iterations[0 if previous is None else 1]
            res = Resolution(cells_panel=cells_per_metre, cells_plate=cells_per_metre,
                             cells_normal=cells, wall_cell=wall_cell, height=0.3,
                             upstream=0.05, courant=0.1, smoothing=0.2, max_iterations=n,
                             sample_every=200, window=10, tolerance=0.0)
            case = write_case(root / f"level{i}", CaseSpec(plate, panel, flow,
                                                           wall_temperature, "laminar", res))
            r = run_case(case, of, res, True,
                         after_mesh=None if previous is None else mapped_from(previous))
            if r.iterations < n:
                raise RuntimeError(f"flat plate {wall_temperature:g} K, level {i}: {r.reason}")
            x, _, p, _, _ = read_samples(case, [n])
            level = {"cells_normal": cells, "wall_cell": wall_cell, "iterations": n,
                     "seconds": r.cpu_seconds, **_settled_mean(case, n),
                     "eckert_mean_heat_flux": float(np.mean(eckert_heat_flux(
                         gas, p, wall_temperature, x, "laminar"))),
                     "similarity_mean_heat_flux": float(np.mean(similarity_heat_flux(
                         gas, float(np.mean(p)), wall_temperature, x)))}
            levels.append(level)
            previous = case
    out: dict[str, Any] = {"wall_temperature": wall_temperature, "levels": levels,
                           "ratio": ratio,
                           "eckert_mean_heat_flux": levels[-1]["eckert_mean_heat_flux"],
                           "similarity_mean_heat_flux": levels[-1]["similarity_mean_heat_flux"]}
    if len(levels) >= 3:
        q = [lv["mean_heat_flux"] for lv in levels[-3:]]
        order, value = richardson(q[0], q[1], q[2], ratio)
        out.update(observed_order=order, richardson_heat_flux=value)
    return out


#: Euler mesh of the shipped CFD ROMs (64 cells on the 1 m panel, 40 wall-normal, 1 mm at
#: the wall) with their convergence settings; the checks below use its spacing.
ROM_RESOLUTION = Resolution(cells_panel=64, cells_plate=16, cells_normal=40, wall_cell=1e-3,
                            height=0.35, courant=0.2, max_iterations=20000, sample_every=25,
                            window=20, tolerance=3e-4)


def _panel_wall(l_le: float, x: Array, w: Array) -> tuple[Array, Array]:
    """Plate and panel polylines of a 2-D case: the flat plate of ``l_le`` and the panel
    ``(l_le + x, w)``."""
    return np.array([[0.0, 0.0], [l_le, 0.0]]), np.column_stack([l_le + x, w])


def leading_edge(l_le: tuple[float, ...] = (1.0, 1.406), amplitudes: tuple[float, ...] = (
        3.0, 0.3, 0.2), thickness: float = 0.018, height: float = 0.7,
        resolution: Resolution = ROM_RESOLUTION, folder: Path | None = None
        ) -> dict[str, Any]:
    """Euler, M 6, 25 km: the 1 m panel ``w = h sum_m A_m sin(m pi x)`` behind rigid plates of
    each length in ``l_le`` (the plate meshed with the same cell length, the domain equally
    high in metres): the panel pressure of each against the first, the largest pointwise
    difference relative to the local pressure (``max_difference``) and in units of the
    largest ``|p - p_inf|`` (``max_difference_overpressure``).

    Default: the ROM's ``a / L_le = 1`` and the Table 9.8 xi = 4 model's ``L_le / a =
    0.3516 / 0.25 = 1.406``."""
    flow = FlowCondition.from_altitude(6.0, 25000.0)
    xs = np.linspace(0.0, 1.0, 4 * resolution.cells_panel + 1)
    w = np.asarray(thickness * sum(A * np.sin((k + 1) * np.pi * xs)
                                   for k, A in enumerate(amplitudes)), dtype=float)
    w[[0, -1]] = 0.0
    cases: list[dict[str, Any]] = []
    for L in l_le:
        res = replace(resolution, height=height / (L + 1.0),
                      cells_plate=max(2, int(round(resolution.cells_plate * L))))
        r = _run(CaseSpec(*_panel_wall(L, xs, w), flow, 300.0, "euler", res), folder)
        cases.append({"l_le": L, "converged": r.converged, "reason": r.reason,
                      "iterations": r.iterations, "seconds": r.cpu_seconds,
                      "x": r.x - L, "pressure": r.pressure})
    out: dict[str, Any] = {"amplitudes": list(amplitudes), "cases": [
        {k: v for k, v in c.items() if k not in ("x", "pressure")} for c in cases]}
    if all(c["converged"] for c in cases):
        ref = cases[0]
        scale = float(np.max(np.abs(ref["pressure"] - flow.pressure)))
        diffs = [np.interp(ref["x"], c["x"], c["pressure"]) - ref["pressure"]
                 for c in cases[1:]]
        out.update(max_difference=max(float(np.max(np.abs(d) / ref["pressure"]))
                                      for d in diffs),
                   max_difference_overpressure=max(float(np.max(np.abs(d))) / scale
                                                   for d in diffs))
    return out


def prototype_deflection() -> tuple[Array, Array]:
    """The Sec. 9.2 prototype's deflection at the end of its run (``pt-bl`` + Eckert, the
    shipped case ``sec9_2_prototype``, 160 s): modal amplitudes (m) of the modes ``sin(i pi x
    / a) sin(j pi y / b)`` symmetric about the centre line (odd j), as ``(modes,
    amplitudes)``."""
    case = load_case(shipped("case")["sec9_2_prototype"])
    assert case.flow is not None  # the shipped case has its flight condition
    r = simulate(case.panel, case.flow, case.simulation, keep_fields=False)
    modal = np.asarray(r.modal)[-1] * case.panel.thickness  # amplitude / h -> m
    idx = np.asarray(r.mode_indices, int)
    keep = idx[:, 1] % 2 == 1
    return idx[keep], modal[keep]


def _nrmse_and_max(ref: Array, other: Array) -> tuple[float, float]:
    """NRMSE (Eq. 7.7, uniform faces) and largest error of ``other``, both in units of the
    range of ``ref``."""
    span = float(np.ptp(ref))
    return (float(np.sqrt(np.mean((other - ref) ** 2))) / span,
            float(np.max(np.abs(other - ref))) / span)


def strips(rom_path: str | Path | None = None, modes: Array | None = None,
           amplitudes: Array | None = None, l_le: float = 0.25, cells_span: int = 32,
           cells_margin: int = 8, margin: float = 0.25, height: float = 0.6,
           strip_rows: int = 8, resolution: Resolution = ROM_RESOLUTION,
           folder: Path | None = None, result3d: CaseResult | None = None
           ) -> dict[str, Any]:
    """Euler, M 6, 25 km: the 1 m x 1 m panel deformed by ``sum A_k sin(m pi x) sin(n pi y)``
    (default: :func:`prototype_deflection`) in 3-D (half span, the mesh spacing of
    ``resolution`` on the panel and at the wall) against

    * 2-D Euler cases of ``strip_rows`` of its streamwise strips (every ``k``-th row of the
      3-D panel faces from the centre line out; the same streamwise and wall-normal mesh):
      the error of strip theory itself;
    * the 2-D CFD ROM of ``rom_path`` applied strip-wise (as the coupled solvers do) on
      every row of faces: the error of what ships (strip theory + the ROM's own error +
      its finer wall-normal mesh).

    Errors of the overpressure ``p - p_inf`` in units of the 3-D range over the compared
    faces (NRMSE of Eq. 7.7, largest point error), of the panel-mean overpressure and of the
    generalized force on the first mode, ``int (p - p_inf) sin(pi x) sin(pi y) dA``; and
    of the Eckert heat flux (turbulent, 500 K wall) on each one's edge state. ``l_le``: any
    plate length serves an Euler case (:func:`leading_edge`). ``result3d``: the result of
    this 3-D case run before (``openfoam_run.read_result`` of its folder), not run again."""
    flow = FlowCondition.from_altitude(6.0, 25000.0)
    if modes is None or amplitudes is None:
        modes, amplitudes = prototype_deflection()
    r = resolution
    case = PanelCase3D(1.0, 1.0, l_le, np.asarray(modes), np.asarray(amplitudes, float), flow,
                       cells_plate=max(2, int(round(r.cells_plate * l_le))),
                       cells_panel=r.cells_panel, cells_span=cells_span,
                       cells_margin=cells_margin, cells_normal=r.cells_normal, margin=margin,
                       height=height, wall_cell=r.wall_cell, resolution=r)
    if result3d is not None:
        res3 = result3d
    else:
        with tempfile.TemporaryDirectory() as tmp:
            where = (folder or Path(tmp)) / "case3d"
            res3 = run_case(write_case_3d(where, case), find_openfoam(), r, False,
                            after_mesh=partial(deform_points, case=case))
    out: dict[str, Any] = {"cells": case.n_cells, "converged": res3.converged,
                           "reason": res3.reason, "iterations": res3.iterations,
                           "seconds": res3.cpu_seconds, "modes": np.asarray(modes).tolist(),
                           "amplitudes_m": [float(v) for v in amplitudes],
                           "max_deflection_m": float(np.max(np.abs(panel_deflection(
                               case, *np.meshgrid(np.linspace(0, 1, 41),
                                                  np.linspace(0, 1, 41))))))}
    if not res3.converged:
        return out
    x3, y3 = res3.x - l_le, res3.y
    # the row of each face (centre line out, half span): face centres of the deformed wall
    # move off their row's y by ~1e-6 m, so the rows are the cells' spanwise index
    dy = 0.5 / cells_span
    row = np.clip(np.floor((y3 - 0.5) / dy).astype(int), 0, cells_span - 1)
    rows = np.arange(cells_span)
    T_w = 500.0

    def eckert(p: Array, T: Array, x: Array) -> Array:
        return eckert_heat_flux_edge(flow, p, T, np.full(p.shape, T_w), l_le + x)

    def compare(sel: Array, p_other: Array, q_other: Array) -> dict[str, float]:
        p3, q3 = res3.pressure[sel] - flow.pressure, eckert(res3.pressure[sel],
                                                            res3.temperature[sel], x3[sel])
        phi = np.sin(np.pi * x3[sel]) * np.sin(np.pi * y3[sel])
        e_p, m_p = _nrmse_and_max(p3, p_other)
        e_q, m_q = _nrmse_and_max(q3, q_other)
        return {"faces": int(sel.sum()), "pressure_nrmse": e_p, "pressure_max_error": m_p,
                "mean_overpressure_error": float(np.mean(p_other) / np.mean(p3) - 1.0),
                "mode11_force_error": float(np.sum(p_other * phi) / np.sum(p3 * phi) - 1.0),
                "heat_flux_nrmse": e_q, "heat_flux_max_error": m_q}

    # 2-D Euler cases of some strips, on the 3-D case's spacing
    step = max(1, rows.size // strip_rows)
    picked = rows[::step][:strip_rows]
    xs = np.linspace(0.0, 1.0, 4 * r.cells_panel + 1)
    res2 = replace(r, height=height / (l_le + 1.0), cells_plate=case.cells_plate)
    p2, q2, sel2, strip_seconds = [], [], np.zeros(x3.size, bool), 0.0
    for j in picked:
        on = row == j
        y = 0.5 + (j + 0.5) * dy  # the row's y on the flat wall
        w = panel_deflection(case, xs, np.full(xs.size, y))
        w[[0, -1]] = 0.0
        c2 = _run(CaseSpec(*_panel_wall(l_le, xs, w), flow, T_w, "euler", res2), folder)
        strip_seconds += c2.cpu_seconds
        if not c2.converged:
            out["strip_failure"] = f"y = {y:g} m: {c2.reason}"
            return out
        sel2 |= on
        xf = x3[on]
        p2.append(np.interp(xf, c2.x - l_le, c2.pressure) - flow.pressure)
        q2.append(eckert(np.interp(xf, c2.x - l_le, c2.pressure),
                         np.interp(xf, c2.x - l_le, c2.temperature), xf))
    # the rows in the order of the faces: re-gather by the face mask
    order = np.concatenate([np.flatnonzero(row == j) for j in picked])
    inv = np.argsort(order, kind="stable")
    p2a, q2a = np.concatenate(p2)[inv], np.concatenate(q2)[inv]
    out["strips_2d"] = dict(compare(sel2, p2a, q2a),
                            rows=[float(0.5 + (j + 0.5) * dy) for j in picked],
                            seconds=strip_seconds)
    if rom_path is not None:  # the 2-D ROM strip-wise on every row of faces
        rom = load_rom(rom_path)
        pr, qr = np.empty(x3.size), np.empty(x3.size)
        line = SurfacePoints.grid(1.0, 1.0, l_le, 4 * r.cells_panel + 1, 1)
        for j in rows:
            on = row == j
            w = panel_deflection(case, line.x, np.full(line.n, 0.5 + (j + 0.5) * dy))
            st = SurfaceState(w, line.streamwise_derivative @ w, 0.0 * w, np.full(line.n, T_w))
            loads = rom.evaluate(line, st, flow)
            pr[on] = np.interp(x3[on], line.x, loads.pressure)
            qr[on] = np.interp(x3[on], line.x, loads.heat_flux)
        out["rom_strips"] = compare(np.ones(x3.size, bool), pr, qr)
    return out


def run(config: dict[str, Any]) -> dict[str, Any]:
    """The verification parts named in ``config``: ``wedge`` (list of Mach numbers),
    ``bump`` (true), ``flat_plate`` (list of wall temperatures), ``leading_edge`` (true),
    ``strips`` (the path of a 2-D CFD ROM, or true for the strip cases alone)."""
    out: dict[str, Any] = {}
    if config.get("leading_edge"):
        out["leading_edge"] = leading_edge()
    if config.get("strips"):
        rom = config["strips"]
        out["strips"] = strips(rom if isinstance(rom, (str, Path)) else None)
    for mach in config.get("wedge", ()):
        out.setdefault("wedge", []).append(wedge(float(mach)))
    if config.get("bump"):
        out["bump"] = bump()
    for T_w in config.get("flat_plate", ()):
        out.setdefault("flat_plate", []).append(flat_plate(float(T_w)))
    return out
