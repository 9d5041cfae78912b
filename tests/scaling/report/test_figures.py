"""hypate.scaling.report.figures: PNGs written, embedded, and figures closed afterwards."""
from __future__ import annotations

import base64
import json
import re
from collections.abc import Callable
from pathlib import Path

import hypate.scaling.report.figures as pareto_mod
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pytest
from conftest import tiny_study_text
from hypate.scaling.cli.main import main
from hypate.scaling.report.figures import (
    embed_png,
    figure_html,
    history_figure,
    log_limits,
    pareto_figure,
    plot_sweep,
    response_figure,
    variable_unit,
)
from hypate.scaling.report.rundata import RunData

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _embedded(fragment: str, count: int = 1) -> bytes:
    """The bytes of the first ``data:image/png`` image in an HTML fragment that holds
    ``count`` of them."""
    found = re.findall(r'src="data:image/png;base64,([^"]*)"', fragment)
    assert len(found) == count
    return base64.b64decode(found[0], validate=True)


def test_embed_png_round_trip(tmp_path: Path) -> None:
    data = PNG_MAGIC + b"rest"
    tag = embed_png(data, 'a "quoted" <alt>')
    assert _embedded(tag) == data
    assert 'alt="a &quot;quoted&quot; &lt;alt&gt;"' in tag
    path = tmp_path / "x.png"
    path.write_bytes(data)
    assert embed_png(path, "x") == embed_png(data, "x")


def test_figure_html_saves_embeds_and_closes(tmp_path: Path) -> None:
    fig, ax = plt.subplots()
    ax.plot([0, 1], [1, 0])
    part = figure_html(fig, RunData(directory=tmp_path), "line", "a <line>")
    png = (tmp_path / "figures" / "line.png").read_bytes()
    assert png.startswith(PNG_MAGIC) and _embedded(part) == png
    assert "<figcaption>a &lt;line&gt;</figcaption>" in part
    assert not plt.get_fignums()


def test_run_figures_of_two_objectives(fabricated_run: Callable[..., RunData]) -> None:
    run = fabricated_run()
    for make, name in ((pareto_figure, "pareto_front"), (history_figure, "hypervolume_history")):
        part = make(run)
        assert _embedded(part) == run.figure_path(name).read_bytes()
    assert response_figure(run) == ""  # no response in the run
    assert not plt.get_fignums()


def test_pareto_figure_draws_every_evaluation_where_it_is(
        fabricated_run: Callable[..., RunData], monkeypatch: pytest.MonkeyPatch) -> None:
    """No clipping to an edge: an evaluation at 4000 % sits at its own coordinates on the
    log axes, and inadmissible evaluations are drawn apart (issue 40)."""
    run = fabricated_run()
    run.evaluations.loc[len(run.evaluations)] = run.evaluations.iloc[0]
    run.evaluations.loc[len(run.evaluations) - 1, ["J_u", "J_T"]] = [40.0, 30.0]  # 4000 %
    run.evaluations["admissible"] = True
    run.evaluations.loc[len(run.evaluations) - 1, "admissible"] = False
    drawn: list = []
    original = pareto_mod._pareto_plot

    def spy(run_, F):
        fig = original(run_, F)
        drawn.append(fig)
        return fig

    monkeypatch.setattr(pareto_mod, "_pareto_plot", spy)
    part = pareto_figure(run)
    assert "1 inadmissible: grey crosses" in part and "<details" not in part
    assert _embedded(part) == run.figure_path("pareto_front").read_bytes()
    ax = drawn[0].axes[0]
    assert ax.get_xscale() == "log" and ax.get_yscale() == "log"
    points = np.vstack([c.get_offsets() for c in ax.collections if len(c.get_offsets())])
    F = 100.0 * run.ok[["J_u", "J_T"]].to_numpy(float)
    for f in F:  # every successful evaluation at its true coordinates
        assert np.any(np.all(np.isclose(points, f), axis=1)), f
    lo, hi = ax.get_xlim()
    assert lo < F[:, 0].min() and hi > 4000.0
    crosses = [c for c in ax.collections if c.get_label().startswith("inadmissible")]
    np.testing.assert_allclose(crosses[0].get_offsets(), [[4000.0, 3000.0]])
    assert not plt.get_fignums()


def test_log_limits_hold_every_point_with_a_margin() -> None:
    lo, hi = log_limits(np.array([8.84]))  # one point: not degenerate, a decade around it
    assert lo < 8.84 < hi and np.log10(hi / lo) >= 1.0 - 1e-12
    lo, hi = log_limits(np.array([0.0, 5.0, 4000.0]))  # zero has no place on a log axis
    assert lo < 5.0 and hi > 4000.0


def test_run_figures_of_one_objective(fabricated_run: Callable[..., RunData]) -> None:
    run = fabricated_run(objectives=["J_u"])
    assert pareto_figure(run) == ""  # a front needs two objectives
    part = history_figure(run)
    assert _embedded(part) == run.figure_path("best_objective_history").read_bytes()
    assert "Best-J_u history" in part


def test_plot_sweep(tmp_path: Path) -> None:
    rows = [{"value": v, "status": "ok", "J_u": 0.1 * v, "J_T": 0.05, "J_s": None}
            for v in (1.0, 2.0, 3.0)]
    rows.append({"value": 4.0, "status": "failed", "J_u": None, "J_T": None, "J_s": None})
    path = plot_sweep(rows, "h", tmp_path / "sweep.png", bounds=(1.5, 3.5))
    assert path == tmp_path / "sweep.png" and path.read_bytes().startswith(PNG_MAGIC)
    assert not plt.get_fignums()


def test_variable_unit() -> None:
    assert variable_unit("p0") == "Pa" and variable_unit("M") == "-"
    assert variable_unit("h[2]") == "m"  # a layer thickness takes the unit of h
    assert variable_unit("no_such_variable") == "-"


def test_a_tiny_schedule_study_runs_and_its_report_plots_the_schedule(
        tmp_path: Path, tiny_run: tuple[Path, Path]) -> None:
    # end to end: a tiny study with a 3-point heater schedule runs, names the control points
    # in evaluations.csv and design_point.json, and its report shows the schedule next to
    # the wall temperatures; the constant-heater tiny run's report has no such figure
    study = tmp_path / "schedule.toml"
    study.write_text(tiny_study_text(
        name="schedule", sections='T_rad = { schedule = 3, range = [300.0, 2500.0] }\n'))
    out = tmp_path / "run"
    assert main(["run", str(study), "--out", str(out)]) == 0
    names = ["T_rad[0]", "T_rad[1]", "T_rad[2]"]
    assert set(names) <= set(pd.read_csv(out / "evaluations.csv").columns)
    point = json.loads((out / "design_point.json").read_text())
    assert set(names) <= set(point["design"])
    page = (out / "report.html").read_text()
    assert (out / "figures" / "schedule.png").read_bytes().startswith(PNG_MAGIC)
    assert "Optimized radiant-heater temperature T_rad(t)" in page
    assert all(name in page for name in names)  # the study and design tables name them
    run_dir, _ = tiny_run
    assert not (run_dir / "figures" / "schedule.png").exists()
    assert "Optimized radiant-heater temperature" not in (run_dir / "report.html").read_text()
