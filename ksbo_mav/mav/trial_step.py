"""A position step after a trial's figure-8: what a pilot's position change asks of the gains.

The training figure-8 streams position, velocity and acceleration setpoints, so the position loop only corrects the
residual of a motion fed forward. A single position target with no feed-forward (a step) is what the validation's
steps and a pilot's position change ask, and PX4 flies it unshaped in OFFBOARD: a position loop stiff enough to
track the fed-forward figure-8 closely can lean far harder into a step than the figure-8 ever shows.

With the campaign setting ``trial_step`` every trial (baseline, search, confirmation) ends its figure-8 and end hold
with one such step, the first horizontal offset of the profile's ``[validation.steps]`` from the figure-8's end
point, held for the quick validation's dwell, with the trial's gains. Every sample is checked by the campaign's
monitor with its tilt limit lowered by the profile's ``[campaign] trial_step_tilt_margin_deg`` (the validation flies
several steps where the trial flies one, and repeats of one gain set lean a degree or two apart): a trip is the
trial's gain-caused abort (tilt), counted and given to the optimiser as every other abort. The figure-8's score
P(a) is unchanged; the step's figures (peak lean, overshoot, rise) go into the trial record.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ksbo_mav.errors import InputError
from ksbo_mav.mav.monitor import Limits, Monitor
from ksbo_mav.mav.validation.manoeuvre_spec import ManoeuvreSpec
from ksbo_task.limit_checks import tilt_rad


@dataclass(frozen=True)
class TrialStep:
    """The step every trial flies after its figure-8.

    Attributes:
        offset_ned: (north, east, down) of the target from the figure-8's end point (m).
        dwell_s: how long the target is held (vehicle time).
        tilt_max_deg: the lean that aborts the trial during the step.
    """

    offset_ned: tuple[float, float, float]
    dwell_s: float
    tilt_max_deg: float

    @classmethod
    def from_profile(cls, profile: Any, limits: Limits) -> "TrialStep":
        """The profile's first horizontal validation step at the quick validation's dwell, its tilt limit the
        monitor's ``limits`` less ``[campaign] trial_step_tilt_margin_deg``. InputError when the profile's mission
        is not a horizontal figure-8 or its steps have no horizontal offset."""
        if profile.mission_spec.type != "figure8-ne":
            raise InputError(f"trial_step needs a horizontal figure-8 mission (figure8-ne); profile "
                             f"{profile.name} flies {profile.mission_spec.type}")
        spec = ManoeuvreSpec.from_dict("steps", profile.validation_spec.sizes("steps")).quick()
        flat = [o for o in spec.offsets_m if math.hypot(o[0], o[1]) > 0]
        if not flat:
            raise InputError(f"trial_step: profile {profile.name}'s [validation.steps] offsets_m has no horizontal "
                             "step")
        margin = float(profile.campaign_spec.trial_step_tilt_margin_deg)
        return cls(tuple(float(v) for v in flat[0]), float(spec.dwell_s), float(limits.tilt_max_deg) - margin)

    def monitor(self, campaign: Monitor) -> Monitor:
        """The campaign's monitor with the step's tilt limit."""
        return Monitor(replace(campaign.limits, tilt_max_deg=self.tilt_max_deg), campaign.guided_mode,
                       campaign.mode_name)


def lean_deg(roll: float, pitch: float) -> float:
    """The body z axis's angle from the vertical (deg), the tilt the monitor judges (:func:`tilt_rad`)."""
    return math.degrees(tilt_rad(roll, pitch))


class StepRecord:
    """What one flown step did, sample by sample, for the trial record (also when the monitor stopped it)."""

    def __init__(self, step: TrialStep, start: np.ndarray) -> None:
        self.step = step
        self.start = np.asarray(start, float)
        self.size = float(np.linalg.norm(step.offset_ned))
        self.along = np.asarray(step.offset_ned, float) / self.size
        self.t0: int | None = None
        self.t: list[float] = []
        self.progress: list[float] = []
        self.lean: list[float] = []

    @property
    def target(self) -> np.ndarray:
        return self.start + np.asarray(self.step.offset_ned, float)

    def feed(self, lpn: Any, att: Any | None) -> None:
        t = int(lpn.time_boot_ms)
        if self.t0 is None:
            self.t0 = t
        pos = np.array([lpn.x, lpn.y, lpn.z], dtype=float)
        self.t.append((t - self.t0) / 1000.0)
        self.progress.append(float((pos - self.start) @ self.along))
        self.lean.append(math.nan if att is None else lean_deg(float(att.roll), float(att.pitch)))

    def figures(self) -> dict[str, Any]:
        """``size_m``, ``tilt_limit_deg``, ``samples``, ``seconds``; with samples ``peak_lean_deg``,
        ``overshoot_pct`` (past the target along the step) and ``rise_s`` (to 90 % of the step; None if never)."""
        out: dict[str, Any] = {"offset_ned": list(self.step.offset_ned), "size_m": self.size,
                               "tilt_limit_deg": self.step.tilt_max_deg, "samples": len(self.t),
                               "seconds": self.t[-1] if self.t else 0.0}
        if not self.t:
            return out
        p = np.asarray(self.progress)
        leans = np.asarray(self.lean)
        reached = np.flatnonzero(p >= 0.9 * self.size)
        out.update(peak_lean_deg=float(np.nanmax(leans)) if np.isfinite(leans).any() else None,
                   overshoot_pct=float(max(0.0, p.max() - self.size) / self.size * 100.0),
                   rise_s=float(self.t[reached[0]]) if reached.size else None)
        return out


def fly_step(vehicle: Any, record: StepRecord, check: Callable[[Any], None], log: Callable[[str], None]) -> None:
    """Fly ``record``'s step on ``vehicle`` (hovering at its start, in guided/offboard): the single position target
    streamed for the dwell, every sample recorded and then given to ``check`` (which raises to abort); then kept
    as the held target."""
    m = vehicle.mission
    target = record.target
    n = max(1, int(round(record.step.dwell_s * m.rate_hz)))

    def on_sample(s: Any) -> None:
        record.feed(s, vehicle.telemetry.last_att)
        check(s)

    vehicle.guided.follow(lambda j: (target, None, None), n, m.dt_ms, on_sample, log)
    vehicle.guided.hold_at(target)
