"""When the link comes back after it was lost mid-trial: what happened on the vehicle while the tuner could not see
it, and whether the tuner may take the vehicle back.

Read before anything is written: the onboard guard's state (did it trip, why, what it said), the flight mode,
whether the vehicle is armed, and which gains are set (the trial's, the baseline's or a mix). The trial stays
interrupted whatever is found (a lost link is never the gains' doing); the baseline is then restored and verified
by the caller as after any trial.

The tuner takes the vehicle back (GUIDED, holding where it is) only from what its own guard did for the lost link:
the guard tripped for "tuner link lost" and the vehicle is armed in the guard's BRAKE or safe mode. Any other mode,
a guard that tripped for another reason (the pilot's mode change), or a disarmed vehicle is somebody else's, as
between any two trials (:mod:`ksbo_mav.mav.pilot`): the campaign stops there.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

from ksbo_mav.errors import KsboError
from ksbo_mav.mav.guard_script import TRIP_REASONS, GuardState
from ksbo_mav.mav.vehicle import Vehicle

#: How long to wait for the guard's twice-a-second KSG_ALIVE once the link is back (wall seconds).
GUARD_REPORT_WAIT_S = 2.0
LINK_TRIP = 1  # KSG_TRIP: tuner link lost


@dataclass(frozen=True)
class LinkReturn:
    """What the vehicle did while the link was down.

    Attributes:
        silent_s: how long the tuner heard nothing (wall seconds, until the heartbeat was back).
        guard: the guard's state once the link was back (None: no guard, or it did not report).
        trip: the guard's trip reason code (``KSG_TRIP``; 0 none, None unknown).
        guard_text: the guard's last STATUSTEXT.
        mode: the vehicle's flight mode by name; armed: whether it is armed.
        gains: "the trial's", "the baseline's", or "N of M at the baseline" (None: not read).
    """

    silent_s: float
    guard: GuardState | None
    trip: int | None
    guard_text: str
    mode: str
    armed: bool
    gains: str | None
    guard_modes: tuple[int, ...] = ()
    custom_mode: int = -1

    @property
    def guard_acted_for_link(self) -> bool:
        return self.guard == GuardState.TRIPPED and self.trip == LINK_TRIP

    @property
    def ours_to_take_back(self) -> bool:
        """Armed in a mode the guard set for the lost link: the tuner may switch it back to GUIDED."""
        return self.armed and self.guard_acted_for_link and self.custom_mode in self.guard_modes

    def text(self) -> str:
        if self.guard is None:
            guard = "no onboard guard report"
        elif self.guard == GuardState.TRIPPED:
            why = TRIP_REASONS.get(self.trip, "unknown") if self.trip is not None else "unknown"
            guard = f"the onboard guard had acted ({why}" + (f": {self.guard_text}" if self.guard_text else "") + ")"
        else:
            guard = f"the onboard guard had not acted (state {self.guard.name.lower()})"
        gains = f", {self.gains} gains set" if self.gains else ""
        return (f"link back after {self.silent_s:.1f} s: {guard}; vehicle {'armed' if self.armed else 'DISARMED'} in "
                f"{self.mode}{gains}")


def _gains(v: Vehicle, trial: dict[str, float], baseline: dict[str, float]) -> str | None:
    """Which gains the vehicle holds, by a fresh read of each."""
    try:
        now = {name: v.params.read(name) for name in baseline}
    except KsboError:
        return None
    same = lambda a, b: math.isclose(a, b, rel_tol=1e-5, abs_tol=1e-6)  # noqa: E731  (float32 on the wire)
    at_base = sum(same(now[n], baseline[n]) for n in baseline)
    if at_base == len(baseline):
        return "the baseline's"
    if all(n in trial and same(now[n], trial[n]) for n in baseline):
        return "the trial's"
    return f"{at_base} of {len(baseline)} at the baseline"


def survey(v: Vehicle, silent_s: float, trial: dict[str, float], baseline: dict[str, float]) -> LinkReturn:
    """Read what the vehicle did while the link was down (nothing is written)."""
    guard = v.guard
    state, trip, text, modes = None, None, "", ()
    if guard is not None:
        guard.alive_state = None  # a fresh report, not the one from before the cut
        deadline = time.monotonic() + GUARD_REPORT_WAIT_S
        while guard.alive_state is None and time.monotonic() < deadline:
            v.link.pump(0.05)
        state = guard.alive_state
        # the guard's trip text, when it arrived (sent while the link was down it is lost; an older one misleads)
        text = guard.last_text() if "gains" in guard.last_text() else ""
        if guard.config is not None:
            modes = (guard.config.brake_mode, guard.config.safe_mode)
        try:
            trip = guard.trip_code()
        except KsboError:
            trip = None
    hb = v.link.last_heartbeat
    custom = int(hb.custom_mode) if hb is not None else -1
    return LinkReturn(silent_s, state, trip, text, v.stack.mode_name(custom) if hb is not None else "unknown mode",
                      bool(hb is not None and hb.base_mode & 128), _gains(v, trial, baseline), modes, custom)


def take_back(v: Vehicle, found: LinkReturn) -> str:
    """Switch the vehicle back to GUIDED, holding where it is, when :attr:`LinkReturn.ours_to_take_back`; what was
    done, for the trial's message ("" when the vehicle is left as it is)."""
    g = v.guided
    if g.in_mode("guided") and g.armed:
        return ""
    if not found.ours_to_take_back:
        return ("left as it is (landed and disarmed)" if not found.armed
                else "left as it is (not the guard's doing)")
    guided_here(v)
    return f"taken back from {found.mode} to GUIDED"


def guided_here(v: Vehicle) -> None:
    """GUIDED again, holding where the vehicle is (the guard stopped it in its BRAKE or safe mode)."""
    g = v.guided
    here = g.position()
    if here is not None:
        g.hold_at(here)
    g.cmd.set_mode("guided")
