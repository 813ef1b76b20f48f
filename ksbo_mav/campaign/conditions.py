"""The conditions a trial flew in: wind, battery voltage and the flight index, kept with each journal entry.

Wind is what the autopilot estimates and streams: ``WIND`` on ArduPilot (speed, and the direction it blows from),
``WIND_COV`` on PX4 (north/east components; NaN while the estimator has none). The battery voltage is the
``SYS_STATUS`` figure the vehicle's :class:`~ksbo_mav.mav.power.PowerWatch` keeps. A trial's wind is the mean of
the speeds received while it flew (and the largest); a vehicle that streams neither leaves the field empty. The
flight index counts every flight the campaign made (optimiser trials, baseline re-flights, prior points,
confirmations), so the record shows how far into the campaign, and into the pack, each trial came.
"""

from __future__ import annotations

import math
from typing import Any

from ksbo_mav.mav.vehicle import Vehicle


class ConditionWatch:
    """Listens for the autopilot's wind estimate on ``v``'s link; :meth:`take` ends one trial's record."""

    def __init__(self, v: Vehicle) -> None:
        self.v = v
        self._speeds: list[float] = []
        v.link.handlers.append(self._on_message)

    def _on_message(self, msg: Any) -> None:
        if not self.v.link.is_vehicle(msg):
            return
        kind = msg.get_type()
        if kind == "WIND":
            speed = float(msg.speed)
        elif kind == "WIND_COV":
            speed = math.hypot(float(msg.wind_x), float(msg.wind_y))
        else:
            return
        if math.isfinite(speed):
            self._speeds.append(speed)

    def start(self) -> None:
        """A trial begins: the wind heard before it is not its wind."""
        self._speeds = []

    def take(self, flight_index: int) -> dict[str, float | int | None]:
        """This trial's conditions: mean and largest wind (m/s), battery voltage (V) now, the flight index."""
        s = self._speeds
        self._speeds = []
        return {"flight": int(flight_index),
                "wind_mps": round(sum(s) / len(s), 3) if s else None,
                "wind_max_mps": round(max(s), 3) if s else None,
                "voltage_v": self.v.power.reading().voltage_v}
