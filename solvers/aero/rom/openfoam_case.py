"""OpenFOAM case of one fluid-ROM snapshot: the deformed, heated wall in a 2-D channel of air.

The CFD counterpart of the RANS snapshots of Sec. 2.2 / 7.1 (Fig. 7.2: a structured mesh
over the rigid plate ahead of the panel and the panel itself, wall-normal spacing graded
towards the wall), written for OpenFOAM's density-based ``rhoCentralFoam`` (central-upwind
fluxes of Kurganov and Tadmor, local time stepping to the steady state).

:class:`CaseSpec` says what is solved -- the wall as two polylines (the rigid plate of
length ``L_le`` and the panel; the panel's shape is the blockMesh ``polyLine`` edge of its
block, so the deformed wall needs no mesh motion), the free stream, the wall temperature,
the flow model (``"euler"``, ``"laminar"``, ``"spalart-allmaras"``) and the
:class:`Resolution`; :func:`write_case` writes the case folder from the template files of
the package (``hypate/solvers/data/openfoam``: the dictionaries are data, only the numbers
and the mesh are generated here).

Blocks (x streamwise, y wall-normal, one cell in z; front and back ``empty``):
an optional ``upstream`` block ahead of the leading edge (symmetry plane below: the viscous
cases start the boundary layer at a sharp leading edge inside the domain), the ``plate``
block and the ``panel`` block; ``inlet`` and ``top`` carry the free stream, ``outlet`` is a
supersonic outflow (zero gradient).
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from string import Template

import numpy as np
from hypate.solvers.aero.base import Array
from hypate.solvers.errors import InputError
from hypate.solvers.flow import SUTHERLAND_BETA, SUTHERLAND_S, FlowCondition

__all__ = ["FLOW_MODELS", "MOLAR_GAS_CONSTANT", "CaseSpec", "Resolution", "eucken_prandtl",
           "first_cell_grading", "write_case"]

#: The flow models of ``[source] model`` (public keys).
FLOW_MODELS = ("euler", "laminar", "spalart-allmaras")
#: OpenFOAM's universal gas constant (J/(kmol K)): the molar mass written for the specie
#: gives back hypate's gas constant R exactly.
MOLAR_GAS_CONSTANT = 8314.47
#: Field files of the ``0/`` folder and dictionaries of ``constant/`` and ``system/``.
_FIELDS = ("U", "p", "T", "nut", "nuTilda", "alphat")
_CONSTANT = ("thermophysicalProperties", "turbulenceProperties")
_SYSTEM = ("controlDict", "fvSchemes", "fvSolution")
#: Spalart-Allmaras free-stream nuTilda in units of the laminar kinematic viscosity (the
#: usual fully turbulent inflow value, 3-5 nu).
_NU_TILDA_RATIO = 3.0


@dataclass(frozen=True)
class Resolution:
    """Mesh and pseudo-time settings of a case (the ``[source]`` resolution keys).

    Attributes
    ----------
    cells_panel : int
        Streamwise cells on the panel.
    cells_plate : int
        Streamwise cells on the rigid plate.
    cells_normal : int
        Wall-normal cells.
    wall_cell : float
        Height of the first cell at the wall (m).
    height : float
        Domain height in units of the wall length ``L_le + a`` (must clear the leading-edge
        shock at the outlet).
    upstream : float
        Length of the block ahead of the leading edge, in units of ``L_le`` (0: none).
    courant : float
        Local Courant number of the local time stepping (<= 0.2 Euler, <= 0.1 viscous).
    smoothing : float
        ``rDeltaTSmoothingCoeff`` of the local time step.
    max_iterations : int
        Pseudo-time iterations before a snapshot is declared unconverged.
    sample_every : int
        Iterations between two samples of the wall averages and distributions.
    window : int
        Samples over which convergence is judged and the distributions averaged.
    tolerance : float
        Largest relative drift of the wall averages over the window (convergence).
    """

    cells_panel: int = 128
    cells_plate: int = 64
    cells_normal: int = 60
    wall_cell: float = 5e-4
    height: float = 0.5
    upstream: float = 0.0
    courant: float = 0.2
    smoothing: float = 0.2
    max_iterations: int = 20000
    sample_every: int = 50
    window: int = 20
    tolerance: float = 5e-4

    def as_dict(self) -> dict[str, float]:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


@dataclass(frozen=True)
class CaseSpec:
    """One snapshot case.

    Attributes
    ----------
    plate, panel : ndarray of shape (k, 2)
        The wall as (x, y) polylines (m), leading edge of the plate at x = 0; the panel
        starts where the plate ends.
    flow : FlowCondition
        Free stream.
    wall_temperature : float
        Uniform wall temperature (K); ignored by the Euler model (adiabatic slip wall).
    model : {"euler", "laminar", "spalart-allmaras"}
    resolution : Resolution
    """

    plate: Array
    panel: Array
    flow: FlowCondition
    wall_temperature: float
    model: str = "euler"
    resolution: Resolution = field(default_factory=Resolution)

    @property
    def viscous(self) -> bool:
        return self.model != "euler"

    @property
    def length(self) -> float:
        """Streamwise length of the wall, ``L_le + a`` (m)."""
        return float(self.panel[-1, 0])


def eucken_prandtl(gamma: float) -> float:
    """Prandtl number of OpenFOAM's Sutherland transport, whose conductivity is the modified
    Eucken law ``kappa = mu c_v (1.32 + 1.77 R / c_v)``: ``Pr = gamma / (1.32 + 1.77 (gamma
    - 1))`` (0.690 for air; hypate's own models use 0.72)."""
    return gamma / (1.32 + 1.77 * (gamma - 1.0))


def first_cell_grading(height: float, first: float, cells: int) -> float:
    """blockMesh ``simpleGrading`` (last cell / first cell) of ``cells`` cells over
    ``height`` whose first cell is ``first`` high (geometric progression)."""
    if cells < 2 or first * cells >= height:
        return 1.0
    # sum_{k<n} first r^k = height: r from bisection on the monotone geometric sum
    lo, hi = 1.0 + 1e-12, 2.0
    while first * (hi**cells - 1.0) / (hi - 1.0) < height:
        hi *= 2.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if first * (mid**cells - 1.0) / (mid - 1.0) < height:
            lo = mid
        else:
            hi = mid
    return float(lo ** (cells - 1))


def _template(name: str) -> Template:
    return Template(resources.files("hypate.solvers").joinpath("data", "openfoam", name)
                    .read_text(encoding="utf-8"))


def _points(xy: Array) -> str:
    return " ".join(f"({x:.10g} {y:.10g} 0)" for x, y in xy)


def _block_mesh(spec: CaseSpec) -> str:
    """blockMeshDict: upstream (optional), plate and panel blocks over the wall polylines."""
    r = spec.resolution
    L = spec.length
    H = r.height * L
    z = 0.01 * L
    l_le = float(spec.plate[-1, 0])
    grading = first_cell_grading(H, r.wall_cell, r.cells_normal)
    # the wall's x stations of the block corners and their wall heights
    xs = [0.0, l_le, L]
    ys = [float(spec.plate[0, 1]), float(spec.plate[-1, 1]), float(spec.panel[-1, 1])]
    cells = [r.cells_plate, r.cells_panel]
    patches = ["plate", "panel"]
    edges = [spec.plate, spec.panel]
    if r.upstream > 0.0:
        x_up = -r.upstream * l_le
        xs.insert(0, x_up)
        ys.insert(0, ys[0])
        # the upstream cells about as long as the plate's first ones
        cells.insert(0, max(2, int(round(r.upstream * r.cells_plate))))
        patches.insert(0, "upstream")
        edges.insert(0, np.array([[x_up, ys[0]], [0.0, ys[0]]]))
    n = len(xs)
    verts = ([(x, y, 0.0) for x, y in zip(xs, ys)] + [(x, H, 0.0) for x in xs]
             + [(x, y, z) for x, y in zip(xs, ys)] + [(x, H, z) for x in xs])
    lines = ["FoamFile { version 2.0; format ascii; class dictionary; object blockMeshDict; }",
             "convertToMeters 1;", "vertices", "("]
    lines += [f"    ({x:.10g} {y:.10g} {zz:.10g})" for x, y, zz in verts]
    lines += [");", "blocks", "("]
    for b in range(n - 1):
        v = (b, b + 1, n + b + 1, n + b, 2 * n + b, 2 * n + b + 1, 3 * n + b + 1, 3 * n + b)
        lines.append(f"    hex ({' '.join(map(str, v))}) ({cells[b]} {r.cells_normal} 1) "
                     f"simpleGrading (1 {grading:.10g} 1)")
    lines += [");", "edges", "("]
    for b, poly in enumerate(edges):
        inner = poly[1:-1]
        if inner.shape[0]:
            lines.append(f"    polyLine {b} {b + 1} ({_points(inner)})")
            back = np.column_stack([inner, np.full(inner.shape[0], z)])
            lines.append(f"    polyLine {2 * n + b} {2 * n + b + 1} ("
                         + " ".join(f"({x:.10g} {y:.10g} {zz:.10g})" for x, y, zz in back)
                         + ")")
    lines += [");", "boundary", "("]

    def patch(name: str, kind: str, faces: Sequence[tuple[int, ...]]) -> None:
        lines.append(f"    {name} {{ type {kind}; faces ("
                     + " ".join(f"({' '.join(map(str, f))})" for f in faces) + "); }")

    patch("inlet", "patch", [(0, 2 * n, 3 * n, n)])
    patch("outlet", "patch", [(n - 1, n + n - 1, 3 * n + n - 1, 2 * n + n - 1)])
    patch("top", "patch", [(n + b, n + b + 1, 3 * n + b + 1, 3 * n + b) for b in range(n - 1)])
    for b, name in enumerate(patches):
        kind = "symmetryPlane" if name == "upstream" else "wall"
        patch(name, kind, [(b, 2 * n + b, 2 * n + b + 1, b + 1)])
    front = [(b, b + 1, n + b + 1, n + b) for b in range(n - 1)]
    back_faces = [(2 * n + b, 3 * n + b, 3 * n + b + 1, 2 * n + b + 1) for b in range(n - 1)]
    patch("frontAndBack", "empty", front + back_faces)
    lines += [");", "mergePatchPairs ();", ""]
    return "\n".join(lines)


def _values(spec: CaseSpec) -> dict[str, str]:
    """The numbers the templates are filled with."""
    f, r = spec.flow, spec.resolution
    cp = f.gamma * f.gas_constant / (f.gamma - 1.0)
    viscous = spec.viscous
    nu_inf = f.viscosity / f.density
    end = r.max_iterations
    return {
        "end_time": str(end), "courant": f"{r.courant:g}", "smoothing": f"{r.smoothing:g}",
        "sample_every": str(r.sample_every),
        "transport": "sutherland" if viscous else "const",
        "transport_coeffs": (f"As {SUTHERLAND_BETA:.10g}; Ts {SUTHERLAND_S:.10g};" if viscous
                             else "mu 0; Pr 1;"),
        "mol_weight": f"{MOLAR_GAS_CONSTANT / f.gas_constant:.10g}", "cp": f"{cp:.10g}",
        "simulation_type": "RAS" if spec.model == "spalart-allmaras" else "laminar",
        "u_inf": f"{f.velocity:.10g}", "p_inf": f"{f.pressure:.10g}",
        "t_inf": f"{f.temperature:.10g}",
        "nu_tilda": f"{_NU_TILDA_RATIO * nu_inf:.10g}" if spec.model == "spalart-allmaras"
        else "0",
        "wall_u": "type noSlip;" if viscous else "type slip;",
        "wall_t": (f"type fixedValue; value uniform {spec.wall_temperature:.10g};" if viscous
                   else "type zeroGradient;"),
    }


def write_case(folder: str | Path, spec: CaseSpec) -> Path:
    """Write the OpenFOAM case of ``spec`` into ``folder`` (created; existing files of the
    same names are replaced). Returns the folder."""
    if spec.model not in FLOW_MODELS:
        raise InputError("source.model", f"must be one of {', '.join(FLOW_MODELS)}")
    if spec.viscous and not spec.wall_temperature > 0.0:
        raise InputError("wall_temperature", "must be > 0 K")
    if spec.panel[0, 0] != spec.plate[-1, 0] or spec.plate[0, 0] != 0.0:
        raise InputError("wall", "the plate starts at x = 0 and the panel where it ends")
    if np.any(np.diff(spec.plate[:, 0]) <= 0) or np.any(np.diff(spec.panel[:, 0]) <= 0):
        raise InputError("wall", "the wall's x must increase along each polyline")
    folder = Path(folder)
    values = _values(spec)
    for sub, names in (("0", _FIELDS), ("constant", _CONSTANT), ("system", _SYSTEM)):
        (folder / sub).mkdir(parents=True, exist_ok=True)
        for name in names:
            if sub == "0" and name in ("nut", "nuTilda", "alphat") and not spec.viscous:
                continue
            text = _template(name).substitute(values)
            (folder / sub / name).write_text(text, encoding="utf-8")
    (folder / "system" / "blockMeshDict").write_text(_block_mesh(spec), encoding="utf-8")
    return folder


def wedge_wall(angle_deg: float, l_le: float = 1.0, a: float = 1.0) -> tuple[Array, Array]:
    """Plate and panel polylines of a straight ramp of ``angle_deg`` from the leading edge:
    the wedge of the oblique-shock check."""
    t = math.tan(math.radians(angle_deg))
    return (np.array([[0.0, 0.0], [l_le, t * l_le]]),
            np.array([[l_le, t * l_le], [l_le + a, t * (l_le + a)]]))
