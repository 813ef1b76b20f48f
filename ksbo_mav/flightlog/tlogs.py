"""MAVLink tlog reader (any ground station) -> FlightLog. Records are framed from an mmap by
:class:`~ksbo_mav.flightlog.tlog_frames.TlogScanner` (resynchronising over damaged spans, which are reported) and
only the needed message ids are decoded.

Targets, in order of preference: the vehicle's POSITION_TARGET_LOCAL_NED; its POSITION_TARGET_GLOBAL_INT (what
ArduPilot streams by default) converted to the local frame with the log's own origin (:mod:`.geo`); the
SET_POSITION_TARGET_LOCAL_NED a ground station sent.
"""

from __future__ import annotations

import mmap
from pathlib import Path

import numpy as np

from ksbo_mav.errors import InputError
import ksbo_mav.flightlog.advice as advice
import ksbo_mav.flightlog.geo as geo
from ksbo_mav.flightlog.detect import open_log
from ksbo_mav.flightlog.model import FlightLog, Marker, ModeChange, Track
from ksbo_mav.flightlog.modes import PX4_AUTO_SUB, PX4_MAIN, ardupilot_mode, vehicle_from_type
from ksbo_mav.flightlog.tlog_frames import TlogScanner
from ksbo_mav.mav.trajectory import BOARD_RE, START_RE
from ksbo_task.figure8_ne import Figure8H

_WANT = {0, 22, 32, 33, 49, 84, 85, 87, 148, 245, 253}
_TIMED = {30, 32, 85, 87, 2, 33}  # messages whose time_boot_ms advances the vehicle clock


class _Rows:
    def __init__(self) -> None:
        self.pos, self.tgt, self.cmd, self.glob, self.gtgt = [], [], [], [], []
        self.modes: list[ModeChange] = []
        self.markers: list[Marker] = []
        self.params: list[tuple[float, str, float]] = []
        self.landed: list[tuple[float, int]] = []
        self.origin = None
        self.info: dict = {}
        self.autopilot, self.vehicle_kind = "unknown", "copter"


def read_any_tlog(p: Path, partial: bool = False) -> FlightLog:
    parser = __import__("ksbo_mav.mav.wire", fromlist=["mavlink"]).mavlink.MAVLink(None)
    parser.robust_parsing = False
    fh, size = open_log(p)
    with fh:
        mm = mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ)
        try:
            scan = TlogScanner(mm, size)
            rows = _walk(scan, parser)
        finally:
            mm.close()
    return _to_log(p, size, rows, scan)


def _walk(scan: TlogScanner, parser) -> _Rows:
    r = _Rows()
    vehicle = None
    clock, last_mode, n_skipped = 0.0, None, 0
    for stamp, start, length, msgid, src in scan:
        if len(scan.skipped) != n_skipped:  # a damaged span just ended: its vehicle times
            n_skipped = len(scan.skipped)
            scan.skipped[-1].t_before = clock if clock else None
            r.info.setdefault("_pending", []).append(scan.skipped[-1])
        if msgid not in _WANT and msgid not in _TIMED:
            continue
        try:
            msg = parser.decode(bytearray(scan.buf[start:start + length]))
        except Exception:  # a frame whose fields do not decode: counted as damage by the scanner's CRC already
            continue
        sent = (stamp & 3) == 3
        if msgid == 0:
            if vehicle is None and msg.autopilot != 8 and msg.type != 6 and not sent:
                vehicle = src
                r.autopilot = {3: "ardupilot", 12: "px4"}.get(msg.autopilot, "unknown")
                r.vehicle_kind = vehicle_from_type(msg.type)
            if src == vehicle and not sent:
                armed = bool(msg.base_mode & 128)
                name, tracking = _hb_mode(r.autopilot, r.vehicle_kind, msg.custom_mode)
                if (name, armed) != last_mode:
                    r.modes.append(ModeChange(clock, name if armed else "DISARMED", tracking and armed))
                    last_mode = (name, armed)
            continue
        if msgid == 253:
            text = str(msg.text)
            if text.startswith("ksbo "):
                r.markers.append(Marker(clock, text))
            elif not sent and (b := advice.parse_banner(text)):
                advice.set_version(r.info, *b)
            continue
        if msgid == 84:
            if msg.coordinate_frame == 1 and not msg.type_mask & 0x7:
                r.cmd.append((msg.time_boot_ms * 1e-3, msg.x, msg.y, msg.z, msg.vx, msg.vy, msg.vz))
            continue
        if vehicle is not None and src != vehicle or sent:
            continue
        if msgid == 148:
            name = {"ardupilot": "ArduPilot", "px4": "PX4"}.get(r.autopilot, "autopilot")
            advice.set_version(r.info, name, advice.sw_version(msg.flight_sw_version))
            continue
        if msgid == 49:
            r.origin = (msg.latitude, msg.longitude, msg.altitude)
            continue
        if msgid == 22:
            r.params.append((clock, str(msg.param_id), float(msg.param_value)))
            continue
        if msgid == 245:
            r.landed.append((clock, int(msg.landed_state)))
            continue
        t = msg.time_boot_ms * 1e-3
        clock = max(clock, t)
        for sk in r.info.pop("_pending", []):
            sk.t_after = t
        if msgid == 32:
            r.pos.append((t, msg.x, msg.y, msg.z, msg.vx, msg.vy, msg.vz))
        elif msgid == 85 and msg.coordinate_frame == 1 and not msg.type_mask & 0x7:
            r.tgt.append((t, msg.x, msg.y, msg.z, msg.vx, msg.vy, msg.vz))
        elif msgid == 33:
            r.glob.append((t, msg.lat * 1e-7, msg.lon * 1e-7, msg.alt * 1e-3, msg.relative_alt * 1e-3))
        elif msgid == 87 and not msg.type_mask & 0x7:
            r.gtgt.append((t, msg.lat_int * 1e-7, msg.lon_int * 1e-7, msg.alt, msg.coordinate_frame,
                           msg.vx, msg.vy, msg.vz))
    r.info.pop("_pending", None)
    return r


def _hb_mode(autopilot: str, vehicle_kind: str, custom: int) -> tuple[str, bool]:
    if autopilot == "px4":
        main, sub = (custom >> 16) & 0xFF, (custom >> 24) & 0xFF
        name = PX4_MAIN.get(main, f"MAIN{main}") + (f".{PX4_AUTO_SUB.get(sub, sub)}" if main == 4 else "")
        return name, main == 6 or (main == 4 and sub == 4)
    return ardupilot_mode(vehicle_kind, custom)


def _track(rows, label) -> Track | None:
    if not rows:
        return None
    a = np.array(rows, dtype=float)
    # one sample per stamp (a stream may repeat a time_boot_ms); keep the last
    _, idx = np.unique(a[::-1, 0], return_index=True)
    a = a[::-1][idx]
    return Track(a[:, 0], a[:, 1:4], a[:, 4:7], label)


def _global_targets(r: _Rows, actual: Track) -> tuple[Track | None, str | None]:
    """POSITION_TARGET_GLOBAL_INT in the local frame, or (None, why not)."""
    if not r.gtgt:
        return None, None
    pairs = geo.origin_from_pairs(np.array(r.glob, dtype=float) if r.glob else None, actual)
    if r.origin is not None:
        org = geo.origin_from_message(*r.origin, pairs)
    elif pairs is not None:
        org = pairs
    else:
        return None, ("POSITION_TARGET_GLOBAL_INT is in the log but neither GPS_GLOBAL_ORIGIN nor GLOBAL_POSITION_INT "
                      "alongside LOCAL_POSITION_NED, so it cannot be put in the local frame")
    g = np.array(r.gtgt, dtype=float)
    ned = org.to_ned(g[:, 1], g[:, 2], g[:, 3], g[:, 4])
    ok = np.all(np.isfinite(ned), axis=1)
    if not ok.any():
        return None, "POSITION_TARGET_GLOBAL_INT uses an altitude frame this log gives no reference for"
    rows = np.column_stack([g[ok, 0], ned[ok], g[ok, 5:8]])
    return _track(rows.tolist(), f"POSITION_TARGET_GLOBAL_INT (autopilot target; local frame from {org.source})"), None


def _coverage(a: Track, b: Track, gap: float = 1.0) -> float:
    """Share of ``b``'s sample times that lie within ``gap`` s of a sample of ``a``."""
    j = np.searchsorted(a.t, b.t)  # the samples of a either side of each time of b
    near = np.minimum(np.abs(a.t[np.minimum(j, len(a.t) - 1)] - b.t), np.abs(a.t[np.maximum(j - 1, 0)] - b.t))
    return float(np.mean(near <= gap)) if len(b.t) else 1.0


def _board_figure8s(markers: list[Marker], step_s: float = 0.02) -> list[tuple[float, ...]]:
    """The references of the figure-8s the onboard guard flew (a ``ksbo f8h board`` marker after a start marker),
    sampled every ``step_s``: the targets the tuner never sent, as rows of the sent setpoints."""
    rows: list[tuple[float, ...]] = []
    start = None
    for mk in markers:
        m = START_RE.match(mk.text)
        if m:
            start = (int(m.group(2)), int(m.group(3)) * int(m.group(4)))  # t0 (ms), length (ms)
            continue
        b = BOARD_RE.match(mk.text)
        if b and start is not None:
            a, e, period, up, lead = (float(g) for g in b.groups())
            t = np.arange(0.0, start[1] / 1000.0 + step_s / 2, step_s)
            pos, vel, _ = Figure8H(amp_north=a, amp_east=e, period=period, altitude=up, lead_in=lead).state(t)
            rows += [(start[0] / 1000.0 + ti, *p, *v) for ti, p, v in zip(t.tolist(), pos.tolist(), vel.tolist())]
            start = None
    return rows


def _to_log(p: Path, size: int, r: _Rows, scan: TlogScanner) -> FlightLog:
    actual = _track(r.pos, "LOCAL_POSITION_NED")
    if actual is None:
        if scan.records == 0:
            raise InputError(f"{p} is corrupted or not a flight log: no MAVLink record with a valid CRC in "
                             f"{size} bytes")
        if scan.cut is not None and len(r.pos) == 0 and scan.records < 10:
            raise InputError(f"tlog {p} is truncated at offset {scan.cut} of {size} bytes, before any "
                             f"LOCAL_POSITION_NED")
        raise InputError(f"tlog {p} has no LOCAL_POSITION_NED from the vehicle ({scan.records} records): "
                         + advice.tlog_no_position(r.info, r.autopilot))
    target = _track(r.tgt, "POSITION_TARGET_LOCAL_NED (autopilot target)")
    warnings = []
    board = _board_figure8s(r.markers)
    if board:  # (in time order with the sent holds around them)
        r.cmd = sorted(r.cmd + board)
    commanded = _track(r.cmd, "SET_POSITION_TARGET_LOCAL_NED (sent by the ground station)")
    if target is None:
        target, why = _global_targets(r, actual)
        if why:
            warnings.append(why)
        cover = _coverage(target, commanded) if target is not None and commanded is not None else 1.0
        if cover < 0.5:
            # ArduCopter sends POSITION_TARGET_GLOBAL_INT only while its guided target is a position (take-off,
            # a go-to), not while it follows streamed position+velocity setpoints: the sent ones are the targets.
            warnings.append(f"POSITION_TARGET_GLOBAL_INT covers only {100 * cover:.0f} % of the time the ground "
                            "station sent setpoints; those are used instead")
            target = None
    info = dict(r.info, bytes=size, records=scan.records, param_changes=r.params, vehicle=r.vehicle_kind,
                landed=r.landed)
    log = FlightLog(p, "tlog", r.autopilot, actual, target or commanded, commanded, r.modes, r.markers,
                    warnings=warnings, info=info)
    log.skipped = scan.skipped
    if target is None and commanded is not None:
        log.warnings.append("the vehicle's POSITION_TARGET_LOCAL_NED is not in the tlog: errors are against the "
                            "setpoints the ground station sent" + (" and the figure-8s the onboard guard flew"
                                                                   if board else ""))
    if log.target is None:
        log.info["no_targets"] = advice.tlog_no_targets(r.info, r.autopilot, r.modes)
    if scan.cut is not None:
        log.truncated_at = float(actual.t[-1])
        log.info["truncated"] = f"ends inside a record at offset {scan.cut} of {size}"
    return log
