"""The autopilot's flight logic around a :class:`VehicleModel`: arming, modes, takeoff, landing, guided
setpoints with dead reckoning and timeout, hold, crash handling, and the estimator.

Home is the NED origin on the ground (down = 0). While disarmed or landed the model is not stepped (the
vehicle sits on the ground); NAV_TAKEOFF starts the physics. A crash (the model reports ``crashed``: geofence,
ground, tilt) disarms and freezes the vehicle where it happened; re-arming (or MAV_CMD_USER_3 "reset") puts it
back on the ground at home.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ksbo_sim.estimator import Estimator
from ksbo_sim.mavlink.auto_nav import AutoNav
from ksbo_sim.mavlink.personality import Mode
from ksbo_sim.mavlink.rtl import RTL_SPEED, rtl_setpoint
from ksbo_sim.vehicle import Setpoint, VehicleModel, VehicleState

SEV_EMERGENCY, SEV_CRITICAL, SEV_ERROR, SEV_WARNING, SEV_NOTICE, SEV_INFO = 0, 2, 3, 4, 5, 6
STATUS_STANDBY, STATUS_ACTIVE, STATUS_CRITICAL, STATUS_EMERGENCY = 3, 4, 5, 6

TOUCHDOWN_DOWN_M = -0.03  # LAND: touchdown once higher than 3 cm above ground is no longer true
TAKEOFF_DONE_M = 0.05


@dataclass
class GuidedTarget:
    """A SET_POSITION_TARGET_LOCAL_NED, completed at receipt and dead-reckoned from its sim time."""

    pos: np.ndarray
    vel: np.ndarray
    acc: np.ndarray
    t_us: int
    timed: bool  # velocity or acceleration given: subject to the setpoint timeout (ArduPilot GUID_TIMEOUT)

    def at(self, t_us: int) -> Setpoint:
        age = (t_us - self.t_us) * 1e-6
        if age == 0.0:  # lockstep: exactly what was sent
            return Setpoint(pos=self.pos, vel=self.vel, acc=self.acc)
        acc = np.where(np.isnan(self.acc), 0.0, self.acc)
        vel = np.where(np.isnan(self.vel), 0.0, self.vel)
        return Setpoint(pos=self.pos + vel * age + 0.5 * acc * age * age, vel=self.vel + acc * age, acc=self.acc.copy())


class Flight:
    def __init__(self, model: VehicleModel, estimator: Estimator, notify: Callable[[int, str], None],
                 boot_mode: Mode = Mode.MANUAL) -> None:
        self.model = model
        self.est = estimator
        self.notify = notify
        self.dt_us = int(round(model.ctrl_dt * 1e6))
        self.mode = boot_mode
        self.armed = False
        self.landed = True
        self.crash_status = 0  # 0, STATUS_CRITICAL or STATUS_EMERGENCY
        self.crash_reason = ""
        self.target: GuidedTarget | None = None
        self.hold = np.zeros(3)
        self.takeoff_alt: float | None = None
        self.takeoff_down = 0.0
        self.land_down = 0.0
        self.sp_timeout_s = 3.0
        self.takeoff_speed = 0.5
        self.land_speed = 0.5
        self.takeoff_alt_default = 1.0
        self.guided_since_us: int | None = None  # sim time of the first guided setpoint since arming
        # PX4 flies NAV_TAKEOFF in AUTO.TAKEOFF, then AUTO.LOITER; ArduPilot stays in GUIDED (personality).
        self.takeoff_mode: Mode | None = None
        self.after_takeoff_mode: Mode | None = None
        self.on_mode_change: Callable[[Mode], None] = lambda m: None
        #: An autopilot failsafe (low battery) is active: HEARTBEAT system_status CRITICAL while armed.
        self.failsafe = False
        #: Refuses arming with a reason (the battery's pre-arm check), else None.
        self.arm_check: Callable[[], str | None] = lambda: None
        self.rtl_landing = False
        #: AUTO: the mission's waypoints from its current item on, [(seq, NED)] (the server's mission store).
        self.mission_legs: Callable[[], list[tuple[int, np.ndarray]]] = lambda: []
        self.nav = AutoNav(speed=5.0, accel=2.5, radius=1.0)
        self._place(np.zeros(3))

    # --- state -----------------------------------------------------------------------------------------
    def _place(self, pos: np.ndarray, vel: np.ndarray | None = None) -> None:
        vel = np.zeros(3) if vel is None else vel
        self.truth: VehicleState = self.model.reset(pos, vel)
        self.est.reset(self.truth.pos, self.truth.vel)
        self.est_pos, self.est_vel = self.truth.pos.copy(), self.truth.vel.copy()

    @property
    def system_status(self) -> int:
        if self.crash_status:
            return self.crash_status
        if self.failsafe and self.armed:
            return STATUS_CRITICAL
        return STATUS_ACTIVE if self.armed and not self.landed else STATUS_STANDBY

    def reset_home(self) -> None:
        """Back on the ground at home, disarmed, crash cleared (re-arm after a crash, MAV_CMD_USER_3)."""
        self.armed, self.landed, self.crash_status, self.crash_reason = False, True, 0, ""
        self.target, self.takeoff_alt, self.guided_since_us = None, None, None
        self._place(np.zeros(3))

    # --- commands (return None when accepted, else a reason for STATUSTEXT) ----------------------------
    def arm(self) -> str | None:
        if self.armed:
            return None
        if self.crash_status:
            self.reset_home()
            self.notify(SEV_INFO, "Vehicle reset to home after crash")
        if self.mode is Mode.LAND:
            return "Arm: Mode not armable"
        if not self.landed:
            return "Arm: vehicle not on the ground"
        refused = self.arm_check()
        if refused:
            return refused
        self.armed = True
        self.guided_since_us = None
        self.notify(SEV_INFO, "Arming motors")
        return None

    def disarm(self, force: bool) -> str | None:
        if not self.armed:
            return None
        if not self.landed and not force:
            return "Disarm: vehicle is flying (use force)"
        if not self.landed:
            self.crash(STATUS_EMERGENCY, "disarmed in flight")
            return None
        self.armed = False
        self.notify(SEV_INFO, "Disarming motors")
        return None

    def takeoff(self, alt: float) -> tuple[int, str | None]:
        """Returns (MAV_RESULT, reason). ArduPilot: GUIDED and armed; airborne -> FAILED."""
        if not (alt > 0.0):
            return 2, "Takeoff: altitude must be positive"
        if not self.armed:
            return 2, "Takeoff: not armed"
        # ArduPilot takes off in GUIDED only; PX4 (a personality with a takeoff mode) from any mode but LAND.
        if self.mode is Mode.LAND or (self.takeoff_mode is None and self.mode is not Mode.GUIDED):
            return 2, "Takeoff: mode must be GUIDED"
        if not self.landed:
            return 4, "Takeoff: already flying"
        self._start_takeoff(alt)
        if self.takeoff_mode is not None:
            self.mode = self.takeoff_mode
            self.on_mode_change(self.mode)
        return 0, None

    def _start_takeoff(self, alt: float) -> None:
        self.landed = False
        self._place(np.array([self.truth.pos[0], self.truth.pos[1], 0.0]))
        self.takeoff_alt, self.takeoff_down = float(alt), 0.0
        self.hold = np.array([self.truth.pos[0], self.truth.pos[1], -alt])
        self.notify(SEV_INFO, f"Takeoff to {alt:g} m")

    def set_mode(self, mode: Mode) -> str | None:
        if mode is self.mode:
            return None
        self.mode = mode
        self.hold = self.est_pos.copy()
        self.target = None
        if mode is not Mode.TAKEOFF:
            self.takeoff_alt = None
        self.rtl_landing = False
        if mode in (Mode.LAND, Mode.RTL):
            self.land_down = float(self.est_pos[2])
        if mode is Mode.AUTO:
            self.nav.start(self.est_pos, self.mission_legs())
        if mode is Mode.LAND:
            if self.armed and self.landed:
                self.armed = False
                self.notify(SEV_INFO, "Landed, disarming")
        elif mode is Mode.TAKEOFF and self.armed and self.landed:
            self._start_takeoff(self.takeoff_alt_default)
        self.on_mode_change(mode)
        return None

    def set_target(self, pos: np.ndarray, vel: np.ndarray, acc: np.ndarray, now_us: int) -> None:
        """A guided setpoint (NaN = ignored). Missing lower derivatives start from the current estimate."""
        if self.mode is not Mode.GUIDED or not self.armed:
            return
        timed = bool(np.any(np.isfinite(vel)) or np.any(np.isfinite(acc)))
        has_pos, has_vel = np.isfinite(pos), np.isfinite(vel)
        vel = np.where(~has_vel & np.isfinite(acc), self.est_vel, vel)
        pos = np.where(~has_pos & np.isfinite(vel), self.est_pos, pos)
        self.target = GuidedTarget(pos=np.asarray(pos, float), vel=np.asarray(vel, float),
                                   acc=np.asarray(acc, float), t_us=now_us, timed=timed)
        if self.guided_since_us is None:
            self.guided_since_us = now_us
        self.takeoff_alt = None  # a guided target takes over from the takeoff climb

    def teleport(self, pos: np.ndarray, vel: np.ndarray) -> str | None:
        """MAV_CMD_USER_1: place the airborne vehicle (NaN position = keep), zero its controller state."""
        if not self.armed or self.crash_status:
            return "Set state: vehicle must be armed"
        pos = np.where(np.isfinite(pos), pos, self.truth.pos)
        vel = np.nan_to_num(vel)
        if pos[2] >= 0.0:
            return "Set state: position must be above ground"
        self.landed, self.takeoff_alt = False, None
        self._place(pos, vel)
        self.hold = pos.copy()
        self.target = None
        return None

    # --- one control period ----------------------------------------------------------------------------
    def _offboard_liftoff(self) -> bool:
        """PX4 (a personality with a takeoff mode): armed on the ground in OFFBOARD with a position setpoint above
        the vehicle, it climbs to it; ArduPilot needs NAV_TAKEOFF in GUIDED."""
        t = self.target
        return (self.takeoff_mode is not None and self.mode is Mode.GUIDED and t is not None
                and bool(np.isfinite(t.pos[2])) and t.pos[2] < self.truth.pos[2] - TAKEOFF_DONE_M)

    def step(self, now_us: int) -> None:
        """Advance the vehicle from ``now_us`` by one control period."""
        if self.armed and self.landed and self._offboard_liftoff():
            self.landed = False
            self.notify(SEV_INFO, "Offboard takeoff")
        if not self.armed or self.landed:
            return
        sp = self._setpoint(now_us)
        prev_vel = self.truth.vel
        st = self.model.step(sp)
        self.truth = st
        acc = (st.vel - prev_vel) / self.model.ctrl_dt
        self.est_pos, self.est_vel = self.est.update(st.pos, st.vel, acc)
        if hasattr(self.model, "nav_error"):  # a model whose loops fly the estimate (copter3d), as autopilots do
            self.model.nav_error = None if self.est.exact else (self.est_pos - st.pos, self.est_vel - st.vel)
        if st.crashed:
            fence = st.crashed in getattr(self.model, "fence_codes", ())
            self.crash(STATUS_CRITICAL if fence else STATUS_EMERGENCY, st.crash_reason or "crash")
        elif (self.mode is Mode.LAND or self.rtl_landing) and st.pos[2] > TOUCHDOWN_DOWN_M and self.land_down >= 0.0:
            self.landed, self.armed = True, False
            self._place(np.array([st.pos[0], st.pos[1], 0.0]))
            self.notify(SEV_INFO, "Landed, disarming")
        elif self.takeoff_alt is not None and self.takeoff_down <= -self.takeoff_alt \
                and abs(st.pos[2] + self.takeoff_alt) < TAKEOFF_DONE_M:
            self.takeoff_alt = None
            self.notify(SEV_INFO, "Takeoff complete")
            if self.mode is Mode.TAKEOFF:
                self.set_mode(self.after_takeoff_mode or Mode.HOLD)
                self.hold = np.array([st.pos[0], st.pos[1], self.takeoff_down])

    def _setpoint(self, now_us: int) -> Setpoint:
        dt = self.model.ctrl_dt
        nan3 = np.full(3, np.nan)
        if self.takeoff_alt is not None:
            self.takeoff_down = max(-self.takeoff_alt, self.takeoff_down - self.takeoff_speed * dt)
            climbing = self.takeoff_down > -self.takeoff_alt
            return Setpoint(pos=np.array([self.hold[0], self.hold[1], self.takeoff_down]),
                            vel=np.array([0.0, 0.0, -self.takeoff_speed if climbing else 0.0]), acc=nan3)
        if self.mode is Mode.RTL and not self.rtl_landing:
            self.hold, vel, self.rtl_landing = rtl_setpoint(self.hold, RTL_SPEED, dt)
            return Setpoint(pos=self.hold.copy(), vel=vel, acc=nan3)
        if self.mode is Mode.LAND or self.rtl_landing:
            self.land_down = min(0.0, self.land_down + self.land_speed * dt)
            return Setpoint(pos=np.array([self.hold[0], self.hold[1], self.land_down]),
                            vel=np.array([0.0, 0.0, self.land_speed if self.land_down < 0 else 0.0]), acc=nan3)
        if self.mode is Mode.AUTO and self.armed:
            pos, vel = self.nav.step(self.est_pos, dt)
            return Setpoint(pos=pos, vel=vel, acc=nan3)
        if self.mode is Mode.GUIDED and self.target is not None:
            age = (now_us - self.target.t_us) * 1e-6
            if not self.target.timed or age <= self.sp_timeout_s:
                return self.target.at(now_us)
            self.hold = self.est_pos.copy()
            self.target = None
            self.notify(SEV_WARNING, "Guided setpoint timeout: holding position")
        return Setpoint(pos=self.hold.copy(), vel=np.zeros(3), acc=nan3)

    def crash(self, status: int, reason: str) -> None:
        """The vehicle crashes: disarmed, ``status`` (STATUS_CRITICAL or STATUS_EMERGENCY) and an EMERGENCY text."""
        self.armed, self.crash_status, self.crash_reason = False, status, reason
        self.target, self.takeoff_alt = None, None
        self.notify(SEV_EMERGENCY, f"Crash: {reason}; disarmed")
