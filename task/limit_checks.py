"""The safety monitor's limit checks, one implementation for the in-process simulator and the MAVLink tuner.

Pure functions of numbers and arrays (no MAVLink, no profiles): :func:`check_state` judges one sample and
returns ``(code, message)`` or None; :func:`trip_codes` judges a batch of planar states at once. The MAVLink
monitor (``ksbo_mav.mav.monitor``) calls :func:`check_state` on telemetry; the planar episode
(``ksbo_sim.episode.simulate`` with ``EpisodeConfig.monitor``) calls :func:`trip_codes` every control step and
on a trip switches the flight to the backup (baseline) gains holding a fixed point.

Outcome of a flight (:class:`Outcome`): ``complete`` (flew the mission), ``aborted`` (the monitor tripped and the
backup recovered: it costs a flight, not a vehicle) or ``crashed`` (the environment bounds were left, with or
without the monitor).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

import numpy as np


class Outcome(str, Enum):
    """How a trial ended. ``str`` valued, so ``Outcome.ABORTED == "aborted"`` and it serialises as text."""

    COMPLETE = "complete"
    ABORTED = "aborted"
    CRASHED = "crashed"

    @classmethod
    def parse(cls, value: "Outcome | str") -> "Outcome":
        """``Outcome`` from itself or its text ("completed" and "ok" are accepted for "complete")."""
        if isinstance(value, Outcome):
            return value
        v = str(value).strip().lower()
        if v in ("completed", "ok"):
            return cls.COMPLETE
        return cls(v)


#: Trip codes of :func:`trip_codes` (0 = no trip).
NO_TRIP, FENCE, TILT, TRACK = 0, 1, 2, 3
TRIP_NAMES = {NO_TRIP: "ok", FENCE: "fence", TILT: "tilt", TRACK: "track"}


@dataclass(frozen=True)
class MonitorLimits:
    """Abort thresholds (metres, degrees). ``x`` is north (planar x), ``up`` the height.

    The defaults are the planar task's environment bounds (the MAVLink profile ``sim-planar``); the in-process
    monitor uses :func:`planar_monitor_limits`, tighter than the crash bounds so the backup has room to recover.
    """

    x_max: float = 2.0
    y_max: float = float("inf")
    z_min: float = -0.05
    z_max: float = 2.0
    tilt_max_deg: float = 85.0
    tracking_error_max: float = 1.0
    #: Deceleration (m/s²) of the stopping-point fence: given a velocity, the box is checked at the point where
    #: the vehicle would stop, ``p + v·|v| / (2 brake_accel)`` per axis, so a fast vehicle trips while the backup
    #: still has room to brake. None: the position only.
    brake_accel: float | None = None


def planar_monitor_limits() -> MonitorLimits:
    """In-process planar monitor: a ±1.6 m × [0.2, 1.8] m box checked at the stopping point (3 m/s² braking), 60°
    tilt, 1 m tracking error (the figure-8 spans ±0.75 m × [0.625, 1.375] m at up to 1.3 m/s, so a good flight
    never comes near these)."""
    return MonitorLimits(x_max=1.6, z_min=0.2, z_max=1.8, tilt_max_deg=60.0, tracking_error_max=1.0,
                         brake_accel=3.0)


def stopping_point(lim: MonitorLimits, p: np.ndarray | float, v: np.ndarray | float | None) -> np.ndarray | float:
    """Where the box is checked: ``p`` itself, or with a velocity and ``lim.brake_accel`` the stopping point
    ``p + v·|v| / (2 brake_accel)``."""
    if v is None or lim.brake_accel is None:
        return p
    return p + v * np.abs(v) / (2.0 * lim.brake_accel)


def _past(value: float, limit: float, digits: int) -> str:
    """``value`` with ``digits`` decimals, or as many more as it takes to differ from ``limit``: a message that
    reads "tilt 60 deg > 60 deg" hides why it tripped (60.4 > 60)."""
    for d in range(digits, digits + 7):
        text = f"{value:.{d}f}"
        if float(text) != limit:
            return text
    return f"{value:.{digits + 6}f}"


def tilt_rad(roll: float, pitch: float) -> float:
    """The angle between the body's z axis and the vertical for Euler roll and pitch (rad): acos(cos r cos p).

    max(|roll|, |pitch|) reads low when both lean at once: roll and pitch of 35 deg each are a 47 deg tilt."""
    return math.acos(max(-1.0, min(1.0, math.cos(roll) * math.cos(pitch))))


def check_state(lim: MonitorLimits, north: float, east: float, up: float, tilt_rad: float | None = None,
                ref: tuple[float, float, float] | None = None,
                vel: tuple[float, float, float] | None = None) -> tuple[str, str] | None:
    """One sample against ``lim``: ``(code, message)`` with code "fence", "tilt" or "track", or None.

    Args:
        north, east, up: position (m). tilt_rad: the tilt (:func:`tilt_rad`) or None if unknown.
        ref: reference (north, east, up) for the tracking-error check, or None (holds).
        vel: velocity (north, east, up) in m/s for the stopping-point fence (``lim.brake_accel``), or None.
    """
    if not (math.isfinite(north) and math.isfinite(up)):
        return "fence", "telemetry position is not finite"
    v = (None, None, None) if vel is None or not all(map(math.isfinite, vel)) else vel
    stop = "" if v[0] is None or lim.brake_accel is None else " at the stopping point"
    n_, e_, u_ = (float(stopping_point(lim, p, w)) for p, w in zip((north, east, up), v))
    if abs(n_) > lim.x_max:
        return "fence", f"|north| {_past(abs(n_), lim.x_max, 2)} m{stop} > {lim.x_max:g} m"
    if abs(e_) > lim.y_max:
        return "fence", f"|east| {_past(abs(e_), lim.y_max, 2)} m{stop} > {lim.y_max:g} m"
    if u_ < lim.z_min or u_ > lim.z_max:
        bound = lim.z_min if u_ < lim.z_min else lim.z_max
        return "fence", f"height {_past(u_, bound, 2)} m{stop} outside [{lim.z_min:g}, {lim.z_max:g}] m"
    if tilt_rad is not None:
        tilt = math.degrees(abs(tilt_rad))
        if tilt > lim.tilt_max_deg:
            return "tilt", f"tilt {_past(tilt, lim.tilt_max_deg, 0)} deg > {lim.tilt_max_deg:g} deg"
    if ref is not None:
        err = math.sqrt((north - ref[0]) ** 2 + (east - ref[1]) ** 2 + (up - ref[2]) ** 2)
        if err > lim.tracking_error_max:
            return "track", f"tracking error {_past(err, lim.tracking_error_max, 2)} m > {lim.tracking_error_max:g} m"
    return None


def trip_codes(lim: MonitorLimits, states: np.ndarray, ref_xz: np.ndarray | None) -> np.ndarray:
    """(B,) trip code of each planar state (B, 6) [x, vx, z, vz, θ, θ̇]; ``ref_xz`` (2,) or (B, 2) or None.

    Same precedence as :func:`check_state` (fence, then tilt, then tracking); NaN positions trip the fence. The
    fence is checked at the stopping point when ``lim.brake_accel`` is set (the states carry the velocity).
    """
    x, z, th = states[:, 0], states[:, 2], states[:, 4]
    code = np.zeros(states.shape[0], dtype=np.int8)
    if ref_xz is not None:
        ref = np.broadcast_to(np.asarray(ref_xz, dtype=float), (states.shape[0], 2))
        err = np.hypot(x - ref[:, 0], z - ref[:, 1])
        code[err > lim.tracking_error_max] = TRACK
    code[np.abs(th) > math.radians(lim.tilt_max_deg)] = TILT
    xs, zs = stopping_point(lim, x, states[:, 1]), stopping_point(lim, z, states[:, 3])
    fence = ~((np.abs(xs) <= lim.x_max) & (zs >= lim.z_min) & (zs <= lim.z_max))
    code[fence] = FENCE
    return code
