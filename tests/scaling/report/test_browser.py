"""The quick-start's report (the study at a shorter budget) in a real browser: headless
Chromium at 1400 px page width shows every figure whole (no image wider than the viewport,
no horizontal overflow), and every figure's labels stay inside its axes (matplotlib side).
The browser test skips only when no Chromium binary exists (``.ci/run`` installs one)."""
from __future__ import annotations

import re
import subprocess
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import pytest
from conftest import REPO, chromium
from hypate.scaling.cli.main import main
from hypate.scaling.report import figures
from hypate.scaling.report.figures import fit_labels, label_overflows
from hypate.scaling.report.rundata import load_run

#: The page width the report must fit (the brief's 1400 px), and the window height.
WIDTH, HEIGHT = 1400, 3000
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"

#: Written into the DOM after load: each <img>'s natural width, its box (with the border)
#: and its rendered content width (``clientWidth``, without the border), and the
#: page's scroll width (``--dump-dom`` then prints it). Closed <details> are opened first,
#: so the Pareto figure's "all evaluations" view is measured too.
PROBE = """<script>
window.addEventListener('load', function () {
  document.querySelectorAll('details').forEach(function (d) { d.open = true; });
  var rows = [];
  document.querySelectorAll('img').forEach(function (img) {
    var r = img.getBoundingClientRect();
    rows.push([img.naturalWidth, r.left, r.right, img.clientWidth].join(','));
  });
  var pre = document.createElement('pre');
  pre.textContent = 'PROBE ' + window.innerWidth + ' '
    + document.documentElement.scrollWidth + ' ' + rows.join(';') + ' END';
  document.body.appendChild(pre);
});
</script>"""


def _browser(page: Path, *args: str) -> str:
    """Run headless Chromium on ``page`` at WIDTH x HEIGHT; its stdout."""
    binary = chromium()
    if binary is None:  # only reached from a test that skips without one
        raise RuntimeError("no chromium binary")
    with tempfile.TemporaryDirectory() as profile:
        done = subprocess.run(
            [binary, "--headless", "--no-sandbox", "--disable-gpu",
             "--disable-background-networking", "--disable-component-update",
             "--disable-sync", "--no-first-run", f"--user-data-dir={profile}",
             f"--window-size={WIDTH},{HEIGHT}", "--virtual-time-budget=5000", *args,
             page.as_uri()], capture_output=True, text=True, timeout=180, check=False)
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout


#: The quick-start's budget cut for the page check: the same study, report, figures and
#: tables in about 10 s instead of about 50 (``hypate run`` of the full default is the
#: README study example's test, tests/scaling/api/test_readme_python.py).
SHORTER = (("iterations = 20", "iterations = 4"), ("polish = 12", "polish = 0"))


@pytest.fixture(scope="module")
def quickstart_report(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The quick-start study at a shorter budget (``hypate run STUDY --out DIR``) and its
    report."""
    data = REPO / "scaling" / "data"
    text = (data / "quickstart.toml").read_text(encoding="utf-8")
    for old, new in (('case = "cases/', f'case = "{data / "cases"}/'), *SHORTER):
        assert old in text, f"the quick-start no longer says {old!r}"
        text = text.replace(old, new)
    root = tmp_path_factory.mktemp("quickstart")
    (root / "quickstart.toml").write_text(text, encoding="utf-8")
    out = root / "run"
    assert main(["run", str(root / "quickstart.toml"), "--out", str(out), "-q"]) == 0
    return out


@pytest.mark.skipif(chromium() is None, reason="no chromium binary")
def test_quickstart_report_fits_1400_px(quickstart_report: Path, tmp_path: Path) -> None:
    page = (quickstart_report / "report.html").read_text(encoding="utf-8")
    probe = tmp_path / "probe.html"
    probe.write_text(page.replace("</body>", PROBE + "</body>"), encoding="utf-8")
    found = re.search(r"PROBE (\d+) (\d+) (.*?) END", _browser(probe, "--dump-dom"))
    assert found, "the probe script did not run"
    viewport, scroll = int(found.group(1)), int(found.group(2))
    images = [[float(v) for v in row.split(",")] for row in found.group(3).split(";")]
    assert scroll <= viewport <= WIDTH  # no horizontal overflow of the page
    assert len(images) >= 3  # Pareto (log axes, every evaluation), hypervolume history, response
    for natural, left, right, width in images:
        assert natural > 0  # decoded
        assert left >= 0 and right <= viewport  # the whole image is on the page
        # shown at its own size, or scaled down to fit: never cut by its container
        assert width <= natural + 0.5
    shot = tmp_path / "report_1400.png"
    _browser(quickstart_report / "report.html", f"--screenshot={shot}")
    assert shot.read_bytes().startswith(PNG_MAGIC)


def test_every_figure_label_fits_its_axes(tiny_run: tuple[Path, Path],
                                          monkeypatch: pytest.MonkeyPatch) -> None:
    """Every figure the report embeds has its axis labels and titles inside its axes."""
    out, study = tiny_run
    run = load_run(out, study_path=study)
    overflows: dict[str, list[str]] = {}
    embed = figures.figure_html

    def checked(fig, run_, name, caption):  # noqa: ANN001 - figure_html's signature
        overflows[name] = label_overflows(fit_labels(fig))
        return embed(fig, run_, name, caption)

    monkeypatch.setattr(figures, "figure_html", checked)
    for make in (figures.pareto_figure, figures.history_figure, figures.response_figure):
        make(run)
    assert {"pareto_front", "hypervolume_history", "response"} <= set(overflows)
    assert all(not v for v in overflows.values()), overflows


def test_fit_labels_wraps_a_label_longer_than_its_axes() -> None:
    fig, ax = plt.subplots(figsize=(4.0, 2.0))
    ax.set_ylabel("mean temperature / stagnation temperature  T/T0 of the panel")
    assert label_overflows(fig)  # the response figure's old thermal label did this
    fit_labels(fig)
    assert not label_overflows(fig) and "\n" in ax.get_ylabel()
    plt.close(fig)
