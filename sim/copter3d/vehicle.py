"""The JSBSim F450 with an ArduCopter-style cascade as a :class:`~ksbo_sim.vehicle.VehicleModel`.

Frames: local NED in metres with the origin at home on the ground (down = 0 is the ground, as for the planar
vehicle); the JSBSim terrain lies 100 m further down and is never touched. Timing: ``step`` covers one control
period ``ctrl_dt`` = 20 ms (the 50 Hz setpoint/telemetry rate) made of 8 physics steps of 2.5 ms; the position,
attitude and rate loops all run every physics step (400 Hz, ArduCopter's main-loop rate). The F450 behaves the
same at 2 ms (hover command 0.4087 at both; figure-8 lap-2 error equal within 0.1 mm) and 2.5 ms costs 20 %
less CPU.

Setpoints behave like ArduCopter GUIDED pos+vel+acc targets: a *new* setpoint replaces the internal target,
which is then dead-reckoned every physics step (pos += vel dt + acc dt^2/2, vel += acc dt) until the next new
one; NaN position axes follow the integrated velocity; all-NaN holds the current target. On the ground
(down >= 0 after a reset or a gentle touchdown) the airframe is clamped with idle motors until a setpoint asks
for height; touching down faster than 2 m/s, tilting beyond SIM_TILT_CRASH, leaving the geofence or a
non-finite state is a crash (``crashed`` > 0, the airframe then stays where it is until ``reset``).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ksbo_sim.copter3d.attitude import AttitudeController
from ksbo_sim.copter3d.backend import G0, F450Backend
from ksbo_sim.copter3d.params import FENCE_NAMES, HOVER_NAMES, TABLES, TILT_CRASH, build_gains, param_specs
from ksbo_sim.copter3d.poscontrol import PositionController
from ksbo_sim.vehicle import ParamSpec, Setpoint, VehicleState

OK, TILT, GROUND, FENCE_HOR, FENCE_ALT, NONFINITE = 0, 1, 2, 3, 4, 5
REASONS = {OK: "", TILT: "tilt beyond SIM_TILT_CRASH", GROUND: "hit the ground", FENCE_HOR: "geofence: too far",
           FENCE_ALT: "geofence: too high", NONFINITE: "non-finite state"}
TOUCHDOWN_SPEED = 2.0  # m/s: faster than this on reaching the ground is a crash
IDLE_FRACTION = 0.03  # per-motor thrust fraction while landed (spin at "MOT_SPIN_ARM")


class Copter3D:
    """JSBSim F450 flown by an AC_PosControl-like cascade; parameters named per ``personality``.

    Args:
        personality: "ardupilot" (PSC_NE_*/PSC_D_*), "ardupilot-legacy" (PSC_POSXY_*/...), or "px4" (MPC_*).
        rotor_drag: linear rotor drag coefficient in 1/s added to the F450 (0 = stock JSBSim files). The
            default 0.3 /s is a calibration, not a measurement: with the stock files (quadratic body drag
            only) lap-2 figure-8 error at default gains is ~0.02 m, ten times below ArduCopter SITL's ~0.2 m;
            a linear drag of this size (physically: rotor drag/blade flapping) gives SITL-like error levels
            and the same trends with PSC_POSXY_P / PSC_VELXY_P (BENCHMARKS.md).
        physics_dt: JSBSim step (s); ctrl_dt must be a multiple of it.
    """

    name = "copter3d"
    #: Crash codes that are geofence breaches (the endpoint reports CRITICAL rather than EMERGENCY for these).
    fence_codes = (FENCE_HOR, FENCE_ALT)

    def __init__(self, personality: str = "ardupilot", rotor_drag: float = 0.3, physics_dt: float = 0.0025,
                 ctrl_dt: float = 0.02) -> None:
        if personality not in TABLES:
            raise ValueError(f"unknown personality {personality!r}; known: {', '.join(TABLES)}")
        self.personality = personality
        self.ctrl_dt = ctrl_dt
        self.n_sub = int(round(ctrl_dt / physics_dt))
        if abs(self.n_sub * physics_dt - ctrl_dt) > 1e-12:
            raise ValueError("ctrl_dt must be a multiple of physics_dt")
        self.backend = F450Backend(dt=physics_dt, rotor_drag=rotor_drag)
        self.af = self.backend.airframe
        self._hover_name = HOVER_NAMES["px4" if personality == "px4" else "ardupilot"]
        as_built = float(self.af.hover_fraction)
        self._specs = [dataclasses.replace(s, default=as_built) if s.name == self._hover_name else s
                       for s in param_specs(personality)]
        self._values = {s.name: float(s.default) for s in self._specs}
        pos_g, att_g = build_gains(personality, self._values)
        self.pos_ctrl = PositionController(physics_dt, self.af.hover_fraction, pos_g, z_px4=personality == "px4")
        self.att_ctrl = AttitudeController(self.af, physics_dt, att_g)
        #: Thrust produced per thrust commanded (1 = as built; lower = warm motors, a sagging pack).
        self.authority = 1.0
        #: The airframe's own thrust per thrust commanded, from the hover parameter (1 = the F450 as built).
        self.airframe_scale = 1.0
        #: The rotor drag, times as calibrated, and the wind toward north [m/s]: kept over resets, as the
        #: authority is (a JSBSim reset puts its properties back to their initial values).
        self.drag_scale, self.wind_north = 1.0, 0.0
        #: The navigation estimate's error (position, velocity; NED) the position loops see on top of the truth,
        #: set each control period by the endpoint from its estimator (SIM_POS_NOISE, SIM_VEL_NOISE, SIM_ACC_NOISE):
        #: as on an autopilot, the loops fly the estimate, so sensor noise reaches the attitude and the motors
        #: through the gains. None: the loops see the truth (no sensor noise).
        self.nav_error: tuple[np.ndarray, np.ndarray] | None = None
        self.reset()

    # --- parameters -------------------------------------------------------------------------------------
    @property
    def thrust_max(self) -> float:
        """N, one motor's static thrust at full command: the MAVLink endpoint's SERVO_OUTPUT_RAW scale."""
        return float(self.af.thrust_max)

    def param_specs(self) -> list[ParamSpec]:
        return list(self._specs)

    def set_param(self, name: str, value: float) -> None:
        """Apply a value; gains change in flight without resetting integrators, as on an autopilot."""
        if name not in self._values:
            raise KeyError(name)
        self._values[name] = float(value)
        if name == self._hover_name:
            hover = min(max(float(value), 0.05), 0.95)
            self.airframe_scale = self.af.hover_fraction / hover
            self.pos_ctrl.hover = hover
            return
        pos_g, att_g = build_gains(self.personality, self._values)
        self.pos_ctrl.g = pos_g
        self.att_ctrl.g = att_g

    def get_param(self, name: str) -> float:
        return self._values[name]

    # --- simulation -------------------------------------------------------------------------------------
    def reset(self, pos: np.ndarray | None = None, vel: np.ndarray | None = None) -> VehicleState:
        pos = np.zeros(3) if pos is None else np.asarray(pos, dtype=float)
        vel = np.zeros(3) if vel is None else np.asarray(vel, dtype=float)
        self.backend.reset(pos, vel)
        self.backend.set_drag_scale(self.drag_scale)
        self.backend.set_wind_north(self.wind_north)
        self.pos_ctrl.reset()
        self.att_ctrl.reset(0.0)
        self.nav_error = None
        self._tgt_p = [float(v) for v in pos]
        self._tgt_v = [0.0, 0.0, 0.0]
        self._tgt_a = [0.0, 0.0, 0.0]
        self._tgt_yaw = 0.0
        self._last_sp: tuple[float, ...] | None = None
        self._landed = bool(pos[2] >= -0.05 and np.allclose(vel, 0.0))
        self._spooling = False
        self.backend.hold(self._landed)
        self._crash = OK
        self._t = 0.0
        self._thrust = np.full(4, self.af.mass * G0 / 4.0)
        return self._observe(self.backend.read_fast())

    def _take_setpoint(self, sp: Setpoint, s: list[float]) -> None:
        key = (*sp.pos, *sp.vel, *sp.acc, sp.yaw)
        if self._last_sp is not None and all(a == b or (a != a and b != b) for a, b in zip(key, self._last_sp)):
            return  # the same setpoint again: keep dead-reckoning the target
        self._last_sp = key
        for i in range(3):
            p, v, a = float(sp.pos[i]), float(sp.vel[i]), float(sp.acc[i])
            self._tgt_v[i] = 0.0 if math.isnan(v) else v
            self._tgt_a[i] = 0.0 if math.isnan(a) else a
            if not math.isnan(p):
                self._tgt_p[i] = p
            elif not math.isnan(v):
                self._tgt_p[i] = s[i]  # velocity control on this axis: the target starts where we are
        if not math.isnan(sp.yaw):
            self._tgt_yaw = float(sp.yaw)

    def step(self, setpoint: Setpoint) -> VehicleState:
        b, dt = self.backend, self.backend.dt
        s = b.read_fast()
        if self._crash:
            self._t += self.ctrl_dt  # frozen where it crashed (clamped) until reset
            return self._observe(s)
        self._take_setpoint(setpoint, s)
        wants_up = self._tgt_p[2] < -0.3 or self._tgt_v[2] < -0.1
        if self._landed and wants_up and not self._spooling:
            # Asked to climb: run the loops from scratch while still clamped; the clamp is released once the
            # motors lift more than the weight (the Z integrators do that), so the props are spun up.
            self._spooling = True
            self.pos_ctrl.reset()
            self.att_ctrl.reset(s[8])
        elif self._landed and not wants_up:
            self._spooling = False
        tp, tv, ta = self._tgt_p, self._tgt_v, self._tgt_a
        cmd_for = self.af.command_for_thrust
        weight = self.af.mass * G0
        for _ in range(self.n_sub):
            if self._landed and self._spooling and b.total_thrust() > 1.05 * weight:
                self._landed = self._spooling = False
                b.hold(False)
            if self._landed and not self._spooling:
                thrust = np.full(4, IDLE_FRACTION * self.af.thrust_max)
            else:
                pos, vel = s[0:3], s[3:6]
                if self.nav_error is not None:
                    pos, vel = [p + e for p, e in zip(pos, self.nav_error[0])], \
                        [v + e for v, e in zip(vel, self.nav_error[1])]
                roll_d, pitch_d, thr = self.pos_ctrl.update(pos, vel, s[8], tp, tv, ta)
                # Angle boost on the measured tilt (ArduPilot), capped so a large tilt cannot ask for 2x thrust.
                thr /= max(math.cos(s[6]) * math.cos(s[7]), 0.5)
                thrust = self.att_ctrl.update(roll_d, pitch_d, self._tgt_yaw, s[6:9], s[9:12], min(thr, 1.0))
            b.set_motors(cmd_for(thrust * (self.authority * self.airframe_scale)))
            b.run(1)
            for i in range(3):  # dead-reckon the guided target (AC_PosControl update_pos_vel_accel)
                tp[i] += tv[i] * dt + 0.5 * ta[i] * dt * dt
                tv[i] += ta[i] * dt
            s = b.read_fast()
            if not self._landed and s[2] >= 0.0 and s[5] > 0.0:
                if s[5] > TOUCHDOWN_SPEED:
                    self._crash = GROUND
                    break
                self._landed = True  # gentle touchdown: sit on the ground
                b.hold(True)
                tp[2], tv[2], ta[2] = 0.0, 0.0, 0.0
        self._thrust = thrust
        self._t += self.ctrl_dt
        if not self._crash:
            self._crash = self._check(s)
        if self._crash:
            b.hold(True)
        return self._observe(s)

    # --- a vehicle that changes (ksbo_sim.conditions) -------------------------------------------------------
    def set_authority(self, k: float) -> None:
        """From the next step, each motor produces ``k`` times the thrust its controller commands."""
        self.authority = float(k)

    def set_drag_scale(self, k: float) -> None:
        """The rotor drag times ``k`` (a payload, dirt, a damaged propeller)."""
        self.drag_scale = float(k)
        self.backend.set_drag_scale(self.drag_scale)

    def set_wind(self, north_mps: float) -> None:
        """Wind blowing toward north at ``north_mps`` (JSBSim's atmosphere: the drag terms see the air speed)."""
        self.wind_north = float(north_mps)
        self.backend.set_wind_north(self.wind_north)

    def _check(self, s: list[float]) -> int:
        v = self._values
        hor, ver = FENCE_NAMES["px4" if self.personality == "px4" else "ardupilot"]
        if not all(math.isfinite(x) for x in s):
            return NONFINITE
        lim = math.radians(v[TILT_CRASH])
        if abs(s[6]) > lim or abs(s[7]) > lim:
            return TILT
        if math.hypot(s[0], s[1]) > v[hor]:
            return FENCE_HOR
        if -s[2] > v[ver]:
            return FENCE_ALT
        return OK

    def _observe(self, s: list[float]) -> VehicleState:
        return VehicleState(time_s=self._t, pos=np.array(s[0:3]), vel=np.array(s[3:6]), rpy=np.array(s[6:9]),
                            rates=np.array(s[9:12]), thrust=np.asarray(self._thrust, dtype=float).copy(),
                            crashed=self._crash, crash_reason=REASONS[self._crash])

    @property
    def landed(self) -> bool:
        """True while the airframe sits clamped on the ground."""
        return self._landed
