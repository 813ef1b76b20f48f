"""The MAVLink mission protocol (mission type 0, the flight plan): download, upload, clear, set the current item.

Upload: MISSION_COUNT; the vehicle asks for each item with MISSION_REQUEST_INT (older firmware MISSION_REQUEST) and
gets a MISSION_ITEM_INT; it ends the transfer with MISSION_ACK (type 0 accepted). Download: MISSION_REQUEST_LIST ->
MISSION_COUNT, then MISSION_REQUEST_INT per item -> MISSION_ITEM_INT, and our MISSION_ACK. On a lossy link: a
download asks again for what did not come; an upload that hears nothing sends its last item again (the vehicle
answers with the request it wants next; before any request, MISSION_COUNT again), and an upload whose closing ACK
was lost is confirmed by downloading the mission and comparing it item for item.

ArduPilot keeps its home position as item 0 of the stored mission (it overwrites whatever is uploaded there), so a
mission for ArduPilot (and for the built-in simulator, which numbers like it) starts with a placeholder home item;
PX4's item 0 is the first item flown.

Waypoints are given in the vehicle's local NED frame and sent as MAV_FRAME_GLOBAL_RELATIVE_ALT_INT: latitude and
longitude from the origin of that frame (GPS_GLOBAL_ORIGIN) by a flat earth (millimetres over a mission a few tens
of metres across), altitude above home (HOME_POSITION).
"""

from __future__ import annotations

import math
import json
from dataclasses import asdict, astuple, dataclass
from pathlib import Path

import numpy as np

from ksbo_mav.errors import VehicleError
from ksbo_mav.mav.link import Link
from ksbo_mav.mav.wire import mavlink

R_EARTH = 6_378_137.0  # WGS-84 equatorial radius (m), the flat-earth scale ArduPilot and PX4 use
FRAME_GLOBAL_INT, FRAME_GLOBAL_RELATIVE_ALT_INT = 5, 6
CMD_NAV_WAYPOINT = 16
MISSION_TYPE = 0  # MAV_MISSION_TYPE_MISSION
ACK_ACCEPTED = 0
ACK_TEXT = {1: "error", 2: "unsupported frame", 3: "unsupported command", 4: "no space", 5: "invalid",
            6: "invalid param1", 7: "invalid param2", 8: "invalid param3", 9: "invalid param4", 10: "invalid x",
            11: "invalid y", 12: "invalid z", 13: "out of sequence", 14: "denied", 15: "operation cancelled"}


def save_items(path: Path, items: list["MissionItem"]) -> None:
    """Keep a mission on disk (atomically, durably): the user's stored mission while a flight of ours replaces it."""
    from ksbo_mav.jsonio import fsync_write

    fsync_write(path, json.dumps([asdict(i) for i in items]))


def load_items(path: Path) -> list["MissionItem"]:
    return [MissionItem(**doc) for doc in json.loads(path.read_text())]


@dataclass(frozen=True)
class MissionItem:
    """One MISSION_ITEM_INT's content (without the addressing): what a download returns and an upload sends."""

    frame: int
    command: int
    current: int
    autocontinue: int
    param1: float
    param2: float
    param3: float
    param4: float
    x: int
    y: int
    z: float

    @classmethod
    def from_msg(cls, m) -> "MissionItem":
        return cls(int(m.frame), int(m.command), int(m.current), int(m.autocontinue), float(m.param1),
                   float(m.param2), float(m.param3), float(m.param4), int(m.x), int(m.y), float(m.z))


@dataclass(frozen=True)
class GlobalFrame:
    """Where the local NED frame sits on the earth: its origin (deg, deg, m AMSL) and home's altitude (m AMSL)."""

    lat0: float
    lon0: float
    alt0: float
    home_alt: float

    def waypoint(self, ned: np.ndarray, *, yaw: float = math.nan, accept_m: float = 0.0) -> MissionItem:
        """A NAV_WAYPOINT at local NED ``ned`` (3,), altitude relative to home, no hold, ``accept_m`` acceptance
        radius (0: the autopilot's own)."""
        n, e, d = (float(v) for v in ned)
        lat = self.lat0 + math.degrees(n / R_EARTH)
        lon = self.lon0 + math.degrees(e / (R_EARTH * math.cos(math.radians(self.lat0))))
        rel = self.alt0 - d - self.home_alt
        return MissionItem(FRAME_GLOBAL_RELATIVE_ALT_INT, CMD_NAV_WAYPOINT, 0, 1, 0.0, float(accept_m), 0.0, yaw,
                           int(round(lat * 1e7)), int(round(lon * 1e7)), rel)

    def home_item(self) -> MissionItem:
        """ArduPilot's item 0: home (it replaces it with its own)."""
        return MissionItem(FRAME_GLOBAL_INT, CMD_NAV_WAYPOINT, 0, 1, 0.0, 0.0, 0.0, 0.0,
                           int(round(self.lat0 * 1e7)), int(round(self.lon0 * 1e7)), self.home_alt)


class MissionTransfer:
    """Mission protocol of one vehicle over ``link``; every wait is a link wait (the hold keepalive goes on)."""

    def __init__(self, link: Link, timeout_s: float = 1.5, attempts: int = 6) -> None:
        self.link, self.timeout_s, self.attempts = link, timeout_s, attempts

    def _addr(self) -> tuple[int, int]:
        return self.link.target_system, self.link.target_component

    def _from_vehicle(self, kind: str, pred=lambda m: True):
        link = self.link
        return lambda m: m.get_type() == kind and link.is_vehicle(m) and pred(m)

    def global_frame(self) -> GlobalFrame:
        """The local frame's origin (GPS_GLOBAL_ORIGIN) and home's altitude (HOME_POSITION), asked for by
        REQUEST_MESSAGE; :class:`VehicleError` when the vehicle has neither (no GPS fix / EKF origin yet)."""
        got = {}
        for name, mid in (("GPS_GLOBAL_ORIGIN", mavlink.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN),
                          ("HOME_POSITION", mavlink.MAVLINK_MSG_ID_HOME_POSITION)):
            for attempt in range(self.attempts):
                self.link.send(self.link.mav.command_long_encode(*self._addr(), mavlink.MAV_CMD_REQUEST_MESSAGE,
                                                                 attempt, mid, 0, 0, 0, 0, 0, 0))
                msg = self.link.wait(self._from_vehicle(name), self.timeout_s)
                if msg is not None:
                    got[name] = msg
                    break
            else:
                raise VehicleError(f"the vehicle did not send {name}: no global position origin for a mission")
        o, h = got["GPS_GLOBAL_ORIGIN"], got["HOME_POSITION"]
        return GlobalFrame(o.latitude / 1e7, o.longitude / 1e7, o.altitude / 1000.0, h.altitude / 1000.0)

    # --- download ------------------------------------------------------------------------------------------
    def download(self) -> list[MissionItem]:
        """The stored mission, every item (ArduPilot's home item 0 included)."""
        link = self.link
        count = None
        for _ in range(self.attempts):
            link.send(link.mav.mission_request_list_encode(*self._addr(), MISSION_TYPE))
            msg = link.wait(self._from_vehicle("MISSION_COUNT", lambda m: getattr(m, "mission_type", 0) == 0),
                            self.timeout_s)
            if msg is not None:
                count = int(msg.count)
                break
        if count is None:
            raise VehicleError("the vehicle did not answer MISSION_REQUEST_LIST")
        items = []
        for seq in range(count):
            for _ in range(self.attempts):
                link.send(link.mav.mission_request_int_encode(*self._addr(), seq, MISSION_TYPE))
                msg = link.wait(self._from_vehicle("MISSION_ITEM_INT", lambda m, s=seq: m.seq == s), self.timeout_s)
                if msg is not None:
                    items.append(MissionItem.from_msg(msg))
                    break
            else:
                raise VehicleError(f"the vehicle did not send mission item {seq} of {count}")
        link.send(link.mav.mission_ack_encode(*self._addr(), ACK_ACCEPTED, MISSION_TYPE))
        return items

    # --- upload --------------------------------------------------------------------------------------------
    def upload(self, items: list[MissionItem]) -> None:
        """Replace the stored mission by ``items`` (verified by the vehicle's MISSION_ACK); an empty list clears."""
        if not items:
            self.clear()
            return
        link = self.link
        n = len(items)
        requests = ("MISSION_REQUEST_INT", "MISSION_REQUEST")

        def answer(m) -> bool:
            return link.is_vehicle(m) and (m.get_type() in requests or m.get_type() == "MISSION_ACK") \
                and getattr(m, "mission_type", 0) == 0

        def send_item(seq: int) -> None:
            link.send(link.mav.mission_item_int_encode(*self._addr(), seq, *astuple(items[seq]), MISSION_TYPE))

        link.send(link.mav.mission_count_encode(*self._addr(), n, MISSION_TYPE))
        silent, last = 0, None
        while True:
            msg = link.wait(answer, self.timeout_s)
            if msg is None:
                silent += 1
                if silent >= self.attempts:
                    if last == n - 1 and self._stored_equals(items):  # only the closing ACK was lost
                        return
                    raise VehicleError(f"mission upload of {n} items: the vehicle stopped asking for items")
                if last is None:
                    link.send(link.mav.mission_count_encode(*self._addr(), n, MISSION_TYPE))
                else:
                    send_item(last)
                continue
            silent = 0
            if msg.get_type() == "MISSION_ACK":
                if int(msg.type) != ACK_ACCEPTED:
                    raise VehicleError(f"mission upload refused by the vehicle: "
                                       f"{ACK_TEXT.get(int(msg.type), msg.type)}")
                return
            seq = int(msg.seq)
            if not 0 <= seq < n:
                raise VehicleError(f"mission upload: the vehicle asked for item {seq} of {n}")
            send_item(seq)
            last = seq

    def _stored_equals(self, items: list[MissionItem]) -> bool:
        """The vehicle's stored mission is ``items`` (home, item 0 on ArduPilot, may differ)."""
        try:
            got = self.download()
        except VehicleError:
            return False

        def key(i: MissionItem) -> tuple:
            return (i.frame, i.command, i.x, i.y, round(i.z, 3))
        return len(got) == len(items) and [key(i) for i in got[1:]] == [key(i) for i in items[1:]]

    def clear(self) -> None:
        """MISSION_CLEAR_ALL, acknowledged."""
        link = self.link
        for _ in range(self.attempts):
            link.send(link.mav.mission_clear_all_encode(*self._addr(), MISSION_TYPE))
            ack = link.wait(self._from_vehicle("MISSION_ACK"), self.timeout_s)
            if ack is not None:
                if int(ack.type) != ACK_ACCEPTED:
                    raise VehicleError(f"mission clear refused: {ACK_TEXT.get(int(ack.type), ack.type)}")
                return
        raise VehicleError("the vehicle did not acknowledge MISSION_CLEAR_ALL")

    def set_current(self, seq: int) -> None:
        """MISSION_SET_CURRENT, confirmed by the vehicle's MISSION_CURRENT."""
        link = self.link
        for _ in range(self.attempts):
            link.send(link.mav.mission_set_current_encode(*self._addr(), seq))
            if link.wait(self._from_vehicle("MISSION_CURRENT", lambda m: int(m.seq) == seq), self.timeout_s):
                return
        raise VehicleError(f"the vehicle did not make mission item {seq} current")
