"""Telemetry streams: message intervals on the simulated clock, REQUEST_DATA_STREAM groups, message builders.

Streams are produced at control-step boundaries, so an interval shorter than one control period gives one
message per step. ``time_boot_ms`` / ``time_usec`` are simulated time since boot. Positions and velocities are
the estimator's output; attitude is the model's truth (NED: pitch = -planar theta for the planar vehicle).
"""

from __future__ import annotations

import time

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from ksbo_sim.mavlink.flight import Flight
from ksbo_sim.mavlink.mission_store import HOME
from ksbo_sim.mavlink.personality import Mode, Personality
from ksbo_sim.mavlink.power import Power
from ksbo_sim.vehicle import ParamSpec

HEARTBEAT, SYS_STATUS, SYSTEM_TIME, ATTITUDE, LOCAL_POSITION_NED = 0, 1, 2, 30, 32
SERVO_OUTPUT_RAW, ACTUATOR_OUTPUT_STATUS, AUTOPILOT_VERSION = 36, 375, 148
GPS_GLOBAL_ORIGIN, HOME_POSITION, RC_CHANNELS = 49, 242, 65
#: Sent only when asked for (REQUEST_MESSAGE).
ON_REQUEST = (AUTOPILOT_VERSION, GPS_GLOBAL_ORIGIN, HOME_POSITION, RC_CHANNELS)

#: Default intervals (µs of simulated time). Heartbeat and status at 1 Hz, state at 10 Hz.
DEFAULT_INTERVALS = {HEARTBEAT: 1_000_000, SYS_STATUS: 1_000_000, SYSTEM_TIME: 1_000_000, ATTITUDE: 100_000,
                     LOCAL_POSITION_NED: 100_000, SERVO_OUTPUT_RAW: 100_000, ACTUATOR_OUTPUT_STATUS: 100_000}

#: REQUEST_DATA_STREAM stream id -> messages (ArduCopter's groups, fact sheet 1.5). 0 = all groups.
STREAM_GROUPS = {2: (SYS_STATUS,), 3: (SERVO_OUTPUT_RAW, ACTUATOR_OUTPUT_STATUS), 6: (LOCAL_POSITION_NED,),
                 10: (ATTITUDE,), 12: (SYSTEM_TIME,)}

_SENSORS = 0x1 | 0x2 | 0x20 | 0x8000  # gyro, accel, GPS-like position, motor outputs


#: The simulated transmitter's throttle stick, reported in RC_CHANNELS (1500 centred; 1000 rests low, as on an
#: ArduCopter SITL bench without a pilot, where LOITER refuses to hold).
RC_THROTTLE = ParamSpec("SIM_RC_THR", 1500, 800, 2200, "INT32", "RC_CHANNELS' throttle [us] (1000: a bench, no pilot)")


class Telemetry:
    def __init__(self, mav: mavlink.MAVLink, flight: Flight, personality: Personality, product_id: int,
                 power: Power | None = None) -> None:
        self.mav = mav
        self.flight = flight
        self.p = personality
        self.product_id = product_id
        self.power = power
        self.defaults = {**DEFAULT_INTERVALS, **(power.streams() if power is not None else {})}
        self.intervals = dict(self.defaults)
        self.due = {m: 0 for m in self.intervals}
        self.boot_unix_us = int(time.time() * 1e6)
        self.drop_rate = 0.0
        self.rc_throttle = lambda: 1500  # SIM_RC_THR: the simulated transmitter's throttle stick (us)
        self.heartbeat_wall = 0.0  # time.monotonic() of the last HEARTBEAT sent
        self.thrust_max = float(getattr(flight.model, "thrust_max", 1.0))

    # --- scheduling ------------------------------------------------------------------------------------
    def set_interval(self, msg_id: int, interval_us: float) -> bool:
        """SET_MESSAGE_INTERVAL semantics: -1 disable, 0 default, > 0 interval. False if not streamable."""
        if msg_id not in self.defaults:
            return False
        if interval_us < 0:
            self.intervals[msg_id] = 0
        elif interval_us == 0:
            self.intervals[msg_id] = self.defaults[msg_id]
        else:
            self.intervals[msg_id] = int(interval_us)
        self.due[msg_id] = 0
        return True

    def request_data_stream(self, stream_id: int, rate_hz: int, start: bool) -> None:
        """Legacy REQUEST_DATA_STREAM: sets whole groups, overriding earlier SET_MESSAGE_INTERVAL (as ArduPilot)."""
        groups = STREAM_GROUPS.values() if stream_id == 0 else [STREAM_GROUPS.get(stream_id, ())]
        for group in groups:
            for m in group:
                self.intervals[m] = int(1e6 / rate_hz) if start and rate_hz > 0 else 0
                self.due[m] = 0

    def send_due(self, now_us: int, force: tuple[int, ...] = ()) -> None:
        """Send every stream whose time has come (and the ``force``d ones if not sent in this step)."""
        for m, iv in self.intervals.items():
            if iv > 0 and now_us >= self.due[m]:
                self.send(m, now_us)
                nxt = self.due[m] + iv
                self.due[m] = nxt if nxt > now_us else now_us + iv  # never burst to catch up
            elif m in force:
                self.send(m, now_us)

    # --- builders --------------------------------------------------------------------------------------
    def send(self, msg_id: int, now_us: int) -> bool:
        f, mav, ms = self.flight, self.mav, (now_us // 1000) & 0xFFFFFFFF
        if msg_id == HEARTBEAT:
            self.heartbeat_wall = time.monotonic()  # (lockstep: at least one per wall second, server.run)
            mode = f.mode
            base = 1 | 16 | (8 if mode is Mode.GUIDED else 0) | (128 if f.armed else 0)
            mav.heartbeat_send(2, self.p.autopilot, base, self.p.custom_mode(mode), f.system_status, 3)
        elif msg_id == SYS_STATUS:
            mv, ca, pct = self.power.sys_status() if self.power is not None else (12600, 500, 100)
            mav.sys_status_send(_SENSORS, _SENSORS, _SENSORS, 200, mv, ca, pct,
                                int(self.drop_rate * 10000), 0, 0, 0, 0, 0)
        elif msg_id == SYSTEM_TIME:
            mav.system_time_send(self.boot_unix_us + now_us, ms)
        elif msg_id == ATTITUDE:
            r, w = f.truth.rpy, f.truth.rates
            mav.attitude_send(ms, r[0], r[1], r[2], w[0], w[1], w[2])
        elif msg_id == LOCAL_POSITION_NED:
            p, v = f.est_pos, f.est_vel
            mav.local_position_ned_send(ms, p[0], p[1], p[2], v[0], v[1], v[2])
        elif msg_id == SERVO_OUTPUT_RAW:
            pwm = [int(1000 + 1000 * min(1.0, max(0.0, t / self.thrust_max))) if f.armed else 1000
                   for t in f.truth.thrust[:8]]
            pwm += [0] * (8 - len(pwm))
            mav.servo_output_raw_send(now_us & 0xFFFFFFFF, 0, *pwm)
        elif msg_id == ACTUATOR_OUTPUT_STATUS:
            thrust = [float(t) for t in f.truth.thrust[:32]]
            mav.actuator_output_status_send(now_us, len(thrust), thrust + [0.0] * (32 - len(thrust)))
        elif msg_id == AUTOPILOT_VERSION:
            custom = list(self.p.custom_version[:8].ljust(8, b"\0"))
            mav.autopilot_version_send(self.p.capabilities, self.p.flight_sw_version, 0, 0, 0, custom,
                                       [0] * 8, [0] * 8, self.p.vendor_id, self.product_id, 0)
        elif msg_id == RC_CHANNELS:  # a transmitter with its sticks centred (the pilot lets the autopilot fly)
            mav.rc_channels_send(ms, 8, 1500, 1500, self.rc_throttle(), *([1500] * 5 + [0] * 10), 255)
        elif msg_id in (GPS_GLOBAL_ORIGIN, HOME_POSITION):  # home is the local frame's origin, on the ground
            lat, lon, alt = int(round(HOME[0] * 1e7)), int(round(HOME[1] * 1e7)), int(round(HOME[2] * 1000))
            if msg_id == GPS_GLOBAL_ORIGIN:
                mav.gps_global_origin_send(lat, lon, alt, now_us)
            else:
                mav.home_position_send(lat, lon, alt, 0.0, 0.0, 0.0, [1.0, 0.0, 0.0, 0.0], 0.0, 0.0, 0.0, now_us)
        else:
            return self.power is not None and self.power.send(mav, msg_id, now_us)
        return True

    def statustext(self, severity: int, text: str) -> None:
        self.mav.statustext_send(severity, text.encode()[:50])
