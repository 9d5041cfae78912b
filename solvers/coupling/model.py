"""The coupled aerothermoelastic model of one panel (Ch. 5).

:class:`PanelModel` holds the three disciplines of one panel in one flow -- the DCS9
structure, the HTSH thermal model and a fluid model of any fidelity -- joined by the
conservative transfer matrices of Eq. (5.1). It provides the discipline couplings the
schemes need: aerodynamic loads and their Jacobians on the structural DOFs, the wall heat
flux as an implicit function of the wall temperature, the static aeroelastic equilibrium
(Eq. 5.31b) by Newton with the aerodynamic Jacobian, and the linearized stability analysis
(Eqs. 5.33-5.35). The schemes that march it in time are :func:`hypate.solvers.coupling.tc.run_tc`
(tightly coupled, quasi-steady) and :func:`hypate.solvers.coupling.lc.run_lc` (loosely coupled
S1/S2); :func:`hypate.solvers.coupling.run.simulate` runs a case from its configuration.

The Newton step's linear solves (:func:`~hypate.solvers.coupling.newton.solve_free_block`)
and :class:`~hypate.solvers.coupling.newton.EquilibriumError` live in
:mod:`hypate.solvers.coupling.newton`.
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from hypate.solvers.aero.base import FluidLoads, FluidModel, SurfaceState
from hypate.solvers.coupling.newton import (
    EquilibriumError,
    gmres_on_factor,
    scaled_operator,
    solve_free_block,
)
from hypate.solvers.coupling.response import sinusoidal_modes
from hypate.solvers.coupling.stability import (
    StabilityResult,
    gep,
    pep,
    shift_invert_gep,
    start_vector,
)
from hypate.solvers.coupling.transfer import PointwiseTransfer, Transfer, fluid_points
from hypate.solvers.flow import FlowCondition
from hypate.solvers.numerics.sparse import DeferredMatrix, FreePattern, PermutedLU, csr_rows
from hypate.solvers.panel import PanelSpec
from hypate.solvers.settings import SimulationSettings
from hypate.solvers.structure.model import StructuralModel
from hypate.solvers.structure.stress import SurfaceStress
from hypate.solvers.thermal.loads import SurfaceCondition, ThermalLoads
from hypate.solvers.thermal.model import ThermalModel
from hypate.solvers.thermal.schedule import HeaterSchedule
from numpy.typing import NDArray

Array = NDArray[np.float64]


@dataclass
class StepTimer:
    """Wall time per discipline (s), accumulated over a run (Table 8.6 style), and the work
    counts: sparse factorizations (structural and thermal; the thermal ones alone and the
    thermal residual evaluations are the thermal model's own counters,
    :attr:`ThermalModel.factorizations` and :attr:`ThermalModel.residual_evaluations`),
    Newton iterations of the aeroelastic equilibrium (Eq. 5.31b; every iteration made, those
    of a discarded prediction or load increment included) and shifted solves of the
    pointwise LSA's Arnoldi iteration (Eq. 5.36)."""

    fluid: float = 0.0
    structural: float = 0.0
    thermal: float = 0.0
    stability: float = 0.0
    factorizations: int = 0
    newton_iterations: int = 0
    shifted_solves: int = 0

    def as_dict(self) -> dict[str, float]:
        return {"fluid": self.fluid, "structural": self.structural, "thermal": self.thermal,
                "stability": self.stability}


class PanelModel:
    """A panel in a flow: structure, thermal model, fluid model and transfer (Eq. 5.1).

    Parameters
    ----------
    panel : PanelSpec
    flow : FlowCondition
    fluid : FluidModel
    settings : SimulationSettings
    structure : StructuralModel, optional
        Reused when given (same panel).
    """

    def __init__(self, panel: PanelSpec, flow: FlowCondition, fluid: FluidModel,
                 settings: SimulationSettings | None = None,
                 structure: StructuralModel | None = None) -> None:
        self.panel = panel
        self.flow = flow
        self.fluid = fluid
        self.settings = settings or SimulationSettings()
        self.structure = structure if structure is not None else StructuralModel(panel)
        self.thermal = ThermalModel(panel)
        self.points = fluid_points(panel, self.settings.fluid_density)
        self.transfer = Transfer.build(panel, self.points, self.thermal.n_levels)
        tr = self.transfer
        top = self.thermal.mesh.top_nodes
        # wall temperature from the top-level nodes only; the fluid heat input goes back as
        # nodal loads on them (Eq. 5.1b)
        self._H_FT_top = tr.H_FT[:, top].tocsr()
        self._H_TF_top = tr.H_TF[top, :].tocsr()
        self.timer = StepTimer()
        s = self.settings
        # radiation surroundings: a constant T_rad (the free stream without a heater), or a
        # heater schedule over this article's own duration (nondimensional time t / t_end)
        self.heater = (None if s.radiation_schedule is None
                       else HeaterSchedule(s.radiation_schedule, s.duration))
        if self.heater is not None:
            self.T_rad = float(self.heater(0.0))  # the schedule's start (radiation_temperature)
        else:
            self.T_rad = float(flow.temperature if s.radiation_temperature is None
                               else s.radiation_temperature)
        self._F_ext = (self.structure.pressure_load(s.external_pressure)
                       if s.external_pressure != 0.0 else np.zeros(self.structure.n_dof))
        self.modes = sinusoidal_modes(panel, self.points)
        # LU of a recent (K - K_A)_ff, preconditions the Newton solves
        self._precond: PermutedLU | spla.SuperLU | None = None
        # the transferred Jacobians of a pointwise fluid model (their maps built on first use)
        self.pointwise = PointwiseTransfer(tr, self.structure.pattern, self._H_TF_top,
                                           self._H_FT_top)
        #: Ply stresses at the load-bearing surfaces, recorded by the response each step.
        self.surface_stress = SurfaceStress(self.structure)
        self._last_state: tuple | None = None  # (u, T, K, loads, ...) of the last residual
        self._lsa_start: Array | None = None  # Arnoldi start of the next LSA (last modes)

    @cached_property
    def free_pattern(self) -> FreePattern:
        """The free-DOF block maps of the structural pattern (the solvers' ``(K - K_A)_ff``)."""
        st = self.structure
        return FreePattern(st.pattern.indptr, st.pattern.indices, st.n_dof, st.free_dofs)

    @cached_property
    def _mass_block(self) -> tuple[NDArray[np.intp], NDArray[np.integer], NDArray[np.int32]]:
        """The free block of the mass pattern (:attr:`StructuralModel.mass_slots`) inside the
        free block of the structural pattern: positions in the block's CSR data, column
        indices and row pointers (the LSA's M_ff without its structural zeros)."""
        fp = self.free_pattern
        keep = np.isin(fp.sel, self.structure.mass_slots)
        counts = np.bincount(csr_rows(fp.indptr)[keep], minlength=fp.n)
        indptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int32)
        return np.flatnonzero(keep), fp.indices[keep], indptr

    def _aero_stiffness_data(self, loads: FluidLoads) -> Array | None:
        """K_A as data on the structural CSR pattern when the pressure Jacobian has the
        pointwise form (:meth:`~hypate.solvers.aero.base.FluidJacobians.pressure_coefficients`),
        else None."""
        coeffs = loads.jacobians.pressure_coefficients()
        if coeffs is None:
            return None
        return self.pointwise.stiffness_data @ coeffs[0]  # dp/dw = 0 (pointwise form)

    def _keep_precond(self, lu) -> None:
        self._precond = lu

    def initial_state(self) -> tuple[Array, Array]:
        """(u0, T0) at t = 0: the initial deflection and the initial temperature field."""
        s = self.settings
        T = self.thermal.initial_state() + s.initial_temperature_rise
        u = np.zeros(self.structure.n_dof)
        if s.initial_deflection:
            x, y = self.structure.mesh.x, self.structure.mesh.y
            shape = np.sin(math.pi * x / self.panel.length)
            if self.panel.kind == "3d":
                shape = shape * np.sin(math.pi * y / self.panel.width)
            u[2::5] = s.initial_deflection * self.panel.thickness * shape
        return u, T

    def relax_inplane(self, u: Array, T: Array, max_iter: int = 30) -> Array:
        """Static equilibrium of every DOF but w, with w held at its value.

        A transient run that starts from a deflected or suddenly heated panel needs an
        initial state whose membrane forces balance (the in-plane waves such an imbalance
        excites are far faster than any step the schemes take): the panel starts at rest
        with the in-plane displacements and rotations in equilibrium with ``w``.
        """
        st = self.structure
        T_s = self.structural_temperature(T)
        T_w = self.wall_temperature(T)
        # every DOF except the free w: the constrained ones too, so the penalty springs
        # carry their static reactions (else the first acceleration is absurd there)
        sub = np.setdiff1d(np.arange(st.n_dof), np.intersect1d(st.free_dofs,
                                                               np.arange(2, st.n_dof, 5)))
        u = np.array(u, dtype=float)
        ref = float(np.linalg.norm(st.thermal_load(T_s)))
        for it in range(max_iter):
            F_I, K = st.force_and_tangent(u, T_s)
            R = (F_I - self.aero_force(self.fluid_loads(u, T_w)))[sub]
            rnorm = float(np.linalg.norm(R))
            if it == 0:
                ref = max(ref, rnorm, 1e-3)
            if rnorm <= 1e-9 * ref:
                return u
            u[sub] -= spla.splu(K[sub][:, sub].tocsc()).solve(R)
        raise EquilibriumError("in-plane equilibrium of the initial state did not converge")

    @property
    def thermal_frozen(self) -> bool:
        """True when nothing heats or cools the panel (no aerodynamic heating, no
        radiation, no external heat flux): the temperature field stays at its initial value
        and the thermal steps are skipped."""
        return (self.fluid.heating == "none" and self.panel.emissivity == 0.0
                and self.settings.external_heat_flux == 0.0)

    # -- fields on the fluid grid -------------------------------------------------------
    def wall_temperature(self, T: Array) -> Array:
        """T_w on the fluid points from the thermal nodal field (Eq. 5.1d)."""
        return self.transfer.H_FT @ T

    def surface_state(self, u: Array, T_w: Array, u_dot: Array | None = None) -> SurfaceState:
        tr = self.transfer
        vel = np.zeros(self.points.n) if u_dot is None else tr.H_FS @ u_dot
        return SurfaceState(tr.H_FS @ u, tr.H_FS_slope @ u, vel, T_w)

    def fluid_loads(self, u: Array, T_w: Array, u_dot: Array | None = None,
                    jacobians: bool = False) -> FluidLoads:
        t0 = time.perf_counter()
        out = self.fluid.evaluate(self.points, self.surface_state(u, T_w, u_dot), self.flow,
                                  jacobians=jacobians)
        self.timer.fluid += time.perf_counter() - t0
        return out

    def _wall_loads(self, u: Array) -> Callable[[Array], FluidLoads]:
        """``T_w -> fluid_loads(u, T_w, jacobians=True)`` at a fixed deflection ``u`` (the
        thermal Newton of one step): the wall geometry on the fluid points (Eq. 5.1c) is
        transferred once, not at every thermal residual. Same numbers as fluid_loads."""
        tr = self.transfer
        w, slope = tr.H_FS @ u, tr.H_FS_slope @ u
        vel = np.zeros(self.points.n)
        for a in (w, slope, vel):
            a.flags.writeable = False  # shared by every evaluation of the step

        def loads(T_w: Array) -> FluidLoads:
            t0 = time.perf_counter()
            out = self.fluid.evaluate(self.points, SurfaceState(w, slope, vel, T_w), self.flow,
                                      jacobians=True)
            self.timer.fluid += time.perf_counter() - t0
            return out

        return loads

    def structural_temperature(self, T: Array) -> Array:
        """Thermal nodal field -> per-shell-node through-thickness profile (n_nodes, n_levels)."""
        return self.thermal.profile(T)

    # -- aerodynamic operators on the structural DOFs -------------------------------------
    def aero_force(self, loads: FluidLoads) -> Array:
        """F_S = H_SF p + external load (Eqs. 5.1a, 5.27)."""
        return self.pressure_force(loads.pressure)

    def pressure_force(self, pressure: Array) -> Array:
        """F_S = H_SF p + external load (Eqs. 5.1a, 5.27) for an overpressure ``p`` on the
        fluid points (e.g. the extrapolated pressure of scheme S1, Eq. 5.3)."""
        return self.transfer.H_SF @ pressure + self._F_ext

    def aero_stiffness(self, loads: FluidLoads) -> sp.csr_matrix | spla.LinearOperator:
        """K_A = dF_S/du = H_SF (dp/dw H_FS + dp/dw_s H_FS_slope) (Eq. 5.34)."""
        tr, J = self.transfer, loads.jacobians
        coeffs = J.pressure_coefficients()
        if coeffs is not None:  # pointwise: on the product's own pattern, data only
            return self.pointwise.stiffness(coeffs[0])
        if all(sp.issparse(J[k]) for k in ("dp_dw", "dp_dws")):
            return (tr.H_SF @ (J["dp_dw"] @ tr.H_FS + J["dp_dws"] @ tr.H_FS_slope)).tocsr()
        n = self.structure.n_dof
        return spla.LinearOperator(
            (n, n), dtype=float,
            matvec=lambda x: tr.H_SF @ (J["dp_dw"] @ (tr.H_FS @ x)
                                        + J["dp_dws"] @ (tr.H_FS_slope @ x)))

    def aero_damping(self, loads: FluidLoads) -> sp.csr_matrix:
        """C_A = dF_S/du_dot = H_SF dp/dw_dot H_FS (Eq. 5.34)."""
        tr = self.transfer
        coeffs = loads.jacobians.pressure_coefficients()
        if coeffs is not None:  # pointwise: on the product's own pattern, data only
            return self.pointwise.damping(coeffs[1])
        return sp.csr_matrix(tr.H_SF @ (loads.jacobians["dp_dwdot"] @ tr.H_FS))

    # -- thermal coupling -------------------------------------------------------------------
    def upper_heat_input(self, q_fluid: Array) -> Array:
        """Nodal heat input (W) of the upper surface, ``H_TF (q + q_ext)`` (Eq. 5.1b): the
        fluid heat flux ``q`` on the fluid points plus the uniform external heat flux
        ``settings.external_heat_flux`` (Eq. 6.1d), both W/m^2."""
        return self._H_TF_top @ (q_fluid + self.settings.external_heat_flux)

    def radiation_temperature(self, t: float) -> float:
        """Temperature of the radiation surroundings at time ``t`` (s): the constant
        :attr:`T_rad`, or the heater schedule ``T_rad(t)`` (its control points at the
        fractions of ``settings.duration``)."""
        return self.T_rad if self.heater is None else float(self.heater(t))

    def thermal_loads(self, u: Array, t: float = 0.0) -> ThermalLoads:
        """Upper surface: aerodynamic heat flux implicit in the wall temperature (Eq. 5.31a)
        plus the external heat flux (Eq. 6.1d) and radiation to ``T_rad`` at time ``t``
        (:meth:`radiation_temperature`, Eq. 4.24); lower surface insulated."""
        H_FT, H_TF = self._H_FT_top, self._H_TF_top
        wall_loads = self._wall_loads(u)
        cache: list = []

        def flux(T_top: Array) -> tuple[Array, DeferredMatrix]:
            # nodal heat input Q = H_TF q (Eq. 5.1b) and its derivative, on the thermal pattern;
            # the Newton asks twice at the same T (residual, then Jacobian): cached
            if cache and np.array_equal(cache[0], T_top):
                return cache[1], cache[2]
            loads = wall_loads(H_FT @ T_top)
            J = loads.jacobians
            n_top = T_top.size

            def build() -> sp.csr_matrix:  # formed only when the thermal Newton needs it
                coeffs = J.tw_coefficients()
                if coeffs is None:  # from the block: H_TF dq/dT_w H_FT
                    return (H_TF @ sp.csr_matrix(J["dq_dTw"]) @ H_FT).tocsr()
                return self.pointwise.wall_flux_derivative(*coeffs)  # diag(a) + diag(b) S

            dQ = DeferredMatrix(build, (n_top, n_top))
            out = (self.upper_heat_input(loads.heat_flux), dQ)
            cache[:] = [np.array(T_top, copy=True), *out]
            return out

        top = SurfaceCondition(flux=flux, emissivity=self.panel.emissivity,
                               T_rad=self.radiation_temperature(t), nodal_load=True)
        return ThermalLoads(top=top)

    def thermal_step(self, T: Array, u: Array, dt: float, T_guess: Array | None = None,
                     t: float = 0.0) -> Array:
        """Temperatures after one Crank-Nicolson step (Eq. 4.28) from ``T`` at time ``t``
        (s) over ``dt`` with the deflection ``u``; the boundary loads are those of the
        step's collocation time ``t + alpha dt`` (a scheduled heater's ``T_rad`` too), at
        which Eq. (4.28) evaluates them."""
        t0, fl0 = time.perf_counter(), self.timer.fluid
        f0 = self.thermal.factorizations
        # consecutive steps of the quasi-steady scheme are close: chord iterations with the
        # last step's factorization while they contract the residual by >= 30x, else a
        # fresh Jacobian (the same solution; 15 % less thermal time than a Jacobian and a
        # factorization every step on the Sec. 9.2 benchmark)
        alpha = self.settings.thermal_alpha
        res = self.thermal.step(T, dt, self.thermal_loads(u, t + alpha * dt), alpha=alpha,
                                T_guess=T_guess, jacobian="modified", contraction=0.03)
        self.timer.factorizations += self.thermal.factorizations - f0
        # the implicit wall flux calls the fluid model: count that time as fluid only
        self.timer.thermal += time.perf_counter() - t0 - (self.timer.fluid - fl0)
        if not res.converged:
            raise EquilibriumError(f"thermal Newton did not converge (residual "
                                   f"{res.residual_norm:.3g} W)")
        return res.T

    # -- aeroelastic equilibrium ---------------------------------------------------------------
    def equilibrium(self, u: Array, T: Array, guess: Array | None = None
                    ) -> tuple[Array, int]:
        """Static aeroelastic equilibrium ``F_I(u, T) = F_S(u, 0, T)`` (Eq. 5.31b).

        Newton-Raphson with the aerodynamic Jacobian (Eq. 5.42) from ``u``. Full Newton
        steps are taken (a residual-norm line search stalls on the membrane stiffening of
        thin panels); when Newton fails, the load -- the aerodynamic force and the
        temperature rise from the initial state -- is applied in increments from ``u``.

        ``guess`` (optional) is a predicted solution, e.g. extrapolated from the previous
        time steps: Newton starts there first, and its result is kept only when the
        correction is smaller than the prediction's distance from ``u`` (so a prediction
        past a limit point cannot carry the solution to another equilibrium branch); else
        the solution starts from ``u`` as without a guess.

        Returns
        -------
        u, iterations
        """
        if guess is not None:
            precond = self._precond
            try:
                x, it = self._newton(guess, T, 1.0)
                if np.linalg.norm(x - guess) <= np.linalg.norm(guess - u):
                    return x, it
            except EquilibriumError:
                pass
            # a failed prediction leaves no trace: the solution from u proceeds exactly as
            # without one (same preconditioner, hence the same Newton path)
            self._precond = precond
        try:
            return self._newton(u, T, 1.0)
        except EquilibriumError:
            pass
        T0 = self.thermal.initial_state()
        total = 0
        for steps in (4, 16):
            x = np.array(u, copy=True)
            try:
                for k in range(1, steps + 1):
                    lam = k / steps
                    x, it = self._newton(x, T0 + lam * (T - T0), lam)
                    total += it
                return x, total
            except EquilibriumError:
                continue
        return self._newton(u, T, 1.0)  # raises with the diagnostic of the full problem

    def continued_equilibrium(self, u: Array, T_from: Array, T_to: Array, steps: int
                              ) -> Array:
        """The equilibrium at ``T_to`` followed from the converged state ``(u, T_from)``
        through ``steps`` equal increments of the temperature field, each Newton started
        at the last (natural continuation of Eq. 5.31b in the thermal load): the branch
        the quasi-steady path is on, where one Newton from ``u`` at ``T_to`` may converge to
        an unstable equilibrium of another branch. Raises :class:`EquilibriumError` when
        an increment has no equilibrium."""
        x = u
        for k in range(1, steps + 1):
            x, _ = self.equilibrium(x, T_from + (T_to - T_from) * (k / steps))
        return x

    def solver_state(self) -> tuple[Any, ...]:
        """What the solvers carry from one call to the next (the Newton preconditioner, the
        last residual's state, the Arnoldi start): :meth:`restore_solver_state` undoes a
        trial so the run proceeds exactly as without it."""
        return (self._precond, self._last_state, self._lsa_start)

    def restore_solver_state(self, state: tuple[Any, ...]) -> None:
        self._precond, self._last_state, self._lsa_start = state

    def _newton(self, u: Array, T: Array, load: float) -> tuple[Array, int]:
        """Newton iterations on ``F_I(u, T) - load * F_S(u, T) = 0`` (free DOFs; the
        constrained DOFs keep their values)."""
        s = self.settings
        st = self.structure
        T_s = self.structural_temperature(T)
        T_w = self.wall_temperature(T)
        free = st.free_dofs

        def residual(x: Array):
            loads = self.fluid_loads(x, T_w, jacobians=True)
            t0 = time.perf_counter()
            F_I, K = st.force_and_tangent(x, T_s)
            self.timer.structural += time.perf_counter() - t0
            # the LSA at the converged state reuses the tangent and the fluid loads
            self._last_state = (x, T, K, loads, self.flow, self.fluid)
            return F_I - load * self.aero_force(loads), K, loads

        R, K, loads = residual(u)
        ref = max(float(np.linalg.norm(st.thermal_load(T_s)[free])),
                  float(np.linalg.norm((self.transfer.H_SF @ loads.pressure)[free])),
                  float(np.linalg.norm(self._F_ext[free])), 1e-3)
        rnorm = float(np.linalg.norm(R[free]))
        for it in range(s.newton_max_iter):
            if rnorm <= s.newton_rtol * ref:
                return u, it
            t0 = time.perf_counter()
            du = np.zeros_like(u)
            KA_data = self._aero_stiffness_data(loads)
            if KA_data is not None:
                # pointwise fluid: (K - load K_A) on the structural pattern, data only
                du[free] = self._solve_free(K.data - load * KA_data, -R[free])
            else:
                KA = self.aero_stiffness(loads)
                KA = load * KA if sp.issparse(KA) else scaled_operator(KA, load)
                du[free] = self._solve(K, KA, -R[free])
            self.timer.structural += time.perf_counter() - t0
            self.timer.newton_iterations += 1
            u = u + du
            R, K, loads = residual(u)
            rnorm = float(np.linalg.norm(R[free]))
            if not np.isfinite(rnorm):
                break
        raise EquilibriumError(
            f"aeroelastic equilibrium did not converge in {s.newton_max_iter} Newton "
            f"iterations (residual {rnorm:.3g} N vs scale {ref:.3g} N)")

    def _solve_free(self, data: Array, b: Array) -> Array:
        """:meth:`_solve` for ``K - K_A`` given as data on the structural pattern (pointwise
        fluid): the free block by index maps, the factor by
        :meth:`hypate.solvers.numerics.sparse.FreePattern.factor`."""
        fp = self.free_pattern
        block = data[fp.sel]
        A = sp.csr_matrix((block, fp.indices, fp.indptr), shape=(fp.n, fp.n))
        x = gmres_on_factor(A.__matmul__, self._precond, b)
        if x is not None:
            return x
        self.timer.factorizations += 1
        self._precond = fp.factor(block)
        return self._precond.solve(b)

    def _solve(self, K: sp.csr_matrix, KA, b: Array) -> Array:
        """:func:`solve_free_block` with the kept preconditioner; a new factor replaces it."""
        return solve_free_block(K, KA, b, self.structure.free_dofs, self._precond,
                                on_factor=self._new_precond)

    def _new_precond(self, lu: spla.SuperLU) -> None:
        self.timer.factorizations += 1
        self._precond = lu

    # -- stability -----------------------------------------------------------------------------
    def stability(self, u: Array, T: Array, method: str = "gep") -> StabilityResult:
        """LSA about the state (u, T): GEP (Eq. 5.35) or PEP with C - C_A (Eq. 5.33)."""
        t0, fl0 = time.perf_counter(), self.timer.fluid
        st = self.structure
        T_s = self.structural_temperature(T)
        last = self._last_state
        if (last is not None and last[4] is self.flow and last[5] is self.fluid
                and np.array_equal(last[0], u) and np.array_equal(last[1], T)):
            K, loads = last[2], last[3]  # the Newton's last residual is at this state
        else:
            loads = self.fluid_loads(u, self.wall_temperature(T), jacobians=True)
            K = st.tangent(u, T_s)
        M = st.mass(T_s)
        KA_data = self._aero_stiffness_data(loads) if method == "gep" else None
        if KA_data is not None:
            res = self._gep_pointwise(K, M, KA_data)
            self.timer.stability += time.perf_counter() - t0 - (self.timer.fluid - fl0)
            self.timer.factorizations += 1
            return res
        KA = self.aero_stiffness(loads)
        free = st.free_dofs
        if not sp.issparse(KA):
            KA = sp.csr_matrix(KA @ np.eye(st.n_dof))  # ROM operator: small dense product
        if method == "pep":
            res = pep(K, M, st.damping(T_s), KA, self.aero_damping(loads),
                      count=self.settings.lsa_modes, free=free)
        else:
            res = gep(K, M, KA, count=self.settings.lsa_modes, free=free,
                      on_factor=self._keep_precond)
        self.timer.stability += time.perf_counter() - t0 - (self.timer.fluid - fl0)
        self.timer.factorizations += 1
        return res

    def _gep_pointwise(self, K: sp.csr_matrix, M: sp.csr_matrix, KA_data: Array
                       ) -> StabilityResult:
        """:func:`hypate.solvers.coupling.stability.gep` (direct solver, default shift) on the
        free block built by index maps; its factor becomes the Newton preconditioner."""
        fp = self.free_pattern
        Kb, Mb = K.data[fp.sel], M.data[fp.sel]
        scale = float(np.mean(np.abs(Kb[fp.diag]) / np.maximum(np.abs(Mb[fp.diag]), 1e-300)))
        sigma = -1e-9 * scale  # as gep's default shift
        lu = fp.factor((Kb - sigma * Mb) - KA_data[fp.sel])
        self._keep_precond(lu)
        # the mass couples like DOFs only: 80 % of the shell pattern's entries are zero, and
        # each Arnoldi step multiplies by M (3.5x faster without them)
        # (its structural zeros dropped by the kept pattern, then the exact zeros of this
        # mass, e.g. the u-psi couplings I2 of a symmetric stack: the same M_ff as before)
        msel, m_indices, m_indptr = self._mass_block
        Mff = sp.csr_matrix((Mb[msel], m_indices.copy(), m_indptr.copy()), shape=(fp.n, fp.n))
        Mff.eliminate_zeros()
        k = self.settings.lsa_modes

        def keep(vectors):  # the next LSA starts from these modes (nearby state)
            self._lsa_start = start_vector(vectors)

        def solve(b: Array) -> Array:  # counted: the Arnoldi's share of the step's work
            self.timer.shifted_solves += 1
            return lu.solve(b)

        # started from the last step's modes with ARPACK's default 20 Arnoldi vectors, the
        # eigenvalues converge in the first Arnoldi pass: 21 shifted solves per LSA instead
        # of 27 (random start, 2k + 2 vectors), the same eigenvalues to 1e-13 (measured on
        # the Sec. 9.2 benchmark)
        return shift_invert_gep(solve, Mff, sigma, count=k, rng=0,
                                v0=self._lsa_start, on_vectors=keep)

