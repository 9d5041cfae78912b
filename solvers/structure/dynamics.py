"""One-step generalized-alpha integrator for the structure (Eq. 3.45) with external loads.

The loosely coupled schemes (Sec. 5.3.1) hand the structure a load vector for the end of
each step (an estimate, Eqs. 5.3 and 5.6); :class:`AlphaStepper` advances (u, v, a) by one
step with Newton iterations on the generalized-alpha residual

    M a_(n+1-am) + C v_(n+1-af) + F_I(u_(n+1-af), T) = F_(n+1-af)

(Eqs. 3.45, 3.48-3.49), keeping the state between calls.
"""
from __future__ import annotations

import math
import warnings

import numpy as np
import scipy.sparse as sp
from hypate.solvers.structure.model import GeneralizedAlpha, StructuralModel
from numpy.typing import NDArray

Array = NDArray[np.float64]

#: Residual (relative to the load scale) below which a stalled Newton iteration is taken as
#: converged to round-off (see :meth:`AlphaStepper.step`).
ROUNDOFF_RTOL = 1e-6


class AlphaStepper:
    """Generalized-alpha time stepping of a :class:`StructuralModel`.

    Parameters
    ----------
    model : StructuralModel
    dt : float
        Time step (s).
    rho_bar : float
        Spectral radius at infinity (1 = no numerical dissipation).
    u0, v0 : ndarray of shape (n_dof,), optional
    T0 : temperature input
        Temperature at t = 0 (initial acceleration from the equation of motion).
    F0 : ndarray of shape (n_dof,), optional
        External load at t = 0.
    rtol : float
        Newton tolerance on the free-DOF residual relative to the load scale.
    """

    def __init__(self, model: StructuralModel, dt: float, rho_bar: float = 1.0,
                 u0: Array | None = None, v0: Array | None = None, T0=None,
                 F0: Array | None = None, rtol: float = 1e-9, max_iter: int = 25) -> None:
        ga = GeneralizedAlpha(rho_bar)
        self.af, self.am, self.gm, self.bt = ga.alpha_f, ga.alpha_m, ga.gamma, ga.beta
        self.model = model
        self.dt = float(dt)
        self.rtol, self.max_iter = rtol, max_iter
        n = model.n_dof
        self.M = model.mass(T0)
        self.C = model.damping(T0)
        self.has_damping = bool(np.any(self.C.data != 0.0))
        self.u = np.zeros(n) if u0 is None else np.array(u0, float)
        self.v = np.zeros(n) if v0 is None else np.array(v0, float)
        self.F = np.zeros(n) if F0 is None else np.array(F0, float)
        self.FI = model.internal_force(self.u, T0)
        rhs = self.F - self.FI - (self.C @ self.v if self.has_damping else 0.0)
        self.a = model.solver.factor(self.M).solve(rhs)
        self.iterations = 0
        self.factorizations = 0

    def step(self, F1: Array, T1=None) -> tuple[Array, Array, Array]:
        """Advance one step with the external load ``F1`` at t_(n+1) and temperature ``T1``.

        Returns
        -------
        u, v, a at t_(n+1) (views of the stepper's state).
        """
        af, am, gm, bt, dt = self.af, self.am, self.gm, self.bt, self.dt
        model, M, C = self.model, self.M, self.C
        u, v, a = self.u, self.v, self.a
        u_pred = u + dt * v + (0.5 - bt) * dt * dt * a
        x = u_pred.copy()
        Fs = (1.0 - af) * F1 + af * self.F
        cM = (1.0 - am) / (bt * dt * dt)
        cC = gm * (1.0 - af) / (bt * dt)
        free = model.free_dofs
        # the internal force of a heated panel is a small difference of large membrane and
        # thermal terms: measure the residual against the thermal load, not only the net force
        scale = max(float(np.linalg.norm(Fs[free])), float(np.linalg.norm(self.FI[free])),
                    float(np.linalg.norm(model.thermal_load(T1)[free])) if T1 is not None else 0.0,
                    float(np.linalg.norm((M @ a)[free])), 1e-300)
        r_prev = math.inf
        for it in range(self.max_iter):
            a1 = (x - u_pred) / (bt * dt * dt)
            v1 = v + dt * ((1.0 - gm) * a + gm * a1)
            FI1, KT = model.force_and_tangent(x, T1)
            R = M @ ((1.0 - am) * a1 + am * a) + (1.0 - af) * FI1 + af * self.FI - Fs
            if self.has_damping:
                R += C @ ((1.0 - af) * v1 + af * v)
            self.iterations += 1
            rnorm = float(np.linalg.norm(R[free]))
            if it > 0 and rnorm <= self.rtol * scale:
                break
            # round-off floor: the residual of a heated panel is a difference of membrane,
            # thermal and penalty forces many orders above it; at small steps (large M/dt^2)
            # it stalls near 1e-9 of the load scale. A stalled Newton (no halving) that far
            # below the load is converged.
            if it > 1 and rnorm > 0.5 * r_prev and rnorm <= ROUNDOFF_RTOL * scale:
                break
            r_prev = rnorm
            K = sp.csr_matrix((cM * M.data + cC * C.data + (1.0 - af) * KT.data,
                               KT.indices, KT.indptr), shape=KT.shape) if self._same_pattern(KT) \
                else (cM * M + cC * C + (1.0 - af) * KT).tocsr()
            self.factorizations += 1
            dx = -model.factor(K).solve(R)
            x = x + dx
            if np.max(np.abs(dx)) <= 1e-15 * max(np.max(np.abs(x)), 1e-300):
                break
        else:
            warnings.warn("generalized-alpha Newton did not converge", RuntimeWarning,
                          stacklevel=2)
        a1 = (x - u_pred) / (bt * dt * dt)
        self.v = v + dt * ((1.0 - gm) * a + gm * a1)
        self.u, self.a = x, a1
        self.FI = model.internal_force(x, T1)
        self.F = np.array(F1, float)
        return self.u, self.v, self.a

    def _same_pattern(self, KT: sp.csr_matrix) -> bool:
        M, C = self.M, self.C
        return (M.nnz == KT.nnz == C.nnz and np.array_equal(M.indices, KT.indices)
                and np.array_equal(C.indices, KT.indices))
