"""Ch. 9 design points: Fig. 9.9 / Table 9.8, Tables 9.9-9.10 and Table 9.11.

Tabulates the dissertation's design points next to those of ``hypate run`` directories:

* Table 9.8 (Sec. 9.2.2, ideal tunnel, Fig. 9.9 solid points):
  ``studies/optimization/sec9_2_2_xi{2..5}.toml``;
* Tables 9.9 / 9.10 (Sec. 9.2.3, WT5-WT7, Case 1 parameter relaxation / Case 2 with the
  radiant heater): ``studies/optimization/sec9_2_3_case{1,2}_wt{5,6,7}.toml``;
* Table 9.11 (Sec. 9.2.4, errors over the flight envelope in WT7):
  ``studies/optimization/sec9_2_4_envelope.toml`` (its ``sweep.csv``; error = 100 J_s, Eq. 9.8).

The optimizations take hours; this script only reads finished (or interrupted) run
directories: ``design_point.json`` (``study``, ``xi``, ``design``, ``objectives``) or
``sweep.csv``. A directory is matched to a table column by its study name; ``assign``
overrides that (e.g. ``"9.8:xi4"`` to show the quick-start run next to Table 9.8).

Run ``python -m hypate.studies.scripts.ch9_tables RUN_DIR ... [--assign RUN_DIR=9.8:xi4]
[--out DIR]``.
"""
from __future__ import annotations

import json
import math
import re
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd
from hypate.studies.scripts.comparison import (
    Bound,
    Finding,
    publish,
    side_by_side,
    standard_parser,
)

#: Table 9.8 (p0 in MPa).
TABLE_9_8 = {
    "xi2": {"M": 6.841, "p0": 64.76, "T0": 2280.0, "L_le": 1.812, "h": 1.000e-2},
    "xi3": {"M": 5.653, "p0": 39.16, "T0": 1868.0, "L_le": 2.000, "h": 5.971e-3},
    "xi4": {"M": 5.407, "p0": 38.58, "T0": 2130.0, "L_le": 0.3516, "h": 4.317e-3},
    "xi5": {"M": 6.250, "p0": 73.30, "T0": 2187.0, "L_le": 0.1950, "h": 4.150e-3},
}
#: Table 9.9 (Case 1) and Table 9.10 (Case 2); p0 in MPa ("L_te" in the tables is L_le).
TABLE_9_9 = {
    "wt5": {"p0": 2.827, "T0": 1267.0, "L": 0.5, "L_le": 0.7601, "h": 7.034e-3},
    "wt6": {"p0": 8.274, "T0": 1664.0, "L": 0.5, "L_le": 0.6270, "h": 8.794e-3},
    "wt7": {"p0": 8.274, "T0": 2317.0, "L": 0.5, "L_le": 0.6419, "h": 1.000e-2},
}
TABLE_9_10 = {
    "wt5": {"p0": 0.4861, "T0": 1222.0, "L": 0.5, "L_le": 2.000, "h": 7.500e-3,
            "emissivity": 0.5, "T_rad": 1621.0},
    "wt6": {"p0": 0.9928, "T0": 1821.0, "L": 0.448, "L_le": 1.761, "h": 7.798e-3,
            "emissivity": 1.0, "T_rad": 1492.0},
    "wt7": {"p0": 6.543, "T0": 2220.0, "L": 0.4448, "L_le": 1.717, "h": 8.210e-3,
            "emissivity": 1.0, "T_rad": 1548.0},
}
#: Table 9.11: errors (%) at (M, H km).
TABLE_9_11 = {
    5.0: (4.82, 4.41, 3.69, 7.20, 9.98), 5.5: (3.40, 2.95, 3.34, 4.51, 5.47),
    6.0: (2.75, 1.50, 4.52, 3.2, 4.13), 6.5: (6.16, 2.15, 3.24, 2.25, 2.81),
    7.0: (5.22, 3.58, 2.43, 5.17, 2.01),
}
ALTITUDES_KM = (20.0, 22.0, 25.0, 28.0, 30.0)
#: Agreement asked of a design variable or an error: 10 %, the threshold at which the run
#: report highlights a similarity mismatch (a design point is one of many near-optimal
#: designs; the tables give 4 digits of one of them).
RTOL = 0.10
TABLES = {"9.8": TABLE_9_8, "9.9": TABLE_9_9, "9.10": TABLE_9_10}
#: Why the design-variable rows of Tables 9.8-9.10 and the errors of Table 9.11 differ
#: (:func:`published_rows` measures its premise on every full reproduction).
FINDING_ADMISSIBILITY = Finding(
    "Accepted finding (Sec. 9.2, issue 40): the dissertation's Ti 6242 models run hundreds of "
    "kelvin past the alloy's service temperature (811 K) and property data (950 K) -- at "
    "Table 9.8's xi = 4 point hypate's model reaches 1408 K, a margin of -597 K "
    "(`hypate whatif studies/optimization/sec9_2_2_xi4.toml --set M=5.407 --set p0=3.858e7 "
    "--set T0=2130 --set L_le=0.3516 --set h=0.004317`). hypate's Sec. 9.2 studies hold the "
    "model to its limits ([admissibility], on by default), so their design points are "
    "admissible models with larger errors, and a published design evaluated in hypate is no "
    "fair target for them.")
FINDING_SEC9_2_MODEL = Finding(
    "Accepted finding (Sec. 9.2, issues 21 and 44): the dissertation simulates the Sec. 9.2"
    " prototype and models with its CFD fluid ROM of Sec. 8.3 (loads and heating, corrected"
    " and scaled); hypate's shipped Sec. 9.2 studies use pt-bl with Eckert heating, and two"
    " of them (sec9_2_2_xi4, sec9_2_4_envelope) have _cfd variants on an Euler ROM of "
    "OpenFOAM snapshots (Eckert heating on the CFD edge state). Evaluated by hypate, every "
    "one of the ten published design points of Tables 9.8-9.10 is worse than hypate's own "
    "design point (rows 'the dissertation's design in hypate'; measured at d83de40: "
    "max(J_u, J_T) 12.5-74.6 % against 7.3-34.7 %; Table 9.10 WT7, the flight condition M "
    "6, H 25 km of Table 9.11's 4.52 %: J_u 28.8 %, J_T 21.5 %, J_s 36 %). The fluid model "
    "is not what separates the two: at Table 9.8's xi = 4 design the CFD ROM moves J_u and "
    "J_T by 0.39 and 0.27 points, at the pt-bl envelope designs J_s by -2.9 to +0.4 points "
    "(items sec9_2_2_fluids, sec9_2_4_fluids; at b9f7b19 and 4278716), and the envelope "
    "optimized on the CFD ROM itself ends -6.2 to +0.7 points (mean -3.0) from the pt-bl "
    "sweep, at 16.2-54.6 % J_s (item sec9_2_4_cfd, seed 0 at fb9871e), while hypate holds "
    "its Ti 6242 models to their service temperature and property data (the admissibility "
    "finding), which the published designs exceed: in WT7 (Mach 7, T_inf matched) the "
    "model's T0 is 2340-2446 K, and J_T's similarity asks a model volume-mean temperature "
    "of 780-1327 K over the envelope, above Ti 6242's 811 K at 24 of 25 conditions (rows "
    "'model volume-mean temperature', seed 0 at 4278716); at M 6 / 25 km and M 5 / 20 km "
    "the same budget without the material limits ends at 18.0 and 21.7 % J_s against 37.8 "
    "and 56.6 % (README). So the design-variable rows compare the optima of different "
    "models, and Table 9.11's error levels (1.5-10 %) are not hypate's: its envelope sweep "
    "ends at 17.9-56.6 % J_s (seed 0 at 4278716; 14-24 % at ee3c233, before the "
    "admissibility constraints).")


@dataclass(frozen=True)
class Config:
    """Run directories and optional explicit table assignments (``DIR=9.8:xi4``)."""

    run_dirs: tuple[str, ...] = ()
    assign: tuple[str, ...] = ()

    @classmethod
    def coarse(cls) -> Config:
        """No run directories: the dissertation columns only (the test adds a quick run)."""
        return cls()


@dataclass(frozen=True)
class Result:
    """Design points found, envelope errors and the side-by-side table."""

    design_points: dict[str, dict[str, float]]
    objectives: dict[str, dict[str, float]]
    envelope_errors: dict[tuple[float, float], float]
    table: pd.DataFrame


def target_of(study: str) -> tuple[str, str] | None:
    """(table, column) of a shipped Sec. 9.2 study name, e.g. ``("9.8", "xi3")``."""
    m = re.fullmatch(r"sec9_2_2_(xi\d)", study)
    if m:
        return "9.8", m.group(1)
    m = re.fullmatch(r"sec9_2_3_case([12])_(wt[567])", study)
    if m:
        return ("9.9" if m.group(1) == "1" else "9.10"), m.group(2)
    return None


def study_of(table: str, col: str) -> str:
    """The shipped study name of column ``col`` of Table ``table`` (inverse of
    :func:`target_of`), e.g. ``("9.10", "wt7")`` -> ``"sec9_2_3_case2_wt7"``."""
    if table == "9.8":
        return f"sec9_2_2_{col}"
    return f"sec9_2_3_case{1 if table == '9.9' else 2}_{col}"


def published_design(table: str, col: str) -> dict[str, float]:
    """The dissertation's design point of column ``col`` of Table ``table`` in SI units (the
    table's p0 in MPa -> Pa), as ``hypate whatif --set`` takes it."""
    return {k: v * 1e6 if k == "p0" else v for k, v in TABLES[table][col].items()}


def _hypate_value(name: str, design: dict[str, float]) -> float | None:
    v = design.get(name)
    if v is None:
        return None
    return float(v) / 1e6 if name == "p0" else float(v)  # Pa -> MPa


def envelope_rows(path: Path, errors: dict[tuple[float, float], float],
                  note: object = "hypate: 100 J_s (Eq. 9.8)") -> list[tuple]:
    """Table 9.11 rows of a finished (or partial) envelope sweep directory (``sweep.csv``);
    fills ``errors[(M, H km)]`` with hypate's 100 J_s (Eq. 9.8). ``note`` goes with every
    row (e.g. an accepted finding)."""
    df = pd.read_csv(path / "sweep.csv")
    rows = []
    for _, r in df.iterrows():
        if "J_s" not in r or pd.isna(r.get("J_s")):
            continue
        mach, h_km = float(r["mach"]), float(r["altitude"]) / 1000.0
        errors[mach, h_km] = 100.0 * float(r["J_s"])
        ref = TABLE_9_11.get(mach)
        d = (ref[ALTITUDES_KM.index(h_km)] if ref is not None and h_km in ALTITUDES_KM
             else None)
        rows.append((f"Table 9.11 error at M = {mach:g}, H = {h_km:g} km (%)", d,
                     errors[mach, h_km], note))
    return rows


#: Sec. 9.2.4's two regions where the errors exceed 5 % (text below Table 9.11): high Mach
#: number at low altitude, low Mach number at high altitude, as (M, H km) cells.
HIGH_ERROR_REGIONS = {
    "M 6.5-7.0 at H 20 km": ((6.5, 20.0), (7.0, 20.0)),
    "M 5.0-5.5 at H 28-30 km": ((5.0, 28.0), (5.0, 30.0), (5.5, 28.0), (5.5, 30.0)),
}


def envelope_trend_rows(errors: dict[tuple[float, float], float]) -> list[tuple]:
    """Sec. 9.2.4's trend, which does not depend on the error level: the mean error of each
    region of :data:`HIGH_ERROR_REGIONS` lies above the mean over the envelope (Table 9.11:
    5.69 and 6.79 % against 4.04 %). ``errors``: (M, H km) -> error (%), as
    :func:`envelope_rows` fills it; a region with a missing cell gives no row."""
    if not errors:
        return []
    overall = sum(errors.values()) / len(errors)
    rows = []
    for name, cells in HIGH_ERROR_REGIONS.items():
        if all(c in errors for c in cells):
            region = sum(errors[c] for c in cells) / len(cells)
            rows.append((f"Table 9.11 {name}: mean error above the envelope's mean", "yes",
                         bool(region > overall), f"hypate: {region:.1f} % against "
                         f"{overall:.1f} % (Sec. 9.2.4: errors above 5 % there)"))
    return rows


def needed_model_temperature(dp: dict) -> tuple[float, float] | None:
    """What J_T's similarity (volume-mean temperature over T0, Sec. 9.2.1.1) asks of a
    design point's model (``design_point.json``): the prototype's highest volume-mean
    temperature over its T0 times the model's T0 (K), and the lowest service temperature of
    the model's materials (K); None for a design point without those responses or limits
    (a run written before admissibility). The tunnel fixes the model's T0 (WT7: Mach 7 and
    the T_inf equality, Eq. 9.7), so where the first exceeds the second no admissible model
    reaches J_T = 0: its peak, held to the service temperature, is at least its volume
    mean."""
    r = dp.get("responses") or {}
    ratio = (r.get("prototype") or {}).get("mean_temperature_over_T0")
    T0 = (r.get("model") or {}).get("stagnation_temperature")
    limits = [m.get("service_temperature") for m in (dp.get("limits") or {}).get("model", [])]
    if ratio is None or T0 is None or not limits or None in limits:
        return None
    return float(ratio) * float(T0), min(float(v) for v in limits)


def envelope_temperature_rows(path: Path) -> list[tuple]:
    """Why Table 9.11's error level is hypate's: on each finished condition of an envelope
    sweep directory, the model temperature J_T's similarity needs
    (:func:`needed_model_temperature`), how many conditions need it above the model's
    service temperature, and the correlation of J_s with it over the conditions (Pearson r;
    a correlation only: the need grows toward low Mach number and altitude, as the errors
    do). Conditions whose design point lacks the responses are left out and counted."""
    df = pd.read_csv(path / "sweep.csv").dropna(subset=["J_s"])
    found = []
    for label, J_s in zip(df["label"], df["J_s"]):
        f = path / str(label) / "design_point.json"
        pair = needed_model_temperature(json.loads(f.read_text(encoding="utf-8"))) \
            if f.is_file() else None
        if pair is not None:
            found.append((*pair, float(J_s)))
    if not found:
        return []
    need = [n for n, _, _ in found]
    limit = min(lim for _, lim, _ in found)
    above = sum(n > lim for n, lim, _ in found)
    missing = len(df) - len(found)
    what = "Table 9.11 model volume-mean temperature J_T's similarity needs"
    rows: list[tuple] = [(
        f"{what}: conditions above the model's service temperature", None, above,
        f"of {len(found)}{f' ({missing} without the responses)' if missing else ''}; "
        f"needed {min(need):.0f}-{max(need):.0f} K against {limit:.1f} K (the tunnel's "
        "T0 times the prototype's mean temperature / T0)")]
    if len(found) > 2:
        r = float(pd.Series(need).corr(pd.Series([J for _, _, J in found])))
        rows.append((f"{what}: correlation with J_s over the conditions (Pearson r)", None, r,
                     "a correlation only; the README's single-condition runs with and "
                     "without the material limits measure the limits' share"))
    return rows


def design_point_rows(path: Path, dp: dict, table: str, col: str,
                      note: object = None) -> list[tuple]:
    """Rows of one run directory's ``design_point.json`` (``dp``) against column ``col``
    of Table ``table`` ("9.8", "9.9", "9.10"): the design variables (p0 in MPa; ``note``
    with each, by default the study and directory), the objectives at the design point (%)
    and the active constraints."""
    rows: list[tuple] = []
    design = dp.get("design", {})
    note = f"{dp.get('study')} ({path.name})" if note is None else note
    for name, ref in TABLES[table][col].items():
        unit = " (MPa)" if name == "p0" else ""
        rows.append((f"Table {table} {col} {name}{unit}", ref, _hypate_value(name, design),
                     note))
    for name, val in dp.get("objectives", {}).items():
        rows.append((f"Table {table} {col} {name} at the design point (%)",
                     Bound("<", 10.0) if table == "9.8" else None, 100.0 * float(val),
                     {"9.8": "Fig. 9.9 / Sec. 9.2.2: response errors < 10 %",
                      "9.9": "Fig. 9.13 Case 1: no good design in any realistic tunnel",
                      "9.10": "Fig. 9.13 Case 2: approximate similarity in every tunnel",
                      }.get(table, "")))
    active = dp.get("active_constraints") or []
    rows.append((f"Table {table} {col} active constraints", None, ", ".join(active) or "-"))
    return rows


def published_rows(table: str, col: str, published: dict[str, Any], dp: dict
                   ) -> list[tuple]:
    """The dissertation's design point of column ``col`` of Table ``table`` evaluated by
    hypate (``published``, from :func:`~.ch9_runs.published_design_errors`), and by how many
    percentage points of max(J_u, J_T) hypate's design point (``dp``) beats it in hypate's
    own model (a run that does not has missed the optimum of the model it searched)."""
    o = published["objectives"]
    if o["J_u"] is None or o["J_T"] is None:
        pub = math.nan
        note = f"the model failed: {published.get('message', '')}"
    else:
        pub = 100.0 * max(o["J_u"], o["J_T"])
        c = published["constraints"]
        off = [f"{b['name']} {b['state']}" for b in c["bounds"]
               if b["state"] in ("above upper", "below lower")]
        off += [f"{e['name']} equality residual {100.0 * e['residual']:.2g} %"
                for e in c["equalities"] if not e["satisfied"]]
        note = (f"J_u {100.0 * o['J_u']:.1f} %, J_T {100.0 * o['J_T']:.1f} %; the table's "
                "values as published" + (f" ({', '.join(off)})" if off else ""))
    own = 100.0 * max(dp["objectives"]["J_u"], dp["objectives"]["J_T"])
    rows: list[tuple] = [(
        f"Table {table} {col} the dissertation's design in hypate, max(J_u, J_T) (%)",
             None, pub, note)]
    # issue 40: whether the published model could be built and tested, as hypate checks it
    temp = next((r for r in published.get("admissibility") or []
                 if r["check"] == "temperature"), None)
    inadmissible = published.get("admissible") is False
    if temp is not None:
        violated = [r["check"] for r in published["admissibility"]
                    if r["ok"] is False and r["mode"] == "constraint"]
        rows.append((f"Table {table} {col} the dissertation's design in hypate: service-"
                     "temperature margin of its model (K)",
                     Bound(">", 0.0, "within its material's service temperature"),
                     temp["margin"],
                     FINDING_ADMISSIBILITY if inadmissible else
                     f"admissible in hypate ({temp['where']})"
                     + (f"; violates {', '.join(violated)}" if violated else "")))
    rows.append((f"Table {table} {col} hypate's design point better than the dissertation's "
                 "design in hypate (max(J_u, J_T), % points)",
                 Bound(">", 0.0, "hypate's design point beats the published one in its own model"),
                 pub - own, FINDING_ADMISSIBILITY if inadmissible else None))
    return rows


def run(config: Config | None = None) -> Result:
    """Read the run directories and tabulate them against Tables 9.8-9.11."""
    config = Config() if config is None else config
    overrides = {}
    for a in config.assign:
        d, _, spec = a.rpartition("=")
        table, _, col = spec.partition(":")
        overrides[str(Path(d))] = (table, col)
    rows: list[tuple] = []
    points: dict[str, dict[str, float]] = {}
    objectives: dict[str, dict[str, float]] = {}
    errors: dict[tuple[float, float], float] = {}
    for d in config.run_dirs:
        path = Path(d)
        if (path / "sweep.csv").exists():
            rows += envelope_rows(path, errors)
            continue
        try:
            dp = json.loads((path / "design_point.json").read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            warnings.warn(f"{d}: no readable design_point.json or sweep.csv ({exc})",
                          stacklevel=2)
            continue
        target = overrides.get(str(path)) or target_of(str(dp.get("study", "")))
        if target is None or target[0] not in TABLES or target[1] not in TABLES[target[0]]:
            warnings.warn(f"{d}: study {dp.get('study')!r} matches no Ch. 9 table column; "
                          "use assign=('DIR=9.8:xi4',)", stacklevel=2)
            continue
        table, col = target
        points[str(d)] = dict(dp.get("design", {}))
        objectives[str(d)] = dict(dp.get("objectives", {}))
        rows += design_point_rows(path, dp, table, col)
    if not rows:  # nothing given: the dissertation's columns alone
        for table, cols in TABLES.items():
            for col, vals in cols.items():
                for name, ref in vals.items():
                    rows.append((f"Table {table} {col} {name}", ref, None, "no run directory"))
    return Result(points, objectives, errors, side_by_side(rows, rtol=RTOL))


def main(argv: list[str] | None = None) -> None:
    """``python -m hypate.studies.scripts.ch9_tables RUN_DIR ... [--assign DIR=9.8:xi4]
    [--out DIR]``."""
    parser = standard_parser(__doc__.splitlines()[0])
    parser.add_argument("run_dirs", nargs="*", help="`hypate run` output directories")
    parser.add_argument("--assign", action="append", default=[],
                        help="DIR=TABLE:COLUMN, e.g. runs/quick=9.8:xi4")
    args = parser.parse_args(argv)
    res = run(Config(run_dirs=tuple(args.run_dirs), assign=tuple(args.assign)))
    title = "Ch. 9: design points (Tables 9.8-9.11)"
    publish(res.table, args.out, "ch9_tables", title)


if __name__ == "__main__":
    main()
