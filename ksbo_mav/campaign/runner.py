"""The campaign runner: connect, snapshot, baseline, prior, safe BO over flown trials, confirm, restore/accept,
land — journalled so that ``--resume`` loses and re-flies nothing.

Order of flights: the baseline gains first (the optimiser's first evaluation and, on 3-D copters, the reference
every score is measured against), then a flown prior if asked for, then the optimiser's trials, then the
confirmation flights of the recommendation. A trial that says nothing about the gains (pilot, link, telemetry,
a slow client) is journalled as ``failed`` and never given to the optimiser; the transient ones are flown again.

Each step lives in its own module: :mod:`~ksbo_mav.campaign.setup` (connect, baseline, snapshot),
:mod:`~ksbo_mav.campaign.mission_rate` (the mission rate the link carries),
:mod:`~ksbo_mav.campaign.trials` (the journalled trial loop with retries), :mod:`~ksbo_mav.campaign.search`
(the optimiser and its later stages, with the journal replayed on resume), :mod:`~ksbo_mav.campaign.ending`
(confirmation flights, restore or accept, land or hold, result.json) and :mod:`~ksbo_mav.campaign.report`
(the report page and its plots); this module only orders them.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ksbo_mav.campaign.battery import BatteryGuard, await_failsafe, failsafe_active, failsafe_message
from ksbo_mav.campaign.drift import ConditionWatch, DriftWatch
from ksbo_mav.campaign.config import CampaignConfig, MissionRate, optimizer_options, prior_kind, settle
from ksbo_mav.campaign.ending import (confirm_failures, end_flight, export_recommended, fly_confirmations,
                                      landed_by_itself, leave_gains, rewrite_report, safe_stop, write_result)
from ksbo_mav.campaign.journal import Journal
from ksbo_mav.campaign.layout import CampaignDir
from ksbo_mav.campaign.link_loss_policy import LinkLossChoice, check_link_loss
from ksbo_mav.campaign.mission_rate import fly_at, record_link
from ksbo_mav.campaign.plan import campaign_plan
from ksbo_mav.campaign.prior import campaign_prior
from ksbo_mav.campaign.resume import check_unchanged
from ksbo_mav.campaign.search import search
from ksbo_mav.campaign.onboard import install_guard, remove_guard
from ksbo_mav.campaign.setup import baseline_params, connect, create_campaign
from ksbo_mav.campaign.stops import EXIT, clear_stop, continue_command, next_phase, set_validation_state, write_stop
from ksbo_mav.campaign.summary import CampaignSummary, TrialEvent, summarize
from ksbo_mav.campaign.trials import TrialLoop
from ksbo_mav.campaign.validation_session import check_validation, validate_after_tune
from ksbo_mav.campaign.warm_start import Earlier, warm_search
from ksbo_mav.campaign.wind_preflight import apply_wind_plan
from ksbo_mav.errors import CampaignPaused, InputError, KsboError, LinkLost
from ksbo_mav.mav.approach import check_moving_start
from ksbo_mav.mav.gains import opt_bounds
from ksbo_mav.mav.link import Endpoint
from ksbo_mav.mav.linkcheck import LinkFigures
from ksbo_mav.mav.monitor import limits_from_profile
from ksbo_mav.mav.objective import MavlinkObjective
from ksbo_mav.mav.params import load_snapshot
from ksbo_mav.mav.vehicle import Vehicle


@dataclass(frozen=True)
class Policy:
    """What the flying will do, decided before it starts."""

    prior: str  # the prior's kind: "sim", "local" or "none"
    prior_on_ground: bool  # simulator episodes, computed before takeoff: no hover spent waiting for them
    warm: bool  # start from an earlier campaign (its flights are the prior)


class Campaign:
    """One tuning campaign on one vehicle (``resume``: continue the one in ``cfg.dir``). ``on_settled`` hears the
    settings once the vehicle's profile has decided the rest of them (the budget), before anything is flown."""

    def __init__(self, cfg: CampaignConfig, endpoint: Endpoint, *, resume: bool = False,
                 log: Callable[[str], None] = print, progress: Callable[[TrialEvent], None] | None = None,
                 connect_timeout: float = 15.0, on_settled: Callable[[CampaignConfig], None] | None = None,
                 link_loss: LinkLossChoice = LinkLossChoice()) -> None:
        self.cfg, self.endpoint, self.resume, self.log = cfg, endpoint, resume, log
        self.link_loss = link_loss  # the pilot's say on a link a loss of which leaves trial gains flying (PX4)
        self.on_link_loss: str | None = None  # what the vehicle does then, once read from it
        self.progress = progress or (lambda event: None)
        self.on_settled = on_settled or (lambda cfg: None)
        self.connect_timeout = connect_timeout
        self.dir = CampaignDir.at(cfg.dir)
        self.rate: MissionRate | None = None  # decided by settle() once connected
        self.base: dict[str, float] | None = None  # the baseline parameters, once read from the vehicle

    @property
    def resume_hint(self) -> str:
        return continue_command(self.dir, self.endpoint, "tune")

    def dry_run(self) -> str:
        """Connect, print the plan, change nothing (and write nothing)."""
        v = self._connect()
        try:
            base = baseline_params(v, self.dir, False, self.log) if not self.resume else \
                load_snapshot(self.dir.root).baseline()
            check_link_loss(v, self.link_loss, self.log)
            return campaign_plan(v, self.cfg, self.dir, base)
        finally:
            v.close()

    def run(self) -> CampaignSummary:
        """Connect and settle the settings, preflight (mission rate and link, baseline, checks), record the
        campaign, fly it (prior, baseline, search, confirmation) and end it (gains, landing, result). A stop on the
        way restores the baseline and lands, or leaves a failsafe to the autopilot, and leaves the report of what was
        flown with the command that continues (:mod:`~ksbo_mav.campaign.stops`); an unexpected error too, as one
        line (its traceback in ``stopped.json``)."""
        if not self.resume and self.dir.exists():
            raise InputError(f"{self.dir.root} already holds a campaign; use --resume {self.dir.root} or another "
                             "directory")
        v = self._connect()
        try:
            link = self._preflight(v)
            self._record(v, link)
            # After the snapshot (it holds MAV_GCS_SYSID as found), before the first trial.
            install_guard(v, self.cfg.onboard_guard, self.base, self.cfg.safety, self.log,
                          on_board=self.cfg.trial_source == "onboard")
            return self._fly(v)
        except (KeyboardInterrupt, KsboError) as exc:
            self._stop(v, exc)
            raise
        except Exception as exc:  # a bug: the vehicle made safe and the flights kept all the same
            import traceback

            self._stop(v, exc, traceback.format_exc())
            raise KsboError(f"unexpected error: {type(exc).__name__}: {exc} (the traceback is in "
                            f"{self.dir.stopped}; please report it)") from exc
        finally:
            remove_guard(v, self.log)
            v.close()

    def _connect(self) -> Vehicle:
        """A resume's profile checked unchanged, the vehicle connected, and the settings that depend on it settled."""
        if self.resume:
            check_unchanged(self.dir, self.cfg.profile, self.log)
        v = connect(self.cfg, self.dir, self.endpoint, self.resume, self.connect_timeout, self.log)
        try:
            self.cfg, self.rate = settle(self.cfg, v.profile, self.dir.read_settings() if self.resume else None)
            self.cfg = apply_wind_plan(self.cfg, v, self.log)  # the day's wind, before anything flies
            self.on_settled(self.cfg)
        except BaseException:
            v.close()
            raise
        return v

    def _preflight(self, v: Vehicle) -> LinkFigures:
        """Everything checked before anything is written to the campaign: the mission rate the link carries, the
        baseline gains (a resume restores them), a start the monitor accepts, the options' gain names, a warm
        start's match. Returns the link's figures."""
        assert self.rate is not None
        link = fly_at(v, self.rate, self.log)
        self.on_link_loss = check_link_loss(v, self.link_loss, self.log)
        self.base = baseline_params(v, self.dir, self.resume, self.log)
        check_moving_start(v.mission, limits_from_profile(v.profile, self.cfg.safety))
        optimizer_options("none", self.cfg.options, self.cfg.method, v.profile)  # gain names: before flying
        check_validation(v, self.cfg)  # the validation manoeuvres fit the box: known before the tune
        if self.cfg.warm_start:
            Earlier(self.cfg.warm_start).check_matches(v)
        return link

    def _record(self, v: Vehicle, link: LinkFigures) -> None:
        """A new campaign's snapshot and settings (the directory exists from here on); the link's figures."""
        if not self.resume:
            create_campaign(self.dir, self.cfg, v, self.base, self.log)
        record_link(self.dir, link, self.on_link_loss)

    def _trials(self, v: Vehicle) -> TrialLoop:
        """The journalled trial loop with its watches (battery, drift, flight conditions)."""
        cfg = self.cfg
        journal = Journal(self.dir.journal)
        objective = MavlinkObjective(v, self.base, self.dir.trials, safety=cfg.safety, settle_s=cfg.settle_s,
                                     first_index=self.dir.next_trial_index(), start_seed=cfg.seed,
                                     trial_step=bool(cfg.trial_step), log=self.log)
        trials = TrialLoop(objective, journal, self.progress, self.log, BatteryGuard(v, self.resume_hint))
        trials.drift = DriftWatch(every=cfg.baseline_every, on_drift=cfg.on_drift, resume_hint=self.resume_hint)
        trials.drift.restore(journal)
        trials.conditions = ConditionWatch(v)
        return trials

    def _policy(self, v: Vehicle, journal: Journal) -> Policy:
        cfg = self.cfg
        kind = prior_kind(cfg, v.profile)
        if cfg.prior == "auto" and journal.of("prior"):
            kind = "local"  # resumed from when "auto" meant a flown prior for this profile: it keeps it
        warm = bool(cfg.warm_start)
        return Policy(prior=kind, prior_on_ground=kind == "sim" and not warm, warm=warm)

    def _fly(self, v: Vehicle) -> CampaignSummary:
        from threadpoolctl import threadpool_limits

        cfg, log = self.cfg, self.log
        clear_stop(self.dir)  # flying again: an earlier stop's record is history
        x0 = v.gain_map.from_params(self.base)
        bounds = opt_bounds(v.profile, x0)
        trials = self._trials(v)
        policy = self._policy(v, trials.journal)
        started = time.time()
        prior = None
        if policy.prior_on_ground:
            with threadpool_limits(1):
                prior = campaign_prior(policy.prior, cfg, self.dir, v.profile, x0, bounds, [], _flies_nothing, log)
        baseline_trial = trials.fly_baseline(x0)
        with threadpool_limits(1):
            result, unused = self._search(v, trials, policy, x0, bounds, prior)
        return self._end(v, trials, result, unused, x0, baseline_trial, started)

    def _search(self, v: Vehicle, trials: TrialLoop, policy: Policy, x0: np.ndarray, bounds: np.ndarray,
                prior: Any) -> tuple[Any, Any]:
        """The optimiser's trials (a flown prior first; from an earlier campaign's with a warm start)."""
        cfg, log = self.cfg, self.log
        if policy.warm:
            prior, result, unused = warm_search(trials, cfg, v, x0, log)
        else:
            if not policy.prior_on_ground:
                prior = campaign_prior(policy.prior, cfg, self.dir, v.profile, x0, bounds,
                                       [e.P for e in trials.journal.of("prior")], lambda x: trials.fly(x, "prior").P,
                                       log)
            result, unused = search(trials, cfg, x0, bounds, prior, self.resume, log)
        return result, unused

    def _end(self, v: Vehicle, trials: TrialLoop, result: Any, unused: Any, x0: np.ndarray, baseline_trial: Any,
             started: float) -> CampaignSummary:
        """Confirm the recommendation and write the tune's result (result.json, the report, the recommendation
        exported) before any validation flight; then the validation, the gains left (restored, or accepted), land or
        hold, and the result written again with the validation's state."""
        cfg, log, base, journal = self.cfg, self.log, self.base, trials.journal
        best = np.asarray(result.x, dtype=float)
        confirms = fly_confirmations(trials, best, cfg.confirm)
        wall_s = time.time() - started
        best_params = v.gain_map.to_params(best)
        failures = confirm_failures(journal.of("confirm"))
        command = continue_command(self.dir, self.endpoint, "validation")

        def summary(accepted: bool, ended: str, validation: dict[str, Any]) -> CampaignSummary:
            s = summarize(journal, result, baseline_x=x0, base=base, baseline_trial=baseline_trial,
                          best_params=best_params, confirms=confirms, failures=failures, unused=unused,
                          accepted=accepted, accept=cfg.accept, on_vehicle={n: v.params.table[n].value for n in base},
                          method=cfg.method, wall_s=wall_s, d=self.dir, ended=ended)
            s.validation = validation
            return s

        export_recommended(self.dir, best_params, v)
        write_result(self.dir, summary(False, "", {"state": "pending", "command": command}), v.profile, log)
        log(f"tuned: the result is on disk ({self.dir.result}, the report, {self.dir.recommended_stem}.param) before "
            "the validation flights")
        checked = validate_after_tune(v, self.dir, cfg, base, trials, x0, best, failures, command, log)
        accepted = leave_gains(v, self.dir, cfg.accept, base, best_params, failures + checked.refusals(), log)
        s = summary(accepted, end_flight(v, cfg.end, False, log), checked.state(command))
        if cfg.accept and not accepted:  # the validation's refusal too, not only a failed confirmation
            s.accept_refused = "; ".join(failures + checked.refusals())
        write_result(self.dir, s, v.profile, log)
        clear_stop(self.dir)
        return s

    def _stop(self, v: Vehicle, exc: BaseException, traceback: str = "") -> None:
        """A campaign stopped on the way: the baseline gains back, and landed — unless the autopilot's failsafe
        flies the vehicle (never overridden: a resumable pause) or it landed by itself while the link was down (a
        pause too); then the stop recorded with the command that continues, and the report of what was flown."""
        log = self.log
        flight = getattr(exc, "flight", None)
        landed = landed_by_itself(v, flight)  # (before our own landing below)
        failsafe = failsafe_active(v) or (flight is not None and flight.outcome == "failsafe")
        if self.base is not None and not isinstance(exc, InputError):
            safe_stop(v, self.base, str(self.dir.root), log)
        if failsafe:
            await_failsafe(v, log)
        else:
            end_flight(v, self.cfg.end, True, log)
        if not self.dir.exists() or isinstance(exc, InputError):  # refused before anything flew: nothing to continue
            return
        phase = next_phase(self.dir) or "tune"
        command = continue_command(self.dir, self.endpoint, phase)
        paused: CampaignPaused | None = None
        if failsafe:
            trial = flight.meta.get("trial") if flight is not None else None
            paused = CampaignPaused(failsafe_message(v, trial, command))
        elif landed:
            paused = CampaignPaused(f"{exc}; {landed}; the campaign goes on with `{command}`")
        elif isinstance(exc, LinkLost):  # outside a trial (a takeoff, a landing): the link's doing, not the tool's
            paused = CampaignPaused(f"{exc} (the link, outside a trial); the campaign goes on with `{command}` once "
                                    "the link is back")
        why = str(paused or exc) or "interrupted (Ctrl-C)"
        status = EXIT["paused"] if paused is not None or isinstance(exc, CampaignPaused) else \
            EXIT["interrupted"] if isinstance(exc, KeyboardInterrupt) else EXIT["error"]
        if phase == "validation":
            set_validation_state(self.dir, {"state": "incomplete", "reason": f"stopped: {why}", "command": command})
        write_stop(self.dir, why, command, phase, status, traceback)
        rewrite_report(self.dir, v.profile, log, draw=False)
        log(f"stopped: `{command}` continues")
        if paused is not None:
            raise paused from None


def _flies_nothing(_x: np.ndarray) -> float:
    raise AssertionError("a simulator prior flies no trial")
