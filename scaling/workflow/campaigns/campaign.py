"""A run directory belongs to one campaign: its identity, the resume check, the run lock and
the preflight that runs before any simulation.

A campaign's identity is the content of what decides its results: the parsed study, the
prototype case file it reads, the ROM archive of a ``rom:PATH`` fluid model and the file of
a user's own simulator (by hash), the simulation settings, the seed and the package version.
The store keeps the identity itself (``meta`` key ``campaign``) and its SHA-256
(``fingerprint``), so that ``--resume`` can say which keys changed, old -> new, and refuse
before anything in the directory is touched.
"""
from __future__ import annotations

import copy
import dataclasses
import errno
import fcntl
import hashlib
import json
import os
import platform
import sqlite3
from collections.abc import Iterator
from contextlib import contextmanager
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import IO, Any, cast

from hypate.scaling.engine.executors import check_scheduler_address
from hypate.scaling.engine.store import EvaluationStore, StoreError
from hypate.scaling.workflow.campaigns.integrity import check_run_directory
from hypate.scaling.workflow.campaigns.resources import check_resources, local_workers
from hypate.scaling.workflow.campaigns.rundir import LOCK_FILE, STORE
from hypate.scaling.workflow.vocabulary.derived import study_data
from hypate.scaling.workflow.vocabulary.external import simulator_source
from hypate.scaling.workflow.vocabulary.study import MAX_SEED, Study
from hypate.solvers.aero.factory import ROM_PREFIX, check_fluid_model
from hypate.solvers.config import read_toml
from hypate.solvers.errors import InputError
from hypate.solvers.numerics.files import LinkRefused, ensure_directory
from threadpoolctl import threadpool_info

try:  # numpy's runtime record of the SIMD extensions it dispatches to (numpy.show_runtime)
    from numpy._core._multiarray_umath import __cpu_features__ as NUMPY_CPU_FEATURES
except ImportError:  # another numpy layout: the environment record then lists none
    NUMPY_CPU_FEATURES = {}

__all__ = ["ENVIRONMENTS", "MAX_SEED", "campaign_identity", "changed_keys", "check_resume",
           "fingerprint", "check_run_settings", "package_version", "preflight",
           "record_campaign", "refuse_changes", "run_lock", "runtime_environment",
           "stored_seed", "sweep_changes", "sweep_identity"]

#: Changed keys named in a refused resume before "... and N more".
SHOWN_CHANGES = 6
#: Store ``meta`` key: the numerical environments the campaign ran in (one entry per
#: distinct environment, in order: a run resumed elsewhere appends the new one).
ENVIRONMENTS = "environments"
#: Distributions whose versions decide the last bits of a result.
NUMERICAL_PACKAGES = ("numpy", "scipy", "scikit-learn", "pymoo", "pandas")


def package_version() -> str:
    """The installed distribution's version (``pyproject.toml``)."""
    try:
        return version("hypate")
    except PackageNotFoundError:  # pragma: no cover - running from an uninstalled tree
        return "unknown"


def _installed(name: str) -> str | None:
    try:
        return version(name)
    except PackageNotFoundError:
        return None


def runtime_environment() -> dict[str, Any]:
    """The numerical environment of this process: Python, hypate and the numerical
    packages' versions, and the BLAS libraries numpy and scipy call (threadpoolctl: library,
    version, kernel architecture, threading layer). A result that differs in its last bits
    between two machines can be traced to a difference here."""
    blas = [{k: lib.get(k) for k in ("internal_api", "version", "architecture",
                                       "threading_layer", "filepath")}
            for lib in threadpool_info() if lib.get("user_api") == "blas"]
    return {"python": platform.python_version(), "machine": platform.machine(),
            "cpu": cpu_model(), "simd": numpy_simd(),
            "hypate": package_version(),
            "packages": {name: _installed(name) for name in NUMERICAL_PACKAGES},
            "blas": blas}


def cpu_model() -> str:
    """The processor's model name (Linux ``/proc/cpuinfo``; else ``platform.processor()``)."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor()


def numpy_simd() -> list[str]:
    """The SIMD extensions numpy dispatches to on this CPU (numpy's own runtime report, as
    ``numpy.show_runtime``). The same code and package versions gave the quick-start's
    design point J_u 8.84 % on an earlier machine (CPU not recorded then) and 16.8 % on an
    AMD EPYC without AVX-512 (presumably last bits of the first evaluations sending the
    optimizer down another path); this record is where to trace such a difference."""
    return sorted(name for name, found in NUMPY_CPU_FEATURES.items() if found)


def _file_sha256(path: Path) -> str | None:
    try:
        return hashlib.sha256(path.read_bytes()).hexdigest()
    except OSError:
        return None


def campaign_identity(study: Study, seed: int) -> dict[str, Any]:
    """What decides a campaign's results, as plain JSON data (see the module docstring)."""
    data = study_data(study)
    case_path = Path(data["prototype"].pop("case"))
    data.pop("sweep", None)  # a sweep point's store belongs to the point's own sub-study
    aero = study.spec.prototype.simulation.aero
    files: dict[str, Any] = {"case": read_toml(case_path)}
    if aero.startswith(ROM_PREFIX):
        files["rom_sha256"] = _file_sha256(Path(aero[len(ROM_PREFIX):]))
    simulator = study.spec.simulator  # a user's simulator's code decides the results too
    if simulator is not None and (source := simulator_source(simulator)) is not None:
        files["simulator_sha256"] = _file_sha256(source)
    return {"study": data, "files": files, "seed": int(seed), "version": package_version(),
            "simulation": dataclasses.asdict(study.spec.prototype.simulation)}


def fingerprint(identity: dict[str, Any]) -> str:
    """SHA-256 of the identity's canonical JSON."""
    text = json.dumps(identity, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def _flatten(value: Any, prefix: str = "") -> dict[str, Any]:
    if isinstance(value, dict) and value:
        out: dict[str, Any] = {}
        for key, sub in value.items():
            out.update(_flatten(sub, f"{prefix}.{key}" if prefix else str(key)))
        return out
    return {prefix: value}


def _text(value: Any) -> str:
    return json.dumps(value, sort_keys=True, default=str)


def changed_keys(old: dict[str, Any], new: dict[str, Any]) -> list[str]:
    """``"key old -> new"`` for every dotted key whose value differs (missing: ``-``)."""
    a, b = _flatten(old), _flatten(new)
    out = []
    for key in sorted(set(a) | set(b)):
        if _text(a.get(key)) != _text(b.get(key)):
            show = [_text(d[key]) if key in d else "-" for d in (a, b)]
            out.append(f"{key} {show[0]} -> {show[1]}")
    return out


def _read_record(store_path: Path) -> tuple[dict[str, Any] | None, int | None]:
    """The stored campaign identity and seed, read without writing to the directory (and
    the store's digest chain verified: an edited store is refused here, exit 2)."""
    try:
        with EvaluationStore(store_path, read_only=True) as store:
            record, seed = store.get_meta("campaign"), store.get_meta("seed")
    except StoreError as exc:
        raise InputError("resume", str(exc)) from None
    return (record if isinstance(record, dict) else None,
            seed if isinstance(seed, int) else None)


def holds_run(out: Path) -> bool:
    """Whether ``out`` holds a run: a store with a campaign record or an evaluation. A store
    without either (a run stopped between creating its store and recording its campaign)
    holds nothing to continue: a new run, or a resume, starts afresh there."""
    store = out / STORE
    if not store.is_file():
        return False
    try:
        with EvaluationStore(store, read_only=True) as st:
            return st.get_meta("campaign") is not None or len(st) > 0
    except StoreError:
        return True  # something is there: never overwrite it


def stored_seed(store_path: Path) -> int | None:
    """The seed a run directory's campaign was started with (None: not recorded)."""
    record, seed = _read_record(store_path)
    if record is not None and isinstance(record.get("seed"), int):
        return int(record["seed"])
    return seed


def check_resume(store_path: Path, identity: dict[str, Any]) -> None:
    """Refuse to resume a store that holds another campaign (exit 2 naming the changes).

    Raises
    ------
    InputError
        ``resume``: the store holds no campaign record or a different one.
    """
    record, _ = _read_record(store_path)
    where = store_path.parent
    if record is None and not holds_run(where):
        return  # an empty store without a campaign: the run starts afresh
    if record is None:
        raise InputError("resume", f"{where} holds no hypate campaign record (not a run "
                         "directory of this version); start a new run with another --out")
    refuse_changes(where, changed_keys(_comparable(record), _comparable(identity)))


def _comparable(identity: dict[str, Any]) -> dict[str, Any]:
    """A campaign identity with its ROM named by file name (:func:`rom_by_name`), at the
    top level and in its study."""
    return dict(rom_by_name(identity), study=rom_by_name(identity.get("study")))


def rom_by_name(data: Any) -> Any:
    """A copy of a study's data (or of a campaign identity's top level, whose
    ``simulation`` holds the same setting) whose ``rom:PATH`` fluid model is named by its
    file name alone, for the resume checks: where a study finds its ROM depends on the working
    directory (as given, beside the study, or the shipped copy:
    :func:`~hypate.scaling.workflow.vocabulary.shipped.resolve_aero`), so a run started in
    one directory would be refused in another; what decides the results is the file's
    content, which the campaign's ``files.rom_sha256`` checks (a sweep: each point's)."""
    data = copy.deepcopy(data)
    sim = data.get("simulation") if isinstance(data, dict) else None
    aero = sim.get("aero") if isinstance(sim, dict) else None
    if isinstance(sim, dict) and isinstance(aero, str) and aero.startswith(ROM_PREFIX):
        sim["aero"] = ROM_PREFIX + Path(aero[len(ROM_PREFIX):]).name
    return data


def refuse_changes(where: Path, changes: list[str]) -> None:
    """Exit 2 (``resume``) naming the changed keys, if any (the first :data:`SHOWN_CHANGES`)."""
    if changes:
        shown = "; ".join(changes[:SHOWN_CHANGES])
        more = f"; and {len(changes) - SHOWN_CHANGES} more" if len(changes) > SHOWN_CHANGES \
            else ""
        raise InputError("resume", f"{where} holds a different campaign ({shown}{more}); "
                         "resume it with its own study, or start a new run with another --out")


def sweep_identity(study: Study) -> dict[str, Any]:
    """What a sweep's resume must find unchanged: the study with its ``[sweep]`` table and
    the prototype case file's content (each point's store checks the rest)."""
    data = study_data(study)
    return {"study": data, "case": read_toml(Path(data["prototype"]["case"]))}


def sweep_changes(stored: dict[str, Any], study: Study) -> list[str]:
    """What differs between a sweep's ``sweep.json`` (``stored``) and ``study``: the study
    data and the prototype case file's content. The case file's path counts only for a
    sweep written before that content was recorded, so a finished sweep of a moved or
    freshly cloned checkout resumes (its points' stores compare content alone as well)."""
    new = sweep_identity(study)
    new["study"] = rom_by_name(new["study"])  # the ROM's content: in each point's store
    old_study = rom_by_name(stored.get("study_data"))
    if stored.get("case") is None:  # the path is all there is to compare
        return changed_keys({"study": old_study}, {"study": new["study"]})
    for data in (old_study, new["study"]):
        if isinstance(data, dict) and isinstance(data.get("prototype"), dict):
            data["prototype"].pop("case", None)
    return changed_keys({"study": old_study, "case": stored["case"]}, new)


def check_seed(seed: int | None) -> None:
    """A seed the store and numpy can keep: ``0 <= seed <= 2**63 - 1``."""
    if seed is not None and not (0 <= int(seed) <= MAX_SEED):
        raise InputError("seed", f"must be within [0, 2**63 - 1]; got {seed}")


def check_run_settings(out: Path, *, seed: int | None, workers: int,
                       scheduler: str | None) -> None:
    """The command-line settings of a run (single or sweep): seed range, worker count,
    executor address form, and an ``out`` that is (or can become) a directory without a
    symbolic link where the run writes (:func:`~.integrity.check_run_directory`)."""
    check_seed(seed)
    if workers < 1:
        raise InputError("workers", "must be >= 1")
    if scheduler is not None:
        try:
            check_scheduler_address(scheduler)
        except ValueError as exc:
            raise InputError("scheduler", getattr(exc, "message", str(exc))) from None
    check_run_directory(out)  # no planted link where the run writes (before out.exists())
    if out.exists() and not out.is_dir():
        raise InputError("out", f"{out} exists and is not a directory")
    parent = next((p for p in (out, *out.parents) if p.exists()), Path("."))
    if not parent.is_dir() or not os.access(parent, os.W_OK | os.X_OK):
        raise InputError("out", f"cannot write in {parent}")


def check_out(out: Path, resume: bool) -> None:
    """The run directory can hold this run: not another run, or the run to resume."""
    store = out / STORE
    if store.exists() and not resume and holds_run(out):
        raise InputError("out", f"{out} already holds a run; use --resume to continue it "
                         "or choose another directory")
    if resume and not store.is_file():
        raise InputError("resume", f"{out} holds no run to resume")


def preflight(study: Study, out: Path, *, resume: bool, seed: int | None, workers: int,
              scheduler: str | None, force: bool = False) -> tuple[dict[str, Any], int]:
    """Every check of a run that needs no simulation, before anything is written.

    Returns the campaign identity and the run's seed (``seed``, else the stored one on
    resume, else the study's).

    Raises
    ------
    InputError
        Naming the setting: ``out``, ``resume``, ``seed``, ``workers``, ``scheduler``,
        ``simulation.aero`` (a ``rom:`` file that is missing or does not load),
        ``simulation.mesh`` (the simulations would need more memory than this machine has
        available, :func:`~.resources.check_resources`; not with ``force``).
    """
    check_run_settings(out, seed=seed, workers=workers, scheduler=scheduler)
    check_out(out, resume)
    check_fluid_model(study.spec.prototype.simulation.aero)  # a rom: file exists and loads
    here = local_workers(workers, scheduler)
    if here is not None:  # a remote cluster's memory is not this machine's to judge
        check_resources(study, here, force=force)
    if seed is None and resume:
        seed = stored_seed(out / STORE)
    run_seed = study.optimizer.seed if seed is None else int(seed)
    identity = campaign_identity(study, run_seed)
    if resume:
        check_resume(out / STORE, identity)
    return identity, run_seed


def _holder(handle: IO[str]) -> str:
    handle.seek(0)
    text = handle.read().strip()
    return text if text.isdigit() else "unknown"


@contextmanager
def run_lock(out: Path) -> Iterator[None]:
    """One process at a time per run directory: an exclusive POSIX record lock on
    ``out/LOCK_FILE``, which holds the owner's pid. The kernel releases it when the owner
    dies, even by SIGKILL, and -- unlike ``flock`` -- a forked worker does not inherit it, so
    a worker that outlives a killed run cannot block the resume.

    Raises
    ------
    InputError
        ``out``: another process holds the directory (its pid named).
    """
    ensure_directory(out)
    try:  # never through a planted link (a received directory may hold one)
        fd = os.open(out / LOCK_FILE, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC,
                     0o644)
    except OSError as exc:
        if exc.errno != errno.ELOOP:
            raise
        raise InputError("out", str(LinkRefused(out / LOCK_FILE, os.readlink(out / LOCK_FILE)))
                         ) from None
    with open(fd, "r+", encoding="ascii") as handle:
        try:
            fcntl.lockf(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            if exc.errno not in (errno.EAGAIN, errno.EACCES):
                raise
            raise InputError("out", f"{out} is in use by another hypate run (pid "
                             f"{_holder(handle)}); wait for it or choose another --out"
                             ) from None
        handle.seek(0)
        handle.truncate()
        handle.write(str(os.getpid()))
        handle.flush()
        try:
            yield
        finally:
            fcntl.lockf(handle, fcntl.LOCK_UN)


def record_campaign(store: EvaluationStore, identity: dict[str, Any], study: Study) -> None:
    """Write the identity (once; a resumed store already holds the same), the report's
    pointers to the study (``study_path``, ``study``) and the numerical environment
    (:data:`ENVIRONMENTS`, appended when it differs from the last one recorded)."""
    try:
        stored = store.get_meta("campaign")
        # a resumed run keeps the identity it was started with where only the ROM's path
        # differs (found from another working directory; the content hash is the same)
        if not (isinstance(stored, dict) and _comparable(stored) == _comparable(identity)):
            store.set_meta("campaign", identity)
            store.set_meta("fingerprint", fingerprint(identity))
        if study.path != "<memory>":
            store.set_meta("study_path", str(Path(study.path).resolve()), replace=True)
        store.set_meta("study", study.name, replace=True)
        env = runtime_environment()
        # the JSON list of environments written here (get_meta: any JSON value)
        seen = cast("list[Any]", store.get_meta(ENVIRONMENTS) or [])
        if not seen or seen[-1] != env:
            store.set_meta(ENVIRONMENTS, [*seen, env], replace=True)
    except (ValueError, sqlite3.Error) as exc:
        raise InputError("resume", str(exc)) from None
