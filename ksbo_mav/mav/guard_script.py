"""The onboard guard's protocol words and its script, rendered for one campaign.

The guard (``ksbo_mav/onboard/ksbo_guard.lua``, an ArduPilot Lua script; the built-in simulator runs the same
protocol in ``ksbo_sim.mavlink.guard``) keeps the baseline gains on the vehicle and puts them back itself when a
trial goes wrong while the tuner cannot act. The protocol, all of it:

* ``KSG_STATE`` (script parameter): the tuner writes 1 to arm a trial and 0 to end it; the guard answers 1
  (armed), 3 (refused: not armed, not in GUIDED, no heartbeat from the tuner's system id) or, after it acted,
  2 (tripped). A reboot or script restart starts at 0.
* ``KSG_TRIP`` (script parameter): why it tripped (:data:`TRIP_REASONS`).
* NAMED_VALUE_FLOAT ``KSG_ALIVE`` = the state and ``KSG_CFG`` = the configuration id, twice a second: the tuner
  knows the guard runs and that it runs *this* campaign's configuration.
* STATUSTEXT ``KSG: ...`` for every arming, refusal and trip.
* The figure-8 flown on board (a guard rendered with a :class:`Figure8OnBoard`): ``KSG_F8`` (script parameter)
  the tuner writes 1 while the trial is armed to start it, 0 to stop it; the guard answers in ``KSG_T0`` the
  vehicle time of the figure-8's t = 0 (``time_boot_ms`` modulo 2^24, exact in a float; -1 until it started).
  It then flies the figure-8 to its end, holds the end point, and trips on a tracking error past its limit too.
  Leaving the armed state (the tuner's 0, a trip) ends it; the guard puts both back.
* ``KSG_MODES`` (script parameter): the flight modes the tuner itself switches to during the next armed flight,
  besides GUIDED (a validation flight's LOITER hold or AUTO mission), as a bit mask of ArduCopter custom modes
  (:func:`modes_mask`), written before ``KSG_STATE`` = 1. The guard reads it when it arms and puts it back to 0
  when the armed flight ends, so a trial it was not written for is GUIDED only. Any other mode is a pilot's.

What the guard must know (the gains and their baseline values, the limits, the modes) is written into the script
itself before upload, between the ``KSBO_CONFIG_BEGIN``/``END`` markers: nothing but ``KSG_STATE`` changes during
a campaign, and what runs on the vehicle can be read back as one file.
"""

from __future__ import annotations

import math
import random
from dataclasses import dataclass
from enum import IntEnum
from importlib import resources
from typing import Any

from ksbo_mav.errors import InputError

SCRIPT_NAME = "ksbo_guard.lua"
STATE_PARAM, TRIP_PARAM = "KSG_STATE", "KSG_TRIP"
FIGURE8_PARAM, T0_PARAM = "KSG_F8", "KSG_T0"
MODES_PARAM = "KSG_MODES"
ALIVE_NAME, CONFIG_NAME = "KSG_ALIVE", "KSG_CFG"
#: Everything the guard adds to the parameter list, with the value it is left at.
GUARD_PARAMS = {STATE_PARAM: 0.0, TRIP_PARAM: 0.0, FIGURE8_PARAM: 0.0, T0_PARAM: -1.0, MODES_PARAM: 0.0}
#: Box limits past this are written as this: Lua reads the number, and "unbounded" needs no special case.
_UNBOUNDED = 1.0e6


class GuardState(IntEnum):
    IDLE = 0
    ARMED = 1
    TRIPPED = 2
    REFUSED = 3


TRIP_REASONS = {0: "none", 1: "tuner link lost", 2: "box", 3: "tilt", 4: "pilot mode change",
                5: "disarmed", 6: "no position estimate", 7: "tracking error"}
#: ``KSG_MODES`` holds a bit per custom mode below this (a float holds every integer below 2^24 exactly).
MODES_LIMIT = 24


def modes_mask(modes: Any) -> float:
    """``KSG_MODES`` for the custom modes ``modes`` (ArduCopter numbering, each below :data:`MODES_LIMIT`)."""
    mask = 0
    for m in set(int(m) for m in modes):
        if not 0 <= m < MODES_LIMIT:
            raise InputError(f"onboard guard: custom mode {m} cannot be declared the tuner's own (0..23 only)")
        mask |= 1 << m
    return float(mask)


@dataclass(frozen=True)
class Figure8OnBoard:
    """The figure-8 the guard flies itself (:class:`ksbo_task.figure8_ne.Figure8H` with its lead-in, centred on the
    EKF origin): amplitudes (m), period (s), height above the origin (m), lead-in (s), how long (ms: laps x period,
    the lead-in inside it, as the ground's stream), a target every ``tick_ms``, and the tracking error (m) past
    which the guard trips (0: none)."""

    amp_north: float
    amp_east: float
    period: float
    up: float
    lead_in: float
    duration_ms: int
    tick_ms: int = 10
    track_max: float = 0.0

    def __post_init__(self) -> None:
        if not (self.period > 0 and self.duration_ms > 0 and 1 <= self.tick_ms <= 100):
            raise InputError(f"onboard figure-8: bad period {self.period!r} s, duration {self.duration_ms!r} ms "
                             f"or tick {self.tick_ms!r} ms")


@dataclass(frozen=True)
class GuardConfig:
    """What one campaign's guard enforces. ``gains``: autopilot parameter name -> baseline value; the box is
    north/east/height above the EKF origin as in ``[safety]``; ``link_timeout_s`` the profile's
    ``heartbeat_timeout_s``; modes are ArduCopter custom modes (BRAKE, then ``safe_mode``, LOITER by default)."""

    gains: dict[str, float]
    x_max: float
    y_max: float
    z_min: float
    z_max: float
    tilt_max_deg: float
    link_timeout_s: float
    brake_accel: float | None = None
    config_id: int = 1
    guided_mode: int = 4
    brake_mode: int = 17
    safe_mode: int = 5
    land_mode: int = 9
    brake_hold_s: float = 2.0
    figure8: Figure8OnBoard | None = None

    def __post_init__(self) -> None:
        if not self.gains:
            raise InputError("the onboard guard needs at least one gain to restore")
        for name, value in self.gains.items():
            if not (0 < len(name) <= 16 and name.replace("_", "").isalnum()) or not math.isfinite(value):
                raise InputError(f"onboard guard: bad gain {name!r} = {value!r}")
        if not 0 < self.config_id < 2 ** 24:  # sent as a float: exact up to 2^24
            raise InputError(f"onboard guard: config id {self.config_id} outside 1..2^24-1")


def new_config_id() -> int:
    """A configuration id for one campaign's guard (tells its KSG_CFG apart from an earlier campaign's)."""
    return random.randint(1, 2 ** 24 - 1)


def _num(v: float | None) -> str:
    if v is None:
        return "0"
    return repr(float(min(v, _UNBOUNDED) if v > 0 else max(v, -_UNBOUNDED)))


def config_block(cfg: GuardConfig) -> str:
    """The Lua lines that replace the shipped script's configuration block."""
    gains = ", ".join(f'{{"{n}", {float(v)!r}}}' for n, v in cfg.gains.items())
    return "\n".join([
        f"local CONFIG_ID = {cfg.config_id}",
        f"local GAINS = {{{gains}}}",
        f"local LINK_TIMEOUT_MS = {round(cfg.link_timeout_s * 1000)}",
        (f"local X_MAX, Y_MAX, Z_MIN, Z_MAX = {_num(cfg.x_max)}, {_num(cfg.y_max)}, {_num(cfg.z_min)}, "
         f"{_num(cfg.z_max)}"),
        f"local TILT_MAX_DEG = {_num(cfg.tilt_max_deg)}",
        f"local BRAKE_ACCEL = {_num(cfg.brake_accel)}",
        (f"local GUIDED_MODE, BRAKE_MODE, SAFE_MODE, LAND_MODE = {cfg.guided_mode}, {cfg.brake_mode}, "
         f"{cfg.safe_mode}, {cfg.land_mode}"),
        f"local BRAKE_HOLD_MS = {round(cfg.brake_hold_s * 1000)}",
        *_figure8_lines(cfg.figure8),
    ])


def _figure8_lines(f8: Figure8OnBoard | None) -> list[str]:
    if f8 is None:  # no figure-8 on board: the script's F8_DURATION_MS 0 never starts one
        return ["local F8_AMP_N, F8_AMP_E, F8_PERIOD, F8_UP, F8_LEAD = 0, 0, 0, 0, 0",
                "local F8_DURATION_MS, F8_TICK_MS, TRACK_MAX = 0, 10, 0"]
    return [f"local F8_AMP_N, F8_AMP_E, F8_PERIOD, F8_UP, F8_LEAD = {_num(f8.amp_north)}, {_num(f8.amp_east)}, "
            f"{_num(f8.period)}, {_num(f8.up)}, {_num(f8.lead_in)}",
            f"local F8_DURATION_MS, F8_TICK_MS, TRACK_MAX = {int(f8.duration_ms)}, {int(f8.tick_ms)}, "
            f"{_num(f8.track_max)}"]


def figure8_for(mission: Any, track_max: float) -> Figure8OnBoard:
    """The onboard figure-8 of a ``figure8-ne`` :class:`~ksbo_mav.mav.mission.Mission` (its reference, lead-in and
    length: the same pattern the ground streams); ``track_max`` the guard's tracking-error limit (m)."""
    if mission.kind != "figure8-ne":
        raise InputError(f"the figure-8 flown on board is the 3-D copters' figure8-ne, not {mission.kind}")
    f = mission.figure8h
    from ksbo_mav.mav.trajectory import board_text  # (the recorder's module; imported here, where it is needed)

    if len(board_text(f)) > 50:
        raise InputError(f"the figure-8's numbers are too long for the tlog's marker ({board_text(f)!r}): give the "
                         "profile's [mission] fewer digits")
    return Figure8OnBoard(f.amp_north, f.amp_east, f.period, f.altitude, f.lead_in,
                          int(mission.steps * mission.dt_ms), track_max=float(track_max))


def shipped_script() -> str:
    return resources.files("ksbo_mav.onboard").joinpath(SCRIPT_NAME).read_text()


def render_script(cfg: GuardConfig) -> bytes:
    """The shipped script with ``cfg`` written into its configuration block."""
    text = shipped_script()
    begin, end = "-- KSBO_CONFIG_BEGIN\n", "-- KSBO_CONFIG_END\n"
    i, j = text.index(begin) + len(begin), text.index(end)
    return (text[:i] + config_block(cfg) + "\n" + text[j:]).encode()



def config_for(limits: Any, link_timeout_s: float, baseline: dict[str, float], config_id: int,
               figure8: Figure8OnBoard | None = None) -> GuardConfig:
    """The guard's configuration from the monitor's limits (:class:`ksbo_task.limit_checks.MonitorLimits`, overrides
    applied), the profile's link timeout and the baseline ``{autopilot parameter name: value}``; with ``figure8``
    it flies the trials' figure-8 on board."""
    return GuardConfig(dict(baseline), limits.x_max, limits.y_max, limits.z_min, limits.z_max, limits.tilt_max_deg,
                       float(link_timeout_s), limits.brake_accel, config_id, figure8=figure8)
