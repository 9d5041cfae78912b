"""ROM geometry (solvers/aero/rom/geometry.py): the Eq. (7.6) wall temperature."""
from __future__ import annotations

import numpy as np
from hypate.solvers.aero.rom.geometry import eq76_wall_temperature
from hypate.solvers.aero.rom.plan import olh_plan


def test_eq76_wall_temperature_stays_in_range() -> None:
    x = np.linspace(0, 1, 65)
    b = olh_plan(np.array([[0.2, 0.9], [-0.3, 0.3], [-0.3, 0.3]]), 200, 0)
    T = eq76_wall_temperature(x, b)
    assert T.min() >= 200.0 - 1e-9 and T.max() <= 900.0 + 1e-9
