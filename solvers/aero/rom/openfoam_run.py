"""Running an OpenFOAM snapshot case to its steady state and reading back the wall.

:func:`find_openfoam` finds the installation (``blockMesh`` and ``rhoCentralFoam`` on the
``PATH``; ``WM_PROJECT_DIR`` from the environment or the package's share folder) or refuses
in one line. :func:`run_case` meshes and runs a case written by
:func:`~hypate.solvers.aero.rom.openfoam_case.write_case`: the solver's function objects
write the area-averaged wall pressure, temperature and heat flux and the wall distributions
every ``sample_every`` pseudo-time iterations; the run is watched while it goes and stopped
once the averages have stopped drifting (density-based local time stepping has no residuals
worth watching): the solver is then ended, the samples hold all a snapshot needs. The
snapshot is the average over the first window that met the tolerance, so that it does not
depend on how late the watcher saw it (the machine's load). The distributions of the last ``window``
samples are averaged. A case that fails, stays unconverged or holds NaN gives a :class:`CaseResult`
with ``converged = False`` and a stated ``reason``; nothing is raised for it, so that a campaign
can record the reason and go on.
"""
from __future__ import annotations

import math
import os
import re
import shutil
import subprocess
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from hypate.solvers.aero.base import Array
from hypate.solvers.aero.rom.openfoam_case import Resolution
from hypate.solvers.errors import InputError

__all__ = ["NOT_FOUND", "CaseResult", "OpenFoam", "drift", "find_openfoam", "read_averages",
           "read_result", "read_samples", "run_case"]

#: The one-line refusal when OpenFOAM is missing (field ``[source] kind``).
NOT_FOUND = "OpenFOAM not found; apt-get install openfoam"
#: Share folders of packaged OpenFOAM installations (Debian's ``openfoam`` package), tried
#: after ``WM_PROJECT_DIR``; relative to the folder of the ``rhoCentralFoam`` binary.
_SHARE = ("../share/openfoam",)
#: Seconds between two looks at a running case's wall averages.
POLL = 0.25
#: The solver's floating-point exception, in :func:`_fatal`'s words.
_FPE = "floating point exception (the solution diverged)"


@dataclass(frozen=True)
class OpenFoam:
    """An OpenFOAM installation: the two commands, the project folder and the version."""

    block_mesh: str
    solver: str
    project_dir: str
    version: str

    def environment(self) -> dict[str, str]:
        env = dict(os.environ)
        env["WM_PROJECT_DIR"] = self.project_dir
        return env


def _project_dir(solver: str) -> str | None:
    env = os.environ.get("WM_PROJECT_DIR")
    candidates = ([Path(env)] if env else []) + [
        (Path(solver).resolve().parent / rel).resolve() for rel in _SHARE]
    for c in candidates:
        if (c / "etc" / "controlDict").is_file():
            return str(c)
    return None


def find_openfoam() -> OpenFoam:
    """The OpenFOAM installation, or :class:`InputError` on ``source.kind`` with
    :data:`NOT_FOUND`."""
    block_mesh, solver = shutil.which("blockMesh"), shutil.which("rhoCentralFoam")
    project = _project_dir(solver) if solver else None
    if not (block_mesh and solver and project):
        raise InputError("source.kind", NOT_FOUND)
    env = dict(os.environ, WM_PROJECT_DIR=project)
    try:
        text = subprocess.run([solver, "-help"], env=env, capture_output=True, text=True,
                              timeout=60).stdout
    except (OSError, subprocess.SubprocessError):
        raise InputError("source.kind", NOT_FOUND) from None
    m = re.search(r"OpenFOAM-\S*\s*\((\w+)\)", text)
    if m is None:
        raise InputError("source.kind", NOT_FOUND)
    return OpenFoam(block_mesh, solver, project, m.group(1))


@dataclass
class CaseResult:
    """The wall of a finished (or failed) case.

    Attributes
    ----------
    converged : bool
    reason : str
        Why the case is rejected ("" when converged).
    x, y : ndarray of shape (n_faces,)
        Panel face centres (m), sorted by x.
    pressure, temperature, heat_flux : ndarray of shape (n_faces,)
        Absolute pressure (Pa), wall-cell temperature (K) and heat flux into the wall
        (W/m^2) on the faces, averaged over the last ``window`` samples.
    iterations : int
        Pseudo-time iterations run.
    drift_pressure, drift_heat_flux : float
        Relative drift of the panel's mean pressure and heat flux over the window.
    cpu_seconds : float
        Wall-clock seconds of mesh and solver.
    diverged : bool
        The solution blew up (a floating-point exception or NaN in the wall averages): a
        case that may converge at a smaller pseudo-time step.
    """

    converged: bool
    reason: str = ""
    x: Array = field(default_factory=lambda: np.zeros(0))
    y: Array = field(default_factory=lambda: np.zeros(0))
    pressure: Array = field(default_factory=lambda: np.zeros(0))
    temperature: Array = field(default_factory=lambda: np.zeros(0))
    heat_flux: Array = field(default_factory=lambda: np.zeros(0))
    iterations: int = 0
    drift_pressure: float = math.nan
    drift_heat_flux: float = math.nan
    cpu_seconds: float = 0.0
    diverged: bool = False


def read_averages(folder: str | Path) -> Array:
    """The wall averages written so far, (k, 4): iteration, mean p, mean T, mean q."""
    files = sorted((Path(folder) / "postProcessing" / "wallAverages").glob("*/*.dat"))
    rows = []
    for f in files:
        for line in f.read_text(encoding="utf-8", errors="replace").splitlines():
            if line and not line.startswith("#"):
                parts = line.split()
                if len(parts) == 4:
                    try:
                        rows.append([float(v) for v in parts])
                    except ValueError:
                        continue
    return np.array(rows, float).reshape(-1, 4)


def drift(values: Array) -> float:
    """Relative drift of a sampled history: the change between the means of its two halves
    over the mean magnitude (0 for a history that no longer moves)."""
    v = np.asarray(values, float)
    h = v.size // 2
    scale = max(float(np.mean(np.abs(v))), 1e-300)
    return abs(float(np.mean(v[h:]) - np.mean(v[:h]))) / scale


def _converged(avg: Array, r: Resolution, viscous: bool) -> tuple[int, float, float]:
    """The first sample at which the averages of ``avg`` have converged (its row index, -1
    if none yet) and the drifts of the pressure and heat flux there (or at the last row).

    The newest row is left out: its distributions may still be being written. The answer
    depends only on the solver's (deterministic) history, not on when it was looked at.
    """
    rows = avg[:-1]
    W = max(r.window, 2)
    if rows.shape[0] < W:
        return -1, math.nan, math.nan
    dp = dq = math.nan
    for k in range(W - 1, rows.shape[0]):
        last = rows[k - W + 1:k + 1]
        if not np.all(np.isfinite(last)):
            return -1, math.nan, math.nan
        dp = drift(last[:, 1])
        dq = drift(last[:, 3]) if viscous else 0.0
        if dp < r.tolerance and dq < r.tolerance:
            return k, dp, dq
    return -1, dp, dq


def read_samples(folder: str | Path, iterations: list[int]) -> tuple[Array, ...]:
    """Panel distributions (x, y, p, T, q) averaged over the samples of ``iterations``."""
    base = Path(folder) / "postProcessing" / "wallSamples"
    acc: dict[str, list[Array]] = {"p": [], "T": [], "wallHeatFlux": []}
    xy = None
    for it in iterations:
        for name in acc:
            data = np.loadtxt(base / str(it) / f"{name}_panel.raw", ndmin=2)
            order = np.argsort(data[:, 0], kind="stable")
            data = data[order]
            xy = data[:, :2] if xy is None else xy
            acc[name].append(data[:, 3])
    if xy is None:
        raise FileNotFoundError(base)
    p, T, q = (np.mean(acc[k], axis=0) for k in ("p", "T", "wallHeatFlux"))
    # OpenFOAM's wallHeatFlux is positive from the wall into the fluid; hypate's q is into
    # the wall
    return xy[:, 0], xy[:, 1], p, T, -q


def _fatal(log: Path) -> str:
    """The solver's own words for a failure: the FOAM FATAL ERROR block or the last line."""
    text = log.read_text(encoding="utf-8", errors="replace") if log.is_file() else ""
    m = re.search(r"FOAM FATAL (?:IO )?ERROR.*?\n\s*\n?(.+?)\n", text, re.S)
    if m:
        return m.group(1).strip()
    if "Floating point exception" in text or "sigFpe" in text:
        return _FPE
    tail = [ln for ln in text.splitlines() if ln.strip()]
    return tail[-1].strip() if tail else "no output"


def _clear_output(folder: Path) -> None:
    """Remove what an earlier run in ``folder`` left: its function objects' output (the
    solver writes a new run's averages beside an existing file, so the watch would read
    the old run's history and samples) and its written time folders (all but ``0``)."""
    shutil.rmtree(folder / "postProcessing", ignore_errors=True)
    for d in folder.iterdir():
        if d.is_dir() and d.name != "0" and re.fullmatch(r"[0-9.eE+-]+", d.name):
            shutil.rmtree(d, ignore_errors=True)


def run_case(folder: str | Path, openfoam: OpenFoam, resolution: Resolution,
             viscous: bool, timeout: float | None = None,
             after_mesh: Callable[[Path], object] | None = None) -> CaseResult:
    """Mesh and run the case in ``folder`` until its wall averages converge.

    Parameters
    ----------
    folder : str or Path
        A case written by :func:`~hypate.solvers.aero.rom.openfoam_case.write_case`.
    openfoam : OpenFoam
    resolution : Resolution
        Convergence settings (``window``, ``tolerance``, ``max_iterations``).
    viscous : bool
        Whether the heat-flux average must converge too.
    timeout : float, optional
        Wall-clock seconds after which the case is stopped and rejected.
    after_mesh : callable, optional
        Called with the folder between blockMesh and the solver (e.g. to move the mesh's
        points: :func:`~hypate.solvers.aero.rom.openfoam_case3d.deform_points`).
    """
    folder = Path(folder)
    env = openfoam.environment()
    t0 = time.monotonic()
    _clear_output(folder)
    with open(folder / "log.blockMesh", "w", encoding="utf-8") as log:
        code = subprocess.run([openfoam.block_mesh, "-case", str(folder)], env=env,
                              stdout=log, stderr=subprocess.STDOUT).returncode
    if code != 0:
        return CaseResult(False, f"blockMesh failed: {_fatal(folder / 'log.blockMesh')}",
                          cpu_seconds=time.monotonic() - t0)
    if after_mesh is not None:
        after_mesh(folder)
    log_path = folder / "log.rhoCentralFoam"
    stopped = False
    with open(log_path, "w", encoding="utf-8") as log:
        proc = subprocess.Popen([openfoam.solver, "-case", str(folder)], env=env, stdout=log,
                                stderr=subprocess.STDOUT)
        try:
            while proc.poll() is None:
                time.sleep(POLL)
                avg = read_averages(folder)
                if avg.size and not np.all(np.isfinite(avg[-1])):
                    break
                if (_converged(avg, resolution, viscous)[0] >= 0
                        or (timeout is not None and time.monotonic() - t0 > timeout)):
                    break  # the samples hold everything the snapshot needs: no final write
        finally:
            if proc.poll() is None:
                stopped = True
                proc.terminate()
                try:
                    proc.wait(timeout=30.0)
                except subprocess.TimeoutExpired:
                    proc.kill()
            proc.wait()
    return read_result(folder, resolution, viscous, time.monotonic() - t0,
                       failed=proc.returncode not in (0, None) and not stopped,
                       timeout=timeout)


def read_result(folder: str | Path, resolution: Resolution, viscous: bool,
                seconds: float = math.nan, failed: bool = False,
                timeout: float | None = None) -> CaseResult:
    """The result of a run in ``folder`` from its wall averages and samples (what
    :func:`run_case` returns; also to read a finished case again). ``failed``: the solver
    exited with an error; ``seconds``: the run's wall-clock time."""
    folder = Path(folder)
    log_path = folder / "log.rhoCentralFoam"
    avg = read_averages(folder)
    k, dp, dq = _converged(avg, resolution, viscous)
    iterations = int(avg[k if k >= 0 else -1, 0]) if avg.size else 0
    result = CaseResult(False, iterations=iterations, drift_pressure=dp, drift_heat_flux=dq,
                        cpu_seconds=seconds)
    if avg.size and not np.all(np.isfinite(avg)):
        result.reason = "NaN in the wall averages (the solution diverged)"
        result.diverged = True
        return result
    if k < 0:
        if failed:
            fatal = _fatal(log_path)
            result.reason = f"rhoCentralFoam failed: {fatal}"
            result.diverged = fatal == _FPE
        elif timeout is not None and seconds > timeout:
            result.reason = (f"not converged within the {timeout:g} s time limit "
                             f"({iterations} iterations, drift p {dp:.2g}, q {dq:.2g})")
        else:
            figures = (f"drift of the wall averages over the last {resolution.window} "
                       f"samples: p {dp:.2g}, q {dq:.2g}; tolerance {resolution.tolerance:g}"
                       if math.isfinite(dp) else
                       f"fewer than the {resolution.window} samples the check needs")
            result.reason = f"not converged after {iterations} iterations ({figures})"
        return result
    # the window that first met the tolerance: the same however late the run was stopped
    window = [int(i) for i in avg[k - resolution.window + 1:k + 1, 0]]
    try:
        x, y, p, T, q = read_samples(folder, window)
    except (OSError, ValueError) as exc:
        result.reason = f"cannot read the wall samples ({type(exc).__name__}: {exc})"
        return result
    if not all(np.all(np.isfinite(a)) for a in (p, T, q)):
        result.reason = "NaN in the wall distributions"
        return result
    result.converged = True
    result.x, result.y, result.pressure, result.temperature, result.heat_flux = x, y, p, T, q
    return result
