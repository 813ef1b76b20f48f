"""What flying gains produces, whatever flew them: a :class:`Trajectory` (in-process simulator, MAVLink vehicle,
offline tlog) and a :class:`Flight` (the trajectory, its score and why it ended).

The tuner scores a trajectory the same way whatever its source (``ksbo_mav.scoring.score_trajectory``, or the
mission's score for the 3-D figure-8); an :class:`Objective` is anything that flies gains and returns a Flight.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np


@dataclass
class Trajectory:
    """A flown (or logged) trajectory, planar task coordinates (x, z up).

    Attributes:
        t: (n,) sample times in seconds from the episode start.
        steps: (n,) control step k after which sample i was taken.
        states: (n, 6) [x, vx, z, vz, theta, theta_dot].
        refs: (n, 6) reference state at the same instants.
        inputs: (n, 2) pair thrusts (N) or None when the source does not report them.
        L: control steps flown.
        source: where it came from ("sim", "mavlink", "tlog").
    """

    t: np.ndarray
    steps: np.ndarray
    states: np.ndarray
    refs: np.ndarray
    inputs: np.ndarray | None
    L: int
    source: str = "sim"


@dataclass
class Flight:
    """The result of flying one gain vector: the trajectory, its score, and why it ended."""

    gains: np.ndarray
    trajectory: Trajectory
    score: dict[str, Any]
    outcome: str = "completed"  # or a crash / abort reason
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def P(self) -> float:
        return float(self.score["P"])


class Objective(Protocol):
    """Anything that can fly gains and score them: the simulator, a MAVLink vehicle, a log replayer."""

    profile: Any  # the vehicle profile (ksbo_mav.profiles.Profile) whose gains it flies

    def fly(self, gains: np.ndarray) -> Flight: ...
