"""hypate.scaling.report.figures: PNGs written, embedded, and figures closed afterwards."""
from __future__ import annotations

import base64
import re
from collections.abc import Callable
from pathlib import Path

import matplotlib.pyplot as plt
from hypate.scaling.report.figures import (
    embed_png,
    figure_html,
    history_figure,
    pareto_figure,
    plot_sweep,
    response_figure,
    variable_unit,
)
from hypate.scaling.report.rundata import RunData

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _embedded(fragment: str) -> bytes:
    """The bytes of the one ``data:image/png`` image in an HTML fragment."""
    (b64,) = re.findall(r'src="data:image/png;base64,([^"]*)"', fragment)
    return base64.b64decode(b64, validate=True)


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
