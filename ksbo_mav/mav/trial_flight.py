"""Flying one trial on a hovering vehicle, and getting the baseline back: nothing here scores or records it.

The trial's gains are written (verified), settle at the start, fly the monitored approach of a moving start if there
is one, then the figure-8 with the monitor watching every sample, and hold its end point; then the baseline is
restored (verified by a fresh read) before anything else happens. What the flight left behind comes back as a
:class:`FlownTrial`: the telemetry recorder, how it ended, whether the baseline is back and the link statistics.

Gain-caused aborts (geofence, tilt, tracking error, crash), a pilot's mode change, a lost link, a failed parameter
write, Ctrl-C and other errors all end the flight the same way: end marker, hold where it is ours to command,
restore, park. Which of them stops the campaign is decided by the caller.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ksbo_mav.errors import KsboError, LinkLost
from ksbo_mav.mav.approach import Approach
from ksbo_mav.mav.monitor import Monitor
from ksbo_mav.mav.outcome import TrialOutcome as T
from ksbo_mav.errors import VerifyError
from ksbo_mav.mav.tlog import TlogWriter
from ksbo_mav.mav import guard_trip, link_return, onboard_trial
from ksbo_mav.mav.trajectory import TrialRecorder, after_text, board_text, end_text, ref_text, start_text
from ksbo_mav.mav.trial_step import StepRecord, TrialStep, fly_step
from ksbo_mav.mav.vehicle import Vehicle


class _Abort(Exception):
    """The monitor tripped: ``outcome`` is the reason's code. Internal: it ends the flight, never the caller."""

    def __init__(self, outcome: str, message: str) -> None:
        super().__init__(message)
        self.outcome, self.message = outcome, message


@dataclass(frozen=True)
class LinkStats:
    """How the link and this computer kept up during one trial.

    Attributes:
        lost_packets: sequence gaps in the vehicle's messages.
        rate_reasserts: telemetry rate requests re-sent because the vehicle's rates dropped.
        lag_ms: (steps + 1,) per figure-8 step, how far the vehicle's newest stamp already was past the step's time
            when its setpoint went out (vehicle ms; empty when the figure-8 was not reached).
    """

    lost_packets: int
    rate_reasserts: int
    lag_ms: tuple[float, ...]


@dataclass(frozen=True)
class FlownTrial:
    """What flying one trial produced, before it is scored.

    Attributes:
        recorder: the telemetry and logged setpoints of the trial (:class:`~ksbo_mav.mav.trajectory.TrialRecorder`).
        outcome, message: how the flight ended (before scoring may reclassify it).
        steps: figure-8 steps flown (L).
        restored: the baseline parameters are back on the vehicle, verified by a fresh read.
        link: :class:`LinkStats`.
        interrupted: the Ctrl-C that ended the trial (re-raised once the trial is recorded), else None.
        link_back: after a lost link, the link came back, the baseline is restored and the vehicle is armed in
            GUIDED again (left so by the guard, or taken back from its BRAKE/LOITER): the campaign may go on.
        step: the figures of the position step flown after the figure-8 (:mod:`ksbo_mav.mav.trial_step`), None
            when the trial flies none or did not reach it.
    """

    recorder: TrialRecorder
    outcome: T
    message: str
    steps: int
    restored: bool
    link: LinkStats
    interrupted: KeyboardInterrupt | None = None
    link_back: bool = False
    step: dict[str, Any] | None = None


class TrialFlight:
    """Flies trials on one hovering vehicle and restores its baseline after each.

    Args:
        vehicle: connected vehicle, hovering at the trial's start (:meth:`Vehicle.ensure_airborne`).
        monitor: the safety monitor every sample is checked by.
        baseline_params: {autopilot parameter name: value} restored after every trial.
        settle_s: hover with the trial gains before the figure-8, and hold of its end point after it.
        link_wait_s: after a link loss, how long to wait for the vehicle to come back to restore the baseline.
    """

    def __init__(self, vehicle: Vehicle, monitor: Monitor, baseline_params: dict[str, float], *, settle_s: float,
                 link_wait_s: float, log: Callable[[str], None]) -> None:
        self.vehicle, self.monitor = vehicle, monitor
        self.mission = vehicle.mission
        self.baseline_params = dict(baseline_params)
        self.settle_s, self.link_wait_s, self.log = settle_s, link_wait_s, log
        #: Fly the figure-8 on board when the guard carries it (False: stream it from the ground anyway).
        self.on_board = True
        #: The position step every trial flies after its figure-8 (None: none).
        self.step: TrialStep | None = None
        self._step_record: StepRecord | None = None

    def fly(self, x: np.ndarray, approach: Approach, tlog: Path, rms_ref: float | None,
            rough_ref: float | None = None) -> FlownTrial:
        """Fly the gains ``x`` (d,), already checked against the trust region, with a two-way tlog at ``tlog``;
        ``rms_ref`` and ``rough_ref`` (3-D missions: the baseline's) go into the tlog after the start marker."""
        v = self.vehicle
        link = v.link
        link.tlog = TlogWriter(tlog)
        rec = TrialRecorder(vehicle=(link.target_system, link.target_component))
        link.taps.append(rec.feed)
        reasserts0 = v.telemetry.reasserts
        lag: list[float] = []
        outcome, message, L, stop = T.OK, "", 0, None
        self._returned: link_return.LinkReturn | None = None
        self._step_record = None
        back = False
        try:
            try:
                L = self._run(x, approach, (rms_ref, rough_ref), lag)
            except _Abort as a:
                outcome, message = T(a.outcome), a.message
                L = self._steps(rec)
            except VerifyError as exc:
                outcome, message = T.VERIFY, str(exc)
            except LinkLost as exc:
                outcome, message, L = T.LINK, str(exc), self._steps(rec)
            except KeyboardInterrupt as exc:
                outcome, message, L, stop = T.SIGINT, "interrupted by the user", self._steps(rec), exc
            except KsboError as exc:
                outcome, message, L = T.ERROR, str(exc), self._steps(rec)
            # The guard's watch ends before our own recovery (it must not fight it); after a lost link, once the
            # link is back (the restore waits for it). A mode change that is the guard's own stop for the gains'
            # breach is that breach, not a pilot's.
            lost = outcome is T.LINK  # the tuner lost the vehicle (else the guard may have lost the tuner)
            guard_note, trip = guard_trip.end_watch(v) if not lost else ("", None)
            outcome, message = guard_trip.classify(v, outcome, message, trip)
            restored, late = self._finish(rec, outcome, L, v.gain_map.to_params(x))
            if lost:
                guard_note, back = self._after_link(restored)
            elif restored:
                guard_note = self._take_back(trip, guard_note)
                back = outcome is T.LINK and v.guided.wait(2.0, lambda: v.guided.armed and v.guided.in_mode("guided"))
            if late is not None:  # the vehicle crashed right after the trial, as the baseline took over
                outcome, message = late
            if guard_note:
                message = f"{message}; {guard_note}" if message else guard_note
        finally:
            link.taps.remove(rec.feed)
            link.tlog.close()
            link.tlog = None
        stats = LinkStats(lost_packets=rec.lost, rate_reasserts=v.telemetry.reasserts - reasserts0, lag_ms=tuple(lag))
        step = None if self._step_record is None else self._step_record.figures()
        return FlownTrial(rec, outcome, message, L, restored, stats, stop, back, step)

    def _after_link(self, restored: bool) -> tuple[str, bool]:
        """Once the link is back and the baseline restored: end the guard's watch, take the vehicle back from what
        the guard did for the lost link, and say what happened on the vehicle. Returns (the trial's note, whether
        the campaign may go on)."""
        found = self._returned
        note, _ = guard_trip.end_watch(self.vehicle)
        if found is None:  # the link did not come back in time
            return note, False
        note = found.text() + ("; baseline restored and verified" if restored else "")
        back = False
        if restored:
            try:
                took = link_return.take_back(self.vehicle, found)
                back = self.vehicle.guided.armed and self.vehicle.guided.in_mode("guided")
            except KsboError as exc:
                took = f"not taken back: {exc}"
            note += f"; {took}" if took else ""
        self.log(note)
        return note, back

    def _take_back(self, trip: guard_trip.GuardTrip | None, note: str) -> str:
        """After the restore: the vehicle the guard stopped taken back to GUIDED (the campaign goes on in it)."""
        took = guard_trip.take_back(self.vehicle, trip)
        if took:
            self.log(f"{note}; {took}")
        return f"{note}; {took}" if took else note

    def _steps(self, rec: TrialRecorder) -> int:
        lpn = self.vehicle.last_lpn
        if rec.t0 is None or lpn is None:
            return 0
        return int(min(max(0, round((lpn.time_boot_ms - rec.t0) / self.mission.dt_ms)), self.mission.steps))

    def _check(self, lpn: Any, ref_ned: np.ndarray | None) -> None:
        v = self.vehicle
        bad = self.monitor.check_heartbeat(v.guided.heartbeat) or \
            self.monitor.check_sample(lpn, v.telemetry.last_att, ref_ned)
        if bad:
            raise _Abort(*bad)

    def _run(self, x: np.ndarray, approach: Approach, refs: tuple[float | None, float | None],
             lag: list[float]) -> int:
        v, m = self.vehicle, self.mission
        g = v.guided
        if v.guard is not None:
            v.guard.arm_trial()  # GuardUnavailable when the guard does not answer: no trial flies without it
        v.write_gains(x)
        settle = max(1, int(round(self.settle_s * m.rate_hz)))
        g.follow(lambda j: (approach.begin, None, None), settle, m.dt_ms, lambda s: self._check(s, None), self.log)
        if approach.steps:  # the trial's gains bring the vehicle to the start at its random velocity
            t_a = int(v.telemetry.clock.last_ms)
            g.follow(approach.setpoint, approach.steps, m.dt_ms,
                     lambda s: self._check(s, approach.setpoint(
                         min(max(s.time_boot_ms - t_a, 0) // m.dt_ms, approach.steps))[0]), self.log, resend_s=0.1)
        n, dt = m.steps, m.dt_ms
        board = self.on_board and onboard_trial.on_board(v)
        t0 = onboard_trial.start(v) if board else int(v.telemetry.clock.last_ms)
        v.statustext(start_text(m.tag, t0, n, dt, m.window[0]))
        if board:
            v.statustext(board_text(m.figure8h))
        if refs[0] is not None:  # after the start marker: a start forgets everything before it
            v.statustext(ref_text(m.tag, *refs))
        ref_at = lambda s: m.setpoint_at(min(max(s.time_boot_ms - t0, 0), n * dt) / 1000.0)[0]  # noqa: E731
        if board:  # the guard flies it and holds the end point: watch the figure-8 and the settle after it
            onboard_trial.watch(v, t0 + n * dt, lambda s: self._check(s, ref_at(s)), self.log)
            end = m.setpoint_at(n * dt / 1000.0)[0]
            onboard_trial.watch(v, t0 + n * dt + int(self.settle_s * 1000), lambda s: self._check(s, None), self.log)
            g.hold_at(end)
            self._fly_step(end)
            return n
        # Step j's setpoint goes out when the vehicle clock reaches t0 + j*dt, stamped with the time its content is
        # for; every sample is checked against the reference at its own stamp, and scored against the logged
        # setpoints at its stamp. An autopilot that holds each position setpoint for a whole step gets the
        # reference of the step's middle (a held target trails the moving one by half a step: 50 ms at 10 Hz).
        lead = 0.5 if v.stack.holds_setpoints else 0.0
        g.follow(lambda j: m.setpoint_at((j + lead) * dt / 1000.0), n, dt, lambda s: self._check(s, ref_at(s)),
                 self.log, resend_s=0.1, lag_ms=lag, lead_ms=lead * dt)
        end = m.setpoint_at(n * dt / 1000.0)[0]
        # The trial's gains fly on until the baseline is restored: hold the end point with them for as long as the
        # pre-trial settle, still monitored. Gains that start to diverge in the last steps of the figure-8 trip
        # here (and count as this trial's abort) instead of tumbling the vehicle during the restore, unseen.
        g.follow(lambda j: (end, None, None), settle, dt, lambda s: self._check(s, None), self.log)
        g.hold_at(end)  # end on a position-only target (no dead reckoning)
        self._fly_step(end)
        return n

    def _fly_step(self, start: np.ndarray) -> None:
        """The position step after the figure-8 (when the trial flies one), watched with the step's tilt limit: a
        trip aborts the trial as the monitor's would."""
        if self.step is None:
            return
        mon = self.step.monitor(self.monitor)
        self._step_record = StepRecord(self.step, start)

        def check(s: Any) -> None:
            bad = mon.check_heartbeat(self.vehicle.guided.heartbeat) or \
                mon.check_sample(s, self.vehicle.telemetry.last_att, None)
            if bad:
                raise _Abort(bad[0], f"position step after the figure-8: {bad[1]}")

        fly_step(self.vehicle, self._step_record, check, self.log)

    def _finish(self, rec: TrialRecorder, outcome: T, L: int,
                trial_params: dict[str, float]) -> tuple[bool, tuple[T, str] | None]:
        """End marker, hold (when it is ours to command), restore the baseline with verification, park.

        Returns whether the baseline was restored, and for a trial that completed but left the vehicle in a state
        the baseline did not recover from (it crashed or disarmed during the restore or within ``max(settle_s, 1.5)``
        s of vehicle time after it) that trial's new outcome and message."""
        v = self.vehicle
        g = v.guided
        restored = False
        try:
            if outcome is T.LINK:
                heard = time.monotonic() - v.link.heartbeat_age()
                deadline = time.monotonic() + self.link_wait_s
                while v.link.heartbeat_age() > v.heartbeat_timeout and time.monotonic() < deadline:
                    v.link.pump(0.2)
                if v.link.heartbeat_age() <= v.heartbeat_timeout:  # back: what happened there, before any write
                    self._returned = link_return.survey(v, time.monotonic() - v.link.heartbeat_age() - heard,
                                                        trial_params, self.baseline_params)
            if rec.t0 is not None:
                v.statustext(end_text(self.mission.tag, L, outcome))
            ours = outcome not in (T.PILOT, T.CRASH, T.LINK, T.FAILSAFE) and g.armed  # never override a failsafe
            if ours and g.position() is not None and outcome is not T.OK:
                g.hold_at(g.position())  # stop where we are: position-only targets never time out
            flying = g.armed
            v.restore(self.baseline_params)
            restored = True  # verified by a fresh read: what follows only watches the vehicle
            late = None
            if outcome.gain_caused and outcome is not T.CRASH and g.armed:
                g.wait(1.0)  # let the baseline gains settle the vehicle before anything else
            elif outcome is T.OK and flying:
                # Gains that end the figure-8 in a violent oscillation (below the tilt limit) can leave the vehicle
                # in a state the baseline does not catch: watch the restore and its first moments, blame the trial.
                if g.armed:
                    # (at least 1.5 s: autopilots send HEARTBEAT at 1 Hz)
                    g.wait(max(self.settle_s, 1.5), lambda: self.monitor.check_heartbeat(g.heartbeat) is not None)
                bad = self.monitor.check_heartbeat(g.heartbeat)
                if bad is not None and bad[0] == T.CRASH:
                    late = (T.CRASH, f"{bad[1]} right after the trial, as the baseline gains took over")
                    if rec.t0 is not None:
                        v.statustext(after_text(self.mission.tag, T.CRASH))
            if g.armed and g.in_mode("guided") and outcome is not T.FAILSAFE:
                g.park()
            return True, late
        except KeyboardInterrupt:
            self.log("second Ctrl-C " + ("after the restore (baseline verified)" if restored else
                                         "during restore: baseline may not be restored"))
            return restored, None
        except KsboError as exc:
            self.log(f"after the restore (baseline verified): {exc}" if restored else f"restore failed: {exc}")
            return restored, None
