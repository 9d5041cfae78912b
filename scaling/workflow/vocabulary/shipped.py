"""The files hypate ships: the product's defaults (package data of ``hypate.scaling``:
the quick-start study and its prototype case) and the examples and reproductions of
``hypate.studies`` (``cases/``, ``optimization/``, ``rom/``).

A command-line path or a study's ``prototype.case`` may name a shipped file by its stem
(``quickstart``, ``sec9_2_2_xi4``, ``sec9_2_prototype``); a path under ``studies/`` that no
longer exists (the layout before the files moved into sub-folders by kind) resolves to the
shipped file of the same stem, so the commands of earlier READMEs keep working. A study's
``aero = "rom:PATH"`` that does not exist from the working directory resolves against the
study's folder, then to the shipped ROM of that file name (:func:`resolve_aero`).
"""
from __future__ import annotations

from importlib import resources
from pathlib import Path

from hypate.solvers.aero.factory import ROM_PREFIX

#: Where each kind of shipped file lives: (package, sub-folder).
_PLACES: dict[str, tuple[tuple[str, str], ...]] = {
    "study": (("hypate.scaling", "data"), ("hypate.studies", "optimization")),
    "case": (("hypate.scaling", "data/cases"), ("hypate.studies", "cases")),
    "rom": (("hypate.studies", "rom"),),
}


#: Shipped data files beside the quick-start study that are not studies.
DATA_FILES = ("tunnels.toml", "best_known.toml")


def shipped(kind: str) -> dict[str, Path]:
    """Shipped files of one kind (``"study"``, ``"case"``, ``"rom"``) by stem."""
    found: dict[str, Path] = {}
    for package, folder in _PLACES[kind]:
        root = Path(str(resources.files(package))).joinpath(folder)
        for path in sorted(root.glob("*.toml")):
            if kind != "study" or path.name not in DATA_FILES:
                found.setdefault(path.stem, path)
    return found


def resolve(arg: str | Path, kind: str, base: Path | None = None) -> Path:
    """The file ``arg`` names: an existing path (relative to ``base`` when given), else a
    shipped file of that stem when ``arg`` is a bare name or a moved ``studies/`` path;
    otherwise the path as given (the loader then reports it missing)."""
    path = Path(arg)
    full = path if path.is_absolute() or base is None else base / path
    if full.exists():
        return full
    bare = path.parent == Path(".") and path.suffix == ""
    moved = path.parts[:1] == ("studies",)
    if bare or moved:
        match = shipped(kind).get(path.stem)
        if match is not None:
            return match
    return full


def resolve_aero(aero: str, base: Path | None = None) -> str:
    """``[simulation] aero`` with a ``rom:PATH`` that names an existing file: ``PATH`` as
    given (relative to the working directory, the rule of case files), else relative to
    ``base`` (the study file's folder), else the shipped ROM of that file name
    (``hypate.studies/rom``), so that a shipped study finds its shipped ROM from any
    working directory. Fixed model names, and paths found nowhere, come back unchanged
    (the loader then reports the missing file)."""
    if not aero.startswith(ROM_PREFIX):
        return aero
    path = Path(aero[len(ROM_PREFIX):])
    if path.exists():
        return aero
    if base is not None and not path.is_absolute() and (base / path).exists():
        return ROM_PREFIX + str((base / path).resolve())
    for package, folder in _PLACES["rom"]:
        candidate = Path(str(resources.files(package))).joinpath(folder, path.name)
        if candidate.is_file():
            return ROM_PREFIX + str(candidate)
    return aero


def default_study() -> Path:
    """The quick-start study, the embedded default of ``hypate run``."""
    return shipped("study")["quickstart"]
