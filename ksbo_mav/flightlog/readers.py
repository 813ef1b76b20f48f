"""Format readers -> :class:`~ksbo_mav.flightlog.model.FlightLog`.

* ``.BIN`` (ArduCopter): actual and target position from the position controller's own log, PSCN/PSCE/PSCD
  (``PN``/``TPN``..., metres, NED, 10 Hz under ``LOG_BITMASK`` bit 5 NTUN), the guided setpoints it received as
  GUIP (north, east, *up*), modes from MODE, trial markers from MSG (ArduPilot logs every STATUSTEXT a ground
  station sends as ``SRC=sys/comp:text``).
* ``.ulg`` (PX4): ``vehicle_local_position`` (actual), ``vehicle_local_position_setpoint`` (the position
  controller's target), ``trajectory_setpoint`` (what offboard/auto asked for), ``vehicle_status.nav_state`` for
  modes (armed only); read with pyulog, filtered to those topics.
* ``.tlog`` (any ground station): the vehicle's LOCAL_POSITION_NED; its POSITION_TARGET_LOCAL_NED when streamed
  (the autopilot's target), else the SET_POSITION_TARGET_LOCAL_NED a ground station sent; modes from the
  vehicle's HEARTBEATs; ksbo trial markers from STATUSTEXT. Streamed: records are framed from an mmap and only
  the needed message ids are decoded.
"""

from __future__ import annotations

import mmap
import struct
from pathlib import Path
from typing import Any

import numpy as np

from ksbo_mav.errors import InputError
from ksbo_mav.flightlog.dataflash import read_dataflash
from ksbo_mav.flightlog.detect import detect_format
from ksbo_mav.flightlog.model import FlightLog, Marker, ModeChange, Track

# ArduCopter modes (fact sheet 1.3 plus the rest of Copter's table); position-target tracking ones flagged.
COPTER_MODES = {0: "STABILIZE", 1: "ACRO", 2: "ALT_HOLD", 3: "AUTO", 4: "GUIDED", 5: "LOITER", 6: "RTL",
                7: "CIRCLE", 9: "LAND", 11: "DRIFT", 13: "SPORT", 14: "FLIP", 15: "AUTOTUNE", 16: "POSHOLD",
                17: "BRAKE", 18: "THROW", 19: "AVOID_ADSB", 20: "GUIDED_NOGPS", 21: "SMART_RTL", 22: "FLOWHOLD",
                23: "FOLLOW", 24: "ZIGZAG", 25: "SYSTEMID", 26: "AUTOROTATE", 27: "AUTO_RTL", 28: "TURTLE"}
COPTER_TRACKING = {3, 4}  # AUTO, GUIDED
# PX4 vehicle_status.nav_state
PX4_NAV = {0: "MANUAL", 1: "ALTCTL", 2: "POSCTL", 3: "AUTO_MISSION", 4: "AUTO_LOITER", 5: "AUTO_RTL",
           6: "POSITION_SLOW", 10: "ACRO", 12: "DESCEND", 13: "TERMINATION", 14: "OFFBOARD", 15: "STAB",
           17: "AUTO_TAKEOFF", 18: "AUTO_LAND", 19: "AUTO_FOLLOW_TARGET", 20: "AUTO_PRECLAND", 21: "ORBIT",
           22: "AUTO_VTOL_TAKEOFF"}
PX4_TRACKING = {3, 14}  # AUTO_MISSION, OFFBOARD
# PX4 custom_mode main modes in HEARTBEAT (fact sheet 1.3): 4 AUTO (sub 4 MISSION), 6 OFFBOARD
PX4_MAIN = {1: "MANUAL", 2: "ALTCTL", 3: "POSCTL", 4: "AUTO", 5: "ACRO", 6: "OFFBOARD", 7: "STABILIZED", 8: "RATTITUDE"}
PX4_AUTO_SUB = {1: "READY", 2: "TAKEOFF", 3: "LOITER", 4: "MISSION", 5: "RTL", 6: "LAND", 8: "FOLLOW_TARGET",
                9: "PRECLAND"}

# Copter LOG_BITMASK bits that the messages needed here depend on.
NTUN_BIT = 5


def read_log(path: str | Path, partial: bool = False) -> FlightLog:
    """Read any supported log (format detected by content)."""
    fmt = detect_format(path)
    return {"bin": read_bin, "ulg": read_ulg, "tlog": read_any_tlog}[fmt](Path(path), partial=partial)


# --- ArduPilot DataFlash ------------------------------------------------------------------------------------------
BIN_WANTED = {"PSCN", "PSCE", "PSCD", "GUIP", "MODE", "MSG", "PARM", "ARM"}


def read_bin(p: Path, partial: bool = False) -> FlightLog:
    c = read_dataflash(p, BIN_WANTED)
    have = {k for k in ("PSCN", "PSCE", "PSCD") if k in c.data and len(c.data[k])}
    params = _bin_params(c)
    if have != {"PSCN", "PSCE", "PSCD"}:
        missing = ", ".join(sorted({"PSCN", "PSCE", "PSCD"} - have))
        bitmask = params.get("LOG_BITMASK")
        if bitmask is not None and not int(bitmask) & (1 << NTUN_BIT):
            why = (f"position-controller logging is off: LOG_BITMASK = {int(bitmask)} lacks bit {NTUN_BIT} "
                   f"(NTUN, value {1 << NTUN_BIT}); set LOG_BITMASK = {int(bitmask) | (1 << NTUN_BIT)} and fly again")
        elif bitmask is None:
            why = (f"no PARM LOG_BITMASK in the log either; PSCN/PSCE/PSCD are logged under LOG_BITMASK bit "
                   f"{NTUN_BIT} (NTUN) in GUIDED/AUTO/LOITER")
        else:
            why = (f"LOG_BITMASK = {int(bitmask)} has bit {NTUN_BIT} (NTUN) set, so the vehicle never flew a "
                   f"position-controlled mode while logging")
        if c.truncated and c.messages < 100:
            raise InputError(f"DataFlash log {p} is truncated: it ends inside message {c.messages + 1} at offset "
                             f"{c.end} of {c.size} bytes, before any position-controller data")
        raise InputError(f"DataFlash log {p} has no position-controller messages ({missing}): {why}")
    n = min(len(c.data[k]) for k in ("PSCN", "PSCE", "PSCD"))
    t = c.data["PSCN"]["TimeUS"][:n].astype(float) * 1e-6
    cols = lambda pre: np.column_stack([c.column(m, f"{pre}{ax}")[:n]  # noqa: E731
                                        for m, ax in (("PSCN", "N"), ("PSCE", "E"), ("PSCD", "D"))])
    actual = Track(t, cols("P"), cols("V"), "PSCN/PSCE/PSCD P* (EKF position)")
    target = Track(t, cols("TP"), cols("TV"), "PSCN/PSCE/PSCD TP* (position controller target)")
    commanded = None
    if "GUIP" in c.data and len(c.data["GUIP"]):
        g = c.data["GUIP"]
        pos = np.column_stack([g["pX"], g["pY"], -g["pZ"].astype(float)])  # GUIP z is up
        vel = np.column_stack([g["vX"], g["vY"], -g["vZ"].astype(float)])
        # ModeGuided SubMode: 2 Pos, 3 PosVelAccel carry a position; 0 TakeOff, 1 WP, 4 VelAccel, 5 Accel,
        # 6 Angle do not (or not in this frame).
        sel = np.isin(g["Type"], (2, 3))
        if sel.any():
            commanded = Track(g["TimeUS"][sel] * 1e-6, pos[sel], vel[sel], "GUIP (guided setpoint received)")
    modes = []
    if "MODE" in c.data:
        for row in c.data["MODE"]:
            num = int(row["ModeNum"])
            modes.append(ModeChange(float(row["TimeUS"]) * 1e-6, COPTER_MODES.get(num, f"MODE{num}"),
                                    num in COPTER_TRACKING))
    if "ARM" in c.data:
        for row in c.data["ARM"]:
            if int(row["ArmState"]) == 0:
                modes.append(ModeChange(float(row["TimeUS"]) * 1e-6, "DISARMED", False))
    modes.sort(key=lambda m: m.t)
    markers = []
    if "MSG" in c.data:
        for row in c.data["MSG"]:
            text = row["Message"].split(b"\0", 1)[0].decode("ascii", "replace")
            if ":" in text and text.startswith("SRC="):
                text = text.split(":", 1)[1]
            if text.startswith("ksbo "):
                markers.append(Marker(float(row["TimeUS"]) * 1e-6, text))
    log = FlightLog(p, "bin", "ardupilot", actual, target, commanded, modes, markers,
                    info={"bytes": c.size, "messages": c.messages, "pscn": n, "params": params,
                          "end_offset": c.end})
    if c.truncated:
        log.truncated_at = float(t[-1]) if n else None
        log.info["truncated"] = f"ends inside a message at offset {c.end} of {c.size}"
    return log


def _bin_params(c) -> dict[str, float]:
    out: dict[str, float] = {}
    if "PARM" in c.data:
        for row in c.data["PARM"]:
            out[row["Name"].split(b"\0", 1)[0].decode("ascii", "replace")] = float(row["Value"])
    return out


# --- PX4 ULog ---------------------------------------------------------------------------------------------------
ULG_TOPICS = ["vehicle_local_position", "vehicle_local_position_setpoint", "trajectory_setpoint", "vehicle_status"]


_ULOG_TYPES = set(b"BFIMPQARDLCSO")  # ULog message types (header: uint16 size, uint8 type)


class _CutDetector:
    """File wrapper for pyulog, which silently stops at a cut and resynchronises over damage: remembers where a
    read came back short (a cut) and where a message header had an unknown type (broken framing)."""

    def __init__(self, fh) -> None:
        self.fh = fh
        self.short_at: int | None = None
        self.bad_at: int | None = None

    def read(self, n: int = -1) -> bytes:
        pos = self.fh.tell()
        data = self.fh.read(n)
        if n is not None and n > 0 and 0 < len(data) < n and self.short_at is None:
            self.short_at = pos
        if n == 3 and len(data) == 3 and data[2] not in _ULOG_TYPES and self.bad_at is None and pos >= 16:
            self.bad_at = pos
        return data

    def __getattr__(self, name: str) -> Any:
        return getattr(self.fh, name)


def read_ulg(p: Path, partial: bool = False) -> FlightLog:
    try:
        from pyulog import ULog
    except ImportError:  # pragma: no cover - a declared dependency
        raise InputError("reading .ulg needs pyulog (pip install pyulog)") from None
    try:
        fh = open(p, "rb")
    except OSError as exc:
        raise InputError(f"cannot read log {p}: {exc.strerror or exc}") from None
    size = p.stat().st_size
    wrap = _CutDetector(fh)
    try:
        ulog = ULog(wrap, ULG_TOPICS, disable_str_exceptions=True)
    except Exception as exc:  # pyulog raises ULogException, struct.error, IndexError... on a damaged header
        raise InputError(f"PX4 ULog {p} is corrupted or truncated in its header/definitions: {exc}") from None
    finally:
        fh.close()
    topics = {d.name: d for d in ulog.data_list if d.multi_id == 0}
    if "vehicle_local_position" not in topics:
        if wrap.short_at is not None:
            raise InputError(f"PX4 ULog {p} is truncated at offset {wrap.short_at} of {size} bytes, before any "
                             f"vehicle_local_position sample")
        raise InputError(f"PX4 ULog {p} has no vehicle_local_position topic (the logger profile must include "
                         f"it: SDLOG_PROFILE default set)")
    lp = topics["vehicle_local_position"].data
    t = lp["timestamp"] * 1e-6
    actual = Track(t, np.column_stack([lp["x"], lp["y"], lp["z"]]), np.column_stack([lp["vx"], lp["vy"], lp["vz"]]),
                   "vehicle_local_position (EKF2)")
    target = None
    if "vehicle_local_position_setpoint" in topics:
        sp = topics["vehicle_local_position_setpoint"].data
        target = Track(sp["timestamp"] * 1e-6, np.column_stack([sp["x"], sp["y"], sp["z"]]),
                       np.column_stack([sp["vx"], sp["vy"], sp["vz"]]),
                       "vehicle_local_position_setpoint (position controller target)")
    commanded = None
    if "trajectory_setpoint" in topics:
        ts = topics["trajectory_setpoint"].data
        commanded = Track(ts["timestamp"] * 1e-6,
                          np.column_stack([ts["position[0]"], ts["position[1]"], ts["position[2]"]]),
                          np.column_stack([ts["velocity[0]"], ts["velocity[1]"], ts["velocity[2]"]]),
                          "trajectory_setpoint")
    if target is None:
        raise InputError(f"PX4 ULog {p} has no vehicle_local_position_setpoint topic: the position controller's "
                         f"target is not logged (logger profile, SDLOG_PROFILE)")
    modes: list[ModeChange] = []
    if "vehicle_status" in topics:
        vs = topics["vehicle_status"].data
        prev = None
        for ts_, nav, arm in zip(vs["timestamp"], vs["nav_state"], vs["arming_state"]):
            key = (int(nav), int(arm) == 2)
            if key != prev:
                name = PX4_NAV.get(key[0], f"NAV{key[0]}") if key[1] else "DISARMED"
                modes.append(ModeChange(float(ts_) * 1e-6, name, key[1] and key[0] in PX4_TRACKING))
                prev = key
    markers = []
    for m in ulog.logged_messages:
        text = m.message
        if "] " in text and text.startswith("["):
            text = text.split("] ", 1)[1]
        if text.startswith("ksbo "):
            markers.append(Marker(m.timestamp * 1e-6, text.strip()))
    log = FlightLog(p, "ulg", "px4", actual, target, commanded, modes, markers,
                    info={"bytes": size, "corruption": bool(ulog.file_corruption)})
    if ulog.file_corruption or wrap.bad_at is not None:
        where = f" at offset {wrap.bad_at}" if wrap.bad_at is not None else ""
        if not partial:
            raise InputError(f"PX4 ULog {p} is corrupted{where}: damaged messages were skipped; pass --partial to "
                             f"score what could be read")
        log.warnings.append("pyulog reported corrupted data and skipped it")
    if wrap.short_at is not None:
        log.truncated_at = float(t[-1])
        log.info["truncated"] = f"ends inside a message at offset {wrap.short_at} of {size}"
    return log


# --- MAVLink tlog -----------------------------------------------------------------------------------------------
_USEC_MIN, _USEC_MAX = 946_684_800 * 10**6, 4_102_444_800 * 10**6
_IDS = {0: "HEARTBEAT", 32: "LOCAL_POSITION_NED", 84: "SET_POSITION_TARGET_LOCAL_NED",
        85: "POSITION_TARGET_LOCAL_NED", 253: "STATUSTEXT"}
_TIMED = {30, 32, 85, 2, 33}  # messages whose time_boot_ms advances the vehicle clock


def read_any_tlog(p: Path, partial: bool = False) -> FlightLog:
    from ksbo_mav.mav.wire import mavlink

    parser = mavlink.MAVLink(None)
    parser.robust_parsing = False
    try:
        fh = open(p, "rb")
    except OSError as exc:
        raise InputError(f"cannot read log {p}: {exc.strerror or exc}") from None
    with fh:
        size = fh.seek(0, 2)
        if size == 0:
            raise InputError(f"log {p} is empty")
        mm = mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ)
        try:
            recs = _tlog_walk(mm, size, parser, p)
        finally:
            mm.close()
    return _tlog_to_log(p, size, *recs)


def _tlog_walk(mm, size, parser, p):
    pos, n = 0, size
    vehicle: tuple[int, int] | None = None
    autopilot = "unknown"
    clock = 0.0
    pos_rows, tgt_rows, cmd_rows, modes, markers = [], [], [], [], []
    last_mode = None
    count = 0
    cut = None
    want = set(_IDS) | _TIMED
    while pos < n:
        if n - pos < 8 + 8:
            cut = pos
            break
        (stamp,) = struct.unpack_from(">Q", mm, pos)
        if not _USEC_MIN <= stamp <= _USEC_MAX:
            raise InputError(f"tlog {p} is corrupted at offset {pos}: implausible timestamp")
        start = pos + 8
        magic = mm[start]
        if magic == 0xFD:
            length = 10 + mm[start + 1] + 2 + (13 if mm[start + 2] & 0x01 else 0)
            msgid = mm[start + 7] | (mm[start + 8] << 8) | (mm[start + 9] << 16)
            src = (mm[start + 5], mm[start + 6])
        elif magic == 0xFE:
            length = 6 + mm[start + 1] + 2
            msgid, src = mm[start + 5], (mm[start + 3], mm[start + 4])
        else:
            raise InputError(f"tlog {p} is corrupted at offset {start}: 0x{magic:02x} is not a MAVLink start byte")
        if start + length > n:
            cut = pos
            break
        pos = start + length
        count += 1
        if msgid not in want:
            continue
        try:
            msg = parser.decode(bytearray(mm[start:start + length]))
        except Exception as exc:
            raise InputError(f"tlog {p} is corrupted at offset {start}: {exc}") from None
        sent = (stamp & 3) == 3
        if msgid == 0:
            if vehicle is None and msg.autopilot != 8 and msg.type != 6 and not sent:
                vehicle = src
                autopilot = {3: "ardupilot", 12: "px4"}.get(msg.autopilot, "unknown")
            if src == vehicle and not sent:
                armed = bool(msg.base_mode & 128)
                name, tracking = _hb_mode(autopilot, msg.custom_mode)
                key = (name, armed)
                if key != last_mode:
                    modes.append(ModeChange(clock, name if armed else "DISARMED", tracking and armed))
                    last_mode = key
            continue
        if msgid == 253:
            text = str(msg.text)
            if text.startswith("ksbo "):
                markers.append(Marker(clock, text))
            continue
        if msgid == 84:
            if msg.coordinate_frame == 1 and not msg.type_mask & 0x7:
                cmd_rows.append((msg.time_boot_ms * 1e-3, msg.x, msg.y, msg.z, msg.vx, msg.vy, msg.vz))
            continue
        if vehicle is not None and src != vehicle:
            continue
        t = msg.time_boot_ms * 1e-3
        clock = max(clock, t)
        if msgid == 32:
            pos_rows.append((t, msg.x, msg.y, msg.z, msg.vx, msg.vy, msg.vz))
        elif msgid == 85 and msg.coordinate_frame == 1 and not msg.type_mask & 0x7:
            tgt_rows.append((t, msg.x, msg.y, msg.z, msg.vx, msg.vy, msg.vz))
    return autopilot, pos_rows, tgt_rows, cmd_rows, modes, markers, count, cut


def _hb_mode(autopilot: str, custom: int) -> tuple[str, bool]:
    if autopilot == "px4":
        main, sub = (custom >> 16) & 0xFF, (custom >> 24) & 0xFF
        name = PX4_MAIN.get(main, f"MAIN{main}") + (f".{PX4_AUTO_SUB.get(sub, sub)}" if main == 4 else "")
        return name, main == 6 or (main == 4 and sub == 4)
    return COPTER_MODES.get(custom, f"MODE{custom}"), custom in COPTER_TRACKING


def _track(rows, label) -> Track | None:
    if not rows:
        return None
    a = np.array(rows, dtype=float)
    # one sample per stamp (a stream may repeat a time_boot_ms); keep the last
    _, idx = np.unique(a[::-1, 0], return_index=True)
    a = a[::-1][idx]
    return Track(a[:, 0], a[:, 1:4], a[:, 4:7], label)


def _tlog_to_log(p, size, autopilot, pos_rows, tgt_rows, cmd_rows, modes, markers, count, cut) -> FlightLog:
    actual = _track(pos_rows, "LOCAL_POSITION_NED")
    if actual is None:
        if cut is not None:
            raise InputError(f"tlog {p} is truncated at offset {cut} of {size} bytes, before any "
                             f"LOCAL_POSITION_NED")
        raise InputError(f"tlog {p} has no LOCAL_POSITION_NED from the vehicle ({count} records): ask for it "
                         f"with SET_MESSAGE_INTERVAL (id 32) when flying")
    target = _track(tgt_rows, "POSITION_TARGET_LOCAL_NED (autopilot target)")
    commanded = _track(cmd_rows, "SET_POSITION_TARGET_LOCAL_NED (sent by the ground station)")
    log = FlightLog(p, "tlog", autopilot, actual, target or commanded, commanded, modes, markers,
                    info={"bytes": size, "records": count})
    if target is None and commanded is not None:
        log.warnings.append("the vehicle's POSITION_TARGET_LOCAL_NED is not in the tlog: errors are against the "
                            "setpoints the ground station sent")
    if cut is not None:
        log.truncated_at = float(actual.t[-1])
        log.info["truncated"] = f"ends inside a record at offset {cut} of {size}"
    return log
