"""Time march of the thermal model: Crank-Nicolson steps (Eq. 4.28) with a damped start.

:func:`simulate` marches any model with the stepping interface of
:class:`hypate.solvers.thermal.model.ThermalModel` (:class:`SteppedModel`: ``step``, the
surface and volume means, a factorization count) and records the histories; the records of
a solve (:class:`StepResult`) and of a march (:class:`ThermalHistory`) live here.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class StepResult:
    """Outcome of a Newton solve (one time step or a steady state).

    Attributes
    ----------
    T : ndarray of shape (n_nodes,)
        Nodal temperatures (K) at the end of the step.
    iterations : int
        Newton iterations (linear solves).
    factorizations : int
        Sparse factorizations performed in this solve.
    residual_norm : float
        Max-norm of the final residual on the unconstrained rows (W).
    converged : bool
    heat_input : float
        Net boundary heat input over the step, ``dt * sum(Q_T(T^alpha))`` (J), flux +
        convection + radiation (penalty reactions excluded); for a steady solve, the
        net boundary heat rate (W).
    """

    T: Array
    iterations: int
    factorizations: int
    residual_norm: float
    converged: bool
    heat_input: float


@dataclass(frozen=True, eq=False)
class ThermalHistory:
    """Time history from :func:`simulate` (K, s)."""

    times: Array
    top_temperature: Array
    bottom_temperature: Array
    mean_temperature: Array
    T: Array
    nodal: Array | None
    heat_input: Array
    factorizations: int
    iterations: int


class SteppedModel(Protocol):
    """What :func:`simulate` needs of a thermal model (:class:`ThermalModel` has it)."""

    n_nodes: int
    factorizations: int

    def initial_state(self) -> Array: ...

    def check_temperature(self, T: ArrayLike) -> Array: ...

    def step(self, T_old: ArrayLike, dt: float, loads: Any, *, alpha: float = 0.5
             ) -> StepResult: ...

    def surface_mean(self, T: ArrayLike, surface: str = "top") -> Array | float: ...

    def mean_temperature(self, T: ArrayLike) -> Array | float: ...


def simulate(model: SteppedModel, T0: ArrayLike | None, dt: float, n_steps: int,
             loads: Any | Callable[[float], Any], *, alpha: float = 0.5,
             keep_nodal: bool = False, damped_start: int = 0) -> ThermalHistory:
    """March ``n_steps`` Crank-Nicolson steps from ``T0`` (default: uniform initial).

    ``loads`` is a :class:`ThermalLoads` or a function of time returning one (evaluated
    at ``t_n + alpha dt``). ``damped_start`` replaces each of the first steps by two
    backward-Euler half steps (Rannacher start-up): a sudden load excites stiff
    through-thickness modes that Crank-Nicolson only flips in sign (amplification
    -> -1), so the surface temperatures would ring at large ``dt``; the damped start
    removes that and keeps second-order accuracy.

    Parameters
    ----------
    model : SteppedModel
        Usually a :class:`hypate.solvers.thermal.model.ThermalModel`.
    T0 : ndarray of shape (n_nodes,), optional
        Initial temperatures (K).
    dt : float
        Time step (s).
    n_steps : int
    loads : ThermalLoads or callable t -> ThermalLoads
    alpha : float
        alpha-bar of Eq. (4.28): 1/2 Crank-Nicolson, 1 backward Euler.
    keep_nodal : bool
        Keep all nodal temperatures.
    damped_start : int
        Steps taken as two backward-Euler half steps.

    Returns
    -------
    ThermalHistory
        ``times``, ``top_temperature``, ``bottom_temperature``, ``mean_temperature``
        of shape (n_steps + 1,), the final ``T`` (n_nodes,), optionally all nodal
        temperatures (n_steps + 1, n_nodes), and per-step ``heat_input`` (J).
    """
    T = model.initial_state() if T0 is None else model.check_temperature(T0).copy()
    n_steps = int(n_steps)
    times = cast(Array, dt * np.arange(n_steps + 1))  # float64 (numpy's stub: floating[Any])
    top = np.empty(n_steps + 1)
    bot = np.empty(n_steps + 1)
    mean = np.empty(n_steps + 1)
    heat = np.zeros(n_steps)
    nodal = np.empty((n_steps + 1, model.n_nodes)) if keep_nodal else None
    f0, iters = model.factorizations, 0

    def record(m: int, T: Array) -> None:
        top[m] = model.surface_mean(T, "top")
        bot[m] = model.surface_mean(T, "bottom")
        mean[m] = model.mean_temperature(T)
        if nodal is not None:
            nodal[m] = T

    record(0, T)
    for m in range(n_steps):
        if m < damped_start:
            for half in (0.5, 1.0):
                t_half = times[m] + half * dt
                ld = loads(t_half) if callable(loads) else loads
                res = model.step(T, 0.5 * dt, ld, alpha=1.0)
                T = res.T
                heat[m] += res.heat_input
                iters += res.iterations
        else:
            ld = loads(times[m] + alpha * dt) if callable(loads) else loads
            res = model.step(T, dt, ld, alpha=alpha)
            T = res.T
            heat[m] = res.heat_input
            iters += res.iterations
        record(m + 1, T)
    return ThermalHistory(times=times, top_temperature=top, bottom_temperature=bot,
                          mean_temperature=mean, T=T, nodal=nodal, heat_input=heat,
                          factorizations=model.factorizations - f0, iterations=iters)
