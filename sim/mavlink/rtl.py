"""RTL of the simulated autopilot: return at the current height to home (the NED origin), then land there.

ArduCopter with ``RTL_ALT`` 0 returns at its current altitude; the simulator always does (its planar vehicle's
ceiling is 2 m). The mode stays RTL through the landing, as ArduCopter's does, and disarms on touchdown.
"""

from __future__ import annotations

import numpy as np

#: Horizontal return speed [m/s].
RTL_SPEED = 1.0


def rtl_setpoint(pos_target: np.ndarray, speed: float, dt: float) -> tuple[np.ndarray, np.ndarray, bool]:
    """One RTL step at the current height toward home (0, 0): the moved target, its velocity, and whether the
    vehicle is above home (time to land)."""
    h = np.array([pos_target[0], pos_target[1]])
    d = float(np.hypot(h[0], h[1]))
    if d <= speed * dt or d < 1e-3:
        return np.array([0.0, 0.0, pos_target[2]]), np.zeros(3), True
    u = -h / d
    moved = np.array([h[0] + u[0] * speed * dt, h[1] + u[1] * speed * dt, pos_target[2]])
    return moved, np.array([u[0] * speed, u[1] * speed, 0.0]), False
