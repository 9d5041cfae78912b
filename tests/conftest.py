"""Shared pytest fixtures."""
from __future__ import annotations

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


def stored_evaluations(store: Path) -> int:
    """Rows in a run's SQLite store, read-only (0 while it does not exist or is locked):
    polled by the kill-and-resume tests while the run writes."""
    import sqlite3

    if not store.exists():
        return 0
    try:
        with sqlite3.connect(f"file:{store}?mode=ro", uri=True, timeout=1.0) as con:
            return int(con.execute("SELECT COUNT(*) FROM evaluations").fetchone()[0])
    except sqlite3.Error:
        return 0


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


def richardson_derivative(f: Callable[[float], np.ndarray], h: float
                          ) -> tuple[np.ndarray, np.ndarray]:
    """Derivative of ``f`` at 0 by Richardson-extrapolated central differences, with an
    error bound measured on this machine.

    ``D(h) = (f(h) - f(-h)) / 2h`` carries a truncation error ``h^2 f'''(0)/6 + O(h^4)`` and a
    rounding error ``~ eps_f / h``, where ``eps_f`` is the noise of ``f`` itself (a GP
    prediction solves with its Cholesky factor, so it sits far above machine epsilon and
    depends on the BLAS kernels). ``R = (4 D(h/2) - D(h)) / 3`` cancels the h^2 term, and
    ``|D(h) - D(h/2)|`` (three times D(h/2)'s truncation error plus both rounding errors)
    bounds R's error. Returns ``(R, bound)``: a test asserts ``|analytic - R| <= bound`` plus
    a small relative floor, so its tolerance is the difference formula's own error.
    """
    d_h = (np.asarray(f(h)) - np.asarray(f(-h))) / (2.0 * h)
    d_h2 = (np.asarray(f(h / 2)) - np.asarray(f(-h / 2))) / h
    return (4.0 * d_h2 - d_h) / 3.0, np.abs(d_h - d_h2)


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


def fd4(f, x: np.ndarray, h: float) -> np.ndarray:
    """Fourth-order central differences, column by column."""
    cols = []
    for e in np.eye(x.size):
        cols.append((8 * (f(x + h * e) - f(x - h * e)) - (f(x + 2 * h * e) - f(x - 2 * h * e)))
                    / (12 * h))
    return np.stack(cols, axis=1)
