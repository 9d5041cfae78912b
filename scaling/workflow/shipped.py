"""The files hypate ships: the product's defaults (package data of ``hypate.scaling``:
the quick-start study and its prototype case) and the examples and reproductions of
``hypate.studies`` (``cases/``, ``optimization/``, ``rom/``).

A command-line path or a study's ``prototype.case`` may name a shipped file by its stem
(``quickstart``, ``sec9_2_2_xi4``, ``sec9_2_prototype``); a path under ``studies/`` that no
longer exists (the layout before the files moved into sub-folders by kind) resolves to the
shipped file of the same stem, so the commands of earlier READMEs keep working.
"""
from __future__ import annotations

from importlib import resources
from pathlib import Path

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


def default_study() -> Path:
    """The quick-start study, the embedded default of ``hypate run``."""
    return shipped("study")["quickstart"]
