"""What one simulation will cost before it runs: memory and time from the mesh, the layers
and the steps, and the refusal of a study this machine cannot hold.

The simulator's memory goes to two banded factorizations (``hypate.solvers.numerics``):

* the thermal Jacobian, LAPACK banded LU of ``n_t = L n_x n_y`` unknowns (``L`` thermal
  levels = the layers' sub-layers + 1, ``n_x = 2 nx + 1`` in-plane points along x) with
  half bandwidth ``b_t = L (min(n_x, n_y) + 1) + 1``, stored in ``(3 b_t + 1) n_t`` doubles;
* the shell stiffness, banded Cholesky of ``N_s = 5 n_x n_y`` unknowns with half bandwidth
  ``b_s = 10 (min(n_x, n_y) + 1) + 4`` (the grid ordering), ``(b_s + 1) N_s`` doubles

(the counts and bandwidths are exact; ``tests/scaling/workflow/test_resources.py`` checks
them against the models). The sparse matrices hold a fixed number of entries per row, and
the shell keeps the mass matrices of its last 9 temperature states. A factorization's work
is ``n b^2``. The estimate of one simulation is linear in these features::

    memory  = m_t 8 (3 b_t + 1) n_t + m_s 8 (b_s + 1) N_s + m_n 8 (n_t + N_s)
              + m_c 8 N_s min(steps, 9) + m_0
    seconds = steps (s_t n_t b_t^2 + s_s N_s b_s^2 + s_n (n_t + N_s)) + s_0

with coefficients fitted (non-negative least squares) to measured simulations of the
quick-start's prototype and model: memory is the rise of the peak resident set over the
process's resident set before the simulation (``VmHWM``, Linux), time is wall time on one
core. ``python -m hypate.studies.scripts.calibrate_resources`` measures, fits and prints
the coefficients and each point's error (README: "What a run guarantees").

Before the first simulation, :func:`check_resources` refuses a study whose prototype, or
whose model simulations running on every worker at once, would need more memory than the
machine has available (``MemAvailable``, a cgroup's ``memory.max``, an address-space
limit), naming ``[simulation] mesh`` and the estimate (``--force`` runs it anyway).
"""
from __future__ import annotations

import math
import os
import resource
from dataclasses import dataclass
from pathlib import Path

from hypate.scaling.workflow.vocabulary.configuration import Configuration
from hypate.scaling.workflow.vocabulary.study import Study
from hypate.solvers.errors import InputError
from hypate.solvers.panel import thermal_levels

__all__ = ["CALIBRATION", "Estimate", "SimulationSize", "StudyEstimate", "available_memory",
           "check_resources", "estimate", "local_workers", "simulation_size", "study_estimate"]

#: Fitted coefficients (``calibrate_resources --points full``, 27 simulations on this
#: project's 2-core AMD EPYC machine, numpy 2.4 / OpenBLAS; README). Memory: bytes per byte
#: of the thermal LU (0.41: the thermal Jacobian is mostly factorized by banded Cholesky,
#: a third of the LU's storage), of the shell's banded Cholesky (fitted to 0: the peak comes
#: with the coupled Newton block's sparse LU, which the per-unknown term carries), per
#: unknown's double, per cached mass matrix's unknown, and a fixed part (bytes). Time:
#: seconds per step per ``n b^2`` of each factorization, per unknown, plus a fixed start.
CALIBRATION = {"m_t": 0.407, "m_s": 0, "m_n": 1.49e+03, "m_c": 160, "m_0": 1.56e+06,
               "s_t": 1.39e-10, "s_s": 1.62e-10, "s_n": 2.49e-05, "s_0": 0.0455}
#: Steps after which the shell's cache of mass matrices stops growing (it holds 9).
CACHED_STEPS = 9


@dataclass(frozen=True)
class SimulationSize:
    """The sizes of one simulation that decide its cost.

    Attributes
    ----------
    mesh : (int, int)
        Nine-node shell elements along x and y.
    levels : int
        Thermal node levels through the thickness (the layers' sub-layers + 1).
    steps : int
        Time steps.
    """

    mesh: tuple[int, int]
    levels: int
    steps: int

    @property
    def points(self) -> tuple[int, int]:
        """In-plane grid points along x and y, ``(2 nx + 1, 2 ny + 1)``."""
        return 2 * self.mesh[0] + 1, 2 * self.mesh[1] + 1

    @property
    def thermal(self) -> tuple[int, int]:
        """Thermal unknowns and the half bandwidth of their banded ordering."""
        nx, ny = self.points
        return self.levels * nx * ny, self.levels * (min(nx, ny) + 1) + 1

    @property
    def structural(self) -> tuple[int, int]:
        """Shell unknowns (5 per point) and their half bandwidth (grid ordering)."""
        nx, ny = self.points
        return 5 * nx * ny, 10 * (min(nx, ny) + 1) + 4

    def memory_features(self) -> tuple[float, float, float, float]:
        """Bytes of the thermal LU and of the shell Cholesky, 8 per unknown (the sparse
        matrices: their entries per row are fixed), and 8 per shell unknown and step up to
        :data:`CACHED_STEPS` (the shell's mass matrices, cached per temperature state)."""
        (nt, bt), (ns, bs) = self.thermal, self.structural
        return (8.0 * (3 * bt + 1) * nt, 8.0 * (bs + 1) * ns, 8.0 * (nt + ns),
                8.0 * ns * min(self.steps, CACHED_STEPS))

    def work_features(self) -> tuple[float, float, float]:
        """Per step: ``n b^2`` of the thermal and the shell factorization, the unknowns."""
        (nt, bt), (ns, bs) = self.thermal, self.structural
        return float(nt) * bt * bt, float(ns) * bs * bs, float(nt + ns)


@dataclass(frozen=True)
class Estimate:
    """Memory (bytes, the rise of the resident set) and wall time (s) of one simulation."""

    memory: float
    seconds: float


def simulation_size(config: Configuration) -> SimulationSize:
    """The :class:`SimulationSize` of a prototype or model configuration."""
    panel = config.panel
    return SimulationSize(mesh=(int(panel.mesh[0]), int(panel.mesh[1])),
                          levels=len(thermal_levels(panel)),
                          steps=int(config.simulation.n_steps))


def estimate(size: SimulationSize, coefficients: dict[str, float] | None = None) -> Estimate:
    """The calibrated estimate of one simulation (module docstring)."""
    c = CALIBRATION if coefficients is None else coefficients
    mt, ms, mn, mc = size.memory_features()
    wt, ws, wn = size.work_features()
    memory = c["m_0"] + c["m_t"] * mt + c["m_s"] * ms + c["m_n"] * mn + c["m_c"] * mc
    seconds = c["s_0"] + size.steps * (c["s_t"] * wt + c["s_s"] * ws + c["s_n"] * wn)
    return Estimate(memory=memory, seconds=seconds)


@dataclass(frozen=True)
class StudyEstimate:
    """The cost of a study's simulations on this machine.

    Attributes
    ----------
    prototype, model : Estimate
        One prototype simulation (run alone, first) and one model evaluation.
    workers : int
        Model evaluations that run at once.
    needed : float
        Bytes needed at the worst moment: the prototype alone, or a model on every worker.
    available : float
        Bytes this machine has available (:func:`available_memory`; inf when unknown).
    """

    prototype: Estimate
    model: Estimate
    workers: int
    needed: float
    available: float

    def summary(self) -> str:
        """One line: ``"one evaluation: about 0.4 s and 25 MB (estimate) ..."``."""
        return (f"one evaluation: about {_seconds(self.model.seconds)} and "
                f"{_bytes(self.model.memory)} (estimate; the prototype "
                f"{_seconds(self.prototype.seconds)} and {_bytes(self.prototype.memory)})")


def _bytes(n: float) -> str:
    """Bytes in SI units (1 GB = 10^9 bytes)."""
    for unit, size in (("GB", 1e9), ("MB", 1e6)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n / 1e3:.3g} kB"


def _seconds(s: float) -> str:
    if s >= 3600:
        return f"{s / 3600:.3g} h"
    return f"{s / 60:.3g} min" if s >= 120 else f"{s:.2g} s"


def _meminfo_available() -> float:
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                return float(line.split()[1]) * 1024.0
    except OSError:
        pass
    try:  # free pages (no page cache counted): a lower bound of what is available
        return float(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError):
        return math.inf


def _cgroup_room() -> float:
    """``memory.max - memory.current`` of this process's cgroup (v2), inf when unlimited."""
    try:
        rel = next(line.split("::", 1)[1] for line in
                   Path("/proc/self/cgroup").read_text().splitlines() if line.startswith("0::"))
        base = Path("/sys/fs/cgroup") / rel.strip().lstrip("/")
        limit = (base / "memory.max").read_text().strip()
        used = float((base / "memory.current").read_text().strip())
    except (OSError, StopIteration, ValueError):
        return math.inf
    return math.inf if limit == "max" else float(limit) - used


def available_memory() -> float:
    """Bytes this machine can give new work now: the smaller of ``MemAvailable``
    (``/proc/meminfo``) and the room left under this process's cgroup limit (inf where
    neither can be read)."""
    return min(_meminfo_available(), _cgroup_room())


def _address_room() -> float:
    """Room under this process's address-space limit (``RLIMIT_AS``; inf without one)."""
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    if soft == resource.RLIM_INFINITY:
        return math.inf
    try:
        status = Path("/proc/self/status").read_text().splitlines()
        vm = next(float(line.split()[1]) * 1024.0 for line in status
                  if line.startswith("VmSize:"))
    except (OSError, StopIteration, ValueError):
        vm = 0.0
    return float(soft) - vm


def study_estimate(study: Study, workers: int, available: float | None = None
                   ) -> StudyEstimate:
    """The estimate of a study's prototype and model simulations with ``workers`` model
    evaluations at once (a multi-fidelity study: its top level, the costliest)."""
    spec = study.spec
    proto = estimate(simulation_size(spec.prototype))
    # the model template's layers and mesh; its steps are the prototype's (matched times)
    model_size = simulation_size(spec.model)
    model = estimate(SimulationSize(model_size.mesh, model_size.levels,
                                    simulation_size(spec.prototype).steps))
    needed = max(proto.memory, max(1, workers) * model.memory)
    room = available_memory() if available is None else available
    return StudyEstimate(prototype=proto, model=model, workers=max(1, workers),
                         needed=needed, available=room)


def local_workers(workers: int, scheduler: str | None) -> int | None:
    """Model evaluations running at once on this machine: ``workers`` without a scheduler,
    ``N`` of ``local:N``; None for a remote cluster (its memory is not this machine's)."""
    if not scheduler:
        return max(1, int(workers))
    if scheduler.startswith("local:"):
        try:
            return max(1, int(scheduler[len("local:"):]))
        except ValueError:
            return None
    return None


def check_resources(study: Study, workers: int, *, force: bool = False,
                    available: float | None = None) -> StudyEstimate:
    """Refuse a study this machine cannot hold in memory, before anything is simulated.

    Parameters
    ----------
    study : Study
    workers : int
        Model evaluations that run at once (local workers; 1 in-process).
    force : bool
        Return the estimate without refusing (``hypate run --force``).
    available : float, optional
        Bytes available (default: :func:`available_memory`).

    Returns
    -------
    StudyEstimate

    Raises
    ------
    InputError
        ``simulation.mesh``: the estimate exceeds the memory available (or a process's
        address-space limit), with both figures and the ways out.
    """
    est = study_estimate(study, workers, available)
    if force:
        return est
    mesh = "x".join(map(str, study.spec.prototype.panel.mesh))
    what = ("the prototype's simulation" if est.needed == est.prototype.memory else
            f"{est.workers} model simulation{'s' * (est.workers > 1)} at once")
    if est.needed > est.available:
        raise InputError("simulation.mesh", f"a {mesh} mesh needs about {_bytes(est.needed)} "
                         f"for {what} (estimate), this machine has {_bytes(est.available)} "
                         "available; use a coarser [simulation] mesh or fewer --workers, or "
                         "--force to run it anyway")
    largest = max(est.prototype.memory, est.model.memory)
    room = _address_room()
    if largest > room:
        raise InputError("simulation.mesh", f"a {mesh} mesh needs about {_bytes(largest)} "
                         f"per simulation (estimate), the address-space limit (ulimit -v) "
                         f"leaves {_bytes(room)}; use a coarser [simulation] mesh, or "
                         "--force to run it anyway")
    return est
