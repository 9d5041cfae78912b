"""Reproduction scripts in ``studies/`` (issue 9): coarse configs against the dissertation.

Each script exposes ``run(config) -> Result`` and does nothing at import (DESIGN.md,
"Studies are importable"). Fast tests total ~25 s; the ``hypate run`` round trip is slow.
"""
from __future__ import annotations

import importlib
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import REPO

SCRIPTS = ("ch7_table7_3_modes", "ch7_flutter", "ch7_benchmark", "ch7_time_accuracy",
           "ch8_effects", "ch9_table9_3", "ch9_tables", "reproduce", "make_model_test",
           "material_choice")


def test_scripts_import_quietly_and_expose_run() -> None:
    code = "; ".join(f"import hypate.studies.scripts.{s}" for s in SCRIPTS)
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True,
                         text=True, check=True, timeout=60)
    assert out.stdout == "" and out.stderr == ""
    for s in SCRIPTS:
        mod = importlib.import_module(f"hypate.studies.scripts.{s}")
        assert callable(mod.run) and callable(mod.main) and hasattr(mod.Config, "coarse")


def test_table_7_3(tmp_path) -> None:
    from hypate.studies.scripts.ch7_table7_3_modes import (
        ANALYTICAL_HZ,
        DISSERTATION_HZ,
        Config,
        main,
        run,
    )

    res = run(Config.coarse())
    # Table 7.3: within 1 % of the analytical column, 0.2 % of the dissertation's DCS9
    np.testing.assert_allclose(res.frequencies_hz[:5], ANALYTICAL_HZ, rtol=0.01)
    np.testing.assert_allclose(res.frequencies_hz[:5], DISSERTATION_HZ, rtol=0.002)
    assert list(res.table.columns)[:4] == ["quantity", "dissertation", "hypate", "difference"]
    main(["--coarse", "--out", str(tmp_path)])
    assert (tmp_path / "ch7_table7_3_modes.csv").exists()
    assert "difference (%)" in (tmp_path / "ch7_table7_3_modes.md").read_text()


def test_comparison_flags_every_kind_of_mismatch() -> None:
    from hypate.studies.scripts.comparison import Approx, Bound, side_by_side, summary, to_markdown

    df = side_by_side([
        ("within 5 %", 2.02, 2.0), ("outside 5 %", 50.0, 42.0),
        ("own tolerance", Approx(0.0, abs=0.1), -0.045), ("bound met", Bound(">", 35.0), 41.9),
        ("bound missed", Bound("<=", 2.5, "within 2.5 s"), 2.6),
        ("trend agrees", "yes", True), ("trend differs", "yes", False),  # ch8's yes | no
        ("word where a number was published", 0.13, "stable"), ("same word", "flutter", "flutter"),
        ("nothing published", None, 3.0), ("not measured", 344.0, None),
    ])
    got = dict(zip(df["quantity"], df["matches"]))
    assert [q for q, m in got.items() if m is False] == [
        "outside 5 %", "bound missed", "trend differs", "word where a number was published"]
    assert got["nothing published"] is None and got["not measured"] is None
    assert all(got[q] is True for q in ("within 5 %", "own tolerance", "bound met",
                                        "trend agrees", "same word"))
    assert summary(df).startswith("5 of 9 compared values match; 4 mismatches (NO): outside 5 %")
    md = to_markdown(df)
    assert "| trend differs | yes | no | - | NO (same) |" in md
    assert "| bound missed | within 2.5 s | 2.6 | - | NO (<= 2.5) |" in md
    assert "| own tolerance | 0 | -0.045 | - | yes (±0.1) |" in md


def test_flutter_coarse(capsys: pytest.CaptureFixture) -> None:
    from hypate.studies.scripts.ch7_flutter import Config, main, run

    res = run(Config.coarse())
    # Sec. 7.2.3 on an 8 x 8 mesh: within 2 % (measured -0.9 %, -0.8 %, -0.6 %)
    assert res.lambda_tcr == pytest.approx(344.0, rel=0.02)
    assert res.lambda_2tcr == pytest.approx(191.1, rel=0.02)
    assert res.divergence_upper_2tcr == pytest.approx(183.5, rel=0.02)
    # without --time-domain the time-domain rows say so instead of showing the LSA value
    t = res.table.set_index("quantity")
    for q in ("lambda_F at T_cr (time domain)", "lambda_F at 2 T_cr (time domain)"):
        assert t.loc[q, "hypate"] is None and t.loc[q, "matches"] is None
        assert "--time-domain" in t.loc[q, "note"]
    assert res.lco_onset_tcr is None and res.lco_curve_tcr == []
    assert t.loc["lambda_F at T_cr (LSA)", "hypate"] == res.lambda_tcr
    main(["--coarse"])
    out = capsys.readouterr().out
    assert "5 of 5 compared values match" in out and "time-domain rows not run" in out


@pytest.mark.slow
def test_flutter_time_domain_rows_report_the_s2_runs() -> None:
    # 6 S2 runs on the 8 x 8 mesh, ~4 min
    import dataclasses

    from hypate.studies.scripts.ch7_flutter import Config, run

    res = run(dataclasses.replace(Config.coarse(), time_domain=True))
    t = res.table.set_index("quantity")
    for q, onset, lsa, ref in (("lambda_F at T_cr (time domain)", res.lco_onset_tcr,
                                res.lambda_tcr, 344.0),
                               ("lambda_F at 2 T_cr (time domain)", res.lco_onset_2tcr,
                                res.lambda_2tcr, 191.1)):
        assert t.loc[q, "hypate"] == onset and onset != lsa  # what the S2 runs measured
        # the Hopf-fit onset agrees with the LSA within 2 % (issue 6) and so with Sec. 7.2.3
        assert onset == pytest.approx(lsa, rel=0.02) and onset == pytest.approx(ref, rel=0.03)
    assert len(res.lco_curve_tcr) == 3 and all(a > 0.03 for _, a in res.lco_curve_tcr)


def test_benchmark_tc_coarse() -> None:
    from hypate.studies.scripts.ch7_benchmark import Config, run

    res = run(Config.coarse())
    # Sec. 7.3: dissertation onset 2.02 s; TC dt = 0.1 s measured 2.0 s
    assert res.tc_type == "divergence"
    assert 1.8 <= res.tc_onset <= 2.4
    assert res.tc_peak > 2.0  # several thicknesses into the flow before the snap


def test_table_9_3() -> None:
    from hypate.studies.scripts.ch9_table9_3 import NAMES, PROTOTYPE, Config, run

    res = run(Config.coarse())
    # Table 9.3 prototype row within 0.1 % (measured 0, -0.065 %, -0.021 %)
    for n in NAMES:
        assert res.prototype[n] == pytest.approx(PROTOTYPE[n], rel=1e-3), n
    # the analytical (Eq. 9.2) models reproduce the prototype exactly
    for xi, m in res.analytical.items():
        for n in NAMES:
            assert m[n] == pytest.approx(res.prototype[n], rel=1e-12), (xi, n)


def test_ch8_trends_coarse() -> None:
    from hypate.studies.scripts.ch8_effects import Config, run

    res = run(Config.coarse())
    # (a) Table 8.2 AM: onsets 1.98, 2.04, 2.26 s for L_le/a = 0.5, 1.5, 7 -- delayed by a
    # thicker boundary layer; each within 5 % (measured 2.0, 2.1, 2.3 s at dt = 0.1 s)
    assert res.onset_delayed_by_thicker_bl
    for L, ref in ((0.5, 1.98), (1.5, 2.04), (7.0, 2.26)):
        assert res.onset_pt[L] == pytest.approx(ref, rel=0.05)
    # (b) Sec. 8.2: the 2D panel snaps within 2.5 s, the 3D panel stays stable to 5 s
    assert res.onset_2d is not None and res.onset_2d <= 2.5
    assert res.stable_3d
    # (c) Sec. 8.3: a larger flow angle fails more area (Fig. 8.23: > 35 % at 30 deg)
    s0, s30 = res.sec8_3["R12=1", 0.0], res.sec8_3["R12=1", 30.0]
    assert s30["final_failed_percent"] > s0["final_failed_percent"]
    # every row with a published and a measured value is judged; the footer counts them
    t = res.table
    judged = [m for d, h, m in zip(t["dissertation"], t["hypate"], t["matches"])
              if d is not None and h is not None]
    assert judged and all(m is not None for m in judged)
    from hypate.studies.scripts.comparison import mismatches, summary

    assert summary(t).startswith(f"{len(judged) - len(mismatches(t))} of {len(judged)} ")


def _fake_run_dir(path: Path, study: str, design: dict, objectives: dict) -> Path:
    path.mkdir(parents=True)
    (path / "design_point.json").write_text(json.dumps(
        {"study": study, "xi": 3.0, "design": design, "objectives": objectives,
         "similarity": [], "active_constraints": ["L_le=upper"]}))
    return path


def test_ch9_tables_reads_run_directories(tmp_path) -> None:
    from hypate.studies.scripts.ch9_tables import TABLE_9_8, Config, run

    ref = TABLE_9_8["xi3"]
    design = {**ref, "p0": ref["p0"] * 1e6}  # run directories hold p0 in Pa
    d = _fake_run_dir(tmp_path / "xi3", "sec9_2_2_xi3", design, {"J_u": 0.05, "J_T": 0.04})
    env = tmp_path / "env"
    env.mkdir()
    (env / "sweep.csv").write_text("label,xi,mach,altitude,status,J_s\n"
                                   "M6_H22km,2.0,6.0,22000.0,done,0.015\n")
    res = run(Config(run_dirs=(str(d), str(env))))
    t = res.table.set_index("quantity")
    assert t.loc["Table 9.8 xi3 p0 (MPa)", "difference"] == pytest.approx(0.0, abs=1e-9)
    assert t.loc["Table 9.8 xi3 J_u at the design point (%)", "hypate"] == pytest.approx(5.0)
    assert res.envelope_errors[6.0, 22.0] == pytest.approx(1.5)
    assert math.isclose(t.loc["Table 9.11 error at M = 6, H = 22 km (%)", "difference"], 0.0,
                        abs_tol=1e-9)


def test_envelope_trend_rows_hold_on_table_9_11_itself_and_see_a_flat_envelope() -> None:
    # The oracle is the published table: Sec. 9.2.4's text says the errors exceed 5 % at
    # high Mach / low altitude and at low Mach / high altitude, and Table 9.11's own
    # values put both regions above its mean (5.69 and 6.79 % against 4.04 %).
    from hypate.studies.scripts.ch9_tables import (
        ALTITUDES_KM,
        HIGH_ERROR_REGIONS,
        TABLE_9_11,
        envelope_trend_rows,
    )

    table = {(m, h): v[i] for m, v in TABLE_9_11.items() for i, h in enumerate(ALTITUDES_KM)}
    rows = envelope_trend_rows(table)
    assert len(rows) == len(HIGH_ERROR_REGIONS) and all(r[2] is True for r in rows)
    assert "6.8 % against 4.0 %" in rows[1][3]
    flat = dict.fromkeys(table, 3.0)
    assert all(r[2] is False for r in envelope_trend_rows(flat))
    del table[5.0, 30.0]  # a region with a cell missing gives no row
    assert len(envelope_trend_rows(table)) == 1 and envelope_trend_rows({}) == []


def test_published_rows_measure_how_far_the_design_point_beats_the_published_design() -> None:
    from hypate.studies.scripts.ch9_tables import published_rows
    from hypate.studies.scripts.comparison import side_by_side

    published = {"objectives": {"J_u": 0.30, "J_T": 0.20, "J_s": 0.36},
                 "constraints": {"bounds": [{"name": "p0", "state": "below lower"},
                                            {"name": "h", "state": "inside"}],
                                 "equalities": [{"name": "T_inf", "residual": 0.075,
                                                 "satisfied": False}]}}
    dp = {"objectives": {"J_u": 0.12, "J_T": 0.13}}
    t = side_by_side(published_rows("9.10", "wt7", published, dp)).set_index("quantity")
    evaluated, beats = t.index
    assert t.loc[evaluated, "hypate"] == pytest.approx(30.0)
    assert "p0 below lower" in t.loc[evaluated, "note"] and "T_inf" in t.loc[evaluated, "note"]
    assert t.loc[beats, "hypate"] == pytest.approx(30.0 - 13.0) and bool(t.loc[beats, "matches"])
    worse = side_by_side(published_rows("9.10", "wt7", published,
                                        {"objectives": {"J_u": 0.31, "J_T": 0.1}}))
    assert not bool(worse.set_index("quantity").loc[beats, "matches"])
    failed = {"objectives": {"J_u": None, "J_T": None, "J_s": None}, "message": "boom"}
    rows = published_rows("9.10", "wt7", failed, dp)
    assert math.isnan(rows[0][2]) and math.isnan(rows[1][2]) and "boom" in rows[0][3]


def test_published_table_9_10_wt7_design_is_far_from_table_9_11_in_hypates_model() -> None:
    # The premise of ch9_tables.FINDING_SEC9_2_MODEL: the dissertation's WT7 Case 2 design
    # (Table 9.10) at the flight condition where Table 9.11 gives 4.52 % is evaluated by
    # hypate's pt-bl + Eckert model at J_s far above it (measured 36.0 %: J_u 28.8 %,
    # J_T 21.5 %); asserted at 4 x 4.52 %, so a heating model that reproduced the
    # dissertation's optimum would fail here and the finding would need revisiting.
    from hypate.studies.scripts.ch9_runs import published_design_errors
    from hypate.studies.scripts.ch9_tables import TABLE_9_10, TABLE_9_11, published_design

    assert published_design("9.10", "wt7")["p0"] == pytest.approx(
        TABLE_9_10["wt7"]["p0"] * 1e6)
    res = published_design_errors("9.10", "wt7")
    assert res["study"] == "sec9_2_3_case2_wt7" and res["status"] == "ok"
    assert res["design"]["T_rad"] == pytest.approx(1548.0)
    assert 100.0 * res["objectives"]["J_s"] > 4.0 * TABLE_9_11[6.0][2]


@pytest.mark.slow
def test_ch9_tables_on_a_quickstart_run(tmp_path) -> None:
    # `hypate run` on the shipped quick study (~20-45 s), shown next to Table 9.8 xi = 4
    from hypate.studies.scripts.ch9_tables import Config, run

    out = tmp_path / "qs"
    subprocess.run([sys.executable, "-m", "hypate.scaling.cli.main", "run",
                    str(REPO / "scaling" / "data" / "quickstart.toml"), "--out", str(out)],
                   cwd=REPO, check=True, capture_output=True, timeout=900)
    res = run(Config(run_dirs=(str(out),), assign=(f"{out}=9.8:xi4",)))
    t = res.table.set_index("quantity")
    assert 5.0 <= t.loc["Table 9.8 xi4 M", "hypate"] <= 7.0
    assert 1e-3 <= t.loc["Table 9.8 xi4 h", "hypate"] <= 1e-2


@pytest.mark.slow
def test_material_choice_compares_the_material_study_with_each_fixed_one(tmp_path) -> None:
    """Coarse: the summary's ratio is the material study's max(J) over the best fixed
    study's, the evaluation counts are the runs' own (3 classical seeds + 6 + 6 against
    3 x (1 + 6 + 4)), and a second call reads the finished runs without simulating."""
    from hypate.studies.scripts.material_choice import Config, run

    config = Config(out=str(tmp_path), coarse_run=True)
    res = run(config)
    table, summary = res.table, res.summary.iloc[0]
    assert list(table["study"]) == ["material", "fixed_ti6242", "fixed_inconel718",
                                    "fixed_al7075"]
    assert list(table["evaluations"]) == [15, 11, 11, 11]
    fixed = table[table["study"] != "material"]
    assert summary["ratio"] == pytest.approx(table["max_J"].iloc[0] / fixed["max_J"].min(),
                                             rel=1e-12)
    assert summary["fewer evaluations"]
    again = run(config)
    assert again.table.equals(table)
