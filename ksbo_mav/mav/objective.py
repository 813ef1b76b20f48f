"""The vehicle behind the objective interface: ``MavlinkObjective.fly(gains) -> Flight``.

One trial = hover at the figure-8 start with the baseline gains, write the trial gains (verified), settle, fly the
figure-8 with the monitor watching every sample, then restore the baseline (verified by a fresh read) before
anything else happens. With a moving start (``[mission] start_speed_mps``, :mod:`ksbo_mav.mav.approach`) the hover
is short of the start and the trial's gains fly a monitored approach that passes the start at the trial's random
velocity as the figure-8 begins. With ``trial_step`` a monitored position step follows the figure-8
(:mod:`ksbo_mav.mav.trial_step`). Every trial leaves a two-way tlog and a JSON record next to it; its score is
computed from exactly what the tlog holds (:mod:`ksbo_mav.mav.trajectory`), so ``ksbo-mav score`` reproduces it.

The three jobs of a trial live in three places: flying it (:class:`~ksbo_mav.mav.trial_flight.TrialFlight`),
scoring it (:func:`~ksbo_mav.mav.trial_record.score_trial`) and recording it
(:func:`~ksbo_mav.mav.trial_record.write_record`); this module only orders them and decides what stops a campaign.

Aborts: gain-caused (geofence, tilt, tracking error, crash) -> hold, restore, the trial scores as unsafe and the
campaign goes on (a crashed *simulator* is re-armed; a crashed real vehicle stops the campaign). Pilot mode change,
link loss, telemetry too sparse to score, a failed parameter write, Ctrl-C, unexpected errors -> restore and stop:
:class:`~ksbo_mav.errors.TrialStopped` (or, for Ctrl-C, :class:`~ksbo_mav.errors.TrialInterrupted`) is raised after
the trial's record is written, carrying it; such a trial says nothing about the gains and the campaign never feeds
it to the optimiser. Failing to get ready (arming, takeoff, reaching the start) raises
:class:`~ksbo_mav.errors.PreflightError` before any trial is recorded.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ksbo_mav.errors import LinkLost, PilotTookOver, PreflightError, TrialInterrupted, TrialStopped, VehicleError
from ksbo_mav.mav.approach import Approach, check_moving_start, start_velocity, stress_velocity
from ksbo_mav.mav.monitor import Monitor, limits_from_profile
from ksbo_mav.mav.outcome import TrialOutcome as T
from ksbo_mav.mav.trial_flight import TrialFlight
from ksbo_mav.mav.trial_record import score_trial, write_record
from ksbo_mav.mav.trial_step import TrialStep
from ksbo_mav.mav.vehicle import Vehicle
from ksbo_task.flight import Flight


class MavlinkObjective:
    """Fly gain vectors on a connected :class:`Vehicle`.

    Args:
        vehicle: connected vehicle.
        baseline_params: {autopilot parameter name: value} restored after every trial (the snapshot's values).
        out_dir: where ``trial_NNN.tlog`` / ``.json`` go.
        safety: overrides of the profile's ``[safety]`` thresholds (``x_max_m`` ...).
        settle_s: hover time with the trial gains before the figure-8 starts, and holding its end point after it
            (monitored; then the baseline is restored).
        link_wait_s: after a link loss, how long to wait for the vehicle to come back to restore the baseline.
        first_index: number of the next trial (a resumed campaign continues its numbering).
        start_seed: seed of the moving starts' random velocities (with the trial number; missions with
            ``start_speed`` only).
        trial_step: every trial flies the profile's position step after its figure-8; a lean past the step's tilt
            limit aborts it (:mod:`ksbo_mav.mav.trial_step`).
    """

    def __init__(self, vehicle: Vehicle, baseline_params: dict[str, float], out_dir: str | Path, *,
                 safety: dict[str, float] | None = None, settle_s: float = 1.0, link_wait_s: float = 30.0,
                 first_index: int = 0, start_seed: int = 0, trial_step: bool = False,
                 log: Callable[[str], None] = lambda s: None) -> None:
        self.vehicle = vehicle
        self.profile = vehicle.profile
        self.baseline_gains = vehicle.gain_map.from_params(baseline_params)
        self.out_dir = Path(out_dir)
        self.mission = vehicle.mission
        self.monitor = Monitor(limits_from_profile(self.profile, safety), vehicle.stack.modes["guided"],
                               vehicle.stack.mode_name)
        check_moving_start(self.mission, self.monitor.limits)
        self.trial_flight = TrialFlight(vehicle, self.monitor, baseline_params, settle_s=settle_s,
                                        link_wait_s=link_wait_s, log=log)
        if trial_step:
            step = self.trial_flight.step = TrialStep.from_profile(self.profile, self.monitor.limits)
            log(f"trials: each figure-8 followed by a {float(sum(v * v for v in step.offset_ned)) ** 0.5:g} m "
                f"position step (no feed-forward), aborted past {step.tilt_max_deg:g} deg of lean")
        #: Number of the next trial.
        self.index = first_index
        self.start_seed = start_seed
        self.log = log
        #: 3-D missions: the baseline flight's lap-2 RMS; every trial's P is relative to it (Mission.score).
        self.rms_ref: float | None = None
        self.rough_ref: float | None = None  # the baseline's roughness (deg/s), for the score's smoothness term

    def __call__(self, x: np.ndarray) -> float:
        return self.fly(x).P

    def fly(self, gains: np.ndarray, label: str = "", stress: bool = False) -> Flight:
        """Fly one trial (with ``stress`` from the hardest start, :func:`~ksbo_mav.mav.approach.stress_velocity`,
        instead of the trial's random one). :class:`PreflightError` (nothing flown, nothing recorded) when the
        vehicle cannot be brought to the figure-8 start; :class:`TrialStopped` after a trial that must end the
        campaign, :class:`TrialInterrupted` after one ended by Ctrl-C (both carry the recorded trial)."""
        v = self.vehicle
        x = v.check_trial_gains(gains, self.baseline_gains)
        m = self.mission
        u = (stress_velocity(m.kind, m.start_speed) if stress
             else start_velocity(m.kind, m.start_speed, self.start_seed, self.index))
        approach = Approach(m.start_ned(), u, m.dt)
        try:
            v.ensure_airborne(self.log, at=approach.begin)
        except (PreflightError, PilotTookOver, LinkLost):  # a lost link: a pause for the campaign (exit 3)
            raise
        except VehicleError as exc:  # trouble while getting ready is not the gains' fault either
            raise PreflightError(str(exc)) from None
        i, self.index = self.index, self.index + 1
        stem = self.out_dir / f"trial_{i:03d}"
        started = time.time()
        flown = self.trial_flight.fly(x, approach, stem.with_suffix(".tlog"), self.rms_ref,
                                       self.rough_ref)
        scored = score_trial(m, flown)
        flight = write_record(stem, i, label, x, self.profile.names, v.gain_map.to_params(x), flown, scored, started,
                              {"start_velocity_ned": approach.velocity.tolist(), "stress_start": stress,
                               **({"step": flown.step} if flown.step is not None else {})})
        outcome = flight.outcome
        if outcome is not T.OK:
            self.log(f"trial {i} aborted ({outcome.text}): {scored.message}")
        if flown.interrupted is not None:
            raise TrialInterrupted(flight)
        if not flown.restored:
            raise TrialStopped(f"trial {i}: {scored.message or outcome.text}; baseline NOT "
                               "restored - run `ksbo-mav restore` with the snapshot as soon as the vehicle is "
                               "reachable", flight)
        if not outcome.continues or (outcome is T.CRASH and not v.is_sim):
            # A lost link that came back, the baseline verified and the vehicle in GUIDED again: fly it again.
            raise TrialStopped(f"trial {i} aborted ({outcome.text}): {scored.message}; "
                               "baseline gains restored and verified", flight,
                               retry=outcome.retry or (outcome is T.LINK and flown.link_back))
        return flight
