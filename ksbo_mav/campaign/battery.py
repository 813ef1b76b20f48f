"""The pack and the autopilot's failsafes during a campaign.

Before each trial the pack must hold a trial's worth (measured on the trials flown so far) above a reserve of
:data:`RESERVE_PCT` %; when it does not, the campaign lands and stops with "swap the battery, then resume" (a
normal stop). An autopilot failsafe (the vehicle's MAV_STATE_CRITICAL, e.g. a low-battery RTL) is never
overridden: the campaign restores the baseline gains (parameter writes do not touch the flight), waits for the
autopilot's own action to land and disarm the vehicle, writes the report and stops; the trial it ended is recorded
as interrupted, never given to the optimiser.
"""

from __future__ import annotations

from collections.abc import Callable

from ksbo_mav.errors import CampaignPaused, VehicleError
from ksbo_mav.mav.power import BatteryReading
from ksbo_mav.mav.simulator import lasting_pack_hint
from ksbo_mav.mav.vehicle import Vehicle

#: The share of the pack (%) a campaign leaves unflown: below it plus one trial's use, no trial starts.
RESERVE_PCT = 25.0
#: A trial's use is taken as this many times the largest measured so far (wind, a long approach).
USE_MARGIN = 1.3
#: Vehicle seconds the campaign waits for an autopilot failsafe to land and disarm the vehicle.
FAILSAFE_WAIT_S = 300.0


class BatteryGuard:
    """Measures each trial's use of the pack and refuses a trial that would not fit (:class:`CampaignPaused`)."""

    def __init__(self, v: Vehicle, resume_hint: str, reserve_pct: float = RESERVE_PCT) -> None:
        self.v, self.resume_hint, self.reserve = v, resume_hint, float(reserve_pct)
        self.uses: list[float] = []  # % of the pack per trial
        self._start: BatteryReading | None = None
        self._said: str | None = None  # the last progress line: a pack that does not change is said once

    @property
    def next_use(self) -> float:
        """% of the pack the next trial may use: the most a trial has used so far, with a margin (0: not known)."""
        return USE_MARGIN * max(self.uses, default=0.0)

    def before_trial(self) -> None:
        now = self.v.power.reading()
        self._start = now
        if now.remaining_pct is None:
            return
        if now.remaining_pct - self.next_use < self.reserve:
            need = f"; a trial uses up to {max(self.uses):.0f} %" if self.uses else ""
            sim = lasting_pack_hint({n: p.value for n, p in self.v.params.table.items()})
            swap = f"{sim}; then" if sim else "swap the battery, then"
            raise CampaignPaused(f"battery: {now.describe()}{need}, the reserve is {self.reserve:.0f} %: {swap} "
                                 f"`{self.resume_hint}`")

    def after_trial(self) -> str | None:
        """One progress line (figures, trials left in this pack) when it differs from the last one, else None (also
        without battery figures)."""
        now = self.v.power.reading()
        if self._start is not None and self._start.remaining_pct is not None and now.remaining_pct is not None:
            self.uses.append(max(0.0, self._start.remaining_pct - now.remaining_pct))
        if now.remaining_pct is None:
            line = None if now.voltage_v is None else f"battery: {now.describe()}"
        else:
            use = self.next_use
            left = "" if not use else f", about {int(max(0.0, now.remaining_pct - self.reserve) // use)} more " \
                                          "trial(s) in this pack"
            line = f"battery: {now.describe()}{left}"
        if line == self._said:
            return None
        self._said = line
        return line


def failsafe_active(v: Vehicle) -> bool:
    """The autopilot reports a failsafe (MAV_STATE_CRITICAL) while armed: its action, not ours, flies the vehicle."""
    hb = v.guided.heartbeat
    return bool(hb is not None and hb.base_mode & 128 and hb.system_status == 5)


def await_failsafe(v: Vehicle, log: Callable[[str], None]) -> str:
    """Leave the failsafe's action (RTL, LAND) to the autopilot and wait for it to disarm the vehicle; returns what
    happened ("landed" or "unknown")."""
    g = v.guided
    g.hold_at(None)  # no setpoint of ours from here on
    mode = v.stack.mode_name(g.heartbeat.custom_mode) if g.heartbeat is not None else "?"
    log(f"the autopilot's failsafe is flying the vehicle ({mode}): waiting for it to land and disarm "
        "(ksbo-mav does not override it)")
    try:
        if g.wait(FAILSAFE_WAIT_S, lambda: not g.armed):
            log("landed and disarmed by the autopilot's failsafe")
            return "landed"
    except (VehicleError, KeyboardInterrupt) as exc:
        log(f"lost sight of the vehicle while its failsafe flies it ({exc}): take over")
        return "unknown"
    log(f"still armed {FAILSAFE_WAIT_S:g} s after the failsafe: take over")
    return "unknown"


def failsafe_message(v: Vehicle, trial: int | None, resume_hint: str) -> str:
    """The one-line stop after a failsafe: what the vehicle said, how the trial was counted, how to go on."""
    text = v.power.battery_text()
    what = "battery" if text else "autopilot"
    events = "" if text else v.cmd.recent_events()  # PX4 main says why only in EVENT messages
    said = f" (\"{text}\")" if text else f" (PX4's events: {events})" if events else ""
    where = f"during trial {trial}" if trial is not None else "between trials"
    counted = "; the trial is recorded as interrupted, not as the gains' fault" if trial is not None else ""
    sim = lasting_pack_hint({n: p.value for n, p in v.params.table.items()}) if text else None
    then = f"{sim}; then " if sim else "swap the battery, then " if text else "check the vehicle, then "
    return (f"{what}: the autopilot's failsafe took over {where}{said}, {v.power.reading().describe()}{counted}; "
            f"baseline gains restored; {then}`{resume_hint}`")
