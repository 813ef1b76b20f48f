"""Is it the gains or the vehicle? Baseline re-flights at a cadence, and a test on them.

Every :attr:`DriftWatch.every` trials (optimiser and flown prior; stretched up to twice that while the re-flights
stay quiet) the campaign flies the baseline gains again (journal kind ``baseline``: never given to the optimiser).
The first baseline flight is the reference of every score, so the re-flights say whether the vehicle still answers
the same gains the same way.

The test is one-sided and robust. Each baseline flight's change from the first is ``d = rms / rms_first - 1``
(the 3-D figure-8s, lap-2 RMS) or ``d = P_first - P`` (the planar task, which has no RMS). The re-flight noise
``s`` is estimated from the successive differences of the re-flights (1.4826 x their median absolute deviation
/ sqrt 2: a steady trend does not inflate it). The newest re-flight shows a change when ``d`` exceeds
``max(floor, 3 s)``; the floor is :attr:`DriftWatch.rms_ratio` - 1 (re-flights of the same gains on ArduCopter
SITL spread by about 10 %) or :attr:`DriftWatch.p_drop`. A change is then confirmed by flying the baseline again
at once: only when that flight shows it too does the test fire. When it fires, the vehicle changed, not the
gains, and the campaign says so with the numbers. By default (``on_drift = "stop"``) it stops in a safe state
(baseline restored, landed, report written), to be resumed after a check of the vehicle. With ``"continue"`` it
goes on with drift-corrected scores (:meth:`DriftWatch.corrected`): each trial is scored against the baseline
as last re-flown, carried forward along the trend of the baseline flights, not against the first flight.

The conditions a trial flew in are kept with its journal entry
(:class:`~ksbo_mav.campaign.flight_conditions.ConditionWatch`): the wind the autopilot estimates and streams
(``WIND`` on ArduPilot, ``WIND_COV`` on PX4: north/east components, NaN while its estimator has none; none at all,
``wind_estimated`` false and an inferred figure instead, when the vehicle does not estimate it: an ArduCopter
without drag fusion streams a 0 whatever blows), the ``SYS_STATUS`` battery voltage the vehicle's
:class:`~ksbo_mav.mav.power.PowerWatch` keeps, and the flight index (every flight of the campaign counted: how far
into the campaign, and into the pack, a trial came).
The drift message names the conditions that changed between the first baseline flight and the newest.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field

import numpy as np

from ksbo_mav.campaign.flight_conditions import ConditionWatch  # noqa: F401 - the campaign's import place
from ksbo_mav.campaign.journal import Journal, JournalEntry
from ksbo_mav.campaign.layout import CampaignDir, write_file
from ksbo_mav.errors import CampaignPaused, InputError

ON_DRIFT = ("stop", "continue")


def conditions_seen(first: JournalEntry, last: JournalEntry) -> str:
    """"; wind 0.0 -> 1.0 m/s, battery 12.6 -> 11.8 V" for the conditions recorded with both flights."""
    a, b = first.cond or {}, last.cond or {}
    parts = [f"{name} {a[k]:.1f} -> {b[k]:.1f} {unit}" for k, name, unit in
             (("wind_mps", "mean wind", "m/s"), ("voltage_v", "battery", "V"))
             if a.get(k) is not None and b.get(k) is not None and abs(b[k] - a[k]) >= 0.05]
    return f"; {', '.join(parts)}" if parts else ""


def save_drift(d: CampaignDir, message: str, mode: str) -> None:
    """Keep the drift test's message with the campaign (``mode``: the campaign stopped, or went on)."""
    write_file(d.drift, json.dumps({"message": message, "on_drift": mode}) + "\n")


def load_drift(d: CampaignDir) -> str | None:
    """The drift test's verdict in plain words, for the report; None when it never fired."""
    try:
        doc = json.loads(d.drift.read_text())
    except (OSError, ValueError):
        return None
    then = ("campaign stopped" if doc.get("on_drift") == "stop"
            else "campaign went on, scored against the re-flown baseline")
    return f"{doc.get('message', '')} ({then})"


#: Gaussian consistency of the median absolute deviation.
MAD_SIGMA = 1.4826
#: Baseline flights at most in the reference level of the vehicle at the start (:meth:`DriftWatch.anchor`).
ANCHOR_FLIGHTS = 3


@dataclass(frozen=True)
class Anchor:
    """The baseline's level at the start: lap-2 RMS (None without one) and P, the mean of ``n`` flights."""

    rms: float | None
    P: float
    n: int


@dataclass
class DriftWatch:
    every: int = 7  # optimiser trials between baseline re-flights (about 1 in 8 flights; 0: never)
    rms_ratio: float = 1.25
    p_drop: float = 0.10
    k_noise: float = 3.0
    on_drift: str = "stop"
    resume_hint: str = "ksbo-mav tune --resume DIR"
    fired: str | None = None  # the plain-words message, once the test has fired (continue mode goes on)
    ref: JournalEntry | None = None  # the baseline flight trials are scored against (continue mode, after firing)
    levels: list[tuple[int, float]] = field(default_factory=list)

    def __post_init__(self) -> None:
        if self.on_drift not in ON_DRIFT:
            raise InputError(f"on_drift must be one of {', '.join(ON_DRIFT)}, got {self.on_drift!r}")

    def interval(self, journal: Journal) -> int:
        """Optimiser trials until the next re-flight: ``every``, stretched by half (up to twice ``every``) after
        each re-flight that tracked within half the floor of the first flight, back to ``every`` after one that
        did not (a static vehicle pays less, a changing one is watched at the cadence)."""
        b = self.flights(journal)
        floor = self.floor(journal)
        n = self.every
        for e in b[1:]:
            n = min(2 * self.every, math.ceil(1.5 * n)) if self.change(b[0], e) <= floor / 2 else self.every
        return n

    def due(self, journal: Journal) -> bool:
        """A baseline re-flight is due: :meth:`interval` trials (optimiser and flown prior) since the baseline or
        its last re-flight. The vehicle changes during the flown prior too: counting those flights bounds the
        flights between a change and the re-flight that sees it (``every`` at the cadence)."""
        opt = journal.of("opt")
        if not opt or self.every <= 0:
            return False
        last = max([opt[0].trial, *(e.trial for e in journal.of("baseline"))])
        flown = opt + journal.of("prior")
        return sum(e.trial > last for e in flown) >= self.interval(journal)

    @staticmethod
    def flights(journal: Journal) -> list[JournalEntry]:
        """The first baseline flight and every re-flight that flew to the end, in order."""
        opt = journal.of("opt")
        return opt[:1] + [e for e in journal.of("baseline") if e.outcome == "ok"]

    @staticmethod
    def change(first: JournalEntry, e: JournalEntry) -> float:
        """How much worse ``e`` tracked than ``first`` (relative RMS rise, or P drop without RMS)."""
        if first.rms is not None and e.rms is not None and first.rms > 0:
            return e.rms / first.rms - 1.0
        return first.P - e.P

    def floor(self, journal: Journal) -> float:
        b = self.flights(journal)
        return self.rms_ratio - 1.0 if b and b[0].rms is not None else self.p_drop

    def anchor(self, journal: Journal) -> Anchor:
        """How the vehicle flew the baseline at the start: the mean of the first flight and the re-flights right
        after it that stayed within half the floor of it (up to :data:`ANCHOR_FLIGHTS`; the newest flight, under
        test, never). One flight is a noisy reference (re-flights of the same gains on ArduCopter SITL spread by
        10 %); a run of quiet ones is a better one, and a trend leaves it at the first flight."""
        b = self.flights(journal)
        first, half = b[0], self.floor(journal) / 2
        quiet = [first]
        for e in b[1:-1]:
            if len(quiet) == ANCHOR_FLIGHTS or self.change(first, e) > half:
                break
            quiet.append(e)
        rms = [e.rms for e in quiet]
        level = float(np.mean(rms)) if all(r is not None and r > 0 for r in rms) else None
        return Anchor(level, float(np.mean([e.P for e in quiet])), len(quiet))

    @staticmethod
    def change_from(a: Anchor, e: JournalEntry) -> float:
        """How much worse ``e`` tracked than the vehicle at the start (relative RMS rise, or P drop without RMS)."""
        if a.rms is not None and e.rms is not None:
            return e.rms / a.rms - 1.0
        return a.P - e.P

    def threshold(self, journal: Journal) -> float:
        """The change the newest re-flight must exceed: the floor, or 3 x the re-flight noise if larger."""
        b = self.flights(journal)
        floor = self.floor(journal)
        a = self.anchor(journal)
        # The newest is tested, not used for its own noise; nor, for a confirmation flown at once, the re-flight
        # it confirms (a step in the vehicle is not noise).
        hist = b[:-2] if len(b) > 2 and b[-1].trial == b[-2].trial + 1 else b[:-1]
        steps = np.diff([self.change_from(a, e) for e in hist])
        if len(steps) < 2:
            return floor
        s = MAD_SIGMA * float(np.median(np.abs(steps - np.median(steps)))) / math.sqrt(2.0)
        return max(floor, self.k_noise * s)

    def shows_change(self, journal: Journal) -> bool:
        """The newest baseline re-flight tracked worse than the vehicle at the start by more than the threshold."""
        b = self.flights(journal)
        if len(b) < 2 or journal.of("baseline")[-1] is not b[-1]:
            return False
        return self.change_from(self.anchor(journal), b[-1]) > self.threshold(journal)

    def message(self, journal: Journal) -> str:
        b = self.flights(journal)
        first, last, a = b[0], b[-1], self.anchor(journal)
        of = f" (the mean of its first {a.n} flights)" if a.n > 1 else ""
        if a.rms is not None and last.rms is not None:
            what = f"the lap-2 RMS went from {a.rms:.2f} m{of} to {last.rms:.2f} m"
        else:
            what = f"the score P went from {a.P:.3f}{of} to {last.P:.3f}"
        return (f"drift: at the baseline gains {what} over {last.trial - first.trial} flights (trial {last.trial}, "
                f"re-flown twice; test threshold {self.threshold(journal):.2f}){conditions_seen(first, last)}; the "
                "gains did not cause this, the vehicle or its conditions changed (battery, propellers, payload, wind)")

    def unflyable(self, journal: Journal, why: str) -> str:
        """The message when the baseline gains, which flew the mission at the start, no longer can."""
        b = self.flights(journal)
        first, last = b[0], b[-1]
        seen = ""
        if last is not first and (first.rms is not None and last.rms is not None):
            seen = f"; its last completed flight had the lap-2 RMS at {last.rms:.2f} m against {first.rms:.2f} m"
        elif last is not first:
            seen = f"; its last completed flight scored P {last.P:.3f} against {first.P:.3f}"
        return (f"drift: the baseline gains flew the mission at trial {first.trial} and now cannot ({why}){seen}; "
                "the gains did not cause this, the vehicle or its conditions changed (battery, propellers, payload, "
                "wind)")

    def paused(self, msg: str) -> CampaignPaused:
        """The stop for a changed vehicle: what the test saw, and how to go on."""
        return CampaignPaused(f"{msg}: check the vehicle, then `{self.resume_hint}`")

    def confirm(self, journal: Journal) -> None:
        """The confirming re-flight has flown: fire when it shows the change too. Stop mode: CampaignPaused with
        the message; continue mode: the message kept in :attr:`fired` and the reference moved to this flight."""
        if not self.shows_change(journal):
            return
        msg = self.message(journal)
        if self.on_drift == "stop":
            raise self.paused(msg)
        self.fired = msg
        self.follow(journal)

    def restore(self, journal: Journal) -> None:
        """A resumed campaign: continue mode goes on against the re-flight its last corrected trial was scored
        against."""
        refs = [e.cond["ref_trial"] for e in journal.of("opt") if e.cond and e.cond.get("ref_trial") is not None]
        if self.on_drift == "continue" and refs:
            self.ref = next((e for e in self.flights(journal) if e.trial == refs[-1]), None)
            self.fired = "drift: found before the resume"

    def follow(self, journal: Journal) -> None:
        """Continue mode: score from now on against the newest baseline flight."""
        self.ref = self.flights(journal)[-1]

    def corrected(self, journal: Journal, P: float, rms: float | None, ratio: float, smooth: float = 0.0) -> float:
        """A trial's score against the baseline in the same condition (the newest re-flight once the test has
        fired): ``1 - rms / (ratio rms_ref) - smooth / ratio`` with the RMS (``smooth``: the smoothness term the trial
        was scored with, unchanged), else P shifted by the baseline's drop in P."""
        if self.ref is None:
            return P
        if rms is not None and self.ref.rms:
            return 1.0 - rms / (ratio * self.reference_rms(journal, len(journal.entries))) - smooth / ratio
        return P + (self.anchor(journal).P - self.ref.P)

    def reference_rms(self, journal: Journal, trial: int) -> float:
        """The baseline's lap-2 RMS expected at ``trial``: the newest re-flight, carried forward along the trend
        of the baseline flights (Theil-Sen slope per flight, a worsening only, at most doubling it)."""
        from scipy.stats import theilslopes

        b = [e for e in self.flights(journal) if e.rms]
        ref = self.ref if self.ref is not None and self.ref.rms else b[-1]
        if len(b) < 3:
            return ref.rms
        slope = theilslopes([e.rms for e in b], [e.trial for e in b])[0]
        return min(2.0 * ref.rms, ref.rms + max(0.0, slope) * (trial - ref.trial))
