"""The moving start of a planar trial: the vehicle passes the figure-8 start at a random velocity.

The paper's task (fact sheet part C, :func:`ksbo_task.starts.random_initial_states`) starts every episode at the
figure-8 origin with a random velocity v0 ~ U(0, 1) m/s in a random direction of the x-z plane. A MAVLink trial
that starts from a settled hover scores only one of those starts, and gains that are bistable - fine from rest,
diverging from some moving starts - look good in every trial, re-flight and confirmation of a campaign
(measured: recommendations confirmed at 0.79-0.88 from hover re-flew at 0.34-0.41 from the task's starts).

With ``[mission] start_speed_mps`` > 0 each trial draws its start velocity ``u`` (seeded by the campaign seed and
the trial number, so a resumed campaign flies the same starts) and flies an *approach* with the trial's gains
before the figure-8: its setpoints start from rest at ``start - D u/|u|``, accelerate at :data:`ACCEL` m/s^2 to
``u``, cruise :data:`CRUISE_S` s and reach the start at ``u`` just as the figure-8's first setpoint goes out (the
vehicle follows with its gains' tracking lag). The approach is monitored like the figure-8 (a trip there is the
trial's abort) and not scored. Re-flights of the optimiser's ``refly_stress`` come in at :func:`stress_velocity`,
the start where bistable gains fail first.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from ksbo_mav.errors import InputError
from ksbo_task.limit_checks import MonitorLimits
from ksbo_task.starts import random_initial_states, stress_initial_state

if TYPE_CHECKING:
    from ksbo_mav.mav.mission import Mission

#: Acceleration of the approach (m/s^2): about the figure-8's own peak (1.75 m/s^2).
ACCEL = 2.0
#: Constant-velocity part of the approach before the start (s): the acceleration transient dies down.
CRUISE_S = 0.3


def moving_starts(kind: str, v_max: float) -> bool:
    """Whether a mission's trials start moving: planar figure-8 missions with a start speed cap above 0."""
    return v_max > 0 and kind == "figure8-xz"


def _ned(s: np.ndarray) -> np.ndarray:
    """(3,) NED velocity of a planar initial state (6,) (vx, vz up) -> (north, east 0, down)."""
    return np.array([s[1], 0.0, -s[3]])


def start_velocity(kind: str, v_max: float, seed: int, trial: int) -> np.ndarray:
    """(3,) NED velocity at the figure-8 start of trial ``trial``: the task's random start (the same draw as
    :func:`ksbo_task.starts.random_initial_states`), zero without :func:`moving_starts`."""
    if not moving_starts(kind, v_max):
        return np.zeros(3)
    return _ned(random_initial_states(1, np.random.default_rng([seed, trial]), v_max=v_max)[0])


def stress_velocity(kind: str, v_max: float) -> np.ndarray:
    """(3,) NED velocity of the stress start (:func:`ksbo_task.starts.stress_initial_state`: 0.9 × ``v_max``
    against the path in x), flown by the re-fly phase with ``refly_stress``; zero without :func:`moving_starts`."""
    return _ned(stress_initial_state(v_max=v_max)) if moving_starts(kind, v_max) else np.zeros(3)


def approach_seconds(speed: float) -> float:
    """Duration of the approach to a start at ``speed`` m/s (0 for a start from hover)."""
    return speed / ACCEL + CRUISE_S if speed > 0 else 0.0


@dataclass(frozen=True)
class Approach:
    """Setpoints from rest at :attr:`begin` to the figure-8 start, passing it at ``velocity``.

    Args:
        start: (3,) NED figure-8 start.
        velocity: (3,) NED velocity at the start (zeros: no approach, :attr:`steps` 0).
        dt: control period (s).
    """

    start: np.ndarray
    velocity: np.ndarray
    dt: float

    # (derived once: setpoint() runs twice per control step, for the stream and for the monitor's reference)
    @cached_property
    def speed(self) -> float:
        return float(np.linalg.norm(self.velocity))

    @cached_property
    def steps(self) -> int:
        """Control steps from :attr:`begin` to the start (the acceleration, then at least ``CRUISE_S``)."""
        return math.ceil(approach_seconds(self.speed) / self.dt - 1e-9) if self.speed > 0 else 0

    @cached_property
    def _accel_s(self) -> float:
        return self.speed / ACCEL

    @cached_property
    def distance(self) -> float:
        """Length of the approach (m)."""
        if not self.steps:
            return 0.0
        return self.speed * (0.5 * self._accel_s + (self.steps * self.dt - self._accel_s))

    @cached_property
    def begin(self) -> np.ndarray:
        """(3,) NED point where the vehicle hovers before the approach (the start for a start from hover)."""
        if not self.steps:
            return np.asarray(self.start, dtype=float)
        return self.start - self.velocity / self.speed * self.distance

    def setpoint(self, j: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(pos, vel, acc) NED ``j`` steps after leaving :attr:`begin`; step :attr:`steps` is the start, at
        ``velocity``."""
        e = self.velocity / self.speed
        t, ta = j * self.dt, self._accel_s
        if t < ta:
            return self.begin + e * (0.5 * ACCEL * t * t), e * (ACCEL * t), e * ACCEL
        return self.begin + e * (0.5 * ACCEL * ta * ta + self.speed * (t - ta)), self.velocity.copy(), np.zeros(3)


def check_moving_start(mission: "Mission", limits: MonitorLimits) -> None:
    """InputError (one line) when the mission's moving starts could trip ``limits`` before the figure-8 begins:
    every such trial would abort and be blamed on its gains."""
    why = approach_outside(mission.start_ned(), mission.start_speed, mission.dt, limits)
    if why is not None:
        raise InputError(why)


def approach_distance(speed: float, dt: float) -> float:
    """Length (m) of the approach to a start at ``speed`` m/s (the farthest point from the start it flies)."""
    return Approach(np.zeros(3), np.array([speed, 0.0, 0.0]), dt).distance


def approach_outside(start: np.ndarray, v_max: float, dt: float, limits: MonitorLimits) -> str | None:
    """Why a moving start of up to ``v_max`` m/s from ``start`` (NED) could trip the abort box before the gains
    fly a step of the figure-8 (None when every direction fits): the approach begins up to its length away from
    the start, and the stopping-point fence sees the start at full speed ``v²/(2 brake)`` further on."""
    if v_max <= 0:
        return None
    reach = approach_distance(v_max, dt)
    if limits.brake_accel:
        reach = max(reach, v_max * v_max / (2.0 * limits.brake_accel))
    north, up = float(start[0]), -float(start[2])
    if abs(north) + reach > limits.x_max or up - reach < limits.z_min or up + reach > limits.z_max:
        return (f"a moving start at up to {v_max:g} m/s reaches {reach:.2f} m from the figure-8 start (north "
                f"{north:g} m, height {up:g} m), outside the abort box (|north| <= {limits.x_max:g} m, height "
                f"{limits.z_min:g}-{limits.z_max:g} m): lower [mission] start_speed_mps or widen [safety]")
    return None
