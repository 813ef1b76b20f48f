"""Flying one validation manoeuvre on one gain set, and what it measured (:func:`fly_manoeuvre`,
:class:`ManoeuvreFlight`).

The flight follows a trial's path (:mod:`ksbo_mav.mav.trial_flight`): the gains written and verified (when given),
a monitored hover on the start point, the manoeuvre with the monitor on every sample, and however it ends — done,
the monitor's abort, a pilot's mode change, a lost link, Ctrl-C — the end marker, the vehicle held where it is
(guided) when it is ours to command, the baseline restored and verified by a fresh read (when given), then the
clean-ups (the user's mission back) and the park. Nothing here is given to the optimiser. The onboard guard
(``vehicle.guard``, when the campaign installed one) watches the flight as it watches a trial, told which of the
autopilot's own modes (hold, auto) the flight switches to: a lost link or a box or tilt breach puts the baseline back
and stops the vehicle on board (a breach it stopped is the gains' abort, :mod:`ksbo_mav.mav.guard_trip`), and any
other mode is still a pilot's take-over.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ksbo_mav.errors import KsboError, LinkLost, PilotTookOver, VerifyError
from ksbo_mav.mav.guard_trip import GuardTrip, classify, end_watch, take_back
from ksbo_mav.mav.monitor import Monitor
from ksbo_mav.mav.outcome import TrialOutcome as T
from ksbo_mav.mav.tlog import TlogWriter
from ksbo_mav.mav.validation.hold_manoeuvre import fly_hold
from ksbo_mav.mav.validation.manoeuvre_frame import ManoeuvreAbort, ManoeuvreFrame
from ksbo_mav.mav.validation.manoeuvre_recorder import ManoeuvreRecorder, after_text, end_text
from ksbo_mav.mav.validation.manoeuvre_spec import ManoeuvreSpec
from ksbo_mav.mav.validation.mission_manoeuvre import fly_auto_mission
from ksbo_mav.mav.validation.step_manoeuvre import fly_steps
from ksbo_mav.mav.vehicle import Vehicle

_FLY = {"steps": fly_steps, "hold": fly_hold, "auto_mission": fly_auto_mission}
#: The stack's modes (besides guided) each manoeuvre switches to: the onboard guard's own modes for the flight.
OWN_MODES = {"steps": (), "hold": ("hold",), "auto_mission": ("auto",)}


@dataclass(frozen=True)
class ManoeuvreFlight:
    """One validation flight.

    Attributes:
        kind: "steps", "hold" or "auto_mission".
        outcome, message: how it ended (:class:`~ksbo_mav.mav.outcome.TrialOutcome`; "ok" when measured).
        metrics: the figures (:meth:`ManoeuvreRecorder.metrics` names; NaN where a figure does not exist), empty
            unless the measured part completed.
        started_at, ended_at: wall-clock Unix seconds.
        tlog: the two-way telemetry log it wrote (``ksbo-mav score`` re-computes the figures from it).
        gains_label: what was flown (e.g. "baseline", "recommended"), also in the tlog's start marker.
        restored: the baseline was written back and verified (None when no baseline was given).
        detail: what was flown (start, targets or waypoints, the user's mission and whether it is back).
        interrupted: the Ctrl-C that ended it (re-raise it once the flight is recorded), else None.
    """

    kind: str
    outcome: T
    message: str
    metrics: dict[str, float]
    started_at: float
    ended_at: float
    tlog: Path
    gains_label: str
    restored: bool | None
    detail: dict[str, Any] = field(default_factory=dict)
    interrupted: KeyboardInterrupt | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly (NaN figures stay NaN: write with :func:`ksbo_mav.jsonio.dumps`, which makes them null)."""
        return {"kind": self.kind, "outcome": str(self.outcome), "message": self.message, "metrics": self.metrics,
                "started_at": self.started_at, "ended_at": self.ended_at, "tlog": str(self.tlog),
                "gains_label": self.gains_label, "restored": self.restored, "detail": self.detail}


def fly_manoeuvre(vehicle: Vehicle, spec: ManoeuvreSpec, monitor: Monitor, *, gains_label: str, tlog_path: Path,
                  gains: np.ndarray | None = None, baseline_params: dict[str, float] | None = None,
                  start: np.ndarray | None = None, link_wait_s: float = 30.0,
                  log: Callable[[str], None] = lambda s: None) -> ManoeuvreFlight:
    """Fly ``spec`` from a hover on ``start`` in guided/offboard (:meth:`Vehicle.ensure_airborne` first: it takes
    off if needed, and refuses a vehicle a pilot has taken over).

    Args:
        monitor: the campaign's monitor (its limits; the expected mode follows the manoeuvre).
        gains_label: a short name of the gain set (first 16 characters go into the tlog marker).
        tlog_path: the flight's two-way tlog.
        gains: (d,) written (verified) before the flight, already checked against the trust region; None flies
            the gains on the vehicle.
        baseline_params: {autopilot parameter: value} restored (verified) after the flight however it ends.
        start: (3,) NED hover point the manoeuvre starts from (default: the profile's figure-8 start).

    :class:`~ksbo_mav.errors.InputError` (nothing flown) when the manoeuvre does not fit the monitor's box.
    """
    v = vehicle
    start = v.mission.start_ned() if start is None else np.asarray(start, float)
    spec.check_inside(start, monitor.limits)
    label = "".join(c for c in gains_label if not c.isspace())[:16]
    link = v.link
    link.tlog = TlogWriter(tlog_path)
    rec = ManoeuvreRecorder(vehicle=(link.target_system, link.target_component))
    link.taps.append(rec.feed)
    frame = ManoeuvreFrame(v, monitor, log)
    detail: dict[str, Any] = {"spec": spec.to_dict()}
    started = time.time()
    outcome, message, stop, restored = T.OK, "", None, None
    try:
        try:
            v.ensure_airborne(log, at=start)  # (PX4 parks in Hold after each flight: back to offboard)
            if v.guard is not None:  # armed before the gains change, as for a trial
                v.guard.arm_trial(v.stack.modes[m] for m in OWN_MODES[spec.kind])
            if gains is not None:
                v.write_gains(np.asarray(gains, float))
            _FLY[spec.kind](frame, spec, start, label, detail)
        except ManoeuvreAbort as a:
            outcome, message = T(a.outcome), a.message
        except VerifyError as exc:
            outcome, message = T.VERIFY, str(exc)
        except PilotTookOver as exc:
            outcome, message = T.PILOT, str(exc)
        except LinkLost as exc:
            outcome, message = T.LINK, str(exc)
        except KeyboardInterrupt as exc:
            outcome, message, stop = T.SIGINT, "interrupted by the user", exc
        except KsboError as exc:
            outcome, message = T.ERROR, str(exc)
        # The guard's watch ends before our own recovery; after a lost link, once the link is back.
        lost = outcome is T.LINK  # the tuner lost the vehicle (else the guard may have lost the tuner: classify)
        note, trip = end_watch(v) if not lost else ("", None)
        outcome, message = classify(v, outcome, message, trip)
        restored, problems = _finish(frame, outcome, baseline_params, link_wait_s)
        if outcome is T.LINK:
            if lost:
                note, trip = end_watch(v)
            problems += _take_back(v, trip, restored)
        problems = [note, *problems] if note else problems
        if problems:
            message = "; ".join([message, *problems]) if message else "; ".join(problems)
    finally:
        link.taps.remove(rec.feed)
        link.tlog.close()
        link.tlog = None
    metrics: dict[str, float] = {}
    if outcome is T.OK and rec.finished:
        metrics = rec.metrics()
    return ManoeuvreFlight(spec.kind, outcome, message, metrics, started, time.time(), Path(tlog_path), gains_label,
                           restored, detail, stop)


def _take_back(v: Vehicle, trip: GuardTrip | None, restored: bool | None) -> list[str]:
    """After a lost link, once the baseline is back: the vehicle the guard stopped back in GUIDED."""
    if restored is False:
        return []
    took = take_back(v, trip)
    return [took] if took else []


def _finish(frame: ManoeuvreFrame, outcome: T, baseline: dict[str, float] | None,
            link_wait_s: float) -> tuple[bool | None, list[str]]:
    """End marker, the vehicle held where it is (guided) when it is ours, the baseline restored and verified, the
    clean-ups, the park. Returns (restored, problems)."""
    v = frame.v
    g = v.guided
    problems: list[str] = []
    restored: bool | None = None if baseline is None else False
    try:
        if outcome is T.LINK:
            deadline = time.monotonic() + link_wait_s
            while v.link.heartbeat_age() > v.heartbeat_timeout and time.monotonic() < deadline:
                v.link.pump(0.2)
        if frame.started and not frame.ended:
            frame.marker(end_text(frame.now_ms(), str(outcome)))
            frame.ended = True
        elif frame.ended and outcome is not T.OK:  # the log says so too: `score` reads what the journal reads
            frame.marker(after_text(frame.now_ms(), str(outcome)))
        ours = outcome not in (T.PILOT, T.CRASH, T.LINK, T.FAILSAFE) and g.armed  # never override a failsafe
        if ours and outcome is not T.OK and g.position() is not None:
            frame.back_to_guided()  # stop where it is, out of the autopilot's own mode
        if baseline is not None:
            v.restore(baseline)
            restored = True
        problems += frame.run_after()
        if g.armed and g.in_mode("guided") and outcome is not T.FAILSAFE:
            g.park()
    except KeyboardInterrupt:
        problems.append("second Ctrl-C " + ("after the restore (baseline verified)" if restored else
                                            "during restore: baseline may not be restored"))
    except KsboError as exc:
        problems.append(f"after the restore (baseline verified): {exc}" if restored else f"restore failed: {exc}")
    if frame.after:  # the restore failed or was interrupted: the user's mission still goes back
        try:
            problems += frame.run_after()
        except KeyboardInterrupt:
            problems.append("second Ctrl-C: the clean-up after the flight did not finish")
    return restored, problems
