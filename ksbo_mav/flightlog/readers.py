"""Format readers -> :class:`~ksbo_mav.flightlog.model.FlightLog`.

* ``.BIN`` (ArduCopter): actual and target position from the position controller's own log, PSCN/PSCE/PSCD
  (``PN``/``TPN``..., metres, NED, 10 Hz under ``LOG_BITMASK`` bit 5 NTUN), the guided setpoints it received as
  GUIP (north, east, *up*), modes from MODE, trial markers from MSG (ArduPilot logs every STATUSTEXT a ground
  station sends as ``SRC=sys/comp:text``, or ``GCS:text`` when the sender's system id is ``MAV_GCS_SYSID``, as
  the tuner's is while its onboard guard runs).
* ``.ulg`` (PX4): ``vehicle_local_position`` (actual), ``vehicle_local_position_setpoint`` (the position
  controller's target), ``trajectory_setpoint`` (what offboard/auto asked for), ``vehicle_status.nav_state`` for
  modes (armed only); read by .ulog_records, filtered to those topics.
* ``.tlog`` (any ground station): the vehicle's LOCAL_POSITION_NED; its POSITION_TARGET_LOCAL_NED when streamed
  (the autopilot's target), else the SET_POSITION_TARGET_LOCAL_NED a ground station sent; modes from the
  vehicle's HEARTBEATs; ksbo trial markers from STATUSTEXT. Streamed: records are framed from an mmap and only
  the needed message ids are decoded.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ksbo_mav.errors import InputError
from ksbo_mav.flightlog.advice import bin_no_position, parse_banner, set_version
from ksbo_mav.flightlog.bin_sources import WANTED as SOURCES
from ksbo_mav.flightlog.bin_sources import position_tracks
from ksbo_mav.flightlog.dataflash import read_dataflash
from ksbo_mav.flightlog.detect import detect_format
from ksbo_mav.flightlog.model import FlightLog, Marker, ModeChange, Outputs, Track
from ksbo_mav.flightlog.modes import COPTER_MODES, COPTER_TRACKING, ardupilot_mode, vehicle_from_text  # noqa: F401
from ksbo_mav.flightlog.tlogs import read_any_tlog
from ksbo_mav.flightlog.ulog import read_ulg

# Copter LOG_BITMASK bits that the messages needed here depend on.
NTUN_BIT = 5


def read_log(path: str | Path, partial: bool = False) -> FlightLog:
    """Read any supported log (format detected by content)."""
    fmt = detect_format(path)
    try:
        return {"bin": read_bin, "ulg": read_ulg, "tlog": read_any_tlog}[fmt](Path(path), partial=partial)
    except InputError:
        raise
    except (ValueError, IndexError, KeyError, TypeError, OverflowError) as exc:  # damage in a definition itself
        raise InputError(f"{path} is damaged where the reader cannot skip it (a format definition): "
                         f"{type(exc).__name__}: {exc}") from None


# --- ArduPilot DataFlash ------------------------------------------------------------------------------------------
BIN_WANTED = {"GUIP", "MODE", "MSG", "PARM", "ARM", "EV", "RCOU"} | SOURCES
EV_ARMED, EV_DISARMED = 10, 11  # DataFlash EV ids (logs without ARM messages)


def bin_modes(c, vehicle: str) -> list[ModeChange]:
    """Mode changes with the arming state folded in: a mode chosen while disarmed is DISARMED (not tracking) until
    the vehicle arms; every arm and disarm (ARM, or EV in older logs) is seen."""
    events = []
    for row in c.data.get("MODE", ()):
        events.append((float(row["TimeUS"]) * 1e-6, "mode", int(row["ModeNum"])))
    for row in c.data.get("ARM", ()):
        events.append((float(row["TimeUS"]) * 1e-6, "arm", int(row["ArmState"]) != 0))
    if "ARM" not in c.data:
        for row in c.data.get("EV", ()):
            if int(row["Id"]) in (EV_ARMED, EV_DISARMED):
                events.append((float(row["TimeUS"]) * 1e-6, "arm", int(row["Id"]) == EV_ARMED))
    events.sort(key=lambda e: e[0])
    arm_known = any(kind == "arm" for _, kind, _ in events)
    first_arm = next((v for _, kind, v in events if kind == "arm"), None)
    armed = not arm_known or first_arm is False  # before the first arm record: the opposite of what it records
    mode, out, last = None, [], None
    for t, kind, v in events:
        if kind == "mode":
            mode = v
        else:
            armed = v
        if mode is None:
            continue
        name, tracking = ardupilot_mode(vehicle, mode)
        key = (name, armed)
        if key != last:
            out.append(ModeChange(t, name if armed else "DISARMED", tracking and armed))
            last = key
    return out


def read_bin(p: Path, partial: bool = False) -> FlightLog:
    c = read_dataflash(p, BIN_WANTED)
    banner = _banner(c)
    vehicle = vehicle_from_text(banner) or "copter"
    params = _bin_params(c)
    info = {"bytes": c.size, "messages": c.messages, "params": params, "end_offset": c.end, "vehicle": vehicle}
    if (b := parse_banner(banner)) is not None:
        set_version(info, *b)
    tracks = position_tracks(c)
    if tracks is None:
        if c.messages < 100 and (c.truncated or c.extra["skipped"]):
            raise InputError(f"DataFlash log {p} is truncated or damaged: {c.messages} message(s) readable of "
                             f"{c.size} bytes, none from the position controller")
        raise InputError(f"DataFlash log {p} has no position-controller messages: "
                         + bin_no_position(info, params, bin_modes(c, vehicle)))
    actual, target, used = tracks
    t = actual.t
    n = len(t)
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
    modes = bin_modes(c, vehicle)
    markers = []
    if "MSG" in c.data:
        for row in c.data["MSG"]:
            text = row["Message"].split(b"\0", 1)[0].decode("ascii", "replace")
            if text.startswith("GCS:") or (":" in text and text.startswith("SRC=")):
                text = text.split(":", 1)[1]
            if text.startswith("ksbo "):
                markers.append(Marker(float(row["TimeUS"]) * 1e-6, text))
    log = FlightLog(p, "bin", "ardupilot", actual, target, commanded, modes, markers,
                    info={**info, "pscn": n, "source": used,
                          "param_changes": [(float(r["TimeUS"]) * 1e-6, r["Name"].split(b"\0", 1)[0].decode(
                              "ascii", "replace"), float(r["Value"])) for r in c.data.get("PARM", ())],
                          "end_offset": c.end})
    log.skipped = c.extra["skipped"]
    log.outputs = _bin_outputs(c)
    if c.truncated:
        log.truncated_at = float(t[-1]) if n else None
        log.info["truncated"] = f"ends inside a message at offset {c.end} of {c.size}"
    return log


def _bin_outputs(c) -> Outputs | None:
    """RCOU's channels C1..C8 (µs) in time order, or None when the log has none (LOG_BITMASK bit 10, RCOUT)."""
    d = c.data.get("RCOU")
    cols = [f"C{i}" for i in range(1, 9) if d is not None and f"C{i}" in d.dtype.names]
    if d is None or len(d) < 2 or not cols:
        return None
    t = d["TimeUS"].astype(float) * 1e-6
    order = np.argsort(t, kind="stable")
    return Outputs(t[order], np.column_stack([c.column("RCOU", k)[order] for k in cols]).astype(float), "RCOU")


def _banner(c) -> str:
    for row in c.data.get("MSG", ()):
        text = row["Message"].split(b"\0", 1)[0].decode("ascii", "replace")
        if vehicle_from_text(text):
            return text
    return ""


def _bin_params(c) -> dict[str, float]:
    out: dict[str, float] = {}
    if "PARM" in c.data:
        for row in c.data["PARM"]:
            out[row["Name"].split(b"\0", 1)[0].decode("ascii", "replace")] = float(row["Value"])
    return out
