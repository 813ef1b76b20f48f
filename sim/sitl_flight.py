"""Fly one horizontal figure-8 on ArduCopter SITL or PX4 SITL with plain pymavlink, logging a tlog.

A small, independent MAVLink client (not the tuner: ksbo_sim never imports ksbo_mav) for tests and benchmarks of
log scoring: it gives a real autopilot's own flight log (ArduCopter ``.BIN``, PX4 ``.ulg``) of a known trajectory,
and a ``.tlog`` written by "another ground station" — records are ``uint64 big-endian µs`` + raw packet, received
packets with link bits 0 and sent ones with link bits 3, like MAVProxy writes them (fact sheet 5.1).

The figure-8 is the one of ``params/ardupilot-copter.toml`` [mission]: north ``A sin(wt)``, east ``B sin(2wt)``,
``up`` metres above the EKF origin, pos+vel+acc setpoints (type_mask 0x0C00, LOCAL_NED) at ``rate_hz``, sent in
answer to each LOCAL_POSITION_NED sample (stamped with its ``time_boot_ms``, sim time). Waiting is always on
``time_boot_ms``; wall-clock timeouts only guard against a dead SITL.

Flow (fact sheet 4.1 / 4.2, shared/sitl/README.md):

* ArduCopter: SET_MESSAGE_INTERVAL (never REQUEST_DATA_STREAM: it changes saved params), GUIDED + arm (retried),
  NAV_TAKEOFF, a position-only hold at the start point, the figure-8, a position-only target, LAND.
* PX4: COM_RCL_EXCEPT=4 (INT32, byte-wise), position setpoints streamed > 1 s, OFFBOARD, arm (retried: refused
  until ~20 s sim after boot), climb and hold at the start point, the figure-8, AUTO.LAND, wait for disarm (the
  ULog closes on disarm).
"""

from __future__ import annotations

import math
import os
import struct
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

os.environ.setdefault("MAVLINK20", "1")

MASK_POS_VEL_ACC = 0x0C00
MASK_POS = 0x0DF8
LINK_SENT = 3
GCS_SYSID, GCS_COMPID = 250, 190  # not the tuner's 245/191


@dataclass
class Figure8Spec:
    scale: float = 10.0
    scale_east: float = 2.5
    period: float = 20.0
    up: float = 10.0
    laps: float = 2.0
    rate_hz: int = 50

    def at(self, t: float) -> tuple[list[float], list[float], list[float]]:
        """(pos, vel, acc) NED at ``t`` s after the start."""
        w = 2 * math.pi / self.period
        A, B = self.scale, self.scale_east
        s, c, s2, c2 = math.sin(w * t), math.cos(w * t), math.sin(2 * w * t), math.cos(2 * w * t)
        return ([A * s, B * s2, -self.up], [A * w * c, 2 * B * w * c2, 0.0],
                [-A * w * w * s, -4 * B * w * w * s2, 0.0])


@dataclass
class FlightResult:
    kind: str
    t0_ms: int  # vehicle time (time_boot_ms) of reference t = 0
    t_end_ms: int
    setpoints: int
    tlog: Path | None
    spec: Figure8Spec
    texts: list[str] = field(default_factory=list)


class _Tlog:
    def __init__(self, path: Path) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        self.fh = open(path, "wb")

    def write(self, buf: bytes, link: int) -> None:
        usec = int(time.time() * 1e6)
        self.fh.write(struct.pack(">Q", (usec & ~3) | link) + bytes(buf))

    def close(self) -> None:
        self.fh.close()


class FlightError(RuntimeError):
    pass


class _Client:
    def __init__(self, device: str, tlog: Path | None, kind: str) -> None:
        from pymavlink import mavutil

        self.mavutil = mavutil
        self.kind = kind
        self.conn = mavutil.mavlink_connection(device, source_system=GCS_SYSID, source_component=GCS_COMPID,
                                               autoreconnect=True)
        self.log = _Tlog(tlog) if tlog else None
        self.texts: list[str] = []
        self.t_ms = 0
        self.pos: Any = None
        self.hb: Any = None
        if self.log:
            self.conn.message_hooks.append(lambda _c, m: m.get_type() != "BAD_DATA"
                                           and self.log.write(m.get_msgbuf(), 0))
            self.conn.mav.set_send_callback(lambda m: self.log.write(m.get_msgbuf(), LINK_SENT))
        self.vehicle = (0, 0)

    def close(self) -> None:
        try:
            self.conn.close()
        finally:
            if self.log:
                self.log.close()

    # --- receive -------------------------------------------------------------------------------------------
    def recv(self, timeout: float = 0.5) -> Any:
        m = self.conn.recv_match(blocking=True, timeout=timeout)
        if m is None:
            return None
        t = m.get_type()
        if t == "HEARTBEAT" and m.autopilot != 8 and m.type != 6:
            self.hb = m
            if self.vehicle == (0, 0):
                self.vehicle = (m.get_srcSystem(), m.get_srcComponent())
        elif t == "STATUSTEXT":
            self.texts.append(str(m.text))
        elif t == "LOCAL_POSITION_NED":
            self.pos = m
        tb = getattr(m, "time_boot_ms", None)
        if tb is not None and t in ("LOCAL_POSITION_NED", "ATTITUDE", "SYSTEM_TIME"):
            self.t_ms = max(self.t_ms, int(tb))
        return m

    def wait(self, cond, sim_s: float, what: str, wall_s: float = 120.0, on_msg=None) -> None:
        """Receive until ``cond()``; fail after ``sim_s`` of vehicle time (or ``wall_s`` without progress)."""
        start = self.t_ms
        deadline = time.monotonic() + wall_s
        while not cond():
            m = self.recv()
            if m is not None and on_msg is not None:
                on_msg(m)
            if self.t_ms and start and self.t_ms - start > sim_s * 1000:
                raise FlightError(f"{self.kind}: {what} not reached within {sim_s:g} s sim; last texts: "
                                  f"{self.texts[-3:]}")
            if time.monotonic() > deadline:
                raise FlightError(f"{self.kind}: {what}: no progress for {wall_s:g} s wall; texts {self.texts[-3:]}")
            if not start:
                start = self.t_ms

    # --- send ------------------------------------------------------------------------------------------------
    def command(self, cmd: int, *p: float) -> None:
        p = list(p) + [0.0] * (7 - len(p))
        self.conn.mav.command_long_send(self.vehicle[0], self.vehicle[1], cmd, 0, *p)

    def interval(self, msg_id: int, hz: float) -> None:
        self.command(511, msg_id, 1e6 / hz)

    def setpoint(self, t_ms: int, mask: int, pos, vel=(0, 0, 0), acc=(0, 0, 0)) -> None:
        self.conn.mav.set_position_target_local_ned_send(t_ms, self.vehicle[0], self.vehicle[1], 1, mask,
                                                         *pos, *vel, *acc, 0, 0)

    @property
    def armed(self) -> bool:
        return bool(self.hb is not None and self.hb.base_mode & 128)


def fly_figure8(kind: str, device: str, tlog: str | Path | None = None, spec: Figure8Spec | None = None,
                stream_target: bool = True, wall_timeout: float = 240.0) -> FlightResult:
    """Fly one figure-8 on a running SITL (``kind`` "ardupilot" or "px4", pymavlink ``device``).

    ``stream_target`` asks the vehicle for POSITION_TARGET_LOCAL_NED (ArduCopter) at the setpoint rate, so the
    tlog also holds the autopilot's own view of the target. Returns the vehicle time of the figure-8 start.
    """
    spec = spec or Figure8Spec()
    c = _Client(device, Path(tlog) if tlog else None, kind)
    try:
        c.wait(lambda: c.hb is not None, 60, "first HEARTBEAT", wall_s=60)
        hz = spec.rate_hz
        for msg_id, rate in ((32, hz), (30, 10), (1, 2), (2, 2)):  # LOCAL_POSITION_NED, ATTITUDE, ...
            c.interval(msg_id, rate)
        if stream_target and kind == "ardupilot":
            c.interval(85, hz)  # POSITION_TARGET_LOCAL_NED
        start_pos, _, _ = spec.at(0.0)
        if kind == "ardupilot":
            _takeoff_ardupilot(c, spec)
        else:
            _takeoff_px4(c, spec)
        # Settle at the start point (position-only hold), 3 s sim.
        t_hold = c.t_ms
        c.wait(lambda: c.t_ms - t_hold > 3000, 30, "hold at start",
               on_msg=lambda m: m.get_type() == "LOCAL_POSITION_NED" and c.setpoint(m.time_boot_ms, MASK_POS,
                                                                                     start_pos))
        # The figure-8, answering each LOCAL_POSITION_NED sample with the reference at its time stamp.
        t0 = c.t_ms + 20
        t0 -= t0 % 10
        dur_ms = int(round(spec.laps * spec.period * 1000))
        count = [0]

        def on_msg(m):
            if m.get_type() != "LOCAL_POSITION_NED":
                return
            T = int(m.time_boot_ms)
            if T < t0:
                c.setpoint(T, MASK_POS, start_pos)
                return
            p, v, a = spec.at(min(T - t0, dur_ms) / 1000.0)
            c.setpoint(T, MASK_POS_VEL_ACC, p, v, a)
            count[0] += 1

        c.wait(lambda: c.t_ms >= t0 + dur_ms + 200, spec.laps * spec.period + 30, "figure-8 end", on_msg=on_msg)
        t_end = c.t_ms
        end_pos, _, _ = spec.at(dur_ms / 1000.0)
        for _ in range(5):  # end on a position-only target (a pos+vel target is dead-reckoned, fact sheet 4.1)
            c.setpoint(c.t_ms, MASK_POS, end_pos)
        if kind == "ardupilot":
            _land_ardupilot(c)
        else:
            _land_px4(c)
        return FlightResult(kind, t0, t_end, count[0], Path(tlog) if tlog else None, spec, list(c.texts))
    finally:
        c.close()


def _takeoff_ardupilot(c: _Client, spec: Figure8Spec) -> None:
    c.wait(lambda: c.pos is not None, 90, "EKF origin (LOCAL_POSITION_NED)")
    last = [-10_000]

    def arm(_m=None):
        if c.t_ms - last[0] >= 3000:
            last[0] = c.t_ms
            c.command(176, 1, 4)  # DO_SET_MODE GUIDED
            c.command(400, 1)  # arm

    arm()
    c.wait(lambda: c.armed and c.hb.custom_mode == 4, 60, "GUIDED + armed", on_msg=arm)
    c.command(22, 0, 0, 0, 0, 0, 0, spec.up)  # NAV_TAKEOFF
    c.wait(lambda: c.pos is not None and -c.pos.z >= spec.up - 0.3, 40, "takeoff altitude")


def _land_ardupilot(c: _Client) -> None:
    c.command(176, 1, 9)  # LAND
    c.wait(lambda: not c.armed, 60, "landed and disarmed")


def _param_int_bytewise(c: _Client, name: str, value: int) -> None:
    f = struct.unpack("<f", struct.pack("<i", value))[0]
    for _ in range(3):
        c.conn.mav.param_set_send(c.vehicle[0], c.vehicle[1], name.encode(), f, 6)
        end = time.monotonic() + 2.0
        while time.monotonic() < end:
            m = c.recv()
            if m is not None and m.get_type() == "PARAM_VALUE" and m.param_id == name:
                got = struct.unpack("<i", struct.pack("<f", m.param_value))[0]
                if got == value:
                    return
    raise FlightError(f"px4: {name}={value} not confirmed")


def _takeoff_px4(c: _Client, spec: Figure8Spec) -> None:
    c.wait(lambda: c.pos is not None, 60, "LOCAL_POSITION_NED")
    _param_int_bytewise(c, "COM_RCL_EXCEPT", 4)
    start_pos, _, _ = spec.at(0.0)
    x0, y0 = c.pos.x, c.pos.y
    ground = [x0, y0, float(c.pos.z)]
    last = [-10_000]
    t_stream = c.t_ms

    def stream(m):
        if m.get_type() == "LOCAL_POSITION_NED":
            c.setpoint(m.time_boot_ms, MASK_POS, start_pos if c.armed else ground)
        if c.t_ms - t_stream > 1500 and c.t_ms - last[0] >= 2000:
            last[0] = c.t_ms
            c.command(176, 1, 6)  # DO_SET_MODE OFFBOARD
            c.command(400, 1)  # arm

    c.wait(lambda: c.armed and (c.hb.custom_mode >> 16) & 0xFF == 6, 90, "OFFBOARD + armed", on_msg=stream)
    c.wait(lambda: math.dist((c.pos.x, c.pos.y, c.pos.z), start_pos) < 0.3, 40, "climb to the start point",
           on_msg=stream)


def _land_px4(c: _Client) -> None:
    c.command(176, 1, 4, 6)  # AUTO.LAND
    c.wait(lambda: not c.armed, 90, "landed and disarmed")
