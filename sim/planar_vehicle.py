"""The planar (x-z) SCG quadrotor as a :class:`~ksbo_sim.vehicle.VehicleModel` for the MAVLink endpoint.

Frame mapping (planar state [x, vx, z, vz, theta, theta_dot], z up, positive theta accelerates +x):

* planar x  <-> NED north,  planar z <-> -NED down (so NED down 0 is the ground, z = 0);
* NED east is always 0 (the vehicle cannot move sideways; east setpoints are ignored);
* NED pitch = -theta: a copter pitching nose-down (negative aircraft pitch) accelerates north, whereas the
  planar model's positive theta accelerates +x. ATTITUDE.pitch and pitchspeed therefore carry -theta, -theta_dot.

The physics, the controller and the bounds are exactly those of :func:`ksbo_sim.simulate` (same
:class:`PlanarPID`, :func:`integrate`, :class:`Bounds`), so a figure-8 flown through the endpoint with one
setpoint per control step reproduces the in-process rollout. Acceleration setpoints are accepted and ignored:
SCG's PID has no acceleration feed-forward.
"""

from __future__ import annotations

import math
import sys
from dataclasses import replace
from importlib import resources

import numpy as np

from ksbo_sim.dynamics import integrate
from ksbo_sim.episode import CEILING, OK, OUT_X, REASONS, Bounds, EpisodeConfig
from ksbo_sim.pid import PlanarPID
from ksbo_sim.vehicle import ParamSpec, Setpoint, VehicleState

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

#: The vehicle accepts gains up to this multiple of the profile's search-box maximum: the search box is the
#: tuner's business, the vehicle only refuses values that are plainly wrong (negative, absurdly large).
GAIN_MAX_FACTOR = 4.0

PROFILE = "sim-planar"


def gain_specs() -> list[ParamSpec]:
    """The 9 tuned gains as vehicle parameters, named and bounded by ``params/sim-planar.toml``.

    The simulator reads the shipped TOML itself (the ``ksbo_params`` data package) rather than through the
    tuner's profile loader: ``ksbo_sim`` never imports ``ksbo_mav``.
    """
    text = resources.files("ksbo_params").joinpath(f"{PROFILE}.toml").read_text()
    return [ParamSpec(str(g["name"]), float(g["default"]), float(g["min"]), float(g["max"]) * GAIN_MAX_FACTOR,
                      "REAL32", f"{g.get('label', g['name'])} [{g.get('unit', '')}]")
            for g in tomllib.loads(text)["gains"]]


def _setting_specs(b: Bounds) -> list[ParamSpec]:
    return [
        ParamSpec("FENCE_X_MAX", b.x_max, 0.1, 100.0, description="geofence |north| limit [m]"),
        ParamSpec("FENCE_Z_MIN", b.z_min, -100.0, 0.0, description="geofence lowest height [m] (ground crash)"),
        ParamSpec("FENCE_Z_MAX", b.z_max, 0.1, 100.0, description="geofence ceiling height [m]"),
        ParamSpec("FENCE_TILT_DEG", b.tilt_max_deg, 1.0, 180.0, description="pitch beyond this is a crash [deg]"),
    ]


class PlanarVehicle:
    """One planar quadrotor flown by SCG's PID; implements :class:`~ksbo_sim.vehicle.VehicleModel`."""

    name = "planar"
    #: Crash codes that are geofence breaches (reported CRITICAL; ground impact and tilt are EMERGENCY).
    fence_codes = (OUT_X, CEILING)

    def __init__(self, config: EpisodeConfig | None = None) -> None:
        self.config = config or EpisodeConfig()
        self.ctrl_dt = self.config.dt
        self._gain_specs = gain_specs()
        self._specs = self._gain_specs + _setting_specs(self.config.bounds)
        self._values = {s.name: float(s.default) for s in self._specs}
        self._gain_names = [s.name for s in self._gain_specs]
        self._pid = PlanarPID(self._gains(), self.config.constants, self.ctrl_dt)
        self._bounds = self.config.bounds
        self._state = np.zeros((1, 6))
        self._thrust = np.full(2, self.config.constants.hover_thrust)
        self._t = 0.0
        self.thrust_max = self.config.constants.thrust_max  # N per motor pair, scales SERVO_OUTPUT_RAW
        #: Thrust produced per thrust commanded (1 = as built; lower = weaker motors, a sagging pack).
        self.authority = 1.0

    # --- parameters -------------------------------------------------------------------------------------
    def param_specs(self) -> list[ParamSpec]:
        return list(self._specs)

    def set_param(self, name: str, value: float) -> None:
        self._values[name] = float(value)
        if name in self._gain_names:
            # Gains change in flight without resetting the integrators, as on an autopilot.
            self._pid.gains = self._gains()
        elif name.startswith("FENCE_"):
            v = self._values
            self._bounds = replace(self._bounds, x_max=v["FENCE_X_MAX"], z_min=v["FENCE_Z_MIN"],
                                   z_max=v["FENCE_Z_MAX"], tilt_max_deg=v["FENCE_TILT_DEG"])

    def _gains(self) -> np.ndarray:
        return np.array([[self._values[n] for n in self._gain_names]])

    # --- simulation -------------------------------------------------------------------------------------
    def reset(self, pos: np.ndarray | None = None, vel: np.ndarray | None = None) -> VehicleState:
        pos = np.zeros(3) if pos is None else np.asarray(pos, dtype=float)
        vel = np.zeros(3) if vel is None else np.asarray(vel, dtype=float)
        self._state = np.array([[pos[0], vel[0], -pos[2], -vel[2], 0.0, 0.0]])
        # Same start as simulate(): integrators zero, previous pitch 0 (= the level initial pitch).
        self._pid.reset()
        self._thrust = np.full(2, self.config.constants.hover_thrust)
        return self._observe(OK)

    def step(self, setpoint: Setpoint) -> VehicleState:
        s = self._state[0]
        # Missing position (NaN) means "no position error"; missing velocity means zero velocity reference.
        ref_pos = np.array([_or(setpoint.pos[0], s[0]), _or(-setpoint.pos[2], s[2])])
        ref_vel = np.array([_or(setpoint.vel[0], 0.0), _or(-setpoint.vel[2], 0.0)])
        u = self._pid(self._state, ref_pos, ref_vel)
        if self.authority != 1.0:
            u = u * self.authority
        self._state = integrate(self._state, u, self.config.constants, self.ctrl_dt, self.config.n_sub)
        self._thrust = u[0]
        self._t += self.ctrl_dt
        return self._observe(int(self._bounds.violation(self._state)[0]))

    def _observe(self, code: int) -> VehicleState:
        x, vx, z, vz, th, om = (float(v) for v in self._state[0])
        return VehicleState(time_s=self._t, pos=np.array([x, 0.0, -z]), vel=np.array([vx, 0.0, -vz]),
                            rpy=np.array([0.0, -th, 0.0]), rates=np.array([0.0, -om, 0.0]),
                            thrust=self._thrust.copy(), crashed=code, crash_reason="" if code == OK else REASONS[code])

    # --- a vehicle that changes (ksbo_sim.conditions) -------------------------------------------------------
    def set_authority(self, k: float) -> None:
        """From the next step, each motor pair produces ``k`` times the thrust its controller commands."""
        self.authority = float(k)

    def disturb(self, acc_ned: np.ndarray, dt: float) -> None:
        """An external acceleration (NED; east ignored) acting for ``dt`` seconds, e.g. the wind."""
        self._state[0, 1] += float(acc_ned[0]) * dt
        self._state[0, 3] -= float(acc_ned[2]) * dt

    @property
    def planar_state(self) -> np.ndarray:
        """(6,) true planar state [x, vx, z, vz, theta, theta_dot] (for tests and diagnostics)."""
        return self._state[0].copy()


def _or(value: float, fallback: float) -> float:
    return fallback if math.isnan(value) else float(value)
