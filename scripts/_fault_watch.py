"""The fault matrix's second MAVLink connection (scripts/bench_fault_matrix.py): what the vehicle does while the tuner
is cut off or dead, read on a port the tuner does not use (ArduCopter SITL's second TCP port, system id 250, not the
one the onboard guard watches)."""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field

os.environ.setdefault("MAVLINK20", "1")

MODES = {0: "STABILIZE", 3: "AUTO", 4: "GUIDED", 5: "LOITER", 6: "RTL", 9: "LAND", 16: "POSHOLD", 17: "BRAKE"}


@dataclass
class Watch:
    """Clock, mode, armed, height, the guard's state and its texts, as the vehicle sends them."""

    device: str
    vehicle_ms: int = 0
    mode: int = -1
    armed: bool | None = None
    height: float | None = None
    guard: float | None = None  # KSG_ALIVE: 0 idle, 1 armed, 2 tripped
    texts: list[str] = field(default_factory=list)
    events: list[tuple[int, str]] = field(default_factory=list)  # (vehicle ms, what changed)

    def __post_init__(self) -> None:
        from pymavlink import mavutil

        self.conn = mavutil.mavlink_connection(self.device, source_system=250, source_component=190,
                                               autoreconnect=True)
        assert self.conn.wait_heartbeat(timeout=30) is not None, f"no heartbeat on {self.device}"
        for msg_id, hz in ((2, 10), (33, 4)):  # SYSTEM_TIME, GLOBAL_POSITION_INT on this link only
            self.conn.mav.command_long_send(1, 1, 511, 0, msg_id, 1e6 / hz, 0, 0, 0, 0, 0)

    def _take(self, m) -> None:
        if m.get_srcSystem() != 1:
            return
        kind = m.get_type()
        if hasattr(m, "time_boot_ms"):
            self.vehicle_ms = max(self.vehicle_ms, int(m.time_boot_ms))
        if kind == "HEARTBEAT" and m.get_srcComponent() == 1:
            mode, armed = int(m.custom_mode), bool(m.base_mode & 128)
            if (mode, armed) != (self.mode, self.armed):
                self.events.append((self.vehicle_ms, f"{MODES.get(mode, mode)} {'armed' if armed else 'disarmed'}"))
            self.mode, self.armed = mode, armed
        elif kind == "GLOBAL_POSITION_INT":
            self.height = m.relative_alt / 1000.0
        elif kind == "NAMED_VALUE_FLOAT" and m.name == "KSG_ALIVE":
            if m.value != self.guard:
                state = ['idle', 'armed', 'tripped', '?'][min(3, int(m.value))]
                self.events.append((self.vehicle_ms, f"guard {state}"))
            self.guard = float(m.value)
        elif kind == "STATUSTEXT":
            text = str(m.text)
            if text.startswith("KSG:") or "Land" in text or "Disarm" in text:
                self.texts.append(text)
                self.events.append((self.vehicle_ms, text))

    def pump(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            m = self.conn.recv_match(blocking=True, timeout=0.05)
            if m is not None:
                self._take(m)

    def until(self, predicate, wall_s: float) -> bool:
        end = time.monotonic() + wall_s
        while time.monotonic() < end:
            if predicate():
                return True
            self.pump(0.05)
        return predicate()

    def params(self, names: list[str], tries: int = 3) -> dict[str, float]:
        """Fresh reads (PARAM_REQUEST_READ), the ones answered."""
        out: dict[str, float] = {}
        for _ in range(tries):
            for name in names:
                if name not in out:
                    self.conn.mav.param_request_read_send(1, 1, name.encode(), -1)
            end = time.monotonic() + 0.6
            while time.monotonic() < end and len(out) < len(names):
                m = self.conn.recv_match(blocking=True, timeout=0.05)
                if m is None:
                    continue
                self._take(m)
                if m.get_type() == "PARAM_VALUE" and m.param_id in names:
                    out[m.param_id] = float(m.param_value)
            if len(out) == len(names):
                break
        return out

    def mode_name(self) -> str:
        return MODES.get(self.mode, str(self.mode))

    def land(self, wall_s: float = 90.0) -> bool:
        """LAND until disarmed (the next case starts on the ground); whether it disarmed."""
        self.pump(0.3)
        if self.armed:
            self.conn.mav.command_long_send(1, 1, 176, 0, 1, 9, 0, 0, 0, 0, 0)
        return self.until(lambda: self.armed is False, wall_s)

    def close(self) -> None:
        self.conn.close()
