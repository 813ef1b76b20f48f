"""What one validation manoeuvre flies, and how its figures are measured: :class:`ManoeuvreSpec`.

Three kinds, each built from the table the profile's ``[validation]`` section gives for it (every key optional):

* ``steps`` — position steps flown as single position targets (no feed-forward) in guided/offboard from the hover
  point: ``offsets_m`` (list of [north, east, down] offsets; each is flown out and back, both measured; default
  5 m north, 5 m east, 2 m up), ``dwell_s`` (time on each target, default 8), ``settle_fraction`` and
  ``settle_floor_m`` (the settling band: within ``max(fraction * step, floor)`` of the target; default 5 %, 0.1 m).
* ``hold`` — the autopilot's own position hold (ArduPilot LOITER, PX4 Hold) for ``seconds`` (default 30).
* ``auto_mission`` — a waypoint mission flown by the autopilot's own navigation (ArduPilot AUTO at its WPNAV
  speeds, PX4 Mission at its cruise speed): ``pattern`` "box" or "lawnmower", ``size_m`` [north, east] (default
  [8, 5]), ``legs`` (lawnmower passes, default 4), ``settle_band_m`` (corner settling band, default 0.2),
  ``arrive_m`` (completion radius at the last waypoint, default 0.5), ``timeout_s`` (default 120).

Every kind also takes ``settle_s`` (hover on the start point in guided before the manoeuvre, default 3).
:meth:`ManoeuvreSpec.quick` is a shorter version of the same manoeuvre (for ``--validation quick`` and SITL tests).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ksbo_mav.errors import InputError

KINDS = ("steps", "hold", "auto_mission")
#: Each kind's headline figure (smaller is better), for a one-line verdict.
HEADLINE = {"steps": "settle_s_mean", "hold": "hold_rms_m", "auto_mission": "xtrack_rms_m"}
_KEYS = {
    "steps": {"offsets_m", "dwell_s", "settle_fraction", "settle_floor_m", "settle_s"},
    "hold": {"seconds", "settle_s"},
    "auto_mission": {"pattern", "size_m", "legs", "settle_band_m", "arrive_m", "timeout_s", "settle_s"},
}
#: Distance kept from the safety box's walls by every target (m).
BOX_MARGIN_M = 1.0


@dataclass(frozen=True)
class ManoeuvreSpec:
    kind: str
    offsets_m: tuple[tuple[float, float, float], ...] = ((5.0, 0.0, 0.0), (0.0, 5.0, 0.0), (0.0, 0.0, -2.0))
    dwell_s: float = 8.0
    settle_fraction: float = 0.05
    settle_floor_m: float = 0.1
    seconds: float = 30.0
    pattern: str = "box"
    size_m: tuple[float, float] = (8.0, 5.0)
    legs: int = 4
    settle_band_m: float = 0.2
    arrive_m: float = 0.5
    timeout_s: float = 120.0
    settle_s: float = 3.0

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise InputError(f"unknown validation manoeuvre {self.kind!r}; known: {', '.join(KINDS)}")
        if self.pattern not in ("box", "lawnmower"):
            raise InputError(f"validation auto_mission pattern must be box or lawnmower, not {self.pattern!r}")
        for name in ("dwell_s", "seconds", "timeout_s", "settle_floor_m", "settle_band_m", "arrive_m"):
            if not float(getattr(self, name)) > 0:
                raise InputError(f"validation {self.kind}: {name} must be positive")
        if not 0 < self.settle_fraction < 1 or self.settle_s < 0 or self.legs < 2:
            raise InputError(f"validation {self.kind}: settle_fraction in (0, 1), settle_s >= 0 and legs >= 2")
        if min(self.size_m) <= 0 or any(np.linalg.norm(o) <= 0 for o in self.offsets_m):
            raise InputError(f"validation {self.kind}: sizes and step offsets must be non-zero")

    @classmethod
    def from_dict(cls, kind: str, table: dict[str, Any] | None = None) -> "ManoeuvreSpec":
        """The spec of ``kind`` from its profile table (``[validation.<kind>]``); unknown keys are refused."""
        table = dict(table or {})
        if kind not in KINDS:
            raise InputError(f"unknown validation manoeuvre {kind!r}; known: {', '.join(KINDS)}")
        unknown = sorted(set(table) - _KEYS[kind])
        if unknown:
            raise InputError(f"[validation.{kind}]: unknown key(s) {', '.join(unknown)}; known: "
                             f"{', '.join(sorted(_KEYS[kind]))}")
        try:
            if "offsets_m" in table:
                table["offsets_m"] = tuple(tuple(float(v) for v in o) for o in table["offsets_m"])
                if any(len(o) != 3 for o in table["offsets_m"]):
                    raise ValueError("each offset is [north, east, down]")
            if "size_m" in table:
                size = [float(v) for v in table["size_m"]]
                if len(size) != 2:
                    raise ValueError("size_m is [north, east]")
                table["size_m"] = (size[0], size[1])
            for key in ("dwell_s", "settle_fraction", "settle_floor_m", "seconds", "settle_band_m", "arrive_m",
                        "timeout_s", "settle_s"):
                if key in table:
                    table[key] = float(table[key])
            if "legs" in table:
                table["legs"] = int(table["legs"])
        except (TypeError, ValueError) as exc:
            raise InputError(f"[validation.{kind}]: {exc}") from None
        return cls(kind=kind, **table)

    def quick(self) -> "ManoeuvreSpec":
        """The same manoeuvre, shorter: the first two step offsets (north and east by default) at half the dwell
        (at least 4 s), a hold of at most 15 s, a box at most 6 x 4 m."""
        return replace(self, offsets_m=self.offsets_m[:2], dwell_s=max(4.0, self.dwell_s / 2),
                       seconds=min(self.seconds, 15.0), pattern="box",
                       size_m=(min(self.size_m[0], 6.0), min(self.size_m[1], 4.0)), settle_s=min(self.settle_s, 2.0))

    # --- geometry ------------------------------------------------------------------------------------------
    def step_targets(self, start: np.ndarray) -> list[np.ndarray]:
        """(3,) NED targets in flying order: each offset out from ``start`` and back to it."""
        start = np.asarray(start, float)
        out = []
        for o in self.offsets_m:
            out += [start + np.asarray(o, float), start.copy()]
        return out

    def waypoints(self, start: np.ndarray) -> np.ndarray:
        """(m, 3) NED waypoints of the mission from ``start`` (its first point) at the start's height: a box north
        then east then back, or a lawnmower of ``legs`` north-south passes stepping east."""
        n, e = self.size_m
        if self.pattern == "box":
            ne = [(0, 0), (n, 0), (n, e), (0, e), (0, 0)]
        else:
            ne = []
            for k in range(self.legs):
                east = e * k / (self.legs - 1)
                ne += [(0, east), (n, east)] if k % 2 == 0 else [(n, east), (0, east)]
        start = np.asarray(start, float)
        return np.array([[start[0] + a, start[1] + b, start[2]] for a, b in ne])

    def points(self, start: np.ndarray) -> np.ndarray:
        """(k, 3) every NED point the manoeuvre targets (for the box check)."""
        start = np.asarray(start, float)
        if self.kind == "steps":
            return np.array(self.step_targets(start))
        if self.kind == "auto_mission":
            return self.waypoints(start)
        return start[None, :]

    def check_inside(self, start: np.ndarray, limits: Any) -> None:
        """:class:`InputError` unless every target is inside the safety box (``limits``: the monitor's
        :class:`~ksbo_task.limit_checks.MonitorLimits`) by :data:`BOX_MARGIN_M`."""
        for p in self.points(start):
            up = -p[2]
            if abs(p[0]) > limits.x_max - BOX_MARGIN_M or abs(p[1]) > limits.y_max - BOX_MARGIN_M \
                    or not limits.z_min + BOX_MARGIN_M <= up <= limits.z_max - BOX_MARGIN_M:
                raise InputError(f"validation {self.kind}: the point north {p[0]:g} m, east {p[1]:g} m, up {up:g} m "
                                 f"is not {BOX_MARGIN_M:g} m inside the profile's safety box "
                                 f"(|north| <= {limits.x_max:g}, |east| <= {limits.y_max:g}, "
                                 f"up {limits.z_min:g}..{limits.z_max:g}); make the manoeuvre smaller")

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, **{k: getattr(self, k) for k in sorted(_KEYS[self.kind])}}
