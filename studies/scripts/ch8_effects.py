"""Ch. 8 effects with analytical aerodynamics: trends of Table 8.2, Sec. 8.2 and Fig. 8.27.

(a) Boundary-layer thickness via L_le (Sec. 8.1, Tables 8.1-8.2): the Sec. 7.3 2D panel at
    L_le/a = 0.5, 1, 1.5, 7 (delta/a = 0.01, 0.02, 0.03, 0.1). Full piston theory with
    Eckert heating is the dissertation's "AM" column (L_le acts through the heating only);
    ``pt-bl`` (effective-shape piston theory) adds the boundary-layer pressure effect, the
    analogue of the RANS column (conclusion 2: a thicker boundary layer delays the
    snap-through; a sufficiently thick one stabilizes the panel).
(b) Aspect ratio (Sec. 8.2): the same panel made 3D (span ``width``); the dissertation's 2D
    panel snaps within 2.5 s while the 3D panel stays stable to 5.0 s.
(c) Flow angle and orthotropy (Sec. 8.3, Tables 8.3-8.4, Figs. 8.23, 8.25, 8.27): the 1 m
    square Inconel 718 sheet (1.5 mm) with 12 mm stiffeners smeared by Eq. (8.10)
    (orthogrid R12 = 1, x-stiffeners R12 = inf, y-stiffeners R12 = 0), M = 6, H = 25 km,
    emissivity 0.85, flow angles 0, 15, 30 deg. Reported: failed area (upper-surface
    temperature > T_max = 850 K) at the end, the time failure starts, and the stability
    boundary (failed area > 25 %, Sec. 8.3.4). The dissertation used a ROM of the CFD
    solution; here the analytical ``pt-bl`` + Eckert model (trends only).

Every case uses the TC scheme with a time step on the thermal scale (cheap).

Run ``python -m hypate.studies.scripts.ch8_effects [--coarse] [--out DIR]``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd
from hypate.solvers.aero.factory import make_fluid_model
from hypate.solvers.coupling.model import PanelModel
from hypate.solvers.coupling.tc import run_tc
from hypate.solvers.flow import FlowCondition
from hypate.solvers.materials import homogenized_stiffener, library_material
from hypate.solvers.panel import Layer, PanelSpec
from hypate.solvers.settings import SimulationSettings
from hypate.studies.scripts.ch7_benchmark import benchmark_model
from hypate.studies.scripts.comparison import Approx, Bound, Finding, side_by_side, simple_main

#: Table 8.1 / 8.2: L_le/a -> (delta/a, RANS onset s or None, AM onset s).
TABLE_8_2 = {0.5: (0.01, 0.13, 1.98), 1.0: (0.02, 1.38, 2.02), 1.5: (0.03, 2.64, 2.04),
             7.0: (0.1, None, 2.26)}
#: Table 8.3 stiffener cases (t1, l1, t2, l2 in m) and their orthotropy ratio label.
STIFFENERS = {"R12=1": (0.002, 0.06, 0.002, 0.06), "R12=inf": (0.004, 0.06, 0.0, 0.06),
              "R12=0": (0.0, 0.06, 0.004, 0.06)}
T_MAX = 850.0  # K, T_MS / 1.4 (Sec. 8.3.1)
#: Agreement asked of an onset time: 5 %, about one TC step (0.1 s) of a 2 s onset.
RTOL = 0.05
#: Why ``pt-bl`` cannot give Table 8.2's RANS onsets (measured: it stays stable to 3 s at
#: delta/a = 0.01, 0.02, 0.03, where RANS snaps at 0.13, 1.38, 2.64 s).
FINDING_PT_BL = Finding(
    "Accepted finding (Sec. 8.1): pt-bl is piston theory on the wall slope plus the "
    "Cox-Crabtree slope d(delta)/dx(x, T_w) (Eqs. 2.33-2.36), which the deflection does not "
    "change (tests/solvers/aero/test_analytic.py), so the boundary layer adds a steady "
    "compression but no out-of-phase pressure p_O; the growth of p_O with the deformation is "
    "what decides the RANS onsets (Figs. 8.3-8.7, conclusion 3). pt-bl gives conclusion 2's "
    "trend (the boundary layer stabilizes), not these times; the AM rows compare the models.")


@dataclass(frozen=True)
class Config:
    """Cases and discretization of the three effects."""

    leading_edge_lengths: tuple[float, ...] = (0.5, 1.0, 1.5, 7.0)
    bl_time_step: float = 0.1
    bl_duration: float = 3.0
    bl_with_pt_bl: bool = True
    width_3d: float = 1.0
    mesh_3d: tuple[int, int] = (8, 4)
    duration_3d: float = 5.0
    time_step_3d: float = 0.1
    flow_angles: tuple[float, ...] = (0.0, 15.0, 30.0)
    stiffener_cases: tuple[str, ...] = ("R12=1", "R12=inf", "R12=0")
    sec8_3_mesh: tuple[int, int] = (8, 8)
    sec8_3_time_step: float = 2.0
    sec8_3_duration: float = 100.0
    sec8_3_aero: str = "pt-bl"
    run_sec8_3: bool = True

    @classmethod
    def coarse(cls) -> Config:
        """Three L_le values, 3D on 8 x 4 to 5 s, Sec. 8.3 isotropic at 0/30 deg, 4 x 4."""
        return cls(leading_edge_lengths=(0.5, 1.5, 7.0), bl_with_pt_bl=False,
                   flow_angles=(0.0, 30.0), stiffener_cases=("R12=1",),
                   sec8_3_mesh=(4, 4), sec8_3_time_step=5.0)


@dataclass(frozen=True)
class Result:
    """Key numbers of the three effects and the side-by-side table."""

    onset_pt: dict[float, float | None]
    onset_pt_bl: dict[float, float | None]
    onset_delayed_by_thicker_bl: bool
    stable_3d: bool
    onset_2d: float | None
    sec8_3: dict[tuple[str, float], dict[str, float | None]]
    table: pd.DataFrame


def _onset(resp) -> float | None:
    return resp.instability_time if resp.status == "unstable" else None


def _stable_if_none(onset: float | None) -> float | str:
    """An onset time, or "stable" when the run ended without one (differs from a number)."""
    return "stable" if onset is None else onset


def stiffened_panel(case: str, flow_angle_deg: float, mesh: tuple[int, int]):
    """Sec. 8.3 panel: 1.5 mm Inconel 718 sheet on 12 mm smeared stiffeners (Eq. 8.10)."""

    inc = library_material("inconel718")
    t1, l1, t2, l2 = STIFFENERS[case]
    stiff = homogenized_stiffener(inc, t1, l1, t2, l2, name=f"stiffener_{case}")
    return PanelSpec(layers=(Layer(stiff, 0.012, 0.0, 1), Layer(inc, 0.0015, 0.0, 2)),
                     length=1.0, width=1.0, mesh=(mesh[0], mesh[1]), emissivity=0.85,
                     flow_angle=math.radians(flow_angle_deg), leading_edge_length=1.0)


def failed_area_history(case: str, flow_angle_deg: float, config: Config
                        ) -> tuple[np.ndarray, np.ndarray, str]:
    """(times, failed upper-surface fraction, status) of one Sec. 8.3 run (TC scheme)."""

    panel = stiffened_panel(case, flow_angle_deg, config.sec8_3_mesh)
    flow = FlowCondition.from_altitude(6.0, 25000.0)
    settings = SimulationSettings(time_step=config.sec8_3_time_step,
                                duration=config.sec8_3_duration, keep_fields=True)
    model = PanelModel(panel, flow, make_fluid_model(config.sec8_3_aero, "eckert", "turbulent"),
                       settings)
    resp = run_tc(model)
    w = np.asarray(model.points.weights)
    frac = np.array([float(np.sum(w[np.asarray(model.wall_temperature(T)) > T_MAX]) / np.sum(w))
                     for T in resp.T])
    return np.asarray(resp.times), frac, resp.status


def _first_time(t: np.ndarray, mask: np.ndarray) -> float | None:
    idx = np.flatnonzero(mask)
    return float(t[idx[0]]) if idx.size else None


def run(config: Config | None = None) -> Result:
    """Run the Ch. 8 trend cases and tabulate them against the dissertation."""

    config = Config() if config is None else config
    rows: list[tuple] = []
    # (a) boundary-layer thickness -----------------------------------------------------
    onset_pt: dict[float, float | None] = {}
    onset_bl: dict[float, float | None] = {}
    for L in config.leading_edge_lengths:
        r = run_tc(benchmark_model(config.bl_time_step, config.bl_duration, aero="pt",
                                   leading_edge_length=L))
        onset_pt[L] = _onset(r)
        ref = TABLE_8_2.get(L)
        runs = f"runs end at {config.bl_duration:g} s"
        rows.append((f"(a) onset, L_le/a = {L:g} (delta/a = {ref[0] if ref else '?'}), "
                     "AM / hypate pt + Eckert (s)", ref[2] if ref else None,
                     _stable_if_none(onset_pt[L]), f"Table 8.2 AM; {runs}"))
        if config.bl_with_pt_bl:
            rb = run_tc(benchmark_model(config.bl_time_step, config.bl_duration, aero="pt-bl",
                                        leading_edge_length=L))
            onset_bl[L] = _onset(rb)
            rans = ref[1] if ref else None
            rows.append((f"(a) onset, L_le/a = {L:g}, RANS / hypate pt-bl (s)",
                         rans if rans is not None else "stable", _stable_if_none(onset_bl[L]),
                         f"Table 8.2 RANS (BL pressure effect); {runs}" if rans is None
                         else FINDING_PT_BL))
    seq = [math.inf if (on := onset_pt[L]) is None else on
           for L in sorted(config.leading_edge_lengths)]
    delayed = bool(all(b >= a for a, b in zip(seq, seq[1:])) and seq[-1] > seq[0])
    rows.append(("(a) thicker boundary layer delays the snap-through (AM onsets increase)",
                 "yes", delayed, "Sec. 8.1 conclusion 2; Table 8.2 AM 1.98 -> 2.26 s"))
    # (b) aspect ratio -------------------------------------------------------------------
    r2 = run_tc(benchmark_model(config.bl_time_step, config.bl_duration, aero="pt"))
    onset_2d = _onset(r2)
    t2, w2 = np.asarray(r2.times), np.asarray(r2.center_deflection)
    peak_2d = float(np.max(w2[t2 < onset_2d])) if onset_2d is not None else float(np.max(w2))
    r3 = run_tc(benchmark_model(config.time_step_3d, config.duration_3d, aero="pt",
                                width=config.width_3d, mesh=config.mesh_3d))
    stable_3d = r3.status == "completed"
    ratio_3d_2d = float(np.max(r3.center_deflection) / peak_2d)
    rows += [("(b) 2D panel onset (s)", Bound("<=", 2.5, "within 2.5 s"),
              _stable_if_none(onset_2d), "Sec. 8.2.2"),
             (f"(b) 3D panel (b = {config.width_3d:g} m) stable to {config.duration_3d:g} s",
              "yes", stable_3d, "Sec. 8.2.2 (to 5.0 s); span of Fig. 8.8 not given in text"),
             ("(b) 3D peak w / 2D pre-snap peak w", None, ratio_3d_2d,
              "Figs. 8.9-8.10 (not tabulated)"),
             ("(b) the 3D panel deforms less than the 2D panel before its snap", "yes",
              ratio_3d_2d < 1.0, "Figs. 8.9-8.10")]
    # (c) flow angle and orthotropy ------------------------------------------------------
    sec8_3: dict[tuple[str, float], dict[str, float | None]] = {}
    if config.run_sec8_3:
        for case in config.stiffener_cases:
            for beta in config.flow_angles:
                t, frac, status = failed_area_history(case, beta, config)
                sec8_3[case, beta] = {"final_failed_percent": 100.0 * float(frac[-1]),
                                      "failure_start": _first_time(t, frac > 0.0),
                                      "stability_boundary": _first_time(t, frac > 0.25),
                                      "status": 0.0 if status == "completed" else 1.0}
        for case in config.stiffener_cases:
            for beta in config.flow_angles:
                s = sec8_3[case, beta]
                ref_start = (50.0 if (case == "R12=1" and beta == 0.0) else
                             48.0 if (case == "R12=0" and beta == 0.0) else None)
                never = f"none by {config.sec8_3_duration:g} s"
                # a time is resolved to one TC step; 5 % where that is finer
                rows.append((f"(c) {case}, beta = {beta:g} deg: failure starts (s)",
                             None if ref_start is None else Approx(
                                 ref_start, rel=RTOL, abs=config.sec8_3_time_step),
                             never if s["failure_start"] is None else s["failure_start"],
                             "Sec. 8.3.4.1-2 text"))
                rows.append((f"(c) {case}, beta = {beta:g} deg: failed area at "
                             f"{config.sec8_3_duration:g} s (%)",
                             Bound(">", 35.0) if (case == "R12=1" and beta == 30.0) else None,
                             s["final_failed_percent"], "Figs. 8.23, 8.27"))
                rows.append((f"(c) {case}, beta = {beta:g} deg: stability boundary, failed "
                             "area > 25 % (s)", None,
                             never if s["stability_boundary"] is None
                             else s["stability_boundary"], "Fig. 8.27 (read-off only)"))
        betas = sorted(config.flow_angles)
        if len(betas) > 1:
            for case in config.stiffener_cases:
                lo, hi = sec8_3[case, betas[0]], sec8_3[case, betas[-1]]
                f_lo, f_hi = lo["final_failed_percent"], hi["final_failed_percent"]
                assert f_lo is not None and f_hi is not None  # always set above
                more = f_hi >= f_lo
                rows.append((f"(c) {case}: beta {betas[-1]:g} deg fails more area than "
                             f"{betas[0]:g} deg", "yes", bool(more),
                             "Sec. 8.3.4.1: larger beta, stronger windward heating"))
                b0 = lo["stability_boundary"] or math.inf
                b1 = hi["stability_boundary"] or math.inf
                rows.append((f"(c) {case}: stability boundary lower at beta "
                             f"{betas[-1]:g} deg", "yes", bool(b1 < b0),
                             "Sec. 8.3.4 / Fig. 8.27"))
        if {"R12=0", "R12=inf"} <= set(config.stiffener_cases) and 0.0 in config.flow_angles:
            a, b = sec8_3["R12=0", 0.0], sec8_3["R12=inf", 0.0]
            rows.append(("(c) R12 = 0 starts failing before R12 = inf (beta 0)", "yes",
                         bool((a["failure_start"] or math.inf) <= (b["failure_start"] or math.inf)),
                         "Sec. 8.3.4.2"))
            if "R12=1" in config.stiffener_cases:
                bnd = [(sec8_3[c, 0.0]["stability_boundary"] or math.inf)
                       for c in ("R12=0", "R12=1", "R12=inf")]
                rows.append(("(c) lower R12 extends the stability boundary (beta 0: "
                             "R12 = 0 >= 1 >= inf)", "yes", bool(bnd[0] >= bnd[1] >= bnd[2]),
                             "Sec. 8.3.4.2, Fig. 8.27"))
    return Result(onset_pt, onset_bl, delayed, stable_3d, onset_2d, sec8_3,
                  side_by_side(rows, rtol=RTOL))


def main(argv: list[str] | None = None) -> None:
    """``python -m hypate.studies.scripts.ch8_effects [--coarse] [--out DIR]``."""
    simple_main(__doc__, run, Config, "ch8_effects",
                "Ch. 8: boundary layer, aspect ratio, flow angle and orthotropy (trends)", argv)


if __name__ == "__main__":
    main()
