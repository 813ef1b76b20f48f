"""PX4 ULog reader (:mod:`.ulog_records`, filtered to the topics needed, resynchronising over damage) ->
FlightLog: ``vehicle_local_position`` (actual), ``vehicle_local_position_setpoint`` (the position controller's
target), ``trajectory_setpoint`` (what offboard/auto asked for), ``vehicle_status`` (nav_state, arming)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ksbo_mav.errors import InputError
from ksbo_mav.flightlog.advice import found, set_version, sw_version, ulg_no_setpoint
from ksbo_mav.flightlog.model import FlightLog, Marker, ModeChange, Track
from ksbo_mav.flightlog.modes import PX4_NAV, PX4_TRACKING
from ksbo_mav.flightlog.ulog_records import column, read_ulog

ULG_TOPICS = ["vehicle_local_position", "vehicle_local_position_setpoint", "trajectory_setpoint", "vehicle_status"]


def _xyz(arr: np.ndarray, names: list[str]) -> np.ndarray:
    return np.column_stack([column(arr, k) for k in names])


def _modes(topics: dict) -> list[ModeChange]:
    modes: list[ModeChange] = []
    vs = topics.get("vehicle_status")
    if vs is None or "nav_state" not in vs.dtype.names:
        return modes
    prev = None
    for ts_, nav, arm in zip(vs["timestamp"], vs["nav_state"], vs["arming_state"]):
        key = (int(nav), int(arm) == 2)
        if key != prev:
            name = PX4_NAV.get(key[0], f"NAV{key[0]}") if key[1] else "DISARMED"
            modes.append(ModeChange(float(ts_) * 1e-6, name, key[1] and key[0] in PX4_TRACKING))
            prev = key
    return modes


def read_ulg(p: Path, partial: bool = False) -> FlightLog:
    try:
        buf = p.read_bytes()
    except OSError as exc:
        raise InputError(f"cannot read log {p}: {exc.strerror or exc}") from None
    try:
        u = read_ulog(buf, ULG_TOPICS)
    except InputError as exc:
        raise InputError(f"PX4 ULog {p} is corrupted or truncated in its header: {exc}") from None
    info: dict = {"bytes": len(buf)}
    if "ver_sw_release" in u.info:
        set_version(info, "PX4", sw_version(int(u.info["ver_sw_release"])))
    topics = u.data
    if "vehicle_local_position" not in topics or len(topics["vehicle_local_position"]) == 0:
        if u.cut is not None or u.skipped:
            raise InputError(f"PX4 ULog {p} is truncated or damaged before any vehicle_local_position sample "
                             f"({len(buf)} bytes)")
        raise InputError(f"PX4 ULog {p} has no vehicle_local_position topic ({found(info)} found): the logger's "
                         f"default SDLOG_PROFILE logs it")
    lp = topics["vehicle_local_position"]
    t = lp["timestamp"] * 1e-6
    actual = Track(t, _xyz(lp, ["x", "y", "z"]), _xyz(lp, ["vx", "vy", "vz"]), "vehicle_local_position (EKF2)")
    modes = _modes(topics)
    target = None
    sp = topics.get("vehicle_local_position_setpoint")
    if sp is not None and len(sp):
        target = Track(sp["timestamp"] * 1e-6, _xyz(sp, ["x", "y", "z"]), _xyz(sp, ["vx", "vy", "vz"]),
                       "vehicle_local_position_setpoint (position controller target)")
    commanded = None
    ts = topics.get("trajectory_setpoint")
    if ts is not None and len(ts) and "position" in ts.dtype.names:
        commanded = Track(ts["timestamp"] * 1e-6, _xyz(ts, ["position[0]", "position[1]", "position[2]"]),
                          _xyz(ts, ["velocity[0]", "velocity[1]", "velocity[2]"]), "trajectory_setpoint")
    if target is None:
        raise InputError(f"PX4 ULog {p} has no vehicle_local_position_setpoint topic: "
                         + ulg_no_setpoint(info, [m.name for m in modes]))
    markers = []
    for stamp, text in u.messages:
        if "] " in text and text.startswith("["):
            text = text.split("] ", 1)[1]
        if text.startswith("ksbo "):
            markers.append(Marker(stamp * 1e-6, text.strip()))
    log = FlightLog(p, "ulg", "px4", actual, target, commanded, modes, markers, info=info)
    log.skipped = u.skipped
    if u.cut is not None:
        log.truncated_at = float(t[-1])
        log.info["truncated"] = f"ends inside a message at offset {u.cut} of {len(buf)}"
    return log
