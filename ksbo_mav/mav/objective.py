"""The vehicle behind the objective interface: ``MavlinkObjective.fly(gains) -> Flight``.

One trial = hover at the figure-8 start with the baseline gains, write the trial gains (verified), settle, fly the
figure-8 with the monitor watching every sample, then restore the baseline (verified by a fresh read) before
anything else happens. With a moving start (``[mission] start_speed_mps``, :mod:`ksbo_mav.mav.approach`) the hover
is short of the start and the trial's gains fly a monitored approach that passes the start at the trial's random
velocity as the figure-8 begins. Every trial leaves a two-way tlog and a JSON record next to it; its score is
computed from exactly what the tlog holds (:mod:`ksbo_mav.mav.trajectory`), so ``ksbo-mav score`` reproduces it.

Aborts: gain-caused (geofence, tilt, tracking error, crash) -> hold, restore, the trial scores as unsafe and the
campaign goes on (a crashed *simulator* is re-armed; a crashed real vehicle stops the campaign). Pilot mode change,
link loss, telemetry too sparse to score, a failed parameter write, Ctrl-C, unexpected errors -> restore and stop:
:class:`TrialStopped` (or KeyboardInterrupt) is raised after the trial's record is written and kept in
:attr:`MavlinkObjective.last_flight`; such a trial says nothing about the gains and the campaign never feeds it to
the optimiser. Failing to get ready (arming, takeoff, reaching the start) raises
:class:`~ksbo_mav.mav.guided.PreflightError` before any trial is recorded.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from ksbo_mav.errors import KsboError, VehicleError
from ksbo_mav.jsonio import dumps
from ksbo_mav.mav.approach import Approach, check_moving_start, start_velocity, stress_velocity
from ksbo_mav.mav.monitor import Monitor, limits_from_profile
from ksbo_mav.mav.outcome import TrialOutcome as T
from ksbo_mav.mav.params import VerifyError
from ksbo_mav.mav.snapshot import fsync_write
from ksbo_mav.mav.tlog import TlogWriter
from ksbo_mav.mav.trajectory import TrialRecorder, after_text, end_text, ref_text, start_text
from ksbo_mav.mav.vehicle import LinkLost, PreflightError, Vehicle
from ksbo_mav.objective import Flight, Trajectory
from ksbo_mav.symptoms import trajectory_symptoms


class TrialStopped(VehicleError):
    """The trial was aborted for a reason that must stop the campaign (pilot, link, crash of a real vehicle)."""

    def __init__(self, message: str, flight: Flight) -> None:
        super().__init__(message)
        self.flight = flight


class _Abort(Exception):
    def __init__(self, outcome: str, message: str) -> None:
        super().__init__(message)
        self.outcome, self.message = outcome, message


class MavlinkObjective:
    """Fly gain vectors on a connected :class:`Vehicle`.

    Args:
        vehicle: connected vehicle.
        baseline: {vehicle parameter name: value} restored after every trial (the snapshot's values).
        out_dir: where ``trial_NNN.tlog`` / ``.json`` go.
        safety: overrides of the profile's ``[safety]`` thresholds (``x_max_m`` ...).
        settle_s: hover time with the trial gains before the figure-8 starts, and holding its end point after it
            (monitored; then the baseline is restored).
        link_wait_s: after a link loss, how long to wait for the vehicle to come back to restore the baseline.
        first_index: number of the next trial (a resumed campaign continues its numbering).
        start_seed: seed of the moving starts' random velocities (with the trial number; missions with
            ``start_speed`` only).
    """

    def __init__(self, vehicle: Vehicle, baseline: dict[str, float], out_dir: str | Path, *,
                 safety: dict[str, float] | None = None, settle_s: float = 1.0, link_wait_s: float = 30.0,
                 first_index: int = 0, start_seed: int = 0, log: Callable[[str], None] = lambda s: None) -> None:
        self.vehicle = vehicle
        self.profile = vehicle.profile
        self.baseline_values = dict(baseline)
        self.baseline = vehicle.gains.from_vehicle(baseline)
        self.out_dir = Path(out_dir)
        self.mission = vehicle.mission
        self.monitor = Monitor(limits_from_profile(self.profile, safety), vehicle.stack.modes["guided"])
        check_moving_start(self.mission, self.monitor.limits)
        self.settle_s = settle_s
        self.link_wait_s = link_wait_s
        self.index = first_index
        self.start_seed = start_seed
        self.log = log
        self.last_flight: Flight | None = None
        #: 3-D missions: the baseline flight's lap-2 RMS; every trial's P is relative to it (Mission.score).
        self.rms_ref: float | None = None

    def __call__(self, x: np.ndarray) -> float:
        return self.fly(x).P

    # --- one trial ---------------------------------------------------------------------------------------
    def fly(self, gains: np.ndarray, label: str = "", stress: bool = False) -> Flight:
        """Fly one trial (with ``stress`` from the hardest start, :func:`~ksbo_mav.mav.approach.stress_velocity`,
        instead of the trial's random one). :class:`PreflightError` (nothing flown, nothing recorded) when the
        vehicle cannot be brought to the figure-8 start; :class:`TrialStopped` after a trial that must end the
        campaign."""
        v = self.vehicle
        x = v.check_trial_gains(gains, self.baseline)
        m = self.mission
        u = (stress_velocity(m.kind, m.start_speed) if stress
             else start_velocity(m.kind, m.start_speed, self.start_seed, self.index))
        approach = Approach(m.start_ned(), u, m.dt)
        try:
            v.ensure_airborne(self.log, at=approach.begin)
        except PreflightError:
            raise
        except VehicleError as exc:  # link trouble while getting ready is not the gains' fault either
            raise PreflightError(str(exc)) from None
        i, self.index = self.index, self.index + 1
        stem = self.out_dir / f"trial_{i:03d}"
        link = v.link
        link.tlog = TlogWriter(stem.with_suffix(".tlog"))
        rec = TrialRecorder(vehicle=(link.target_system, link.target_component))
        link.taps.append(rec.feed)
        started = time.time()
        reasserts0 = v.telemetry.reasserts
        self._lag: list[float] = []
        outcome, message, L, stop = T.OK, "", 0, None
        try:
            try:
                L = self._run(x, rec, approach)
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
            restored, late = self._finish(rec, outcome, L)
            if late is not None:  # the vehicle crashed right after the trial, as the baseline took over
                outcome, message = late
        finally:
            link.taps.remove(rec.feed)
            link.tlog.close()
            link.tlog = None
        link_stats = {"lost_packets": rec.lost, "rate_reasserts": v.telemetry.reasserts - reasserts0,
                      **_lag_stats(self._lag, self.mission.window[0])}
        flight = self._record(i, stem, x, rec, outcome, message, restored, started, label,
                              {"link": link_stats, "start_velocity_ned": approach.velocity.tolist(),
                               "stress_start": stress})
        self.last_flight = flight
        if stop is not None:
            raise stop
        outcome = flight.outcome
        if not restored:
            raise TrialStopped(f"trial {i}: {flight.meta['message'] or outcome.text}; baseline NOT "
                               "restored - run `ksbo-mav restore` with the snapshot as soon as the vehicle is "
                               "reachable", flight)
        if not outcome.continues or (outcome is T.CRASH and not v.is_sim):
            raise TrialStopped(f"trial {i} aborted ({outcome.text}): {flight.meta['message']}; "
                               "baseline gains restored and verified", flight)
        return flight

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

    def _run(self, x: np.ndarray, rec: TrialRecorder, approach: Approach) -> int:
        v, m = self.vehicle, self.mission
        g = v.guided
        v.write_gains(x)
        settle = max(1, int(round(self.settle_s * m.rate_hz)))
        g.follow(lambda j: (approach.begin, None, None), settle, m.dt_ms, lambda s: self._check(s, None), self.log)
        if approach.steps:  # the trial's gains bring the vehicle to the start at its random velocity
            t_a = int(v.telemetry.clock.last_ms)
            g.follow(approach.setpoint, approach.steps, m.dt_ms,
                     lambda s: self._check(s, approach.setpoint(
                         min(max(s.time_boot_ms - t_a, 0) // m.dt_ms, approach.steps))[0]), self.log, resend_s=0.1)
        t0 = int(v.telemetry.clock.last_ms)
        n, dt = m.steps, m.dt_ms
        v.statustext(start_text(m.tag, t0, n, dt, m.window[0]))
        if self.rms_ref is not None:  # after the start marker: a start forgets everything before it
            v.statustext(ref_text(m.tag, self.rms_ref))
        # Step j's setpoint goes out when the vehicle clock reaches t0 + j*dt, stamped with that time; every
        # sample is checked against the reference at its own stamp, and scored against the logged setpoints.
        g.follow(lambda j: m.setpoint_at(j * dt / 1000.0), n, dt,
                 lambda s: self._check(s, m.setpoint_at(min(max(s.time_boot_ms - t0, 0), n * dt) / 1000.0)[0]),
                 self.log, resend_s=0.1, lag_ms=self._lag)
        end = m.setpoint_at(n * dt / 1000.0)[0]
        # The trial's gains fly on until the baseline is restored: hold the end point with them for as long as the
        # pre-trial settle, still monitored. Gains that start to diverge in the last steps of the figure-8 trip
        # here (and count as this trial's abort) instead of tumbling the vehicle during the restore, unseen.
        g.follow(lambda j: (end, None, None), settle, dt, lambda s: self._check(s, None), self.log)
        g.hold_at(end)  # end on a position-only target (no dead reckoning)
        return n

    def _finish(self, rec: TrialRecorder, outcome: T, L: int) -> tuple[bool, tuple[T, str] | None]:
        """End marker, hold (when it is ours to command), restore the baseline with verification, park.

        Returns whether the baseline was restored, and for a trial that completed but left the vehicle in a state
        the baseline did not recover from (it crashed or disarmed during the restore or within ``max(settle_s, 1.5)``
        s of vehicle time after it) that trial's new outcome and message."""
        v = self.vehicle
        g = v.guided
        restored = False
        try:
            if outcome is T.LINK:
                deadline = time.monotonic() + self.link_wait_s
                while v.link.heartbeat_age() > v.heartbeat_timeout and time.monotonic() < deadline:
                    v.link.pump(0.2)
            if rec.t0 is not None:
                v.statustext(end_text(self.mission.tag, L, outcome))
            ours = outcome not in (T.PILOT, T.CRASH, T.LINK) and g.armed
            if ours and g.position() is not None and outcome is not T.OK:
                g.hold_at(g.position())  # stop where we are: position-only targets never time out
            flying = g.armed
            v.restore(self.baseline_values)
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
            if g.armed and g.in_mode("guided"):
                g.park()
            return True, late
        except KeyboardInterrupt:
            self.log("second Ctrl-C " + ("after the restore (baseline verified)" if restored else
                                         "during restore: baseline may not be restored"))
            return restored, None
        except KsboError as exc:
            self.log(f"after the restore (baseline verified): {exc}" if restored else f"restore failed: {exc}")
            return restored, None

    def _record(self, i: int, stem: Path, x: np.ndarray, rec: TrialRecorder, outcome: T, message: str,
                restored: bool, started: float, label: str, extra: dict[str, Any]) -> Flight:
        n = self.mission.steps
        link_stats = extra["link"]
        if rec.t0 is not None and rec.finished:
            traj, info = rec.trajectory("mavlink")
        else:
            traj, info = _empty_trajectory(), {"L": 0, "outcome": outcome}
        score = self.mission.score(traj, rms_ref=info.get("rms_ref"))
        if outcome is T.OK and not score["complete"]:
            # Not the gains' fault: the lap could not be measured. Say why, and whether packets were lost.
            why = score.get("incomplete") or f"telemetry gaps in the scored lap ({info.get('unfilled')})"
            lost = link_stats["lost_packets"]
            cause = (f"{lost} packet(s) lost on the link (sequence gaps)" if lost else
                     "no packet was lost (sequence numbers complete): the vehicle sent less - another ground "
                     "station's stream request, or a saturated link")
            outcome, message = T.TELEMETRY, f"{why}; {cause}"
        stall = _stall_before(self._lag, int(traj.L))
        if outcome.gain_caused and stall > STALL_MS:
            # The tuner stopped streaming just before the trip (PX4's OFFBOARD fails safe, ArduPilot dead-reckons
            # the last setpoint): the computer caused it, not the gains.
            outcome, message = T.CLIENT, (f"{message}, {stall:.0f} ms (vehicle time) after the tuner's setpoint "
                                          "stream stalled: this computer could not keep up with the vehicle")
        if outcome is T.OK and link_stats.get("late_fraction", 0.0) > MAX_LATE_FRACTION:
            # The vehicle flew stale setpoints: the tracking error measures this computer, not the gains.
            outcome, message = T.CLIENT, (
                f"{100 * link_stats['late_fraction']:.0f} % of the scored lap's setpoints went out more than "
                f"{LATE_MS:g} ms (vehicle time) late (max {link_stats['lag_max_ms']:.0f} ms): this computer could "
                "not keep up with the vehicle - lower the simulation speed-up or the machine's load")
        if outcome is not T.OK:
            score["P"] = min(float(score["P"]), -1.0 / n)  # an aborted trial is unsafe, whatever its length
            score["safe"] = False
        symptoms = trajectory_symptoms(self.mission.kind, traj, self.mission.window)  # for chatter_dim
        meta = {"trial": i, "label": label, "outcome": outcome.value, "outcome_text": outcome.text,
                "symptoms": symptoms, "message": message, "restored": restored, "tlog": str(stem.with_suffix(".tlog")),
                "record": str(stem.with_suffix(".json")), "wall_s": time.time() - started,
                "vehicle_values": self.vehicle.gains.to_vehicle(x), "trajectory": info, **extra}
        doc = {"gains": x.tolist(), "names": self.profile.names, "score": score, **meta}
        fsync_write(stem.with_suffix(".json"), dumps(doc, indent=1))
        if outcome is not T.OK:
            self.log(f"trial {i} aborted ({outcome.text}): {message}")
        return Flight(gains=x, trajectory=traj, score=score, outcome=outcome, meta=meta)


#: A setpoint sent more than LATE_MS of vehicle time after its step is late; more than MAX_LATE_FRACTION of the
#: scored lap late and the trial measures the client, not the gains (outcome "client", retried by the campaign).
LATE_MS, MAX_LATE_FRACTION = 100.0, 0.02


#: A monitor trip within 2 s of the setpoint stream stalling by more than STALL_MS is the client's doing.
STALL_MS = 500.0


def _stall_before(lag: list[float], L: int, window: int = 100) -> float:
    """Largest setpoint lateness (ms) in the ``window`` steps before step ``L`` (0 when nothing was streamed)."""
    recent = lag[max(0, L - window):L + 1] if lag else []
    return float(max(recent)) if len(recent) else 0.0


def _lag_stats(lag: list[float], w: int) -> dict[str, float]:
    """Setpoint lateness over the scored steps (w..): max, mean, fraction later than LATE_MS."""
    scored = np.asarray(lag[w:], dtype=float)
    if not scored.size:
        return {}
    return {"lag_max_ms": float(scored.max()), "lag_mean_ms": float(scored.mean()),
            "late_fraction": float(np.mean(scored > LATE_MS))}




def _empty_trajectory() -> Trajectory:
    return Trajectory(t=np.zeros(0), steps=np.zeros(0, dtype=int), states=np.zeros((0, 6)), refs=np.zeros((0, 6)),
                      inputs=None, L=0, source="mavlink")
