"""Nonlinear static equilibrium of a :class:`StructuralModel` (Sec. 3.2.3).

:func:`static` applies pressure and temperature proportionally and solves each increment by
Newton-Raphson with line search (Eqs. 3.46-3.47), with adaptive load stepping, branch
switching past bifurcations (along the lowest eigenmode of the tangent) and a Riks
arc-length fallback for limit points. :func:`shift_invert_eigs` (the sparse eigen-solve
the branch switch needs) is shared with :mod:`hypate.solvers.structure.modal`.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from typing import cast

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from hypate.solvers.numerics.sparse import Factor
from hypate.solvers.structure.element import NDOF
from hypate.solvers.structure.model import Array, StructuralModel, TemperatureLike, W
from numpy.typing import ArrayLike


def shift_invert_eigs(K: sp.csr_matrix, M: sp.csr_matrix, fac: Factor, k: int,
                      sigma: float = 0.0) -> tuple[Array, Array]:
    """The ``k`` eigenpairs of ``K phi = lam M phi`` nearest ``sigma``, ascending.

    ARPACK in shift-invert mode with the given factorization ``fac`` of ``K - sigma M``
    (``sigma = 0``: of ``K``); ``k`` is capped at ``n - 2`` (ARPACK's limit).
    """
    n = K.shape[0]
    k = min(k, n - 2)
    op = spla.LinearOperator((n, n), matvec=fac.solve, dtype=float)
    vals, vecs = spla.eigsh(K, k=k, M=M, sigma=sigma, which="LM", OPinv=op)
    order = np.argsort(vals, kind="stable")
    return vals[order], vecs[:, order]


@dataclass
class StaticResult:
    """Nonlinear static equilibrium.

    Attributes
    ----------
    u : ndarray of shape (n_dof,)
    converged : bool
    load_factors : list of float
        Converged load factors of the path.
    iterations : int
        Total Newton iterations.
    stable : bool
        Tangent positive definite at the solution.
    path : list of (float, float)
        (load factor, centre deflection) along the path.
    """

    u: Array
    converged: bool
    load_factors: list[float] = field(default_factory=list)
    iterations: int = 0
    stable: bool = True
    path: list[tuple[float, float]] = field(default_factory=list)

    def center_deflection(self, model: StructuralModel) -> float:
        return float(self.u[NDOF * model.mesh.center + W])

    def max_deflection(self, model: StructuralModel) -> float:
        w = model.deflection(self.u)
        return float(w[np.argmax(np.abs(w))])


class _Problem:
    """Residual ``R(u, lam) = F_I(u, T(lam)) - lam F_p`` of the proportional load path."""

    def __init__(self, model: StructuralModel, Fp: Array, T: TemperatureLike) -> None:
        self.model = model
        self.Fp = Fp
        self.Tn = model.nodal_temperature(T)
        self.heated = not (isinstance(self.Tn, float) and self.Tn == model.T0)

    def T(self, lam: float) -> TemperatureLike:
        if not self.heated:
            return None
        Tn = self.Tn
        return self.model.T0 + lam * (Tn - self.model.T0)

    def residual(self, u: Array, lam: float) -> Array:
        return self.model.internal_force(u, self.T(lam)) - lam * self.Fp

    def residual_tangent(self, u: Array, lam: float) -> tuple[Array, sp.csr_matrix]:
        F, K = self.model.force_and_tangent(u, self.T(lam))
        return F - lam * self.Fp, K

    def dR_dlam(self, u: Array, lam: float) -> Array:
        if not self.heated:
            return -self.Fp
        h = 1e-6 * max(1.0, abs(lam))
        return ((self.model.internal_force(u, self.T(lam + h))
                 - self.model.internal_force(u, self.T(lam - h))) / (2.0 * h) - self.Fp)

    def scale(self) -> float:
        # an np.float64, a float (numpy's stub: norm gives floating)
        ref = cast(float, np.linalg.norm(self.Fp)
                   + np.linalg.norm(self.model.thermal_load(self.T(1.0))))
        return ref if ref > 0.0 else 1.0


def _free_norm(model: StructuralModel, r: Array) -> float:
    return float(np.linalg.norm(r[model.free_dofs]))


def _newton(prob: _Problem, u: Array, lam: float, rtol: float, max_iter: int
            ) -> tuple[Array, bool, int, bool | None]:
    """Newton-Raphson with a backtracking line search (Eqs. 3.46-3.47) at a fixed load.

    Returns the solution, convergence flag, iterations and whether the last factorized
    tangent was positive definite.
    """
    model = prob.model
    ref = prob.scale()
    R, K = prob.residual_tangent(u, lam)
    rn = _free_norm(model, R)
    pd: bool | None = None
    for it in range(1, max_iter + 1):
        if rn <= rtol * ref:
            return u, True, it - 1, pd
        fac = model.factor(K)
        pd = fac.positive_definite
        du = -fac.solve(R)
        theta = 1.0
        for _ in range(12):                       # Eq. (3.47): backtracking on ||R||
            u_try = u + theta * du
            R_try = prob.residual(u_try, lam)
            rn_try = _free_norm(model, R_try)
            if np.isfinite(rn_try) and rn_try < rn * (1.0 - 1e-4 * theta) or rn_try <= rtol * ref:
                break
            theta *= 0.5
        else:
            return u, False, it, pd
        u = u_try
        small_step = np.max(np.abs(theta * du)) <= 1e-13 * max(np.max(np.abs(u)), 1e-30)
        if small_step and rn_try <= 1e-6 * ref:
            return u, True, it, pd
        R, K = prob.residual_tangent(u, lam)
        rn = _free_norm(model, R)
    return u, rn <= rtol * ref, max_iter, pd


def _lowest_mode(model: StructuralModel, K: sp.csr_matrix, T: TemperatureLike) -> Array:
    """Eigenvector of the most negative eigenvalue of ``K phi = lam M phi``."""
    M = model.mass(T)
    fac = model.solver.splu(K.data)
    vals, vecs = shift_invert_eigs(K, M, fac, 4)
    return vecs[:, int(np.argmin(vals))]


def _branch_switch(prob: _Problem, u: Array, lam: float, rtol: float, max_iter: int,
                   amplitude: float) -> tuple[Array, bool, int, bool | None]:
    """Leave an unstable equilibrium along the lowest (negative) eigenmode of the tangent."""
    model = prob.model
    K = model.tangent(u, prob.T(lam))
    phi = _lowest_mode(model, K, prob.T(lam))
    w = model.deflection(phi)
    phi = phi / w[np.argmax(np.abs(w))]
    total = 0
    sign = 1.0 if float(np.sum(prob.Fp[W::NDOF])) >= 0.0 else -1.0
    for s in (sign, -sign):
        u_try, ok, it, pd = _newton(prob, u + s * amplitude * phi, lam, rtol, max_iter)
        total += it
        if ok and pd is not False:
            return u_try, ok, total, pd
    return u, False, total, False


def static(model: StructuralModel, pressure: ArrayLike = 0.0, T: TemperatureLike = None,
           u0: Array | None = None, steps: int = 1, rtol: float = 1e-9, max_iter: int = 20,
           min_step: float = 1.0 / 1024, branch_switch: bool = True,
           arc_length: bool = True) -> StaticResult:
    """Nonlinear static equilibrium ``F_I(u, T) = F_S`` under pressure and temperature.

    The load (pressure and temperature rise from the initial temperature) is applied
    proportionally, ``lam`` from 0 to 1, in ``steps`` increments that halve on failure.
    Each increment is solved by Newton-Raphson with line search (Eqs. 3.46-3.47). When a
    converged state has a tangent that is not positive definite (past a bifurcation, e.g.
    thermal buckling of a flat plate) the solver switches to the stable branch along the
    lowest eigenmode. When the increment falls below ``min_step`` (a limit point,
    snap-through) it continues with a Riks arc-length method on the w DOFs.

    Parameters
    ----------
    pressure : float or ndarray of shape (n_nodes,) or (n_elem, 9)
        Pa, positive towards +z.
    T : temperature input
        Final temperature (K).
    u0 : ndarray of shape (n_dof,), optional
        Starting point (equilibrium at lam = 0 assumed when given).
    """
    Fp = model.pressure_load(pressure)
    prob = _Problem(model, Fp, T)
    u = np.zeros(model.n_dof) if u0 is None else np.array(u0, dtype=float)
    result = StaticResult(u=u, converged=True)
    if np.linalg.norm(Fp) == 0.0 and not prob.heated:
        result.stable = True
        return result
    h = model.panel.thickness
    lam, dlam = 0.0, 1.0 / max(int(steps), 1)
    pd: bool | None = None
    while lam < 1.0 - 1e-14:
        target = min(1.0, lam + dlam)
        # predictor: linear extrapolation is left to Newton (start from the last state)
        u_new, ok, it, pd = _newton(prob, u, target, rtol, max_iter)
        result.iterations += it
        if ok and pd is None:           # converged without a factorization: check now
            pd = model.factor(model.tangent(u_new, prob.T(target))).positive_definite
        if ok and pd is False and branch_switch:
            u_new, ok, it, pd = _branch_switch(prob, u_new, target, rtol, max_iter, h)
            result.iterations += it
        if ok:
            u, lam = u_new, target
            result.load_factors.append(lam)
            result.path.append((lam, float(u[NDOF * model.mesh.center + W])))
            dlam = min(2.0 * dlam, 1.0)
            continue
        dlam *= 0.5
        if dlam < min_step:
            if not arc_length:
                break
            u, lam_end, ok, it = _arc_length(prob, u, lam, result, rtol, max_iter)
            result.iterations += it
            if ok:
                lam = lam_end
                u_new, ok, it, pd = _newton(prob, u, 1.0, rtol, max_iter)
                result.iterations += it
                if ok:
                    u, lam = u_new, 1.0
                    result.load_factors.append(lam)
            break
    result.u = u
    result.converged = lam >= 1.0 - 1e-14
    if not result.converged:
        warnings.warn(f"static: equilibrium not reached (load factor {lam:.4g} of 1)",
                      RuntimeWarning, stacklevel=2)
    K = model.tangent(u, prob.T(lam))
    result.stable = bool(model.factor(K).positive_definite)
    if result.converged and not result.stable and branch_switch:
        # e.g. reached along an unstable branch by the arc length: go to a stable one
        u_s, ok, it, pd = _branch_switch(prob, u, 1.0, rtol, max_iter, h)
        result.iterations += it
        if ok and pd is not False:
            result.u = u_s
            result.stable = bool(model.factor(model.tangent(u_s, prob.T(1.0)))
                                 .positive_definite)
    return result


def _arc_length(prob: _Problem, u: Array, lam: float, result: StaticResult, rtol: float,
                max_iter: int, max_steps: int = 400) -> tuple[Array, float, bool, int]:
    """Riks arc-length continuation on the w DOFs past limit points until ``lam >= 1``.

    Returns the state at (or just past) ``lam = 1`` -- interpolated back to 1 -- the load
    factor, success flag and iterations.
    """
    model = prob.model
    ref = prob.scale()
    wmask = np.zeros(model.n_dof)
    wmask[W::NDOF] = 1.0
    R, K = prob.residual_tangent(u, lam)
    fac = model.factor(K)
    ut = -fac.solve(prob.dR_dlam(u, lam))          # du/dlam along the tangent
    ds = 0.05 * model.panel.thickness * max(1.0, math.sqrt(model.n_nodes) / 4)
    ds_max = 4.0 * ds
    direction = 1.0
    prev_dir: Array | None = None
    total = 0
    for _ in range(max_steps):
        nt = math.sqrt(float(np.sum(wmask * ut * ut)) + 1e-300)
        dl = direction * ds / nt
        du_tot = dl * ut
        if prev_dir is not None and float(np.sum(wmask * du_tot * prev_dir)) < 0.0:
            dl, du_tot = -dl, -du_tot
        u_i, lam_i = u + du_tot, lam + dl
        ok = False
        for it in range(max_iter):  # noqa: B007 - `it` is read after the loop
            total += 1
            R, K = prob.residual_tangent(u_i, lam_i)
            if _free_norm(model, R) <= rtol * ref:
                ok = True
                break
            fac = model.factor(K)
            ur = -fac.solve(R)
            ul = -fac.solve(prob.dR_dlam(u_i, lam_i))
            num = float(np.sum(wmask * du_tot * ur))
            den = float(np.sum(wmask * du_tot * ul))
            dlam = -num / den if den != 0.0 else 0.0
            step = ur + dlam * ul
            u_i = u_i + step
            lam_i = lam_i + dlam
            du_tot = du_tot + step
        if ok and lam_i < 0.0:      # turned back towards the unloaded state: refine
            ok = False
        if not ok:
            ds *= 0.5
            if ds < 1e-6 * model.panel.thickness:
                return u, lam, False, total
            continue
        prev_dir = du_tot
        if lam_i >= 1.0:
            s = (1.0 - lam) / (lam_i - lam)
            return u + s * (u_i - u), 1.0, True, total
        u, lam = u_i, lam_i
        result.load_factors.append(lam)
        result.path.append((lam, float(u[NDOF * model.mesh.center + W])))
        _, K = prob.residual_tangent(u, lam)
        fac = model.factor(K)
        ut = -fac.solve(prob.dR_dlam(u, lam))
        if it <= 3:
            ds = min(1.5 * ds, ds_max)
    return u, lam, False, total
