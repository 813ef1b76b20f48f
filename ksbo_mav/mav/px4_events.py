"""PX4's EVENT messages (MAVLink id 410), which say why a failsafe fired or a mode was refused where PX4 main sends
no STATUSTEXT ("No offboard signal"). pymavlink's dialect here has no EVENT, so the frame arrives as an unknown
message with its raw bytes: the payload is id (uint32: component << 24 | a hash of the event's name),
event_time_boot_ms (uint32), sequence (uint16), destination component and system, log_levels (uint8: external
level in the low nibble, MAV_SEVERITY's scale) and 40 bytes of arguments; MAVLink 2 cuts trailing zero bytes.

The texts are those of PX4's own event metadata (``etc/extras/all_events.json.xz`` of PX4 main of 2026-08-13, the
events a tuner meets: failsafes, link and navigation checks, batteries, the geofence); an event id PX4 renames
stays unknown and is said by number. A vehicle serves the full metadata only as component metadata, which the tool
does not fetch.
"""

from __future__ import annotations

import struct
from typing import Any

#: PX4's EVENT message id.
MSG_ID = 410
#: The autopilot's events (component 1 of the metadata): 24-bit id -> text.
TEXTS = {
    11464574: "No offboard signal", 453929: "No manual control input", 5623108: "Manual control lost",
    11331989: "Manual control lost: switching to Hold", 14234660: "GCS connection regained",
    13277401: "Failsafe warning", 12216659: "Low battery level, return advised",
    2474944: "Critical battery level, land now", 51327: "Emergency battery level, land immediately",
    5049764: "Low battery", 2627595: "Critical battery", 11344647: "Emergency battery level",
    2228586: "Remaining flight time low", 13344346: "Battery unhealthy",
    13835193: "Navigation error: No valid position estimate",
    10011251: "Navigation error: No valid global position estimate",
    929525: "Estimated position error is approaching the failsafe threshold",
    9697819: "Horizontal position unstable", 16642797: "Heading estimate invalid",
    13679014: "Offboard requires local position", 12712246: "Offboard requires local velocity",
    16265915: "Offboard requires attitude estimate", 143019: "Geofence violation: approaching or outside geofence",
    4065583: "Geofence violation: exceeding maximum distance to Home",
    13923616: "Geofence violation: exceeding maximum altitude above Home", 377561: "No valid mission available",
    7067274: "Mission start denied! No valid mission", 12805643: "Mission cannot be completed",
    7884377: "RTL switch engaged", 3322590: "Landing at current position",
}


def decode(msg: Any, source: tuple[int, int] | None = None) -> tuple[int, int, str] | None:
    """(24-bit event id, MAV_SEVERITY, text) of an EVENT frame pymavlink left undecoded, sent by ``source``
    (system, component; pymavlink gives an unknown message no source, so it is read from the frame); None for
    anything else. An unknown id reads "PX4 event N"."""
    if msg.get_type() != f"UNKNOWN_{MSG_ID}":
        return None
    raw = bytes(msg.data)
    if len(raw) < 12 or raw[0] != 0xFD or (source is not None and (raw[5], raw[6]) != tuple(source)):
        return None
    payload = (raw[10:10 + raw[1]] + bytes(53))[:53]  # MAVLink 2: byte 1 the payload's length, 10-byte header
    eid, _t_ms, _seq, _comp, _sys, levels = struct.unpack_from("<IIHBBB", payload)
    if eid >> 24 != 1:
        return None  # not the autopilot's own events
    sub = eid & 0xFFFFFF
    return sub, levels & 0x0F, TEXTS.get(sub, f"PX4 event {sub}")
