"""Laminate stiffness, thermal resultants and inertia of a layer stack (Eqs. 3.3-3.9, 3.13).

The stack is described by a :class:`~solvers.panel.PanelSpec` (layers bottom to top,
mid-surface at ``z = 0``). The temperature is given per point at the thermal node levels
``thermal_levels(panel)`` (each layer split into ``sublayers`` equal intervals, temperature
piecewise linear in z between levels), so every integral through the thickness is done per
level interval with Simpson's rule, Eq. (3.9): exact for constant properties and a linear
temperature profile in each interval.

Everything is vectorized over an arbitrary leading shape (nodes, quadrature points, ...);
the only Python loop is over the layers of the stack.

Conventions
-----------
* In-plane strain/stress ordering ``(xx, yy, xy)`` with engineering shear strain.
* Transverse shear ordering ``(xz, yz)``; ``S = kappa * int G dz`` with ``kappa = 5/6``
  (Eq. 3.8b).
* ``N_T``, ``M_T`` are the thermal force and moment resultants from the stress-free
  temperature (the panel's ``initial_temperature``), Eq. (3.8c), using the secant thermal
  strain of :meth:`~solvers.materials.Material.thermal_strain`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from hypate.solvers.errors import InputError
from hypate.solvers.panel import PanelSpec, layer_of_level_interval, thermal_levels
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]

#: Transverse shear correction factor (Eq. 3.8b, pp. 135-136 of Ref. [156]).
SHEAR_CORRECTION = 5.0 / 6.0


def strain_rotation(theta: ArrayLike) -> Array:
    """Strain transformation R (global -> material axes), engineering shear.

    ``eps_material = R @ eps_global`` with ``eps = (xx, yy, xy)``, so the rotated reduced
    stiffness is ``Qbar = R.T @ Q @ R``.

    Parameters
    ----------
    theta : float or ndarray
        Angle of the material 1-axis from the panel x-axis (rad).

    Returns
    -------
    ndarray of shape theta.shape + (3, 3)
    """
    t = np.asarray(theta, dtype=float)
    c, s = np.cos(t), np.sin(t)
    R = np.empty(t.shape + (3, 3))
    R[..., 0, 0] = c * c
    R[..., 0, 1] = s * s
    R[..., 0, 2] = c * s
    R[..., 1, 0] = s * s
    R[..., 1, 1] = c * c
    R[..., 1, 2] = -c * s
    R[..., 2, 0] = -2.0 * c * s
    R[..., 2, 1] = 2.0 * c * s
    R[..., 2, 2] = c * c - s * s
    return R


def shear_rotation(theta: ArrayLike) -> Array:
    """Transverse shear strain transformation: ``(g13, g23) = Rs @ (g_xz, g_yz)``."""
    t = np.asarray(theta, dtype=float)
    c, s = np.cos(t), np.sin(t)
    Rs = np.empty(t.shape + (2, 2))
    Rs[..., 0, 0] = c
    Rs[..., 0, 1] = s
    Rs[..., 1, 0] = -s
    Rs[..., 1, 1] = c
    return Rs


@dataclass(frozen=True)
class LaminateState:
    """Laminate resultant matrices at a set of points (leading shape ``P``).

    Attributes
    ----------
    A, B, D : ndarray of shape P + (3, 3)
        Extensional (N/m), coupling (N) and bending (N m) stiffness, Eq. (3.8a).
    S : ndarray of shape P + (2, 2)
        Transverse shear stiffness (N/m), ordering (xz, yz), Eq. (3.8b).
    NT : ndarray of shape P + (3,)
        Thermal force resultant (N/m), Eq. (3.8c).
    MT : ndarray of shape P + (3,)
        Thermal moment resultant (N), Eq. (3.8c).
    I1, I2, I3 : ndarray of shape P
        Mass moments ``int rho z^(k-1) dz`` (kg/m^2, kg/m, kg), Eq. (3.13).
    """

    A: Array
    B: Array
    D: Array
    S: Array
    NT: Array
    MT: Array
    I1: Array
    I2: Array
    I3: Array

    @property
    def ABD(self) -> Array:
        """The 6 x 6 matrix ``[[A, B], [B, D]]`` of Eq. (3.7), shape P + (6, 6)."""
        top = np.concatenate([self.A, self.B], axis=-1)
        bot = np.concatenate([self.B, self.D], axis=-1)
        return np.concatenate([top, bot], axis=-2)

    @property
    def thermal_resultants(self) -> Array:
        """``(N_T, M_T)`` stacked, shape P + (6,)."""
        return np.concatenate([self.NT, self.MT], axis=-1)


def level_temperatures(panel: PanelSpec, T: ArrayLike | None) -> Array:
    """Normalize a temperature input to shape ``P + (n_levels,)``.

    ``None`` means the initial (stress-free) temperature everywhere; a scalar is uniform; an
    array whose last axis has length ``n_levels`` is a through-thickness profile per point.
    """
    n_levels = thermal_levels(panel).size
    if T is None:
        return np.full((n_levels,), float(panel.initial_temperature))
    arr = np.asarray(T, dtype=float)
    if arr.ndim == 0:
        return np.full((n_levels,), float(arr))
    if arr.shape[-1] != n_levels:
        raise InputError("temperature", f"last axis must have the {n_levels} thermal levels "
                         f"of the panel, got shape {arr.shape}")
    return arr


def _wsum(w: Array, X: Array, lead: int) -> Array:
    """``sum_{m,p} w[m, p] X[..., m, p, ...]`` over the two axes after ``lead`` leading ones
    (sequential sum over the Simpson points, the order of the former einsum)."""
    head = (slice(None),) * lead
    acc = None
    for a in range(w.shape[0]):  # a handful of Simpson points: explicit sequential sum,
        for b in range(w.shape[1]):  # far cheaper than a reduction over a middle axis
            term = X[head + (a, b)] * w[a, b]
            acc = term if acc is None else acc + term
    assert acc is not None  # w has at least one point
    return acc


#: Parts :func:`laminate` can be restricted to.
LAMINATE_PARTS = ("all", "shear", "inertia")


def laminate(panel: PanelSpec, T: ArrayLike | None = None, parts: str = "all") -> LaminateState:
    """A, B, D, S, N_T, M_T, I1..I3 of the panel's stack at the given temperatures.

    Simpson's rule (Eq. 3.9) on every interval between thermal levels: the end points and
    the midpoint, where the temperature is the mean of the end values (linear profile).

    Parameters
    ----------
    panel : PanelSpec
        Layer stack (bottom to top) and the stress-free temperature.
    T : float or ndarray of shape P + (n_levels,), optional
        Temperature (K) at the thermal levels ``thermal_levels(panel)``; default: the
        initial temperature (then ``N_T = M_T = 0``).
    parts : {"all", "shear", "inertia"}
        ``"shear"`` computes only S, ``"inertia"`` only I1..I3 (the other fields are
        zero): the structural model needs S alone at the reduced shear quadrature and the
        mass matrix only the inertia, so they skip the rest.

    Returns
    -------
    LaminateState
        Arrays with leading shape ``P`` (``()`` for a scalar or a single profile).
    """
    if parts not in LAMINATE_PARTS:
        raise ValueError(f"parts must be one of {LAMINATE_PARTS}, got {parts!r}")
    want_abd = parts == "all"
    want_shear = parts in ("all", "shear")
    want_inertia = parts in ("all", "inertia")
    TL = level_temperatures(panel, T)
    P = TL.shape[:-1]
    lead = len(P)
    z = thermal_levels(panel)
    owner = layer_of_level_interval(panel)
    T0 = float(panel.initial_temperature)
    # Simpson points of every interval: (n_int, 3) in z and P + (n_int, 3) in T.
    zs = np.stack([z[:-1], 0.5 * (z[:-1] + z[1:]), z[1:]], axis=-1)
    Ts = np.stack([TL[..., :-1], 0.5 * (TL[..., :-1] + TL[..., 1:]), TL[..., 1:]], axis=-1)
    wts = (z[1:] - z[:-1])[:, None] / 6.0 * np.array([1.0, 4.0, 1.0])  # (n_int, 3)

    A = np.zeros(P + (3, 3))
    B = np.zeros(P + (3, 3))
    D = np.zeros(P + (3, 3))
    S = np.zeros(P + (2, 2))
    NT = np.zeros(P + (3,))
    MT = np.zeros(P + (3,))
    I1 = np.zeros(P)
    I2 = np.zeros(P)
    I3 = np.zeros(P)
    for k, layer in enumerate(panel.layers):
        sel = np.flatnonzero(owner == k)
        if sel.size == 0:
            continue
        mat = layer.material
        zk = zs[sel]            # (m, 3)
        wk = wts[sel]           # (m, 3)
        Tk = Ts[..., sel, :]    # P + (m, 3)
        w0 = wk
        w1 = wk * zk
        w2 = wk * zk * zk
        if want_inertia and not want_abd:
            rho = mat.density(Tk)
        else:
            Q, G, rho = mat.lamina_values(Tk)                 # P + (m, 3, 3, 3), (.., 2)
        if want_shear:
            Gbar = np.zeros(G.shape + (2,))
            if layer.angle == 0.0:
                # Rs = I: Gbar = diag(G13, G23), as R^T diag(G) R gives exactly
                Gbar[..., 0, 0] = G[..., 0]
                Gbar[..., 1, 1] = G[..., 1]
            else:
                Rs = shear_rotation(layer.angle)
                Gbar = np.einsum("ji,...j,jl->...il", Rs, G, Rs)
            S += _wsum(w0, Gbar, lead)
        if want_abd:
            Tr = mat.reference_temperature
            # secant thermal strain (Material.thermal_strain) in material axes
            e1 = mat.alpha1(Tk) * (Tk - Tr) - mat.alpha1(T0) * (T0 - Tr)
            e2 = e1 if mat.alpha2 is mat.alpha1 else (
                mat.alpha2(Tk) * (Tk - Tr) - mat.alpha2(T0) * (T0 - Tr))
            if layer.angle == 0.0:
                Qbar = Q  # R = I
                sT = np.empty(Q.shape[:-1])
                for i in range(3):
                    sT[..., i] = Q[..., i, 0] * e1 + Q[..., i, 1] * e2
            else:
                R = strain_rotation(layer.angle)
                Qbar = np.matmul(np.matmul(R.T, Q), R)        # Qbar = R^T Q R
                # sigma_T in global axes: R^T Q eps_T(material)
                sT = np.einsum("ji,...j->...i", R, Q[..., 0] * e1[..., None]
                               + Q[..., 1] * e2[..., None])
            A += _wsum(w0, Qbar, lead)
            B += _wsum(w1, Qbar, lead)
            D += _wsum(w2, Qbar, lead)
            NT += _wsum(w0, sT, lead)
            MT += _wsum(w1, sT, lead)
        if want_inertia:
            I1 += _wsum(w0, rho, lead)
            I2 += _wsum(w1, rho, lead)
            I3 += _wsum(w2, rho, lead)
    return LaminateState(A=A, B=B, D=D, S=SHEAR_CORRECTION * S, NT=NT, MT=MT,
                         I1=I1, I2=I2, I3=I3)


def classical_abd(panel: PanelSpec, T: float | None = None) -> tuple[Array, Array, Array]:
    """Closed-form classical lamination theory A, B, D at a uniform temperature.

    ``A = sum Qbar_k (z_k+1 - z_k)``, ``B = 1/2 sum Qbar_k (z_k+1^2 - z_k^2)``,
    ``D = 1/3 sum Qbar_k (z_k+1^3 - z_k^3)`` -- the reference for :func:`laminate`.
    """
    Tu = float(panel.initial_temperature if T is None else T)
    zi = panel.interfaces
    A = np.zeros((3, 3))
    B = np.zeros((3, 3))
    D = np.zeros((3, 3))
    for k, layer in enumerate(panel.layers):
        Q, _ = layer.material.plane_stress_stiffness(Tu)
        R = strain_rotation(layer.angle)
        Qbar = R.T @ Q @ R
        z0, z1 = zi[k], zi[k + 1]
        A += Qbar * (z1 - z0)
        B += Qbar * (z1**2 - z0**2) / 2.0
        D += Qbar * (z1**3 - z0**3) / 3.0
    return A, B, D
