"""The loosely coupled (staggered) transient schemes S1 and S2 (Sec. 5.3.1).

:func:`run_lc` marches the structure (generalized-alpha), the thermal model
(Crank-Nicolson) and the fluid one after the other with extrapolated interface values
(Eqs. 5.2-5.8); the helpers are the smooth flow start (:func:`smoothstep`), the fluid's wall
velocity from the displacements it is handed (:func:`bdf2_velocity`, Eq. 2.28), the thermal
loads with an explicit heat flux (:func:`explicit_thermal_loads`) and the snap-through onset
of a deflection history (:func:`snap_onset`).
"""
from __future__ import annotations

import math
import time

import numpy as np
from hypate.solvers.aero.base import FluidLoads
from hypate.solvers.coupling.model import PanelModel
from hypate.solvers.coupling.newton import EquilibriumError
from hypate.solvers.coupling.response import Response
from hypate.solvers.errors import InputError
from hypate.solvers.structure.dynamics import AlphaStepper
from hypate.solvers.thermal.loads import SurfaceCondition, ThermalLoads
from numpy.typing import NDArray

Array = NDArray[np.float64]


def explicit_thermal_loads(model: PanelModel, q_fluid: Array, t: float = 0.0) -> ThermalLoads:
    """Thermal loads with a given (estimated) fluid heat flux plus the external heat flux
    (Eq. 6.1d) and radiation to the surroundings at time ``t`` (S1/S2; a scheduled
    heater's ``T_rad(t)``, :meth:`PanelModel.radiation_temperature`)."""
    top = SurfaceCondition(flux=model.upper_heat_input(q_fluid),
                           emissivity=model.panel.emissivity,
                           T_rad=model.radiation_temperature(t), nodal_load=True)
    return ThermalLoads(top=top)


def run_lc(model: PanelModel, scheme: str = "s2", rho_bar: float | None = None,
           record_every: int = 1,
           progress=None, stop_on_snap: bool = True,
           record_energy: bool = False, ramp_time: float = 0.0) -> Response:
    """Loosely coupled transient schemes S1 and S2 (Sec. 5.3.1), time step ``settings.time_step``.

    Both: thermal step with the extrapolated heat flux ``1.5 q^n - 0.5 q^(n-1)`` (Eq. 5.2).
    S1: structure with the extrapolated pressure ``2 p^n - p^(n-1)`` (Eq. 5.3), then the fluid
    at the new displacement (Eq. 5.4). S2: fluid at the extrapolated displacement
    ``u^n + dt (1.5 v^n - 0.5 v^(n-1))`` (Eq. 5.5), then the structure with that pressure
    (Eq. 5.6). Start: Eq. (5.7). Generalized-alpha structure, Crank-Nicolson thermal.
    The fluid is handed displacements only (Eq. 5.8) and forms the wall velocity of the
    piston-theory term from them by the three-point backward difference of Eq. (2.28).

    ``ramp_time > 0`` gives a smooth start: the fluid pressure and heat flux are multiplied
    by the C^3 smoothstep ``s(t / ramp_time)`` (``s = 35x^4 - 84x^5 + 70x^6 - 20x^7``, 0 at
    t = 0, 1 from ``ramp_time`` on) -- a flow switched on over ``ramp_time`` instead of
    impulsively. The default 0 is the impulsive start of the benchmarks; the smooth start is
    for convergence studies, where the impulsive start's high-frequency transient (modes no
    practical step resolves) masks the schemes' order. The stored pressure and heat flux are
    the ramped ones.

    ``rho_bar`` (generalized-alpha spectral radius, Eq. 3.45): ``None`` takes
    ``model.settings.rho_bar``.

    The run ends at ``settings.duration``; with ``stop_on_snap`` it ends once a snap-through
    is over (the centre deflection has reversed sign and passed its pre-snap magnitude).

    With ``record_energy`` the artificial energy of the fluid-structure interface of every
    step (Sec. 5.3.3) is stored in ``Response.artificial_energy`` (J, entry ``n-1`` for the
    step ``t^(n-1) -> t^n``; NaN for the start step, Eq. 5.7):
    ``dE = dE_S + dE_F`` (Eq. 5.21), with the work on the structure
    ``dE_S = 1/2 (F^(n+1,E) + F^(n,E))^T (u^(n+1) - u^n)`` (Eq. 5.19) and the work on the fluid
    ``dE_F = -1/2 (F^(n+1) + F^n)^T (u^(n+1,E) - u^(n,E))`` (Eq. 5.20), ``F = H_SF p``;
    superscript E marks the estimated values each scheme hands over (S1: ``p^E`` by Eq. 5.3,
    ``u^E = u``; S2: ``p^E = p``, ``u^E`` by Eq. 5.5). Per step it is O(dt^3) for S1 (Eq. 5.23)
    and O(dt^4) for S2 (Eq. 5.24).
    """
    # One long function (about 120 lines of code), knowingly: the S1/S2 step updates a dozen
    # interface histories together (p, q, u^E, v^(n-1), the energy terms); split, each piece
    # would pass them all around. A stepper object holding them is the next step.
    if scheme not in ("s1", "s2"):
        raise InputError("simulation.scheme", "loosely coupled schemes are 's1' and 's2'")
    s = model.settings
    dt, n_steps = s.time_step, s.n_steps
    st, tr = model.structure, model.transfer
    resp = Response.start(model, scheme=scheme)
    u0, T = model.initial_state()
    u0 = model.relax_inplane(u0, T)
    T_s = model.structural_temperature(T)
    T_w = model.wall_temperature(T)
    if not (ramp_time >= 0.0 and math.isfinite(ramp_time)):
        raise InputError("ramp_time", "must be >= 0 (s)")

    def fluid(t: float, u: Array, T_w: Array, u_dot: Array | None = None) -> FluidLoads:
        """The fluid solution at t (ramped on over ``ramp_time``)."""
        loads = model.fluid_loads(u, T_w, u_dot=u_dot)
        k = smoothstep(t / ramp_time) if ramp_time > 0.0 else 1.0
        return loads if k == 1.0 else FluidLoads(k * loads.pressure, k * loads.heat_flux)

    def record(t: float, u: Array, T: Array, u_dot: Array | None = None) -> None:
        resp.record(t, u, T, model, None, u_dot=u_dot)
        k = smoothstep(t / ramp_time) if ramp_time > 0.0 else 1.0
        if k != 1.0 and resp.keep_fields:
            resp.pressure[-1] *= k
            resp.heat_flux[-1] *= k

    loads0 = fluid(0.0, u0, T_w)
    F0 = model.aero_force(loads0)
    rho = model.settings.rho_bar if rho_bar is None else rho_bar  # None: the settings'
    stepper = AlphaStepper(st, dt, rho_bar=rho, u0=u0, T0=T_s, F0=F0)
    record(0.0, stepper.u, T)
    center = 5 * st.mesh.center + 2
    t_start = time.perf_counter()
    # start procedure, Eq. (5.7): u^1, v^1 from the initial acceleration -- on the free
    # transverse DOFs; the in-plane, rotational and penalty-constrained DOFs are far
    # stiffer than any explicit step resolves, so they are relaxed to equilibrium at t^1
    w_free = np.intersect1d(st.free_dofs, np.arange(2, st.n_dof, 5))
    u1, v1 = stepper.u.copy(), stepper.v.copy()
    u1[w_free] += dt * stepper.v[w_free] + 0.5 * dt * dt * stepper.a[w_free]
    v1[w_free] += dt * stepper.a[w_free]
    p_hist = [loads0.pressure, loads0.pressure]  # [p^n, p^(n-1)]; n = 1 sets both anew
    q_hist = [loads0.heat_flux, loads0.heat_flux]
    v_prev = stepper.v.copy()
    # displacements handed to the fluid at the last two step ends, u^(n,E) and u^(n-1,E)
    # (Eq. 5.8): the fluid forms its wall velocity from them by Eq. (2.28)
    uE_hist = [u0, u0]
    peak = 0.0
    # interface histories of the energy balance (Sec. 5.3.3): estimated and actual pressure
    # and the estimated displacement at the previous step end
    pE_prev = p_act_prev = uE_prev = None
    try:
        for n in range(1, n_steps + 1):
            t = n * dt
            # -- thermal step with the extrapolated heat flux (Eq. 5.2)
            if not model.thermal_frozen:
                q_est = 1.5 * q_hist[0] - 0.5 * q_hist[1]
                t0 = time.perf_counter()
                t_load = t - dt + s.thermal_alpha * dt  # Eq. (4.28) collocation time
                res = model.thermal.step(T, dt, explicit_thermal_loads(model, q_est, t_load),
                                         alpha=s.thermal_alpha)
                model.timer.thermal += time.perf_counter() - t0
                if not res.converged:
                    raise EquilibriumError("thermal Newton did not converge")
                T = res.T
                T_s = model.structural_temperature(T)
                T_w = model.wall_temperature(T)
            if n == 1:
                # Eq. (5.7): the first step is taken by the start procedure
                u1 = model.relax_inplane(u1, T)
                loads = fluid(t, u1, T_w, u_dot=v1)
                stepper.u, stepper.v = u1, v1
                stepper.FI = st.internal_force(u1, T_s)
                stepper.F = model.aero_force(loads)
                stepper.a = st.solver.factor(stepper.M).solve(
                    stepper.F - stepper.FI - (stepper.C @ v1 if stepper.has_damping else 0.0))
                p_hist = [loads.pressure, p_hist[0]]
                pE_prev = p_act_prev = loads.pressure
                uE_prev = u1
                uE_hist = [u1, uE_hist[0]]
                if record_energy:
                    resp.artificial_energy.append(float("nan"))
            elif scheme == "s1":
                p_est = 2.0 * p_hist[0] - p_hist[1]  # Eq. (5.3)
                u_old = stepper.u
                t0 = time.perf_counter()
                u, v, _ = stepper.step(model.pressure_force(p_est), T_s)
                model.timer.structural += time.perf_counter() - t0
                # Eq. (5.4): u^(n+1,E) = u^(n+1); wall velocity by Eq. (2.28)
                loads = fluid(t, u, T_w, u_dot=bdf2_velocity(u, uE_hist, dt))
                uE_hist = [u, uE_hist[0]]
                p_hist = [loads.pressure, p_hist[0]]
                if record_energy:  # Eqs. (5.19)-(5.21) with u^E = u
                    assert pE_prev is not None and p_act_prev is not None  # set at n == 1
                    du = tr.H_SF.T @ (u - u_old)
                    resp.artificial_energy.append(float(
                        0.5 * (p_est + pE_prev) @ du - 0.5 * (loads.pressure + p_act_prev) @ du))
                pE_prev, p_act_prev = p_est, loads.pressure
            else:
                u_est = stepper.u + dt * (1.5 * stepper.v - 0.5 * v_prev)  # Eq. (5.5)
                # the fluid's wall velocity at t^(n+1) from the estimated displacements,
                # Eq. (2.28) (not 1.5 v^n - 0.5 v^(n-1): that is v at t^(n+1/2), an O(dt)
                # error in the piston-theory velocity term)
                loads = fluid(t, u_est, T_w, u_dot=bdf2_velocity(u_est, uE_hist, dt))
                uE_hist = [u_est, uE_hist[0]]
                v_prev = stepper.v.copy()
                u_old = stepper.u
                t0 = time.perf_counter()
                stepper.step(model.aero_force(loads), T_s)  # Eq. (5.6)
                model.timer.structural += time.perf_counter() - t0
                p_hist = [loads.pressure, p_hist[0]]
                if record_energy:  # Eqs. (5.19)-(5.21) with p^E = p
                    assert p_act_prev is not None and uE_prev is not None  # set at n == 1
                    p_mid = 0.5 * (loads.pressure + p_act_prev)
                    resp.artificial_energy.append(float(
                        p_mid @ (tr.H_SF.T @ ((stepper.u - u_old) - (u_est - uE_prev)))))
                pE_prev, p_act_prev, uE_prev = loads.pressure, loads.pressure, u_est
            if n == 1:
                v_prev = stepper.v.copy() if scheme == "s1" else v_prev
            q_hist = [loads.heat_flux, q_hist[0]]
            if not np.all(np.isfinite(stepper.u)):
                raise EquilibriumError("the transient response diverged (non-finite state)")
            if n % record_every == 0 or n == n_steps:
                record(t, stepper.u, T, u_dot=stepper.v)
            if progress is not None:
                progress(n, n_steps)
            w = float(stepper.u[center])
            if stop_on_snap:
                if abs(w) > abs(peak) and (peak == 0.0 or np.sign(w) == np.sign(peak)):
                    peak = w
                elif (abs(peak) > 0.25 * model.panel.thickness and np.sign(w) != np.sign(peak)
                      and abs(w) > abs(peak)):
                    onset = snap_onset(np.asarray(resp.times), np.asarray(resp.center_deflection))
                    resp.finish("unstable", "snap-through", (onset, "divergence"))
                    break
        else:
            resp.finish("completed", "", None)
    except EquilibriumError as exc:
        resp.finish("failed", str(exc), None)
    resp.wall_seconds = time.perf_counter() - t_start
    resp.timing = model.timer.as_dict()
    return resp


def smoothstep(x: float) -> float:
    """C^3 smoothstep ``35x^4 - 84x^5 + 70x^6 - 20x^7`` on [0, 1], 0 below and 1 above."""
    x = min(max(float(x), 0.0), 1.0)
    return x ** 4 * (35.0 - 84.0 * x + 70.0 * x * x - 20.0 * x ** 3)


def bdf2_velocity(u_new: Array, u_hist: list[Array], dt: float) -> Array:
    """Wall velocity the fluid forms from the displacements it is handed, Eq. (2.28):
    ``(3 u^(n+1,E) - 4 u^(n,E) + u^(n-1,E)) / (2 dt)``, second order at t^(n+1)."""
    return (3.0 * u_new - 4.0 * u_hist[0] + u_hist[1]) / (2.0 * dt)


def snap_onset(times: Array, w: Array) -> float:
    """Onset of a snap-through in a deflection history: the last time the deflection still
    moved away from zero on the pre-snap side (the turning point before the reversal)."""
    sign0 = np.sign(w[np.argmax(np.abs(w[: max(2, np.argmax(np.sign(w) != np.sign(w[-1])))]))])
    pre = np.flatnonzero(np.sign(w) == sign0)
    if pre.size == 0:
        return float(times[0])
    last = pre[-1]
    k = int(np.argmax(np.abs(w[: last + 1])))
    return float(times[k])
