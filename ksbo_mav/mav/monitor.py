"""In-flight safety monitor: the profile's ``[safety]`` thresholds checked on every telemetry sample.

Each check returns an *outcome code* (short, used in the tlog end marker and the trial record) and a message for
the user. The monitor only judges; what happens next (hold, restore the baseline, stop the campaign, never fight
the pilot) is decided by the trial runner, because the right reaction depends on the cause.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ksbo_mav.profiles import Profile

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
        for that instant, NED, or None during holds)."""
        lim = self.limits
        north, up = float(lpn.x), -float(lpn.z)
        if not (math.isfinite(north) and math.isfinite(up)):
            return "fence", "telemetry position is not finite"
        if abs(north) > lim.x_max:
            return "fence", f"|north| {abs(north):.2f} m > {lim.x_max:g} m"
        if abs(float(lpn.y)) > lim.y_max:
            return "fence", f"|east| {abs(float(lpn.y)):.2f} m > {lim.y_max:g} m"
        if up < lim.z_min or up > lim.z_max:
            return "fence", f"height {up:.2f} m outside [{lim.z_min:g}, {lim.z_max:g}] m"
        if att is not None:
            tilt = math.degrees(max(abs(float(att.pitch)), abs(float(att.roll))))
            if tilt > lim.tilt_max_deg:
                return "tilt", f"tilt {tilt:.0f} deg > {lim.tilt_max_deg:g} deg"
        if ref_ned is not None:
            err = math.sqrt((north - ref_ned[0]) ** 2 + (float(lpn.y) - ref_ned[1]) ** 2
                            + (float(lpn.z) - ref_ned[2]) ** 2)
            if err > lim.tracking_error_max:
                return "track", f"tracking error {err:.2f} m > {lim.tracking_error_max:g} m"
        return None

    def check_heartbeat(self, hb: Any) -> tuple[str, str] | None:
        """Crash / disarm / pilot mode change from the vehicle's latest HEARTBEAT."""
        if hb is None:
            return None
        if hb.system_status >= 5 or not hb.base_mode & 128:
            return "crash", f"vehicle disarmed or in emergency (system_status {hb.system_status})"
        if hb.custom_mode != self.guided_mode:
            return "pilot", f"mode changed to {hb.custom_mode} by someone else"
        return None
