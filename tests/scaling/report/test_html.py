"""hypate.scaling.report.html and `hypate report`: the self-contained page of a real tiny run
(the ``tiny_run`` fixture of this folder's conftest.py)."""
from __future__ import annotations

import base64
import json
import re
import shutil
import subprocess
from pathlib import Path

import pandas as pd
import pytest
from conftest import chromium, forget_study_file
from hypate.scaling.cli.main import main
from hypate.scaling.report.figures import MISMATCH_THRESHOLD
from hypate.scaling.report.html import (
    register_section,
    render_html,
    unregister_section,
    write_report,
    write_report_safely,
)
from hypate.scaling.report.rundata import RunData
from hypate.scaling.report.sections import Section

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
SECTIONS = ("Study", "Design point", "Similarity parameters", "Figures", "Run statistics")


def _check_self_contained(page: str) -> list[bytes]:
    """Every <img> is an embedded PNG; nothing refers outside the page."""
    assert page.startswith("<!DOCTYPE html>")
    assert not re.search(r"""(src|href)\s*=\s*["']?(https?:|//|file:)""", page, re.I)
    assert "http://" not in page and "https://" not in page
    assert "<script" not in page.lower()
    srcs = re.findall(r"<img[^>]*\ssrc=\"([^\"]*)\"", page)
    pngs = []
    for src in srcs:
        assert src.startswith("data:image/png;base64,"), src[:40]
        data = base64.b64decode(src.split(",", 1)[1], validate=True)
        assert data.startswith(PNG_MAGIC)
        pngs.append(data)
    for href in re.findall(r"href=\"([^\"]*)\"", page):
        assert href.startswith(("#", "data:")), href
    return pngs


def test_report_of_finished_run(tiny_run: tuple[Path, Path]) -> None:
    out, study = tiny_run
    path = write_report(out, study_path=study)
    assert path == out / "report.html"
    page = path.read_text(encoding="utf-8")
    pngs = _check_self_contained(page)
    assert len(pngs) >= 3  # Pareto front, hypervolume history, response
    for title in SECTIONS:
        assert f"<h2>{title}</h2>" in page, title
    for name in ("pareto_front", "hypervolume_history", "response"):
        assert (out / "figures" / f"{name}.png").read_bytes().startswith(PNG_MAGIC)
    point = json.loads((out / "design_point.json").read_text())
    for name, value in point["design"].items():  # design values as shown (4 significant)
        assert f"<td>{name}</td>" in page
        assert f"<td>{value:.4g}</td>" in page, (name, value)
    for name, value in point["objectives"].items():
        assert f"{100 * value:.3g} %" in page
    for rec in point["similarity"]:
        assert f"<td>{rec['name']}</td>" in page
    n_bad = sum(1 for r in point["similarity"] if r["relative_difference"] is not None
                and abs(r["relative_difference"]) > MISMATCH_THRESHOLD)
    assert page.count('<tr class="mismatch">') == n_bad
    assert "tiny" in page and "ideal" in page  # study name, tunnel


def test_report_ids_are_the_csv_ids(tiny_run: tuple[Path, Path]) -> None:
    """evaluations.csv starts with the id column; the id the report cites for the design
    point is the CSV row holding its objectives; the rule is stated and recorded."""
    out, study = tiny_run
    page = write_report(out, study_path=study).read_text(encoding="utf-8")
    csv = pd.read_csv(out / "evaluations.csv")
    assert csv.columns[0] == "id" and csv["id"].tolist() == list(range(len(csv)))
    point = json.loads((out / "design_point.json").read_text())
    assert point["rule"] == "minmax"
    row = csv.loc[csv["id"] == point["evaluation"]].iloc[0]
    assert {o: row[o] for o in point["objectives"]} == pytest.approx(point["objectives"])
    assert f"Selection rule.</strong> The design point (evaluation {point['evaluation']}," \
        in page
    marked = page.split('<tr class="design">')[1].split("</tr>")[0]
    assert marked.startswith(f"<td>{point['evaluation']}</td>")


def test_extra_and_registered_sections(tiny_run: tuple[Path, Path]) -> None:
    out, study = tiny_run

    def laws(run: RunData) -> Section:
        assert run.study is not None and run.variables == ["M", "p0", "T0", "h"]
        return Section("Scaling laws", "<p>laws here</p>")

    def broken(run: RunData) -> Section:
        raise ValueError("boom")

    register_section("test_laws", laws)
    register_section("test_broken", broken)
    try:
        with pytest.warns(RuntimeWarning, match="boom"):
            page = write_report(out, study_path=study,
                                       extra_sections=[("Notes <x>", "<p>static</p>")]
                                       ).read_text()
    finally:
        unregister_section("test_laws")
        unregister_section("test_broken")
    assert page.index("<h2>Scaling laws</h2>") > page.index("<h2>Run statistics</h2>")
    assert "<h2>Notes &lt;x&gt;</h2>" in page and "<p>static</p>" in page
    assert "This section failed" in page and "boom" in page


def test_report_of_interrupted_run(tiny_run: tuple[Path, Path], tmp_path: Path) -> None:
    out, study = tiny_run
    run = tmp_path / "killed"
    shutil.copytree(out, run)
    for name in ("design_point.json", "design_point.npz", "evaluations.csv", "pareto.csv",
                 "report.html"):
        (run / name).unlink(missing_ok=True)
    shutil.rmtree(run / "figures", ignore_errors=True)
    # without the study file (moved since): degrade gracefully, from the store alone
    forget_study_file(run)
    assert main(["report", str(run)]) == 0
    page = (run / "report.html").read_text()
    _check_self_contained(page)
    assert "interrupted run" in page and "study file unknown" in page
    for title in SECTIONS:
        assert f"<h2>{title}</h2>" in page
    # with the study file: the variable names and the rebuilt similarity table
    assert main(["report", str(run), "--study", str(study)]) == 0
    page = (run / "report.html").read_text()
    _check_self_contained(page)
    assert "<td>lambda_F</td>" in page and "<td>p0</td>" in page


def test_report_errors(tmp_path: Path, tiny_run: tuple[Path, Path], capsys) -> None:
    assert main(["report", str(tmp_path)]) == 2
    assert "not a run directory" in capsys.readouterr().err
    assert main(["report", str(tmp_path / "missing")]) == 2
    out, _ = tiny_run
    assert main(["report", str(out), "--study", str(tmp_path / "nope.toml")]) == 2
    assert "--study" in capsys.readouterr().err


@pytest.mark.skipif(chromium() is None, reason="no chromium/google-chrome binary installed")
def test_report_renders_in_headless_chromium(tiny_run: tuple[Path, Path], tmp_path: Path
                                             ) -> None:
    """The page loads with every image decoded and no console error."""
    out, study = tiny_run
    page = write_report(out, study_path=study)
    # A probe page: an <iframe> would need JS access; instead append a tiny script to a copy
    # that marks images which failed to decode, then read the DOM after load.
    probe = tmp_path / "probe.html"
    probe.write_text(page.read_text().replace(
        "</body>", "<script>window.addEventListener('load',()=>{const bad=[...document.images]"
        ".filter(i=>!(i.complete&&i.naturalWidth>0)).length;document.body.setAttribute("
        "'data-bad-images',String(bad));document.body.setAttribute('data-images',"
        "String(document.images.length));});</script></body>"))
    cmd = [chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
           "--enable-logging=stderr", "--v=0", "--virtual-time-budget=5000",
           "--user-data-dir=" + str(tmp_path / "profile"), "--dump-dom", probe.as_uri()]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=90)
    assert proc.returncode == 0, proc.stderr[-2000:]
    dom = proc.stdout
    assert 'data-bad-images="0"' in dom, dom[-500:]
    n = int(re.search(r'data-images="(\d+)"', dom).group(1))
    assert n >= 3
    # chromium logs every console message as "...:CONSOLE:<line>] ..." (the level is not
    # shown); the page itself has no script and the probe logs nothing, so any is an error
    console = [line for line in proc.stderr.splitlines() if ":CONSOLE" in line]
    assert not console, console
    # the original page (no script) loads too
    proc = subprocess.run(cmd[:-1] + [page.as_uri()], capture_output=True, text=True, timeout=90)
    assert proc.returncode == 0 and "<h2>Design point</h2>" in proc.stdout


def test_render_html_anchors_and_notes(tmp_path: Path) -> None:
    """Sections of one title get distinct anchors; notes and titles are escaped."""
    run = RunData(directory=tmp_path, notes=["a <note>"])
    page = render_html(run, [Section("Same", "<p>1</p>"), Section("Same", "<p>2</p>"),
                             Section("<b>", ""), Section("?!", "")])
    assert '<section id="same">' in page and '<section id="same-2">' in page
    assert '<section id="b">' in page
    assert '<section id="section">' in page  # a title without letters or digits
    assert "<li>a &lt;note&gt;</li>" in page and "<h2>&lt;b&gt;</h2>" in page
    assert "interrupted run" in page  # no design_point.json in tmp_path


def test_write_report_safely_warns_instead_of_raising(tmp_path: Path) -> None:
    with pytest.warns(RuntimeWarning, match="not a run directory"):
        assert write_report_safely(tmp_path) is None
