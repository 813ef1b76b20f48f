"""AUTO (ArduPilot) / Mission (PX4) of the simulated autopilot: the stored waypoints flown as straight legs.

The target moves along each leg from the previous waypoint (the first leg from where AUTO was entered) with a
trapezoidal speed profile — up to ``WP_SPEED`` at ``WP_ACCEL``, braking to stop on the waypoint — and carries that
velocity as feed-forward, as an autopilot's waypoint navigation does. A waypoint counts as reached once the target
is on it and the vehicle within ``WP_RADIUS``; after the last one the vehicle holds it (and stays in AUTO).
"""

from __future__ import annotations

import math

import numpy as np


class AutoNav:
    def __init__(self, speed: float, accel: float, radius: float) -> None:
        self.speed, self.accel, self.radius = speed, accel, radius
        self.legs: list[tuple[int, np.ndarray]] = []
        self.a = self.b = np.zeros(3)
        self.s = self.v = 0.0
        self.seq = -1
        self.done = True
        #: ("reached" | "current", seq) since the last look; the server sends them as MAVLink messages.
        self.events: list[tuple[str, int]] = []

    def start(self, pos: np.ndarray, legs: list[tuple[int, np.ndarray]]) -> None:
        """Fly ``legs`` [(seq, NED)] from ``pos``."""
        self.legs = list(legs)
        self.b = np.asarray(pos, float).copy()
        self.done = not self.legs
        if not self.done:
            self._next_leg()

    def _next_leg(self) -> None:
        self.seq, end = self.legs.pop(0)
        self.a, self.b = self.b.copy(), np.asarray(end, float)
        self.s = self.v = 0.0
        self.events.append(("current", self.seq))

    def step(self, est_pos: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """The target (position, velocity) NED for this control period."""
        if self.done:
            return self.b.copy(), np.zeros(3)
        d = self.b - self.a
        length = float(np.linalg.norm(d))
        u = d / length if length > 0 else np.zeros(3)
        left = length - self.s
        cap = min(self.speed, math.sqrt(2.0 * self.accel * max(left, 0.0)))
        self.v = min(self.v + self.accel * dt, cap)
        self.s = min(length, self.s + self.v * dt)
        if self.s >= length:
            self.v = 0.0
            if float(np.linalg.norm(np.asarray(est_pos) - self.b)) <= self.radius:
                self.events.append(("reached", self.seq))
                if self.legs:
                    self._next_leg()
                else:
                    self.done = True
        return self.a + u * self.s, u * self.v
