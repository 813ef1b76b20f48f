"""A second MAVLink connection that reads what a vehicle does while a tuner flies it (or is cut off, or dead): its
clock, mode, arming, height above home, the onboard guard's state and texts, and fresh parameter reads. Its system
id (250) is not the one the onboard guard watches, so it is no ground station the guard counts.

Used by the guard's and the stops' tests and by the fault-matrix benchmark (on ArduCopter SITL's second TCP port,
or a simulator's UDP port). pymavlink only: ksbo_sim never imports ksbo_mav.
"""

from __future__ import annotations

import os
import time
from typing import Callable

os.environ.setdefault("MAVLINK20", "1")

#: ArduCopter's flight modes by number (the ones a tuner, its guard and a pilot use).
COPTER_MODES = {0: "STABILIZE", 2: "ALT_HOLD", 3: "AUTO", 4: "GUIDED", 5: "LOITER", 6: "RTL", 9: "LAND",
                16: "POSHOLD", 17: "BRAKE"}
#: What the guard's KSG_ALIVE value says (0 idle, 1 a trial armed, 2 tripped).
GUARD_STATES = ("idle", "armed", "tripped")


class VehicleWatch:
    """Reads the vehicle (system 1) on ``device`` (pymavlink's notation). ``events`` lists each change as it arrives:
    (vehicle ms, "LOITER armed" / "guard tripped" / a guard or landing text)."""

    def __init__(self, device: str, position_hz: float = 0.0, reconnect: bool = False,
                 wait_s: float = 10.0) -> None:
        from pymavlink import mavutil

        self.conn = mavutil.mavlink_connection(device, source_system=250, source_component=190,
                                               autoreconnect=reconnect)
        if device.startswith("udpout:"):  # a simulator answers whoever talked to it
            self.conn.mav.heartbeat_send(6, 8, 0, 0, 4)
        if self.conn.wait_heartbeat(timeout=wait_s) is None:
            self.conn.close()
            raise TimeoutError(f"no heartbeat on {device} within {wait_s:g} s")
        self.vehicle_ms = 0
        self.mode = -1
        self.armed: bool | None = None
        self.height: float | None = None
        self.texts: list[str] = []  # the guard's texts (KSG: ...)
        self.alive: list[tuple[int, float]] = []  # (time_boot_ms, KSG_ALIVE)
        self.events: list[tuple[int, str]] = []
        self.interval(2, 20.0)  # SYSTEM_TIME: the vehicle's clock at 20 Hz on this link only
        if position_hz:
            self.interval(33, position_hz)  # GLOBAL_POSITION_INT: the height

    def interval(self, msg_id: int, hz: float) -> None:
        """SET_MESSAGE_INTERVAL on this link (nothing stored on the vehicle)."""
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
                self.events.append((self.vehicle_ms, f"{self.mode_name(mode)} {'armed' if armed else 'disarmed'}"))
            self.mode, self.armed = mode, armed
        elif kind == "GLOBAL_POSITION_INT":
            self.height = m.relative_alt / 1000.0
        elif kind == "NAMED_VALUE_FLOAT" and m.name == "KSG_ALIVE":
            value = float(m.value)
            if not self.alive or self.alive[-1][1] != value:
                self.events.append((self.vehicle_ms, f"guard {GUARD_STATES[int(value)] if value < 3 else value}"))
            self.alive.append((int(m.time_boot_ms), value))
        elif kind == "STATUSTEXT":
            text = str(m.text)
            if text.startswith("KSG:"):
                self.texts.append(text)
            if text.startswith("KSG:") or "Land" in text or "Disarm" in text:
                self.events.append((self.vehicle_ms, text))

    def pump(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            m = self.conn.recv_match(blocking=True, timeout=0.05)
            if m is not None:
                self._take(m)

    def until(self, predicate: Callable[[], bool], wall_s: float) -> bool:
        end = time.monotonic() + wall_s
        while time.monotonic() < end:
            if predicate():
                return True
            self.pump(0.05)
        return predicate()

    def first_alive(self, value: float, after_ms: int = 0) -> int | None:
        """Vehicle time of the guard's first report of ``value`` at or after ``after_ms``."""
        return next((t for t, v in self.alive if v == value and t >= after_ms), None)

    def params(self, names: list[str], tries: int = 3, wait_s: float = 0.6) -> dict[str, float]:
        """Fresh reads (PARAM_REQUEST_READ) of ``names``: those answered within ``tries`` rounds."""
        out: dict[str, float] = {}
        for _ in range(tries):
            for name in names:
                if name not in out:
                    self.conn.mav.param_request_read_send(1, 1, name.encode(), -1)
            end = time.monotonic() + wait_s
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

    def param(self, name: str) -> float:
        got = self.params([name], tries=5, wait_s=1.0)
        if name not in got:
            raise TimeoutError(f"no PARAM_VALUE for {name}")
        return got[name]

    @staticmethod
    def mode_name(mode: int) -> str:
        return COPTER_MODES.get(mode, str(mode))

    def set_mode(self, mode: int) -> None:
        self.conn.mav.command_long_send(1, 1, 176, 0, 1, mode, 0, 0, 0, 0, 0)

    def land(self, wall_s: float = 120.0) -> bool:
        """LAND (ArduCopter mode 9) until the vehicle disarms, so what comes next starts from the ground whatever was
        left flying (the guard's LOITER descends on a SITL's resting throttle, and a vehicle found landed but still
        armed in it takes no new takeoff). Whether it disarmed (never raises: called in clean-ups)."""
        self.pump(0.5)
        if self.armed is not False:
            self.set_mode(9)
        return self.until(lambda: self.armed is False, wall_s)

    def close(self) -> None:
        self.conn.close()
