"""Studies derived from a study: its plain data (:func:`study_data`, stored in sweep run
directories and edited by the benchmarks and scripts), the points of its ``[sweep]``
(:func:`sweep_points`, Sec. 9.1.3, 9.2.2, 9.2.4) and the single study of one point
(:func:`study_at`). The study file itself is parsed and checked in :mod:`.study`."""
from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

from hypate.scaling.workflow.vocabulary.shipped import resolve
from hypate.scaling.workflow.vocabulary.study import Study, parse_study
from hypate.scaling.workflow.vocabulary.variables import CATEGORICAL


@dataclasses.dataclass(frozen=True)
class SweepPoint:
    """One point of a ``[sweep]``: a geometric scale and/or a flight condition.

    Attributes
    ----------
    label : str
        Sub-directory name, e.g. ``"xi_2"``, ``"M6_H25km"`` or ``"xi_2_M6_H25km"``.
    xi : float or None
        Geometric scale (None: the study's).
    mach, altitude : float or None
        Prototype flight condition (altitude in m; None: the study's).
    """

    label: str
    xi: float | None = None
    mach: float | None = None
    altitude: float | None = None

    def as_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


def _num(value: float) -> str:
    return f"{value:g}"


def sweep_points(study: Study) -> list[SweepPoint]:
    """The points of a study's ``[sweep]`` in the order they are run
    (:meth:`~hypate.scaling.workflow.vocabulary.study_file.SweepSection.grid`), with their labels. A
    study without ``[sweep]`` has no points."""
    if study.sweep is None:
        return []
    points = []
    for xi, m, h in study.sweep.grid():
        parts = []
        if xi is not None:
            parts.append(f"xi_{_num(xi)}")
        cond = ""
        if m is not None:
            cond += f"M{_num(m)}"
        if h is not None:
            cond += ("_" if cond else "") + f"H{_num(h / 1000.0)}km"
        if cond:
            parts.append(cond)
        points.append(SweepPoint(label="_".join(parts), xi=xi, mach=m, altitude=h))
    return points


def study_data(study: Study) -> dict[str, Any]:
    """The study as a plain dict that :func:`parse_study` accepts anywhere (the prototype
    case path and a user's simulator file made absolute, a ``rom:`` fluid model as the
    study found it); stored in sweep
    run directories to rebuild sub-studies."""
    data = study.raw.model_dump(mode="json", exclude_none=True)
    for name in CATEGORICAL:  # the template's default would clash with the variable
        if name in data["variables"]:
            data["model"].pop(name, None)
    base = Path(study.path).parent if study.path != "<memory>" else Path.cwd()
    data["prototype"]["case"] = str(resolve(data["prototype"]["case"], "case", base).resolve())
    data["simulation"]["aero"] = study.spec.prototype.simulation.aero  # a ROM as found
    if study.spec.simulator is not None:  # a user's simulator file as found (absolute)
        data["simulation"]["simulator"] = study.spec.simulator
    return data


def study_at(study: Study | dict[str, Any], point: SweepPoint | None = None, *,
             xi: float | None = None, first: bool = True) -> Study:
    """The single study of one sweep point (no ``[sweep]`` table).

    Parameters
    ----------
    study : Study or dict
        The sweep study (or its :func:`study_data`).
    point : SweepPoint, optional
    xi : float, optional
        Geometric scale (overrides the point's), e.g. for a law prediction.
    first : bool
        False: the budget of the later points (``sweep.initial_samples``/``iterations``).
    """
    data = study_data(study) if isinstance(study, Study) else dict(study)
    data = {k: (dict(v) if isinstance(v, dict) else v) for k, v in data.items()}
    sw = data.pop("sweep", None) or {}
    scale = xi if xi is not None else (point.xi if point is not None else None)
    if scale is not None:
        data.setdefault("study", {})["xi"] = float(scale)
    if point is not None:
        if point.mach is not None:
            data["prototype"]["mach"] = float(point.mach)
        if point.altitude is not None:
            data["prototype"]["altitude"] = float(point.altitude)
        data.setdefault("study", {})["name"] = (f"{data.get('study', {}).get('name', 'study')}"
                                                f" [{point.label}]")
    sub = parse_study(data, study.path if isinstance(study, Study) else "<memory>")
    if not first:
        update = {}
        if sw.get("initial_samples") is not None:
            update["initial_samples"] = int(sw["initial_samples"])
        if sw.get("iterations") is not None:
            update["iterations"] = int(sw["iterations"])
        if update:
            sub = dataclasses.replace(sub, optimizer=sub.optimizer.model_copy(update=update))
    return sub



__all__ = ["SweepPoint", "study_at", "study_data", "sweep_points"]
