"""What the vehicle says of its battery and its failsafes: SYS_STATUS, BATTERY_STATUS and STATUSTEXT, kept as they
arrive on both stacks (ArduPilot and PX4 send all three by default), so that the campaign can tell a pack running
out and an autopilot failsafe from anything the gains did.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Any

from ksbo_mav.mav.link import Link

#: Words in a STATUSTEXT that name a battery failsafe (ArduPilot "Battery 1 is low 10.45V used 1998 mAh",
#: "Battery failsafe"; PX4 "Low battery level!", "Critical battery level!").
BATTERY_WORDS = ("battery", "batt ")


@dataclass
class BatteryReading:
    """One moment of the pack: voltage (V), current (A), consumed (mAh) and remaining (%), None when not sent."""

    voltage_v: float | None = None
    current_a: float | None = None
    consumed_mah: float | None = None
    remaining_pct: float | None = None

    def describe(self) -> str:
        parts = []
        if self.voltage_v is not None:
            parts.append(f"{self.voltage_v:.2f} V")
        if self.remaining_pct is not None:
            parts.append(f"{self.remaining_pct:.0f} % left")
        if self.consumed_mah is not None:
            parts.append(f"{self.consumed_mah:.0f} mAh used")
        return ", ".join(parts) or "no battery figures from the vehicle"

    def to_dict(self) -> dict[str, float | None]:
        return {"voltage_v": self.voltage_v, "current_a": self.current_a, "consumed_mah": self.consumed_mah,
                "remaining_pct": self.remaining_pct}


class PowerWatch:
    """Keeps the latest battery figures and the vehicle's recent STATUSTEXTs (a handler on ``link``)."""

    def __init__(self, link: Link) -> None:
        self.link = link
        self.now = BatteryReading()
        self.texts: deque[str] = deque(maxlen=20)
        link.handlers.append(self._on_message)

    def _on_message(self, msg: Any) -> None:
        if not self.link.is_vehicle(msg):
            return
        kind = msg.get_type()
        if kind == "SYS_STATUS":
            if 0 < msg.voltage_battery < 65535:
                self.now.voltage_v = msg.voltage_battery / 1000.0
            if msg.current_battery >= 0:
                self.now.current_a = msg.current_battery / 100.0
            if msg.battery_remaining >= 0:
                self.now.remaining_pct = float(msg.battery_remaining)
        elif kind == "BATTERY_STATUS" and msg.id == 0:
            if msg.current_consumed >= 0:
                self.now.consumed_mah = float(msg.current_consumed)
            if msg.battery_remaining >= 0:
                self.now.remaining_pct = float(msg.battery_remaining)
        elif kind == "STATUSTEXT":
            self.texts.append(str(msg.text).strip("\x00 "))

    def reading(self) -> BatteryReading:
        return BatteryReading(**self.now.to_dict())

    def battery_text(self) -> str | None:
        """The vehicle's latest STATUSTEXT that names the battery, if any."""
        for text in reversed(self.texts):
            if any(w in text.lower() for w in BATTERY_WORDS):
                return text
        return None
