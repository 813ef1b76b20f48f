"""The trial loop of a campaign: every flown trial journalled before anyone sees its value, trials spoiled by this
computer or the link flown again, and the baseline flight every score is measured against."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from ksbo_mav.campaign.battery import BatteryGuard
from ksbo_mav.campaign.drift import ConditionWatch, DriftWatch, save_drift
from ksbo_mav.campaign.journal import Journal, JournalEntry
from ksbo_mav.campaign.layout import CampaignDir
from ksbo_mav.campaign.summary import TrialEvent
from ksbo_mav.errors import CampaignPaused, PreflightError, TrialInterrupted, TrialStopped, VehicleError
from ksbo_mav.mav.objective import MavlinkObjective
from ksbo_mav.opt.evaluation import Evaluation
from ksbo_task.flight import Flight

#: How often a trial spoiled by this computer or the link (TrialOutcome.retry) is flown again.
RETRIES = 2


class TrialLoop:
    """Flies trials through ``objective`` and journals each one; ``progress`` hears of every journalled trial."""

    def __init__(self, objective: MavlinkObjective, journal: Journal, progress: Callable[[TrialEvent], None],
                 log: Callable[[str], None], guard: BatteryGuard | None = None) -> None:
        self.objective, self.journal, self.progress, self.log = objective, journal, progress, log
        self.guard = guard  # refuses a trial the pack would not fit (CampaignPaused), reports its use
        self.drift: DriftWatch | None = None  # baseline re-flights at a cadence and the drift test on them
        self.x0: np.ndarray | None = None
        self.conditions: ConditionWatch | None = None  # wind, voltage and flight index with each entry
        self.check_on_resume = False  # a resumed campaign re-flies the baseline before its next trial

    @property
    def _dir(self) -> CampaignDir:
        """The campaign directory (the objective writes its trial files into its ``trials`` folder)."""
        return CampaignDir(self.objective.out_dir.parent)

    def fly(self, x: np.ndarray, kind: str, stress: bool = False) -> Flight:
        """One trial of journal ``kind``, journalled; flown again (up to :data:`RETRIES` times) when this computer
        or the link spoiled it. :class:`TrialStopped` for a trial that must end the campaign."""
        if self.check_on_resume and kind != "baseline":
            self.check_on_resume = False
            self._check_vehicle("resume: the baseline gains again (the vehicle after the stop: is it the one the "
                                "campaign started with?)")
        elif kind in ("opt", "prior") and self.drift is not None and self.x0 is not None \
                and self.drift.due(self.journal):
            self._check_vehicle("trial: the baseline gains again (is the vehicle still the one the campaign started "
                                "with?)")
        for attempt in range(RETRIES + 1):
            if self.guard is not None:
                self.guard.before_trial()
            try:
                return self._fly_once(x, kind, stress)
            except TrialStopped as exc:
                if not exc.retry or attempt == RETRIES:
                    raise
                self.log(f"trial {exc.flight.meta['trial']} not counted ({exc.flight.meta['message']}); "
                         "flying it again")
        raise AssertionError("unreachable")

    def _fly_once(self, x: np.ndarray, kind: str, stress: bool) -> Flight:
        journal = self.journal
        if self.conditions is not None:
            self.conditions.start()
        try:
            f = self.objective.fly(x, label=kind, stress=stress)
        except (TrialStopped, TrialInterrupted) as exc:
            f = exc.flight
            if not journal.has_trial(f.meta["trial"]):
                # A crash of a real vehicle is the gains' doing; anything else that stops a trial (a failsafe, the
                # pilot, the link) is not: recorded as interrupted, never given to the optimiser.
                journal.append(self._entry(kind if f.outcome == "crash" else "failed", f))
            raise
        journal.append(self._entry(kind, f))
        self.progress(TrialEvent.of(kind, f, journal, self.x0))
        line = self.guard.after_trial() if self.guard is not None else None
        if line:
            self.log(line)
        return f

    def _entry(self, kind: str, f: Flight) -> JournalEntry:
        e = JournalEntry.of(kind, f)
        cond = self.conditions.take(len(self.journal.entries), CampaignDir.tlog_of(f.meta["record"])) \
            if self.conditions is not None else {}
        drift = self.drift
        if kind == "opt" and drift is not None and drift.ref is not None:  # scored in the same condition
            cond["P_corrected"] = drift.corrected(self.journal, f.P, f.score.get("rms_lap2_m"),
                                                  float(f.score.get("unsafe_rms_ratio", 2.0)),
                                                  float(f.score.get("smooth_penalty") or 0.0))
            cond["ref_trial"] = drift.ref.trial
        return replace(e, cond=cond or None)

    def evaluate(self, x: np.ndarray, stress: bool = False) -> Evaluation:
        """An optimiser evaluation: a flown trial, with the monitor's aborts and crashes as censored outcomes
        (``stress``: from the hardest start, for the re-fly phase's ``refly_stress``)."""
        try:
            f = self.fly(x, "opt", stress)
        except PreflightError as exc:
            self._gains_or_vehicle(exc)
            raise
        return Evaluation(self.journal.entries[-1].scored, f.outcome.evaluation)

    def _check_vehicle(self, why: str) -> None:
        """A baseline re-flight and the drift test on it: a change is confirmed by flying the baseline again at
        once; then stop mode stops (CampaignPaused) and continue mode scores against the newest re-flight."""
        drift = self.drift
        assert drift is not None
        self.log(why)
        self._refly_baseline()
        if not drift.fired and drift.shows_change(self.journal):  # once fired (continue mode): a new reference
            self.log("the baseline flew worse than at the start: flying it again at once to tell noise from a "
                     "changed vehicle")
            self._refly_baseline()
            try:
                drift.confirm(self.journal)  # CampaignPaused (stop mode) when the vehicle changed
            except CampaignPaused:
                save_drift(self._dir, drift.message(self.journal), drift.on_drift)
                raise
            if drift.fired:  # continue mode, fired just now
                save_drift(self._dir, drift.fired, drift.on_drift)
                self.log(f"{drift.fired}; continuing with every trial scored against the baseline as re-flown, "
                         "carried along its trend")
        if drift.fired:
            drift.follow(self.journal)

    def _gains_or_vehicle(self, exc: PreflightError) -> None:
        """A trial's gains could not bring the vehicle to the mission's start: the baseline flies at once, and a
        baseline that cannot either, or tracks worse than at the start (confirmed), is a changed vehicle
        (CampaignPaused); otherwise the error stands."""
        drift = self.drift
        if drift is None or self.x0 is None or drift.every <= 0:
            return
        self.log(f"{exc}: flying the baseline gains at once (the gains, or the vehicle?)")
        self._refly_baseline()
        if drift.shows_change(self.journal):
            self._refly_baseline()
            if drift.shows_change(self.journal):
                raise self._stop_changed(drift.message(self.journal)) from exc

    def _refly_baseline(self) -> None:
        """A baseline re-flight. Gains that flew the mission at the start and now cannot reach its start are a
        changed vehicle, not a gain failure: the campaign stops (CampaignPaused) in either drift mode."""
        try:
            self.fly(self.x0, "baseline")
        except PreflightError as exc:
            assert self.drift is not None
            raise self._stop_changed(self.drift.unflyable(self.journal, str(exc))) from None

    def _stop_changed(self, msg: str) -> CampaignPaused:
        """The stop for a changed vehicle (either drift mode), its message kept with the campaign for the report."""
        assert self.drift is not None
        save_drift(self._dir, msg, "stop")
        return self.drift.paused(msg)

    def fly_baseline(self, x0: np.ndarray) -> int:
        """Fly the baseline gains first (answered from the journal when the optimiser asks for x0): every 3-D
        score is relative to this flight's tracking (:meth:`ksbo_mav.mav.mission.Mission.score`). Returns its
        trial number; VehicleError if the baseline flew unsafe."""
        self.x0 = np.asarray(x0, dtype=float)
        opt = self.journal.of("opt")
        resumed = bool(opt)
        if not opt:
            self.log("trial: baseline gains (the reference every score is measured against)")
            f = self.fly(x0, "opt")
            opt = self.journal.of("opt")
            if f.P < 0 or f.outcome != "ok":
                raise VehicleError(f"the baseline gains flew unsafe (P = {f.P:.3f}, {f.outcome.text}: "
                                   f"{f.meta.get('message') or 'see the trial record'}); safe BO needs a safe start: "
                                   "fix the gains or the mission/safety settings first (baseline restored)")
        if self.objective.mission.kind != "figure8-xz":
            self.objective.rms_ref, self.objective.rough_ref = opt[0].rms, opt[0].rough
        # A resumed campaign: after a stop (a pack swap, a check of the vehicle) the vehicle is not known to answer
        # as it did; the baseline flies before the next trial (none when nothing is left to fly), tested like a
        # re-flight at the cadence.
        self.check_on_resume = resumed and self.drift is not None and self.drift.every > 0
        return opt[0].trial
