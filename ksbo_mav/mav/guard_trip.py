"""What the onboard guard's trip means for the flight it watched, and taking the vehicle back from what it did.

When the guard trips for the box, the tilt or the tracking error it switches the vehicle to BRAKE (then its safe
mode) itself. The tuner's monitor then sees a mode it did not set, which on its own reads as a pilot's take-over.
It is not: the gains being flown broke a limit, and the flight is aborted-and-recovered as when the monitor on the
ground aborts it (:attr:`~ksbo_mav.mav.outcome.TrialOutcome.gain_caused`). The guard's trip code tells the two
apart: code 4 (pilot mode change), or no trip at all, stays a pilot's; and so does a vehicle found in any mode but
the guard's BRAKE or safe mode (a pilot switched after the guard acted).

After the baseline is restored and verified the tuner takes back a vehicle the guard stopped — for the gains or for
a lost link — in GUIDED, holding where it is, as :mod:`ksbo_mav.mav.link_return` does after a link loss.
"""

from __future__ import annotations

from dataclasses import dataclass

from ksbo_mav.errors import KsboError
from ksbo_mav.mav.guard_script import TRIP_REASONS, GuardState
from ksbo_mav.mav.link_return import guided_here
from ksbo_mav.mav.outcome import TrialOutcome as T
from ksbo_mav.mav.vehicle import Vehicle

#: Trip codes of the gains' own doing, and the outcome the ground monitor gives the same breach.
GAIN_TRIPS = {2: T.FENCE, 3: T.TILT, 7: T.TRACK}
LINK_TRIP = 1


@dataclass(frozen=True)
class GuardTrip:
    """The guard's trip at the end of a flight: its code (``KSG_TRIP``) and its STATUSTEXT."""

    code: int
    text: str

    @property
    def reason(self) -> str:
        return TRIP_REASONS.get(self.code, "unknown")

    @property
    def outcome(self) -> T | None:
        """The gain-caused outcome of this trip, None when it is not the gains' doing."""
        return GAIN_TRIPS.get(self.code)

    def note(self) -> str:
        return f"the onboard guard tripped: {self.reason}" + (f" ({self.text})" if self.text else "")


def end_watch(v: Vehicle) -> tuple[str, GuardTrip | None]:
    """End the guard's watch of the flight (``v.guard``; nothing without one). Returns the note for the flight's
    message and the trip when the guard had acted."""
    guard = v.guard
    if guard is None:
        return "", None
    try:
        if guard.disarm_trial() != GuardState.TRIPPED:
            return "", None
        # KSG_TRIP stays until the next arming; the trip's STATUSTEXT may have been lost (a cut link): an older
        # text (the arming's) would mislead
        text = guard.last_text() if "gains" in guard.last_text() else ""
        trip = GuardTrip(guard.trip_code(), text)
    except KsboError as exc:
        return f"the onboard guard was not disarmed: {exc}", None
    return trip.note(), trip


def _guards_stop(v: Vehicle) -> bool:
    """Armed in the guard's BRAKE or safe mode."""
    hb, cfg = v.guided.heartbeat, v.guard.config if v.guard is not None else None
    return bool(hb is not None and cfg is not None and hb.base_mode & 128
                and int(hb.custom_mode) in (cfg.brake_mode, cfg.safe_mode))


def _landed_in_guards_mode(v: Vehicle) -> bool:
    """Disarmed on the ground in the guard's BRAKE or safe mode: its stop came down where nobody held the sticks."""
    hb, cfg = v.guided.heartbeat, v.guard.config if v.guard is not None else None
    height = v.guided.height() if v.guided.position() is not None else None
    return bool(hb is not None and cfg is not None and not hb.base_mode & 128 and height is not None and height < 1.0
                and int(hb.custom_mode) in (cfg.brake_mode, cfg.safe_mode))


def classify(v: Vehicle, outcome: T, message: str, trip: GuardTrip | None) -> tuple[T, str]:
    """A flight that the guard stopped for the gains (a gain-caused trip, the vehicle still in its BRAKE or safe
    mode) and that the monitor ended as a pilot's mode change, or did not end at all (the tuner ended the watch
    before it saw the new mode), gets that trip's outcome; one the guard stopped because the tuner's heartbeat
    stopped reaching it while the tuner still heard the vehicle (a tuner held up by a busy computer, a one-way
    link) is a lost link, not a pilot, and so is a vehicle that then landed and disarmed in the guard's mode (not a
    crash: nobody held the sticks); everything else stays as it is."""
    if trip is not None and trip.code == LINK_TRIP and outcome is T.CRASH and _landed_in_guards_mode(v):
        return T.LINK, ("the onboard guard stopped hearing the tuner (the tuner held up, or the link one way) and the "
                        f"vehicle landed and disarmed in its {v.stack.mode_name(int(v.guided.heartbeat.custom_mode))} "
                        "(nobody on the sticks)")
    if outcome not in (T.PILOT, T.OK) or trip is None or not _guards_stop(v):
        return outcome, message
    mode = v.stack.mode_name(int(v.guided.heartbeat.custom_mode))
    if trip.code == LINK_TRIP:
        return T.LINK, (f"the onboard guard stopped hearing the tuner and switched to {mode} (the tuner held up, or "
                        "the link one way)")
    if trip.outcome is None:
        return outcome, message
    return trip.outcome, f"{trip.outcome.text} on board (the guard switched to {mode})"


def take_back(v: Vehicle, trip: GuardTrip | None) -> str:
    """Once the baseline is restored and verified: GUIDED again, holding where it is, then parked as after any
    flight, when the guard tripped for the gains or a lost link and the vehicle is armed in its BRAKE or safe mode.
    What was done, for the flight's message ("" when nothing was; "not taken back: ..." when it failed)."""
    if trip is None or not (trip.outcome is not None or trip.code == LINK_TRIP) or not _guards_stop(v):
        return ""
    mode = v.stack.mode_name(int(v.guided.heartbeat.custom_mode))
    try:
        guided_here(v)
        v.guided.park()
    except KsboError as exc:
        return f"not taken back: {exc}"
    return f"taken back from the guard's {mode} to GUIDED"
