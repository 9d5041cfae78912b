"""The fluid-model factory: ``[simulation] aero`` / ``heating`` names -> a FluidModel.

The one list of aero-model names (case files, study files and the CLI validate against
:data:`AERO_NAMES`); each fidelity lives in its own module and none knows this one.
"""
from __future__ import annotations

from pathlib import Path

from hypate.solvers.aero.analytic import AnalyticFluid
from hypate.solvers.aero.base import FluidModel
from hypate.solvers.aero.rom.io import load_rom
from hypate.solvers.aero.shock_expansion import ShockExpansionFluid
from hypate.solvers.errors import InputError

#: Analytic models: name -> (pressure model, effective shape of the boundary layer).
ANALYTIC_AERO = {"pt": ("pt", False), "pt1": ("pt1", False), "pt3": ("pt3", False),
                 "ls": ("ls", False), "pt-bl": ("pt", True)}
#: Every fixed name accepted by ``[simulation] aero``; ``"rom:PATH"`` loads a ROM file.
AERO_NAMES: tuple[str, ...] = (*ANALYTIC_AERO, "se")
ROM_PREFIX = "rom:"


def is_aero_name(aero: str) -> bool:
    """Whether ``aero`` names a fluid model (a fixed name or ``rom:PATH``)."""
    return aero in AERO_NAMES or (aero.startswith(ROM_PREFIX) and len(aero) > len(ROM_PREFIX))


def make_fluid_model(aero: str, heating: str = "eckert", regime: str = "turbulent"
                     ) -> FluidModel:
    """A fluid model from the config names (``[simulation] aero``, ``heating``)."""
    if aero in ANALYTIC_AERO:
        pressure, eff = ANALYTIC_AERO[aero]
        return AnalyticFluid(pressure, eff, heating, regime)
    if aero == "se":
        return ShockExpansionFluid(boundary_layer=True, heating=heating, regime=regime)
    if aero.startswith(ROM_PREFIX):
        if not aero[len(ROM_PREFIX):]:
            raise InputError("simulation.aero", "'rom:PATH' needs the path of a ROM file")
        return load_rom(aero[len(ROM_PREFIX):], regime=regime)
    raise InputError("simulation.aero", f"must be one of {', '.join(AERO_NAMES)} or "
                     f"'rom:PATH'; got {aero!r}")


def check_fluid_model(aero: str, field: str = "simulation.aero") -> None:
    """Check the file an ``aero = "rom:PATH"`` names exists and loads (the path taken as
    :func:`make_fluid_model` takes it, relative to the working directory); fixed names need
    no file. Problems raise :class:`InputError` naming ``field``."""
    if not aero.startswith(ROM_PREFIX):
        return
    path = Path(aero[len(ROM_PREFIX):])
    if not path.exists():
        raise InputError(field, f"ROM file {path} not found")
    try:
        load_rom(path)
    except InputError as exc:
        raise InputError(field, f"ROM file {path}: {exc.message}") from None
