"""The vehicle behind the objective interface: ``MavlinkObjective.fly(gains) -> Flight``.

One trial = hover at the figure-8 start with the baseline gains, write the trial gains (verified), settle, fly the
figure-8 with the monitor watching every sample, then restore the baseline (verified by a fresh read) before
anything else happens. Every trial leaves a two-way tlog and a JSON record next to it; its score is computed from
exactly what the tlog holds (:mod:`ksbo_mav.mav.trajectory`), so ``ksbo-mav score`` reproduces it.

Aborts: gain-caused (geofence, tilt, tracking error, crash) -> hold, restore, the trial scores as unsafe and the
campaign goes on (a crashed *simulator* is re-armed; a crashed real vehicle stops the campaign). Pilot mode change,
link loss, Ctrl-C, unexpected errors -> restore and stop: :class:`TrialStopped` (or KeyboardInterrupt) is raised
after the trial's record is written and kept in :attr:`MavlinkObjective.last_flight`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ksbo_mav.errors import KsboError, VehicleError
from ksbo_mav.jsonio import dumps
from ksbo_mav.mav.monitor import GAIN_OUTCOMES, OUTCOMES, Limits, Monitor
from ksbo_mav.mav.params import VerifyError
from ksbo_mav.mav.snapshot import fsync_write
from ksbo_mav.mav.tlog import TlogWriter
from ksbo_mav.mav.trajectory import TrialRecorder, end_text, start_text
from ksbo_mav.mav.vehicle import LinkLost, Sample, Vehicle
from ksbo_mav.objective import Flight, Trajectory


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
        settle_s: hover time with the trial gains before the figure-8 starts.
        link_wait_s: after a link loss, how long to wait for the vehicle to come back to restore the baseline.
        first_index: number of the next trial (a resumed campaign continues its numbering).
    """

    def __init__(self, vehicle: Vehicle, baseline: dict[str, float], out_dir: str | Path, *,
                 safety: dict[str, float] | None = None, settle_s: float = 1.0, link_wait_s: float = 30.0,
                 first_index: int = 0, log: Callable[[str], None] = lambda s: None) -> None:
        self.vehicle = vehicle
        self.profile = vehicle.profile
        self.baseline_values = dict(baseline)
        self.baseline = vehicle.gains.from_vehicle(baseline)
        self.out_dir = Path(out_dir)
        self.mission = vehicle.mission
        self.monitor = Monitor(Limits.from_profile(self.profile, safety), vehicle.stack.modes["guided"])
        self.settle_s = settle_s
        self.link_wait_s = link_wait_s
        self.index = first_index
        self.log = log
        self.last_flight: Flight | None = None

    def __call__(self, x: np.ndarray) -> float:
        return self.fly(x).P

    # --- one trial ---------------------------------------------------------------------------------------
    def fly(self, gains: np.ndarray, label: str = "") -> Flight:
        v = self.vehicle
        x = v.check_trial_gains(gains, self.baseline)
        i, self.index = self.index, self.index + 1
        stem = self.out_dir / f"trial_{i:03d}"
        link = v.link
        link.tlog = TlogWriter(stem.with_suffix(".tlog"))
        rec = TrialRecorder(vehicle=(link.target_system, link.target_component))
        link.taps.append(rec.feed)
        started = time.time()
        outcome, message, L, stop = "ok", "", 0, None
        try:
            try:
                L = self._run(x, rec)
            except _Abort as a:
                outcome, message = a.outcome, a.message
                L = self._steps(rec)
            except VerifyError as exc:
                outcome, message = "verify", str(exc)
            except LinkLost as exc:
                outcome, message, L = "link", str(exc), self._steps(rec)
            except KeyboardInterrupt as exc:
                outcome, message, L, stop = "sigint", "interrupted by the user", self._steps(rec), exc
            except KsboError as exc:
                outcome, message, L = "error", str(exc), self._steps(rec)
            restored = self._finish(rec, outcome, L)
        finally:
            link.taps.remove(rec.feed)
            link.tlog.close()
            link.tlog = None
        flight = self._record(i, stem, x, rec, outcome, message, restored, started, label)
        self.last_flight = flight
        if stop is not None:
            raise stop
        if not restored:
            raise TrialStopped(f"trial {i}: {message or OUTCOMES[outcome]}; baseline NOT restored - run "
                               "`ksbo-mav restore` with the snapshot as soon as the vehicle is reachable", flight)
        if outcome in ("pilot", "link", "error") or (outcome == "crash" and not v.is_sim):
            raise TrialStopped(f"trial {i} aborted: {message}; baseline gains restored and verified", flight)
        return flight

    def _steps(self, rec: TrialRecorder) -> int:
        lpn = self.vehicle.last_lpn
        if rec.t0 is None or lpn is None:
            return 0
        return int(min(max(0, round((lpn.time_boot_ms - rec.t0) / self.mission.dt_ms)), self.mission.steps))

    def _check(self, s: Sample, ref_ned: np.ndarray | None) -> None:
        self.vehicle.check_link()
        bad = self.monitor.check_heartbeat(self.vehicle.heartbeat()) or self.monitor.check_sample(s.lpn, s.att, ref_ned)
        if bad:
            raise _Abort(*bad)

    def _run(self, x: np.ndarray, rec: TrialRecorder) -> int:
        v, m = self.vehicle, self.mission
        v.ensure_airborne(self.log)
        v.write_gains(x)
        s = v.hold(m.start_ned(), self.settle_s, lambda s: self._check(s, None))
        t0, n, dt = s.t_ms, m.steps, m.dt_ms
        v.statustext(start_text(m.tag, t0, n, dt, m.window[0]))
        # Each sample is answered with the reference at *its* timestamp (logged with that stamp), so state and
        # reference are paired at the same instant even when a real vehicle's stream jitters; in lockstep the
        # stamps are exactly t0 + j*dt.
        tau = 0
        while True:
            j = round(tau / dt)
            if j >= n:
                tau = n * dt
            pos, vel, acc = m.setpoint_at(tau / 1000.0)
            s = v.exchange(pos, vel, acc, t_ms=t0 + tau)
            if j >= n:
                return n
            tau = s.t_ms - t0
            self._check(s, m.setpoint_at(min(tau, n * dt) / 1000.0)[0])

    def _finish(self, rec: TrialRecorder, outcome: str, L: int) -> bool:
        """End marker, hold (when it is ours to command), restore the baseline with verification."""
        v = self.vehicle
        try:
            if outcome == "link":
                deadline = time.monotonic() + self.link_wait_s
                while v.link.heartbeat_age() > v.heartbeat_timeout and time.monotonic() < deadline:
                    v.link.pump(0.2)
            if rec.t0 is not None:
                v.statustext(end_text(self.mission.tag, L, outcome))
            if outcome not in ("pilot", "crash", "link") and v.armed and v.last_lpn is not None:
                here = np.array([v.last_lpn.x, v.last_lpn.y, v.last_lpn.z])
                v.exchange(here)  # stop where we are: position-only targets never time out
            v.restore(self.baseline_values)
            if outcome in GAIN_OUTCOMES and outcome != "crash" and v.armed:
                v.hold(np.array([v.last_lpn.x, v.last_lpn.y, v.last_lpn.z]), 1.0)
            return True
        except KeyboardInterrupt:
            self.log("second Ctrl-C during restore: baseline may not be restored")
            return False
        except KsboError as exc:
            self.log(f"restore failed: {exc}")
            return False

    def _record(self, i: int, stem: Path, x: np.ndarray, rec: TrialRecorder, outcome: str, message: str,
                restored: bool, started: float, label: str) -> Flight:
        n = self.mission.steps
        if rec.t0 is not None and rec.finished:
            traj, info = rec.trajectory("mavlink")
        else:
            traj, info = _empty_trajectory(), {"L": 0, "outcome": outcome}
        score = self.mission.score(traj)
        if outcome == "ok" and not score["complete"]:
            outcome, message = "link", f"telemetry gaps in the scored lap ({info.get('unfilled')})"
        if outcome != "ok":
            score["P"] = min(float(score["P"]), -1.0 / n)  # an aborted trial is unsafe, whatever its length
            score["safe"] = False
        meta = {"trial": i, "label": label, "outcome": outcome, "outcome_text": OUTCOMES[outcome],
                "message": message, "restored": restored, "tlog": str(stem.with_suffix(".tlog")),
                "record": str(stem.with_suffix(".json")), "wall_s": time.time() - started,
                "vehicle_values": self.vehicle.gains.to_vehicle(x), "trajectory": info}
        doc = {"gains": x.tolist(), "names": self.profile.names, "score": score, **meta}
        fsync_write(stem.with_suffix(".json"), dumps(doc, indent=1))
        if outcome != "ok":
            self.log(f"trial {i} aborted ({OUTCOMES[outcome]}): {message}")
        return Flight(gains=x, trajectory=traj, score=score, outcome=outcome, meta=meta)


def _empty_trajectory() -> Trajectory:
    return Trajectory(t=np.zeros(0), steps=np.zeros(0, dtype=int), states=np.zeros((0, 6)), refs=np.zeros((0, 6)),
                      inputs=None, L=0, source="mavlink")
