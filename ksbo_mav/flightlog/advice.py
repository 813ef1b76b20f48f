"""The autopilot version a log was written by, and what to change *on that version* when the log lacks what
scoring needs (one line: version found, messages needed, the setting that records or streams them)."""

from __future__ import annotations

import re
from typing import Any

_BANNER = re.compile(r"(ArduCopter|ArduPlane|ArduRover|ArduSub|APM:Copter|APM:Plane|APM:Rover|Rover|Sub|Blimp)"
                     r"\s+V?(\d+)\.(\d+)(?:\.(\d+))?")
PX4_POSITION_NAV = {"POSCTL", "AUTO_MISSION", "AUTO_LOITER", "AUTO_RTL", "OFFBOARD", "AUTO_TAKEOFF", "AUTO_LAND",
                    "POSITION_SLOW", "ORBIT", "AUTO_FOLLOW_TARGET", "AUTO_PRECLAND", "DESCEND"}


def parse_banner(text: str) -> tuple[str, tuple[int, int, int]] | None:
    """("ArduCopter", (3, 4, 6)) from a firmware banner such as "APM:Copter V3.4.6 (…)"."""
    m = _BANNER.search(text)
    if not m:
        return None
    name = m.group(1).replace("APM:", "Ardu")
    name = {"Rover": "ArduRover", "Sub": "ArduSub"}.get(name, name)
    return name, (int(m.group(2)), int(m.group(3)), int(m.group(4) or 0))


def sw_version(u32: int) -> tuple[int, int, int]:
    """(major, minor, patch) of ArduPilot's flight_sw_version / PX4's ver_sw_release (major<<24|minor<<16|patch<<8)."""
    return (u32 >> 24) & 0xFF, (u32 >> 16) & 0xFF, (u32 >> 8) & 0xFF


def set_version(info: dict[str, Any], name: str, ver: tuple[int, int, int]) -> None:
    if "version" not in info and ver != (0, 0, 0):
        info["version"] = f"{name} {ver[0]}.{ver[1]}.{ver[2]}"
        info["version_tuple"] = ver


def found(info: dict[str, Any]) -> str:
    return info.get("version") or "an unknown version"


def tlog_no_position(info: dict[str, Any], autopilot: str) -> str:
    ver = info.get("version_tuple")
    if autopilot == "ardupilot" and ver and ver[:2] < (3, 6):
        return (f"{found(info)} found: LOCAL_POSITION_NED (id 32) is needed; this version has no "
                f"SET_MESSAGE_INTERVAL, set the stream rate SRn_POSITION (n = the telemetry port) to 5 Hz or more")
    if autopilot == "ardupilot":
        return (f"{found(info)} found: LOCAL_POSITION_NED (id 32) is needed; request it with "
                f"SET_MESSAGE_INTERVAL (id 32) or raise SRn_POSITION")
    if autopilot == "px4":
        return (f"{found(info)} found: LOCAL_POSITION_NED (id 32) is needed; request it with SET_MESSAGE_INTERVAL "
                f"or use MAVLink mode 'onboard'/'normal' on the telemetry port (MAV_n_MODE)")
    return "LOCAL_POSITION_NED (id 32) is needed and the log names no autopilot (no HEARTBEAT from a vehicle)"


def tlog_no_targets(info: dict[str, Any], autopilot: str, modes: list) -> str:
    tracked = [m.name for m in modes if m.tracking]
    if not tracked:
        seen = ", ".join(dict.fromkeys(m.name for m in modes)) or "none"
        return (f"{found(info)} found: no guided/auto/offboard mode was flown (modes: {seen}); the autopilot "
                f"publishes position targets only there")
    ver = info.get("version_tuple")
    if autopilot == "ardupilot" and ver and ver[:2] < (3, 6):
        how = "set the stream rate SRn_EXT_STAT to 5 Hz or more (this version has no SET_MESSAGE_INTERVAL)"
    elif autopilot == "ardupilot":
        how = "request POSITION_TARGET_GLOBAL_INT (id 87) with SET_MESSAGE_INTERVAL or raise SRn_EXT_STAT"
    else:
        how = "request POSITION_TARGET_LOCAL_NED (id 85) with SET_MESSAGE_INTERVAL"
    return (f"{found(info)} found: {', '.join(dict.fromkeys(tracked))} was flown but the log has no "
            f"POSITION_TARGET_LOCAL_NED / POSITION_TARGET_GLOBAL_INT nor setpoints sent; {how}")


def bin_no_position(info: dict[str, Any], params: dict[str, float], modes: list) -> str:
    ver = info.get("version_tuple")
    if ver and ver[:2] < (3, 7):
        need = "NTUN and CTUN"
    elif ver and ver[:2] < (4, 2):
        need = "PSC and CTUN (or PSCZ)"
    else:
        need = "PSCN, PSCE, PSCD"
    bitmask = params.get("LOG_BITMASK")
    tracked = [m.name for m in modes if m.tracking]
    head = f"{found(info)} found: the position controller's messages ({need}) are needed"
    if bitmask is not None and not int(bitmask) & 32:
        return (f"{head}; they are logged under LOG_BITMASK bit 5 (NTUN, value 32), which is off: set "
                f"LOG_BITMASK = {int(bitmask) | 32} and fly again")
    if not tracked:
        seen = ", ".join(dict.fromkeys(m.name for m in modes)) or "none logged"
        return f"{head}; no guided/auto mode was flown (modes: {seen}), and they are only logged there"
    if bitmask is None:
        return f"{head}; no PARM LOG_BITMASK in the log: they are logged under LOG_BITMASK bit 5 (NTUN, value 32)"
    return (f"{head}; LOG_BITMASK = {int(bitmask)} has bit 5 (NTUN) and {', '.join(dict.fromkeys(tracked))} was "
            f"flown, yet none were logged (a log started after the flight, or a firmware that logs them elsewhere)")


def ulg_no_setpoint(info: dict[str, Any], nav_names: list[str]) -> str:
    seen = list(dict.fromkeys(n for n in nav_names if n != "DISARMED"))
    if seen and not set(seen) & PX4_POSITION_NAV:
        return (f"{found(info)} found: flown only in {', '.join(seen)}; PX4 publishes "
                f"vehicle_local_position_setpoint only in position-controlled modes (POSCTL, AUTO, OFFBOARD), "
                f"whatever SDLOG_PROFILE is: fly one of those")
    return (f"{found(info)} found: vehicle_local_position_setpoint is needed and was not logged; the default "
            f"SDLOG_PROFILE logs it")
