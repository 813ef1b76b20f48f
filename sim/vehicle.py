"""The contract between a simulated vehicle model and the MAVLink endpoint that serves it.

A :class:`VehicleModel` is a Gymnasium-style ``reset()``/``step()`` object stepped once per control period.
It knows nothing about MAVLink: the endpoint (``ksbo_sim.mavlink``) turns MAVLink setpoints into
:class:`Setpoint`, steps the model, and turns :class:`VehicleState` into telemetry. Frames are local NED
(north, east, down; metres), attitude roll/pitch/yaw in radians.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np


def _nan3() -> np.ndarray:
    return np.full(3, np.nan)


@dataclass
class Setpoint:
    """Position/velocity/acceleration target in local NED. NaN components are ignored (MAVLink type_mask)."""

    pos: np.ndarray = field(default_factory=_nan3)
    vel: np.ndarray = field(default_factory=_nan3)
    acc: np.ndarray = field(default_factory=_nan3)
    yaw: float = float("nan")


@dataclass
class VehicleState:
    """What the vehicle's sensors/estimator would report after a step (truth; the endpoint adds noise/EKF)."""

    time_s: float
    pos: np.ndarray  # (3,) NED m
    vel: np.ndarray  # (3,) NED m/s
    rpy: np.ndarray  # (3,) rad
    rates: np.ndarray  # (3,) rad/s
    thrust: np.ndarray  # (n_motors,) normalised 0..1 or newtons, model-specific
    crashed: int = 0  # 0 = flying normally, >0 model-specific crash code
    crash_reason: str = ""


@dataclass(frozen=True)
class ParamSpec:
    """One vehicle parameter as an autopilot exposes it."""

    name: str  # <= 16 characters
    default: float
    min: float
    max: float
    type: str = "REAL32"  # or "INT32"
    description: str = ""


@runtime_checkable
class VehicleModel(Protocol):
    """A simulated vehicle stepped at a fixed control rate."""

    ctrl_dt: float

    def param_specs(self) -> list[ParamSpec]:
        """Parameters the model owns (tunable gains first)."""

    def set_param(self, name: str, value: float) -> None:
        """Apply a parameter (already range-checked by the endpoint)."""

    def reset(self, pos: np.ndarray | None = None, vel: np.ndarray | None = None) -> VehicleState:
        """Place the vehicle (NED), zero its controller state, return the state."""

    def step(self, setpoint: Setpoint) -> VehicleState:
        """Run the controller against ``setpoint`` and advance the physics one control period."""
