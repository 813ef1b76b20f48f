"""Shared by the onboard-trial tests (built-in simulator and ArduCopter SITL): a short figure-8, the guard installed
for it and the vehicle airborne, a pair of trials flown on board and streamed, and what a trial's tlog says was
streamed."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from ksbo_mav.mav.guard_script import config_for, figure8_for, new_config_id
from ksbo_mav.mav.mission import MASK_POS_VEL_ACC, Mission
from ksbo_mav.mav.monitor import limits_from_profile
from ksbo_mav.mav.objective import MavlinkObjective
from ksbo_mav.mav.onboard_guard import OnboardGuard
from ksbo_mav.mav.tlog import read_tlog
from ksbo_mav.mav.trajectory import END_RE, START_RE


def short_mission(m: Mission) -> Mission:
    """The profile's figure-8 made short: 4 m x 1 m, 8 s period, 2 s lead-in, 2 laps (16 s)."""
    return replace(m, scale=4.0, scale2=1.0, period=8.0, lead_in=2.0, laps=2)


def guarded_and_airborne(v) -> tuple[dict[str, float], OnboardGuard]:
    """The short figure-8 set, the baseline gains read, the guard installed with the profile's limits and that
    figure-8, the streams set up and the vehicle airborne: (baseline gains, guard)."""
    v.mission = short_mission(v.mission)
    base = {n: v.params.read(n) for n in v.gain_map.param_names}
    limits = limits_from_profile(v.profile)
    guard = OnboardGuard(v.link, v.params, v.cmd)
    guard.install(config_for(limits, v.heartbeat_timeout, base, new_config_id(),
                             figure8=figure8_for(v.mission, 1.5 * limits.tracking_error_max)))
    v.guard = guard
    v.setup_streams()
    v.ensure_airborne()
    return base, guard


def fly_pair_of_trials(v, base: dict[str, float], d: Path):
    """The baseline flown once on board, then once streamed, by the tuner's own objective: (on board, streamed)."""
    obj = MavlinkObjective(v, base, d)
    x = v.gain_map.from_params(base)
    board = obj.fly(x, label="on board")
    obj.trial_flight.on_board = False
    return board, obj.fly(x, label="streamed")


def sent_setpoints(tlog: str | Path) -> int:
    """Position+velocity+acceleration setpoints the tuner sent between the trial's start and end markers."""
    n, inside = 0, False
    for r in read_tlog(tlog):
        kind = r.msg.get_type()
        if r.sent and kind == "STATUSTEXT":
            text = str(r.msg.text)
            inside = bool(START_RE.match(text)) or (inside and not END_RE.match(text))
        elif r.sent and inside and kind == "SET_POSITION_TARGET_LOCAL_NED" and r.msg.type_mask == MASK_POS_VEL_ACC:
            n += 1
    return n
