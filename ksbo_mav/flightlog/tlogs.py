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
from ksbo_mav.flightlog.tlog_frames import frame_len, resync, valid_record
from ksbo_mav.flightlog.modes import COPTER_MODES, COPTER_TRACKING, PX4_AUTO_SUB, PX4_MAIN

# --- MAVLink tlog -----------------------------------------------------------------------------------------------
#: A tlog record is an 8-byte big-endian timestamp (µs, the low 2 bits flag sent/received on our own logs) and one
#: MAVLink frame. The timestamp is not trusted to be a date (ground stations with a clock near 1970 exist); a
#: record is recognised by its frame, and where the bytes stop making records (recording began mid-stream, damage)
#: the reader resynchronises on the next frame whose checksum holds, and says how many bytes it skipped.
_IDS = {0: "HEARTBEAT", 32: "LOCAL_POSITION_NED", 84: "SET_POSITION_TARGET_LOCAL_NED",
        85: "POSITION_TARGET_LOCAL_NED", 253: "STATUSTEXT"}
_TIMED = {30, 32, 85, 87, 2, 33}  # messages whose time_boot_ms advances the vehicle clock


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
    glob_rows, gtgt_rows = [], []  # GLOBAL_POSITION_INT, POSITION_TARGET_GLOBAL_INT (flightlog.geo)
    last_mode = None
    count = 0
    cut = None
    skipped: list[tuple[int, int]] = []  # (offset, bytes) of damaged or foreign spans passed over
    want = set(_IDS) | _TIMED
    while pos < n:
        if n - pos < 8 + 8:
            cut = pos
            break
        (stamp,) = struct.unpack_from(">Q", mm, pos)
        start = pos + 8
        length = frame_len(mm, start, n)
        if length is None or (count == 0 and not valid_record(mm, pos, n, parser)):
            nxt = resync(mm, pos + (0 if count == 0 else 1), n, parser)
            if nxt is None or nxt == pos and length is None:
                if count == 0:
                    raise InputError(f"{p} holds no MAVLink tlog record: no frame with a valid checksum after an "
                                     "8-byte timestamp in its first megabyte")
                skipped.append((pos, n - pos))
                break
            if nxt != pos:
                skipped.append((pos, nxt - pos))
                pos = nxt
                continue
        magic = mm[start]
        if magic == 0xFD:
            msgid = mm[start + 7] | (mm[start + 8] << 8) | (mm[start + 9] << 16)
            src = (mm[start + 5], mm[start + 6])
        else:
            msgid, src = mm[start + 5], (mm[start + 3], mm[start + 4])
        if start + length > n:
            cut = pos
            break
        pos = start + length
        count += 1
        if msgid not in want:
            continue
        try:
            msg = parser.decode(bytearray(mm[start:start + length]))
        except Exception:  # damaged inside a record: skip to the next valid one
            nxt = resync(mm, pos - length - 7, n, parser)
            skipped.append((pos - length - 8, (nxt if nxt is not None else n) - (pos - length - 8)))
            if nxt is None:
                break
            pos = nxt
            continue
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
        elif msgid == 33:
            glob_rows.append((t, msg.lat * 1e-7, msg.lon * 1e-7, msg.alt * 1e-3, msg.relative_alt * 1e-3))
        elif msgid == 87 and not msg.type_mask & 0x7:
            gtgt_rows.append((t, msg.lat_int * 1e-7, msg.lon_int * 1e-7, msg.alt, msg.coordinate_frame, msg.vx,
                              msg.vy, msg.vz))
    tgt_label = "POSITION_TARGET_LOCAL_NED (autopilot target)"
    if not tgt_rows and gtgt_rows:
        tgt_rows = _global_targets(pos_rows, glob_rows, gtgt_rows)
        tgt_label = "POSITION_TARGET_GLOBAL_INT (autopilot target, in the log's local frame)"
    return autopilot, pos_rows, tgt_rows, tgt_label, cmd_rows, modes, markers, count, cut, skipped


def _global_targets(pos_rows, glob_rows, gtgt_rows) -> list[tuple]:
    """POSITION_TARGET_GLOBAL_INT rows in the local frame (origin from the GLOBAL_POSITION_INT /
    LOCAL_POSITION_NED pairs); [] when the log holds no such pairs."""
    from ksbo_mav.flightlog.geo import origin_from_pairs, to_local

    if not pos_rows or not glob_rows:
        return []
    pos, glob = np.asarray(pos_rows, float), np.asarray(glob_rows, float)
    local = np.column_stack([np.interp(glob[:, 0], pos[:, 0], pos[:, k]) for k in (1, 2, 3)])
    inside = (glob[:, 0] >= pos[0, 0]) & (glob[:, 0] <= pos[-1, 0])
    if not inside.any():
        return []
    origin = origin_from_pairs(glob[inside, 1:5], local[inside])
    g = np.asarray(gtgt_rows, float)
    ned = to_local(g[:, 1], g[:, 2], g[:, 3], g[:, 4].astype(int), origin)
    return [(t, *xyz, *v) for t, xyz, v in zip(g[:, 0], ned, g[:, 5:8])]


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


def _tlog_to_log(p, size, autopilot, pos_rows, tgt_rows, tgt_label, cmd_rows, modes, markers, count, cut,
                 skipped) -> FlightLog:
    actual = _track(pos_rows, "LOCAL_POSITION_NED")
    if actual is None:
        if cut is not None:
            raise InputError(f"tlog {p} is truncated at offset {cut} of {size} bytes, before any "
                             f"LOCAL_POSITION_NED")
        raise InputError(f"tlog {p} has no LOCAL_POSITION_NED from the vehicle ({count} records): ask for it "
                         f"with SET_MESSAGE_INTERVAL (id 32) when flying")
    target = _track(tgt_rows, tgt_label)
    commanded = _track(cmd_rows, "SET_POSITION_TARGET_LOCAL_NED (sent by the ground station)")
    log = FlightLog(p, "tlog", autopilot, actual, target or commanded, commanded, modes, markers,
                    info={"bytes": size, "records": count})
    if target is None and commanded is not None:
        log.warnings.append("the vehicle's POSITION_TARGET_LOCAL_NED is not in the tlog: errors are against the "
                            "setpoints the ground station sent")
    if cut is not None:
        log.truncated_at = float(actual.t[-1])
        log.info["truncated"] = f"ends inside a record at offset {cut} of {size}"
    if skipped:
        total = sum(b for _, b in skipped)
        log.info["skipped_bytes"] = total
        log.warnings.append(f"skipped {total} damaged or foreign byte(s) in {len(skipped)} span(s), the first at "
                            f"offset {skipped[0][0]}: the records around them were read")
    return log
