"""Validation flights: the baseline and the recommended gains flown alternately (A B A B ...) on the manoeuvres
pilots fly — position steps, a position hold, an AUTO waypoint mission (:mod:`ksbo_mav.mav.validation`) — after
the tune's confirmation, in the same session and pack, or later by ``ksbo-mav validate``.

Each flight is flown like a trial: the vehicle hovering with the baseline gains, the gains written (verified), the
manoeuvre flown under the monitor with a two-way tlog, then the baseline restored (verified by a fresh read)
whatever happened. It is journalled in ``validation.jsonl`` (:mod:`ksbo_mav.campaign.validation_log`), never in
the trial journal, so no validation flight ever reaches the optimiser. A resume flies only what the journal lacks.
When the recommendation is worse than the baseline on a manoeuvre (:mod:`ksbo_mav.campaign.verdict`), the next
candidates from the campaign's best trials are flown the same way, at most ``candidates`` of them, until one is
worse nowhere. Before each flight the pack must hold one more (:class:`~ksbo_mav.campaign.battery.BatteryGuard`);
when it does not, the validation stops cleanly and says that ``ksbo-mav validate`` flies the rest later.

A flight that cannot start or fails for a reason that leaves the vehicle ours, hovering with the baseline verified
(a refusal: sticks off centre for ArduPilot's LOITER, a mission upload or a mode refused; a write not verified) is
journalled with its reason and its manoeuvre is left out, the others still flown; anything else (the pilot, the
link, a failsafe, a baseline not verified) stops the validation there (:attr:`ValidationFlights.stopped`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ksbo_mav.campaign.battery import BatteryGuard
from ksbo_mav.campaign.journal import Journal
from ksbo_mav.campaign.layout import CampaignDir
from ksbo_mav.campaign.validation_log import BASELINE, RECOMMENDATION, ValidationEntry, ValidationJournal
from ksbo_mav.campaign.verdict import PairVerdict, judge_pairs
from ksbo_mav.errors import KsboError, PilotTookOver, VehicleError
from ksbo_mav.mav.monitor import Monitor, limits_from_profile
from ksbo_mav.mav.outcome import TrialOutcome as T
from ksbo_mav.mav.pilot import tool_modes
from ksbo_mav.mav.vehicle import Vehicle

#: How often a flight spoiled by this computer or the link (TrialOutcome.retry) is flown again.
RETRIES = 2
#: Outcomes after which the other manoeuvres may still be flown (the vehicle ours, the baseline verified).
SKIPPABLE = (T.ERROR, T.VERIFY, T.TELEMETRY, T.CLIENT)


class NotFlown(Exception):
    """A manoeuvre that could not be flown (``reason``); the others may be."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


@dataclass(frozen=True)
class ValidationPlan:
    """What to fly: the manoeuvres (built from the profile's ``[validation]``), flights of each gain set per
    manoeuvre, and how many further candidates may be flown when the recommendation is worse somewhere."""

    manoeuvres: tuple[Any, ...]  # ksbo_mav.mav.validation.ManoeuvreSpec
    repeats: int
    candidates: int

    @classmethod
    def of(cls, profile: Any, mode: str) -> "ValidationPlan | None":
        """The plan of ``mode`` ("quick": each manoeuvre's shorter version, the profile's ``repeats`` and one further
        candidate at most; "full": its ``full_repeats`` and ``candidates``); None for "off" or a profile without
        manoeuvres."""
        spec = profile.validation_spec
        kinds = spec.kinds
        if mode == "off" or not kinds:
            return None
        from ksbo_mav.mav.validation.manoeuvre_spec import ManoeuvreSpec

        manoeuvres = tuple(ManoeuvreSpec.from_dict(k, spec.sizes(k)) for k in kinds)
        if mode == "full":
            return cls(manoeuvres, spec.full_repeats, spec.candidates)
        return cls(tuple(m.quick() for m in manoeuvres), spec.repeats, min(1, spec.candidates))

    @staticmethod
    def describe(profile: Any, mode: str) -> str:
        """One line of the flight plan: what the validation will fly (``tune --dry-run``)."""
        plan = ValidationPlan.of(profile, mode)
        if plan is None:
            return ("validation: none (--validation off)" if mode == "off"
                    else f"validation: none (profile {profile.name} names no [validation] manoeuvres)")
        kinds = ", ".join(m.kind for m in plan.manoeuvres)
        n = 2 * plan.repeats * len(plan.manoeuvres)
        more = f", and as many per further candidate (up to {plan.candidates}) if it flies worse" \
            if plan.candidates else ""
        return (f"validation ({mode}): {kinds}, the baseline and the recommendation alternated, {plan.repeats} "
                f"flights each: {n} flights after the confirmation{more}")

    def check(self, v: Vehicle, safety: dict[str, float] | None = None) -> None:
        """InputError (one line) unless every manoeuvre's targets lie inside the safety box, from the mission's
        start where the vehicle hovers before each flight."""
        limits = limits_from_profile(v.profile, safety)
        for m in self.manoeuvres:
            m.check_inside(v.mission.start_ned(), limits)


def candidates_from(journal: Journal, x0: np.ndarray, best: np.ndarray, n: int) -> list[tuple[str, np.ndarray]]:
    """The campaign's next best gain sets after the recommendation ``best``: completed optimiser trials with
    P >= 0, best scored first, distinct gains, neither the baseline ``x0`` nor ``best``; at most ``n``, as
    ("trial N", x)."""
    seen = [np.asarray(x0, float), np.asarray(best, float)]
    out: list[tuple[str, np.ndarray]] = []
    for e in sorted((e for e in journal.of("opt") if e.outcome == "ok" and e.scored >= 0), key=lambda e: -e.scored):
        x = np.asarray(e.x, float)
        if any(np.allclose(x, s, rtol=1e-6, atol=1e-9) for s in seen):
            continue
        seen.append(x)
        out.append((f"trial {e.trial}", x))
        if len(out) == n:
            break
    return out


class ValidationFlights:
    """Flies a :class:`ValidationPlan` on a connected, campaign-ready vehicle.

    Args:
        v: the vehicle; ``base``: {parameter: value} restored after every flight.
        d: the campaign directory (journal and tlogs); ``guard``: the pack's guard (None: no battery figures).
        safety: the campaign's overrides of the profile's ``[safety]`` thresholds.
        conditions: the campaign's :class:`~ksbo_mav.campaign.drift.ConditionWatch` (wind, voltage), if any.
    """

    def __init__(self, v: Vehicle, base: dict[str, float], d: CampaignDir, plan: ValidationPlan,
                 guard: BatteryGuard | None, log: Callable[[str], None], safety: dict[str, float] | None = None,
                 conditions: Any = None) -> None:
        self.v, self.base, self.d, self.plan, self.guard, self.log = v, dict(base), d, plan, guard, log
        v.mission_file = d.user_mission
        self.journal = ValidationJournal(d.validation_journal)
        self.monitor = Monitor(limits_from_profile(v.profile, safety), v.stack.modes["guided"], v.stack.mode_name)
        self.conditions = conditions
        self.stopped: str | None = None  # why the validation stopped before the end (the pack, the pilot), else None
        self.not_flown: dict[str, str] = {}  # manoeuvre -> why it was left out

    def run(self, x0: np.ndarray, best: np.ndarray, more: list[tuple[str, np.ndarray]]) -> list[PairVerdict]:
        """The recommendation ``best`` against the baseline ``x0``; while every pair flown so far is worse
        somewhere, the next of ``more`` (:func:`candidates_from`). Returns the verdicts; :attr:`stopped` says why
        it ended early (the pack, the pilot, the link) and :attr:`not_flown` which manoeuvres were left out."""
        pairs = [(RECOMMENDATION, np.asarray(best, float)), *more]
        try:
            for n, (label, x) in enumerate(pairs):
                if n and not all(p.worse_on for p in self.verdicts()):
                    break
                if n:
                    self.log(f"validation: the gains flown so far are worse than the baseline somewhere; flying the "
                             f"next candidate, {label}")
                self._pair(label, np.asarray(x0, float), x)
        except KsboError as exc:  # CampaignPaused (the pack) too; Ctrl-C goes on up
            self.stopped = str(exc)
            self.log(f"validation stopped: {exc}")
        return self.verdicts()

    def verdicts(self) -> list[PairVerdict]:
        return judge_pairs(self.journal.entries)

    def _pair(self, label: str, x0: np.ndarray, x: np.ndarray) -> None:
        """A B A B ... on each manoeuvre: the slots the journal already holds are skipped (a resume); a manoeuvre
        that could not be flown is left out (:attr:`not_flown`), the next one flown."""
        for spec in self.plan.manoeuvres:
            if spec.kind in self.not_flown:
                continue
            try:
                for rep in range(self.plan.repeats):
                    for gains, xg in ((BASELINE, x0), (label, x)):
                        if len(self.journal.flown(label, spec.kind, gains)) > rep:
                            continue
                        self._fly(spec, label, gains, xg)
            except NotFlown as exc:
                self.not_flown[spec.kind] = exc.reason
                self.log(f"validation: {spec.kind} not flown ({exc.reason}); the other manoeuvres go on")

    def _fly(self, spec: Any, pair: str, gains: str, x: np.ndarray) -> ValidationEntry:
        for attempt in range(RETRIES + 1):
            if self.guard is not None:
                self.guard.before_trial()  # CampaignPaused: the pack would not fit one more flight
            e = self._fly_once(spec, pair, gains, x)
            if self.guard is not None:
                line = self.guard.after_trial()
                if line:
                    self.log(line)
            done = "restored and verified" if e.restored else "NOT restored - run `ksbo-mav restore`"
            if e.counted and e.restored and not (e.outcome == "crash" and not self.v.is_sim):
                return e
            # a lost link that came back, the baseline verified and the vehicle ours again: flown again, as a trial
            again = e.outcome.retry or (e.outcome is T.LINK and e.restored and self._ours())
            if not e.restored or not again or attempt == RETRIES or e.counted:
                if e.restored and e.outcome in SKIPPABLE and self._ours():
                    raise NotFlown(e.message or e.outcome.text)
                raise VehicleError(f"validation flight {e.flight} ({spec.kind}, {gains}): {e.outcome.text}"
                                   f"{': ' + e.message if e.message else ''}; baseline gains {done}; "
                                   f"`ksbo-mav validate {self.d.root}` flies the rest later")
            self.log(f"validation flight {e.flight} not counted ({e.message or e.outcome.text}); flying it again")
        raise AssertionError("unreachable")

    def _ours(self) -> bool:
        """Armed in a mode the tool flies in: no pilot, failsafe or landing took the vehicle."""
        hb = self.v.guided.heartbeat
        return bool(hb is not None and hb.base_mode & 128 and int(hb.custom_mode) in tool_modes(self.v.stack))

    def _next_index(self) -> int:
        on_disk = [int(p.stem.split("_")[1]) for p in self.d.validation_flights.glob("flight_*")
                   if p.stem.split("_")[1].isdigit()]
        return max([self.journal.next_flight() - 1, *on_disk], default=-1) + 1

    def _fly_once(self, spec: Any, pair: str, gains: str, x: np.ndarray) -> ValidationEntry:
        from ksbo_mav.mav.validation import fly_manoeuvre

        v = self.v
        try:
            v.ensure_airborne(self.log)  # hovering at the mission's start with the baseline gains
        except PilotTookOver:
            raise
        except VehicleError as exc:
            raise VehicleError(f"validation: could not get the vehicle ready ({exc})") from None
        index = self._next_index()
        tlog = self.d.validation_tlog(index)
        tlog.parent.mkdir(parents=True, exist_ok=True)
        started = time.time()
        if self.conditions is not None:
            self.conditions.start()
        try:
            xs = v.check_trial_gains(x, v.gain_map.from_params(self.base))
        except KsboError as exc:  # outside the trust region: never flown
            raise VehicleError(f"validation: {exc}") from None
        flight = fly_manoeuvre(v, spec, self.monitor, gains_label=gains, tlog_path=tlog, gains=xs,
                               baseline_params=self.base, log=self.log)
        outcome, message, restored, stop = T(flight.outcome), flight.message, bool(flight.restored), \
            flight.interrupted
        metrics = {k: float(val) for k, val in flight.metrics.items() if val is not None and np.isfinite(val)}
        entry = ValidationEntry(flight=index, manoeuvre=spec.kind, pair=pair, gains=gains,
                                x=tuple(float(g) for g in x), outcome=outcome,
                                metrics=metrics,
                                tlog=str(tlog), restored=restored, message=message, started_unix=started,
                                ended_unix=time.time(),
                                cond=self.conditions.take(index, tlog) if self.conditions is not None else {})
        self.journal.append(entry)
        self.log(self._line(entry))
        if stop is not None:
            raise stop
        return entry

    @staticmethod
    def _line(e: ValidationEntry) -> str:
        from ksbo_mav.campaign.verdict import DECIDING, FALLBACK

        metric = DECIDING.get(e.manoeuvre, "")
        if metric not in e.metrics:
            metric = FALLBACK.get(e.manoeuvre, metric)
        value = e.metrics.get(metric)
        figure = f" {metric} {value:.3g}" if value is not None else ""
        mark = "ok" if e.outcome == "ok" else f"ABORT {e.outcome}" if e.counted else f"NOT COUNTED {e.outcome}"
        return f"validation {e.flight:3d} {e.manoeuvre:<12} {e.gains:<14} {mark}{figure}"
