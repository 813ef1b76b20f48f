"""The campaign runner: connect, snapshot, baseline, prior, safe BO over flown trials, confirm, restore/accept,
land — journalled so that ``--resume`` loses and re-flies nothing.

Order of flights: the baseline gains first (the optimiser's first evaluation and, on 3-D copters, the reference
every score is measured against), then a flown prior if asked for, then the optimiser's trials, then the
confirmation flights of the recommendation. A trial that says nothing about the gains (pilot, link, telemetry,
a slow client) is journalled as ``failed`` and never given to the optimiser; the transient ones are flown again.

Each step lives in its own module: :mod:`~ksbo_mav.campaign.setup` (connect, baseline, snapshot),
:mod:`~ksbo_mav.campaign.trials` (the journalled trial loop with retries), :mod:`~ksbo_mav.campaign.search`
(the optimiser, with the journal replayed on resume), :mod:`~ksbo_mav.campaign.confirm`,
:mod:`~ksbo_mav.campaign.ending` (restore or accept, land or hold) and :mod:`~ksbo_mav.campaign.result`
(summary, plots, result.json); this module only orders them.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from ksbo_mav.campaign.battery import BatteryGuard, await_failsafe, failsafe_active, failsafe_message
from ksbo_mav.campaign.conditions import ConditionWatch
from ksbo_mav.campaign.drift import DriftWatch
from ksbo_mav.campaign.config import CampaignConfig, optimizer_options, prior_kind, with_profile_budget
from ksbo_mav.campaign.confirm import confirm_failures, fly_confirmations
from ksbo_mav.campaign.ending import end_flight, leave_gains, safe_stop
from ksbo_mav.campaign.journal import Journal
from ksbo_mav.campaign.layout import CampaignDir
from ksbo_mav.campaign.link_check import check_link, record_link
from ksbo_mav.campaign.plan import campaign_plan
from ksbo_mav.campaign.prior import campaign_prior
from ksbo_mav.campaign.report import write_report
from ksbo_mav.campaign.result import summarize, write_result
from ksbo_mav.campaign.resume import check_unchanged
from ksbo_mav.campaign.search import search
from ksbo_mav.campaign.setup import baseline_params, connect, create_campaign
from ksbo_mav.campaign.summary import CampaignSummary, TrialEvent
from ksbo_mav.campaign.trials import TrialLoop
from ksbo_mav.campaign.warm_start import Earlier, warm_search
from ksbo_mav.campaign.widen import widen_search
from ksbo_mav.errors import CampaignPaused, InputError, KsboError
from ksbo_mav.mav.approach import check_moving_start
from ksbo_mav.mav.gains import opt_bounds
from ksbo_mav.mav.link import Endpoint
from ksbo_mav.mav.monitor import limits_from_profile
from ksbo_mav.mav.objective import MavlinkObjective
from ksbo_mav.mav.snapshot import load_snapshot
from ksbo_mav.mav.vehicle import Vehicle


class Campaign:
    """One tuning campaign on one vehicle (``resume``: continue the one in ``cfg.dir``)."""

    def __init__(self, cfg: CampaignConfig, endpoint: Endpoint, *, resume: bool = False,
                 log: Callable[[str], None] = print, progress: Callable[[TrialEvent], None] | None = None,
                 connect_timeout: float = 15.0) -> None:
        self.cfg, self.endpoint, self.resume, self.log = cfg, endpoint, resume, log
        self.progress = progress or (lambda event: None)
        self.connect_timeout = connect_timeout
        self.dir = CampaignDir.at(cfg.dir)

    @property
    def resume_hint(self) -> str:
        ep = self.endpoint
        where = f"--{ep.kind} {ep.host}:{ep.port}" if ep.kind in ("udp", "udpout", "tcp") else f"--serial {ep.host}"
        return f"ksbo-mav tune --resume {self.dir.root} {where}"

    def _report_after_stop(self, v: Vehicle, log: Callable[[str], None]) -> None:
        """The report of a campaign stopped to be resumed (what was flown so far); a report that cannot be made is
        said, never an error on top of the stop."""
        if not self.dir.exists():
            return
        try:
            paths = write_report(self.dir, v.profile)
            if paths.get("page"):
                log(f"report: {paths['page']}")
        except Exception as exc:  # noqa: BLE001 - the stop's own message matters more
            log(f"report not written: {exc}")

    def _connect(self) -> Vehicle:
        v = connect(self.cfg, self.dir, self.endpoint, self.resume, self.connect_timeout, self.log)
        self.cfg = with_profile_budget(self.cfg, v.profile)  # the vehicle's profile is known from here on
        return v

    def dry_run(self) -> str:
        """Connect, print the plan, change nothing (and write nothing)."""
        if self.resume:
            check_unchanged(self.dir, self.cfg.profile, self.log)
        v = self._connect()
        try:
            base = baseline_params(v, self.dir, False, self.log) if not self.resume else \
                load_snapshot(self.dir.root).baseline()
            return campaign_plan(v, self.cfg, self.dir, base)
        finally:
            v.close()

    def run(self) -> CampaignSummary:
        from threadpoolctl import threadpool_limits

        cfg, log = self.cfg, self.log
        if not self.resume and self.dir.exists():
            raise InputError(f"{self.dir.root} already holds a campaign; use --resume {self.dir.root} or another "
                             "directory")
        if self.resume:
            check_unchanged(self.dir, cfg.profile, log)
        v = self._connect()
        cfg = self.cfg
        base: dict[str, float] | None = None
        try:
            if self.resume:  # the rate the campaign flies at (a thin link may have lowered it): the same again
                v.set_mission_rate(int(self.dir.read_settings().get("mission", {}).get("rate_hz",
                                                                                      v.mission.rate_hz)))
            elif cfg.rate_hz:
                v.set_mission_rate(cfg.rate_hz)
            # before anything is read for, or written to, the campaign
            link = check_link(v, log, reduce=not self.resume and not cfg.rate_hz)
            base = baseline_params(v, self.dir, self.resume, log)
            check_moving_start(v.mission, limits_from_profile(v.profile, cfg.safety))
            optimizer_options("none", cfg.options, cfg.method, v.profile)  # gain names: before flying
            if cfg.warm_start:
                Earlier(cfg.warm_start).check_matches(v)
            if not self.resume:
                create_campaign(self.dir, cfg, v, base, log)
            record_link(self.dir, link)
            x0 = v.gain_map.from_params(base)
            bounds = opt_bounds(v.profile, x0)
            journal = Journal(self.dir.journal)
            objective = MavlinkObjective(v, base, self.dir.trials, safety=cfg.safety, settle_s=cfg.settle_s,
                                         first_index=self.dir.next_trial_index(), start_seed=cfg.seed, log=log)
            trials = TrialLoop(objective, journal, self.progress, log, BatteryGuard(v, self.resume_hint))
            trials.drift = DriftWatch(every=cfg.baseline_every, on_drift=cfg.on_drift, resume_hint=self.resume_hint)
            trials.drift.restore(journal)
            trials.conditions = ConditionWatch(v)
            started = time.time()
            kind = prior_kind(cfg, v.profile)
            if cfg.prior == "auto" and journal.of("prior"):
                kind = "local"  # resumed from when "auto" meant a flown prior for this profile: it keeps it
            prior = None
            if kind == "sim" and not cfg.warm_start:  # simulated before takeoff: no hover spent waiting for it
                with threadpool_limits(1):
                    prior = campaign_prior(kind, cfg, self.dir, v.profile, x0, bounds, [], _flies_nothing, log)
            baseline_trial = trials.fly_baseline(x0)
            with threadpool_limits(1):
                if cfg.warm_start:
                    prior, result, unused, bounds = warm_search(trials, cfg, v, x0, log)
                else:
                    if kind != "sim":
                        prior = campaign_prior(kind, cfg, self.dir, v.profile, x0, bounds,
                                               [e.P for e in journal.of("prior")], lambda x: trials.fly(x, "prior").P,
                                               log)
                    result, unused = search(trials, cfg, x0, bounds, prior, self.resume, log)
                if cfg.widen or v.profile.trust_region.widen:
                    result, unused, bounds = widen_search(trials, cfg, v, self.dir, bounds, prior, result, unused, log)
            best = np.asarray(result.x, dtype=float)
            confirms = fly_confirmations(trials, best, cfg.confirm)
            wall_s = time.time() - started
            best_params = v.gain_map.to_params(best)
            failures = confirm_failures(journal.of("confirm"))
            accepted = leave_gains(v, self.dir, cfg.accept, base, best_params, failures, log)
            on_vehicle = {n: v.params.table[n].value for n in base}
            ended = end_flight(v, cfg.end, False, log)
            summary = summarize(journal, result, baseline_x=x0, base=base, baseline_trial=baseline_trial,
                                best_params=best_params, confirms=confirms, failures=failures, unused=unused,
                                accepted=accepted, accept=cfg.accept, on_vehicle=on_vehicle, method=cfg.method,
                                wall_s=wall_s, d=self.dir, ended=ended)
            write_result(self.dir, summary, v.profile, log)
            return summary
        except (KeyboardInterrupt, KsboError) as exc:
            flight = getattr(exc, "flight", None)
            failsafe = failsafe_active(v) or (flight is not None and flight.outcome == "failsafe")
            if base is not None and not isinstance(exc, InputError):
                safe_stop(v, base, str(self.dir.root), log)
            if failsafe:
                await_failsafe(v, log)  # the autopilot's RTL / LAND is never overridden
            else:
                end_flight(v, cfg.end, True, log)
            if failsafe or isinstance(exc, CampaignPaused):
                self._report_after_stop(v, log)
                if failsafe:
                    trial = flight.meta.get("trial") if flight is not None else None
                    raise CampaignPaused(failsafe_message(v, trial, self.resume_hint)) from None
            raise
        finally:
            v.close()


def _flies_nothing(_x: np.ndarray) -> float:
    raise AssertionError("a simulator prior flies no trial")
