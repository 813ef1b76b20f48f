"""Telemetry service: the vehicle's latest state, its clock and stream rates.

Stream rates are requested with SET_MESSAGE_INTERVAL only. REQUEST_DATA_STREAM would change ArduPilot's saved
``MAVn_*`` stream-rate parameters (left changed after the campaign); SET_MESSAGE_INTERVAL changes nothing stored.
A ground station sharing the link may still send REQUEST_DATA_STREAM, which resets our intervals to its stream
rate (ArduPilot documents this): :meth:`Telemetry.keep_rates` re-asserts them whenever the measured rate falls
below what we asked for, and :meth:`Telemetry.rate_hz` measures the rate actually received, on vehicle time.

Lost packets are told apart from a slow client by MAVLink sequence numbers, counted per trial by
:class:`~ksbo_mav.mav.trajectory.TrialRecorder` (so a tlog replay counts the same): a gap in the vehicle's ``seq``
is a packet lost on the link; a late setpoint with no gap is the client (or the machine) being slow.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from typing import Any

from ksbo_mav.errors import VehicleError
from ksbo_mav.mav.clock import VehicleClock
from ksbo_mav.mav.commands import CMD_INTERVAL, Commander
from ksbo_mav.mav.link import Link

MSG_ATTITUDE, MSG_LPN, MSG_ACTUATOR = 30, 32, 375
MSG_SYS_STATUS, MSG_BATTERY_STATUS = 1, 147  # the pack, at 1 Hz (ksbo_mav.mav.power)
MSG_WIND, MSG_WIND_COV = 168, 231  # the wind estimate, at 1 Hz (ksbo_mav.campaign.drift)




class Telemetry:
    """Latest LOCAL_POSITION_NED / ATTITUDE, the vehicle clock, LPN rate and sequence-gap counts."""

    def __init__(self, link: Link, cmd: Commander, rate_hz: float, actuators: bool = True) -> None:
        self.link, self.cmd, self.rate_wanted = link, cmd, float(rate_hz)
        #: ACTUATOR_OUTPUT_STATUS asked at the mission rate too (a mission that reads it: the planar task)
        self.actuators = actuators
        self._power_asked = False
        self.clock = VehicleClock()
        self.last_lpn: Any = None
        self.last_att: Any = None
        self.received = 0
        self._lpn_stamps: deque[int] = deque(maxlen=256)
        self._last_assert_ms = -1e18
        self.reasserts = 0
        self.on_sample: list[Callable[[Any], None]] = []
        link.handlers.append(self._on_msg)

    def _on_msg(self, msg: Any) -> None:
        if not self.link.is_vehicle(msg):
            return
        self.received += 1
        self.clock.feed(msg)
        kind = msg.get_type()
        if kind == "LOCAL_POSITION_NED":
            if self.last_lpn is None or msg.time_boot_ms > self.last_lpn.time_boot_ms:
                self.last_lpn = msg
                self._lpn_stamps.append(int(msg.time_boot_ms))
                for cb in list(self.on_sample):
                    cb(msg)
        elif kind == "ATTITUDE":
            self.last_att = msg

    # --- rates ---------------------------------------------------------------------------------------------
    def request_rates(self) -> bool:
        """SET_MESSAGE_INTERVAL for LOCAL_POSITION_NED and ATTITUDE at the mission rate; False if refused."""
        period_us = 1e6 / self.rate_wanted
        ok = all([self.cmd.set_interval(m, period_us) for m in (MSG_LPN, MSG_ATTITUDE)])
        if self.actuators:  # optional (thrusts for P(a)'s input term); not on SITLs
            self.cmd.set_interval(MSG_ACTUATOR, period_us)
        if not self._power_asked:  # optional: a link whose stream rates are off still reports the pack
            self._power_asked = True
            # ArduCopter streams WIND only in EXTRA3 (its rate often 0 on SITL and USB), PX4 WIND_COV when its
            # estimator has one: asked for, not assumed; the one a stack lacks is refused by its ACK
            for m in (MSG_SYS_STATUS, MSG_BATTERY_STATUS, MSG_WIND, MSG_WIND_COV):
                try:
                    self.cmd.set_interval(m, 1e6)
                except VehicleError:  # not answered: the battery watch then has what the vehicle sends anyway
                    pass
        self._last_assert_ms = self.clock.last_ms if self.clock.valid else -1e18
        return ok

    def mission_intervals(self) -> list[tuple[int, float]]:
        """(message id, interval µs) of the campaign's own streams as :meth:`request_rates` asks for them (the
        mission's at its rate, the pack's and the wind's once a second), to assert them again after a ground
        station's stream request reset them."""
        period_us = 1e6 / self.rate_wanted
        return [(MSG_LPN, period_us), (MSG_ATTITUDE, period_us)] + [(MSG_ACTUATOR, period_us)] * self.actuators + [
            (m, 1e6) for m in (MSG_SYS_STATUS, MSG_BATTERY_STATUS, MSG_WIND, MSG_WIND_COV)]

    def rate_hz(self, window_ms: float = 1000.0) -> float | None:
        """LOCAL_POSITION_NED samples per second of vehicle time over the last ``window_ms`` (None: too few)."""
        if not self._lpn_stamps:
            return None
        newest = self._lpn_stamps[-1]
        inside = [t for t in self._lpn_stamps if newest - t <= window_ms]
        if len(inside) < 3 or inside[-1] == inside[0]:
            return None
        return (len(inside) - 1) * 1000.0 / (inside[-1] - inside[0])

    def keep_rates(self, log: Callable[[str], None] = lambda s: None) -> None:
        """Re-assert the intervals (at most every 2 s of vehicle time) when the measured rate has dropped below
        80 % of the wanted rate, e.g. because another ground station requested its own stream rates."""
        r = self.rate_hz()
        if r is None or r >= 0.8 * self.rate_wanted or not self.clock.valid:
            return
        if self.clock.last_ms - self._last_assert_ms < 2000:
            return
        self.reasserts += 1
        if self.reasserts == 1:
            log(f"LOCAL_POSITION_NED arrives at {r:.0f} Hz (asked {self.rate_wanted:.0f} Hz): another ground "
                "station's stream request may have reset it; re-asserting the message intervals")
        period_us = 1e6 / self.rate_wanted
        for m in (MSG_LPN, MSG_ATTITUDE):  # fire and forget: waiting for the ACK would stall the setpoint stream
            self.cmd.send(CMD_INTERVAL, m, period_us)
        self._last_assert_ms = self.clock.last_ms
