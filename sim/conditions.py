"""A vehicle that changes while it flies: loss of control authority with flight time or battery use (motors and
ESCs warming, a sagging pack), a step change at a given flight time (a payload or a propeller swapped), and a wind
that rises, with turbulence; an airframe whose drag grows (a payload, dirt, a damaged propeller).

:class:`Conditions` is pure arithmetic on the flight time and the battery; the MAVLink endpoint applies its
outputs to models that accept them: ``set_authority(k)`` (thrust actually produced = commanded x k),
``set_wind(north_mps)`` (models with their own aerodynamics) or else ``disturb(acc_ned, dt)`` (an external
acceleration for one control period), and ``set_drag_scale(k)``. Models without these hooks fly unchanged. An
autopilot's loops make up for lost thrust (the JSBSim copter tracks the same at 0.6 of it): on a 3-D copter the
drag is what degrades the response (its lap-2 RMS doubles at twice the drag).
The wind blows along NED north (the planar vehicle's axis) from the south, i.e. toward +north.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

#: Drag coefficient of the wind force: acceleration = DRAG * (air speed relative to the vehicle) [1/s].
DRAG_PER_S = 0.35
#: Time constant of the turbulence (Ornstein-Uhlenbeck gusts) [s].
GUST_TAU_S = 1.0


@dataclass
class Conditions:
    """Args:
        drift: authority lost per minute of flight (``drift_per`` "min") or per full pack used ("pack").
        step_at_s, step_factor: from this much flight time on, the authority is multiplied by ``step_factor``.
        wind_mps, wind_rise_per_min, wind_max_mps: mean wind at take-off, its rise per minute of flight, its cap.
        wind_at_s, wind_to_mps: a step of the mean wind to ``wind_to_mps`` at this flight time.
        turbulence: gust standard deviation as a fraction of the mean wind.
        authority_floor: the authority never falls below this.
        drag_scale, drag_rise_per_min: the airframe's drag (times as built) at take-off, its rise per minute of
            flight.
    """

    drift: float = 0.0
    drift_per: str = "min"
    step_at_s: float | None = None
    step_factor: float = 1.0
    wind_mps: float = 0.0
    wind_rise_per_min: float = 0.0
    wind_max_mps: float = 20.0
    wind_at_s: float | None = None
    wind_to_mps: float = 0.0
    turbulence: float = 0.3
    authority_floor: float = 0.3
    drag_scale: float = 1.0
    drag_rise_per_min: float = 0.0
    seed: int | None = None
    flight_s: float = 0.0
    gust: float = 0.0
    rng: np.random.Generator = field(default_factory=np.random.default_rng)

    def __post_init__(self) -> None:
        self.rng = np.random.default_rng(self.seed)

    @property
    def active(self) -> bool:
        return bool(self.drift or self.step_at_s is not None or self.wind_mps or self.wind_rise_per_min
                    or self.wind_at_s is not None or self.drag_scale != 1.0 or self.drag_rise_per_min)

    def authority(self, used_fraction: float = 0.0) -> float:
        """Thrust produced per thrust commanded, now (``used_fraction``: of the battery pack, for "pack")."""
        amount = self.flight_s / 60.0 if self.drift_per == "min" else used_fraction
        k = 1.0 - self.drift * amount
        if self.step_at_s is not None and self.flight_s >= self.step_at_s:
            k *= self.step_factor
        return max(self.authority_floor, k)

    def drag(self) -> float:
        """The airframe's drag now, times as built."""
        return self.drag_scale + self.drag_rise_per_min * self.flight_s / 60.0

    def mean_wind(self) -> float:
        w = self.wind_mps + self.wind_rise_per_min * self.flight_s / 60.0
        if self.wind_at_s is not None and self.flight_s >= self.wind_at_s:
            w = self.wind_to_mps
        return min(self.wind_max_mps, max(0.0, w))

    def wind(self) -> float:
        """Wind speed toward +north now, gusts included [m/s]."""
        return self.mean_wind() + self.gust

    def step(self, dt: float, airborne: bool) -> None:
        """Advance the flight clock (airborne time only) and the gusts by ``dt`` seconds."""
        if not airborne:
            return
        self.flight_s += dt
        sigma = self.turbulence * self.mean_wind()
        a = math.exp(-dt / GUST_TAU_S)
        self.gust = a * self.gust + sigma * math.sqrt(1.0 - a * a) * float(self.rng.standard_normal())

    def wind_accel(self, vel_ned: np.ndarray) -> np.ndarray:
        """External acceleration (NED) of the wind on a vehicle moving at ``vel_ned``."""
        if not (self.wind_mps or self.wind_rise_per_min or self.wind_at_s is not None):
            return np.zeros(3)  # no wind configured: the plant is the unchanged one (no drag either)
        return np.array([DRAG_PER_S * (self.wind() - float(vel_ned[0])), 0.0, 0.0])
