"""The similarity errors of a scaling problem: the nondimensional histories of a response and
their relative RMS differences J against the prototype's (Eqs. 6.4, 9.8).

Objectives (Eq. 6.4), written as relative RMS errors over the time samples so that 0.1
reads "10 %":

* ``J_u``: nondimensional deflection -- centre deflection / thickness (``projection =
  "center"``, Sec. 9.2.1.1), the sinusoidal modal coordinates / thickness (``"modal"``), or
  the whole nodal displacement field nondimensionalized as in Eq. (3.17b) --
  ``(u, v, w) / h`` and ``(psi_x, psi_y) L / h`` -- with the in-plane ``(u, v)``, transverse
  ``w`` and rotation fields weighted equally (``"fields"``: the in-plane field, which scales
  with ``h / L`` at matched ``lambda_F`` and thermal load, makes the thickness identifiable;
  both meshes must have the same node grid);
* ``J_T``: volume-mean temperature / stagnation temperature (Sec. 9.2.1.1);
* ``J_s = sqrt(J_u^2 + J_T^2)`` (Eq. 9.8) for single-objective studies.
"""
from __future__ import annotations

import math

import numpy as np
from hypate.solvers.coupling.response import Response

#: Projections of the structural response for J_u.
PROJECTIONS = ("center", "modal", "fields")
#: DOF groups of the "fields" projection (DOF order u, v, w, psi_x, psi_y per node).
FIELD_GROUPS = {"in-plane": (0, 1), "transverse": (2,), "rotation": (3, 4)}


class ModelFailure(RuntimeError):
    """The model simulation did not produce a response comparable to the prototype's."""


def _series(resp: Response, projection: str) -> np.ndarray:
    """Nondimensional deflection history (n_t, k): modal coordinates or centre w / h."""
    if projection == "modal":
        return np.asarray(resp.modal)
    return np.asarray(resp.center_deflection)[:, None] / resp.thickness


def relative_rms(model: np.ndarray, prototype: np.ndarray) -> float:
    """``||model - prototype|| / ||prototype||`` over all samples (Eq. 6.4, normalized)."""
    num = float(np.linalg.norm(np.asarray(model) - np.asarray(prototype)))
    den = float(np.linalg.norm(prototype))
    return num / den if den > 0.0 else num


def _field_series(resp: Response) -> np.ndarray:
    """Nodal displacements nondimensionalized by Eq. (3.17b), shape (n_t, n_nodes, 5)."""
    if not resp.u:
        raise ModelFailure("the 'fields' projection needs the displacement fields "
                           "(keep_fields)")
    U = np.asarray(resp.u, dtype=float)
    U = U.reshape(len(U), -1, 5) / resp.thickness
    U[..., 3:] *= resp.length
    return U


def response_series(resp: Response, projection: str = "center") -> dict[str, np.ndarray]:
    """The nondimensional histories J compares, by name: ``"u"`` (centre w / h or modal
    coordinates; for ``"fields"`` one entry per :data:`FIELD_GROUPS` group instead) and
    ``"T"`` (volume-mean temperature / stagnation temperature), each (n_t, ...)."""
    if projection == "fields":
        U = _field_series(resp)
        out = {g: U[..., list(k)] for g, k in FIELD_GROUPS.items()}
    else:
        out = {"u": _series(resp, projection)}
    out["T"] = np.asarray(resp.mean_temperature) / resp.stagnation_temperature
    return out


def history_vector(series: dict[str, np.ndarray], n: int) -> np.ndarray:
    """The ``"u"`` and ``"T"`` series of :func:`response_series` over steps 1 .. n - 1,
    flattened and concatenated: exactly what J compares with the prototype's (a comparable
    model runs at least the prototype's ``n`` steps)."""
    return np.concatenate([np.asarray(series[key], float)[1:n].reshape(-1)
                           for key in ("u", "T")])


def series_errors(model: dict[str, np.ndarray], prototype: dict[str, np.ndarray], n: int
                  ) -> dict[str, float]:
    """J_u, J_T, J_s (Eqs. 6.4, 9.8) of :func:`response_series` over steps 1 .. n - 1."""
    if "u" in prototype:
        J_u = relative_rms(model["u"][1:n], prototype["u"][1:n])
    else:
        errs = [relative_rms(model[g][1:n], prototype[g][1:n]) for g in FIELD_GROUPS]
        J_u = float(np.sqrt(np.mean(np.square(errs))))
    J_T = relative_rms(model["T"][1:n], prototype["T"][1:n])
    return {"J_u": J_u, "J_T": J_T, "J_s": math.hypot(J_u, J_T)}


def response_errors(model: Response, prototype: Response, projection: str = "center"
                    ) -> dict[str, float]:
    """J_u, J_T, J_s (Eqs. 6.4, 9.8) at matched nondimensional times (same step index)."""
    n = min(len(model.times), len(prototype.times))
    sm, sp = response_series(model, projection), response_series(prototype, projection)
    if projection == "fields" and sm["in-plane"].shape[1:] != sp["in-plane"].shape[1:]:
        raise ModelFailure(f"'fields' projection: model and prototype meshes differ "
                           f"({sm['in-plane'].shape[1]} and {sp['in-plane'].shape[1]} nodes)")
    return series_errors(sm, sp, n)
