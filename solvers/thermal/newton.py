"""The thermal model's solution (Eqs. 4.28-4.32): the Crank-Nicolson residual and its exact
Jacobian, the banded (or SuperLU) factorization with its reuse, and Newton-Raphson with line
search for a step or the steady state.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Literal

import numpy as np
import scipy.sparse as sp
from hypate.solvers.errors import InputError
from hypate.solvers.numerics.banded import Factorization, SparseLU
from hypate.solvers.numerics.threads import blas_threads
from hypate.solvers.thermal.boundary import ThermalBoundary
from hypate.solvers.thermal.loads import ThermalLoads
from hypate.solvers.thermal.march import StepResult
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]
IntArray = NDArray[np.int64]


#: Why a banded factorization failed, in the thermal model's words.
SINGULAR_JACOBIAN = ("singular thermal Jacobian (a steady problem needs a prescribed "
                     "temperature, radiation or convection somewhere)")



@dataclass(eq=False)
class _Evaluation:
    """Residual (W), its max-norm on free rows, the magnitude of its terms, the net
    boundary heat rate sum(Q) (W), the penalty-row residual over the penalty (K) and, on
    request, the Jacobian data (nnz,), an extra sparse
    Jacobian term outside the element pattern, and whether the Jacobian is symmetric."""

    R: Array
    rnorm: float
    ref: float
    heat_rate: float
    constraint_error: float = 0.0
    J: Array | None = None
    extra: sp.spmatrix | None = None
    symmetric: bool = False


class ThermalNewton(ThermalBoundary):
    """Residual, Jacobian and Newton solves of the thermal model."""

    def _evaluate(self, T1: Array, T0: Array | None, dt: float | None, alpha: float,
                  loads: ThermalLoads, jacobian: bool) -> _Evaluation:
        """Residual of Eq. (4.28) (transient) or ``K T - Q`` (steady) and its Jacobian."""
        self.residual_evaluations += 1
        steady = dt is None
        a = 1.0 if steady else alpha
        dT: Array | None
        if steady:
            Ta = T1
            dT = None
        else:
            assert T0 is not None  # every caller passes T^n with a dt (transient)
            Ta = (1.0 - a) * T0 + a * T1
            dT = T1 - T0
        Kx, Cx, Jvol = self._volume_terms(Ta, dT, dt, a, jacobian)
        Q, D, extra, mag = self._boundary(Ta, loads, a, jacobian)
        R = Kx - Q
        ref = max(float(np.max(np.abs(Kx))), mag)
        if Cx is not None:
            R += Cx
            ref = max(ref, float(np.max(np.abs(Cx))))
        nodes, values = self._prescribed(loads)
        pen = 0.0
        if nodes.size:
            pen = self._penalty_value(loads, dt, alpha)
            R[nodes] += pen * (T1[nodes] - values)  # penalty on T^{n+1} (see step())
            free = np.ones(self.n_nodes, bool)
            free[nodes] = False
            rnorm = float(np.max(np.abs(R[free]))) if free.any() else 0.0
            perr = float(np.max(np.abs(R[nodes]))) / pen
        else:
            rnorm = float(np.max(np.abs(R)))
            perr = 0.0
        out = _Evaluation(R=R, rnorm=rnorm, ref=ref, heat_rate=float(Q.sum()),
                          constraint_error=perr)
        if not jacobian:
            return out
        # Eq. (4.29): dR/dT^{n+1} - dQ/dT^{n+1}; D is already alpha dQ/dT^alpha (Eq. 4.30b)
        assert Jvol is not None  # _volume_terms forms it with jacobian=True
        J = Jvol - D
        if nodes.size:
            np.add.at(J, self._diag_map[nodes], pen)
        out.J = J
        out.extra = -extra if extra is not None else None
        out.symmetric = (self.constant_conductivity and extra is None
                         and not self._has_nodal_flux_derivative(loads))
        return out


    @staticmethod
    def _has_nodal_flux_derivative(loads: ThermalLoads) -> bool:
        return any(callable(getattr(loads, s).flux) for s in ("top", "bottom"))

    def residual(self, T_new: ArrayLike, T_old: ArrayLike | None, dt: float | None,
                 loads: ThermalLoads, alpha: float = 0.5) -> Array:
        """Residual of the Crank-Nicolson equations (Eq. 4.28 minus Q_T), W.

        ``R = C(T^a) (T^{n+1} - T^n)/dt + K(T^a) T^a - Q(T^a) + alpha~ (T^{n+1} - T_b)``
        on prescribed nodes; with ``dt=None`` the steady residual ``K(T) T - Q(T)``.

        Returns
        -------
        ndarray of shape (n_nodes,)
        """
        T1 = self.check_temperature(T_new)
        T0 = None if dt is None else self.check_temperature(T_old)
        return self._evaluate(T1, T0, dt, float(alpha), loads, False).R

    def jacobian(self, T_new: ArrayLike, T_old: ArrayLike | None, dt: float | None,
                 loads: ThermalLoads, alpha: float = 0.5) -> sp.csr_matrix:
        """Exact Jacobian dR/dT^{n+1} of :meth:`residual`, Eqs. (4.29)-(4.32), W/K."""
        T1 = self.check_temperature(T_new)
        T0 = None if dt is None else self.check_temperature(T_old)
        ev = self._evaluate(T1, T0, dt, float(alpha), loads, True)
        assert ev.J is not None
        M = self._matrix(ev.J)
        return M + ev.extra if ev.extra is not None else M

    def _factorize(self, J: Array, extra: sp.spmatrix | None, symmetric: bool,
                   key: tuple) -> Factorization:
        """Factor the Jacobian unless the cached factor is of the identical matrix."""
        if (extra is None and self._factor is not None and self._factor_key == key
                and self._factor_data is not None and np.array_equal(J, self._factor_data)):
            return self._factor
        self.factorizations += 1
        factor: Factorization | None = None
        if extra is not None:
            try:
                factor = SparseLU(self._matrix(J) + extra)
            except RuntimeError as exc:  # SuperLU: "Factor is exactly singular"
                raise np.linalg.LinAlgError(f"singular thermal Jacobian: {exc}") from exc
            self._factor, self._factor_data = factor, None
        else:
            try:
                if symmetric:
                    factor = self._banded.cholesky(J)
                if factor is None:
                    factor = self._banded.lu(J)
            except np.linalg.LinAlgError as exc:  # a negligible pivot (numerics.banded)
                raise np.linalg.LinAlgError(SINGULAR_JACOBIAN) from exc
            self._factor, self._factor_data = factor, J.copy()
        self._factor_key = key
        self._factor_stale = False
        return factor

    def _newton(self, T_start: Array, T_old: Array | None, dt: float | None, alpha: float,
                loads: ThermalLoads, jacobian: str | None = None,
                contraction: float | None = None) -> StepResult:
        with blas_threads(self.blas_threads):
            return self._newton_iterations(T_start, T_old, dt, alpha, loads,
                                           jacobian or self.jacobian_mode,
                                           self.contraction if contraction is None
                                           else float(contraction))

    def _newton_iterations(self, T_start: Array, T_old: Array | None, dt: float | None,
                           alpha: float, loads: ThermalLoads, jacobian: str,
                           contraction: float) -> StepResult:
        """Newton-Raphson with backtracking line search on ||R||_2 (Sec. 4.2.4)."""
        f0 = self.factorizations
        nodes, _ = self._prescribed(loads)
        key = (dt, alpha, hash(np.sort(nodes).tobytes()))
        modified = jacobian == "modified"
        T = T_start.copy()
        fresh_factor = False
        # with the full Jacobian the first iteration always forms it at T_start: evaluate it
        # with the residual once (the same residual, bit for bit) instead of twice
        ev = self._evaluate(T, T_old, dt, alpha, loads, not modified)
        converged = False
        it = 0
        while it < self.max_iterations:
            scale = max(1.0, float(np.max(np.abs(T))))
            if (ev.rnorm <= self.rtol * ev.ref or ev.rnorm == 0.0) \
                    and ev.constraint_error <= self.xtol * scale:
                converged = True
                break
            # Chord iterations with this step's factorization once the residual is small
            # (quadratic phase: the stale Jacobian still contracts by ~|dJ| |J^-1| << 1).
            chord = (fresh_factor and not self._factor_stale
                     and ev.rnorm <= self.chord_threshold * ev.ref)
            use_cached = chord or (modified and self._factor is not None
                                   and not self._factor_stale and self._factor_key == key)
            if use_cached:
                factor = self._factor
            else:
                # ev.J is only set by the start evaluation, at the current T
                full = ev if ev.J is not None else self._evaluate(T, T_old, dt, alpha, loads,
                                                                  True)
                assert full.J is not None
                factor = self._factorize(full.J, full.extra, full.symmetric, key)
                fresh_factor = True
            assert factor is not None
            delta = -factor.solve(ev.R)
            it += 1
            # Line search on phi(s) = ||R(T + s delta)||^2 / 2 with quadratic backtracking.
            phi0 = 0.5 * float(ev.R @ ev.R)
            newton_step = float(np.max(np.abs(delta)))
            s = min(1.0, self.max_step_fraction * scale / max(newton_step, 1e-300))
            for _ in range(12):
                trial = self._evaluate(T + s * delta, T_old, dt, alpha, loads, False)
                phit = 0.5 * float(trial.R @ trial.R)
                if phit <= (1.0 - 2e-4 * s) * phi0 or (trial.rnorm <= self.rtol * trial.ref and
                                                        trial.constraint_error <= self.xtol
                                                        * scale):
                    break
                curv = (phit - phi0 + 2.0 * phi0 * s) / (s * s)
                s = min(0.5 * s, max(0.1 * s, phi0 / curv))
            else:
                self._factor_stale = True  # no descent: refresh a frozen Jacobian
            if use_cached and phit > contraction**2 * phi0:
                self._factor_stale = True  # slow contraction: refactor next iteration
            T = T + s * delta
            ev = trial
            if newton_step <= self.xtol * scale:  # the full Newton increment is negligible
                converged = True
                break
        if not converged:
            warnings.warn(f"thermal Newton did not converge in {self.max_iterations} "
                          f"iterations (residual {ev.rnorm:.3e} W, reference {ev.ref:.3e} W)",
                          RuntimeWarning, stacklevel=3)
        heat = ev.heat_rate * (1.0 if dt is None else dt)
        return StepResult(T=T, iterations=it, factorizations=self.factorizations - f0,
                          residual_norm=ev.rnorm, converged=converged, heat_input=heat)

    # ------------------------------------------------------------------------------------
    # Solvers
    # ------------------------------------------------------------------------------------
    def step(self, T_old: ArrayLike, dt: float, loads: ThermalLoads, *, alpha: float = 0.5,
             T_guess: ArrayLike | None = None,
             jacobian: Literal["full", "modified"] | None = None,
             contraction: float | None = None) -> StepResult:
        """One Crank-Nicolson step, Eq. (4.28), solved by Newton-Raphson with line search.

        The residual is

            C(T^a) (T^{n+1} - T^n)/dt + K(T^a) T^a - Q(T^a) = 0,
            T^a = (1 - alpha) T^n + alpha T^{n+1},

        with the Jacobian of Eqs. (4.30)-(4.32) (capacity, conductivity, radiation and
        flux-function derivatives). Prescribed temperatures are imposed by the penalty of
        Eq. (4.27) on ``T^{n+1}`` (not on ``T^a``: with ``alpha = 1/2`` that would make
        ``T^{n+1} = 2 T_b - T^n`` oscillate when the initial state violates the constraint;
        both are identical once ``T^n`` satisfies it).

        Parameters
        ----------
        T_old : ndarray of shape (n_nodes,)
            Temperatures at t_n (K).
        dt : float
            Time step (s), > 0.
        loads : ThermalLoads
            Boundary conditions, evaluated at ``T^a`` (time t_n + alpha dt).
        alpha : float
            alpha-bar in (0, 1]; 1/2 is Crank-Nicolson, 1 backward Euler.
        T_guess : ndarray of shape (n_nodes,), optional
            Newton start (default ``T_old``).
        jacobian, contraction : optional
            Override the model's ``jacobian`` mode and ``contraction`` for this step (the
            same solution to ``rtol``/``xtol``; a caller marching smooth steps keeps the
            last step's factorization with ``"modified"`` and a strict ``contraction``).

        Returns
        -------
        StepResult
        """
        if jacobian not in (None, "full", "modified"):
            raise InputError("jacobian", "must be 'full' or 'modified'")
        T0 = self.check_temperature(T_old)
        if not (dt > 0.0 and math.isfinite(dt)):
            raise InputError("time_step", "must be > 0 (s)")
        if not (0.0 < alpha <= 1.0):
            raise InputError("alpha", "alpha-bar must be in (0, 1]")
        start = T0 if T_guess is None else self.check_temperature(T_guess)
        return self._newton(start, T0, float(dt), float(alpha), loads, jacobian, contraction)

    def steady(self, loads: ThermalLoads, T_guess: ArrayLike | None = None) -> StepResult:
        """Steady state ``K_T(T) T = Q_T(T)`` (Eq. 4.27 without the capacity term).

        Needs a prescribed temperature, convection or radiation to be well posed.
        ``T_guess`` (default: the initial temperature) starts the Newton iteration.
        """
        start = (np.full(self.n_nodes, float(self.panel.initial_temperature))
                 if T_guess is None else self.check_temperature(T_guess))
        return self._newton(start, None, None, 1.0, loads)
