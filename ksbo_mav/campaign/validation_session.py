"""Where validation flights are flown: right after a tune's confirmation (the same session and pack), or later by
``ksbo-mav validate DIR`` for a finished campaign, accepted or not.

``validate`` keeps the campaign's promise about the vehicle's parameters: before it writes anything it notes which
gains it found (the campaign's baseline, or its accepted recommendation) in ``validation_start.json``, restores them
after every flight, and leaves them on the vehicle at the end however it ends (a resumed ``validate`` after a crash
puts back the ones noted first). Gains on the vehicle that are neither are refused: ``ksbo-mav restore`` first.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ksbo_mav.campaign.access import check_identity
from ksbo_mav.campaign.battery import BatteryGuard, await_failsafe, failsafe_active
from ksbo_mav.campaign.config import CampaignConfig, MissionRate
from ksbo_mav.campaign.drift import ConditionWatch
from ksbo_mav.campaign.ending import end_flight, rewrite_report, safe_stop
from ksbo_mav.campaign.journal import Journal
from ksbo_mav.campaign.layout import CampaignDir, write_file
from ksbo_mav.campaign.onboard import install_guard, remove_guard
from ksbo_mav.campaign.stops import EXIT, clear_stop, continue_command, set_validation_state, write_stop
from ksbo_mav.campaign.validation import ValidationFlights, ValidationPlan, candidates_from
from ksbo_mav.campaign.verdict import PairVerdict, best_not_worse, refusal
from ksbo_mav.errors import CampaignPaused, InputError, KsboError
from ksbo_mav.mav.link import Endpoint
from ksbo_mav.mav.params import load_snapshot
from ksbo_mav.mav.vehicle import Vehicle


@dataclass
class ValidationReport:
    """What a validation found: the verdict of each comparison flown, and why it stopped early (else None)."""

    verdicts: list[PairVerdict] = field(default_factory=list)
    stopped: str | None = None
    skipped: str | None = None  # why nothing was flown (off, no manoeuvres, nothing to compare)
    not_flown: dict[str, str] = field(default_factory=dict)  # manoeuvre -> why it was left out

    def incomplete(self) -> str | None:
        """Why some validation flights are missing (manoeuvres left out, a stop), else None."""
        parts = [f"{kind} not flown ({why})" for kind, why in self.not_flown.items()]
        if self.stopped:
            parts.append(f"stopped: {self.stopped}")
        return "; ".join(parts) or None

    def state(self, command: str) -> dict[str, Any]:
        """result.json's ``validation``: "complete", "incomplete" (with the reason and the command that flies the
        rest) or "skipped" (with why)."""
        if self.skipped:
            return {"state": "skipped", "reason": self.skipped}
        why = self.incomplete()
        return {"state": "incomplete", "reason": why, "command": command} if why else {"state": "complete"}

    def refusals(self) -> list[str]:
        """Why ``--accept`` must not leave the recommendation on the vehicle (worse somewhere), else empty."""
        why = refusal(self.verdicts)
        return [why] if why else []

    def lines(self) -> list[str]:
        """The console's lines: per comparison and manoeuvre, the plain verdict with the figures."""
        if self.skipped:
            return [f"validation: {self.skipped}"]
        out = []
        for p in self.verdicts:
            out.append(f"validation, {p.pair} against the baseline: {p.overall}")
            out += [f"  {line}" for line in p.lines()]
        if self.verdicts and self.verdicts[0].worse_on:
            best = best_not_worse(self.verdicts)
            out.append(f"  best candidate worse nowhere: {best.pair}" if best is not None else
                       "  no candidate flown is worse nowhere: keep the baseline gains")
        if self.incomplete():
            out.append(f"validation incomplete: {self.incomplete()}")
        return out


def validation_verdicts(path: str | Path) -> list[dict[str, Any]]:
    """The verdicts of a campaign's validation flights as flown so far (its ``validation.jsonl``), one dict per
    comparison (:meth:`~ksbo_mav.campaign.verdict.PairVerdict.to_dict`); empty without validation flights."""
    from ksbo_mav.campaign.validation_log import ValidationJournal
    from ksbo_mav.campaign.verdict import judge_pairs

    d = CampaignDir.at(path)
    return [p.to_dict() for p in judge_pairs(ValidationJournal(d.validation_journal).entries)]


def check_validation(v: Vehicle, cfg: CampaignConfig) -> None:
    """Before a tune flies: InputError (one line) when the profile's validation manoeuvres would not fit the safety
    box (found now, not after the tune)."""
    plan = ValidationPlan.of(v.profile, cfg.validation)
    if plan is not None:
        plan.check(v, cfg.safety)


def validate_after_tune(v: Vehicle, d: CampaignDir, cfg: CampaignConfig, base: dict[str, float], trials: Any,
                        x0: np.ndarray, best: np.ndarray, failures: list[str], hint: str,
                        log: Callable[[str], None]) -> ValidationReport:
    """The validation flights after the confirmation (``trials``: the campaign's TrialLoop, for its journal, pack
    guard and condition watch; ``hint``: the ``validate`` command that flies them later)."""
    plan = ValidationPlan.of(v.profile, cfg.validation)
    why = _nothing_to_fly(plan, cfg.validation, v.profile.name, x0, best, failures)
    if why:
        rep = ValidationReport(skipped=why)
    else:
        # A stop on the way leaves this note: a later `validate` puts the baseline back whatever it finds.
        write_file(d.validation_start, json.dumps({"which": "baseline", "gains": base}, indent=1))
        rep = fly(v, d, plan, base, Journal(d.journal), x0, best, trials.guard, trials.conditions, hint, log,
                  cfg.safety)
        d.validation_start.unlink(missing_ok=True)
    for line in rep.lines():
        log(line)
    return rep


def _nothing_to_fly(plan: ValidationPlan | None, mode: str, profile: str, x0: np.ndarray, best: np.ndarray,
                    failures: list[str]) -> str | None:
    if mode == "off":
        return "off (--validation off)"
    if plan is None:
        return f"profile {profile} names no [validation] manoeuvres"
    if failures:
        return "the recommendation failed its confirmation: not validated"
    if np.allclose(np.asarray(best, float), np.asarray(x0, float), rtol=1e-6, atol=1e-9):
        return "the recommendation is the baseline gains: nothing to compare"
    return None


def fly(v: Vehicle, d: CampaignDir, plan: ValidationPlan, base: dict[str, float], journal: Journal, x0: np.ndarray,
        best: np.ndarray, guard: BatteryGuard | None, conditions: Any, hint: str,
        log: Callable[[str], None], safety: dict[str, float] | None = None) -> ValidationReport:
    """Fly the plan (the pack guard's stop line names ``hint``) with the campaign's ``safety`` overrides (a raised
    tilt limit for the day's wind among them); restores ``base`` after every flight."""
    if guard is not None:
        guard.resume_hint = hint
    if v.guard is not None:
        log("validation: the onboard guard watches every flight (GUIDED and the hold or AUTO mode the flight switches "
            "to are the tool's; any other mode is a pilot's)")
    flights = ValidationFlights(v, base, d, plan, guard, log, safety=safety, conditions=conditions)
    verdicts = flights.run(x0, best, candidates_from(journal, x0, best, plan.candidates))
    return ValidationReport(verdicts, flights.stopped, not_flown=flights.not_flown)


def validate_campaign(path: str | Path, endpoint: Endpoint, *, mode: str | None = None, end: str = "land",
                      log: Callable[[str], None] = print, timeout: float = 15.0, sysid: int | None = None,
                      compid: int | None = None) -> ValidationReport:
    """``ksbo-mav validate``: fly a finished campaign's validation (``mode``: "quick" or "full"; None: the
    campaign's setting, "quick" if it was off), leave the gains found on the vehicle, write the report."""
    from ksbo_mav.campaign.link_loss_policy import LinkLossChoice, check_link_loss
    from ksbo_mav.campaign.mission_rate import fly_at

    d = CampaignDir.at(path)
    settings, result = d.read_settings(), d.read_result()
    command = continue_command(d, endpoint, "validation")
    cfg = CampaignConfig.from_saved(settings["config"], str(d.config))
    mode = mode or (cfg.validation if cfg.validation != "off" else "quick")
    snap = load_snapshot(d.snapshot)
    v = Vehicle.connect(endpoint, settings["profile"], sysid=sysid, compid=compid, timeout=timeout, log=log)
    home: dict[str, float] | None = None
    try:
        check_identity(snap, v)
        plan = ValidationPlan.of(v.profile, mode)
        x0, best = np.asarray(settings["x0"], float), np.asarray(result["best"]["x"], float)
        why = _nothing_to_fly(plan, mode, v.profile.name, x0, best, result["best"].get("confirm_failures") or [])
        if why:
            log(f"validation: {why}")
            return ValidationReport(skipped=why)
        plan.check(v, cfg.safety)
        check_link_loss(v, LinkLossChoice(), log)  # PX4 over a link away from the vehicle: refused, as for tune
        home = _home_gains(v, d, snap.baseline(), result["best"]["values"], log)
        flown = ((settings.get("mission") or {}).get("rate_hz"))
        fly_at(v, MissionRate(int(flown or v.mission.rate_hz), lowerable=False), log)
        install_guard(v, cfg.onboard_guard, home, cfg.safety, log)  # its baseline: the gains put back after each
        set_validation_state(d, {"state": "pending", "command": command})  # a killed validate: restore says so
        rep = fly(v, d, plan, home, Journal(d.journal), x0, best, BatteryGuard(v, command), ConditionWatch(v),
                  command, log, cfg.safety)
        set_validation_state(d, rep.state(command))
        v.restore(home)
        d.validation_start.unlink(missing_ok=True)  # done: a later validate notes what it finds then
        log("the gains found on the vehicle are back, verified by a fresh read")
        end_flight(v, end, False, log)
    except (KeyboardInterrupt, KsboError) as exc:
        if home is not None:
            safe_stop(v, home, str(d.root), log)
            if failsafe_active(v):
                await_failsafe(v, log)
            else:
                end_flight(v, end, True, log)
            why = str(exc) or "interrupted (Ctrl-C)"
            set_validation_state(d, {"state": "incomplete", "reason": f"stopped: {why}", "command": command})
            write_stop(d, why, command, "validation", EXIT["interrupted" if isinstance(exc, KeyboardInterrupt)
                                                              else "paused" if isinstance(exc, CampaignPaused)
                                                              else "error"])
            rewrite_report(d, v.profile, log, draw=False)
            log(f"validation stopped: `{command}` flies the rest")
        raise
    finally:
        remove_guard(v, log)
        v.close()
    for line in rep.lines():
        log(line)
    if rep.incomplete() is None:
        clear_stop(d)
    rewrite_report(d, v.profile, log)
    return rep


def _home_gains(v: Vehicle, d: CampaignDir, base: dict[str, float], best: dict[str, float],
                log: Callable[[str], None]) -> dict[str, float]:
    """The gains ``validate`` leaves on the vehicle: those noted by an earlier, interrupted ``validate``, else the
    ones on it now when they are the campaign's baseline or its recommendation (InputError otherwise)."""
    if d.validation_start.is_file():
        try:
            home = {str(k): float(x) for k, x in json.loads(d.validation_start.read_text())["gains"].items()}
            log(f"validation: putting back the gains noted by the earlier validate ({d.validation_start})")
            return home
        except (OSError, ValueError, KeyError, AttributeError):
            raise InputError(f"{d.validation_start} is not readable; `ksbo-mav restore {d.root}` first") from None
    now = {n: v.params.read(n) for n in base}
    which = next((name for name, gains in (("baseline", base), ("accepted", best))
                  if all(np.isclose(now[n], float(gains[n]), rtol=1e-5, atol=1e-6) for n in base)), None)
    if which is None:
        raise InputError("the vehicle holds gains that are neither this campaign's baseline nor its recommendation; "
                         f"`ksbo-mav restore {d.root}` (or accept) first")
    home = {n: float(now[n]) for n in base}
    write_file(d.validation_start, json.dumps({"which": which, "gains": home}, indent=1))
    log(f"validation: the vehicle holds the {which} gains; they are put back after every flight and at the end")
    return home

