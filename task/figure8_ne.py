"""Horizontal figure-8 mission of the 3-D copter (fact sheet section 8): the reference the MAVLink client streams
and the JSBSim copter flies in process.

Reference (local NED, metres): north = A sin(wt), east = B sin(2wt), down = -altitude, w = 2 pi / period
(``second_axis=2`` puts the B term on down instead: the fact sheet's x-z variant);
defaults A = 10 m, B = 2.5 m, period 20 s, altitude 10 m: peak speed 3.1 m/s, peak acceleration 1.0 m/s^2
(x) / 1.0 m/s^2 (y). The client streams pos+vel+acc setpoints from it (SET_POSITION_TARGET_LOCAL_NED type_mask
0x0C00 = 3072, frame LOCAL_NED) at ``rate_hz``; the tracking error is the measured position minus the
commanded position at the same time, and lap 2 (the steady state) is what is scored. ``lead_in`` > 0 starts the
pattern from rest (:mod:`ksbo_task.lead_in`; the vehicle profiles' ``[mission] lead_in_s``), so a hovering
vehicle does not see a 3.5 m/s velocity step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ksbo_task.lead_in import lead_in_phase


@dataclass(frozen=True)
class Figure8H:
    """Horizontal figure-8 (north-east plane) at constant altitude; times in s from the mission start."""

    amp_north: float = 10.0  # m
    amp_east: float = 2.5  # m
    period: float = 20.0  # s
    altitude: float = 10.0  # m above home
    laps: int = 2
    rate_hz: float = 50.0
    second_axis: int = 1  # 1: east (horizontal pattern, the mission); 2: down (fact sheet's x-z variant)
    lead_in: float = 0.0  # s: start from rest (ksbo_task.lead_in); 0 = the fact sheet's pattern from t = 0

    @property
    def omega(self) -> float:
        return 2.0 * math.pi / self.period

    @property
    def duration(self) -> float:
        return self.laps * self.period

    def position(self, t: np.ndarray | float) -> np.ndarray:
        """(*t.shape, 3) NED position in m."""
        return self._pattern(lead_in_phase(t, self.lead_in)[0], 0)

    def velocity(self, t: np.ndarray | float) -> np.ndarray:
        """(*t.shape, 3) NED velocity in m/s."""
        return self.state(t)[1]

    def acceleration(self, t: np.ndarray | float) -> np.ndarray:
        """(*t.shape, 3) NED acceleration in m/s^2."""
        return self.state(t)[2]

    def state(self, t: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(position, velocity, acceleration), each (*t.shape, 3), with the lead-in's phase computed once (the
        setpoint stream asks for all three at every step)."""
        ph, rate, rate_dot = lead_in_phase(t, self.lead_in)
        d1 = self._pattern(ph, 1)
        return (self._pattern(ph, 0), d1 * rate[..., None],
                self._pattern(ph, 2) * (rate * rate)[..., None] + d1 * rate_dot[..., None])

    def _pattern(self, ph: np.ndarray, order: int) -> np.ndarray:
        """(*ph.shape, 3) ``order``-th time derivative (0, 1, 2) of the unwarped pattern at phase ``ph`` (s)."""
        w = self.omega
        out = np.zeros(ph.shape + (3,))
        # d^k/dt^k sin(a t) = a^k sin(a t + k pi / 2)
        out[..., 0] = self.amp_north * w**order * np.sin(w * ph + order * math.pi / 2)
        if order == 0:
            out[..., 2] = -self.altitude
        out[..., self.second_axis] += self.amp_east * (2 * w) ** order * np.sin(2 * w * ph + order * math.pi / 2)
        return out

    def start(self) -> np.ndarray:
        """(3,) where the vehicle should hover before the stream starts (the crossing point)."""
        return self.position(0.0)

    def sample_times(self) -> np.ndarray:
        """(n,) send times 0, 1/rate, ... < duration."""
        return np.arange(int(round(self.duration * self.rate_hz))) / self.rate_hz
