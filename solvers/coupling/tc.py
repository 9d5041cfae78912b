"""The tightly coupled quasi-steady scheme (Sec. 5.4.3) with the LSA every step.

:func:`run_tc` integrates Eq. (5.31) on the thermal time scale: each step a Crank-Nicolson
thermal step with the aerodynamic heat flux implicit in the wall temperature, then the
aeroelastic equilibrium with fluid and structure converged together, optionally repeated
(fixed-point passes) until both fields stop changing; then the LSA (Eqs. 5.33-5.35). The run
stops after ``unstable_steps`` consecutive unstable LSA results. With ``continuation_steps``
> 0 a step whose equilibrium may have left the quasi-steady path (divergent, or a jump of
the deflection field) is checked by continuation in the temperature from the last state
(:func:`_off_path`, :func:`_continued_step`).
"""
from __future__ import annotations

import time

import numpy as np
from hypate.solvers.coupling.model import PanelModel
from hypate.solvers.coupling.newton import EquilibriumError
from hypate.solvers.coupling.response import Response
from hypate.solvers.coupling.stability import StabilityResult
from hypate.solvers.numerics.threads import single_threaded_blas
from numpy.typing import NDArray

Array = NDArray[np.float64]

#: Relative change of the deflection field in one step above which the step's equilibrium
#: is checked against the continuation (``continuation_steps``): a buckling or a branch jump
#: moves it by about its own size or twice, a quasi-steady step by a fraction.
JUMP = 0.5
#: Relative distance below which the continued state is the one Newton found (kept as is).
SAME_STATE = 1e-3


def extrapolate(history: list[Array]) -> Array:
    """Polynomial extrapolation to the next of equally spaced states, ``history`` newest
    first: ``3 x_n - 3 x_(n-1) + x_(n-2)`` (quadratic) from three states, ``2 x_n - x_(n-1)``
    from two, ``x_n`` from one. A smooth history ``x(t)`` is predicted to O(dt^3)."""
    if len(history) >= 3:
        return 3.0 * history[0] - 3.0 * history[1] + history[2]
    if len(history) == 2:
        return 2.0 * history[0] - history[1]
    return np.array(history[0], copy=True)


def _coupled_step(model: PanelModel, T: Array, u: Array, t: float, T_hist: list[Array],
                  u_hist: list[Array], continued: bool = False) -> tuple[Array, Array]:
    """One step from the converged state ``(T, u)`` to time ``t``: the thermal step and the
    aeroelastic equilibrium, repeated as fixed-point passes (Sec. 5.4.3). ``T_hist`` and
    ``u_hist`` are the earlier states, newest first (the Newton predictors). With
    ``continued``, each pass's equilibrium is instead followed by continuation in the
    temperature from ``(u, T)`` (:meth:`PanelModel.continued_equilibrium`)."""
    s = model.settings
    dt = s.time_step
    T_new, u_new = T, u
    for k in range(s.passes):
        T_prev, u_prev = T_new, u_new
        if not model.thermal_frozen:
            # the thermal Newton starts from the extrapolation of the last steps (same
            # solution, about one Newton iteration fewer per step)
            guess = T_new if (k > 0 or not T_hist) else extrapolate([T, *T_hist])
            T_new = model.thermal_step(T, u_new, dt, T_guess=guess, t=t - dt)
        if continued:
            u_new = model.continued_equilibrium(u, T, T_new, s.continuation_steps)
        else:
            # likewise the aeroelastic Newton (the same equilibrium to its tolerance: 1.3
            # instead of 2.4 iterations per step on the Sec. 9.2 benchmark)
            u_guess = extrapolate([u, *u_hist]) if (k == 0 and u_hist) else None
            u_new, _ = model.equilibrium(u_new, T_new, guess=u_guess)
        dT = np.max(np.abs(T_new - T_prev)) / max(np.max(np.abs(T_new - T)), 1e-12)
        du = np.max(np.abs(u_new - u_prev)) / max(np.max(np.abs(u_new)), 1e-12)
        if dT <= s.pass_tol and du <= s.pass_tol:
            break
    return T_new, u_new


def _off_path(model: PanelModel, u_last: Array, u: Array, lsa: StabilityResult | None
              ) -> bool:
    """Whether one Newton's equilibrium of a step may have left the quasi-steady path: the
    LSA finds it divergent, or its deflection field moved by more than :data:`JUMP` of its
    size (the flat panel buckling, or a jump onto another branch)."""
    if lsa is not None and lsa.status == "divergence":
        return True
    w_last, w = model.structure.deflection(u_last), model.structure.deflection(u)
    size = max(float(np.linalg.norm(w_last)), float(np.linalg.norm(w)))
    return float(np.linalg.norm(w - w_last)) > JUMP * size


def _continued_step(model: PanelModel, T: Array, u: Array, t: float,
                    found: tuple[Array, Array, StabilityResult | None], resp: Response
                    ) -> tuple[Array, Array, StabilityResult | None]:
    """A step off the path (:func:`_off_path`) followed from the last state ``(T, u)`` by
    continuation in ``settings.continuation_steps`` increments of the temperature: one
    Newton from the flat, pre-buckling state across a large temperature step converges to
    whichever equilibrium its start is nearest in Newton's sense -- the unstable one between
    the buckled branches, or the branch the panel does not buckle onto. The continued state
    replaces ``found`` when it is an equilibrium all the way, not unstable, and another
    state than ``found`` (the step is then listed in ``resp.continued``). Otherwise
    ``found`` stays -- the same state, or a snap-through (the path's equilibrium ceased to
    exist) -- and the run proceeds exactly as without the trial."""
    state = model.solver_state()
    T_f, u_f, _ = found
    try:  # the equilibrium at the step's temperature (the thermal solver is not touched)
        u_c = model.continued_equilibrium(u, T, T_f, model.settings.continuation_steps)
        lsa_c = model.stability(u_c, T_f)
    except EquilibriumError:
        lsa_c = None
    if lsa_c is None or lsa_c.unstable or \
            np.linalg.norm(u_c - u_f) <= SAME_STATE * np.linalg.norm(u_f):
        model.restore_solver_state(state)
        return found
    resp.continued.append(t)
    if model.settings.passes == 1:  # T_f came from the last state: it is the step's
        return T_f, u_c, lsa_c
    # fixed-point passes: the temperature converges with the continued deflection
    T_c, u_c = _coupled_step(model, T, u, t, [], [], continued=True)
    return T_c, u_c, model.stability(u_c, T_c)


def run_tc(model: PanelModel, progress=None) -> Response:
    """Tightly coupled quasi-steady scheme (Sec. 5.4.3) with LSA each step.

    Parameters
    ----------
    model : PanelModel
    progress : callable(step, n_steps), optional
        Called after every step.

    Returns
    -------
    Response
        Histories up to the end or to the instability (``instability_time``,
        ``instability_type``); a solver failure ends the run with ``status = "failed"``
        and the reason in ``message`` (never an exception).
    """
    # one BLAS thread: every dense operation of a step is small, and on a busy machine
    # OpenBLAS's second thread spins or waits for a core (measured: the ARPACK eigenvector
    # extraction takes 50 ms instead of 1 ms, the whole run 30-50 % longer)
    with single_threaded_blas():
        return _run_tc(model, progress)


def _run_tc(model: PanelModel, progress) -> Response:
    s = model.settings
    dt, n_steps = s.time_step, s.n_steps
    resp = Response.start(model, scheme="tc")
    u, T = model.initial_state()
    unstable_run = 0
    first_unstable: tuple[float, str] | None = None
    t_start = time.perf_counter()
    try:
        u, _ = model.equilibrium(u, T)
        lsa: StabilityResult | None = model.stability(u, T)
        resp.record(0.0, u, T, model, lsa)
        # converged states of the previous steps, newest first: the Newton predictors
        T_hist: list[Array] = []
        u_hist: list[Array] = []
        for n in range(1, n_steps + 1):
            t = n * dt
            T_new, u_new = _coupled_step(model, T, u, t, T_hist, u_hist)
            T_hist, u_hist = [T, *T_hist[:1]], [u, *u_hist[:1]]
            T, u = T_new, u_new
            lsa = model.stability(u, T) if n % s.lsa_every == 0 else None
            if s.continuation_steps and _off_path(model, u_hist[0], u, lsa):
                T, u, lsa = _continued_step(model, T_hist[0], u_hist[0], t, (T, u, lsa),
                                            resp)
            resp.record(t, u, T, model, lsa)
            if progress is not None:
                progress(n, n_steps)
            if lsa is not None and lsa.unstable:
                unstable_run += 1
                if first_unstable is None:
                    first_unstable = (t, lsa.status)
                if unstable_run >= s.unstable_steps:
                    resp.finish("unstable", f"{lsa.status} detected by the LSA at "
                                f"t = {first_unstable[0]:g} s", first_unstable)
                    break
            elif lsa is not None:
                unstable_run, first_unstable = 0, None
        else:
            resp.finish("completed", "", None)
    except EquilibriumError as exc:
        if not resp.times:
            resp.finish("failed", f"no equilibrium at t = 0: {exc}", None)
        else:
            # the quasi-steady equilibrium ceased to exist during the step: a limit point of
            # the static aeroelastic problem, i.e. a snap-through (divergence-type instability)
            t_fail = resp.times[-1] + dt
            resp.finish("unstable", f"static aeroelastic equilibrium lost at t = {t_fail:g} s "
                        f"(limit point, snap-through): {exc}",
                        first_unstable or (t_fail, "divergence"))
    resp.wall_seconds = time.perf_counter() - t_start
    resp.timing = model.timer.as_dict()
    return resp
