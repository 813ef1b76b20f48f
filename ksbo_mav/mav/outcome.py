"""How a flown trial ended: one enum for the monitor, the trial runner, the journal, the display and the report.

``TrialOutcome`` is a ``str`` enum, so it is written to JSON (trial records, the journal, the tlog end marker) as
its short code and compares equal to it. :attr:`TrialOutcome.evaluation` maps it onto the optimiser's coarser
:class:`ksbo_mav.opt.evaluation.Outcome` (complete / aborted / crashed), the same classes the in-process simulators use.
"""

from __future__ import annotations

from enum import Enum

from ksbo_mav.opt.evaluation import Outcome


class TrialOutcome(str, Enum):
    OK = "ok"
    FENCE = "fence"
    TILT = "tilt"
    TRACK = "track"
    CRASH = "crash"
    VERIFY = "verify"
    PILOT = "pilot"
    FAILSAFE = "failsafe"
    LINK = "link"
    TELEMETRY = "telemetry"
    CLIENT = "client"
    SIGINT = "sigint"
    ERROR = "error"

    def __str__(self) -> str:  # the short code in messages and markers, on every Python version
        return self.value

    def __format__(self, spec: str) -> str:
        return format(self.value, spec)

    @property
    def text(self) -> str:
        return _TEXT[self]

    @property
    def gain_caused(self) -> bool:
        """The gains being flown caused it (geofence, tilt, tracking error, crash)."""
        return self in (TrialOutcome.FENCE, TrialOutcome.TILT, TrialOutcome.TRACK, TrialOutcome.CRASH)

    @property
    def continues(self) -> bool:
        """The campaign goes on after it: the flight says something about the gains (a refused write too)."""
        return self is TrialOutcome.OK or self is TrialOutcome.VERIFY or self.gain_caused

    @property
    def retry(self) -> bool:
        """Spoiled by this computer or the link, not the gains: worth flying again."""
        return self in (TrialOutcome.TELEMETRY, TrialOutcome.CLIENT)

    @property
    def evaluation(self) -> Outcome:
        """The optimiser's view: complete, aborted (censored) or crashed."""
        if self is TrialOutcome.OK:
            return Outcome.COMPLETE
        return Outcome.CRASHED if self is TrialOutcome.CRASH else Outcome.ABORTED


_TEXT = {
    TrialOutcome.OK: "completed",
    TrialOutcome.FENCE: "geofence / altitude limit",
    TrialOutcome.TILT: "tilt limit",
    TrialOutcome.TRACK: "tracking error limit",
    TrialOutcome.CRASH: "vehicle reported a crash / disarmed",
    TrialOutcome.VERIFY: "parameter write not verified",
    TrialOutcome.PILOT: "pilot changed the mode",
    TrialOutcome.FAILSAFE: "the autopilot's failsafe took over (battery, radio or another; not the gains)",
    TrialOutcome.LINK: "link lost (no heartbeat / telemetry)",
    TrialOutcome.TELEMETRY: "telemetry too sparse to score",
    TrialOutcome.CLIENT: "the tuner fell behind the vehicle",
    TrialOutcome.SIGINT: "interrupted (Ctrl-C)",
    TrialOutcome.ERROR: "unexpected error",
}
