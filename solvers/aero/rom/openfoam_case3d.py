"""A 3-D OpenFOAM Euler case of a deformed panel in a flat wall: the check of the strip-wise
2-D ROM (issue "CFD-grade fluid loads"; Secs. 2.2, 8.3, 9.2).

The 2-D snapshots of :mod:`.openfoam_case` are applied to a 3-D panel strip by strip
(:class:`~hypate.solvers.aero.rom.model.RomFluid`); this case gives the 3-D inviscid wall
pressure of the same deformed panel to measure what the strips miss (the spanwise relief of
the flow around a deflection of finite span).

Geometry (x streamwise, y spanwise, z normal to the wall): the free stream enters at
``x = 0`` over a rigid flat wall of length ``L_le`` ahead of the panel ``[L_le, L_le + a] x
[0, b]``; beside the panel the wall continues flat for ``margin`` to a symmetry plane
(``side``). A deformation symmetric about the panel's centre line (modes ``sin(m pi x / a)
sin(n pi y / b)`` with odd ``n``) may be solved on the half span: a symmetry plane
(``centre``) at ``y = b / 2``. Four hex blocks (plate / panel by panel span / margin),
graded towards the wall; blockMesh meshes the flat wall and the points are then moved
normal to it by ``w(x, y) (1 - z / H)`` (the deformed wall exactly at the mesh's bottom
face, the top of the domain left flat): no mesh motion in the solver.

:func:`write_case_3d` writes the case with the same template dictionaries as the 2-D cases
(``hypate/solvers/data/openfoam``); :func:`deform_points` moves the mesh after blockMesh
(``run_case(..., after_mesh=...)``), whose wall samples then hold the panel's faces with
their ``(x, y)`` centres.
"""
from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from hypate.solvers.aero.base import Array
from hypate.solvers.aero.rom.openfoam_case import (
    CaseSpec,
    Resolution,
    first_cell_grading,
    write_case,
)
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition

__all__ = ["PanelCase3D", "deform_points", "panel_deflection", "write_case_3d"]


@dataclass(frozen=True)
class PanelCase3D:
    """One 3-D Euler case.

    Attributes
    ----------
    length, width, leading_edge_length : float
        a, b, L_le (m).
    modes : ndarray of int, shape (k, 2)
        (m, n) half-wave numbers of the deformation ``w = sum_k A_k sin(m pi x / a)
        sin(n pi y / b)``.
    amplitudes : ndarray of shape (k,)
        A_k (m).
    flow : FlowCondition
    cells_plate, cells_panel, cells_span, cells_margin, cells_normal : int
        Cells along the plate and the panel (x), the panel's span (y; half of it with
        ``half_span``), the margin beside it (y) and normal to the wall (z).
    margin : float
        Flat wall beside the panel (m).
    height : float
        Domain height H (m).
    wall_cell : float
        First cell at the wall (m).
    half_span : bool
        Solve ``y >= b / 2`` with a symmetry plane at the centre line (needs a deformation
        symmetric about it: odd ``n``).
    resolution : Resolution
        Pseudo-time settings (courant, smoothing, sample_every, window, tolerance,
        max_iterations; the 2-D mesh counts are not used).
    """

    length: float
    width: float
    leading_edge_length: float
    modes: np.ndarray
    amplitudes: np.ndarray
    flow: FlowCondition
    cells_plate: int = 8
    cells_panel: int = 48
    cells_span: int = 24
    cells_margin: int = 8
    cells_normal: int = 30
    margin: float = 0.25
    height: float = 0.6
    wall_cell: float = 2e-3
    half_span: bool = True
    resolution: Resolution = Resolution()

    @property
    def n_cells(self) -> int:
        return ((self.cells_plate + self.cells_panel) * (self.cells_span + self.cells_margin)
                * self.cells_normal)


def panel_deflection(case: PanelCase3D, x: Array, y: Array) -> Array:
    """``w(x, y)`` (m) at panel coordinates (x from the panel's leading edge); zero off the
    panel."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    m = np.asarray(case.modes)[:, 0].astype(float)
    n = np.asarray(case.modes)[:, 1].astype(float)
    on = (x >= 0.0) & (x <= case.length) & (y >= 0.0) & (y <= case.width)
    xs = np.clip(x, 0.0, case.length)[..., None] / case.length
    ys = np.clip(y, 0.0, case.width)[..., None] / case.width
    w = (np.sin(m * np.pi * xs) * np.sin(n * np.pi * ys)) @ np.asarray(case.amplitudes, float)
    return np.where(on, w, 0.0)


def _block_mesh(case: PanelCase3D) -> str:
    """blockMeshDict of the flat wall: blocks (plate, panel) x (panel span, margin)."""
    a, b, L = case.length, case.width, case.leading_edge_length
    xs = [0.0, L, L + a]
    y0 = 0.5 * b if case.half_span else 0.0
    ys = [y0, b, b + case.margin]
    H = case.height
    nx = [case.cells_plate, case.cells_panel]
    ny = [case.cells_span, case.cells_margin]
    grading = first_cell_grading(H, case.wall_cell, case.cells_normal)

    def v(i: int, j: int, k: int) -> int:  # vertex index of (x_i, y_j, z_k)
        return k * 9 + j * 3 + i

    verts = [(x, y, z) for z in (0.0, H) for y in ys for x in xs]
    lines = ["FoamFile { version 2.0; format ascii; class dictionary; object blockMeshDict; }",
             "convertToMeters 1;", "vertices", "("]
    lines += [f"    ({x:.10g} {y:.10g} {z:.10g})" for x, y, z in verts]
    lines += [");", "blocks", "("]
    for j in range(2):
        for i in range(2):
            hexv = (v(i, j, 0), v(i + 1, j, 0), v(i + 1, j + 1, 0), v(i, j + 1, 0),
                    v(i, j, 1), v(i + 1, j, 1), v(i + 1, j + 1, 1), v(i, j + 1, 1))
            lines.append(f"    hex ({' '.join(map(str, hexv))}) ({nx[i]} {ny[j]} "
                         f"{case.cells_normal}) simpleGrading (1 1 {grading:.10g})")
    lines += [");", "edges ();", "boundary", "("]

    def quad(face: tuple[int, ...]) -> str:
        return f"({' '.join(map(str, face))})"

    def patch(name: str, kind: str, faces: Sequence[tuple[int, ...]]) -> None:
        lines.append(f"    {name} {{ type {kind}; faces ({' '.join(quad(f) for f in faces)}); }}")

    bottom = {(i, j): (v(i, j, 0), v(i, j + 1, 0), v(i + 1, j + 1, 0), v(i + 1, j, 0))
              for i in range(2) for j in range(2)}
    patch("panel", "wall", [bottom[(1, 0)]])
    patch("plate", "wall", [bottom[(0, 0)], bottom[(0, 1)], bottom[(1, 1)]])
    patch("top", "patch", [(v(i, j, 1), v(i + 1, j, 1), v(i + 1, j + 1, 1), v(i, j + 1, 1))
                           for i in range(2) for j in range(2)])
    patch("inlet", "patch", [(v(0, j, 0), v(0, j, 1), v(0, j + 1, 1), v(0, j + 1, 0))
                             for j in range(2)])
    patch("outlet", "patch", [(v(2, j, 0), v(2, j + 1, 0), v(2, j + 1, 1), v(2, j, 1))
                              for j in range(2)])
    patch("side", "symmetryPlane", [(v(i, 2, 0), v(i, 2, 1), v(i + 1, 2, 1), v(i + 1, 2, 0))
                                    for i in range(2)])
    low = [(v(i, 0, 0), v(i + 1, 0, 0), v(i + 1, 0, 1), v(i, 0, 1)) for i in range(2)]
    patch("centre" if case.half_span else "sideLow", "symmetryPlane", low)
    lines += [");", "mergePatchPairs ();", ""]
    return "\n".join(lines)


def write_case_3d(folder: str | Path, case: PanelCase3D) -> Path:
    """Write the 3-D Euler case into ``folder``: the 2-D case's templates (free stream,
    slip walls, function objects on the ``panel`` patch) and this module's blockMeshDict.
    Run blockMesh, then :func:`deform_points`, then the solver."""
    if np.any(np.asarray(case.modes)[:, 1] % 2 == 0) and case.half_span:
        raise InputError("modes", "a half-span case needs modes symmetric about the centre "
                         "line (odd n)")
    # the 2-D writer fills the templates (Euler: slip walls, no wall temperature); its
    # blockMeshDict is replaced by the 3-D one
    L = case.leading_edge_length
    dummy = CaseSpec(np.array([[0.0, 0.0], [L, 0.0]]),
                     np.array([[L, 0.0], [L + case.length, 0.0]]), case.flow, 300.0, "euler",
                     case.resolution)
    folder = write_case(folder, dummy)
    (folder / "system" / "blockMeshDict").write_text(_block_mesh(case), encoding="utf-8")
    return folder


_POINT = re.compile(r"\(([-+0-9.eE]+) ([-+0-9.eE]+) ([-+0-9.eE]+)\)")


def deform_points(folder: str | Path, case: PanelCase3D) -> float:
    """Move the meshed flat wall's points to the deformed panel: ``z += w(x, y) (1 - z/H)``
    (constant/polyMesh/points, ASCII). Returns the largest ``|w|`` applied (m)."""
    path = Path(folder) / "constant" / "polyMesh" / "points"
    text = path.read_text(encoding="utf-8")
    start = text.index("(", text.index("\n", text.index("}")))  # after the header's count
    head, body = text[:start], text[start:]
    P = np.array(_POINT.findall(body), float)
    w = panel_deflection(case, P[:, 0] - case.leading_edge_length, P[:, 1])
    P[:, 2] += w * (1.0 - P[:, 2] / case.height)
    pts = "\n".join(f"({x:.12g} {y:.12g} {z:.12g})" for x, y, z in P)
    path.write_text(f"{head}(\n{pts}\n)\n", encoding="utf-8")
    return float(np.max(np.abs(w)))
