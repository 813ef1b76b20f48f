"""The vehicle's clock: ``time_boot_ms`` of its telemetry, the only time a trial may be measured in.

A SITL runs at any speed-up (and the built-in simulator in lockstep), a real vehicle at 1x: wall time says nothing
about how far the vehicle has flown. :class:`VehicleClock` follows the newest ``time_boot_ms`` of any message from
the vehicle, estimates how fast vehicle time runs against the wall clock (the speed-up), and extrapolates between
messages, so setpoints can be paced on vehicle time even when telemetry arrives slowly or in bursts.

Waits (:meth:`VehicleClock.wait`) are measured on this clock. Their wall-clock guard is derived from it: a vehicle
whose clock stops advancing for ``stall_s`` wall seconds is lost (:class:`~ksbo_mav.errors.LinkLost`), and no
wait runs longer than its vehicle time at the slowest plausible rate (``min_rate``) plus ``stall_s``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from ksbo_mav.errors import ClockStalled, VehicleError


class VehicleClock:
    """Vehicle time in ms (``time_boot_ms``), fed with every message from the vehicle.

    Args:
        max_extrapolation_ms: how far :meth:`now_ms` may run ahead of the last received stamp.
    """

    def __init__(self, max_extrapolation_ms: float = 300.0) -> None:
        self.last_ms: int | None = None
        self.last_wall = 0.0
        self.rate = 1.0  # vehicle ms per wall ms (the speed-up), smoothed
        self.max_extrapolation_ms = max_extrapolation_ms
        self.reboots = 0
        self._anchor: tuple[float, int] | None = None  # (wall, ms) of the rate estimate's window start

    def feed(self, msg: Any) -> None:
        """Take ``time_boot_ms`` from a vehicle message that has one."""
        t = getattr(msg, "time_boot_ms", None)
        if t is None:
            return
        t = int(t)
        now = time.monotonic()
        if self.last_ms is not None and t < self.last_ms - 5000:  # the vehicle rebooted
            self.reboots += 1
            self._anchor = None
        elif self.last_ms is not None and t <= self.last_ms:
            return  # an older or equal stamp (another stream of the same instant)
        self.last_ms, self.last_wall = t, now
        if self._anchor is None:
            self._anchor = (now, t)
            return
        w0, t0 = self._anchor
        if now - w0 >= 0.5 and t > t0:  # re-estimate the speed-up over >= 0.5 s of wall time
            r = (t - t0) / ((now - w0) * 1000.0)
            self.rate = r if self.rate <= 0 else 0.5 * self.rate + 0.5 * r
            self._anchor = (now, t)

    @property
    def valid(self) -> bool:
        return self.last_ms is not None

    def now_ms(self) -> float:
        """Vehicle time now: the last stamp plus the wall time since, at the estimated rate (bounded)."""
        if self.last_ms is None:
            raise VehicleError("no timestamped telemetry from the vehicle yet")
        ahead = (time.monotonic() - self.last_wall) * 1000.0 * self.rate
        return self.last_ms + min(ahead, self.max_extrapolation_ms)

    def wall_for(self, vehicle_s: float) -> float:
        """Expected wall seconds for ``vehicle_s`` of vehicle time at the current rate."""
        return vehicle_s / max(self.rate, 1e-3)

    def wait(self, seconds: float, pump: Callable[[float], Any], until: Callable[[], bool] | None = None,
             stall_s: float = 3.0, min_rate: float = 0.2) -> bool:
        """Pump the link until ``seconds`` of vehicle time passed or ``until()`` holds; returns whether ``until``
        held (True without a condition).

        :class:`ClockStalled` if the clock does not advance for ``stall_s`` wall seconds; the whole wait is also
        bounded by ``seconds / min_rate + stall_s`` wall seconds (a vehicle running slower than ``min_rate`` x real
        time is treated as stalled).
        """
        start_wall = time.monotonic()
        while self.last_ms is None:
            pump(0.05)
            if time.monotonic() - start_wall > stall_s:
                raise ClockStalled(f"no timestamped telemetry from the vehicle within {stall_s:g} s")
        start_ms = self.last_ms
        guard = seconds / min_rate + stall_s
        while True:
            if until is not None and until():
                return True
            if self.last_ms - start_ms >= seconds * 1000.0:
                return until is None
            pump(0.02)
            now = time.monotonic()
            if now - self.last_wall > stall_s:
                raise ClockStalled(f"the vehicle's clock (time_boot_ms) has not advanced for "
                                   f"{now - self.last_wall:.1f} s")
            if now - start_wall > guard:
                raise ClockStalled(f"{seconds:g} s of vehicle time took more than {guard:.0f} s of wall time "
                                   f"(vehicle clock at {self.rate:.2f}x real time)")


class StreamLateness:
    """How late each setpoint of a stream went out: vehicle ms past its step's time, appended to ``out`` (None:
    not kept).

    A setpoint's lateness is the newest stamp received when it went out, minus its step's time. Sent while this
    computer was still working through a backlog (behind the vehicle: :attr:`~ksbo_mav.mav.link.Link.behind`), that
    newest stamp is itself old; once the backlog is gone the newest stamp is the vehicle's time again, and each such
    setpoint's lateness becomes what the vehicle's clock read when it went out, counted back from there at the
    clock's rate (never less than first measured)."""

    def __init__(self, clock: VehicleClock, out: list[float] | None) -> None:
        self.clock, self.out = clock, out
        self._while_behind: list[tuple[int, float, float]] = []  # (index in out, step ms, wall time sent)

    def sent(self, step_ms: float, behind: bool) -> None:
        if self.out is None:
            return
        self.out.append(max(0.0, float(self.clock.last_ms - step_ms)))
        if behind:
            self._while_behind.append((len(self.out) - 1, step_ms, time.monotonic()))

    def settle(self, behind: bool) -> None:
        """After a pump: once caught up (not ``behind``), the setpoints sent while behind get their lateness."""
        if behind or not self._while_behind:
            return
        c, now = self.clock, time.monotonic()
        for i, step_ms, wall in self._while_behind:
            self.out[i] = max(self.out[i], c.last_ms - (now - wall) * 1000.0 * c.rate - step_ms)
        self._while_behind.clear()
