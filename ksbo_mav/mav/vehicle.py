"""The vehicle as the tuner sees it: preflight, whitelisted gain writes, verified restore, paced setpoints.

:meth:`Vehicle.connect` does the preflight: heartbeat, AUTOPILOT_VERSION, stack detection, a complete parameter
download and the profile's gain map (refusing profiles meant for another stack). Writes go only to the profile's
gains, inside the profile box *and* the trust region around the baseline, each verified by its echo.

Setpoints are paced by the vehicle's clock: each LOCAL_POSITION_NED sample (50 Hz, ``time_boot_ms``) is answered
with the setpoint for that instant (fact sheet 4.1 step 7). The same loop runs a real vehicle, a real-time or
sped-up simulator, and the built-in simulator in lockstep, where every setpoint advances time by one step.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ksbo_mav.errors import InputError, VehicleError
from ksbo_mav.mav.commands import Commander
from ksbo_mav.mav.link import Endpoint, Link
from ksbo_mav.mav.mission import FRAME_LOCAL_NED, MASK_POS, MASK_POS_VEL_ACC, Mission
from ksbo_mav.mav.params import ParamClient
from ksbo_mav.mav.stacks import GainMap, Identity, Stack, default_profile, detect_stack
from ksbo_mav.mav.wire import mavlink
from ksbo_mav.profiles import Profile, load_profile

MSG_ATTITUDE, MSG_LPN, MSG_ACTUATOR = 30, 32, 375
CMD_SIM_STEP = 31011  # built-in simulator, lockstep: advance p1 seconds


def trust_region(profile: Profile, baseline: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where trial gains may go: the profile box, at most ``max_step_fraction`` of each gain's range from the
    baseline and, with ``max_ratio`` r, inside [baseline / r, baseline * r] for positive baselines."""
    b = profile.bounds
    tr = profile.section("trust_region")
    frac = float(tr.get("max_step_fraction", 1.0))
    w = b[:, 1] - b[:, 0]
    lo, hi = np.maximum(b[:, 0], baseline - frac * w), np.minimum(b[:, 1], baseline + frac * w)
    if "max_ratio" in tr:
        r = float(tr["max_ratio"])
        pos = baseline > 0
        lo = np.where(pos, np.maximum(lo, baseline / r), lo)
        hi = np.where(pos, np.minimum(hi, baseline * r), hi)
    return lo, hi


class LinkLost(VehicleError):
    """No heartbeat / telemetry from the vehicle for longer than the profile's timeout."""


@dataclass
class Sample:
    lpn: Any
    att: Any | None

    @property
    def t_ms(self) -> int:
        return int(self.lpn.time_boot_ms)


class Vehicle:
    def __init__(self, link: Link, stack: Stack, identity: Identity, params: ParamClient, cmd: Commander,
                 profile: Profile, gains: GainMap) -> None:
        self.link, self.stack, self.identity = link, stack, identity
        self.params, self.cmd, self.profile, self.gains = params, cmd, profile, gains
        self.mission = Mission.from_profile(profile)
        self.is_sim = "SIM_LOCKSTEP" in params.table
        self.lockstep = self.is_sim and params.table["SIM_LOCKSTEP"].value == 1
        self.last_lpn: Any = None
        self.last_att: Any = None
        self.heartbeat_timeout = float(profile.section("safety").get("heartbeat_timeout_s", 3.0))
        link.handlers.append(self._on_msg)

    # --- preflight -----------------------------------------------------------------------------------------
    @classmethod
    def connect(cls, endpoint: Endpoint, profile: str | None = None, *, sysid: int | None = None,
                compid: int | None = None, timeout: float = 15.0,
                log: Callable[[str], None] = lambda s: None) -> "Vehicle":
        kwargs = {k: v for k, v in (("sysid", sysid), ("compid", compid)) if v is not None}
        link = Link(endpoint, **kwargs)
        try:
            hb = link.wait_heartbeat(timeout)
            cmd = Commander(link)
            ver = cmd.request_message(mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION, "AUTOPILOT_VERSION")
            if ver is None:
                raise VehicleError("the vehicle did not answer REQUEST_MESSAGE(AUTOPILOT_VERSION)")
            ident = Identity(sysid=link.target_system, compid=link.target_component, autopilot=int(hb.autopilot),
                             vehicle_type=int(hb.type), vendor_id=int(ver.vendor_id), product_id=int(ver.product_id),
                             flight_sw_version=int(ver.flight_sw_version), capabilities=int(ver.capabilities),
                             uid=int(ver.uid))
            stack = detect_stack(ident)
            cmd.stack = stack
            log(f"vehicle sysid {ident.sysid}: {stack.name} {ident.firmware}, type {ident.vehicle_type}")
            params = ParamClient(link, stack.encoding)
            table = params.fetch_all()
            log(f"parameters: {len(table)} of {params.count} downloaded")
            prof = load_profile(profile or default_profile(ident, stack))
            want = str(prof.vehicle.get("autopilot", ""))
            if want and want != stack.name:
                raise InputError(f"profile {prof.name} is for autopilot {want!r}, the vehicle runs {stack.name}")
            gains = GainMap.build(prof.names, stack, table, prof)
            return cls(link, stack, ident, params, cmd, prof, gains)
        except BaseException:
            link.close()
            raise

    def close(self) -> None:
        self.link.close()

    def _on_msg(self, msg: Any) -> None:
        if not self.link.is_vehicle(msg):
            return
        kind = msg.get_type()
        if kind == "LOCAL_POSITION_NED":
            self.last_lpn = msg
        elif kind == "ATTITUDE":
            self.last_att = msg

    # --- gains -----------------------------------------------------------------------------------------------
    def gain_values(self) -> np.ndarray:
        """Gain vector from the downloaded table (no traffic)."""
        return self.gains.from_vehicle({n: self.params.table[n].value for n in self.gains.vehicle})

    def read_gains(self) -> np.ndarray:
        """Gain vector from a fresh read of every tuned parameter."""
        return self.gains.from_vehicle({n: self.params.read(n) for n in self.gains.vehicle})

    def check_trial_gains(self, x: np.ndarray, baseline: np.ndarray) -> np.ndarray:
        """Absolute box of the profile and the trust region around the baseline; InputError otherwise."""
        b = self.profile.bounds
        width = b[:, 1] - b[:, 0]
        x = np.asarray(x, dtype=float)
        if x.shape == (self.profile.dim,) and np.all(np.isfinite(x)):
            # An optimiser's lower + u (upper - lower) can overshoot a bound by an ulp: that is the bound.
            tol = 1e-9 * width
            x = np.where((x > b[:, 1]) & (x <= b[:, 1] + tol), b[:, 1], x)
            x = np.where((x < b[:, 0]) & (x >= b[:, 0] - tol), b[:, 0], x)
        x = self.profile.check_gains(x)
        lo, hi = trust_region(self.profile, baseline)
        tol = 1e-9 * width
        far = (x < lo - tol) | (x > hi + tol)
        if np.any(far):
            i = int(np.flatnonzero(far)[0])
            raise InputError(f"gain {self.profile.names[i]} = {x[i]:g} is outside the trust region "
                             f"[{lo[i]:g}, {hi[i]:g}] around the baseline {baseline[i]:g}")
        return np.clip(x, lo, hi)

    def write_gains(self, x: np.ndarray) -> None:
        """Set-and-verify every tuned parameter (callers check bounds first)."""
        for name, value in self.gains.to_vehicle(x).items():
            self.params.set_verified(name, value)

    def write_values(self, values: dict[str, float], retries: int = 3) -> None:
        for name, value in values.items():
            if name not in self.gains.vehicle:
                raise InputError(f"{name} is not one of the tuned parameters; refusing to write it")
            self.params.set_verified(name, value, retries=retries)

    def restore(self, values: dict[str, float], attempts: int = 3, retries: int = 8) -> None:
        """Write the baseline and confirm it with a fresh read of every parameter; VehicleError if impossible.

        More retries than a trial write: a restore is the one write that must get through a lossy link."""
        last: Exception | None = None
        for _ in range(attempts):
            try:
                self.write_values(values, retries=retries)
                wrong = [n for n, v in values.items()
                         if not np.isclose(self.params.read(n, retries=retries), v, rtol=1e-6, atol=1e-7)]
                if not wrong:
                    return
                last = VehicleError(f"read-back differs for {', '.join(wrong)}")
            except VehicleError as exc:
                last = exc
        raise VehicleError(f"baseline NOT restored: {last}")

    # --- streams and flight --------------------------------------------------------------------------------
    def setup_streams(self) -> None:
        """Legacy stream request first, then exact 50 Hz intervals (the reverse order resets them, fact sheet 1.5)."""
        link = self.link
        link.send(link.mav.request_data_stream_encode(link.target_system, link.target_component, 0, 4, 1))
        period_us = 1e6 / self.mission.rate_hz
        for msg_id in (MSG_LPN, MSG_ATTITUDE):
            if not self.cmd.set_interval(msg_id, period_us):
                raise VehicleError(f"vehicle refused to stream message {msg_id} at {self.mission.rate_hz} Hz")
        self.cmd.set_interval(MSG_ACTUATOR, period_us)  # optional: thrusts for the input term of P(a)

    def heartbeat(self) -> Any:
        return self.link.last_heartbeat

    @property
    def armed(self) -> bool:
        hb = self.heartbeat()
        return bool(hb is not None and hb.base_mode & 128)

    def check_link(self) -> None:
        if self.link.heartbeat_age() > self.heartbeat_timeout:
            raise LinkLost(f"no heartbeat from the vehicle for {self.link.heartbeat_age():.1f} s")

    def wait_sim(self, seconds: float, until: Callable[[], bool] | None = None) -> bool:
        """Let ``seconds`` of vehicle time pass (lockstep: MAV_CMD_USER_2 in 0.5 s chunks), stopping early once
        ``until()`` holds. Returns whether the condition was met (True without a condition)."""
        chunk = 0.5
        elapsed = 0.0
        while elapsed < seconds:
            if until is not None and until():
                return True
            if self.lockstep:
                self.cmd.require("simulator step", CMD_SIM_STEP, chunk, timeout=5.0)
                self.link.pump(0.0)
            else:
                self.link.pump(chunk)
            self.check_link()
            elapsed += chunk
        return True if until is None else bool(until())

    def exchange(self, pos: np.ndarray, vel: np.ndarray | None = None, acc: np.ndarray | None = None,
                 t_ms: int | None = None, resend_s: float | None = None) -> Sample:
        """Send one setpoint (position-only if ``vel`` is None) and return the next telemetry sample.

        Re-sends the same setpoint every ``resend_s`` without an answer (a lost packet must not stall a lockstep
        simulator); raises :class:`LinkLost` after the profile's heartbeat timeout without any sample.
        """
        link = self.link
        if resend_s is None:
            # Long enough that a busy machine does not trigger spurious re-sends (in lockstep each one is an
            # extra control step flown with a stale setpoint), short enough to ride out a lost packet.
            resend_s = 0.1
        last_t = self.last_lpn.time_boot_ms if self.last_lpn is not None else -1
        if t_ms is None:
            t_ms = max(last_t, 0)
        if vel is None:
            mask, vel, acc = MASK_POS, np.zeros(3), np.zeros(3)
        else:
            mask = MASK_POS_VEL_ACC
            acc = np.zeros(3) if acc is None else acc
        msg = link.mav.set_position_target_local_ned_encode(
            int(t_ms) & 0xFFFFFFFF, link.target_system, link.target_component, FRAME_LOCAL_NED, mask,
            *map(float, pos), *map(float, vel), *map(float, acc), 0.0, 0.0)
        start = time.monotonic()
        while True:
            link.send(msg)
            deadline = time.monotonic() + resend_s
            while time.monotonic() < deadline:
                link.pump(max(0.0, min(0.01, deadline - time.monotonic())))
                if self.last_lpn is not None and self.last_lpn.time_boot_ms > last_t:
                    return Sample(self.last_lpn, self.last_att)
            if time.monotonic() - start > self.heartbeat_timeout:
                raise LinkLost(f"no telemetry from the vehicle for {time.monotonic() - start:.1f} s")

    def ensure_airborne(self, log: Callable[[str], None] = lambda s: None) -> None:
        """GUIDED, armed and hovering at the figure-8 start; arms and takes off from the ground if needed.

        An armed vehicle in another mode is the pilot's: the tuner refuses rather than taking over.
        """
        hb = self.link.wait_heartbeat(self.heartbeat_timeout)
        guided = self.stack.modes["guided"]
        alt = float(self.mission.center_up)
        if hb.base_mode & 128 and hb.custom_mode != guided:
            raise VehicleError(f"vehicle is armed in mode {self.stack.mode_name(hb.custom_mode)}; switch it to "
                               f"{self.stack.mode_name(guided)} (or land it) before tuning")
        if not hb.base_mode & 128:
            log(f"arming and taking off to {alt:g} m")
            self.cmd.set_mode("guided")
            self.cmd.arm()
            self.cmd.takeoff(alt)
            climb_s = 30.0 + 4.0 * alt  # a slow autopilot climb (0.5 m/s) to 10 m takes 20 s
            climbed = self.wait_sim(climb_s, lambda: self.last_lpn is not None and -self.last_lpn.z > 0.9 * alt)
            if not climbed:
                raise VehicleError("takeoff did not reach the mission altitude")
        self.hold(self.mission.start_ned(), 2.0)
        hb = self.link.last_heartbeat
        if hb is not None and hb.custom_mode != guided:  # PX4 ends a takeoff in AUTO.LOITER: back to OFFBOARD
            self.cmd.set_mode("guided")  # (PX4 wants the setpoint stream running before the switch: it is)
            self.hold(self.mission.start_ned(), 1.0)

    def hold(self, pos_ned: np.ndarray, seconds: float,
             check: Callable[[Sample], None] | None = None) -> Sample:
        """Stream a position-only target for ``seconds`` of vehicle time (paced by telemetry)."""
        steps = max(1, int(round(seconds * self.mission.rate_hz)))
        s = None
        for _ in range(steps):
            s = self.exchange(pos_ned)
            if check is not None:
                check(s)
        assert s is not None
        return s

    def land(self, timeout_s: float = 30.0) -> None:
        """LAND and wait (vehicle time) until disarmed."""
        self.cmd.set_mode("land")
        self.wait_sim(timeout_s, lambda: not self.armed)

    def statustext(self, text: str, severity: int = 6) -> None:
        """Tell the vehicle / other ground stations (and the tlog) what the tuner is doing."""
        link = self.link
        link.send(link.mav.statustext_encode(severity, text.encode()[:50]))
