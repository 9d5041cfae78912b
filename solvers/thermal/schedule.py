"""Time-scheduled radiant heating: the heater temperature ``T_rad(t)`` of the radiation
boundary condition ``eps sigma (T^4 - T_rad^4)`` (Eq. 4.24).

Sec. 9.2.3 (Case 2) gives a heat-starved tunnel model a radiant heater at a constant
``T_rad`` (Table 9.7). :class:`HeaterSchedule` lets ``T_rad`` follow a piecewise-linear
function of the *nondimensional* time ``t / t_end``: ``n`` control temperatures at the
equally spaced fractions ``0, 1/(n-1), ..., 1`` of the test duration ``t_end``. A test
article run for its own duration (the model's, at matched nondimensional time, Eqs.
9.5-9.6) therefore sees the schedule at the same nondimensional times as any other model.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from hypate.solvers.errors import InputError
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]


@dataclass(frozen=True)
class HeaterSchedule:
    """Piecewise-linear heater temperature over one test.

    Attributes
    ----------
    values : tuple of float
        Control temperatures (K), at least two, at the fractions ``k / (n - 1)`` of
        ``duration``.
    duration : float
        Test duration ``t_end`` (s) the fractions refer to.
    """

    values: tuple[float, ...]
    duration: float

    def __post_init__(self) -> None:
        check_schedule(self.values)
        if not (math.isfinite(self.duration) and self.duration > 0.0):
            raise InputError("simulation.duration", f"must be > 0 (s); got {self.duration:g}")

    @property
    def fractions(self) -> Array:
        """Nondimensional times ``t / t_end`` of the control points, shape (n,)."""
        return np.linspace(0.0, 1.0, len(self.values))

    def __call__(self, t: ArrayLike) -> Array | float:
        """``T_rad(t)`` (K) at times ``t`` (s); held at the end values outside
        ``[0, t_end]``. A scalar in, a float out."""
        tau = np.asarray(t, dtype=float) / self.duration
        out = np.interp(tau, self.fractions, np.asarray(self.values, dtype=float))
        return float(out) if out.ndim == 0 else out

    def mean_fourth_power(self) -> float:
        """Time mean of ``T_rad(t)^4`` over the test (K^4), exact for the piecewise-linear
        schedule: on a segment from ``a`` to ``b`` the mean of ``(a + (b - a) s)^4`` over
        ``s in [0, 1]`` is ``(a^4 + a^3 b + a^2 b^2 + a b^3 + b^4) / 5``. Times
        ``emissivity sigma`` it is the mean absorbed heater flux (the q_ext of Eq. 6.1d)."""
        v = np.asarray(self.values, dtype=float)
        a, b = v[:-1], v[1:]
        seg = (a**4 + a**3 * b + a**2 * b**2 + a * b**3 + b**4) / 5.0
        return float(np.mean(seg))


def check_schedule(values: tuple[float, ...], field: str = "simulation.radiation_schedule"
                   ) -> tuple[float, ...]:
    """``values`` as a tuple of floats, validated: at least two finite temperatures > 0 (K).

    Raises
    ------
    InputError
        Naming ``field``.
    """
    vals = tuple(float(v) for v in values)
    if len(vals) < 2:
        raise InputError(field, f"a schedule needs at least 2 control points; got {len(vals)}")
    bad = [v for v in vals if not (math.isfinite(v) and v > 0.0)]
    if bad:
        raise InputError(field, f"control temperatures must be finite and > 0 (K); got "
                         f"{bad[0]:g}")
    return vals


__all__ = ["HeaterSchedule", "check_schedule"]
