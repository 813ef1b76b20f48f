"""The simulated autopilot's stored mission and its side of the MAVLink mission protocol (mission type 0).

Upload: MISSION_COUNT -> MISSION_REQUEST_INT for each item in turn -> MISSION_ITEM_INT (or MISSION_ITEM) ->
MISSION_ACK accepted; an upload that stalls is re-requested when the ground station sends its MISSION_COUNT again.
Download: MISSION_REQUEST_LIST -> MISSION_COUNT; MISSION_REQUEST(_INT) -> MISSION_ITEM_INT. MISSION_CLEAR_ALL ->
MISSION_ACK. MISSION_SET_CURRENT -> MISSION_CURRENT.

Like ArduPilot, a personality with ``mission_home_item`` keeps home as item 0 (whatever is uploaded there) and
flies from item 1; PX4 flies from item 0. The simulator's home is fixed (ArduPilot SITL's CMAC field) and is the
origin of its local NED frame, on the ground (:data:`HOME`); global waypoints map to NED by a flat earth.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: (latitude deg, longitude deg, altitude m AMSL) of home = the local frame's origin.
HOME = (-35.363261, 149.165230, 584.0)
R_EARTH = 6_378_137.0
CMD_NAV_WAYPOINT = 16
ACCEPTED, UNSUPPORTED_FRAME, INVALID_SEQUENCE = 0, 2, 13
_REL_FRAMES, _AMSL_FRAMES = (3, 6), (0, 5)


@dataclass(frozen=True)
class Item:
    frame: int
    command: int
    autocontinue: int
    params: tuple[float, float, float, float]
    x: int  # latitude * 1e7
    y: int  # longitude * 1e7
    z: float

    def ned(self) -> np.ndarray:
        """(3,) local NED of a global item (MISSION_ITEM_INT x/y scaled by 1e7)."""
        lat0, lon0, alt0 = HOME
        n = math.radians(self.x / 1e7 - lat0) * R_EARTH
        e = math.radians(self.y / 1e7 - lon0) * R_EARTH * math.cos(math.radians(lat0))
        d = -self.z if self.frame in _REL_FRAMES else alt0 - self.z
        return np.array([n, e, d])


def home_item() -> Item:
    lat0, lon0, alt0 = HOME
    return Item(0, CMD_NAV_WAYPOINT, 1, (0.0, 0.0, 0.0, 0.0), int(round(lat0 * 1e7)), int(round(lon0 * 1e7)), alt0)


class MissionStore:
    """Mission items and the transfer state; ``send`` is the server's MAVLink object (messages go out at once)."""

    def __init__(self, mav, home_item_first: bool, now=lambda: 0.0) -> None:
        self.mav = mav
        self.now = now  # simulated seconds
        self.stored_at = -1e9
        self.home_first = home_item_first
        self.items: list[Item] = [home_item()] if home_item_first else []
        self.current = self.first
        self._incoming: list[Item] | None = None
        self._expected = 0
        self._peer = (0, 0)

    @property
    def first(self) -> int:
        return 1 if self.home_first else 0

    def legs(self) -> list[tuple[int, np.ndarray]]:
        """(seq, NED) of the waypoints to fly from the current item on (other commands are skipped)."""
        return [(i, it.ned()) for i, it in enumerate(self.items)
                if i >= max(self.current, self.first) and it.command == CMD_NAV_WAYPOINT]

    def handle(self, msg) -> None:
        kind = msg.get_type()
        src = (msg.get_srcSystem(), msg.get_srcComponent())
        if getattr(msg, "mission_type", 0) != 0:
            self.mav.mission_ack_send(*src, 1, msg.mission_type)  # only the flight plan is supported
            return
        if kind == "MISSION_COUNT":
            self._incoming, self._expected, self._peer = [], 0, src
            if msg.count == 0:
                self._store([])
                return
            self._count = int(msg.count)
            self.mav.mission_request_int_send(*src, 0, 0)
        elif kind in ("MISSION_ITEM_INT", "MISSION_ITEM") and self._incoming is not None:
            if msg.seq != self._expected:
                self.mav.mission_request_int_send(*src, self._expected, 0)  # out of order: ask again
                return
            scale = 1 if kind == "MISSION_ITEM_INT" else 1e7
            if msg.frame not in _REL_FRAMES + _AMSL_FRAMES and msg.command == CMD_NAV_WAYPOINT:
                self._incoming = None
                self.mav.mission_ack_send(*src, UNSUPPORTED_FRAME, 0)
                return
            self._incoming.append(Item(int(msg.frame), int(msg.command), int(msg.autocontinue),
                                       (msg.param1, msg.param2, msg.param3, msg.param4),
                                       int(round(msg.x * scale)), int(round(msg.y * scale)), float(msg.z)))
            self._expected += 1
            if self._expected < self._count:
                self.mav.mission_request_int_send(*src, self._expected, 0)
            else:
                self._store(self._incoming)
        elif kind == "MISSION_REQUEST_LIST":
            self.mav.mission_count_send(*src, len(self.items), 0)
        elif kind in ("MISSION_REQUEST_INT", "MISSION_REQUEST"):
            if 0 <= msg.seq < len(self.items):
                it = self.items[msg.seq]
                self.mav.mission_item_int_send(*src, msg.seq, it.frame, it.command, int(msg.seq == self.current),
                                               it.autocontinue, *it.params, it.x, it.y, it.z, 0)
            else:
                self.mav.mission_ack_send(*src, INVALID_SEQUENCE, 0)
        elif kind == "MISSION_CLEAR_ALL":
            self.items = [home_item()] if self.home_first else []
            self.current = self.first
            self.mav.mission_ack_send(*src, ACCEPTED, 0)
        elif kind == "MISSION_SET_CURRENT":
            if self.first <= msg.seq < len(self.items):
                self.current = int(msg.seq)
            self.mav.mission_current_send(self.current, len(self.items))

    def _store(self, items: list[Item]) -> None:
        if self.home_first:
            items = [home_item()] + items[1:]  # home stays item 0, as ArduPilot keeps it
        self.items, self.current, self._incoming = items, self.first, None
        self.stored_at = self.now()
        self.mav.mission_ack_send(*self._peer, ACCEPTED, 0)
