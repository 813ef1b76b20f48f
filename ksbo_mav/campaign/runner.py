"""The campaign runner: connect, snapshot, baseline, prior, safe BO over flown trials, confirm, restore/accept,
land — journalled so that ``--resume`` loses and re-flies nothing.

Order of flights: the baseline gains first (the optimiser's first evaluation and, on 3-D copters, the reference
every score is measured against), then a flown prior if asked for, then the optimiser's trials, then the
confirmation flights of the recommendation. A trial that says nothing about the gains (pilot, link, telemetry,
a slow client) is journalled as ``failed`` and never given to the optimiser; the transient ones are flown again.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from ksbo_mav.campaign.access import check_identity, confirm_failures, write_accepted
from ksbo_mav.campaign.config import CampaignConfig, optimizer_options, profile_defaults
from ksbo_mav.campaign.ending import end_flight, safe_stop
from ksbo_mav.campaign.journal import Journal, JournalEntry
from ksbo_mav.campaign.layout import CampaignDir
from ksbo_mav.campaign.plan import flight_plan
from ksbo_mav.campaign.prior import campaign_prior
from ksbo_mav.campaign.replay import JournalReplay
from ksbo_mav.campaign.resume import check_unchanged
from ksbo_mav.campaign.summary import CampaignSummary, TrialEvent
from ksbo_mav.errors import InputError, KsboError, UnsafeStartError, VehicleError
from ksbo_mav.mav.approach import check_moving_start, moving_starts
from ksbo_mav.mav.gains import opt_bounds
from ksbo_mav.mav.link import Endpoint
from ksbo_mav.mav.monitor import limits_from_profile
from ksbo_mav.mav.objective import MavlinkObjective, TrialStopped
from ksbo_mav.mav.snapshot import fsync_write, load_snapshot, write_snapshot
from ksbo_mav.mav.vehicle import Vehicle
from ksbo_mav.objective import Flight
from ksbo_mav.opt.outcome import Evaluation

#: How often a trial spoiled by this computer or the link (TrialOutcome.retry) is flown again.
RETRIES = 2


class Campaign:
    """One tuning campaign on one vehicle (``resume``: continue the one in ``cfg.dir``)."""

    def __init__(self, cfg: CampaignConfig, endpoint: Endpoint, *, resume: bool = False,
                 log: Callable[[str], None] = print, progress: Callable[[TrialEvent], None] | None = None,
                 connect_timeout: float = 15.0) -> None:
        self.cfg, self.endpoint, self.resume, self.log = cfg, endpoint, resume, log
        self.progress = progress or (lambda event: None)
        self.connect_timeout = connect_timeout
        self.dir = CampaignDir.at(cfg.dir)
        self.vehicle: Vehicle | None = None
        self.objective: MavlinkObjective | None = None
        self.journal: Journal | None = None
        self.baseline_trial: int | None = None
        self.unused: list[JournalEntry] = []  # journalled trials a diverged replay could not use

    # --- setup -----------------------------------------------------------------------------------------------
    def _connect(self) -> Vehicle:
        # A resume loads the profile the campaign was started with: the file it named, else the detected one.
        profile = (self.cfg.profile or self.dir.read_settings()["profile"]) if self.resume else self.cfg.profile
        self.vehicle = Vehicle.connect(self.endpoint, profile, sysid=self.cfg.sysid, compid=self.cfg.compid,
                                       timeout=self.connect_timeout, log=self.log)
        return self.vehicle

    def _baseline_values(self, v: Vehicle) -> dict[str, float]:
        if self.resume:
            snap = load_snapshot(self.dir.root)
            check_identity(snap, v)
            base = snap.baseline()
            current = {n: v.params.read(n) for n in base}
            if any(not np.isclose(current[n], base[n], rtol=1e-6, atol=1e-7) for n in base):
                self.log("vehicle gains differ from the baseline (interrupted trial?): restoring the baseline")
                v.restore(base)
            else:
                self.log("baseline gains verified on the vehicle")
            return base
        base = {n: v.params.table[n].value for n in v.gains.vehicle}
        try:
            v.profile.check_gains(v.gains.from_vehicle(base))
        except InputError as exc:
            raise InputError(f"the vehicle's current gains are outside the profile's search box ({exc}); "
                             "set safe gains inside the box first") from None
        return base

    def _create(self, v: Vehicle, base: dict[str, float]) -> None:
        """Snapshot every parameter, then the settings: the directory exists only from here on."""
        x0 = v.gains.from_vehicle(base)
        snap = write_snapshot(self.dir.snapshot_stem, v.identity.to_dict(), v.stack.name, v.gains.generation,
                              v.profile.name, list(v.gains.vehicle), v.params.table)
        self.log(f"snapshot written: {snap.path.with_suffix('')}.{{param,params,json}}")
        self.dir.write_settings({"config": self.cfg.to_dict(), "profile": v.profile.name, "baseline": base,
                                 "x0": x0.tolist(), "bounds": opt_bounds(v.profile, x0).tolist(),
                                 "mission": v.mission.to_dict(),
                                 "identity": v.identity.to_dict(), "created_unix": time.time()})

    def plan(self, base: dict[str, float]) -> str:
        v = self.vehicle
        assert v is not None
        x0 = v.gains.from_vehicle(base)
        b = opt_bounds(v.profile, x0)
        rows = [f"  {g.name:<16} {n:<16} now {x:<10.5g} tune in [{lo:.5g}, {hi:.5g}]"
                for g, n, x, (lo, hi) in zip(v.profile.gains, v.gains.vehicle, x0, b)]
        n_prior = self.cfg.n_prior or 8 if self._prior_kind() == "local" else 0
        return "\n".join([
            f"vehicle: sysid {v.identity.sysid}, {v.stack.name} {v.identity.firmware}"
            + (f", {v.gains.generation} parameter names" if v.gains.generation else ""),
            f"profile: {v.profile.name}; method {self.cfg.method}, {self.cfg.budget} trials "
            f"(+ prior '{self._prior_kind()}'), seed {self.cfg.seed}" + _options_note(self.cfg, v.profile),
            "gains (profile name, vehicle name, current value, optimiser range):", *rows,
            flight_plan(v.profile, n_prior, self.cfg.budget, self.cfg.confirm, self.cfg.settle_s),
            f"at the end: {'write the best gains (accept)' if self.cfg.accept else 'restore the baseline'}, "
            f"then {self.cfg.end}",
            f"logs: {self.dir.trials}, snapshot {self.dir.snapshot_stem.parent}"])

    def _prior_kind(self) -> str:
        k = self.cfg.prior
        if k == "auto":
            return "sim" if self.vehicle is not None and self.vehicle.profile.name == "sim-planar" else "local"
        return k

    def _prior(self, x0: np.ndarray, bounds: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        assert self.vehicle is not None and self.journal is not None
        return campaign_prior(self._prior_kind(), self.cfg, self.dir, self.vehicle.profile, x0, bounds,
                              [e.P for e in self.journal.of("prior")], lambda x: self._fly(x, "prior").P, self.log)

    # --- flying ----------------------------------------------------------------------------------------------
    def _fly(self, x: np.ndarray, kind: str, stress: bool = False) -> Flight:
        """One trial, journalled; flown again (up to :data:`RETRIES` times) when this computer or the link
        spoiled it. :class:`TrialStopped` for a trial that must end the campaign."""
        for attempt in range(RETRIES + 1):
            try:
                return self._fly_once(x, kind, stress)
            except TrialStopped as exc:
                outcome = exc.flight.outcome
                if not outcome.retry or attempt == RETRIES:
                    raise
                self.log(f"trial {exc.flight.meta['trial']} not counted ({exc.flight.meta['message']}); "
                         "flying it again")
        raise AssertionError("unreachable")

    def _fly_once(self, x: np.ndarray, kind: str, stress: bool = False) -> Flight:
        assert self.objective is not None and self.journal is not None
        journal = self.journal
        try:
            f = self.objective.fly(x, label=kind, stress=stress)
        except (TrialStopped, KeyboardInterrupt) as exc:
            f = exc.flight if isinstance(exc, TrialStopped) else self.objective.last_flight
            if f is not None and f.meta.get("trial") == self.objective.index - 1 and not journal.has_trial(
                    f.meta["trial"]):
                # A crash of a real vehicle is the gains' doing; anything else that stops a trial is not.
                journal.append(JournalEntry.of(kind if f.outcome == "crash" else "failed", f))
            raise
        journal.append(JournalEntry.of(kind, f))
        self.progress(TrialEvent.of(kind, f, journal))
        return f

    def _evaluate(self, x: np.ndarray, stress: bool = False) -> Evaluation:
        """An optimiser evaluation: a flown trial, with the monitor's aborts and crashes as censored outcomes
        (``stress``: from the hardest start, for the re-fly phase's ``refly_stress``)."""
        f = self._fly(x, "opt", stress)
        return Evaluation(f.P, f.outcome.evaluation, f.meta.get("symptoms"))

    def _baseline(self, x0: np.ndarray) -> None:
        """Fly the baseline gains first (answered from the journal when the optimiser asks for x0): every 3-D
        score is relative to this flight's tracking (:meth:`ksbo_mav.mav.mission.Mission.score`)."""
        assert self.objective is not None and self.journal is not None and self.vehicle is not None
        opt = self.journal.of("opt")
        if not opt:
            self.log("trial: baseline gains (the reference every score is measured against)")
            f = self._fly(x0, "opt")
            opt = self.journal.of("opt")
            if f.P < 0 or f.outcome != "ok":
                raise VehicleError(f"the baseline gains flew unsafe (P = {f.P:.3f}, {f.outcome.text}: "
                                   f"{f.meta.get('message') or 'see the trial record'}); safe BO needs a safe start: "
                                   "fix the gains or the mission/safety settings first (baseline restored)")
        self.baseline_trial = opt[0].trial
        if self.vehicle.mission.kind != "figure8-xz":
            self.objective.rms_ref = opt[0].rms

    def _optimize(self, x0: np.ndarray, bounds: np.ndarray, prior: Any) -> Any:
        from ksbo_mav import optimize

        done = self.journal.of("opt")
        m = self.vehicle.mission  # a stress start exists only with moving starts
        replay = JournalReplay(done, self._evaluate, self.log, (lambda x: self._evaluate(x, stress=True))
                               if moving_starts(m.kind, m.start_speed) else None)
        if self.resume and len(done) > 1:
            self.log(f"resume: replaying {len(done)} journalled trial(s) through the optimiser (nothing re-flown)")
        try:
            result = optimize(replay, x0, bounds, prior=prior, budget=self.cfg.budget, method=self.cfg.method,
                              seed=self.cfg.seed, p_min=0.0, check_x0=True,
                              **optimizer_options(self._prior_kind(), self.cfg.options, self.cfg.method,
                                                  self.vehicle.profile))
        except UnsafeStartError:
            raise VehicleError(f"the baseline gains flew unsafe (P = {done[0].P:.3f} < 0): safe BO needs a safe "
                               "start; fix the gains or the mission/safety settings first (baseline restored)"
                               ) from None
        self.unused = replay.unused
        return result

    # --- the whole campaign ----------------------------------------------------------------------------------
    def dry_run(self) -> str:
        """Connect, print the plan, change nothing (and write nothing)."""
        if self.resume:
            check_unchanged(self.dir, self.cfg.profile, self.log)
        v = self._connect()
        try:
            return self.plan(self._baseline_values(v) if not self.resume else load_snapshot(self.dir.root).baseline())
        finally:
            v.close()

    def run(self) -> CampaignSummary:
        from threadpoolctl import threadpool_limits

        if not self.resume and self.dir.exists():
            raise InputError(f"{self.dir.root} already holds a campaign; use --resume {self.dir.root} or another "
                             "directory")
        if self.resume:
            check_unchanged(self.dir, self.cfg.profile, self.log)
        v = self._connect()
        base: dict[str, float] | None = None
        try:
            base = self._baseline_values(v)
            check_moving_start(v.mission, limits_from_profile(v.profile, self.cfg.safety))
            optimizer_options("none", self.cfg.options, self.cfg.method, v.profile)  # gain names: before flying
            if not self.resume:
                self._create(v, base)
            x0 = v.gains.from_vehicle(base)
            bounds = opt_bounds(v.profile, x0)
            self.journal = Journal(self.dir.journal)
            v.setup_streams()
            self.objective = MavlinkObjective(v, base, self.dir.trials, safety=self.cfg.safety,
                                              settle_s=self.cfg.settle_s, first_index=self.dir.next_trial_index(),
                                              start_seed=self.cfg.seed, log=self.log)
            started = time.time()
            self._baseline(x0)
            with threadpool_limits(1):
                prior = self._prior(x0, bounds)
                result = self._optimize(x0, bounds, prior)
            best = np.asarray(result.x, dtype=float)
            confirms = [e.P for e in self.journal.of("confirm")]
            for _ in range(len(confirms), self.cfg.confirm):
                confirms.append(self._fly(best, "confirm").P)
            return self._finish(base, best, result, confirms, time.time() - started)
        except (KeyboardInterrupt, KsboError) as exc:
            if base is not None and not isinstance(exc, InputError):
                self._safe_stop(base)
            self._end_flight(error=True)
            raise
        finally:
            v.close()

    def _safe_stop(self, base: dict[str, float]) -> None:
        if self.vehicle is not None:
            safe_stop(self.vehicle, base, str(self.dir.root), self.log)

    def _end_flight(self, error: bool) -> str:
        return end_flight(self.vehicle, self.cfg.end, error, self.log) if self.vehicle is not None else ""

    def _finish(self, base: dict[str, float], best: np.ndarray, result: Any, confirms: list[float],
                wall: float) -> CampaignSummary:
        v = self.vehicle
        journal = self.journal
        assert v is not None and journal is not None
        opt = journal.of("opt")
        best_values = v.gains.to_vehicle(best)
        # Gains that failed a confirmation flight are never left on the vehicle by themselves.
        failures = confirm_failures(journal.of("confirm"))
        accepted = self.cfg.accept and not failures
        if accepted:
            v.restore(best_values)  # write + fresh read-back of every gain
            write_accepted(self.dir, base, best_values, v)
            self.log("accepted: best gains written and verified on the vehicle")
        else:
            v.restore(base)
            self.log("baseline gains restored and verified by a fresh read")
            if self.cfg.accept:
                self.log(f"--accept refused: {'; '.join(failures)} (`ksbo-mav accept {self.dir.root} --force` "
                         "writes them anyway)")
        on_vehicle = {n: v.params.table[n].value for n in base}
        ended = self._end_flight(error=False)
        gain_aborts = [e for e in journal.entries if e.outcome.gain_caused]
        summary = CampaignSummary(
            baseline={"x": v.gains.from_vehicle(base).tolist(), "values": base, "P": opt[0].P if opt else None,
                      "trial": self.baseline_trial, "rms_m": opt[0].rms if opt else None},
            best={"x": best.tolist(), "values": best_values, "P_model": float(result.fun),
                  "P_confirm": float(np.mean(confirms)) if confirms else None, "P_confirm_all": confirms,
                  "confirm_failures": failures,
                  "unused_journal_trials": [e.trial for e in self.unused]},
            accepted=accepted, accept_refused="; ".join(failures) if self.cfg.accept else "",
            on_vehicle=on_vehicle, n_trials=len(journal.entries),
            n_unsafe=int(sum(e.P < 0 for e in opt)),
            n_aborted=sum(e.outcome != "crash" for e in gain_aborts),
            n_crashed=sum(e.outcome == "crash" for e in gain_aborts), n_failed=len(journal.of("failed")),
            method=self.cfg.method, orders=list(result.orders) if result.orders else None, wall_s=wall,
            dir=str(self.dir.root), ended=ended)
        fsync_write(self.dir.result, json.dumps(summary.to_dict(), indent=1))
        try:
            from ksbo_mav.campaign.report import write_report

            summary.plots = write_report(self.dir, v.profile, summary.to_dict())
        except Exception as exc:  # a plotting problem must never hide the tuning result
            self.log(f"report plots failed: {exc}")
        fsync_write(self.dir.result, json.dumps(summary.to_dict(), indent=1))
        return summary


def _options_note(cfg: CampaignConfig, profile: Any) -> str:
    """The optimiser options that differ from the method's defaults (the profile's, then the user's)."""
    implied = profile_defaults(cfg.method, profile)
    parts = [f"{k}={v} (profile: the backup covers its trials)" for k, v in implied.items() if k not in cfg.options]
    parts += [f"{k}={v}" for k, v in cfg.options.items()]
    return f"; options {', '.join(parts)}" if parts else ""
