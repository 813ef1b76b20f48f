"""What every validation manoeuvre shares: the monitor on every sample (in whichever mode the manoeuvre flies), the
markers, holds in guided/offboard, waits in the autopilot's own modes, and the way back into guided.

The monitor is the campaign's (:class:`~ksbo_mav.mav.monitor.Monitor`: the box, the tilt, a crash, the heartbeat's
mode); while the autopilot flies its own mode (hold, auto) the expected mode is that one, so a pilot switching away
from it is seen as a take-over exactly as during a trial. The tracking-error limit is not applied: a step is an
error by design, and in hold and auto the reference is the autopilot's own.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ksbo_mav.errors import KsboError, VehicleError
from ksbo_mav.mav.commands import CMD_SET_MODE, refusal
from ksbo_mav.mav.monitor import Monitor
from ksbo_mav.mav.vehicle import Vehicle


class ManoeuvreAbort(Exception):
    """The monitor tripped: ``outcome`` is its code. Internal: it ends the flight, never the caller."""

    def __init__(self, outcome: str, message: str) -> None:
        super().__init__(message)
        self.outcome, self.message = outcome, message


class ManoeuvreFrame:
    """One validation flight's services on a hovering vehicle.

    Attributes:
        started / ended: the start and end markers went out.
        after: callables run once the vehicle is back under the tool's control (or left to the pilot), whatever
            the outcome — e.g. putting the user's mission back.
    """

    def __init__(self, vehicle: Vehicle, monitor: Monitor, log: Callable[[str], None]) -> None:
        self.v, self.monitor, self.log = vehicle, monitor, log
        self.started = self.ended = False
        self.after: list[Callable[[], None]] = []

    # --- time and markers ----------------------------------------------------------------------------------
    def now_ms(self) -> int:
        return int(self.v.telemetry.clock.last_ms)

    def marker(self, text: str) -> None:
        self.v.statustext(text)

    def monitor_for(self, mode: str) -> Monitor:
        """The campaign's limits, expecting the stack's ``mode`` ("guided", "hold", "auto") in the heartbeat."""
        return Monitor(self.monitor.limits, self.v.stack.modes[mode], self.v.stack.mode_name)

    def check(self, lpn: Any, monitor: Monitor, also: Callable[[], set[int]] = set) -> None:
        """The monitor on one sample; a heartbeat in one of the modes ``also()`` is not a mode change."""
        hb = self.v.guided.heartbeat
        bad = None if hb is not None and int(hb.custom_mode) in also() else monitor.check_heartbeat(hb)
        bad = bad or monitor.check_sample(lpn, self.v.telemetry.last_att, None)
        if bad:
            raise ManoeuvreAbort(*bad)

    # --- flying --------------------------------------------------------------------------------------------
    def hold_target(self, point: np.ndarray, seconds: float) -> None:
        """Stream the single position target ``point`` (NED, no feed-forward) in guided/offboard for ``seconds`` of
        vehicle time, every sample monitored; then keep holding it (the link's keepalive)."""
        v = self.v
        m = v.mission
        n = max(1, int(round(seconds * m.rate_hz)))
        point = np.asarray(point, float)
        v.guided.follow(lambda j: (point, None, None), n, m.dt_ms, lambda s: self.check(s, self.monitor), self.log)
        v.guided.hold_at(point)

    def watch(self, seconds: float, mode: str, until: Callable[[], bool] | None = None,
              also: Callable[[], set[int]] = set) -> bool:
        """Let the autopilot fly its ``mode`` for up to ``seconds`` of vehicle time (stopping early once ``until()``
        holds; returns whether it did), every position sample checked by the monitor expecting that mode (or one of
        the custom modes ``also()`` gives at that moment)."""
        mon = self.monitor_for(mode)
        fresh: list[Any] = []
        tel = self.v.telemetry
        tel.on_sample.append(fresh.append)

        def done() -> bool:
            while fresh:
                self.check(fresh.pop(0), mon, also)
            return bool(until()) if until is not None else False

        try:
            return self.v.guided.wait(seconds, done)
        finally:
            tel.on_sample.remove(fresh.append)

    def enter(self, mode: str, retry_s: float = 10.0) -> int:
        """Switch the vehicle to the stack's ``mode`` (confirmed by the heartbeat); returns the vehicle time then.
        A switch the vehicle answers "temporarily rejected" is asked for again for up to ``retry_s`` of vehicle
        time (PX4 refuses Mission until it has checked a mission just uploaded). No target is streamed or kept
        alive in the autopilot's own modes."""
        v = self.v
        custom = v.stack.modes[mode]
        deadline = self.now_ms() + retry_s * 1000.0
        while True:  # (the hold target keeps streaming until the switch: PX4's OFFBOARD needs it)
            result, reason = v.cmd.attempt(CMD_SET_MODE, *v.stack.mode_params(custom))
            if result == 0:
                break
            if result != 1 or self.now_ms() > deadline:
                raise VehicleError(refusal(f"mode {v.stack.mode_name(custom)}", result, reason))
            v.guided.wait(0.5)
        v.cmd.set_mode(mode)  # accepted: wait for the heartbeat to show it
        v.guided.hold_at(None)
        return self.now_ms()

    def back_to_guided(self, point: np.ndarray | None = None) -> None:
        """Guided/offboard again, holding ``point`` (default: where the vehicle is now)."""
        g = self.v.guided
        here = g.position() if point is None else np.asarray(point, float)
        g.hold_at(here)
        if not g.in_mode("guided"):
            g.enter("guided")

    def run_after(self) -> list[str]:
        """Run :attr:`after` (each once); the failures' messages."""
        problems = []
        while self.after:
            job = self.after.pop(0)
            try:
                job()
            except KsboError as exc:  # a clean-up that fails must not stop the others (or the restore)
                problems.append(str(exc))
        return problems
