"""In-flight safety monitor: the profile's ``[safety]`` thresholds checked on every telemetry sample.

Each check returns an *outcome code* (:class:`ksbo_mav.mav.outcome.TrialOutcome`, short, used in the tlog end
marker and the trial record) and a message for the user. The monitor only judges; what happens next (hold, restore
the baseline, stop the campaign, never fight the pilot) is decided by the trial runner, because the right reaction
depends on the cause.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from ksbo_mav.errors import InputError
from ksbo_mav.mav.outcome import TrialOutcome
from ksbo_mav.profiles import Profile
from ksbo_task.limit_checks import MonitorLimits, check_state, tilt_rad

#: The abort thresholds: the task package's dataclass (one implementation of the limit checks for the MAVLink
#: monitor and the simulators).
Limits = MonitorLimits

_SAFETY_KEYS = {"x_max_m": "x_max", "y_max_m": "y_max", "z_min_m": "z_min", "z_max_m": "z_max",
                "tilt_max_deg": "tilt_max_deg", "tracking_error_max_m": "tracking_error_max",
                "brake_accel_mps2": "brake_accel"}


def limits_from_profile(profile: Profile, overrides: dict[str, float] | None = None) -> Limits:
    """The profile's ``[safety]`` thresholds with ``overrides`` (profile key names, e.g. ``x_max_m``) applied."""
    s = profile.safety
    raw = {field: getattr(s, key) for key, field in _SAFETY_KEYS.items()}
    values = {field: None if v is None else float(v) for field, v in raw.items()}  # brake_accel may be unset
    for key, value in (overrides or {}).items():
        if key in _SAFETY_KEYS:
            values[_SAFETY_KEYS[key]] = float(value)
        elif key != "heartbeat_timeout_s":  # that one is the vehicle link's (ksbo_mav.mav.vehicle)
            raise InputError(f"unknown safety override {key!r}; known: {', '.join(_SAFETY_KEYS)}")
    return Limits(**values)


class Monitor:
    """Checks samples against :class:`Limits`; ``guided_mode`` is the custom_mode the trial runs in, ``mode_name``
    names a custom_mode for the user (:meth:`ksbo_mav.mav.stacks.Stack.mode_name`)."""

    def __init__(self, limits: Limits, guided_mode: int, mode_name: Callable[[int], str] = str) -> None:
        self.limits = limits
        self.guided_mode = guided_mode
        self.mode_name = mode_name

    def check_sample(self, lpn: Any, att: Any | None, ref_ned: np.ndarray | None) -> tuple[str, str] | None:
        """Position/attitude/tracking checks on one LOCAL_POSITION_NED (+ latest ATTITUDE, + the reference sent
        for that instant, NED, or None during holds). The checks are :func:`ksbo_task.limit_checks.check_state`, the
        same code the in-process simulator's monitor runs; the sample's velocity feeds the stopping-point fence
        when the profile sets ``brake_accel_mps2``."""
        tilt = None if att is None else tilt_rad(float(att.roll), float(att.pitch))
        ref = None if ref_ned is None else (float(ref_ned[0]), float(ref_ned[1]), -float(ref_ned[2]))
        vel = (float(getattr(lpn, "vx", math.nan)), float(getattr(lpn, "vy", math.nan)),
               -float(getattr(lpn, "vz", math.nan)))  # no velocity in the sample: the position only
        return check_state(self.limits, float(lpn.x), float(lpn.y), -float(lpn.z), tilt, ref, vel)

    def check_heartbeat(self, hb: Any) -> tuple[str, str] | None:
        """Crash / disarm / pilot mode change from the vehicle's latest HEARTBEAT."""
        if hb is None:
            return None
        if not hb.base_mode & 128:
            return TrialOutcome.CRASH, "vehicle disarmed in flight"
        if hb.system_status >= 6:  # MAV_STATE_EMERGENCY: the vehicle is going down
            return TrialOutcome.CRASH, f"vehicle in emergency, system_status {hb.system_status}"
        if hb.system_status == 5:  # MAV_STATE_CRITICAL: a failsafe (battery, radio, GCS) took over, not the gains
            return TrialOutcome.FAILSAFE, f"the autopilot's failsafe took over (system_status {hb.system_status}, " \
                f"custom mode {hb.custom_mode})"
        if hb.custom_mode != self.guided_mode:
            return TrialOutcome.PILOT, f"mode changed to {self.mode_name(hb.custom_mode)} by the pilot or a " \
                "ground station"
        return None
