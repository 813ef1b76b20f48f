"""In-flight safety monitor: the profile's ``[safety]`` thresholds checked on every telemetry sample.

Each check returns an *outcome code* (short, used in the tlog end marker and the trial record) and a message for
the user. The monitor only judges; what happens next (hold, restore the baseline, stop the campaign, never fight
the pilot) is decided by the trial runner, because the right reaction depends on the cause.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ksbo_mav.profiles import Profile
from ksbo_sim.monitor import MonitorLimits, check_state

#: Outcome codes. "ok" = completed; the rest abort the trial and count as unsafe in the optimiser.
OUTCOMES = {
    "ok": "completed",
    "fence": "geofence / altitude limit",
    "tilt": "tilt limit",
    "track": "tracking error limit",
    "crash": "vehicle reported a crash / disarmed",
    "pilot": "pilot changed the mode",
    "link": "link lost (no heartbeat / telemetry)",
    "verify": "parameter write not verified",
    "sigint": "interrupted (Ctrl-C)",
    "error": "unexpected error",
}
#: Outcomes caused by the gains being flown (as opposed to the pilot, the link, the user or the tool).
GAIN_OUTCOMES = ("fence", "tilt", "track", "crash")


@dataclass
class Limits:
    x_max: float = 2.0
    y_max: float = float("inf")
    z_min: float = -0.05
    z_max: float = 2.0
    tilt_max_deg: float = 85.0
    tracking_error_max: float = 1.0
    heartbeat_timeout: float = 3.0

    @classmethod
    def from_profile(cls, profile: Profile, overrides: dict[str, float] | None = None) -> "Limits":
        s = profile.section("safety") | dict(overrides or {})
        d = cls()
        return cls(x_max=float(s.get("x_max_m", d.x_max)), y_max=float(s.get("y_max_m", d.y_max)),
                   z_min=float(s.get("z_min_m", d.z_min)),
                   z_max=float(s.get("z_max_m", d.z_max)), tilt_max_deg=float(s.get("tilt_max_deg", d.tilt_max_deg)),
                   tracking_error_max=float(s.get("tracking_error_max_m", d.tracking_error_max)),
                   heartbeat_timeout=float(s.get("heartbeat_timeout_s", d.heartbeat_timeout)))


class Monitor:
    """Checks samples against :class:`Limits`; ``guided_mode`` is the custom_mode the trial runs in."""

    def __init__(self, limits: Limits, guided_mode: int) -> None:
        self.limits = limits
        self.guided_mode = guided_mode

    def check_sample(self, lpn: Any, att: Any | None, ref_ned: np.ndarray | None) -> tuple[str, str] | None:
        """Position/attitude/tracking checks on one LOCAL_POSITION_NED (+ latest ATTITUDE, + the reference sent
        for that instant, NED, or None during holds). The checks are :func:`ksbo_sim.monitor.check_state`, the
        same code the in-process simulator's monitor runs."""
        lim = self.limits
        shared = MonitorLimits(x_max=lim.x_max, y_max=lim.y_max, z_min=lim.z_min, z_max=lim.z_max,
                               tilt_max_deg=lim.tilt_max_deg, tracking_error_max=lim.tracking_error_max)
        tilt = None if att is None else max(abs(float(att.pitch)), abs(float(att.roll)))
        ref = None if ref_ned is None else (float(ref_ned[0]), float(ref_ned[1]), -float(ref_ned[2]))
        return check_state(shared, float(lpn.x), float(lpn.y), -float(lpn.z), tilt, ref)

    def check_heartbeat(self, hb: Any) -> tuple[str, str] | None:
        """Crash / disarm / pilot mode change from the vehicle's latest HEARTBEAT."""
        if hb is None:
            return None
        if hb.system_status >= 5 or not hb.base_mode & 128:
            return "crash", f"vehicle disarmed or in emergency (system_status {hb.system_status})"
        if hb.custom_mode != self.guided_mode:
            return "pilot", f"mode changed to {hb.custom_mode} by someone else"
        return None
