"""Shared pytest fixtures."""
from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypate.solvers.aero.base import SurfacePoints, SurfaceState
from hypate.solvers.aero.rom.geometry import RomGeometry

REPO = Path(__file__).resolve().parents[1]
PROTOTYPE_CASE = REPO / "scaling" / "data" / "cases" / "sec9_2_prototype.toml"

#: A tiny quasi-steady scaling study (the Sec. 9.2 prototype on a coarse mesh, few steps):
#: one evaluation takes well under a second, a whole run a few seconds.
TINY_STUDY = """
[study]
name = "{name}"
kind = "quasi_steady"
objectives = ["J_u", "J_T"]
xi = {xi}

[prototype]
case = "{case}"

[simulation]
time_step = {time_step}
steps = {steps}
aero = "pt-bl"
mesh = [{mesh}, {mesh}]

[model]
material = "ti6242"

[tunnel]
name = "ideal"

[variables]
M = "tunnel"
p0 = "tunnel"
T0 = "tunnel"
h = [0.001, 0.01]
{sections}
[optimizer]
initial_samples = {initial}
iterations = {iterations}
seed = {seed}
{tail}"""


def tiny_study_text(name: str = "tiny", xi: float = 4.0, mesh: int = 2, steps: int = 4,
                    time_step: float = 40.0, initial: int = 4, iterations: int = 2,
                    seed: int = 3, sections: str = "", tail: str = "") -> str:
    """The tiny study as TOML text; ``sections`` go before [optimizer], ``tail`` after."""
    return TINY_STUDY.format(name=name, xi=xi, case=PROTOTYPE_CASE.as_posix(), mesh=mesh,
                             steps=steps, time_step=time_step, initial=initial,
                             iterations=iterations, seed=seed, sections=sections, tail=tail)


#: The tiny run of the prediction tests: 20 steps of 8 s (21 matched time points, so one
#: point outside a band is under 5 % of them); a run takes about 10 s.
PREDICTION_RUN = {"steps": 20, "time_step": 8.0, "initial": 3, "iterations": 1}


@pytest.fixture(scope="session")
def prediction_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished tiny run directory (``hypate run STUDY --out DIR -q``), shared by the
    prediction tests: read it, copy it before writing into it."""
    from hypate.scaling.cli.main import main

    root = tmp_path_factory.mktemp("prediction")
    study = root / "tiny_predict.toml"
    study.write_text(tiny_study_text(name="tiny_predict", **PREDICTION_RUN))
    assert main(["run", str(study), "--out", str(root / "run"), "-q"]) == 0
    return root / "run"


#: Names of a headless-capable browser binary, in the order they are looked for.
BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")


def chromium() -> str | None:
    """The path of a Chromium/Chrome binary, or None (the browser checks then skip)."""
    return next((p for p in map(shutil.which, BROWSERS) if p), None)


def stored_evaluations(store: Path) -> int:
    """Rows in a run's SQLite store, read-only (0 while it does not exist or is locked):
    polled by the kill-and-resume tests while the run writes."""
    import sqlite3
    from contextlib import closing

    if not store.exists():
        return 0
    try:  # closing: sqlite3's own context manager commits but leaves the connection open
        with closing(sqlite3.connect(f"file:{store}?mode=ro", uri=True, timeout=1.0)) as con:
            return int(con.execute("SELECT COUNT(*) FROM evaluations").fetchone()[0])
    except sqlite3.Error:
        return 0


def stored_campaign(run_dir: Path) -> list[tuple]:
    """A run's stored campaign: (iteration, batch_index, x, F, status) in slot order, NaN as
    None (so that equal campaigns compare equal): what a resumed run must reproduce."""
    from hypate.scaling.engine.store import EvaluationStore

    def values(a: np.ndarray) -> tuple:
        return tuple(float(v) if np.isfinite(v) else None for v in a)

    with EvaluationStore(run_dir / "evaluations.sqlite", read_only=True) as store:
        return sorted((r.iteration, r.batch_index, values(r.x), values(r.F), r.status)
                      for r in store.load())


def foreground_sigint() -> None:
    """``preexec_fn`` of a child that must take Ctrl-C: SIGINT at its default disposition
    and unblocked, as in a terminal's foreground job. Both are inherited across exec, and a
    pytest-xdist worker's children get SIGINT ignored (a background job's convention, which
    hypate keeps): without this a SIGINT test passes serially and fails under -n."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


def kill_after(proc, store: Path, rows: int, timeout: float = 300.0) -> None:
    """SIGKILL ``proc`` (a ``hypate run`` subprocess) once ``store`` holds ``rows``
    evaluations; fails the test if the run finished first."""
    import os
    import signal
    import time

    deadline = time.monotonic() + timeout
    while stored_evaluations(store) < rows and proc.poll() is None \
            and time.monotonic() < deadline:
        time.sleep(0.02)
    if proc.poll() is not None:
        pytest.fail("the run finished before it could be killed; enlarge it")
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait(timeout=30)


def _richardson_parts(f: Callable[[float], np.ndarray], h: float
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(R, |R - R(h/2)|, eps_f)`` of :func:`richardson_derivative` (eps_f in units of
    ``f``)."""
    y = {s: np.asarray(f(s)) for s in (0.0, h, -h, h / 2, -h / 2, h / 4, -h / 4)}
    d = [(y[s] - y[-s]) / (2.0 * s) for s in (h, h / 2, h / 4)]
    R, R_half = (4.0 * d[1] - d[0]) / 3.0, (4.0 * d[2] - d[1]) / 3.0
    # noise samples: the 4th difference at spacing h/4 (its smooth part h^4 f''''/256 is
    # below R's truncation; noise std sqrt(70) sigma), 2nd differences at tiny steps (std
    # sqrt(6) sigma, but rounding there can correlate with f(0)'s), 4 ulp of f(0)
    quartic = y[h / 2] - 4.0 * y[h / 4] + 6.0 * y[0.0] - 4.0 * y[-h / 4] + y[-h / 2]
    tiny = [np.asarray(f(s)) - 2.0 * y[0.0] + np.asarray(f(-s)) for s in (h / 1024, h / 2048)]
    eps_f = np.maximum.reduce([np.abs(quartic) / 3.0, *map(np.abs, tiny),
                               4.0 * np.finfo(float).eps * np.abs(y[0.0])])
    return R, np.abs(R - R_half), eps_f


def richardson_derivative(f: Callable[[float], np.ndarray], h: float
                          ) -> tuple[np.ndarray, np.ndarray]:
    """Derivative of ``f`` at 0 by Richardson-extrapolated central differences, with an
    error bound measured on this machine.

    ``D(h) = (f(h) - f(-h)) / 2h`` carries a truncation error ``h^2 f'''(0)/6 + O(h^4)`` and a
    rounding error ``~ eps_f / h``, where ``eps_f`` is the noise of ``f`` itself (a GP
    prediction solves with its Cholesky factor, so it sits far above machine epsilon and
    depends on the BLAS kernels). ``R = (4 D(h/2) - D(h)) / 3`` cancels the h^2 term; the
    bound is the sum of

    * ``|R - R(h/2)|``, R at half the steps: R's O(h^4) truncation (15/16 of it) plus a
      sample of the rounding of both;
    * ``6 eps_f / h``: R's rounding is at most ``(4 * 2 + 1) / 3 = 3`` times the largest
      rounding of one evaluation of ``f`` over h, taken as twice the measured noise
      ``eps_f``: the largest of a 4th difference at spacing h/4 (smooth part
      ``h^4 f''''/256``, below R's truncation), 2nd differences at the tiny steps
      ``h / 2^10, h / 2^11`` and four units in the last place of ``f(0)``;
    * four units in the last place of R (the extrapolation's own arithmetic).

    Returns ``(R, bound)`` of the shape of ``f(0)``: a test asserts ``|analytic - R| <=
    safety * bound`` (:func:`assert_matches_richardson`), so its tolerance is the difference
    formula's own error on this machine, not a hand-picked number that a BLAS kernel can
    flip; a wrong derivative (a missing chain-rule factor, a sign) is off by O(|f'|), many
    orders of magnitude above the bound, and fails.
    """
    R, sample, eps_f = _richardson_parts(f, h)
    return R, sample + 6.0 * eps_f / h + 4.0 * np.finfo(float).eps * np.abs(R)


def richardson_jacobian(f: Callable[[np.ndarray], np.ndarray], x: np.ndarray,
                        h: float | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Jacobian ``df/dx`` at ``x``, column by column as :func:`richardson_derivative`.

    The noise ``eps_f`` of an output component is a property of that component, not of the
    input perturbed: each row's samples are pooled (their largest, divided by each
    column's step), so one sample that happens to be small does not make a tolerance.

    Parameters
    ----------
    f : callable
        ``f(x) -> ndarray of shape (m,)``.
    x : ndarray of shape (n,)
    h : float or ndarray of shape (n,)
        Step of each column.

    Returns
    -------
    J, bound : ndarray of shape (m, n)
    """
    x = np.asarray(x, float)
    steps = np.broadcast_to(np.asarray(h, float), x.shape)
    parts = [_richardson_parts(lambda t, e=e: f(x + t * e), float(hj))
             for e, hj in zip(np.eye(x.size), steps)]
    J, sample, eps_f = (np.stack([p[k] for p in parts], axis=1) for k in range(3))
    rounding = 6.0 * eps_f.max(axis=1, keepdims=True) / steps[None, :]
    return J, sample + rounding + 4.0 * np.finfo(float).eps * np.abs(J)


@pytest.fixture
def repo_root() -> Path:
    return REPO


@pytest.fixture
def tiny_study(tmp_path: Path) -> Callable[..., Path]:
    """Factory writing a tiny study file: ``tiny_study(text=None, **options) -> Path``."""

    def write(text: str | None = None, filename: str = "tiny.toml", **options) -> Path:
        path = tmp_path / filename
        path.write_text(text if text is not None else tiny_study_text(**options))
        return path

    return write


#: A small 2-D fluid ROM (three modes, 33 points, 50 samples): built in about a second.
SMALL_ROM = {
    "panel": {"kind": "2d", "length": 1.0, "leading_edge_length": 1.0, "thickness": 0.0025},
    "grid": {"n_x": 33},
    "reference": {"mach": 6.0, "altitude": 25000.0},
    "modes": [{"m": 1, "range": [-6.0, 6.0]}, {"m": 2, "range": [-2.0, 2.0]},
              {"m": 3, "range": [-2.0, 2.0]}],
    "wall_temperature": {"range": [200.0, 900.0]},
    "training": {"samples": 50, "seed": 3, "restarts": 0, "optimized_modes": 2},
}


def toml_text(data: dict[str, Any]) -> str:
    """``data`` (tables of scalars, lists of scalars, sub-tables and lists of tables, as
    :data:`SMALL_ROM`) as TOML text, for the commands that read a file."""

    def value(v: object) -> str:
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(value(x) for x in v) + "]"
        return repr(v)

    def table(name: str, body: dict[str, Any], header: str) -> list[str]:
        lines = [header] if header else []
        nested = []
        for k, v in body.items():
            if isinstance(v, dict):
                nested += table(f"{name}{k}.", v, f"[{name}{k}]")
            elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
                for item in v:
                    nested += table(f"{name}{k}.", item, f"[[{name}{k}]]")
            else:
                lines.append(f"{k} = {value(v)}")
        return lines + nested

    return "\n".join(table("", data, "")) + "\n"


#: The Sec. 7.1 ROM build file (Table 7.1).
ROM_STUDY = REPO / "studies" / "rom" / "rom_2d_panel.toml"


def rom_state(geom: RomGeometry, scale: float, amplitudes, nonuniform: bool = True,
              velocity: float = 0.0) -> tuple[SurfacePoints, SurfaceState]:
    """Surface points of ``geom`` at ``scale`` and a wall state: modal ``amplitudes``, a
    non-uniform (or uniform 550 K) wall temperature, a sine-shaped normal velocity."""
    pts = geom.points(scale)
    w, ws = geom.deformation(np.asarray(amplitudes, float)[None, :], scale)
    xr = pts.x * scale
    T = (450.0 + 150.0 * xr + 60.0 * np.sin(2 * np.pi * xr)) if nonuniform else np.full(pts.n,
                                                                                        550.0)
    return pts, SurfaceState(w[0], ws[0], velocity * np.sin(np.pi * xr), T)


def assert_matches_richardson(analytic: np.ndarray, reference: np.ndarray,
                              bound: np.ndarray, label: object = "",
                              safety: float = 4.0) -> None:
    """``|analytic - reference| <= safety * bound`` entry by entry, for ``(reference,
    bound)`` from :func:`richardson_derivative` / :func:`richardson_jacobian`; the message
    gives the worst ratio of error to bound.

    ``safety`` 4: the truncation part is already three times the error of the plain
    difference at h/2, but the rounding part is an estimate from a few samples of a random
    quantity. Measured on the Jacobians of tests/solvers/aero/test_analytic.py (its five
    fluid models, two flow angles, eight random states: 376 000 entries): error / bound at
    most 1.9, 99.9 % of them below 0.25.
    """
    err = np.abs(np.asarray(analytic) - np.asarray(reference))
    tol = safety * np.asarray(bound)
    ratio = float(np.max(err / np.maximum(tol, np.finfo(float).tiny)))
    assert np.all(err <= tol), f"{label}: |analytic - FD| / (safety * bound) up to {ratio:.3g}"


def forget_study_file(run_dir: Path) -> None:
    """Make a copied run directory's study file unknown, as when the study was moved since:
    the store records the study file's path (for the report of an interrupted run)."""
    from hypate.scaling.engine.store import EvaluationStore

    with EvaluationStore(run_dir / "evaluations.sqlite") as store:
        store.set_meta("study_path", str(run_dir / "moved-away.toml"), replace=True)
