"""The generalized-alpha integrator of the structure (Eqs. 3.45, 3.48-3.49).

One stepper, :class:`AlphaStepper`, advances (u, v, a) by one step with Newton iterations
on the generalized-alpha residual

    M a_(n+1-am) + C v_(n+1-af) + F_I(u_(n+1-af), T) = F_(n+1-af)

(Eq. 3.45) and keeps the state between calls. :func:`transient` marches it under given load
and temperature histories; the loosely coupled schemes (Sec. 5.3.1) hand it a load vector
for the end of each step (an estimate, Eqs. 5.3 and 5.6). The parameters come from the
spectral radius rho-bar once, in :class:`GeneralizedAlpha`.
"""
from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np
import scipy.sparse as sp
from hypate.solvers.errors import InputError
from hypate.solvers.numerics.sparse import Factor
from hypate.solvers.settings import DEFAULTS
from hypate.solvers.structure.model import Array, StructuralModel, TemperatureLike

#: Residual (relative to the load scale) below which a stalled Newton iteration is taken as
#: converged to round-off (``scale="heated"``, see :meth:`AlphaStepper.step`).
ROUNDOFF_RTOL = 1e-6


@dataclass(frozen=True)
class GeneralizedAlpha:
    """Generalized-alpha parameters from the spectral radius rho-bar (Eq. 3.45); the default
    spectral radius of every integrator is :data:`hypate.solvers.settings.DEFAULTS`'s."""

    rho_bar: float

    def __post_init__(self) -> None:
        if not 0.0 <= self.rho_bar <= 1.0:
            raise InputError("rho_bar", "must be in [0, 1]")

    @property
    def alpha_f(self) -> float:
        return self.rho_bar / (self.rho_bar + 1.0)

    @property
    def alpha_m(self) -> float:
        return (2.0 * self.rho_bar - 1.0) / (self.rho_bar + 1.0)

    @property
    def gamma(self) -> float:
        return 0.5 - self.alpha_m + self.alpha_f

    @property
    def beta(self) -> float:
        return 0.25 * (1.0 - self.alpha_m + self.alpha_f) ** 2

    def matrix_coefficients(self, dt: float) -> tuple[float, float, float]:
        """Coefficients ``(c_M, c_C, c_K)`` of the Newton matrix ``c_M M + c_C C + c_K K_T``.

        Eqs. (3.48)-(3.49): ``c_M = (1 - am)/(beta dt^2)``, ``c_C = gamma (1 - af)/(beta dt)``,
        ``c_K = 1 - af``.
        """
        af, am, gm, bt = self.alpha_f, self.alpha_m, self.gamma, self.beta
        return (1.0 - am) / (bt * dt * dt), gm * (1.0 - af) / (bt * dt), 1.0 - af


class LinearForce:
    """Internal force of the linear model, ``K_L u - F_T(T)`` (Eq. 3.34, no von Karman terms).

    The same two methods as :class:`StructuralModel` (``internal_force``,
    ``force_and_tangent``), with the constant tangent ``K_L`` at the initial temperature.
    """

    def __init__(self, model: StructuralModel) -> None:
        self.model = model
        self.KL = model.linear_stiffness()

    def internal_force(self, u: Array, T: TemperatureLike = None) -> Array:
        return self.KL @ u - (self.model.thermal_load(T) if T is not None else 0.0)

    def force_and_tangent(self, u: Array, T: TemperatureLike = None
                          ) -> tuple[Array, sp.csr_matrix]:
        return self.internal_force(u, T), self.KL


class AlphaStepper:
    """Generalized-alpha time stepping of a :class:`StructuralModel` (Eqs. 3.45, 3.48-3.49).

    The state ``u, v, a`` (at t_n), the load ``F`` and internal force ``FI`` at t_n are
    public attributes: a caller may restart the integration from a state it set itself
    (the start procedure of the loosely coupled schemes, Eq. 5.7).

    Parameters
    ----------
    model : StructuralModel
    dt : float
        Time step (s).
    rho_bar : float
        Spectral radius at infinity (1 = no numerical dissipation, 0 = the quasi-steady
        limit).
    u0, v0 : ndarray of shape (n_dof,), optional
        Initial displacement and velocity (zero by default).
    T0 : temperature input
        Temperature at t = 0 (initial acceleration from the equation of motion).
    F0 : ndarray of shape (n_dof,), optional
        External load at t = 0 (N).
    rtol : float
        Newton tolerance on the free-DOF residual relative to the load scale.
    max_iter : int
        Newton iterations per step before a ``RuntimeWarning``.
    nonlinear : bool
        False: the linear model ``K_L u - F_T`` (:class:`LinearForce`), whose Newton
        matrix is factorized once.
    mass, damping : csr_matrix, optional
        Constant M and C (Eqs. 3.38, 3.44); default ``model.mass(T0)``, ``model.damping(T0)``.
    scale : {"heated", "net"}
        What the residual is measured against. "heated" (the coupled schemes): the largest
        free-DOF norm of the load, the internal force, the thermal load at t_(n+1) and the
        inertia force -- the internal force of a heated panel is a small difference of
        large membrane and thermal terms -- and a stalled iteration below
        :data:`ROUNDOFF_RTOL` of it is converged. "net" (:func:`transient`): the largest
        norm over all DOFs of the load, the internal force and the inertia force.
    """

    def __init__(self, model: StructuralModel, dt: float, rho_bar: float = DEFAULTS.rho_bar,
                 u0: Array | None = None, v0: Array | None = None, T0: TemperatureLike = None,
                 F0: Array | None = None, rtol: float = 1e-9, max_iter: int = 25, *,
                 nonlinear: bool = True, mass: sp.csr_matrix | None = None,
                 damping: sp.csr_matrix | None = None,
                 scale: Literal["heated", "net"] = "heated") -> None:
        if scale not in ("heated", "net"):
            raise InputError("scale", "must be 'heated' or 'net'")
        ga = GeneralizedAlpha(rho_bar)
        self.af, self.am, self.gm, self.bt = ga.alpha_f, ga.alpha_m, ga.gamma, ga.beta
        self.dt = float(dt)
        self.cM, self.cC, self.cK = ga.matrix_coefficients(self.dt)
        self.model = model
        self.force: StructuralModel | LinearForce = model if nonlinear else LinearForce(model)
        self.rtol, self.max_iter = rtol, max_iter
        self.scale = scale
        n = model.n_dof
        self.M = model.mass(T0) if mass is None else mass
        self.C = model.damping(T0) if damping is None else damping
        self.has_damping = bool(np.any(self.C.data != 0.0))
        self.u = np.zeros(n) if u0 is None else np.array(u0, float)
        self.v = np.zeros(n) if v0 is None else np.array(v0, float)
        self.F = np.zeros(n) if F0 is None else np.array(F0, float)
        self.FI = self.force.internal_force(self.u, T0)
        rhs = self.F - self.FI - (self.C @ self.v if self.has_damping else 0.0)
        self.a = model.solver.factor(self.M).solve(rhs)
        self._linear_factor: Factor | None = None   # the linear model's one Newton matrix
        self.iterations = 0
        self.factorizations = 0

    def step(self, F1: Array, T1: TemperatureLike = None, t: float | None = None
             ) -> tuple[Array, Array, Array]:
        """Advance one step with the external load ``F1`` at t_(n+1) and temperature ``T1``.

        ``t`` (s), optional, is t_(n+1); it only labels the warning when Newton does not
        converge.

        Returns
        -------
        u, v, a at t_(n+1) (views of the stepper's state).
        """
        af, am, gm, bt, dt = self.af, self.am, self.gm, self.bt, self.dt
        M, C = self.M, self.C
        u, v, a = self.u, self.v, self.a
        u_pred = u + dt * v + (0.5 - bt) * dt * dt * a   # a_(n+1) = 0 start
        x = u_pred.copy()
        Fs = (1.0 - af) * F1 + af * self.F
        free = self.model.free_dofs
        scale = self._load_scale(Fs, T1)
        r_prev = math.inf
        for it in range(self.max_iter):
            a1 = (x - u_pred) / (bt * dt * dt)
            v1 = v + dt * ((1.0 - gm) * a + gm * a1)
            FI1, KT = self.force.force_and_tangent(x, T1)
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
            if (self.scale == "heated" and it > 1 and rnorm > 0.5 * r_prev
                    and rnorm <= ROUNDOFF_RTOL * scale):
                break
            r_prev = rnorm
            dx = -self._newton_factor(KT).solve(R)
            x = x + dx
            if np.max(np.abs(dx)) <= 1e-15 * max(np.max(np.abs(x)), 1e-300):
                break
        else:
            at = "" if t is None else f" at t = {t:.6g} s"
            warnings.warn(f"generalized-alpha Newton did not converge{at}", RuntimeWarning,
                          stacklevel=2)
        a1 = (x - u_pred) / (bt * dt * dt)
        self.v = v + dt * ((1.0 - gm) * a + gm * a1)
        self.u, self.a = x, a1
        self.FI = self.force.internal_force(x, T1)
        self.F = np.array(F1, float)
        return self.u, self.v, self.a

    def _load_scale(self, Fs: Array, T1: TemperatureLike) -> float:
        """The force the step's residual is measured against (see ``scale``)."""
        if self.scale == "net":
            return max(float(np.linalg.norm(Fs)), float(np.linalg.norm(self.FI)),
                       float(np.linalg.norm(self.M @ self.a)), 1e-300)
        free, model = self.model.free_dofs, self.model
        return max(float(np.linalg.norm(Fs[free])), float(np.linalg.norm(self.FI[free])),
                   float(np.linalg.norm(model.thermal_load(T1)[free])) if T1 is not None
                   else 0.0,
                   float(np.linalg.norm((self.M @ self.a)[free])), 1e-300)

    def _newton_factor(self, KT: sp.csr_matrix) -> Factor:
        """Factor of the Newton matrix ``c_M M + c_C C + c_K K_T`` (Eqs. 3.48-3.49)."""
        if self._linear_factor is not None:
            return self._linear_factor
        M, C = self.M, self.C
        if self._same_pattern(KT):
            K = sp.csr_matrix((self.cM * M.data + self.cC * C.data + self.cK * KT.data,
                               KT.indices, KT.indptr), shape=KT.shape)
        else:
            K = (self.cM * M + self.cC * C + self.cK * KT).tocsr()
        self.factorizations += 1
        fac = self.model.factor(K)
        if isinstance(self.force, LinearForce):   # constant K_L: one factorization
            self._linear_factor = fac
        return fac

    def _same_pattern(self, KT: sp.csr_matrix) -> bool:
        M, C = self.M, self.C
        return (M.nnz == KT.nnz == C.nnz and np.array_equal(M.indices, KT.indices)
                and np.array_equal(C.indices, KT.indices))


@dataclass
class TransientResult:
    """Time history: ``t`` (n_rec,), ``u``, ``v``, ``a`` (n_rec, n_dof), Newton iterations."""

    t: Array
    u: Array
    v: Array
    a: Array
    iterations: int


def transient(model: StructuralModel, dt: float, n_steps: int, u0: Array | None = None,
              v0: Array | None = None, rho_bar: float = DEFAULTS.rho_bar,
              temperature: Callable[[float], TemperatureLike] | None = None,
              load: Callable[[float], Array] | None = None, nonlinear: bool = True,
              rtol: float = 1e-10, max_iter: int = 25, record_every: int = 1,
              t0: float = 0.0) -> TransientResult:
    """Transient response by the generalized-alpha method (Eq. 3.45) with Newton per step.

    ``M a_(n+1-am) + C v_(n+1-af) + F_I_(n+1-af) = F_S_(n+1-af)`` with the Newmark updates
    of Eq. (3.45); ``C`` is the proportional damping of the panel (Eq. 3.44), M and C are
    constant (at the initial temperature). The Newton matrix is Eq. (3.48)-(3.49):
    ``(1 - am)/(beta dt^2) M + gamma (1 - af)/(beta dt) C + (1 - af) K_T``. ``rho_bar = 0``
    gives the quasi-steady limit (maximal high-frequency dissipation). The steps are
    :meth:`AlphaStepper.step` with ``scale="net"``.

    Parameters
    ----------
    dt : float
        Time step (s).
    n_steps : int
    u0, v0 : ndarray of shape (n_dof,), optional
        Initial displacement and velocity (zero by default); the initial acceleration is
        computed from the equation of motion.
    temperature : callable t -> temperature input, optional
        Default: the initial temperature.
    load : callable t -> ndarray of shape (n_dof,), optional
        External load vector ``F_S(t)`` (N), e.g. ``model.pressure_load(p(t))``.
    nonlinear : bool
        False: linear model ``K_L u - F_T`` (no von Karman terms).
    """
    n = model.n_dof
    Tf = temperature if temperature is not None else (lambda t: None)
    Ff = load if load is not None else (lambda t: np.zeros(n))
    stepper = AlphaStepper(model, dt, rho_bar=rho_bar, u0=u0, v0=v0, T0=Tf(t0), F0=Ff(t0),
                           rtol=rtol, max_iter=max_iter, nonlinear=nonlinear,
                           mass=model.mass(), damping=model.damping(), scale="net")
    ts = [t0]
    us, vs, as_ = [stepper.u.copy()], [stepper.v.copy()], [stepper.a.copy()]
    for step in range(1, n_steps + 1):
        t1 = t0 + step * dt
        u, v, a = stepper.step(Ff(t1), Tf(t1), t=t1)
        if step % record_every == 0 or step == n_steps:
            ts.append(t1)
            us.append(u.copy())
            vs.append(v.copy())
            as_.append(a.copy())
    return TransientResult(t=np.asarray(ts), u=np.asarray(us), v=np.asarray(vs),
                           a=np.asarray(as_), iterations=stepper.iterations)
