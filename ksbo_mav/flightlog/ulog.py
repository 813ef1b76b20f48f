"""PX4 ULog reader (pyulog, filtered to the topics needed) -> FlightLog."""

from __future__ import annotations

import contextlib
import io
from pathlib import Path
from typing import Any

import numpy as np

from ksbo_mav.errors import InputError
from ksbo_mav.flightlog.model import FlightLog, Marker, ModeChange, Track
from ksbo_mav.flightlog.modes import PX4_NAV, PX4_TRACKING

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


def _pyulog_said(buf: io.StringIO) -> str:
    """pyulog's own printed warnings, first few, as a suffix for our message ('' when it said nothing)."""
    lines = [ln.strip() for ln in buf.getvalue().splitlines() if ln.strip()]
    if not lines:
        return ""
    more = f" (+{len(lines) - 3} more)" if len(lines) > 3 else ""
    return " (pyulog: " + "; ".join(lines[:3]) + more + ")"


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
    said = io.StringIO()  # pyulog print()s its warnings to stdout; `score` keeps stdout for the result (JSON)
    try:
        with contextlib.redirect_stdout(said):
            ulog = ULog(wrap, ULG_TOPICS, disable_str_exceptions=True)
    except Exception as exc:  # pyulog raises ULogException, struct.error, IndexError... on a damaged header
        raise InputError(f"PX4 ULog {p} is corrupted or truncated in its header/definitions: {exc}"
                         f"{_pyulog_said(said)}") from None
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
                             f"score what could be read{_pyulog_said(said)}")
        log.warnings.append(f"pyulog reported corrupted data and skipped it{_pyulog_said(said)}")
    if wrap.short_at is not None:
        log.truncated_at = float(t[-1])
        log.info["truncated"] = f"ends inside a message at offset {wrap.short_at} of {size}"
    return log
