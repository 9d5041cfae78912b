"""Natural frequencies and linear thermal buckling of a :class:`StructuralModel` (Ch. 3).

:func:`modes` solves ``K_T phi = omega^2 M phi`` about a (heated, deformed) equilibrium;
:func:`buckling_delta_T` the critical uniform temperature rise.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse.linalg as spla
from hypate.solvers.errors import InputError
from hypate.solvers.structure.model import Array, StructuralModel, TemperatureLike
from hypate.solvers.structure.static import shift_invert_eigs, static
from numpy.typing import ArrayLike


@dataclass
class ModalResult:
    """Natural frequencies about an equilibrium.

    Attributes
    ----------
    frequencies_hz : ndarray of shape (k,)
        Ascending; a negative value ``-f`` marks an unstable mode (negative eigenvalue
        ``-(2 pi f)^2``).
    eigenvalues : ndarray of shape (k,)
        omega^2 (rad^2/s^2).
    shapes : ndarray of shape (n_dof, k)
        Mass-normalized mode shapes.
    u : ndarray of shape (n_dof,)
        The equilibrium the modes are about.
    """

    frequencies_hz: Array
    eigenvalues: Array
    shapes: Array
    u: Array



def modes(model: StructuralModel, count: int = 6, T: TemperatureLike = None,
          u: Array | None = None, pressure: ArrayLike = 0.0,
          equilibrium: bool = True) -> ModalResult:
    """Natural frequencies about a (heated, deformed) equilibrium.

    Sparse generalized eigenproblem ``K_T phi = omega^2 M phi`` in shift-invert mode about
    zero, with the factorization of :mod:`hypate.solvers.numerics.sparse`.

    Parameters
    ----------
    model : StructuralModel
    count : int
        Number of modes.
    T : temperature input, optional
        The heated state (K); default: the initial temperature.
    u : ndarray of shape (n_dof,), optional
        Equilibrium to linearize about; if omitted and ``equilibrium`` is true, it is
        found by :func:`static` under ``pressure`` and ``T`` (zero when unloaded).
    pressure : float or ndarray of shape (n_nodes,)
        Static pressure (Pa) for the equilibrium.
    """
    if count < 1:
        raise InputError("count", "must be >= 1")
    loaded = (T is not None) or np.any(np.asarray(pressure) != 0.0)
    if u is None:
        if equilibrium and loaded:
            res = static(model, pressure=pressure, T=T)
            u = res.u
        else:
            u = np.zeros(model.n_dof)
    K = model.tangent(u, T)
    M = model.mass(T)
    fac = model.factor(K)
    vals, vecs = shift_invert_eigs(K, M, fac, count)
    f = np.sign(vals) * np.sqrt(np.abs(vals)) / (2.0 * np.pi)
    return ModalResult(frequencies_hz=f, eigenvalues=vals, shapes=vecs, u=np.asarray(u))


@dataclass
class BucklingResult:
    """Linear buckling: ``critical_delta_T`` (K) and the buckling modes (n_dof, k)."""

    critical_delta_T: float
    factors: Array
    shapes: Array
    iterations: int


def buckling_delta_T(model: StructuralModel, count: int = 1,
                     profile: ArrayLike | None = None, max_iter: int = 20,
                     rtol: float = 1e-6) -> BucklingResult:
    """Critical uniform temperature rise at first buckling (linear buckling analysis).

    Prebuckling state: ``K_L u0 = F_T(T0 + dT)`` (linear). Buckling: the smallest positive
    ``lambda`` of ``(K_L + lambda K_G1) phi = 0`` with ``K_G1`` the initial-stress matrix of
    the prebuckling resultants per kelvin. With temperature-dependent properties the
    properties are re-evaluated at ``T0 + dT_cr`` until the estimate is stationary.

    Parameters
    ----------
    profile : ndarray, optional
        Shape of the temperature rise (same forms as the temperature input, a rise in K per
        unit factor); default a uniform 1 K rise.
    """
    base = 1.0 if profile is None else np.asarray(profile, dtype=float)
    dT = 1.0
    shapes = np.zeros((model.n_dof, 0))
    lam = np.array([np.nan])
    it = 0
    for it in range(1, max_iter + 1):
        T = model.T0 + dT * base
        if np.ndim(T) == 0:
            T = float(T)
        KL = model.linear_stiffness(T)
        fac = model.factor(KL)
        u0 = fac.solve(model.thermal_load(T))
        KG = model.geometric_stiffness(u0, T, nonlinear=False)
        KG1 = -KG / dT      # positive for compression
        n = model.n_dof
        op = spla.LinearOperator((n, n), matvec=lambda x, fac=fac, KG1=KG1: fac.solve(KG1 @ x),
                                 dtype=float)
        k = min(max(count, 1) + 3, n - 2)
        mu, vec = spla.eigs(op, k=k, which="LR", tol=1e-10)
        pos = np.real(mu) > 0
        if not np.any(pos):
            raise RuntimeError("no buckling under a temperature rise (no compressive state)")
        mu_r = np.real(mu[pos])
        order = np.argsort(-mu_r, kind="stable")
        lam = 1.0 / mu_r[order]
        shapes = np.real(vec[:, pos][:, order])
        new = float(lam[0])
        if abs(new - dT) <= rtol * abs(new) or it == max_iter:
            dT = new
            break
        dT = new
    return BucklingResult(critical_delta_T=float(lam[0]), factors=lam[:count],
                          shapes=shapes[:, :count], iterations=it)
