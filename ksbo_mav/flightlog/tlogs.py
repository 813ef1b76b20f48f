"""MAVLink tlog reader (any ground station; records framed from an mmap, only needed ids decoded) ->
FlightLog."""

from __future__ import annotations

import mmap
import struct
from pathlib import Path

import numpy as np

from ksbo_mav.errors import InputError
from ksbo_mav.flightlog.detect import open_log
from ksbo_mav.flightlog.model import FlightLog, Marker, ModeChange, Track
from ksbo_mav.flightlog.modes import COPTER_MODES, COPTER_TRACKING, PX4_AUTO_SUB, PX4_MAIN

# --- MAVLink tlog -----------------------------------------------------------------------------------------------
_USEC_MIN, _USEC_MAX = 946_684_800 * 10**6, 4_102_444_800 * 10**6
_IDS = {0: "HEARTBEAT", 32: "LOCAL_POSITION_NED", 84: "SET_POSITION_TARGET_LOCAL_NED",
        85: "POSITION_TARGET_LOCAL_NED", 253: "STATUSTEXT"}
_TIMED = {30, 32, 85, 2, 33}  # messages whose time_boot_ms advances the vehicle clock


def read_any_tlog(p: Path, partial: bool = False) -> FlightLog:
    from ksbo_mav.mav.wire import mavlink

    parser = mavlink.MAVLink(None)
    parser.robust_parsing = False
    fh, size = open_log(p)
    with fh:
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
