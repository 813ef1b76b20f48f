"""Synthetic flight logs with known tracking errors (flight-log tests): an ArduPilot DataFlash writer and a tlog
writer, both flying the profile figure-8 with ``actual = target + error(t)`` in closed form."""

from __future__ import annotations

import math
import struct
from pathlib import Path

import numpy as np

from ksbo_mav.mav.mission import MASK_POS_VEL_ACC, Mission
from ksbo_mav.mav.tlog import LINK_RECEIVED, LINK_SENT, TlogWriter
from ksbo_mav.mav.wire import mavlink
from ksbo_mav.profiles import load_profile

MISSION = Mission.from_profile(load_profile("ardupilot-copter"))
W = 2 * math.pi / MISSION.period
T_GUIDED, T0, T_LAND, T_DISARM = 10.0, 20.0, 62.0, 70.0  # s since boot
EH, EV = (0.2, 0.1), 0.05  # error: north 0.2 cos(wt), east 0.1 sin(wt), down 0.05


def error(t: np.ndarray, scale: float = 1.0) -> np.ndarray:
    t = np.asarray(t, dtype=float)
    return scale * np.column_stack([EH[0] * np.cos(W * t), EH[1] * np.sin(W * t), np.full_like(t, EV)])


def target(t: float, laps: float = 2.0) -> tuple[np.ndarray, np.ndarray]:
    """Commanded (pos, vel) NED: hold at the start point, the figure-8 from T0 for ``laps``, then hold."""
    tt = min(max(t - T0, 0.0), laps * MISSION.period)
    p, v, _ = MISSION.setpoint_at(tt)
    if t < T0 or t > T0 + laps * MISSION.period:
        v = np.zeros(3)
    return p, v


def on_ground(p: np.ndarray) -> np.ndarray:
    """Where the vehicle sits before take-off: below the hold point, on the ground (D = 0)."""
    return np.array([p[0], p[1], 0.0])


# expected lap statistics of the error above (one full period of cos/sin)
H_RMS = math.sqrt((EH[0] ** 2 + EH[1] ** 2) / 2)


_CONV = {"Q": "Q", "f": "f", "B": "B", "M": "B", "b": "b", "I": "I", "Z": "64s", "N": "16s", "n": "4s", "h": "h",
         "H": "H"}


class DFWriter:
    def __init__(self) -> None:
        self.buf = bytearray()
        self.fmts: dict[str, tuple[int, struct.Struct]] = {}
        self._write_fmt(0x80, "FMT", "BBnNZ", "Type,Length,Name,Format,Columns")

    def _write_fmt(self, typ: int, name: str, fmt: str, cols: str) -> None:
        st = struct.Struct("<" + "".join(_CONV[c] for c in fmt))
        self.fmts[name] = (typ, st)
        body = struct.pack("<BB4s16s64s", typ, st.size + 3, name.encode(), fmt.encode(), cols.encode())
        self.buf += b"\xa3\x95\x80" + body

    def define(self, typ: int, name: str, fmt: str, cols: str) -> None:
        self._write_fmt(typ, name, fmt, cols)

    def msg(self, name: str, *values) -> None:
        typ, st = self.fmts[name]
        vals = [v.encode() if isinstance(v, str) else v for v in values]
        self.buf += bytes((0xA3, 0x95, typ)) + st.pack(*vals)


def write_bin(path: Path, laps: float = 2.0, log_bitmask: int = 180222, psc: bool = True, guided: bool = True,
              markers: bool | str = False, err_scale: float = 1.0, motor_shake_us: float | None = None) -> Path:
    """``markers``: log the tuner's start marker, True as ArduPilot logs another system's STATUSTEXT
    (``SRC=245/191:``) or the prefix given (``GCS:``, the sender being ``MAV_GCS_SYSID``). ``motor_shake_us``: log
    RCOU at 50 Hz, four motors around 1500 µs with this amplitude at 7 Hz on top of a slow throttle change (C5-C8
    unused, 0)."""
    w = DFWriter()
    w.define(32, "PARM", "QNff", "TimeUS,Name,Value,Default")
    w.define(120, "MODE", "QMBB", "TimeUS,Mode,ModeNum,Rsn")
    w.define(59, "MSG", "QZ", "TimeUS,Message")
    w.define(186, "ARM", "QBIBB", "TimeUS,ArmState,ArmChecks,Forced,Method")
    for i, ax in enumerate("NED"):
        w.define(200 + i, f"PSC{ax}", "Qfffffffff",
                 f"TimeUS,DP{ax},TP{ax},P{ax},DV{ax},TV{ax},V{ax},DA{ax},TA{ax},A{ax}")
    w.define(8, "GUIP", "QBfffbffffff", "TimeUS,Type,pX,pY,pZ,Terrain,vX,vY,vZ,aX,aY,aZ")
    w.define(11, "IMU", "Qffffff", "TimeUS,GyrX,GyrY,GyrZ,AccX,AccY,AccZ")  # filler the reader must skip
    if motor_shake_us is not None:
        w.define(9, "RCOU", "QHHHHHHHH", "TimeUS,C1,C2,C3,C4,C5,C6,C7,C8")
    us = lambda t: int(round(t * 1e6))  # noqa: E731
    w.msg("PARM", us(1.0), "LOG_BITMASK", float(log_bitmask), 180222.0)
    w.msg("MSG", us(1.0), "ArduCopter V4.7.0-dev (synthetic)")
    w.msg("MODE", us(1.0), 0, 0, 1)
    w.msg("MODE", us(T_GUIDED), 4 if guided else 5, 4 if guided else 5, 2)
    if markers:
        n = MISSION.steps
        prefix = "SRC=245/191:" if markers is True else markers
        w.msg("MSG", us(T0 - 0.01), f"{prefix}ksbo f8h start t0={int(T0 * 1000)} n={n} dt=20 w={n // 2}")
    events = [(T_LAND, "land"), (T_DISARM, "disarm")]
    t = 1.0
    k = 0
    while t < T_DISARM + 1.0:
        if events and t >= events[0][0]:
            what = events.pop(0)[1]
            if what == "land":
                w.msg("MODE", us(t), 9, 9, 2)
            else:
                w.msg("ARM", us(t), 0, 0, 0, 13)
        w.msg("IMU", us(t), 0.0, 0.0, 0.0, 0.0, 0.0, -9.8)
        if motor_shake_us is not None:
            slow, shake = 1500 + 60 * math.sin(2 * math.pi * t / 20.0), motor_shake_us * math.sin(2 * math.pi * 7 * t)
            w.msg("RCOU", us(t), *(int(round(slow + sg * shake)) for sg in (1, -1, 1, -1)), 0, 0, 0, 0)
        if k % 5 == 0 and psc and T_GUIDED <= t <= T_LAND and log_bitmask & (1 << 5):
            p, v = target(t, laps)
            a = p + error([t], err_scale)[0]
            for i, ax in enumerate("NED"):
                w.msg(f"PSC{ax}", us(t), p[i], p[i], a[i], v[i], v[i], v[i], 0.0, 0.0, 0.0)
        if T0 <= t <= T0 + laps * MISSION.period:
            p, v = target(t, laps)
            w.msg("GUIP", us(t + 0.002), 3, p[0], p[1], -p[2], 0, v[0], v[1], -v[2], 0.0, 0.0, 0.0)
        k += 1
        t = 1.0 + k * 0.02
    path.write_bytes(bytes(w.buf))
    return path


def write_other_tlog(path: Path, laps: float = 2.0, sent: bool = True, err_scale: float = 1.0) -> Path:
    """A tlog as another ground station writes it: vehicle HEARTBEAT/LOCAL_POSITION_NED received, its own
    SET_POSITION_TARGET_LOCAL_NED sent (link 3, if ``sent``), no ksbo markers."""
    veh, gcs = mavlink.MAVLink(None, srcSystem=1, srcComponent=1), mavlink.MAVLink(None, 255, 190)
    wr = TlogWriter(path)
    usec = [1_700_000_000_000_000]

    def put(mav, msg, link):
        usec[0] += 1000
        wr.write(msg.pack(mav), link, usec[0])

    t = 1.0
    k = 0
    while t < T_DISARM:
        ms = int(round(t * 1000))
        if k % 50 == 0:
            mode = 4 if T_GUIDED <= t < T_LAND else (9 if t >= T_LAND else 0)
            put(veh, veh.heartbeat_encode(2, 3, 128 | 1 if t >= 5 else 1, mode, 4, 3), LINK_RECEIVED)
        p, v = target(t, laps)
        a = p + error([t], err_scale)[0] if t >= T_GUIDED else on_ground(p)
        put(veh, veh.local_position_ned_encode(ms, *a, *v), LINK_RECEIVED)
        if sent and T_GUIDED <= t < T_LAND:
            put(gcs, gcs.set_position_target_local_ned_encode(ms, 1, 1, 1, MASK_POS_VEL_ACC, *p, *v, 0, 0, 0, 0, 0),
                LINK_SENT)
        k += 1
        t = 1.0 + k * 0.02
    wr.close()
    return path


# --- PX4 ULog -------------------------------------------------------------------------------------------------
_ULOG_TOPICS = {
    "vehicle_local_position": ("uint64_t timestamp;float x;float y;float z;float vx;float vy;float vz;", "<Q6f"),
    "vehicle_local_position_setpoint": ("uint64_t timestamp;float x;float y;float z;float vx;float vy;float vz;",
                                        "<Q6f"),
    "trajectory_setpoint": ("uint64_t timestamp;float[3] position;float[3] velocity;", "<Q6f"),
    "vehicle_status": ("uint64_t timestamp;uint8_t nav_state;uint8_t arming_state;", "<QBB"),
}


def _ulog_msg(typ: bytes, payload: bytes) -> bytes:
    return struct.pack("<HB", len(payload), typ[0]) + payload


def write_ulg(path: Path, laps: float = 2.0, err_scale: float = 1.0, topics=tuple(_ULOG_TOPICS)) -> Path:
    """A PX4 ULog of the same flight as :func:`write_bin`: OFFBOARD from T_GUIDED, AUTO.LAND at T_LAND, disarm."""
    out = bytearray(b"ULog\x01\x12\x35\x01" + struct.pack("<Q", 0))
    key = b"char[9] sys_name"
    out += _ulog_msg(b"I", bytes([len(key)]) + key + b"PX4 synth")
    for name in topics:
        out += _ulog_msg(b"F", f"{name}:{_ULOG_TOPICS[name][0]}".encode())
    ids = {}
    for i, name in enumerate(topics):
        ids[name] = i
        out += _ulog_msg(b"A", struct.pack("<BH", 0, i) + name.encode())
    us = lambda t: int(round(t * 1e6))  # noqa: E731

    def data(name, *values):
        if name in ids:
            out.extend(_ulog_msg(b"D", struct.pack("<H", ids[name]) + struct.pack(_ULOG_TOPICS[name][1], *values)))

    state = None
    t, k = 1.0, 0
    while t < T_DISARM + 1.0:
        nav, arm = (14, 2) if T_GUIDED <= t < T_LAND else ((18, 2) if T_LAND <= t < T_DISARM else (4, 1))
        if (nav, arm) != state or k % 50 == 0:
            data("vehicle_status", us(t), nav, arm)
            state = (nav, arm)
        p, v = target(t, laps)
        a = p + error([t], err_scale)[0] if t >= T_GUIDED else on_ground(p)
        data("vehicle_local_position", us(t), *a, *v)
        if k % 5 == 0 and T_GUIDED <= t < T_LAND:
            data("vehicle_local_position_setpoint", us(t), *p, *v)
        if k % 10 == 0 and T_GUIDED <= t < T_LAND:
            data("trajectory_setpoint", us(t - 0.001), *p, *v)
        k += 1
        t = 1.0 + k * 0.02
    out += _ulog_msg(b"L", struct.pack("<BQ", 54, us(t)) + b"[commander] Disarmed")
    path.write_bytes(bytes(out))
    return path
