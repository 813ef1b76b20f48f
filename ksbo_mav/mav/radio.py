"""Flow control from a telemetry radio's RADIO_STATUS: a SiK-class radio reports, about once a second, ``txbuf``,
the free share of its buffer toward the other end. When the ground radio's buffer fills, setpoints sent at the
mission rate would queue for seconds or be dropped; the setpoint stream then sends every second or fourth one
(each carries velocity and acceleration feed-forward, so the autopilot's controller bridges the gaps), as
ArduPilot slows its own streams on the same figure (``GCS_MAVLINK::handle_radio_status``: below 50 % and 20 %).
"""

from __future__ import annotations

import time
from typing import Any

from ksbo_mav.mav.link import Link

#: (free share of the radio's buffer below which, send every Nth setpoint), from the most crowded up.
STRIDES = ((20, 4), (50, 2))
#: A report older than this (s) is no longer believed: the radio went quiet or was never there.
STALE_S = 3.0


class RadioWatch:
    """The newest RADIO_STATUS on ``link`` (from any system: radios have their own system id) and the setpoint
    stride it implies."""

    def __init__(self, link: Link) -> None:
        self.txbuf: int | None = None
        self.at = 0.0
        self.thinned = 0  # setpoints left out for the radio so far
        link.handlers.append(self._on_msg)

    def _on_msg(self, msg: Any) -> None:
        if msg.get_type() == "RADIO_STATUS":
            self.txbuf, self.at = int(msg.txbuf), time.monotonic()

    def stride(self) -> int:
        """1 (every setpoint), 2 or 4 by the newest fresh ``txbuf``."""
        if self.txbuf is None or time.monotonic() - self.at > STALE_S:
            return 1
        return next((n for below, n in STRIDES if self.txbuf < below), 1)
