"""Guided (ArduPilot) / offboard (PX4) control: modes, holds and position-target streaming (arming, takeoff and
landing: :mod:`ksbo_mav.mav.takeoff_landing`).

Every wait runs on the vehicle's clock (:class:`~ksbo_mav.mav.clock.VehicleClock`); a lockstep simulator is
stepped instead. Differences between stacks that matter here:

* ArduCopter (and the built-in simulator): GUIDED + arm + MAV_CMD_NAV_TAKEOFF; a position-only target holds
  forever, so nothing has to stream between trials.
* PX4: OFFBOARD is accepted only while setpoints already stream (> 1 s) and is left (failsafe) when they stop, so
  the client streams before the switch and *parks* the vehicle in AUTO.LOITER whenever it stops streaming (between
  trials, while the optimiser thinks). A takeoff is a position target above the vehicle, streamed in OFFBOARD.
  Arming is refused ("temporarily rejected") until the preflight checks pass: the client retries and reports the
  vehicle's reason on one line.

While a hold target is set (:meth:`Guided.hold_at`), the link's idle hook re-sends it during *every* wait —
command acknowledgements and parameter echoes included — so the stream never lapses: at 20 Hz where the stack
needs a stream (PX4 OFFBOARD), twice a second elsewhere (a position-only target holds anyway; on a half-duplex
radio 20 Hz of targets took 1.3 kB/s of the air the vehicle's telemetry needed).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from ksbo_mav.errors import ClockStalled, LinkLost, PreflightError
from ksbo_mav.mav.clock import StreamLateness
from ksbo_mav.mav.commands import Commander
from ksbo_mav.mav.link import Link
from ksbo_mav.mav.mission import FRAME_LOCAL_NED, MASK_POS, MASK_POS_VEL_ACC
from ksbo_mav.mav.radio import RadioWatch
from ksbo_mav.mav.stacks import Stack
from ksbo_mav.mav.telemetry import Telemetry

CMD_SIM_STEP = 31011  # built-in simulator, lockstep: advance p1 seconds
#: Wall seconds between re-sent hold targets: (the stack needs a stream, it does not).
KEEPALIVE_S = (0.05, 0.5)
PRESTREAM_S = 1.5  # vehicle seconds of setpoints before asking PX4 for OFFBOARD (it wants > 1 s)
STREAM_PUMP_LIMIT = 8  # messages read between two looks at the due setpoints (~2 steps of telemetry at 50 Hz)


class Guided:
    """Position control of one vehicle in the stack's guided/offboard mode.

    Args:
        heartbeat_timeout: wall seconds without heartbeat or vehicle-clock progress that count as a lost link
            (the profile's ``[safety] heartbeat_timeout_s``: the one place this timeout comes from).
        lockstep: the built-in simulator in lockstep (time advances only when the client steps it).
    """

    def __init__(self, link: Link, cmd: Commander, stack: Stack, tel: Telemetry, heartbeat_timeout: float,
                 lockstep: bool = False) -> None:
        self.link, self.cmd, self.stack, self.tel = link, cmd, stack, tel
        self.heartbeat_timeout, self.lockstep = heartbeat_timeout, lockstep
        self._hold: np.ndarray | None = None
        self._last_keep = 0.0
        self.radio = RadioWatch(link)
        if lockstep:
            tel.clock.max_extrapolation_ms = 0.0  # lockstep time is frozen between steps
        link.idle.append(self._keepalive)

    # --- state -------------------------------------------------------------------------------------------------
    @property
    def heartbeat(self) -> Any:
        return self.link.last_heartbeat

    @property
    def armed(self) -> bool:
        hb = self.heartbeat
        return bool(hb is not None and hb.base_mode & 128)

    def in_mode(self, mode: str) -> bool:
        hb = self.heartbeat
        return hb is not None and int(hb.custom_mode) == self.stack.modes[mode]

    def position(self) -> np.ndarray | None:
        lpn = self.tel.last_lpn
        return None if lpn is None else np.array([lpn.x, lpn.y, lpn.z], dtype=float)

    def height(self) -> float:
        lpn = self.tel.last_lpn
        return float("nan") if lpn is None else -float(lpn.z)

    def check_link(self) -> None:
        """LinkLost when no heartbeat came for the timeout, unless the vehicle's telemetry still arrives: over a
        lossy radio a few heartbeats in a row can be lost while the link carries the flight (a false "link lost"
        would abort good gains); then heartbeats may be missing up to three timeouts."""
        age = self.link.heartbeat_age()
        if age <= self.heartbeat_timeout:
            return
        clock = self.tel.clock
        quiet = time.monotonic() - clock.last_wall if clock.valid else float("inf")
        if quiet < self.heartbeat_timeout and age < 3 * self.heartbeat_timeout:
            return
        raise LinkLost(f"no heartbeat from the vehicle for {age:.1f} s"
                       + (f" (telemetry {quiet:.1f} s old)" if quiet < float("inf") else ""))

    # --- wire --------------------------------------------------------------------------------------------------
    def send(self, pos: np.ndarray, vel: np.ndarray | None = None, acc: np.ndarray | None = None,
             t_ms: float | None = None) -> None:
        """One SET_POSITION_TARGET_LOCAL_NED: position-only when ``vel`` is None, else pos+vel+acc."""
        link = self.link
        if t_ms is None:
            t_ms = self.tel.clock.last_ms or 0
        if vel is None:
            mask, vel, acc = MASK_POS, np.zeros(3), np.zeros(3)
        else:
            mask = MASK_POS_VEL_ACC
            acc = np.zeros(3) if acc is None else acc
        link.send(link.mav.set_position_target_local_ned_encode(
            int(t_ms) & 0xFFFFFFFF, link.target_system, link.target_component, FRAME_LOCAL_NED, mask,
            *map(float, pos), *map(float, vel), *map(float, acc), 0.0, 0.0))

    def hold_at(self, pos: np.ndarray | None) -> None:
        """Hold a position (NED): sent now and re-sent at 20 Hz during every wait; None stops re-sending."""
        self._hold = None if pos is None else np.asarray(pos, dtype=float).copy()
        if self._hold is not None and not self.lockstep:  # in lockstep each setpoint is a simulator step
            self.send(self._hold)
            self._last_keep = time.monotonic()

    def _keepalive(self) -> None:
        if self._hold is None or self.lockstep:
            return
        now = time.monotonic()
        if now - self._last_keep >= KEEPALIVE_S[0 if self.stack.needs_stream else 1]:
            self._last_keep = now
            self.send(self._hold)

    # --- time --------------------------------------------------------------------------------------------------
    def wait(self, seconds: float, until: Callable[[], bool] | None = None) -> bool:
        """Let ``seconds`` of vehicle time pass, stopping early once ``until()`` holds (returns whether it held;
        True without a condition). :class:`LinkLost` if the vehicle's clock or heartbeat stops."""
        if self.lockstep:
            return self._wait_lockstep(seconds, until)

        def pump(t: float) -> None:
            self.link.pump(t)
            self.check_link()

        try:
            return self.tel.clock.wait(seconds, pump, until, stall_s=self.heartbeat_timeout)
        except ClockStalled as exc:
            raise LinkLost(str(exc)) from None

    def _wait_lockstep(self, seconds: float, until: Callable[[], bool] | None) -> bool:
        chunk, elapsed = 0.5, 0.0
        while elapsed < seconds:
            if until is not None and until():
                return True
            hold = self._hold
            if hold is not None:
                self.send(hold)  # one step with the hold target, then the rest of the chunk
            # (a lossy link loses a command or its ACK now and then: re-sending a step only advances time further)
            self.cmd.require("simulator step", CMD_SIM_STEP, chunk, timeout=5.0, retries=6)
            self.link.pump(0.0)
            self.check_link()
            elapsed += chunk
        return True if until is None else bool(until())

    # --- streaming ---------------------------------------------------------------------------------------------
    def follow(self, setpoint: Callable[[int], tuple[np.ndarray, np.ndarray | None, np.ndarray | None]], n: int,
               dt_ms: int, on_sample: Callable[[Any], None], log: Callable[[str], None] = lambda s: None,
               resend_s: float = 0.1, lag_ms: list[float] | None = None, lead_ms: float = 0.0) -> int:
        """Stream setpoints ``setpoint(j)`` for j = 0..n, each sent once when the vehicle clock reaches
        ``t0 + j*dt_ms`` (t0 = now; stamped with that time plus ``lead_ms``, the time its content is for), none
        skipped: if the client falls behind, the due ones go out in order, between the messages of the backlog
        (never after all of it). ``on_sample`` sees every new LOCAL_POSITION_NED (it may raise to abort). Returns
        t0 once a sample stamped at or after ``t0 + n*dt_ms`` has arrived. ``lag_ms`` (if given) receives, per
        step, how far the vehicle's clock already was past the step's time when it went out
        (:class:`~ksbo_mav.mav.clock.StreamLateness`): a slow client (or machine) shows up here, a lossy link in
        the sequence numbers.

        In lockstep each setpoint is one simulator step; a setpoint with no answer within ``resend_s`` (wall
        time) is re-sent with its stamp (a lost packet must not stall the simulator; the simulator steps a
        re-sent stamp once, so a late answer on a loaded machine does not shift the stream).
        """
        clock = self.tel.clock
        if not clock.valid:
            raise LinkLost("no timestamped telemetry from the vehicle")
        t0 = int(clock.last_ms)
        fresh: list[Any] = []
        self.tel.on_sample.append(fresh.append)
        self.hold_at(None)
        j, last_send, thinned0 = 0, time.monotonic(), self.radio.thinned
        late = StreamLateness(clock, lag_ms)
        try:
            while True:
                due = min(n, int((clock.now_ms() - t0) // dt_ms))
                while j <= due:
                    if 0 < j < n and j % self._stride():  # the radio's buffer is filling: thin the stream out
                        self.radio.thinned += 1
                        j += 1
                        continue
                    pos, vel, acc = setpoint(j)
                    self.send(pos, vel, acc, t_ms=int(t0 + j * dt_ms + lead_ms))
                    late.sent(t0 + j * dt_ms, self.link.behind)
                    j, last_send = j + 1, time.monotonic()
                while fresh:
                    on_sample(fresh.pop(0))
                # (in lockstep the answer to step n, stamped one step later, is awaited too: else it would
                # arrive during the next stream and shift that stream's steps by one)
                if j > n and clock.last_ms >= t0 + (n + self.lockstep) * dt_ms:
                    return t0
                if self.lockstep and time.monotonic() - last_send > resend_s:
                    pos, vel, acc = setpoint(j - 1)
                    self.send(pos, vel, acc, t_ms=int(t0 + (j - 1) * dt_ms + lead_ms))
                    last_send = time.monotonic()
                # A few messages at a time: behind the vehicle, the due setpoints go out between them instead of
                # after the whole backlog (PX4 leaves OFFBOARD when its stream pauses for COM_OF_LOSS_T)
                self.link.pump(0.002, limit=STREAM_PUMP_LIMIT)
                late.settle(self.link.behind)
                self.check_link()
                stalled = time.monotonic() - clock.last_wall
                if stalled > self.heartbeat_timeout:
                    raise LinkLost(f"no telemetry from the vehicle for {stalled:.1f} s")
                self.tel.keep_rates(log)
        finally:
            self.tel.on_sample.remove(fresh.append)
            if self.radio.thinned > thinned0:
                log(f"radio: {self.radio.thinned - thinned0} of {n + 1} setpoints left out while the ground radio's "
                    "buffer was filling (each setpoint carries feed-forward; the autopilot bridges the gaps)")

    def _stride(self) -> int:
        """Every how many setpoints one goes out: 1, except when a radio reports its buffer filling (never in
        lockstep, where each setpoint is a simulator step)."""
        return 1 if self.lockstep else self.radio.stride()

    # --- modes and arming --------------------------------------------------------------------------------------
    def enter(self, mode: str) -> None:
        """Switch mode; for guided on a stack that needs a running stream, stream the hold target first."""
        if mode == "guided" and self.stack.needs_stream:
            if self._hold is None:
                pos = self.position()
                if pos is None:
                    raise PreflightError("no position estimate yet: cannot start the setpoint stream")
                self.hold_at(pos)
            if not self.in_mode("guided"):
                self.wait(PRESTREAM_S)
        self.cmd.set_mode(mode)

    def park(self) -> None:
        """After a stream: PX4 goes to hold mode (its OFFBOARD would fail-safe without setpoints); elsewhere the
        last position-only target holds by itself."""
        if self.stack.needs_stream and self.armed and self.in_mode("guided"):
            self.cmd.set_mode("hold")
        self.hold_at(None)

    def near(self, pos: np.ndarray, tol: float) -> bool:
        here = self.position()
        return here is not None and float(np.linalg.norm(here - pos)) < tol
